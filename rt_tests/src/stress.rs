//! `--stress`: CPU and memory load in child processes, ended with the harness.
//!
//! The load is `stress-ng` when installed (and `[stress] use_stress_ng`), otherwise this binary
//! re-executed as the hidden `stress-worker` subcommand: one busy-loop thread per worker and a
//! thread that keeps writing one byte per page of a `memory_mb` buffer. Children run at the
//! default policy (`SCHED_OTHER`, nice 0). They are killed when the [`Load`] is dropped (normal
//! end, error, Ctrl-C via [`crate::interrupted`]); a worker also exits on its own when its parent
//! dies (it is given its parent's pid and watches it), so a `kill -9` of the harness does not leave load behind.

use crate::settings::StressSettings;
use anyhow::{Context, Result};
use std::process::{Child, Command, Stdio};
use std::time::Duration;

/// Running load processes; killed on drop.
#[derive(Debug, Default)]
pub struct Load {
    children: Vec<Child>,
    /// What was started, for the report.
    pub description: String,
}

impl Load {
    /// No load.
    pub fn none() -> Self {
        Self {
            children: Vec::new(),
            description: "none".into(),
        }
    }

    /// Start the configured load.
    pub fn start(s: &StressSettings) -> Result<Self> {
        let cpus = std::thread::available_parallelism().map_or(1, |n| n.get());
        let workers = if s.cpu_workers == 0 {
            cpus
        } else {
            s.cpu_workers
        };
        let mut load = Self::default();
        if s.use_stress_ng && which("stress-ng") {
            let mut cmd = Command::new("stress-ng");
            cmd.args(["--cpu", &workers.to_string(), "--quiet"]);
            if s.memory_mb > 0 {
                cmd.args(["--vm", "1", "--vm-bytes", &format!("{}M", s.memory_mb)]);
            }
            load.spawn(cmd)?;
            load.description = format!(
                "stress-ng --cpu {workers} --vm 1 --vm-bytes {}M",
                s.memory_mb
            );
        } else {
            let exe = std::env::current_exe().context("find own executable")?;
            let mut cmd = Command::new(exe);
            cmd.args([
                "stress-worker",
                "--cpu",
                &workers.to_string(),
                "--memory-mb",
                &s.memory_mb.to_string(),
                "--parent",
                &std::process::id().to_string(),
            ]);
            load.spawn(cmd)?;
            load.description = format!(
                "built-in: {workers} busy-loop workers + {} MB memory toucher (SCHED_OTHER)",
                s.memory_mb
            );
        }
        // Let the load ramp up before measuring.
        std::thread::sleep(Duration::from_millis(300));
        Ok(load)
    }

    fn spawn(&mut self, mut cmd: Command) -> Result<()> {
        let child = cmd
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .spawn()
            .with_context(|| format!("start load {cmd:?}"))?;
        self.children.push(child);
        Ok(())
    }
}

impl Drop for Load {
    fn drop(&mut self) {
        for c in &mut self.children {
            let _ = c.kill();
            let _ = c.wait();
        }
    }
}

/// `true` if `prog` is on `PATH`.
pub fn which(prog: &str) -> bool {
    std::env::var_os("PATH")
        .is_some_and(|paths| std::env::split_paths(&paths).any(|d| d.join(prog).is_file()))
}

/// The hidden `stress-worker` subcommand: run until the parent dies or we are killed.
///
/// `parent` is the harness's pid, passed on the command line rather than read at start-up: a
/// harness killed before the worker first asked would otherwise leave it re-parented to init
/// (or a subreaper) and watching that forever. Without `parent` it runs until killed.
pub fn worker(cpu: usize, memory_mb: usize, parent: Option<u32>) -> Result<()> {
    let orphaned = || parent.is_some_and(|p| std::os::unix::process::parent_id() != p);
    if orphaned() {
        return Ok(());
    }
    for k in 0..cpu {
        std::thread::Builder::new()
            .name(format!("stress-cpu-{k}"))
            .spawn(|| {
                let mut x: u64 = 1;
                loop {
                    for _ in 0..10_000 {
                        x = std::hint::black_box(
                            x.wrapping_mul(6364136223846793005).wrapping_add(1),
                        );
                    }
                }
            })
            .context("spawn cpu worker")?;
    }
    if memory_mb > 0 {
        std::thread::Builder::new()
            .name("stress-mem".into())
            .spawn(move || {
                let mut buf = vec![0u8; memory_mb << 20];
                let mut v: u8 = 0;
                loop {
                    v = v.wrapping_add(1);
                    for b in buf.iter_mut().step_by(4096) {
                        *b = v;
                    }
                    std::hint::black_box(&buf);
                }
            })
            .context("spawn memory worker")?;
    }
    loop {
        std::thread::sleep(Duration::from_millis(100));
        if orphaned() {
            return Ok(());
        }
    }
}
