//! The deadline monitor: [`DeadlineMonitor`] records each cycle's wake-up lateness and execution
//! time, counts misses (with their cause, [`miss_cause_of`]) and escalations, and builds the
//! [`DeadlineEvent`] trace records; [`CycleSched`] is a cycle's share of the thread's scheduler
//! statistics.

use super::stats::latency_histogram;
use crate::os::SchedStatReading;
use hdrhistogram::Histogram;
use shm_types::{DeadlineEvent, Header, miss_cause};

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
}
