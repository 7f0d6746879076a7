//! The periodic loop: [`Executor`] (builder and thread), [`ExecutorHandle`] (the running
//! executor), [`StopFlag`], and what the loop reports ([`Cycle`], [`Control`], [`StopReason`],
//! [`ExecutorState`], [`ExecutorError`]). See the module docs of `executor` for the timeline.

use super::config::{EscalateAction, EventTrace, ExecutorConfig, MissPolicy};
use super::monitor::{CycleSched, DeadlineMonitor};
use super::sched::{SchedReport, apply_sched, start_backup};
use super::stats::{HIST_MAX_NS, Stats, Summary};
use crate::clock::Clock;
use crate::os::ThreadSchedStat;
use crate::waker::BackupWaker;
use crossbeam::channel::Sender;
use shm_types::DeadlineEvent;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU8, AtomicU64, Ordering};
use std::thread::JoinHandle;
use std::time::Duration;

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
