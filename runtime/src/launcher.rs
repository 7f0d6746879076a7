//! Process launcher with health watching: spawns node processes, watches their exit status,
//! their heartbeats ([`Liveness`]: a child that stops beating without dying is hung, and is
//! killed) and iceoryx2's dead-node list, removes a dead node's stale shared-memory resources,
//! restarts it up to a limit, and stops everything cleanly (SIGINT, then SIGKILL after a grace
//! period).
//!
//! The launcher does not know where heartbeats come from: its owner receives them (for `vpsom
//! run`, `NodeHealth` samples on the `health` topic) and calls [`Launcher::heartbeat`] with the
//! sender's name and pid, so a heartbeat still buffered from a killed incarnation never counts
//! for its successor.

use iceoryx2::node::NodeView;
use iceoryx2::prelude::*;
use std::collections::HashMap;
use std::fmt;
use std::os::unix::process::ExitStatusExt;
use std::path::PathBuf;
use std::process::{Child, Command, ExitStatus, Stdio};
use std::time::{Duration, Instant};

/// Environment variable every child is started with: how many times it has been restarted
/// (`0` at the first start). A child that can continue an earlier incarnation's work (the
/// mapper, from its last map) reads it.
pub const RESTART_ENV: &str = "VPSOM_RESTART";

/// How to start one supervised process.
#[derive(Debug, Clone)]
pub struct ChildSpec {
    /// Name used in reports and as the iceoryx2 node name of the child.
    pub name: String,
    /// Executable.
    pub program: PathBuf,
    /// Arguments.
    pub args: Vec<String>,
    /// Restarts allowed after unexpected exits.
    pub max_restarts: u32,
    /// Whether the child's stdout is passed through (else discarded); stderr always is.
    pub inherit_stdout: bool,
    /// Hang detection: `None` = the child is only watched for its exit.
    pub liveness: Option<Liveness>,
}

/// When a child that still runs counts as hung.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Liveness {
    /// Longest silence between two heartbeats.
    pub timeout: Duration,
    /// Longest wait for the first heartbeat after a (re)start.
    pub startup: Duration,
}

/// Why a child stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ExitReason {
    /// Exited with this code.
    Code(i32),
    /// Killed by this signal.
    Signal(i32),
}

impl From<ExitStatus> for ExitReason {
    fn from(s: ExitStatus) -> Self {
        match (s.code(), s.signal()) {
            (Some(c), _) => ExitReason::Code(c),
            (None, Some(sig)) => ExitReason::Signal(sig),
            (None, None) => ExitReason::Code(-1),
        }
    }
}

impl fmt::Display for ExitReason {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ExitReason::Code(c) => write!(f, "exit code {c}"),
            ExitReason::Signal(s) => write!(f, "killed by signal {s} ({})", signal_name(*s)),
        }
    }
}

fn signal_name(sig: i32) -> &'static str {
    match sig {
        libc::SIGINT => "SIGINT",
        libc::SIGTERM => "SIGTERM",
        libc::SIGKILL => "SIGKILL",
        libc::SIGSEGV => "SIGSEGV",
        libc::SIGABRT => "SIGABRT",
        libc::SIGBUS => "SIGBUS",
        _ => "?",
    }
}

/// Something the launcher noticed.
#[derive(Debug, Clone, PartialEq)]
pub enum ChildEvent {
    /// A running child sent no heartbeat for longer than its [`Liveness`] allows; it was
    /// killed (SIGKILL), and its death follows as [`ChildEvent::Restarted`] or
    /// [`ChildEvent::Failed`].
    Hung {
        /// Child name.
        name: String,
        /// Time since its last heartbeat (or since its start, if it never sent one).
        silent_for: Duration,
        /// Whether it had sent any heartbeat.
        ever_beat: bool,
    },
    /// A child exited with code 0 on its own.
    Finished {
        /// Child name.
        name: String,
    },
    /// A child died unexpectedly and was restarted.
    Restarted {
        /// Child name.
        name: String,
        /// How it died.
        reason: ExitReason,
        /// Restart number (1-based).
        attempt: u32,
        /// Stale iceoryx2 nodes removed before the restart.
        cleaned_nodes: u64,
    },
    /// A child died and has no restarts left (or could not be restarted).
    Failed {
        /// Child name.
        name: String,
        /// What happened.
        reason: String,
    },
}

impl fmt::Display for ChildEvent {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ChildEvent::Hung {
                name,
                silent_for,
                ever_beat,
            } => write!(
                f,
                "{name}: hung: no heartbeat for {:.1} s{}; killed",
                silent_for.as_secs_f64(),
                if *ever_beat { "" } else { " since its start" }
            ),
            ChildEvent::Finished { name } => write!(f, "{name}: finished"),
            ChildEvent::Restarted {
                name,
                reason,
                attempt,
                cleaned_nodes,
            } => write!(
                f,
                "{name}: died ({reason}); removed {cleaned_nodes} stale node(s); restart {attempt}"
            ),
            ChildEvent::Failed { name, reason } => write!(f, "{name}: failed: {reason}"),
        }
    }
}

/// Errors of the launcher itself.
#[derive(Debug, thiserror::Error)]
pub enum LaunchError {
    /// The launcher's own iceoryx2 node could not be created.
    #[error("cannot create the launcher's iceoryx2 node: {0}")]
    Node(String),
    /// A child could not be spawned.
    #[error("cannot start {name} ({program}): {source}")]
    Spawn {
        /// Child name.
        name: String,
        /// Program.
        program: String,
        /// The OS error.
        source: std::io::Error,
    },
}

struct Supervised {
    spec: ChildSpec,
    child: Option<Child>,
    restarts: u32,
    last_exit: Option<ExitReason>,
    /// When the running incarnation started.
    started: Instant,
    /// Its newest heartbeat.
    last_beat: Option<Instant>,
}

impl Supervised {
    /// If the running child is hung (per its liveness): how long it has been silent, and
    /// whether it ever sent a heartbeat.
    fn hung(&self, now: Instant) -> Option<(Duration, bool)> {
        let l = self.spec.liveness?;
        self.child.as_ref()?;
        let (since, limit) = match self.last_beat {
            Some(t) => (t, l.timeout),
            None => (self.started, l.startup),
        };
        let silent = now.saturating_duration_since(since);
        (silent > limit).then_some((silent, self.last_beat.is_some()))
    }
}

/// Supervises a set of child processes.
pub struct Launcher {
    node: Node<ipc::Service>,
    children: Vec<Supervised>,
    stale_at_start: u64,
}

impl fmt::Debug for Launcher {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Launcher")
            .field(
                "children",
                &self
                    .children
                    .iter()
                    .map(|c| &c.spec.name)
                    .collect::<Vec<_>>(),
            )
            .finish()
    }
}

impl Launcher {
    /// Create the launcher's iceoryx2 node (named `name`) and remove stale resources left by
    /// crashed processes of earlier runs.
    pub fn new(name: &str, config: &iceoryx2::config::Config) -> Result<Self, LaunchError> {
        let node_name = NodeName::new(name).map_err(|e| LaunchError::Node(format!("{e:?}")))?;
        // The dead nodes are removed below, where they are counted, not silently by the
        // node's creation.
        let mut config = config.clone();
        config.global.node.cleanup_dead_nodes_on_creation = false;
        let node = NodeBuilder::new()
            .name(&node_name)
            .config(&config)
            .signal_handling_mode(SignalHandlingMode::Disabled)
            .create::<ipc::Service>()
            .map_err(|e| LaunchError::Node(format!("{e:?}")))?;
        let cleaned = node.try_cleanup_dead_nodes();
        Ok(Self {
            node,
            children: Vec::new(),
            stale_at_start: cleaned.cleanups,
        })
    }

    /// Dead iceoryx2 nodes of earlier runs removed when the launcher started.
    pub fn stale_nodes_removed_at_start(&self) -> u64 {
        self.stale_at_start
    }

    /// Start a supervised child.
    pub fn spawn(&mut self, spec: ChildSpec) -> Result<u32, LaunchError> {
        let child = start(&spec, 0)?;
        let pid = child.id();
        self.children.push(Supervised {
            spec,
            child: Some(child),
            restarts: 0,
            last_exit: None,
            started: Instant::now(),
            last_beat: None,
        });
        Ok(pid)
    }

    /// A heartbeat from child `name` with process id `pid`; one from another pid (a killed
    /// incarnation's, still buffered) or an unknown name is ignored. Returns whether it counted.
    pub fn heartbeat(&mut self, name: &str, pid: u32) -> bool {
        let Some(sup) = self
            .children
            .iter_mut()
            .find(|c| c.spec.name == name && c.child.as_ref().is_some_and(|ch| ch.id() == pid))
        else {
            return false;
        };
        sup.last_beat = Some(Instant::now());
        true
    }

    /// Pids of the running children by name.
    pub fn pids(&self) -> HashMap<String, u32> {
        self.children
            .iter()
            .filter_map(|c| c.child.as_ref().map(|ch| (c.spec.name.clone(), ch.id())))
            .collect()
    }

    /// Whether every child has stopped (finished or failed).
    pub fn all_stopped(&self) -> bool {
        self.children.iter().all(|c| c.child.is_none())
    }

    /// Names of iceoryx2 nodes that iceoryx2 reports dead (their process is gone without cleanup).
    pub fn dead_nodes(&self) -> Vec<String> {
        let mut dead = Vec::new();
        let _ = Node::<ipc::Service>::list(self.node.config(), |state| {
            if let NodeState::Dead(view) = state {
                let name = view
                    .details()
                    .as_ref()
                    .map_or_else(|| "<unnamed>".to_string(), |d| d.name().to_string());
                dead.push(name);
            }
            CallbackProgression::Continue
        });
        dead
    }

    /// Check every child once: kill hung ones, report exits, clean stale resources, restart
    /// within limits.
    pub fn poll(&mut self) -> Vec<ChildEvent> {
        let mut events = Vec::new();
        for i in 0..self.children.len() {
            if let Some((silent_for, ever_beat)) = self.children[i].hung(Instant::now())
                && let Some(child) = self.children[i].child.as_mut()
            {
                // SIGKILL also ends a stopped process; the exit is collected below.
                let _ = child.kill();
                let _ = child.wait();
                events.push(ChildEvent::Hung {
                    name: self.children[i].spec.name.clone(),
                    silent_for,
                    ever_beat,
                });
            }
            let status = match self.children[i].child.as_mut().map(Child::try_wait) {
                Some(Ok(Some(status))) => status,
                Some(Ok(None)) | None => continue,
                Some(Err(e)) => {
                    let sup = &mut self.children[i];
                    sup.child = None;
                    events.push(ChildEvent::Failed {
                        name: sup.spec.name.clone(),
                        reason: format!("cannot query its status: {e}"),
                    });
                    continue;
                }
            };
            let reason = ExitReason::from(status);
            self.children[i].child = None;
            self.children[i].last_exit = Some(reason);
            if reason == ExitReason::Code(0) {
                events.push(ChildEvent::Finished {
                    name: self.children[i].spec.name.clone(),
                });
                continue;
            }
            let cleaned_nodes = self.node.try_cleanup_dead_nodes().cleanups;
            let sup = &mut self.children[i];
            if sup.restarts >= sup.spec.max_restarts {
                events.push(ChildEvent::Failed {
                    name: sup.spec.name.clone(),
                    reason: format!(
                        "died ({reason}) after {} restart(s); removed {cleaned_nodes} stale node(s)",
                        sup.restarts
                    ),
                });
                continue;
            }
            sup.restarts += 1;
            match start(&sup.spec, sup.restarts) {
                Ok(child) => {
                    sup.child = Some(child);
                    sup.started = Instant::now();
                    sup.last_beat = None;
                    events.push(ChildEvent::Restarted {
                        name: sup.spec.name.clone(),
                        reason,
                        attempt: sup.restarts,
                        cleaned_nodes,
                    });
                }
                Err(e) => events.push(ChildEvent::Failed {
                    name: sup.spec.name.clone(),
                    reason: format!("died ({reason}) and could not be restarted: {e}"),
                }),
            }
        }
        events
    }

    /// Ask every running child to stop with SIGINT, wait up to `grace`, then SIGKILL the rest.
    /// Returns each child's final exit reason (`None` if it never ran).
    pub fn stop_all(&mut self, grace: Duration) -> Vec<(String, Option<ExitReason>)> {
        for sup in &self.children {
            if let Some(child) = &sup.child {
                let _ = crate::os::send_signal(child.id(), libc::SIGINT);
            }
        }
        let deadline = Instant::now() + grace;
        while Instant::now() < deadline && !self.all_exited() {
            std::thread::sleep(Duration::from_millis(20));
        }
        for sup in &mut self.children {
            if let Some(mut child) = sup.child.take() {
                let status = match child.try_wait() {
                    Ok(Some(s)) => Some(s),
                    _ => {
                        let _ = child.kill();
                        child.wait().ok()
                    }
                };
                sup.last_exit = status.map(ExitReason::from);
            }
        }
        self.node.try_cleanup_dead_nodes();
        self.children
            .iter()
            .map(|s| (s.spec.name.clone(), s.last_exit))
            .collect()
    }

    fn all_exited(&mut self) -> bool {
        self.children.iter_mut().all(|s| match s.child.as_mut() {
            Some(c) => matches!(c.try_wait(), Ok(Some(_))),
            None => true,
        })
    }
}

impl Drop for Launcher {
    fn drop(&mut self) {
        if !self.all_stopped() {
            self.stop_all(Duration::from_secs(2));
        }
    }
}

fn start(spec: &ChildSpec, restarts: u32) -> Result<Child, LaunchError> {
    let mut cmd = Command::new(&spec.program);
    crate::os::default_stop_signals_on_exec(&mut cmd);
    cmd.args(&spec.args)
        .env(RESTART_ENV, restarts.to_string())
        .stdin(Stdio::null())
        .stdout(if spec.inherit_stdout {
            Stdio::inherit()
        } else {
            Stdio::null()
        })
        .stderr(Stdio::inherit())
        .spawn()
        .map_err(|source| LaunchError::Spawn {
            name: spec.name.clone(),
            program: spec.program.display().to_string(),
            source,
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sh(name: &str, script: &str, max_restarts: u32) -> ChildSpec {
        ChildSpec {
            name: name.into(),
            program: "/bin/sh".into(),
            args: vec!["-c".into(), script.into()],
            max_restarts,
            inherit_stdout: false,
            liveness: None,
        }
    }

    /// Poll until `n` events arrived; the 60 s limit only ends a hung test.
    fn poll_until(l: &mut Launcher, n: usize) -> Vec<ChildEvent> {
        let mut all = Vec::new();
        let deadline = Instant::now() + Duration::from_secs(60);
        while all.len() < n && Instant::now() < deadline {
            all.extend(l.poll());
            std::thread::sleep(Duration::from_millis(10));
        }
        all
    }

    /// A fresh directory for the readiness files of one test.
    fn ready_dir(test: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("vpsom-launcher-{test}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    /// A shell that installs `trap`, then says so by creating `ready` (atomically: written, then
    /// renamed), then loops.
    fn trapping_sh(name: &str, trap: &str, ready: &std::path::Path) -> ChildSpec {
        let r = ready.display();
        sh(
            name,
            &format!(
                "{trap}; echo ok > '{r}.tmp' && mv '{r}.tmp' '{r}'; while true; do sleep 0.05; done"
            ),
            0,
        )
    }

    /// Wait until every file exists: the children have installed their traps. The 60 s limit
    /// only ends a hung test.
    fn wait_ready(files: &[PathBuf]) {
        let deadline = Instant::now() + Duration::from_secs(60);
        while !files.iter().all(|f| f.exists()) {
            assert!(Instant::now() < deadline, "children never became ready");
            std::thread::sleep(Duration::from_millis(5));
        }
    }

    #[test]
    fn crashed_child_is_restarted_then_reported_failed() {
        let mut l =
            Launcher::new("launcher-test-a", iceoryx2::config::Config::global_config()).unwrap();
        l.spawn(sh("crasher", "exit 3", 2)).unwrap();
        l.spawn(sh("ok", "exit 0", 2)).unwrap();
        let events = poll_until(&mut l, 4);
        assert!(
            events.contains(&ChildEvent::Finished { name: "ok".into() }),
            "{events:?}"
        );
        let restarts: Vec<_> = events
            .iter()
            .filter_map(|e| match e {
                ChildEvent::Restarted {
                    name,
                    reason,
                    attempt,
                    ..
                } if name == "crasher" => Some((*reason, *attempt)),
                _ => None,
            })
            .collect();
        assert_eq!(
            restarts,
            vec![(ExitReason::Code(3), 1), (ExitReason::Code(3), 2)]
        );
        let failed = events.iter().find_map(|e| match e {
            ChildEvent::Failed { name, reason } if name == "crasher" => Some(reason.clone()),
            _ => None,
        });
        assert!(failed.unwrap().contains("exit code 3"), "{events:?}");
        assert!(l.all_stopped());
    }

    #[test]
    fn stop_all_interrupts_then_kills() {
        let dir = ready_dir("stop");
        // The polite child exits on SIGINT: a generous grace, which stop_all cuts short as soon
        // as every child has exited.
        let mut polite =
            Launcher::new("launcher-test-b", iceoryx2::config::Config::global_config()).unwrap();
        let ready_p = dir.join("polite");
        polite
            .spawn(trapping_sh("polite", "trap 'exit 0' INT", &ready_p))
            .unwrap();
        // The stubborn child ignores SIGINT: whatever the grace, it ends by SIGKILL.
        let mut stubborn =
            Launcher::new("launcher-test-c", iceoryx2::config::Config::global_config()).unwrap();
        let ready_s = dir.join("stubborn");
        stubborn
            .spawn(trapping_sh("stubborn", "trap '' INT", &ready_s))
            .unwrap();
        // Signals are sent only once both traps are installed.
        wait_ready(&[ready_p, ready_s]);
        assert!(polite.poll().is_empty());
        assert!(stubborn.poll().is_empty());
        let out = polite.stop_all(Duration::from_secs(60));
        assert_eq!(out, vec![("polite".to_string(), Some(ExitReason::Code(0)))]);
        let out = stubborn.stop_all(Duration::from_millis(200));
        assert_eq!(
            out,
            vec![(
                "stubborn".to_string(),
                Some(ExitReason::Signal(libc::SIGKILL))
            )]
        );
        assert_eq!(
            ExitReason::Signal(9).to_string(),
            "killed by signal 9 (SIGKILL)"
        );
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_silent_child_is_killed_as_hung_and_restarted_a_beating_one_is_not() {
        let mut l =
            Launcher::new("launcher-test-d", iceoryx2::config::Config::global_config()).unwrap();
        let liveness = Some(Liveness {
            timeout: Duration::from_millis(300),
            startup: Duration::from_millis(300),
        });
        // Both run forever; only the "beating" one is given heartbeats.
        l.spawn(ChildSpec {
            liveness,
            ..sh("silent", "exec sleep 600", 1)
        })
        .unwrap();
        let beating_pid = l
            .spawn(ChildSpec {
                liveness,
                ..sh("beating", "exec sleep 600", 0)
            })
            .unwrap();
        // A heartbeat from a pid that is not the child's does not count.
        assert!(!l.heartbeat("beating", beating_pid + 1));
        let mut events = Vec::new();
        let start = Instant::now();
        // Hang guard only: the 60 s limit ends a test whose launcher never reacts.
        while events.len() < 4 && start.elapsed() < Duration::from_secs(60) {
            assert!(l.heartbeat("beating", beating_pid));
            events.extend(l.poll());
            std::thread::sleep(Duration::from_millis(10));
        }
        let names: Vec<(&str, &str)> = events
            .iter()
            .map(|e| match e {
                ChildEvent::Hung { name, .. } => (name.as_str(), "hung"),
                ChildEvent::Restarted { name, .. } => (name.as_str(), "restarted"),
                ChildEvent::Failed { name, .. } => (name.as_str(), "failed"),
                ChildEvent::Finished { name } => (name.as_str(), "finished"),
            })
            .collect();
        // The silent child: hung at start, restarted, hung again, out of restarts.
        assert_eq!(
            names,
            vec![
                ("silent", "hung"),
                ("silent", "restarted"),
                ("silent", "hung"),
                ("silent", "failed")
            ],
            "{events:?}"
        );
        match &events[0] {
            ChildEvent::Hung {
                silent_for,
                ever_beat,
                ..
            } => assert!(*silent_for > Duration::from_millis(300) && !ever_beat),
            e => panic!("{e:?}"),
        }
        assert!(
            matches!(&events[1], ChildEvent::Restarted { reason, .. } if *reason == ExitReason::Signal(libc::SIGKILL)),
            "{events:?}"
        );
        assert!(
            l.pids().contains_key("beating"),
            "the beating child was killed"
        );
        let out = l.stop_all(Duration::from_secs(10));
        assert_eq!(out.len(), 2);
    }
}
