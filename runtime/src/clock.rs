//! Clocks: the real monotonic clock and a stepped clock for lockstep hosting.
//!
//! Times are nanoseconds on one monotonic axis. Node logic never reads a clock; hosts pass the
//! time in. The periodic executor takes an `Arc<dyn Clock>` so the same executor runs on the real
//! clock (deployment) and on a [`SteppedClock`] (lockstep tests).

use std::fmt::Debug;
use std::sync::{Arc, Condvar, Mutex, MutexGuard};

/// A source of monotonic time that can also put the calling thread to sleep.
pub trait Clock: Send + Sync + Debug {
    /// Now, nanoseconds.
    fn now_ns(&self) -> u64;

    /// Block until the clock has reached `t_ns` (returns at once if it already has).
    fn sleep_until(&self, t_ns: u64);

    /// Like [`Clock::sleep_until`], but a real clock sleeps only until `spin_margin_ns` before
    /// `t_ns` and busy-waits the rest (a VM wakes an idle vCPU late). Clocks that are not real
    /// time ignore the margin (the default).
    fn sleep_until_spin(&self, t_ns: u64, spin_margin_ns: u64) {
        let _ = spin_margin_ns;
        self.sleep_until(t_ns);
    }

    /// `true` if time passes by itself (wall time); `false` for a stepped clock.
    fn is_real_time(&self) -> bool;
}

/// `CLOCK_MONOTONIC`, with absolute-deadline sleeps (`clock_nanosleep(TIMER_ABSTIME)`).
#[derive(Debug, Clone, Copy, Default)]
pub struct MonotonicClock;

impl MonotonicClock {
    /// The real clock.
    pub fn new() -> Self {
        Self
    }

    /// The real clock as a shareable trait object.
    pub fn shared() -> Arc<dyn Clock> {
        Arc::new(Self)
    }
}

impl Clock for MonotonicClock {
    fn now_ns(&self) -> u64 {
        crate::os::monotonic_ns()
    }

    fn sleep_until(&self, t_ns: u64) {
        // clock_nanosleep only fails for invalid arguments (impossible here); if it ever did,
        // fall back to spinning so the deadline is still honoured.
        if crate::os::sleep_until_ns(t_ns).is_err() {
            while self.now_ns() < t_ns {
                std::hint::spin_loop();
            }
        }
    }

    fn sleep_until_spin(&self, t_ns: u64, spin_margin_ns: u64) {
        if spin_margin_ns > 0 {
            let wake = t_ns.saturating_sub(spin_margin_ns);
            if self.now_ns() < wake {
                self.sleep_until(wake);
            }
            while self.now_ns() < t_ns {
                std::hint::spin_loop();
            }
        } else {
            self.sleep_until(t_ns);
        }
    }

    fn is_real_time(&self) -> bool {
        true
    }
}

/// How a [`SteppedClock`] treats `sleep_until`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StepMode {
    /// Pure lockstep: `sleep_until(t)` jumps the clock forward to `t` (if it is behind) and
    /// returns at once, so a periodic loop runs as fast as the CPU allows on simulated time.
    Jump,
    /// Hosted: `sleep_until(t)` blocks until another thread advances the clock to `t` or beyond.
    Wait,
}

#[derive(Debug)]
struct Stepped {
    now: Mutex<u64>,
    moved: Condvar,
    mode: StepMode,
}

/// A simulated clock shared between a lockstep host and the code it drives. Cloning shares it.
#[derive(Debug, Clone)]
pub struct SteppedClock {
    inner: Arc<Stepped>,
}

impl SteppedClock {
    /// A clock at `start_ns` in the given mode.
    pub fn new(start_ns: u64, mode: StepMode) -> Self {
        Self {
            inner: Arc::new(Stepped {
                now: Mutex::new(start_ns),
                moved: Condvar::new(),
                mode,
            }),
        }
    }

    /// The mode.
    pub fn mode(&self) -> StepMode {
        self.inner.mode
    }

    /// Move the clock forward to `t_ns` (never backwards) and wake sleepers that are due.
    pub fn advance_to(&self, t_ns: u64) {
        let mut now = self.lock();
        if t_ns > *now {
            *now = t_ns;
            self.inner.moved.notify_all();
        }
    }

    /// Move the clock forward by `dt_ns`.
    pub fn advance_by(&self, dt_ns: u64) {
        let mut now = self.lock();
        *now = now.saturating_add(dt_ns);
        self.inner.moved.notify_all();
    }

    /// This clock as a shareable trait object (sharing the same time).
    pub fn shared(&self) -> Arc<dyn Clock> {
        Arc::new(self.clone())
    }

    fn lock(&self) -> MutexGuard<'_, u64> {
        // A panic while holding this lock cannot leave the u64 inconsistent; keep going.
        self.inner
            .now
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner())
    }
}

impl Clock for SteppedClock {
    fn now_ns(&self) -> u64 {
        *self.lock()
    }

    fn sleep_until(&self, t_ns: u64) {
        let mut now = self.lock();
        match self.inner.mode {
            StepMode::Jump => {
                if t_ns > *now {
                    *now = t_ns;
                    self.inner.moved.notify_all();
                }
            }
            StepMode::Wait => {
                while *now < t_ns {
                    now = self
                        .inner
                        .moved
                        .wait(now)
                        .unwrap_or_else(|poisoned| poisoned.into_inner());
                }
            }
        }
    }

    fn is_real_time(&self) -> bool {
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    #[test]
    fn monotonic_spin_sleep_reaches_deadline() {
        let c = MonotonicClock::new();
        let t0 = c.now_ns();
        c.sleep_until_spin(t0 + 2_000_000, 500_000);
        assert!(c.now_ns() >= t0 + 2_000_000);
        c.sleep_until_spin(t0 + 3_000_000, 0);
        assert!(c.now_ns() >= t0 + 3_000_000);
        assert!(c.is_real_time());
    }

    #[test]
    fn jump_mode_moves_time_forward_only() {
        let c = SteppedClock::new(100, StepMode::Jump);
        c.sleep_until(500);
        assert_eq!(c.now_ns(), 500);
        c.sleep_until(200);
        assert_eq!(c.now_ns(), 500);
        c.advance_to(400);
        assert_eq!(c.now_ns(), 500);
        c.advance_by(50);
        assert_eq!(c.now_ns(), 550);
        assert!(!c.is_real_time());
    }

    #[test]
    fn wait_mode_blocks_until_stepped_past() {
        let c = SteppedClock::new(0, StepMode::Wait);
        let sleeper = {
            let c = c.clone();
            std::thread::spawn(move || {
                c.sleep_until(1_000);
                c.now_ns()
            })
        };
        std::thread::sleep(Duration::from_millis(20));
        c.advance_to(500);
        std::thread::sleep(Duration::from_millis(20));
        assert!(
            !sleeper.is_finished(),
            "woke before the clock reached the deadline"
        );
        c.advance_to(1_200);
        assert_eq!(sleeper.join().unwrap(), 1_200);
    }
}
