//! Faults injected into `vpsom run` as a user would inject them, on real processes (issue #16
//! part 1):
//! - SIGKILL of each node in turn (mapper, sim, planner, recorder) mid-run: the launcher reports
//!   it, cleans the dead node's iceoryx2 resources and restarts it; the restarted mapper
//!   resumes from its last published map (the first map it publishes has the objects the last
//!   one before the kill had); the session still terminates.
//! - A subscriber that stops reading (the recorder, SIGSTOPped for less than the hang timeout)
//!   stalls no publisher (the sim's ground truth keeps arriving here), and its overflow is
//!   counted (the summary's `recorder ← robot/state` row).
//! - A node that hangs without dying (the mapper, SIGSTOPped for good) is found by its silent
//!   heartbeat, killed and restarted.
//! - SIGKILL of the whole process group, then a new `vpsom run` in the same namespace: it
//!   removes the stale resources, runs to its end and leaves no service behind.
//!
//! The sessions run one at a time (a lock): four at once would be four pipelines on two CPUs.
//! Every wait has a generous hang guard; no time is asserted. The kill-to-report times are
//! printed (`--nocapture`) for the "within 1 s".

use runtime::ports::PortContext;
use shm_types::{ObjectMap, RobotState};
use std::os::unix::process::CommandExt;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use vpsom::config::Config;
use vpsom::topics;

/// One session at a time.
static SESSIONS: Mutex<()> = Mutex::new(());

/// Hang guard of every wait: only ends a test whose run never gets there.
const GUARD: Duration = Duration::from_secs(240);

/// A `vpsom run` in its own process group, its stderr collected line by line with the time
/// each line arrived.
struct Run {
    child: Child,
    lines: Arc<Mutex<Vec<(Instant, String)>>>,
    reader: Option<std::thread::JoinHandle<()>>,
}

fn scratch(test: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("vpsom-faults-{test}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

impl Run {
    /// `vpsom run --time-scale 4 --ns NS --out DIR/out [--config DIR/overlay.toml]`.
    fn start(dir: &Path, ns: &str, overlay: Option<&str>) -> Self {
        let out = dir.join("out");
        let mut cmd = Command::new(env!("CARGO_BIN_EXE_vpsom"));
        cmd.args(["run", "--time-scale", "4", "--ns", ns, "--out"])
            .arg(&out);
        if let Some(text) = overlay {
            let file = dir.join("overlay.toml");
            std::fs::write(&file, text).unwrap();
            cmd.arg("--config").arg(file);
        }
        let mut child = cmd
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .process_group(0)
            .spawn()
            .unwrap();
        let lines = Arc::new(Mutex::new(Vec::new()));
        let (sink, stderr) = (Arc::clone(&lines), child.stderr.take().unwrap());
        let reader = std::thread::spawn(move || {
            // Status lines end in '\r', reports in '\n': both end a line.
            let mut stderr = stderr;
            let (mut buf, mut line) = ([0u8; 4096], Vec::new());
            loop {
                let n = match std::io::Read::read(&mut stderr, &mut buf) {
                    Ok(0) | Err(_) => break,
                    Ok(n) => n,
                };
                let now = Instant::now();
                for &b in &buf[..n] {
                    if b == b'\n' || b == b'\r' {
                        let text = String::from_utf8_lossy(&line).to_string();
                        sink.lock().unwrap().push((now, text));
                        line.clear();
                    } else {
                        line.push(b);
                    }
                }
            }
            if !line.is_empty() {
                let text = String::from_utf8_lossy(&line).to_string();
                sink.lock().unwrap().push((Instant::now(), text));
            }
        });
        Self {
            child,
            lines,
            reader: Some(reader),
        }
    }

    /// The whole stderr so far.
    fn log(&self) -> String {
        let l = self.lines.lock().unwrap();
        l.iter()
            .map(|(_, s)| s.as_str())
            .collect::<Vec<_>>()
            .join("\n")
    }

    /// The first stderr line (from line `from` on) containing `what`: its index, arrival and
    /// text.
    fn wait_line(&self, from: usize, what: &str) -> (usize, Instant, String) {
        let start = Instant::now();
        loop {
            {
                let l = self.lines.lock().unwrap();
                if let Some((i, (t, s))) = l
                    .iter()
                    .enumerate()
                    .skip(from)
                    .find(|(_, (_, s))| s.contains(what))
                {
                    return (i, *t, s.clone());
                }
            }
            assert!(
                start.elapsed() < GUARD,
                "no {what:?} from vpsom run:\n{}",
                self.log()
            );
            std::thread::sleep(Duration::from_millis(5));
        }
    }

    fn line_count(&self) -> usize {
        self.lines.lock().unwrap().len()
    }

    /// The pid of node `role` (a child of the launcher running `vpsom node <role>`).
    fn node_pid(&self, role: &str) -> u32 {
        let start = Instant::now();
        loop {
            if let Some(pid) = child_pid(self.child.id(), role) {
                return pid;
            }
            assert!(
                start.elapsed() < GUARD,
                "no {role} process:\n{}",
                self.log()
            );
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    /// Wait for the run to end; its output.
    fn finish(mut self) -> (std::process::ExitStatus, String, String) {
        let mut stdout = String::new();
        if let Some(mut s) = self.child.stdout.take() {
            std::io::Read::read_to_string(&mut s, &mut stdout).unwrap();
        }
        let status = self.child.wait().unwrap();
        if let Some(r) = self.reader.take() {
            r.join().unwrap();
        }
        (status, stdout, self.log())
    }
}

/// The child of `parent` whose command line is `… node <role> …`.
fn child_pid(parent: u32, role: &str) -> Option<u32> {
    for entry in std::fs::read_dir("/proc").ok()?.flatten() {
        let Ok(pid) = entry.file_name().to_string_lossy().parse::<u32>() else {
            continue;
        };
        let Ok(stat) = std::fs::read_to_string(format!("/proc/{pid}/stat")) else {
            continue;
        };
        // Fields after the parenthesised name: state, ppid, …
        let ppid = stat
            .rsplit_once(')')
            .and_then(|(_, rest)| rest.split_whitespace().nth(1))
            .and_then(|p| p.parse::<u32>().ok());
        if ppid != Some(parent) {
            continue;
        }
        let cmdline = std::fs::read(format!("/proc/{pid}/cmdline")).unwrap_or_default();
        let args: Vec<&[u8]> = cmdline.split(|b| *b == 0).collect();
        if args
            .windows(2)
            .any(|w| w[0] == b"node" && w[1] == role.as_bytes())
        {
            return Some(pid);
        }
    }
    None
}

fn signal(pid: &str, sig: &str) {
    let ok = Command::new("kill")
        .args(["-s", sig, "--", pid])
        .status()
        .unwrap()
        .success();
    assert!(ok, "kill -s {sig} {pid} failed");
}

/// Every map published on the run's `map` topic, as (seq, objects), read by a thread of its
/// own (the buffer holds only 2).
struct MapWatch {
    seen: Arc<Mutex<Vec<(u64, usize)>>>,
    stop: Arc<std::sync::atomic::AtomicBool>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl MapWatch {
    fn new(ns: &str) -> Self {
        let seen: Arc<Mutex<Vec<(u64, usize)>>> = Arc::default();
        let stop: Arc<std::sync::atomic::AtomicBool> = Arc::default();
        let (seen2, stop2, ns) = (Arc::clone(&seen), Arc::clone(&stop), ns.to_string());
        let (ready_tx, ready) = std::sync::mpsc::channel();
        let thread = std::thread::spawn(move || {
            let cfg = Config::default();
            let ctx = PortContext::with_namespace(&cfg.ports, "fault-test", &ns).unwrap();
            let sub = ctx.subscriber::<ObjectMap>(topics::MAP).unwrap();
            ready_tx.send(()).unwrap();
            while !stop2.load(std::sync::atomic::Ordering::Relaxed) {
                while let Some(m) = sub.receive().unwrap() {
                    seen2
                        .lock()
                        .unwrap()
                        .push((m.header.seq, m.objects().len()));
                }
                std::thread::sleep(Duration::from_millis(2));
            }
        });
        ready.recv().unwrap();
        Self {
            seen,
            stop,
            thread: Some(thread),
        }
    }

    fn seen(&self) -> Vec<(u64, usize)> {
        self.seen.lock().unwrap().clone()
    }
}

impl Drop for MapWatch {
    fn drop(&mut self) {
        self.stop.store(true, std::sync::atomic::Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// Waits until the newest map has at least `n` objects and the mapper has published 20 maps
/// (2 s simulated: mid-run).
fn wait_objects(run: &Run, maps: &MapWatch, n: usize) {
    let start = Instant::now();
    while !maps.seen().last().is_some_and(|m| m.1 >= n && m.0 >= 20) {
        assert!(
            start.elapsed() < GUARD,
            "the map never reached {n} objects ({:?}):\n{}",
            maps.seen(),
            run.log()
        );
        std::thread::sleep(Duration::from_millis(10));
    }
}

/// SIGKILL `role`; wait for the launcher's report of the death and restart. Returns the time
/// from the kill to the report and the report.
fn kill_and_wait_restart(run: &Run, role: &str) -> (Duration, String) {
    let pid = run.node_pid(role);
    let from = run.line_count();
    let t0 = Instant::now();
    signal(&pid.to_string(), "KILL");
    let (_, t, line) = run.wait_line(from, &format!("{role}: died (killed by signal 9"));
    assert!(line.contains("restart 1"), "{line}");
    let new_pid = run.node_pid(role);
    assert_ne!(new_pid, pid, "{role} was not restarted");
    (t.duration_since(t0), line)
}

/// The number of stale iceoryx2 nodes a restart report says were removed.
fn cleaned(line: &str) -> u64 {
    line.split("removed ")
        .nth(1)
        .and_then(|s| s.split_whitespace().next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no cleanup count in {line:?}"))
}

/// A summary row `| name | a / b / c |` as numbers.
fn row(stdout: &str, name: &str) -> Vec<u64> {
    let line = stdout
        .lines()
        .find(|l| l.starts_with(&format!("| {name}")))
        .unwrap_or_else(|| panic!("no {name:?} row:\n{stdout}"));
    let value = line.trim_end_matches('|').rsplit('|').next().unwrap();
    value
        .split('/')
        .map(|v| v.trim().parse().unwrap_or_else(|_| panic!("{line}")))
        .collect()
}

fn assert_ended_by_planner(status: std::process::ExitStatus, stdout: &str, log: &str) {
    assert!(status.success(), "vpsom run failed:\n{stdout}\n{log}");
    assert!(
        log.contains("stopping: planner"),
        "the session did not end by the planner:\n{stdout}\n{log}"
    );
}

#[test]
fn each_node_killed_mid_run_is_restarted_the_mapper_resumes_and_the_session_ends() {
    let _one = SESSIONS.lock().unwrap_or_else(|e| e.into_inner());
    let dir = scratch("kill");
    let ns = format!("faultk{}", std::process::id());
    let run = Run::start(&dir, &ns, None);
    let maps = MapWatch::new(&ns);

    // The mapper, once it has mapped a few objects.
    wait_objects(&run, &maps, 3);
    let (mapper_latency, line) = kill_and_wait_restart(&run, "mapper");
    assert!(cleaned(&line) >= 1, "{line}");
    let (_, _, resumed) =
        run.wait_line(0, "mapper: restart 1: resumed from the last published map");
    // The restarted mapper's publisher counts from 1 again: its first map follows the last
    // one of the killed mapper.
    let start = Instant::now();
    let (last_before, first_after) = loop {
        let seen = maps.seen();
        if let Some(w) = seen.windows(2).find(|w| w[1].0 < w[0].0) {
            break (w[0], w[1]);
        }
        assert!(
            start.elapsed() < GUARD,
            "no map from the restarted mapper: {seen:?}"
        );
        std::thread::sleep(Duration::from_millis(10));
    };
    eprintln!(
        "mapper: last map before the kill seq {} with {} objects; first after the restart seq {} \
         with {} objects ({resumed})",
        last_before.0, last_before.1, first_after.0, first_after.1
    );
    // Resumed, not empty: the first map of the new mapper has every object of the last one
    // (nodes/vpsom/tests/mapper_resume.rs checks that object by object on many restarts).
    assert!(
        first_after.1 >= last_before.1 && first_after.1 >= 3,
        "before {last_before:?}, after {first_after:?}"
    );

    let mut latencies = vec![("mapper", mapper_latency)];
    for role in ["sim", "planner", "recorder"] {
        std::thread::sleep(Duration::from_secs(2));
        let (latency, line) = kill_and_wait_restart(&run, role);
        assert!(cleaned(&line) >= 1, "{line}");
        latencies.push((role, latency));
    }
    eprintln!("kill → launcher report: {latencies:?}");
    let (status, stdout, log) = run.finish();
    assert_ended_by_planner(status, &stdout, &log);
    let faults = stdout
        .lines()
        .find(|l| l.starts_with("| node faults"))
        .unwrap_or_default();
    for role in ["mapper", "sim", "planner", "recorder"] {
        assert!(faults.contains(&format!("{role}: died")), "{faults}");
    }
    drop(maps);
    assert!(runtime::ports::list_services(&ns).unwrap().is_empty());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_stalled_subscriber_stalls_no_publisher_and_a_hung_node_is_restarted() {
    let _one = SESSIONS.lock().unwrap_or_else(|e| e.into_inner());
    let dir = scratch("hang");
    let ns = format!("faulth{}", std::process::id());
    // A short hang timeout, still 8 heartbeats at 4 Hz.
    let run = Run::start(&dir, &ns, Some("[run]\nhang_timeout_s = 2.0\n"));
    let maps = MapWatch::new(&ns);
    let cfg = Config::default();
    let ctx = PortContext::with_namespace(&cfg.ports, "fault-test-truth", &ns).unwrap();
    let truth = ctx.subscriber::<RobotState>(topics::TRUTH).unwrap();
    wait_objects(&run, &maps, 2);

    // The recorder stops reading for 1 s (half the hang timeout), then goes on.
    let recorder = run.node_pid("recorder").to_string();
    while truth.receive().unwrap().is_some() {}
    signal(&recorder, "STOP");
    let stopped = Instant::now();
    let mut during = 0u64;
    while stopped.elapsed() < Duration::from_secs(1) {
        while truth.receive().unwrap().is_some() {
            during += 1;
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    signal(&recorder, "CONT");
    // The sim published on (50 Hz simulated x 4 = 200 Hz: about 200 in 1 s) while one of its
    // subscribers did not read.
    eprintln!("sim/truth samples received here while the recorder was stopped 1 s: {during}");
    assert!(during >= 20, "the sim stalled with the recorder: {during}");

    // The mapper hangs without dying.
    std::thread::sleep(Duration::from_secs(1));
    let mapper = run.node_pid("mapper");
    let from = run.line_count();
    signal(&mapper.to_string(), "STOP");
    let (_, _, hung) = run.wait_line(from, "mapper: hung: no heartbeat for");
    let (_, _, restarted) = run.wait_line(from, "mapper: died (killed by signal 9");
    assert!(restarted.contains("restart 1"), "{restarted}");
    assert_ne!(run.node_pid("mapper"), mapper);
    eprintln!("{hung}\n{restarted}");

    let (status, stdout, log) = run.finish();
    assert_ended_by_planner(status, &stdout, &log);
    assert!(!log.contains("recorder: hung"), "{log}");
    // The recorder's overflow while it was stopped: robot/state (200 Hz into a buffer of 16).
    let state = row(&stdout, "recorder ← robot/state");
    eprintln!("recorder ← robot/state received / invalid / overflow: {state:?}");
    assert!(state[2] > 0, "no overflow counted: {state:?}\n{stdout}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_killed_process_group_leaves_nothing_a_new_run_cannot_clean() {
    let _one = SESSIONS.lock().unwrap_or_else(|e| e.into_inner());
    let dir = scratch("group");
    let ns = format!("faultg{}", std::process::id());
    // No port of this test's own: a live node would remove the dead ones' resources when it
    // goes (iceoryx2 cleans dead nodes up when a node is dropped).
    let run = Run::start(&dir, &ns, None);
    // Mid-run: a status line names a GBV (any: at 1 Hz a line can skip the first round).
    run.wait_line(0, "GBV #");
    let pids: Vec<u32> = ["sim", "mapper", "planner", "recorder"]
        .iter()
        .map(|r| run.node_pid(r))
        .collect();
    signal(&format!("-{}", run.child.id()), "KILL");
    let (status, _, _) = run.finish();
    assert_eq!(
        std::os::unix::process::ExitStatusExt::signal(&status),
        Some(9)
    );
    // Every node died with the group (the launcher's children are its group's).
    let start = Instant::now();
    while pids
        .iter()
        .any(|p| Path::new(&format!("/proc/{p}")).exists())
    {
        assert!(start.elapsed() < GUARD, "nodes outlived their group");
        std::thread::sleep(Duration::from_millis(20));
    }
    // The nodes' services are left behind.
    assert!(!runtime::ports::list_services(&ns).unwrap().is_empty());

    let run = Run::start(&dir, &ns, None);
    let (_, _, line) = run.wait_line(0, "removed stale shared-memory resources of");
    let (status, stdout, log) = run.finish();
    assert_ended_by_planner(status, &stdout, &log);
    let removed: u64 = line
        .split("resources of ")
        .nth(1)
        .and_then(|s| s.split_whitespace().next())
        .and_then(|n| n.parse().ok())
        .unwrap();
    // The launcher and the four nodes (and any other dead run's on this machine).
    eprintln!("after the group kill, the new run: {line}");
    assert!(removed >= 5, "{line}");
    assert!(runtime::ports::list_services(&ns).unwrap().is_empty());
    let _ = std::fs::remove_dir_all(&dir);
}
