//! The periodic executor: a named thread that runs a closure at a fixed rate on absolute
//! deadlines, with a [`DeadlineMonitor`] that records wake-up lateness and execution time, counts
//! misses, emits [`DeadlineEvent`](shm_types::DeadlineEvent)s and applies a miss policy.
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
//!
//! # Files
//! | file | content |
//! |---|---|
//! | `config.rs` | [`ExecutorConfig`] (`[executor]`), its enums, range check |
//! | `sched.rs` | [`apply_sched`]: affinity, FIFO / nice, `mlockall`, CPU latency hold, backup waker start; [`SchedReport`] |
//! | `stats.rs` | [`latency_histogram`], [`Stats`], the end-of-run [`Summary`] |
//! | `monitor.rs` | [`DeadlineMonitor`], [`Verdict`], [`CycleSched`], [`miss_cause_of`] |
//! | `run.rs` | the loop: [`Executor`], [`ExecutorHandle`], [`StopFlag`], [`Cycle`], [`ExecutorError`], [`ExecutorState`] |

mod config;
mod monitor;
mod run;
mod sched;
mod stats;

pub use crate::os::{SchedStatReading, ThreadSchedStat};
pub use config::{EscalateAction, EventTrace, ExecutorConfig, MissPolicy, SchedPolicy};
pub use monitor::{CycleSched, DeadlineMonitor, Verdict, miss_cause_of};
pub use run::{
    Control, Cycle, Executor, ExecutorError, ExecutorHandle, ExecutorState, StopFlag, StopReason,
};
pub(crate) use sched::log_once;
pub use sched::{SchedReport, apply_sched};
pub use stats::{Stats, Summary, latency_histogram};
