//! The worker pool never blocks its caller: a fixed-rate caller keeps submitting and polling
//! while every worker is stuck in a long job, completes all its iterations, gets `Busy` instead
//! of waiting, and sees the results once the jobs finish.

use crossbeam::channel::bounded;
use runtime::executor::{Control, Cycle, Executor, ExecutorConfig, StopReason};
use runtime::pool::{PoolConfig, PoolPriority, WorkerPool, WorkerPriority};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant};

#[derive(Debug, Default)]
struct Counts {
    accepted: AtomicU64,
    busy: AtomicU64,
    results: AtomicU64,
    /// Jobs that left their wait loop (released, or the 60 s safety limit ran out).
    finished: AtomicU64,
}

#[test]
fn a_fixed_rate_caller_is_never_blocked_by_a_saturated_pool() {
    let cfg = PoolConfig {
        threads: 2,
        queue: 4,
        priority: PoolPriority::Idle,
        nice: 19,
        ..PoolConfig::default()
    };
    let pool = Arc::new(WorkerPool::<u64>::new("gbv-test", &cfg).unwrap());
    for p in pool.priorities() {
        assert!(
            matches!(p, WorkerPriority::Idle | WorkerPriority::Nice(19)),
            "worker did not lower its priority: {p:?}"
        );
    }
    // Every job runs until `release` is set (or a 60 s safety limit): the pool stays saturated
    // for the whole caller loop, so a caller that waited for the pool could never finish.
    let release = Arc::new(AtomicBool::new(false));
    let counts = Arc::new(Counts::default());
    const CYCLES: u64 = 50;

    let (p, r, c) = (pool.clone(), release.clone(), counts.clone());
    let handle = Executor::builder("lbv-caller", Duration::from_millis(2))
        .config(&ExecutorConfig::default())
        .max_cycles(CYCLES)
        .spawn(move || {
            move |cycle: &Cycle| {
                let (r, c2) = (r.clone(), c.clone());
                let job_id = cycle.index;
                let job = move || {
                    let t0 = Instant::now();
                    while !r.load(Ordering::Acquire) && t0.elapsed() < Duration::from_secs(60) {
                        std::hint::spin_loop();
                    }
                    c2.finished.fetch_add(1, Ordering::Release);
                    job_id
                };
                match p.try_submit(job) {
                    Ok(_) => c.accepted.fetch_add(1, Ordering::Relaxed),
                    Err(_busy) => c.busy.fetch_add(1, Ordering::Relaxed),
                };
                while p.try_recv().is_some() {
                    c.results.fetch_add(1, Ordering::Relaxed);
                }
                Control::Continue
            }
        })
        .unwrap();

    // Watchdog: the caller must finish its iterations while the jobs are still stuck.
    let (tx, rx) = bounded(1);
    std::thread::spawn(move || {
        let _ = tx.send(handle.wait());
    });
    let summary = rx
        .recv_timeout(Duration::from_secs(60))
        .expect("the caller loop was blocked by the pool")
        .unwrap();
    assert_eq!(summary.reason, StopReason::MaxCycles);
    assert_eq!(summary.monitor.cycles(), CYCLES);
    // The caller finished while no job had: the pool was saturated the whole time.
    assert_eq!(
        counts.finished.load(Ordering::Acquire),
        0,
        "a job ended before the caller loop did (60 s safety limit?)"
    );
    assert_eq!(counts.accepted.load(Ordering::Relaxed), 4, "queue limit");
    assert_eq!(counts.busy.load(Ordering::Relaxed), CYCLES - 4);
    assert_eq!(counts.results.load(Ordering::Relaxed), 0);
    assert_eq!(pool.outstanding(), 4);

    // Let the jobs finish: the four results arrive (ids = the submitting cycles 0..=3) and the
    // pool accepts work again.
    release.store(true, Ordering::Release);
    let mut got: Vec<u64> = (0..4)
        .map(|_| {
            let done = pool
                .recv_timeout(Duration::from_secs(60))
                .expect("result did not arrive");
            done.result.unwrap()
        })
        .collect();
    got.sort_unstable();
    assert_eq!(got, vec![0, 1, 2, 3]);
    assert_eq!(counts.finished.load(Ordering::Acquire), 4);
    assert_eq!(pool.outstanding(), 0);
    let id = pool.try_submit(|| 42).unwrap();
    let done = pool.recv_timeout(Duration::from_secs(60)).unwrap();
    assert_eq!((done.id, done.result.unwrap()), (id, 42));
}

#[test]
fn jobs_may_use_rayon_parallelism_inside_the_pool() {
    let pool = WorkerPool::<u64>::new(
        "par-test",
        &PoolConfig {
            threads: 2,
            ..PoolConfig::default()
        },
    )
    .unwrap();
    pool.try_submit(|| {
        use rayon::prelude::*;
        (1..=1000u64).into_par_iter().sum()
    })
    .unwrap();
    let done = pool.recv_timeout(Duration::from_secs(60)).unwrap();
    assert_eq!(done.result.unwrap(), 500_500);
    assert_eq!(pool.install(rayon::current_num_threads), 2);
}

/// The calling thread's `Cpus_allowed_list` from `/proc/thread-self/status` (e.g. "0-1").
fn cpus_allowed() -> String {
    std::fs::read_to_string("/proc/thread-self/status")
        .unwrap()
        .lines()
        .find_map(|l| l.strip_prefix("Cpus_allowed_list:"))
        .expect("Cpus_allowed_list in /proc/thread-self/status")
        .trim()
        .to_string()
}

/// The planner builds its pool on the LBV thread, which is pinned to one CPU: the workers must
/// not inherit that pin, or GBV evaluation would share one CPU with the LBV.
#[test]
fn workers_of_a_pool_built_on_a_pinned_thread_run_on_the_process_cpus() {
    let process = cpus_allowed();
    let (creator, worker) = std::thread::spawn(|| {
        let pin = ExecutorConfig {
            policy: runtime::executor::SchedPolicy::Other,
            nice: 0,
            mlockall: false,
            cpu_dma_latency_us: -1,
            cpus: vec![0],
            ..ExecutorConfig::default()
        };
        runtime::executor::apply_sched("pinned-creator", &pin);
        let pool = WorkerPool::<String>::new(
            "unpin",
            &PoolConfig {
                threads: 1,
                ..PoolConfig::default()
            },
        )
        .unwrap();
        pool.try_submit(cpus_allowed).unwrap();
        let done = pool.recv_timeout(Duration::from_secs(10)).expect("job ran");
        (cpus_allowed(), done.result.unwrap())
    })
    .join()
    .unwrap();
    assert_eq!(creator, "0");
    assert_eq!(worker, process);
}

/// The scheduling policy of the calling thread (field 41 of `/proc/thread-self/stat`).
fn policy() -> u32 {
    let stat = std::fs::read_to_string("/proc/thread-self/stat").unwrap();
    let (_, rest) = stat.rsplit_once(')').unwrap();
    // Fields from the 3rd on; policy is the 41st.
    rest.split_whitespace()
        .nth(41 - 3)
        .unwrap()
        .parse()
        .unwrap()
}

#[test]
fn by_default_workers_run_at_nice_10_under_sched_other() {
    let pool = WorkerPool::<u32>::new(
        "nice-test",
        &PoolConfig {
            threads: 1,
            ..PoolConfig::default()
        },
    )
    .unwrap();
    assert_eq!(pool.priorities(), &[WorkerPriority::Nice(10)]);
    pool.try_submit(policy).unwrap();
    let done = pool.recv_timeout(Duration::from_secs(60)).expect("job ran");
    assert_eq!(done.result.unwrap(), libc::SCHED_OTHER as u32);
}

#[test]
#[ignore = "needs CAP_SYS_NICE (root) for SCHED_DEADLINE"]
fn a_deadline_pool_runs_its_workers_under_their_reservation() {
    let pool = WorkerPool::<u32>::new(
        "dl-test",
        &PoolConfig {
            threads: 1,
            priority: PoolPriority::Deadline,
            deadline_runtime_us: 2_000,
            deadline_period_us: 10_000,
            ..PoolConfig::default()
        },
    )
    .unwrap();
    assert_eq!(
        pool.priorities(),
        &[WorkerPriority::Deadline {
            runtime_us: 2_000,
            period_us: 10_000
        }],
        "SCHED_DEADLINE was refused"
    );
    pool.try_submit(policy).unwrap();
    let done = pool.recv_timeout(Duration::from_secs(60)).expect("job ran");
    // SCHED_DEADLINE = 6.
    assert_eq!(done.result.unwrap(), 6);
}
