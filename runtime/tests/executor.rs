//! The periodic executor: no drift on the real clock, exact miss accounting on a stepped clock,
//! skip / hold policies, escalation, lockstep hosting, event tracing.
//!
//! Real-clock tests assert properties of the release grid and exact accounting, never a bound
//! on time (lateness figures are printed; `vpsom-rt-tests` measures them); hangs are guarded by
//! generous watchdogs that fail only a hung test.

use crossbeam::channel::{Receiver, bounded};
use runtime::clock::{Clock, MonotonicClock, StepMode, SteppedClock};
use runtime::executor::{
    Control, Cycle, EscalateAction, EventTrace, Executor, ExecutorConfig, ExecutorHandle,
    MissPolicy, SchedPolicy, StopReason, Summary,
};
use shm_types::{DeadlineEvent, miss_cause};
use std::time::Duration;

const MS: u64 = 1_000_000;

/// Join with a watchdog: a hung executor fails the test instead of hanging it.
fn join_within(handle: ExecutorHandle, secs: u64) -> Summary {
    let (tx, rx) = bounded(1);
    std::thread::spawn(move || {
        let _ = tx.send(handle.wait());
    });
    rx.recv_timeout(Duration::from_secs(secs))
        .expect("executor did not finish in time")
        .expect("executor failed")
}

fn drain(rx: &Receiver<DeadlineEvent>) -> Vec<DeadlineEvent> {
    rx.try_iter().collect()
}

/// Executor settings for stepped-clock tests: no privileges needed, everything traced.
fn stepped_config(policy: MissPolicy, escalate_after: u32) -> ExecutorConfig {
    ExecutorConfig {
        policy: SchedPolicy::Other,
        nice: 0,
        spin_margin_us: 0,
        miss_policy: policy,
        escalate_after,
        trace: EventTrace::All,
        ..ExecutorConfig::default()
    }
}

#[test]
fn real_clock_keeps_the_release_grid_over_200_cycles_at_2ms() {
    let period = 2 * MS;
    let (tx, rx) = bounded(512);
    let cfg = ExecutorConfig {
        trace: EventTrace::All,
        ..ExecutorConfig::default() // SCHED_FIFO if permitted, 200 µs spin margin
    };
    let handle = Executor::builder("grid-2ms", Duration::from_nanos(period))
        .config(&cfg)
        .events(tx)
        .max_cycles(200)
        .spawn(|| |_: &Cycle| Control::Continue)
        .unwrap();
    let sched = handle.sched().clone();
    assert!(
        sched.fifo.is_some() || !sched.refusals.is_empty(),
        "a refused FIFO request must be reported: {sched:?}"
    );
    let summary = join_within(handle, 60);
    assert_eq!(summary.reason, StopReason::MaxCycles);
    assert_eq!(summary.monitor.cycles(), 200);
    assert_eq!(summary.events_dropped, 0);
    let events = drain(&rx);
    assert_eq!(events.len(), 200);

    let release = |e: &DeadlineEvent| (e.header.stamp_ns as i64 - e.lateness_ns) as u64;
    let start = release(&events[0]);
    let mut skipped_before = 0;
    let mut previous_grid: Option<u64> = None;
    for (k, e) in events.iter().enumerate() {
        assert_eq!(e.cycle, k as u64);
        let r = release(e);
        // Absolute deadlines: every release is exactly on the grid start + g·period, and the
        // k-th release is start + (k + releases skipped so far)·period: no drift accumulates.
        assert_eq!((r - start) % period, 0, "cycle {k} released off the grid");
        let g = (r - start) / period;
        if let Some(p) = previous_grid {
            assert!(g > p, "grid must advance");
            skipped_before += g - p - 1;
        }
        assert_eq!(g, k as u64 + skipped_before);
        previous_grid = Some(g);
        // Never early: the k-th wake-up is at or after start + k·period.
        assert!(
            e.lateness_ns >= 0,
            "cycle {k} woke early: {}",
            e.lateness_ns
        );
        assert!(e.header.stamp_ns >= start + k as u64 * period);
    }
    assert_eq!(skipped_before, summary.skipped);
    // How late the wake-ups were is a measurement, not a property: it depends on the machine's
    // load (this VM sometimes wakes even a SCHED_FIFO thread several ms late; a late wake-up
    // drops the releases it overran instead of running them in a burst, so the grid index, not
    // the cycle count, tracks wall time). It is printed here and measured by `vpsom-rt-tests
    // wakeup`; the test checks only what holds on any machine.
    eprintln!("grid-2ms: {summary}");
}

#[test]
fn real_clock_reports_a_deliberately_slow_cycle_as_a_miss() {
    let (tx, rx) = bounded(64);
    let cfg = ExecutorConfig {
        trace: EventTrace::Misses,
        ..ExecutorConfig::default()
    };
    let handle = Executor::builder("slow-cycle", Duration::from_millis(2))
        .config(&cfg)
        .events(tx)
        .max_cycles(30)
        .spawn(|| {
            |c: &Cycle| {
                if c.index == 10 {
                    std::thread::sleep(Duration::from_millis(20));
                }
                Control::Continue
            }
        })
        .unwrap();
    let summary = join_within(handle, 60);
    let misses = drain(&rx);
    assert!(summary.monitor.misses() >= 1, "{summary}");
    assert_eq!(misses.len() as u64, summary.monitor.misses());
    let slow = misses
        .iter()
        .find(|e| e.cycle == 10)
        .expect("cycle 10 is traced as a miss");
    assert_eq!(slow.missed, 1);
    assert!(slow.exec_ns >= 20 * MS);
    assert_eq!(slow.thread_name(), "slow-cycle");
    // The body slept: its time was neither CPU nor run-queue wait, so the cause is blocking.
    // Where the kernel reports per-thread scheduler statistics the executor must use them;
    // where it does not, it must say the cause is unknown (both branches are checks).
    let schedstat = std::fs::read_to_string("/proc/thread-self/schedstat").is_ok();
    assert_eq!(slow.sched_stats == 1, schedstat, "{slow:?}");
    if schedstat {
        assert_eq!(slow.miss_cause, miss_cause::BLOCKED, "{slow:?}");
        assert!(slow.cpu_ns < slow.exec_ns, "{slow:?}");
        assert!(summary.monitor.misses_by(miss_cause::BLOCKED) >= 1);
    } else {
        assert_eq!(slow.miss_cause, miss_cause::UNKNOWN);
    }
    // Skip policy: at least the release after the miss was skipped.
    assert!(summary.skipped >= 1, "{summary}");
}

/// Body for stepped-clock tests: every cycle costs 1 ms of simulated time; listed cycles
/// cost `slow_ms` instead.
fn stepped_body(
    clock: SteppedClock,
    slow: &'static [u64],
    slow_ms: u64,
) -> impl FnMut(&Cycle) -> Control {
    move |c: &Cycle| {
        let cost = if slow.contains(&c.index) { slow_ms } else { 1 };
        clock.advance_by(cost * MS);
        Control::Continue
    }
}

#[test]
fn stepped_clock_gives_exact_miss_and_skip_counts() {
    let clock = SteppedClock::new(1_000 * MS, StepMode::Jump);
    let (tx, rx) = bounded(64);
    let body_clock = clock.clone();
    let handle = Executor::builder("stepped-skip", Duration::from_millis(10))
        .config(&stepped_config(MissPolicy::Skip, 0))
        .clock(clock.shared())
        .events(tx)
        .max_cycles(30)
        .spawn(move || stepped_body(body_clock, &[5, 12], 15))
        .unwrap();
    let s = join_within(handle, 30);
    assert_eq!(s.monitor.cycles(), 30);
    assert_eq!(s.monitor.misses(), 2);
    assert_eq!(s.monitor.max_consecutive(), 1);
    assert_eq!(s.skipped, 2, "one release skipped after each miss");
    let ev = drain(&rx);
    let missed: Vec<u64> = ev
        .iter()
        .filter(|e| e.missed == 1)
        .map(|e| e.cycle)
        .collect();
    assert_eq!(missed, vec![5, 12]);
    // Scheduler statistics mean nothing against a stepped clock: not measured, cause unknown.
    assert!(ev.iter().all(|e| e.sched_stats == 0));
    assert_eq!(s.monitor.misses_by(miss_cause::UNKNOWN), 2);
    // Exact timing on the stepped clock: no lateness, except none at all.
    assert!(ev.iter().all(|e| e.lateness_ns == 0));
    assert_eq!(ev[5].exec_ns, 15 * MS);
    // Cycle 6 runs at grid 7 (grid 6 skipped): 1000 ms + 70 ms.
    assert_eq!(ev[6].header.stamp_ns, 1_070 * MS);
    // Last cycle: 29 cycles after the first plus 2 skipped releases.
    assert_eq!(ev[29].header.stamp_ns, 1_000 * MS + 31 * 10 * MS);
    assert_eq!(s.lateness.max, 0);
    // Histograms keep 3 significant digits.
    assert!(
        s.exec.max.abs_diff(15 * MS) <= 15 * MS / 1000,
        "{}",
        s.exec.max
    );
}

#[test]
fn hold_policy_runs_the_late_cycle_once_and_flags_it() {
    let clock = SteppedClock::new(0, StepMode::Jump);
    let (tx, rx) = bounded(64);
    let (flag_tx, flag_rx) = bounded(64);
    let body_clock = clock.clone();
    let handle = Executor::builder("stepped-hold", Duration::from_millis(10))
        .config(&stepped_config(MissPolicy::Hold, 0))
        .clock(clock.shared())
        .events(tx)
        .max_cycles(10)
        .spawn(move || {
            let mut inner = stepped_body(body_clock, &[5], 35);
            move |c: &Cycle| {
                let _ = flag_tx.try_send((c.index, c.grid, c.previous_missed));
                inner(c)
            }
        })
        .unwrap();
    let s = join_within(handle, 30);
    assert_eq!(s.monitor.misses(), 1);
    // Cycle 5 released at 50 ms ran until 85 ms: releases 60 and 70 passed and are dropped,
    // release 80 runs at once (5 ms late), then the grid resumes at 90 ms.
    assert_eq!(s.skipped, 2);
    let ev = drain(&rx);
    assert_eq!(ev[6].lateness_ns, 5 * MS as i64);
    assert_eq!(ev[6].missed, 0);
    assert_eq!(ev[7].lateness_ns, 0);
    let flags: Vec<(u64, u64, bool)> = flag_rx.try_iter().collect();
    assert_eq!(flags[6], (6, 8, true));
    assert_eq!(flags[7], (7, 9, false));
}

#[test]
fn escalates_after_n_consecutive_misses_and_can_stop() {
    let clock = SteppedClock::new(0, StepMode::Jump);
    let cfg = ExecutorConfig {
        on_escalate: EscalateAction::Stop,
        ..stepped_config(MissPolicy::Skip, 3)
    };
    let body_clock = clock.clone();
    static SLOW: [u64; 20] = [
        10, 11, 12, 13, 14, 15, 16, 17, 18, 19, 20, 21, 22, 23, 24, 25, 26, 27, 28, 29,
    ];
    let handle = Executor::builder("escalate-stop", Duration::from_millis(10))
        .config(&cfg)
        .clock(clock.shared())
        .max_cycles(100)
        .spawn(move || stepped_body(body_clock, &SLOW, 25))
        .unwrap();
    let s = join_within(handle, 30);
    assert_eq!(s.reason, StopReason::Escalated);
    assert_eq!(
        s.monitor.cycles(),
        13,
        "stopped at the third consecutive miss"
    );
    assert_eq!(s.monitor.misses(), 3);
    assert_eq!(s.monitor.escalations(), 1);
}

#[test]
fn escalation_in_report_mode_is_latched_and_visible_to_the_body() {
    let clock = SteppedClock::new(0, StepMode::Jump);
    let (flag_tx, flag_rx) = bounded(64);
    let body_clock = clock.clone();
    let handle = Executor::builder("escalate-report", Duration::from_millis(10))
        .config(&stepped_config(MissPolicy::Skip, 2))
        .clock(clock.shared())
        .max_cycles(8)
        .spawn(move || {
            let mut inner = stepped_body(body_clock, &[2, 3, 5], 25);
            move |c: &Cycle| {
                let _ = flag_tx.try_send(c.escalated);
                inner(c)
            }
        })
        .unwrap();
    let s = join_within(handle, 30);
    assert_eq!(s.reason, StopReason::MaxCycles);
    assert_eq!(s.monitor.misses(), 3);
    assert_eq!(s.monitor.max_consecutive(), 2);
    assert_eq!(
        s.monitor.escalations(),
        1,
        "misses 2,3 escalate; 5 alone does not"
    );
    let flags: Vec<bool> = flag_rx.try_iter().collect();
    assert_eq!(
        flags,
        vec![false, false, false, false, true, true, true, true],
        "latched from the cycle after the escalation"
    );
}

#[test]
fn a_lockstep_host_steps_the_executor_on_a_waiting_clock() {
    let period = 10 * MS;
    let clock = SteppedClock::new(0, StepMode::Wait);
    let (tx, rx) = bounded(16);
    let handle = Executor::builder("lockstep", Duration::from_nanos(period))
        .config(&stepped_config(MissPolicy::Skip, 0))
        .clock(clock.shared())
        .start_at(100 * MS)
        .events(tx)
        .max_cycles(5)
        .spawn(|| |_: &Cycle| Control::Continue)
        .unwrap();
    for k in 0..5u64 {
        clock.advance_to(100 * MS + k * period);
        let watchdog = std::time::Instant::now();
        while handle.cycles() < k + 1 {
            assert!(
                watchdog.elapsed() < Duration::from_secs(20),
                "cycle {k} did not run"
            );
            std::thread::yield_now();
        }
    }
    let s = join_within(handle, 30);
    assert_eq!(s.monitor.cycles(), 5);
    let ev = drain(&rx);
    let wakes: Vec<u64> = ev.iter().map(|e| e.header.stamp_ns).collect();
    assert_eq!(
        wakes,
        vec![100 * MS, 110 * MS, 120 * MS, 130 * MS, 140 * MS]
    );
    assert!(ev.iter().all(|e| e.lateness_ns == 0 && e.missed == 0));
}

#[test]
fn body_stop_and_full_event_sink_are_reported() {
    let clock = SteppedClock::new(0, StepMode::Jump);
    let (tx, rx) = bounded(1);
    let handle = Executor::builder("stopper", Duration::from_millis(1))
        .config(&stepped_config(MissPolicy::Skip, 0))
        .clock(clock.shared())
        .events(tx)
        .spawn(|| {
            |c: &Cycle| {
                if c.index == 9 {
                    Control::Stop
                } else {
                    Control::Continue
                }
            }
        })
        .unwrap();
    let s = join_within(handle, 30);
    assert_eq!(s.reason, StopReason::Body);
    assert_eq!(s.monitor.cycles(), 10);
    assert_eq!(
        s.events_dropped, 9,
        "sink holds one event, never blocks the loop"
    );
    assert_eq!(drain(&rx).len(), 1);
}

#[test]
fn stop_request_ends_a_real_clock_executor() {
    let handle = Executor::builder("stop-me", Duration::from_millis(1))
        .config(&ExecutorConfig {
            policy: SchedPolicy::Other,
            nice: 0,
            ..ExecutorConfig::default()
        })
        .spawn(|| |_: &Cycle| Control::Continue)
        .unwrap();
    let flag = handle.stop_flag();
    while handle.cycles() < 3 {
        std::thread::sleep(Duration::from_millis(1));
    }
    flag.stop();
    let s = join_within(handle, 30);
    assert_eq!(s.reason, StopReason::Requested);
    assert!(s.monitor.cycles() >= 3);
}

#[test]
fn cpu_latency_limit_is_held_while_the_process_runs_or_the_refusal_is_reported() {
    let cfg = ExecutorConfig {
        policy: SchedPolicy::Other,
        nice: 0,
        cpu_dma_latency_us: 0,
        ..ExecutorConfig::default()
    };
    let report = runtime::executor::apply_sched("latency-test", &cfg);
    match report.cpu_dma_latency_us {
        Some(us) => {
            assert_eq!(us, 0);
            // The kernel reports the effective (lowest requested) limit.
            let bytes = std::fs::read("/dev/cpu_dma_latency").unwrap();
            let held = i32::from_ne_bytes(bytes[..4].try_into().unwrap());
            assert_eq!(held, 0, "the limit is not in force");
            assert!(report.to_string().contains("cpu latency 0 µs"), "{report}");
        }
        None => assert!(
            report
                .refusals
                .iter()
                .any(|r| r.contains("/dev/cpu_dma_latency")),
            "neither held nor refused: {report:?}"
        ),
    }
    let off = ExecutorConfig {
        cpu_dma_latency_us: -1,
        ..cfg
    };
    assert_eq!(
        runtime::executor::apply_sched("latency-off", &off).cpu_dma_latency_us,
        None
    );
}

/// A thread on CPU 0 that outranks the executor holds that CPU across two releases: the
/// executor's own wake-up would wait for it (~28 ms), but its backup waker on CPU 1 moves it
/// there and wakes it `backup_delay_us` after each release. Needs SCHED_FIFO and two CPUs: not
/// in the default run (a user without RT privileges could not pass it); `.ci/run` runs it with
/// `--ignored`, where both hold, and there a missing precondition fails the test.
#[test]
#[ignore = "needs SCHED_FIFO (root or rtprio) and 2 CPUs; run by .ci/run with --ignored"]
fn backup_waker_wakes_the_thread_on_its_cpu_when_the_home_cpu_is_held() {
    let period = 20 * MS;
    let start = MonotonicClock::new().now_ns() + 200 * MS;
    let (tx, rx) = bounded(64);
    let cfg = ExecutorConfig {
        cpus: vec![0],
        backup_cpu: 1,
        backup_delay_us: 1000,
        spin_margin_us: 0,
        budget_fraction: 0.25,
        trace: EventTrace::All,
        ..ExecutorConfig::default()
    };
    let handle = Executor::builder("backed-up", Duration::from_nanos(period))
        .config(&cfg)
        .events(tx)
        .start_at(start)
        .max_cycles(20)
        .spawn(|| |_: &Cycle| Control::Continue)
        .unwrap();
    let sched = handle.sched().clone();
    assert!(
        sched.fifo.is_some() && sched.backup_cpu.is_some(),
        "precondition: this test needs SCHED_FIFO and a second CPU ({sched})"
    );
    assert!(
        sched.to_string().contains("backup waker on CPU 1"),
        "{sched}"
    );
    // The hog: SCHED_FIFO 90 on CPU 0 from 2 ms before release 10 to 28 ms after it.
    let hog = std::thread::spawn(move || {
        let hog_cfg = ExecutorConfig {
            priority: 90,
            cpus: vec![0],
            mlockall: false,
            cpu_dma_latency_us: -1,
            ..ExecutorConfig::default()
        };
        let got = runtime::executor::apply_sched("hog", &hog_cfg);
        assert_eq!(got.fifo, Some(90), "{got}");
        let clock = MonotonicClock::new();
        let from = start + 10 * period - 2 * MS;
        clock.sleep_until(from);
        while clock.now_ns() < from + 30 * MS {
            std::hint::spin_loop();
        }
    });
    let s = join_within(handle, 60);
    hog.join().unwrap();
    let ev = drain(&rx);
    for k in [10, 11] {
        let e = ev.iter().find(|e| e.cycle == k).expect("cycle traced");
        // The wake-up came from the backup waker (the home CPU was held by the hog). How late
        // it was is printed, not asserted: it depends on the machine's load.
        assert_eq!(e.backup_wake, 1, "cycle {k}: {e:?}");
        eprintln!(
            "cycle {k}: woken by the backup waker {:.3} ms after its release",
            e.lateness_ns as f64 / 1e6
        );
    }
    assert!(s.backup_wakes >= 2, "{s}");
    assert!(s.to_string().contains("backup wake-ups"), "{s}");
}

#[test]
fn backup_cpu_settings_are_checked() {
    let check = |cfg: ExecutorConfig| {
        cfg.validate(&runtime::config::Checker::new("test.toml"))
            .map_err(|e| e.to_string())
    };
    let e = check(ExecutorConfig {
        backup_cpu: 1,
        ..ExecutorConfig::default()
    })
    .unwrap_err();
    assert!(
        e.contains("executor.backup_cpu") && e.contains("needs executor.cpus"),
        "{e}"
    );
    let e = check(ExecutorConfig {
        cpus: vec![0, 1],
        backup_cpu: 1,
        ..ExecutorConfig::default()
    })
    .unwrap_err();
    assert!(e.contains("without the backup CPU"), "{e}");
    assert!(
        check(ExecutorConfig {
            cpus: vec![0],
            backup_cpu: 1,
            ..ExecutorConfig::default()
        })
        .is_ok()
    );
    let e = check(ExecutorConfig {
        backup_delay_us: 0,
        ..ExecutorConfig::default()
    })
    .unwrap_err();
    assert!(e.contains("executor.backup_delay_us"), "{e}");
}
