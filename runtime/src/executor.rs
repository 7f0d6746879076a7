//! The periodic executor: a named thread that runs a closure at a fixed rate on absolute
//! deadlines, with a [`DeadlineMonitor`] that records wake-up lateness and execution time, counts
//! misses, emits [`DeadlineEvent`]s and applies a miss policy.
//!
//! Timeline of cycle `k` (release `r`, budget `b ≤ period`):
//! sleep until `r − spin_margin` (`clock_nanosleep(TIMER_ABSTIME)`), spin to `r`, wake at `w`,
//! run the body until `e`. Lateness = `w − r`; execution time = `e − w`; the cycle **misses**
//! its deadline if `e > r + b`. Releases lie on the grid `start + g·period` (no drift); a release
//! that has already passed when the previous cycle ends is never run in a burst:
//! - [`MissPolicy::Skip`]: after a miss the next release is skipped too (consumers keep the last
//!   output while the system recovers), then the executor resumes at the first future release;
//! - [`MissPolicy::Hold`]: the executor runs once at once (late) and resumes the grid; the body
//!   sees [`Cycle::previous_missed`] so it can hold its last output.
//!
//! With `backup_cpu` set, a backup waker on that CPU wakes the thread there when its own timer
//! has not woken it `backup_delay_us` after a release (see `waker.rs`: a VM stalls one virtual
//! CPU at a time).
//!
//! Each cycle also reads the thread's scheduler statistics (`/proc/thread-self/schedstat`, one
//! `pread` after the body), so every miss carries its cause ([`miss_cause_of`]): the body's own
//! execution, waiting for a CPU, a wake-up that came late, or blocking inside the body.
//!
//! After `escalate_after` consecutive misses the executor **escalates**: the state becomes
//! [`ExecutorState::Escalated`] (latched until [`ExecutorHandle::clear_escalation`]), the body
//! sees [`Cycle::escalated`], and with [`EscalateAction::Stop`] the executor stops.
//!
//! Scheduling (applied on the executor thread before the body is built): CPU affinity, then
//! `SCHED_FIFO` at `priority` (+ process-wide `mlockall`) when permitted; if refused, the refusal
//! is logged once per process and the thread falls back to `nice` — never a crash. The outcome is
//! in [`SchedReport`].

use crate::clock::Clock;
use crate::config::{Checker, ConfigError};
pub use crate::os::{SchedStatReading, ThreadSchedStat};
use crate::pool::PoolConfig;
use crate::waker::BackupWaker;
use crossbeam::channel::Sender;
use hdrhistogram::Histogram;
use serde::{Deserialize, Serialize};
use shm_types::{DeadlineEvent, Header, miss_cause};
use std::fmt;
use std::sync::atomic::{AtomicBool, AtomicU8, AtomicU64, Ordering};
use std::sync::{Arc, Mutex, OnceLock};
use std::thread::JoinHandle;
use std::time::Duration;

/// Scheduling policy requested for an executor thread.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SchedPolicy {
    /// `SCHED_FIFO` at `priority` (falls back to `nice` if refused).
    Fifo,
    /// `SCHED_OTHER` at `nice`.
    Other,
}

/// What happens after a missed deadline (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MissPolicy {
    /// Skip the next release, then resume at the first future release.
    Skip,
    /// Run once immediately (late), flag `previous_missed`, resume the grid.
    Hold,
}

/// What escalation does besides being reported.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum EscalateAction {
    /// Keep running; the state is `Escalated` and the body sees `Cycle::escalated`.
    Report,
    /// Stop the executor; `join` reports `StopReason::Escalated`.
    Stop,
}

/// Which cycles produce a [`DeadlineEvent`] on the event sink.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum EventTrace {
    /// Every cycle.
    All,
    /// Only cycles that missed their deadline.
    Misses,
    /// None.
    None,
}

/// `[executor]` section: defaults for every periodic executor (the period comes from the node's
/// rate), and `[executor.pool]` for the low-priority worker pool.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExecutorConfig {
    /// Requested policy.
    pub policy: SchedPolicy,
    /// `SCHED_FIFO` priority, 1..=98 (99 is left to kernel watchdogs).
    pub priority: i32,
    /// Nice value for `other`, and the fallback when FIFO is refused (-20..=19; a negative value
    /// needs privileges and is itself logged and dropped if refused).
    pub nice: i32,
    /// Lock the process's memory (`mlockall(MCL_CURRENT | MCL_FUTURE)`) when FIFO is granted.
    pub mlockall: bool,
    /// CPUs to pin the thread to; empty = no pinning.
    pub cpus: Vec<usize>,
    /// Sleep until this long before each release, then spin (µs); 0 = pure sleep.
    pub spin_margin_us: u64,
    /// While the process runs, hold `/dev/cpu_dma_latency` at this many µs (no deep idle
    /// states; cyclictest does the same by default); -1 = leave the system's setting.
    pub cpu_dma_latency_us: i32,
    /// CPU of the backup waker (-1 = none): a second thread at the executor's priority that
    /// wakes the executor thread on this CPU when its own timer has not woken it
    /// `backup_delay_us` after a release (a VM stalls one virtual CPU at a time). Needs `cpus`
    /// set, without this CPU, and the real clock.
    pub backup_cpu: i32,
    /// How long after a release the backup waker steps in, µs.
    pub backup_delay_us: u64,
    /// Budget as a fraction of the period, (0, 1]: a cycle misses if it ends after release+budget.
    pub budget_fraction: f64,
    /// Policy after a miss.
    pub miss_policy: MissPolicy,
    /// Escalate after this many consecutive misses (0 = never).
    pub escalate_after: u32,
    /// What escalation does.
    pub on_escalate: EscalateAction,
    /// Which cycles are traced as `DeadlineEvent`s.
    pub trace: EventTrace,
    /// Worker pool settings (`[executor.pool]`).
    pub pool: PoolConfig,
}

impl Default for ExecutorConfig {
    /// The `[executor]` section of the built-in `config/default.toml`.
    fn default() -> Self {
        crate::config::DEFAULTS.section("executor")
    }
}

impl ExecutorConfig {
    /// Range-check.
    pub fn validate(&self, c: &Checker) -> Result<(), ConfigError> {
        c.require(
            (1..=98).contains(&self.priority),
            "executor.priority",
            self.priority,
            "must be in [1, 98]",
        )?;
        c.require(
            (-20..=19).contains(&self.nice),
            "executor.nice",
            self.nice,
            "must be in [-20, 19]",
        )?;
        for &cpu in &self.cpus {
            c.require(
                cpu < 1024,
                "executor.cpus",
                cpu,
                "must be a CPU index below 1024",
            )?;
        }
        c.require(
            self.spin_margin_us <= 100_000,
            "executor.spin_margin_us",
            self.spin_margin_us,
            "must be in [0, 100000]",
        )?;
        c.require(
            (-1..=10_000_000).contains(&self.cpu_dma_latency_us),
            "executor.cpu_dma_latency_us",
            self.cpu_dma_latency_us,
            "must be in [-1, 10000000] (-1 = leave the system setting)",
        )?;
        c.require(
            (-1..1024).contains(&self.backup_cpu),
            "executor.backup_cpu",
            self.backup_cpu,
            "must be a CPU index below 1024, or -1 for none",
        )?;
        if let Ok(cpu) = usize::try_from(self.backup_cpu) {
            c.require(
                !self.cpus.is_empty() && !self.cpus.contains(&cpu),
                "executor.backup_cpu",
                self.backup_cpu,
                "needs executor.cpus set to the executor's own CPUs, without the backup CPU",
            )?;
        }
        c.require(
            (10..=1_000_000).contains(&self.backup_delay_us),
            "executor.backup_delay_us",
            self.backup_delay_us,
            "must be in [10, 1000000]",
        )?;
        c.require(
            self.budget_fraction.is_finite()
                && self.budget_fraction > 0.0
                && self.budget_fraction <= 1.0,
            "executor.budget_fraction",
            self.budget_fraction,
            "must be in (0, 1]",
        )?;
        c.require(
            self.escalate_after <= 1_000_000,
            "executor.escalate_after",
            self.escalate_after,
            "must be in [0, 1000000] (0 = never)",
        )?;
        self.pool.validate(c)
    }
}

/// Body's verdict at the end of a cycle.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Control {
    /// Keep running.
    Continue,
    /// Stop after this cycle.
    Stop,
}

/// What the body is told about the current cycle.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Cycle {
    /// Cycles executed before this one.
    pub index: u64,
    /// Grid index of the release (`release_ns = start_ns + grid · period`); larger than `index`
    /// when releases were skipped.
    pub grid: u64,
    /// Intended wake-up, clock ns.
    pub release_ns: u64,
    /// Actual wake-up, clock ns.
    pub wake_ns: u64,
    /// Release + budget, clock ns.
    pub deadline_ns: u64,
    /// The previous cycle missed its deadline.
    pub previous_missed: bool,
    /// The executor is escalated (latched).
    pub escalated: bool,
}

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
fn start_backup(
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

/// A latency histogram: 1 ns .. 60 s, 3 significant digits (what [`DeadlineMonitor`] records
/// into, and what [`Stats::of_samples`] uses).
pub fn latency_histogram() -> Histogram<u64> {
    Histogram::new_with_bounds(1, HIST_MAX_NS, 3).expect("constant histogram bounds are valid")
}

/// Percentiles of one histogram, nanoseconds.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct Stats {
    /// Samples.
    pub count: u64,
    /// Smallest.
    pub min: u64,
    /// Mean.
    pub mean: f64,
    /// Median.
    pub p50: u64,
    /// 90th percentile.
    pub p90: u64,
    /// 99th percentile.
    pub p99: u64,
    /// 99.9th percentile.
    pub p999: u64,
    /// Largest.
    pub max: u64,
}

impl Stats {
    /// Percentiles of `h` (all zero if it is empty).
    pub fn of(h: &Histogram<u64>) -> Self {
        if h.is_empty() {
            return Self::default();
        }
        Self {
            count: h.len(),
            min: h.min(),
            mean: h.mean(),
            p50: h.value_at_quantile(0.5),
            p90: h.value_at_quantile(0.9),
            p99: h.value_at_quantile(0.99),
            p999: h.value_at_quantile(0.999),
            max: h.max(),
        }
    }

    /// Percentiles of raw samples, ns, through a [`latency_histogram`] (0 counts as 1 ns,
    /// beyond 60 s as 60 s).
    pub fn of_samples(samples: &[u64]) -> Self {
        let mut h = latency_histogram();
        for &s in samples {
            h.saturating_record(s.max(1));
        }
        Self::of(&h)
    }
}

impl fmt::Display for Stats {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "n={} min={:.1}µs p50={:.1}µs p99={:.1}µs p99.9={:.1}µs max={:.1}µs",
            self.count,
            self.min as f64 / 1e3,
            self.p50 as f64 / 1e3,
            self.p99 as f64 / 1e3,
            self.p999 as f64 / 1e3,
            self.max as f64 / 1e3
        )
    }
}

/// Verdict of [`DeadlineMonitor::record`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Verdict {
    /// The cycle missed its deadline.
    pub missed: bool,
    /// Consecutive misses including this one.
    pub consecutive: u32,
    /// This cycle made the monitor escalate (the `escalate_after`-th consecutive miss).
    pub escalate: bool,
    /// Why it missed ([`miss_cause`] code; `NONE` if it did not).
    pub cause: u8,
}

/// The thread's scheduler statistics over one cycle: from the end of the previous cycle (after
/// its bookkeeping) to the end of this one.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct CycleSched {
    /// Time on a CPU, ns (with a spin margin, this includes the spin before the release).
    pub cpu_ns: u64,
    /// Time runnable but waiting for a CPU, ns.
    pub run_wait_ns: u64,
}

impl CycleSched {
    /// The difference of two readings, `before` then `after`.
    pub fn between(before: &SchedStatReading, after: &SchedStatReading) -> Self {
        Self {
            cpu_ns: after.cpu_ns.saturating_sub(before.cpu_ns),
            run_wait_ns: after.run_wait_ns.saturating_sub(before.run_wait_ns),
        }
    }
}

/// Why a cycle released at `r`, woken at `r + lateness_ns` and ended `exec_ns` later missed its
/// deadline: the largest share of `lateness + exec`, split by the scheduler statistics `sched`
/// into running (`cpu`: [`miss_cause::EXECUTION`]), waiting for a CPU (`run_wait`:
/// [`miss_cause::RUN_QUEUE`]), and not runnable: before the wake-up ([`miss_cause::LATE_WAKEUP`],
/// the timer's wake-up came late; counted as `lateness − run_wait`, so run-queue wait is never
/// taken for a late timer) or after it ([`miss_cause::BLOCKED`]). Ties go to the cause listed
/// first. `UNKNOWN` without statistics.
pub fn miss_cause_of(lateness_ns: u64, exec_ns: u64, sched: Option<CycleSched>) -> u8 {
    let Some(CycleSched {
        cpu_ns,
        run_wait_ns,
    }) = sched
    else {
        return miss_cause::UNKNOWN;
    };
    let total = lateness_ns + exec_ns;
    let not_runnable = total.saturating_sub(cpu_ns).saturating_sub(run_wait_ns);
    let late = not_runnable.min(lateness_ns.saturating_sub(run_wait_ns));
    let blocked = not_runnable - late;
    [
        (cpu_ns, miss_cause::EXECUTION),
        (run_wait_ns, miss_cause::RUN_QUEUE),
        (late, miss_cause::LATE_WAKEUP),
        (blocked, miss_cause::BLOCKED),
    ]
    .into_iter()
    .fold((0, miss_cause::EXECUTION), |best, (t, c)| {
        if t > best.0 { (t, c) } else { best }
    })
    .1
}

/// Records lateness and execution time into HDR histograms (1 ns .. 60 s, 3 significant
/// digits, no allocation when recording), counts misses and builds [`DeadlineEvent`]s. Usable on
/// its own by a lockstep host.
#[derive(Debug, Clone)]
pub struct DeadlineMonitor {
    thread: String,
    period_ns: u64,
    budget_ns: u64,
    escalate_after: u32,
    lateness: Histogram<u64>,
    exec: Histogram<u64>,
    cycles: u64,
    misses: u64,
    consecutive: u32,
    max_consecutive: u32,
    escalations: u64,
    /// Misses by cause, indexed by [`miss_cause`] code.
    causes: [u64; MISS_CAUSES],
}

/// Number of [`miss_cause`] codes.
const MISS_CAUSES: usize = miss_cause::UNKNOWN as usize + 1;

const HIST_MAX_NS: u64 = 60_000_000_000;

impl DeadlineMonitor {
    /// A monitor for a thread with this period and budget (ns); `escalate_after` 0 = never.
    pub fn new(thread: &str, period_ns: u64, budget_ns: u64, escalate_after: u32) -> Self {
        Self {
            thread: thread.to_string(),
            period_ns,
            budget_ns,
            escalate_after,
            lateness: latency_histogram(),
            exec: latency_histogram(),
            cycles: 0,
            misses: 0,
            consecutive: 0,
            max_consecutive: 0,
            escalations: 0,
            causes: [0; MISS_CAUSES],
        }
    }

    /// Record one cycle: released at `release_ns`, woke at `wake_ns`, ended at `end_ns`, with
    /// the thread's scheduler statistics over it if measured.
    pub fn record(
        &mut self,
        release_ns: u64,
        wake_ns: u64,
        end_ns: u64,
        sched: Option<CycleSched>,
    ) -> Verdict {
        let lateness = wake_ns.saturating_sub(release_ns);
        let exec = end_ns.saturating_sub(wake_ns);
        self.lateness.saturating_record(lateness);
        self.exec.saturating_record(exec);
        self.cycles += 1;
        let missed = end_ns > release_ns.saturating_add(self.budget_ns);
        let mut escalate = false;
        let mut cause = miss_cause::NONE;
        if missed {
            cause = miss_cause_of(lateness, exec, sched);
            self.causes[usize::from(cause)] += 1;
            self.misses += 1;
            self.consecutive += 1;
            self.max_consecutive = self.max_consecutive.max(self.consecutive);
            if self.escalate_after > 0 && self.consecutive == self.escalate_after {
                self.escalations += 1;
                escalate = true;
            }
        } else {
            self.consecutive = 0;
        }
        Verdict {
            missed,
            consecutive: self.consecutive,
            escalate,
            cause,
        }
    }

    /// The trace record of a cycle that [`DeadlineMonitor::record`] just recorded with the same
    /// arguments and gave verdict `v` (`seq` = cycle + 1, stamped with the wake-up time).
    pub fn event(
        &self,
        cycle: u64,
        release_ns: u64,
        wake_ns: u64,
        end_ns: u64,
        sched: Option<CycleSched>,
        v: &Verdict,
    ) -> DeadlineEvent {
        let s = sched.unwrap_or_default();
        let mut e = DeadlineEvent {
            header: Header {
                seq: cycle + 1,
                stamp_ns: wake_ns,
                sim_time_ns: 0,
            },
            cycle,
            period_ns: self.period_ns,
            budget_ns: self.budget_ns,
            lateness_ns: wake_ns as i64 - release_ns as i64,
            exec_ns: end_ns.saturating_sub(wake_ns),
            cpu_ns: s.cpu_ns,
            run_wait_ns: s.run_wait_ns,
            consecutive_misses: v.consecutive,
            missed: v.missed as u8,
            miss_cause: v.cause,
            sched_stats: sched.is_some() as u8,
            ..DeadlineEvent::default()
        };
        e.set_thread_name(&self.thread);
        e
    }

    /// Cycles recorded.
    pub fn cycles(&self) -> u64 {
        self.cycles
    }

    /// Deadline misses.
    pub fn misses(&self) -> u64 {
        self.misses
    }

    /// Current run of consecutive misses.
    pub fn consecutive(&self) -> u32 {
        self.consecutive
    }

    /// Longest run of consecutive misses.
    pub fn max_consecutive(&self) -> u32 {
        self.max_consecutive
    }

    /// Times the run of consecutive misses reached `escalate_after`.
    pub fn escalations(&self) -> u64 {
        self.escalations
    }

    /// Misses with cause `code` ([`miss_cause`]).
    pub fn misses_by(&self, code: u8) -> u64 {
        self.causes.get(usize::from(code)).copied().unwrap_or(0)
    }

    /// `"late-wakeup 3, run-queue 1"`: the causes of the misses so far, most frequent first
    /// (empty without misses).
    pub fn miss_causes(&self) -> String {
        let mut v: Vec<(u64, u8)> = (0..MISS_CAUSES as u8)
            .map(|c| (self.misses_by(c), c))
            .filter(|(n, _)| *n > 0)
            .collect();
        v.sort_by_key(|&(n, c)| (std::cmp::Reverse(n), c));
        v.iter()
            .map(|&(n, c)| format!("{} {n}", miss_cause::name(c)))
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// Wake-up lateness histogram (ns).
    pub fn lateness(&self) -> &Histogram<u64> {
        &self.lateness
    }

    /// Execution time histogram (ns).
    pub fn exec(&self) -> &Histogram<u64> {
        &self.exec
    }

    /// Period, ns.
    pub fn period_ns(&self) -> u64 {
        self.period_ns
    }

    /// Budget, ns.
    pub fn budget_ns(&self) -> u64 {
        self.budget_ns
    }
}

/// Why an executor stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StopReason {
    /// [`ExecutorHandle::stop`] (or a [`StopFlag`]) was called.
    Requested,
    /// The body returned [`Control::Stop`].
    Body,
    /// The configured number of cycles ran.
    MaxCycles,
    /// Escalation with [`EscalateAction::Stop`].
    Escalated,
}

/// What [`ExecutorHandle::join`] returns.
#[derive(Debug, Clone)]
pub struct Summary {
    /// Thread name.
    pub name: String,
    /// Why it stopped.
    pub reason: StopReason,
    /// Scheduling the thread got.
    pub sched: SchedReport,
    /// Releases skipped (never run) because of misses or overruns.
    pub skipped: u64,
    /// Deadline events that could not be queued (sink full or gone).
    pub events_dropped: u64,
    /// Cycles whose wake-up the backup waker did (the thread's own timer was late).
    pub backup_wakes: u64,
    /// The monitor (counts and histograms).
    pub monitor: DeadlineMonitor,
    /// Lateness percentiles.
    pub lateness: Stats,
    /// Execution-time percentiles.
    pub exec: Stats,
}

impl fmt::Display for Summary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "{}: {} cycles, {} misses{} (max {} in a row), {} skipped, {}{} escalations, {:?}, {}",
            self.name,
            self.monitor.cycles(),
            self.monitor.misses(),
            match self.monitor.miss_causes() {
                c if c.is_empty() => c,
                c => format!(" ({c})"),
            },
            self.monitor.max_consecutive(),
            self.skipped,
            match self.sched.backup_cpu {
                Some(_) => format!("{} backup wake-ups, ", self.backup_wakes),
                None => String::new(),
            },
            self.monitor.escalations(),
            self.reason,
            self.sched
        )?;
        writeln!(f, "  lateness {}", self.lateness)?;
        write!(f, "  exec     {}", self.exec)
    }
}

/// Why the executor could not be started or finished abnormally.
#[derive(Debug, thiserror::Error)]
pub enum ExecutorError {
    /// The OS refused to create the thread.
    #[error("executor '{name}': cannot spawn thread: {source}")]
    Spawn {
        /// Thread name.
        name: String,
        /// The OS error.
        source: std::io::Error,
    },
    /// The period is zero or too long.
    #[error("executor '{name}': period {period:?} must be in (0, 60 s]")]
    Period {
        /// Thread name.
        name: String,
        /// The period.
        period: Duration,
    },
    /// `make_body` or the body panicked.
    #[error("executor '{name}': the {what} panicked: {message}")]
    Panicked {
        /// Thread name.
        name: String,
        /// `"body"` or `"setup"`.
        what: &'static str,
        /// The panic payload, if it was a string.
        message: String,
    },
}

/// Current state of an executor.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ExecutorState {
    /// Running normally.
    Running,
    /// `escalate_after` consecutive misses happened (latched until cleared).
    Escalated,
    /// The thread has left its loop.
    Finished,
}

const STATE_RUNNING: u8 = 0;
const STATE_ESCALATED: u8 = 1;
const STATE_FINISHED: u8 = 2;

#[derive(Debug, Default)]
struct Shared {
    stop: AtomicBool,
    state: AtomicU8,
    cycles: AtomicU64,
    misses: AtomicU64,
}

/// A cloneable stop request for one executor (e.g. for a signal handler thread).
#[derive(Debug, Clone)]
pub struct StopFlag(Arc<Shared>);

impl StopFlag {
    /// Ask the executor to stop before its next cycle.
    pub fn stop(&self) {
        self.0.stop.store(true, Ordering::Release);
    }
}

/// Builds and spawns a periodic executor.
#[derive(Debug)]
pub struct Executor {
    name: String,
    period: Duration,
    config: ExecutorConfig,
    clock: Arc<dyn Clock>,
    events: Option<Sender<DeadlineEvent>>,
    max_cycles: Option<u64>,
    start_ns: Option<u64>,
}

impl Executor {
    /// An executor thread `name` with `period`, default config and the real clock.
    pub fn builder(name: &str, period: Duration) -> Self {
        Self {
            name: name.to_string(),
            period,
            config: ExecutorConfig::default(),
            clock: crate::clock::MonotonicClock::shared(),
            events: None,
            max_cycles: None,
            start_ns: None,
        }
    }

    /// Scheduling, spin margin, budget, miss policy (usually the `[executor]` section).
    pub fn config(mut self, config: &ExecutorConfig) -> Self {
        self.config = config.clone();
        self
    }

    /// Drive the executor from `clock` (e.g. a [`crate::clock::SteppedClock`]).
    pub fn clock(mut self, clock: Arc<dyn Clock>) -> Self {
        self.clock = clock;
        self
    }

    /// Send [`DeadlineEvent`]s (per `config.trace`) to `sink` with `try_send`; a full or closed
    /// sink drops the event (counted in [`Summary::events_dropped`]), it never blocks the loop.
    pub fn events(mut self, sink: Sender<DeadlineEvent>) -> Self {
        self.events = Some(sink);
        self
    }

    /// Stop after `n` cycles.
    pub fn max_cycles(mut self, n: u64) -> Self {
        self.max_cycles = Some(n);
        self
    }

    /// First release at `t_ns` on the executor's clock (default: when the loop starts).
    pub fn start_at(mut self, t_ns: u64) -> Self {
        self.start_ns = Some(t_ns);
        self
    }

    /// Start the thread. `make_body` runs **on the executor thread** after scheduling is
    /// applied (so ports, which are not `Send`, are created where they are used); the body it
    /// returns is called once per cycle. Returns once setup is done.
    pub fn spawn<M, B>(self, make_body: M) -> Result<ExecutorHandle, ExecutorError>
    where
        M: FnOnce() -> B + Send + 'static,
        B: FnMut(&Cycle) -> Control + 'static,
    {
        let name = self.name.clone();
        let period_ns = self.period.as_nanos();
        if period_ns == 0 || period_ns > HIST_MAX_NS as u128 {
            return Err(ExecutorError::Period {
                name,
                period: self.period,
            });
        }
        let shared = Arc::new(Shared::default());
        let (ready_tx, ready_rx) = crossbeam::channel::bounded::<SchedReport>(1);
        let thread_shared = shared.clone();
        let thread = std::thread::Builder::new()
            .name(name.clone())
            .spawn(move || {
                let mut sched = apply_sched(&self.name, &self.config);
                let backup = start_backup(
                    &self.name,
                    &self.config,
                    self.clock.is_real_time(),
                    &mut sched,
                );
                let body = make_body();
                // The spawner waits for this; if it has gone, running is pointless.
                let _ = ready_tx.send(sched.clone());
                self.run(body, sched, backup, &thread_shared)
            })
            .map_err(|source| ExecutorError::Spawn {
                name: name.clone(),
                source,
            })?;
        match ready_rx.recv() {
            Ok(sched) => Ok(ExecutorHandle {
                name,
                shared,
                sched,
                thread,
            }),
            Err(_) => {
                // Setup panicked before reporting.
                let message = match thread.join() {
                    Err(p) => panic_message(&p),
                    Ok(_) => "setup ended without reporting".into(),
                };
                Err(ExecutorError::Panicked {
                    name,
                    what: "setup",
                    message,
                })
            }
        }
    }

    fn run<B: FnMut(&Cycle) -> Control>(
        self,
        mut body: B,
        sched: SchedReport,
        mut backup: Option<BackupWaker>,
        shared: &Shared,
    ) -> Summary {
        let clock = self.clock;
        let cfg = self.config;
        let period = self.period.as_nanos() as u64;
        let budget = ((period as f64 * cfg.budget_fraction).round() as u64).clamp(1, period);
        let margin = cfg.spin_margin_us * 1000;
        let mut monitor = DeadlineMonitor::new(&self.name, period, budget, cfg.escalate_after);
        // Scheduler statistics only mean something against wall time.
        let schedstat = clock
            .is_real_time()
            .then(ThreadSchedStat::open_current)
            .and_then(Result::ok);
        let read_stat = || schedstat.as_ref().and_then(|s| s.read().ok());
        let mut last_stat = read_stat();
        let start = self.start_ns.unwrap_or_else(|| clock.now_ns());
        if let Some(w) = backup.as_mut() {
            w.begin(start, period, cfg.backup_delay_us * 1000);
        }
        let mut grid: u64 = 0;
        let mut skipped: u64 = 0;
        let mut events_dropped: u64 = 0;
        let mut previous_missed = false;
        let reason = loop {
            if shared.stop.load(Ordering::Acquire) {
                break StopReason::Requested;
            }
            if self.max_cycles.is_some_and(|n| monitor.cycles() >= n) {
                break StopReason::MaxCycles;
            }
            let release = start + grid * period;
            let rescued = match &backup {
                Some(w) => w.sleep_until(|| clock.now_ns(), release, margin),
                None => {
                    clock.sleep_until_spin(release, margin);
                    false
                }
            };
            let wake = clock.now_ns();
            let cycle = Cycle {
                index: monitor.cycles(),
                grid,
                release_ns: release,
                wake_ns: wake,
                deadline_ns: release + budget,
                previous_missed,
                escalated: shared.state.load(Ordering::Acquire) == STATE_ESCALATED,
            };
            let control = body(&cycle);
            let end = clock.now_ns();
            let stat = read_stat();
            let sched = last_stat
                .zip(stat)
                .map(|(a, b)| CycleSched::between(&a, &b));
            last_stat = stat;
            let v = monitor.record(release, wake, end, sched);
            shared.cycles.store(monitor.cycles(), Ordering::Release);
            shared.misses.store(monitor.misses(), Ordering::Release);
            if let Some(sink) = &self.events
                && (cfg.trace == EventTrace::All || (cfg.trace == EventTrace::Misses && v.missed))
                && sink
                    .try_send(DeadlineEvent {
                        backup_wake: rescued as u8,
                        ..monitor.event(cycle.index, release, wake, end, sched, &v)
                    })
                    .is_err()
            {
                events_dropped += 1;
            }
            previous_missed = v.missed;
            if v.escalate {
                let _ = shared.state.compare_exchange(
                    STATE_RUNNING,
                    STATE_ESCALATED,
                    Ordering::AcqRel,
                    Ordering::Acquire,
                );
                if cfg.on_escalate == EscalateAction::Stop {
                    break StopReason::Escalated;
                }
            }
            if control == Control::Stop {
                break StopReason::Body;
            }
            // Next release on the grid; never run passed releases in a burst.
            let mut next = grid + 1;
            if v.missed && cfg.miss_policy == MissPolicy::Skip {
                next += 1;
            }
            let now = clock.now_ns();
            if now > start + next * period {
                let last_passed = (now - start) / period; // latest grid point ≤ now
                next = if v.missed && cfg.miss_policy == MissPolicy::Skip {
                    last_passed + 1
                } else {
                    last_passed.max(next)
                };
            }
            skipped += next - grid - 1;
            grid = next;
        };
        let backup_wakes = backup.as_ref().map_or(0, BackupWaker::rescues);
        drop(backup);
        shared.state.store(STATE_FINISHED, Ordering::Release);
        Summary {
            name: self.name,
            reason,
            sched,
            skipped,
            events_dropped,
            backup_wakes,
            lateness: Stats::of(monitor.lateness()),
            exec: Stats::of(monitor.exec()),
            monitor,
        }
    }
}

fn panic_message(p: &Box<dyn std::any::Any + Send>) -> String {
    if let Some(s) = p.downcast_ref::<&str>() {
        (*s).to_string()
    } else if let Some(s) = p.downcast_ref::<String>() {
        s.clone()
    } else {
        "non-string panic payload".into()
    }
}

/// A running executor.
#[derive(Debug)]
pub struct ExecutorHandle {
    name: String,
    shared: Arc<Shared>,
    sched: SchedReport,
    thread: JoinHandle<Summary>,
}

impl ExecutorHandle {
    /// Thread name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Ask the thread to stop before its next cycle (a `Wait`-mode stepped clock must still be
    /// advanced for a sleeping executor to notice).
    pub fn stop(&self) {
        self.shared.stop.store(true, Ordering::Release);
    }

    /// A cloneable stop request.
    pub fn stop_flag(&self) -> StopFlag {
        StopFlag(self.shared.clone())
    }

    /// Scheduling the thread got.
    pub fn sched(&self) -> &SchedReport {
        &self.sched
    }

    /// Current state.
    pub fn state(&self) -> ExecutorState {
        match self.shared.state.load(Ordering::Acquire) {
            STATE_RUNNING => ExecutorState::Running,
            STATE_ESCALATED => ExecutorState::Escalated,
            _ => ExecutorState::Finished,
        }
    }

    /// Leave the escalated state (after the host acted on it).
    pub fn clear_escalation(&self) {
        let _ = self.shared.state.compare_exchange(
            STATE_ESCALATED,
            STATE_RUNNING,
            Ordering::AcqRel,
            Ordering::Acquire,
        );
    }

    /// Cycles executed so far.
    pub fn cycles(&self) -> u64 {
        self.shared.cycles.load(Ordering::Acquire)
    }

    /// Deadline misses so far.
    pub fn misses(&self) -> u64 {
        self.shared.misses.load(Ordering::Acquire)
    }

    /// The thread has left its loop.
    pub fn is_finished(&self) -> bool {
        self.thread.is_finished()
    }

    /// Stop (if still running) and wait for the thread; the monitor's summary.
    pub fn join(self) -> Result<Summary, ExecutorError> {
        self.stop();
        self.wait()
    }

    /// Wait for the thread to finish on its own (body `Stop`, max cycles, escalation).
    pub fn wait(self) -> Result<Summary, ExecutorError> {
        self.thread.join().map_err(|p| ExecutorError::Panicked {
            name: self.name.clone(),
            what: "body",
            message: panic_message(&p),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn monitor_counts_misses_and_escalates_once_per_run() {
        let mut m = DeadlineMonitor::new("t", 1000, 800, 2);
        assert!(!m.record(0, 10, 500, None).missed);
        let v = m.record(1000, 1000, 1801, None);
        assert_eq!((v.missed, v.consecutive, v.escalate), (true, 1, false));
        assert_eq!(v.cause, miss_cause::UNKNOWN, "no statistics");
        let sched = Some(CycleSched {
            cpu_ns: 850,
            run_wait_ns: 20,
        });
        let v = m.record(2000, 2100, 3000, sched);
        assert_eq!((v.missed, v.consecutive, v.escalate), (true, 2, true));
        assert_eq!(v.cause, miss_cause::EXECUTION);
        let e = m.event(7, 2000, 2100, 3000, sched, &v);
        assert_eq!(e.lateness_ns, 100);
        assert_eq!(e.exec_ns, 900);
        assert_eq!((e.cpu_ns, e.run_wait_ns, e.sched_stats), (850, 20, 1));
        assert_eq!((e.missed, e.miss_cause, e.consecutive_misses), (1, 1, 2));
        assert_eq!((e.cycle, e.header.seq), (7, 8));
        assert_eq!(e.thread_name(), "t");
        let v = m.record(3000, 3000, 4000, None);
        assert_eq!((v.missed, v.consecutive, v.escalate), (true, 3, false));
        let v = m.record(4000, 4000, 4800, None);
        assert!(!v.missed, "end == deadline is on time");
        assert_eq!(v.cause, miss_cause::NONE);
        let e = m.event(8, 4000, 4000, 4800, None, &v);
        assert_eq!((e.missed, e.miss_cause, e.sched_stats), (0, 0, 0));
        assert_eq!((m.cycles(), m.misses(), m.max_consecutive()), (5, 3, 3));
        assert_eq!(m.escalations(), 1);
        assert_eq!(m.lateness().max(), 100);
        assert_eq!(m.misses_by(miss_cause::UNKNOWN), 2);
        assert_eq!(m.miss_causes(), "unknown 2, execution 1");
    }

    #[test]
    fn a_miss_is_put_down_to_the_largest_share_of_its_time() {
        use miss_cause::{BLOCKED, EXECUTION, LATE_WAKEUP, RUN_QUEUE};
        const MS: u64 = 1_000_000;
        // (lateness, execution, CPU, run-queue wait, cause); budget 5 ms.
        let cases = [
            // Woke 7 ms late, ran 0.3 ms, never waited for a CPU: the timer was late.
            (7 * MS, MS * 3 / 10, MS * 3 / 10, 0, LATE_WAKEUP),
            // Woke 7 ms late, but 6.5 ms of it runnable on a run queue: the CPU was taken.
            (7 * MS, MS * 3 / 10, MS * 3 / 10, MS * 13 / 2, RUN_QUEUE),
            // On time, 6 ms of computing.
            (MS / 100, 6 * MS, 6 * MS, 0, EXECUTION),
            // On time, 6 ms in the body but 1 ms of CPU: it blocked.
            (MS / 100, 6 * MS, MS, 0, BLOCKED),
            // Shares: cpu 2, wait 1.5, late 3 − 1.5 = 1.5, blocked 6 − 2 − 1.5 − 1.5 = 1.
            (3 * MS, 3 * MS, 2 * MS, MS * 3 / 2, EXECUTION),
            // CPU time read across the cycle boundary can exceed the cycle: no underflow.
            (0, 1_000, 5_000, 5_000, EXECUTION),
        ];
        for (lateness, exec, cpu_ns, run_wait_ns, want) in cases {
            let sched = Some(CycleSched {
                cpu_ns,
                run_wait_ns,
            });
            assert_eq!(
                miss_cause_of(lateness, exec, sched),
                want,
                "{lateness} {exec} {cpu_ns} {run_wait_ns}"
            );
        }
        assert_eq!(miss_cause_of(7 * MS, 0, None), miss_cause::UNKNOWN);
    }

    #[test]
    fn stats_of_one_to_thousand_samples() {
        let samples: Vec<u64> = (1..=1000).map(|k| k * 1000).collect();
        let p = Stats::of_samples(&samples);
        assert_eq!(p.count, 1000);
        assert_eq!(p.min, 1000);
        // 3 significant digits: values are exact to within 0.1%.
        for (got, want) in [
            (p.p50, 500_000),
            (p.p90, 900_000),
            (p.p99, 990_000),
            (p.p999, 999_000),
            (p.max, 1_000_000),
        ] {
            assert!(
                (got as f64 - want as f64).abs() <= want as f64 * 1e-3,
                "{got} {want}"
            );
        }
        assert!((p.mean - 500_500.0).abs() <= 500.0, "{}", p.mean);
        assert_eq!(Stats::of_samples(&[]), Stats::default());
        assert_eq!(Stats::of_samples(&[0]).min, 1, "0 ns counts as 1 ns");
    }

    #[test]
    fn zero_period_is_refused() {
        let e = Executor::builder("z", Duration::ZERO)
            .spawn(|| |_: &Cycle| Control::Stop)
            .unwrap_err();
        assert!(matches!(e, ExecutorError::Period { .. }), "{e}");
    }

    #[test]
    fn a_setup_panic_is_reported() {
        let e = Executor::builder("p", Duration::from_millis(1))
            .spawn(|| -> fn(&Cycle) -> Control { panic!("no ports") })
            .unwrap_err();
        assert!(e.to_string().contains("no ports"), "{e}");
    }
}
