//! The node-hosting abstraction. A [`NodeHost`] is one node's ports and logic: what it does in
//! one step. [`drive`] owns everything around the step, the same for every node: the stop flag
//! (SIGINT/SIGTERM), the thread and its scheduling, the pace ([`Pace`]: fixed rate on a
//! deadline-monitored executor, wake on data, or polling), health reporting after each step,
//! the executor's timing summary, and what an error does.
//!
//! Lifecycle of a host (the hooks other than `step` default to nothing):
//! ```text
//! make()  → start()  → { step() → health() → heartbeat }*  → finish()
//! (on the stepping thread)          (until Done, stop, or an error: then no finish)
//! ```
//! The heartbeat ([`NodeHost::heartbeat`]): after each step the driver publishes the node's
//! `NodeHealth` (with [`NodeHost::inputs`]) once per period, from the stepping thread, so a
//! node stuck inside a step falls silent and the launcher restarts it.
//! On an executor thread ([`Pace::Periodic`]) the driver adds nothing to a cycle but the two
//! calls: no allocation, no lock (the host is built on that thread, so ports need not be `Send`).

use super::health::Heartbeat;
use runtime::clock::{Clock, MonotonicClock};
use runtime::executor::{Control, Executor, ExecutorConfig, ExecutorError, apply_sched};
use runtime::ports::PortContext;
use runtime::ports::{
    ConnectError, ContextError, LoanError, PublisherError, ReceiveError, SendError, Stamp,
    SubscriberError, WaitError,
};
use shm_types::{DeadlineEvent, NodeHealth};
use std::error::Error;
use std::fmt;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

/// Why a node host failed.
#[derive(Debug, thiserror::Error)]
pub enum HostError {
    /// The SIGINT/SIGTERM handler could not be installed.
    #[error("installing signal handler")]
    Signal(#[source] std::io::Error),
    /// The node's port context (iceoryx2 node) could not be created.
    #[error(transparent)]
    Context(#[from] ContextError),
    /// A publisher (and its event notifier) could not be created.
    #[error(transparent)]
    Publisher(#[from] PublisherError),
    /// A subscriber (and its event listener) could not be created.
    #[error(transparent)]
    Subscriber(#[from] SubscriberError),
    /// A sample could not be loaned.
    #[error(transparent)]
    Loan(#[from] LoanError),
    /// A sample could not be sent.
    #[error(transparent)]
    Send(#[from] SendError),
    /// A sample could not be received.
    #[error(transparent)]
    Receive(#[from] ReceiveError),
    /// Waiting for data failed.
    #[error(transparent)]
    Wait(#[from] WaitError),
    /// Connecting to a topic's other ports failed.
    #[error(transparent)]
    Connect(#[from] ConnectError),
    /// The executor could not start, or its thread panicked.
    #[error(transparent)]
    Executor(#[from] ExecutorError),
    /// The scene could not be loaded.
    #[error(transparent)]
    Scene(#[from] crate::sim::SceneError),
    /// The simulator could not be built.
    #[error(transparent)]
    Sim(#[from] crate::sim::SimError),
    /// A configuration section was refused (e.g. the mapper's).
    #[error(transparent)]
    Config(#[from] settings::ConfigError),
    /// The worker pool could not be built.
    #[error(transparent)]
    Pool(#[from] runtime::pool::PoolError),
    /// The recorder failed.
    #[error(transparent)]
    Recorder(#[from] runtime::recorder::RecorderError),
    /// A file operation failed.
    #[error(transparent)]
    Io(#[from] std::io::Error),
    /// A planning job panicked on the worker pool.
    #[error("planning job panicked: {0}")]
    JobPanicked(String),
    /// The worker pool refused a GBV load job although it had a free slot.
    #[error("worker pool refused a load job although it had room")]
    LoadRefused,
    /// The worker pool refused a planning job.
    #[error("worker pool refused a planning job with {outstanding} of {capacity} slots taken")]
    JobRefused {
        /// Jobs in the pool.
        outstanding: usize,
        /// Its limit.
        capacity: usize,
    },
    /// The planner's thread ended although the session did not (and no stop was asked for).
    #[error("planner thread stopped before the session ended")]
    EndedEarly,
}

/// What one step did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Flow {
    /// It worked; step again (at the next release, or at once).
    Busy,
    /// Nothing to do (no input yet): a polling host sleeps before the next step.
    Idle,
    /// The node is done (session over, or stopped while waiting): no more steps.
    Done,
}

/// One node's hosting: its ports and logic, stepped by [`drive`].
pub trait NodeHost {
    /// Once, on the stepping thread, before the first step (e.g. connect to the inputs).
    fn start(&mut self) {}

    /// One step: take the newest inputs, compute, publish. `stop` is set by SIGINT/SIGTERM (a
    /// host that blocks waiting for input checks it).
    fn step(&mut self, stop: &AtomicBool) -> Result<Flow, HostError>;

    /// After every successful step: report health (e.g. forward deadline events).
    fn health(&mut self) -> Result<(), HostError> {
        Ok(())
    }

    /// The node's heartbeat: the port context to publish `NodeHealth` with, and the period;
    /// `None` = no heartbeat.
    fn heartbeat(&self) -> Option<(&PortContext, Duration)> {
        None
    }

    /// List every input subscriber into the node's health report
    /// ([`report_input`](super::health::report_input) per subscriber).
    fn inputs(&self, _report: &mut NodeHealth) {}

    /// After the last step (not after an error): flush and report.
    fn finish(self) -> Result<(), HostError>
    where
        Self: Sized,
    {
        Ok(())
    }
}

/// How a node is paced, and on which thread.
#[derive(Debug)]
pub enum Pace {
    /// A deadline-monitored executor thread released at a fixed period; the node's thread
    /// returns once it ends (or a stop signal ends it), printing the executor's summary.
    Periodic(Periodic),
    /// The calling thread, stepping again at once: the step waits for its own input (wake on
    /// data). `sched`: scheduling applied to the calling thread first (and printed).
    OnData {
        /// Scheduling of the calling thread, if any.
        sched: Option<ExecutorConfig>,
    },
    /// The calling thread; after a step that found nothing ([`Flow::Idle`]), sleep `idle`.
    Poll {
        /// Sleep after an idle step.
        idle: Duration,
    },
}

/// A periodic executor thread.
#[derive(Debug)]
pub struct Periodic {
    /// Thread (and executor) name.
    pub thread: &'static str,
    /// Release period, wall time.
    pub period: Duration,
    /// Scheduling, budget, miss policy.
    pub config: ExecutorConfig,
    /// Where the executor sends its deadline events, if anywhere.
    pub events: Option<crossbeam::channel::Sender<DeadlineEvent>>,
}

/// How a driven node ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Ended {
    /// The host said [`Flow::Done`].
    pub finished: bool,
    /// A stop signal arrived.
    pub interrupted: bool,
}

/// A flag set by SIGINT/SIGTERM.
pub fn stop_on_signals() -> Result<Arc<AtomicBool>, HostError> {
    let flag = Arc::new(AtomicBool::new(false));
    for sig in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
        signal_hook::flag::register(sig, Arc::clone(&flag)).map_err(HostError::Signal)?;
    }
    Ok(flag)
}

/// The wall period of a rate given in simulated time.
pub fn wall_period(hz: f64, time_scale: f64) -> Duration {
    Duration::from_secs_f64(1.0 / (hz * time_scale))
}

/// A message stamp: the clock's time now and the simulated time `sim_ns`.
pub fn stamp(clock: &MonotonicClock, sim_ns: u64) -> Stamp {
    Stamp {
        source_ns: clock.now_ns(),
        sim_ns,
    }
}

/// An error and its sources, `outer: inner: …` (as `anyhow` prints with `{:#}`).
#[derive(Debug, Clone, Copy)]
pub struct Chain<'a>(pub &'a (dyn Error + 'static));

impl fmt::Display for Chain<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.0)?;
        let mut source = self.0.source();
        while let Some(s) = source {
            write!(f, ": {s}")?;
            source = s.source();
        }
        Ok(())
    }
}

/// Host the node `name` (the prefix of its messages): build it with `make` on the stepping
/// thread, then step it at `pace` until it is done, `stop` is set, or it fails.
///
/// On the calling thread an error of `make` or a step is returned. On an executor thread it is
/// printed (`name: error`) and ends the thread; the node then returns normally, and its caller
/// tells from [`Ended`] whether the node finished.
pub fn drive<H, M>(
    name: &'static str,
    stop: &Arc<AtomicBool>,
    pace: Pace,
    make: M,
) -> Result<Ended, HostError>
where
    H: NodeHost + 'static,
    M: FnOnce() -> Result<H, HostError> + Send + 'static,
{
    match pace {
        Pace::Periodic(p) => periodic(name, stop, p, make),
        Pace::OnData { sched } => {
            if let Some(cfg) = sched {
                let report = apply_sched(name, &cfg);
                eprintln!("{name}: {report}");
            }
            on_this_thread(name, stop, None, make)
        }
        Pace::Poll { idle } => on_this_thread(name, stop, Some(idle), make),
    }
}

/// `step`, `health`, then the heartbeat.
fn step_once<H: NodeHost>(
    name: &str,
    host: &mut H,
    beat: Option<&mut Heartbeat>,
    stop: &AtomicBool,
) -> Result<Flow, HostError> {
    let flow = host.step(stop)?;
    host.health()?;
    if let Some(b) = beat {
        b.tick(name, host)?;
    }
    Ok(flow)
}

fn on_this_thread<H, M>(
    name: &str,
    stop: &AtomicBool,
    idle: Option<Duration>,
    make: M,
) -> Result<Ended, HostError>
where
    H: NodeHost,
    M: FnOnce() -> Result<H, HostError>,
{
    let mut host = make()?;
    let mut beat = Heartbeat::of(&host)?;
    host.start();
    let mut finished = false;
    while !stop.load(Ordering::Relaxed) {
        match step_once(name, &mut host, beat.as_mut(), stop)? {
            Flow::Busy => {}
            Flow::Idle => {
                if let Some(idle) = idle {
                    std::thread::sleep(idle);
                }
            }
            Flow::Done => {
                finished = true;
                break;
            }
        }
    }
    host.finish()?;
    Ok(Ended {
        finished,
        interrupted: stop.load(Ordering::Relaxed),
    })
}

/// A host on an executor thread; finished when the thread drops it, unless a step failed.
struct OnThread<H: NodeHost> {
    name: &'static str,
    host: Option<H>,
    beat: Option<Heartbeat>,
    failed: bool,
}

impl<H: NodeHost> Drop for OnThread<H> {
    fn drop(&mut self) {
        if let Some(host) = self.host.take()
            && !self.failed
            && let Err(e) = host.finish()
        {
            eprintln!("{}: {}", self.name, Chain(&e));
        }
    }
}

fn periodic<H, M>(
    name: &'static str,
    stop: &Arc<AtomicBool>,
    p: Periodic,
    make: M,
) -> Result<Ended, HostError>
where
    H: NodeHost + 'static,
    M: FnOnce() -> Result<H, HostError> + Send + 'static,
{
    let finished = Arc::new(AtomicBool::new(false));
    let (finished2, stop2) = (Arc::clone(&finished), Arc::clone(stop));
    let mut builder = Executor::builder(p.thread, p.period).config(&p.config);
    if let Some(events) = p.events {
        builder = builder.events(events);
    }
    let exec = builder.spawn(move || {
        let built = make().and_then(|h| Ok((Heartbeat::of(&h)?, h)));
        let (beat, host) = match built {
            Ok((beat, mut h)) => {
                h.start();
                (beat, Some(h))
            }
            Err(e) => {
                eprintln!("{name}: {}", Chain(&e));
                (None, None)
            }
        };
        let mut on = OnThread {
            name,
            host,
            beat,
            failed: false,
        };
        move |_cycle| {
            let Some(h) = on.host.as_mut() else {
                return Control::Stop;
            };
            match step_once(name, h, on.beat.as_mut(), &stop2) {
                Ok(Flow::Busy | Flow::Idle) => Control::Continue,
                Ok(Flow::Done) => {
                    finished2.store(true, Ordering::Relaxed);
                    Control::Stop
                }
                Err(e) => {
                    eprintln!("{name}: {}", Chain(&e));
                    on.failed = true;
                    Control::Stop
                }
            }
        }
    })?;
    while !stop.load(Ordering::Relaxed) && !exec.is_finished() {
        std::thread::sleep(Duration::from_millis(20));
    }
    let summary = exec.join()?;
    eprintln!("{name}: {summary}");
    Ok(Ended {
        finished: finished.load(Ordering::Relaxed),
        interrupted: stop.load(Ordering::Relaxed),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use runtime::executor::SchedPolicy;
    use std::sync::atomic::AtomicU32;

    /// Counts of a test host's hooks.
    #[derive(Debug, Default)]
    struct Counts {
        start: AtomicU32,
        step: AtomicU32,
        health: AtomicU32,
        finish: AtomicU32,
    }

    /// Idle twice, then busy; done (or failing) at step `last`.
    struct Counter {
        counts: Arc<Counts>,
        last: u32,
        fail: bool,
    }

    impl NodeHost for Counter {
        fn start(&mut self) {
            self.counts.start.fetch_add(1, Ordering::Relaxed);
        }
        fn step(&mut self, _stop: &AtomicBool) -> Result<Flow, HostError> {
            let n = self.counts.step.fetch_add(1, Ordering::Relaxed) + 1;
            match n {
                n if n == self.last && self.fail => Err(HostError::LoadRefused),
                n if n == self.last => Ok(Flow::Done),
                1 | 2 => Ok(Flow::Idle),
                _ => Ok(Flow::Busy),
            }
        }
        fn health(&mut self) -> Result<(), HostError> {
            self.counts.health.fetch_add(1, Ordering::Relaxed);
            Ok(())
        }
        fn finish(self) -> Result<(), HostError> {
            self.counts.finish.fetch_add(1, Ordering::Relaxed);
            Ok(())
        }
    }

    fn counter(
        last: u32,
        fail: bool,
    ) -> (Arc<Counts>, impl FnOnce() -> Result<Counter, HostError>) {
        let counts = Arc::new(Counts::default());
        let c = Arc::clone(&counts);
        (counts, move || {
            Ok(Counter {
                counts: c,
                last,
                fail,
            })
        })
    }

    fn get(a: &AtomicU32) -> u32 {
        a.load(Ordering::Relaxed)
    }

    fn periodic_pace() -> Pace {
        Pace::Periodic(Periodic {
            thread: "host-test",
            period: Duration::from_millis(1),
            config: ExecutorConfig {
                policy: SchedPolicy::Other,
                nice: 0,
                mlockall: false,
                spin_margin_us: 0,
                cpu_dma_latency_us: -1,
                ..ExecutorConfig::default()
            },
            events: None,
        })
    }

    #[test]
    fn a_polled_host_steps_until_done_then_finishes() {
        let stop = Arc::new(AtomicBool::new(false));
        let (counts, make) = counter(5, false);
        let pace = Pace::Poll {
            idle: Duration::from_millis(1),
        };
        let ended = drive("test", &stop, pace, make).unwrap();
        assert_eq!(
            ended,
            Ended {
                finished: true,
                interrupted: false
            }
        );
        assert_eq!(get(&counts.start), 1);
        assert_eq!(get(&counts.step), 5);
        assert_eq!(get(&counts.health), 5);
        assert_eq!(get(&counts.finish), 1);
    }

    #[test]
    fn an_error_on_the_calling_thread_is_returned_without_finish() {
        let stop = Arc::new(AtomicBool::new(false));
        let (counts, make) = counter(3, true);
        let err = drive("test", &stop, Pace::OnData { sched: None }, make).unwrap_err();
        assert!(matches!(err, HostError::LoadRefused), "{err}");
        assert_eq!(get(&counts.step), 3);
        // No health after the failed step.
        assert_eq!(get(&counts.health), 2);
        assert_eq!(get(&counts.finish), 0);
    }

    #[test]
    fn a_stop_signal_ends_the_loop_and_the_host_finishes() {
        let stop = Arc::new(AtomicBool::new(true));
        let (counts, make) = counter(5, false);
        let ended = drive("test", &stop, Pace::OnData { sched: None }, make).unwrap();
        assert_eq!(
            ended,
            Ended {
                finished: false,
                interrupted: true
            }
        );
        assert_eq!(get(&counts.step), 0);
        assert_eq!(get(&counts.finish), 1);
    }

    #[test]
    fn a_periodic_host_runs_on_the_executor_until_done() {
        let stop = Arc::new(AtomicBool::new(false));
        let (counts, make) = counter(4, false);
        let ended = drive("test", &stop, periodic_pace(), make).unwrap();
        assert!(ended.finished && !ended.interrupted, "{ended:?}");
        assert_eq!(get(&counts.start), 1);
        assert_eq!(get(&counts.step), 4);
        assert_eq!(get(&counts.health), 4);
        // Finished when the executor thread dropped it.
        assert_eq!(get(&counts.finish), 1);
    }

    #[test]
    fn a_failing_periodic_host_ends_its_thread_unfinished() {
        let stop = Arc::new(AtomicBool::new(false));
        let (counts, make) = counter(3, true);
        let ended = drive("test", &stop, periodic_pace(), make).unwrap();
        assert!(!ended.finished && !ended.interrupted, "{ended:?}");
        assert_eq!(get(&counts.step), 3);
        assert_eq!(get(&counts.finish), 0);
        // A failed build: no step at all.
        let ended = drive("test", &stop, periodic_pace(), || {
            Err::<Counter, _>(HostError::EndedEarly)
        })
        .unwrap();
        assert!(!ended.finished, "{ended:?}");
    }

    #[test]
    fn chains_print_every_source_like_anyhow() {
        let e = HostError::Signal(std::io::Error::other("refused"));
        assert_eq!(Chain(&e).to_string(), "installing signal handler: refused");
        assert_eq!(
            Chain(&e).to_string(),
            format!("{:#}", anyhow::Error::from(e))
        );
    }
}
