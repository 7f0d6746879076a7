//! The backup waker of a periodic executor thread.
//!
//! A virtual machine can stall one virtual CPU for milliseconds while the other runs (on the
//! 2-vCPU VM this was built on, cyclictest under load saw 5–150 ms stalls on each vCPU, never on
//! both at once). A thread whose timer is due on the stalled CPU then wakes late, however high
//! its priority: its timer interrupt is not delivered until that CPU runs again. The backup
//! waker is a second thread, pinned to another CPU at the executor's priority, that checks
//! `delay` after each release whether the executor thread has woken for it. If not, it moves the
//! executor thread onto its own CPU and wakes it there; the executor thread goes back to its
//! home CPUs when it next goes to sleep (after announcing that release, so that if its home CPU
//! is still held, the waker sees it waiting and moves it again). The same rescue works when the
//! home CPU is held by a higher-priority thread or non-preemptible kernel work.
//!
//! Protocol (all on one atomic, `target`): before sleeping, the executor thread stores the
//! release it sleeps for, and after waking takes it back with a compare-exchange (release → 0).
//! The waker claims a release with a compare-exchange (release → `RESCUING`), moves and wakes the
//! thread, then stores `RESCUED`. Exactly one of the two exchanges succeeds, so a thread that woke
//! by itself is never moved, and a moved thread always knows it was (and waits the few µs the
//! waker needs to finish).

use crate::os;
use crossbeam::channel::{Receiver, Sender, bounded};
use std::sync::Arc;
use std::sync::atomic::{AtomicU32, AtomicU64, Ordering};
use std::thread::JoinHandle;

/// `target` while the waker moves the thread.
const RESCUING: u64 = u64::MAX;
/// `target` once the waker has moved and woken the thread.
const RESCUED: u64 = u64::MAX - 1;

#[derive(Debug, Default)]
struct Line {
    /// The release (clock ns) the executor thread sleeps for; 0 while it is awake.
    target: AtomicU64,
    /// Futex the executor thread sleeps on; 1 = woken by the waker.
    word: AtomicU32,
    /// Futex the waker sleeps on; 1 = stop.
    stop: AtomicU32,
    /// Wake-ups done by the waker.
    rescues: AtomicU64,
}

/// The grid the waker follows: release k at `start_ns + k·period_ns`, checked `delay_ns` after.
#[derive(Debug, Clone, Copy)]
struct Grid {
    start_ns: u64,
    period_ns: u64,
    delay_ns: u64,
}

/// A started backup waker (see the module docs); stopped and joined on drop.
#[derive(Debug)]
pub(crate) struct BackupWaker {
    line: Arc<Line>,
    home: Vec<usize>,
    /// The waker moved the calling thread off its home CPUs.
    away: std::cell::Cell<bool>,
    begin: Option<Sender<Grid>>,
    thread: Option<JoinHandle<()>>,
}

impl BackupWaker {
    /// Start the waker for the calling thread, whose home CPUs are `home`: a thread pinned to
    /// `cpu`, at `SCHED_FIFO fifo` if given, idle until [`BackupWaker::begin`]. `Err` says why it
    /// could not be set up (the caller then runs without it).
    pub(crate) fn start(
        name: &str,
        cpu: usize,
        home: &[usize],
        fifo: Option<i32>,
    ) -> Result<Self, String> {
        let line = Arc::new(Line::default());
        let tid = os::gettid();
        let (ready_tx, ready_rx) = bounded::<Result<(), String>>(1);
        let (begin_tx, begin_rx) = bounded::<Grid>(1);
        let l = Arc::clone(&line);
        let thread = std::thread::Builder::new()
            .name(format!("{name}-backup"))
            .spawn(move || {
                let setup = os::set_affinity(&[cpu])
                    .map_err(|e| format!("pinning it to CPU {cpu} refused ({e})"))
                    .and_then(|()| match fifo {
                        Some(p) => os::set_fifo(p)
                            .map_err(|e| format!("SCHED_FIFO {p} refused for it ({e})")),
                        None => Ok(()),
                    });
                let ok = setup.is_ok();
                let _ = ready_tx.send(setup);
                if ok {
                    watch(&l, tid, cpu, &begin_rx);
                }
            })
            .map_err(|e| format!("cannot spawn it ({e})"))?;
        match ready_rx.recv() {
            Ok(Ok(())) => Ok(Self {
                line,
                home: home.to_vec(),
                away: std::cell::Cell::new(false),
                begin: Some(begin_tx),
                thread: Some(thread),
            }),
            Ok(Err(why)) => {
                let _ = thread.join();
                Err(why)
            }
            Err(_) => Err("it ended during setup".into()),
        }
    }

    /// Start watching the release grid `start_ns + k·period_ns`, `delay_ns` after each release.
    pub(crate) fn begin(&mut self, start_ns: u64, period_ns: u64, delay_ns: u64) {
        if let Some(tx) = self.begin.take() {
            let _ = tx.send(Grid {
                start_ns,
                period_ns,
                delay_ns,
            });
        }
    }

    /// Sleep until `release − margin_ns` on the real clock `now`, then spin to `release`,
    /// unless the waker wakes the thread first. `true` if it did (the thread then runs on the
    /// waker's CPU until its next sleep).
    ///
    /// A thread the waker moved goes home only once it has announced its next release: its home
    /// CPU may still be held, and going home there would make it wait, unseen by the waker.
    pub(crate) fn sleep_until(&self, now: impl Fn() -> u64, release: u64, margin_ns: u64) -> bool {
        let l = &self.line;
        l.word.store(0, Ordering::SeqCst);
        l.target.store(release, Ordering::SeqCst);
        if self.away.replace(false) {
            let _ = os::set_affinity(&self.home);
        }
        let wake_at = release.saturating_sub(margin_ns);
        while now() < wake_at && l.word.load(Ordering::Acquire) == 0 {
            os::futex_wait_until(&l.word, 0, wake_at);
        }
        match l
            .target
            .compare_exchange(release, 0, Ordering::AcqRel, Ordering::Acquire)
        {
            Ok(_) => {
                while now() < release {
                    std::hint::spin_loop();
                }
                false
            }
            Err(_) => {
                // Claimed by the waker: wait until it has moved and woken this thread. Yield,
                // never spin: moving this thread can block the waker (the kernel waits for the
                // migration), this thread can then land on the waker's CPU and run there, and
                // a SCHED_FIFO thread spinning at the waker's priority would never let the
                // waker run again to finish (a livelock seen in `vpsom run`: LBV cycles stop,
                // the `lbv-backup` thread runnable on the same CPU with no CPU time).
                while l.target.load(Ordering::Acquire) == RESCUING {
                    std::thread::yield_now();
                }
                l.target.store(0, Ordering::Release);
                self.away.set(true);
                true
            }
        }
    }

    /// Wake-ups the waker has done.
    pub(crate) fn rescues(&self) -> u64 {
        self.line.rescues.load(Ordering::Relaxed)
    }
}

impl Drop for BackupWaker {
    fn drop(&mut self) {
        self.begin.take();
        self.line.stop.store(1, Ordering::Release);
        os::futex_wake(&self.line.stop);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// The waker's loop: for each release r of the grid, at r + delay, claim r if the thread `tid`
/// still sleeps for it, move it to `cpu` and wake it.
fn watch(l: &Line, tid: libc::pid_t, cpu: usize, begin: &Receiver<Grid>) {
    let Ok(g) = begin.recv() else {
        return; // dropped before it began
    };
    let next_after = |t: u64| {
        let since = t.saturating_sub(g.delay_ns).saturating_sub(g.start_ns);
        since / g.period_ns + 1
    };
    let mut k = if os::monotonic_ns() < g.start_ns + g.delay_ns {
        0
    } else {
        next_after(os::monotonic_ns())
    };
    loop {
        let release = g.start_ns + k * g.period_ns;
        let at = release + g.delay_ns;
        while os::monotonic_ns() < at && l.stop.load(Ordering::Acquire) == 0 {
            os::futex_wait_until(&l.stop, 0, at);
        }
        if l.stop.load(Ordering::Acquire) != 0 {
            return;
        }
        if l.target
            .compare_exchange(release, RESCUING, Ordering::AcqRel, Ordering::Acquire)
            .is_ok()
        {
            let _ = os::set_thread_affinity(tid, &[cpu]);
            l.word.store(1, Ordering::Release);
            os::futex_wake(&l.word);
            l.rescues.fetch_add(1, Ordering::Relaxed);
            l.target.store(RESCUED, Ordering::Release);
        }
        k = (k + 1).max(next_after(os::monotonic_ns()));
    }
}
