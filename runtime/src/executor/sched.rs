//! Scheduling of an executor thread: [`apply_sched`] (CPU affinity, `SCHED_FIFO` or `nice`,
//! process-wide `mlockall`, the `/dev/cpu_dma_latency` hold), the backup waker's start, and the
//! [`SchedReport`] of what was granted. A refusal is logged once per process, never fatal.

use super::config::{ExecutorConfig, SchedPolicy};
use crate::waker::BackupWaker;
use std::fmt;
use std::sync::{Mutex, OnceLock};

/// What scheduling the thread actually got.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SchedReport {
    /// `Some(priority)` if `SCHED_FIFO` was granted.
    pub fifo: Option<i32>,
    /// The thread's nice value after setup (meaningful when not FIFO).
    pub nice: i32,
    /// The process's memory is locked.
    pub mlocked: bool,
    /// The CPUs the thread is pinned to, if pinning was requested and granted.
    pub cpus: Option<Vec<usize>>,
    /// The CPU wake-up latency limit the process holds, µs, if one was requested and granted.
    pub cpu_dma_latency_us: Option<i32>,
    /// The backup waker's CPU, if one was requested and runs.
    pub backup_cpu: Option<usize>,
    /// One line per refused request (empty if everything was granted).
    pub refusals: Vec<String>,
}

impl fmt::Display for SchedReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.fifo {
            Some(p) => write!(f, "SCHED_FIFO {p}")?,
            None => write!(f, "SCHED_OTHER nice {}", self.nice)?,
        }
        write!(f, ", mlock {}", if self.mlocked { "yes" } else { "no" })?;
        match &self.cpus {
            Some(c) => write!(f, ", cpus {c:?}")?,
            None => write!(f, ", cpus any")?,
        }
        if let Some(us) = self.cpu_dma_latency_us {
            write!(f, ", cpu latency {us} µs")?;
        }
        if let Some(c) = self.backup_cpu {
            write!(f, ", backup waker on CPU {c}")?;
        }
        Ok(())
    }
}

/// Log `msg` to stderr the first time `key` is seen in this process.
pub(crate) fn log_once(key: &str, msg: &str) {
    static SEEN: OnceLock<Mutex<Vec<String>>> = OnceLock::new();
    let seen = SEEN.get_or_init(|| Mutex::new(Vec::new()));
    let mut seen = seen.lock().unwrap_or_else(|p| p.into_inner());
    if !seen.iter().any(|k| k == key) {
        seen.push(key.to_string());
        eprintln!("vpsom runtime: {msg}");
    }
}

/// Process-wide `mlockall`, attempted once; the outcome is remembered.
fn mlock_process() -> Result<(), String> {
    static DONE: OnceLock<Result<(), String>> = OnceLock::new();
    DONE.get_or_init(|| crate::os::mlockall().map_err(|e| e.to_string()))
        .clone()
}

/// Process-wide `/dev/cpu_dma_latency` hold, attempted once (the first value requested wins);
/// the file is kept open for the life of the process.
fn hold_cpu_latency(us: i32) -> Result<i32, String> {
    static HELD: OnceLock<Result<(std::fs::File, i32), String>> = OnceLock::new();
    HELD.get_or_init(|| {
        crate::os::hold_cpu_dma_latency(us)
            .map(|f| (f, us))
            .map_err(|e| e.to_string())
    })
    .as_ref()
    .map(|(_, held)| *held)
    .map_err(Clone::clone)
}

/// Apply `cfg`'s affinity, policy, memory locking and CPU latency limit to the calling thread;
/// never fails.
pub fn apply_sched(thread: &str, cfg: &ExecutorConfig) -> SchedReport {
    let mut refusals = Vec::new();
    let mut refuse = |kind: &str, msg: String| {
        log_once(kind, &format!("thread '{thread}': {msg}"));
        refusals.push(msg);
    };
    let cpus = if cfg.cpus.is_empty() {
        None
    } else {
        match crate::os::set_affinity(&cfg.cpus) {
            Ok(()) => Some(cfg.cpus.clone()),
            Err(e) => {
                refuse(
                    "affinity",
                    format!("CPU affinity {:?} refused ({e})", cfg.cpus),
                );
                None
            }
        }
    };
    let mut fifo = None;
    if cfg.policy == SchedPolicy::Fifo {
        match crate::os::set_fifo(cfg.priority) {
            Ok(()) => fifo = Some(cfg.priority),
            Err(e) => refuse(
                "fifo",
                format!(
                    "SCHED_FIFO {} refused ({e}); falling back to nice {}",
                    cfg.priority, cfg.nice
                ),
            ),
        }
    }
    if fifo.is_none()
        && cfg.nice != 0
        && let Err(e) = crate::os::set_nice(cfg.nice)
    {
        refuse(
            "nice",
            format!("nice {} refused ({e}); keeping nice 0", cfg.nice),
        );
    }
    let mut mlocked = false;
    if cfg.mlockall && fifo.is_some() {
        match mlock_process() {
            Ok(()) => mlocked = true,
            Err(e) => refuse("mlockall", format!("mlockall refused ({e})")),
        }
    }
    let mut cpu_dma_latency_us = None;
    if cfg.cpu_dma_latency_us >= 0 {
        match hold_cpu_latency(cfg.cpu_dma_latency_us) {
            Ok(us) => cpu_dma_latency_us = Some(us),
            Err(e) => refuse(
                "cpu_dma_latency",
                format!(
                    "CPU latency limit {} µs refused (/dev/cpu_dma_latency: {e})",
                    cfg.cpu_dma_latency_us
                ),
            ),
        }
    }
    SchedReport {
        fifo,
        nice: crate::os::nice().unwrap_or(0),
        mlocked,
        cpus,
        cpu_dma_latency_us,
        backup_cpu: None,
        refusals,
    }
}

/// Start the backup waker `cfg` asks for (on the executor thread, after [`apply_sched`]),
/// recording the outcome in `sched`. Only for the real clock, and only if the thread's pinning
/// was granted.
pub(super) fn start_backup(
    thread: &str,
    cfg: &ExecutorConfig,
    real_clock: bool,
    sched: &mut SchedReport,
) -> Option<BackupWaker> {
    let cpu = usize::try_from(cfg.backup_cpu).ok()?;
    let why = match (&sched.cpus, real_clock) {
        (_, false) => "the clock is not real time".to_string(),
        (None, _) => "the thread is not pinned".to_string(),
        (Some(home), true) => match BackupWaker::start(thread, cpu, home, sched.fifo) {
            Ok(w) => {
                sched.backup_cpu = Some(cpu);
                return Some(w);
            }
            Err(why) => why,
        },
    };
    let msg = format!("backup waker on CPU {cpu} not started: {why}");
    log_once("backup", &format!("thread '{thread}': {msg}"));
    sched.refusals.push(msg);
    None
}
