//! `vpsom node mapper`: the mapper on the process's main thread, woken by depth frames.
//!
//! Restarted by the launcher (`VPSOM_RESTART` = n > 0) with `[run] resume_map`, it first waits
//! (up to [`RESUME_WAIT`]) for the launcher's copy of the last map it published, the n-th
//! sample on `map/resume`, and continues from it ([`Mapper::resume_from`]) instead of from an
//! empty map.

use super::RunArgs;
use super::health::report_input;
use super::host::{self, Flow, HostError, NodeHost, Pace};
use crate::config::Config;
use crate::mapper::{Mapper, MapperError};
use crate::topics;
use runtime::clock::MonotonicClock;
use runtime::executor::{ExecutorConfig, SchedPolicy};
use runtime::ports::{PortContext, Publisher, Received, Subscriber};
use shm_types::{DepthFrame, Detections, NodeHealth, ObjectMap, OccupancyGrid, RobotState};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// `vpsom node mapper`: integrates every depth frame (read in place) with its detections and
/// the newest estimated state; publishes the object map at `rates.map_hz` (simulated) and the
/// exploration grid, both written in place into loaned samples.
pub fn mapper_node(args: &RunArgs, cfg: &Config) -> Result<(), HostError> {
    let stop = host::stop_on_signals()?;
    let sched = ExecutorConfig {
        policy: if cfg.run.mapper_priority > 0 {
            SchedPolicy::Fifo
        } else {
            SchedPolicy::Other
        },
        priority: cfg.run.mapper_priority.max(1),
        ..cfg.executor.clone()
    };
    let (cfg, ns) = (cfg.clone(), args.namespace.clone());
    let pace = Pace::OnData { sched: Some(sched) };
    host::drive("mapper", &stop, pace, move || MapperHost::new(&cfg, &ns))?;
    Ok(())
}

/// The mapper and its ports.
struct MapperHost {
    clock: MonotonicClock,
    depth: Subscriber<DepthFrame>,
    dets: Subscriber<Detections>,
    state_sub: Subscriber<RobotState>,
    map_pub: Publisher<ObjectMap>,
    grid_pub: Publisher<OccupancyGrid>,
    mapper: Mapper,
    /// Map publication period (simulated), ns.
    map_period: u64,
    state: RobotState,
    next_map: u64,
    /// Detections of a frame not integrated yet.
    pending: Option<Received<Detections>>,
    /// Frames integrated, rejected as invalid, and skipped for want of matching detections
    /// (published in every map, so the run's summary reports them).
    counts: FrameCounts,
    /// Simulated time of the newest frame.
    last_t: u64,
    ctx: PortContext,
    health_period: Duration,
}

/// Longest wait of a restarted mapper for the map it resumes from.
pub const RESUME_WAIT: Duration = Duration::from_secs(5);

/// How many times the launcher has restarted this process (0: first start, or no launcher).
fn restart_number() -> u64 {
    std::env::var(runtime::launcher::RESTART_ENV)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(0)
}

impl MapperHost {
    fn new(cfg: &Config, ns: &str) -> Result<Self, HostError> {
        let clock = MonotonicClock::new();
        let ctx = PortContext::with_namespace(&cfg.ports, "mapper", ns)?;
        let restart = restart_number();
        let resume = if restart > 0 && cfg.run.resume_map {
            Some(ctx.subscriber::<ObjectMap>(topics::MAP_RESUME)?)
        } else {
            None
        };
        let mut host = Self {
            clock,
            depth: ctx.subscriber(topics::DEPTH)?,
            dets: ctx.subscriber(topics::DETECTIONS)?,
            state_sub: ctx.subscriber(topics::STATE)?,
            map_pub: ctx.publisher(topics::MAP)?,
            grid_pub: ctx.publisher(topics::MAP_GRID)?,
            mapper: Mapper::new(&cfg.mapper, &cfg.camera.camera())?,
            map_period: (1e9 / cfg.rates.map_hz).round() as u64,
            state: RobotState::default(),
            next_map: 0,
            pending: None,
            counts: FrameCounts::default(),
            last_t: 0,
            ctx,
            health_period: Duration::from_secs_f64(1.0 / cfg.run.health_hz),
        };
        if let Some(sub) = resume {
            host.resume(&sub, restart)?;
        }
        Ok(host)
    }

    /// Continue from the `restart`-th map the launcher handed over on `map/resume` (earlier
    /// ones, still in its history, are older). Polled: history arrives without an event.
    fn resume(&mut self, sub: &Subscriber<ObjectMap>, restart: u64) -> Result<(), HostError> {
        let deadline = Instant::now() + RESUME_WAIT;
        loop {
            if let Some(m) = sub.latest()?
                && m.header.seq >= restart
            {
                let n = self.mapper.resume_from(&m);
                (
                    self.counts.integrated,
                    self.counts.rejected,
                    self.counts.unmatched,
                ) = (m.frames_integrated, m.frames_rejected, m.frames_unmatched);
                self.last_t = m.header.sim_time_ns;
                eprintln!(
                    "mapper: restart {restart}: resumed from the last published map ({n} objects, \
                     frame {}, {:.1} s)",
                    m.last_frame_seq,
                    m.header.sim_time_ns as f64 * 1e-9
                );
                return Ok(());
            }
            if Instant::now() >= deadline {
                eprintln!(
                    "mapper: restart {restart}: no map to resume from on {} after {RESUME_WAIT:?}; \
                     starting empty",
                    topics::MAP_RESUME
                );
                return Ok(());
            }
            std::thread::sleep(Duration::from_millis(10));
        }
    }

    /// The detections of frame `seq`: they follow it closely; older ones are skipped, a newer
    /// one is kept for its frame. `None` after 500 ms or on stop.
    fn detections_of(
        &mut self,
        seq: u64,
        stop: &AtomicBool,
    ) -> Result<Option<Received<Detections>>, HostError> {
        let deadline = Instant::now() + Duration::from_millis(500);
        loop {
            let candidate = match self.pending.take() {
                Some(d) => Some(d),
                None => self.dets.receive()?,
            };
            match candidate {
                Some(d) if d.frame_seq == seq => return Ok(Some(d)),
                Some(d) if d.frame_seq > seq => {
                    self.pending = Some(d);
                    return Ok(None);
                }
                Some(_) => continue,
                None => {
                    if Instant::now() > deadline || stop.load(Ordering::Relaxed) {
                        return Ok(None);
                    }
                    self.pending = self.dets.wait(Duration::from_millis(20))?;
                }
            }
        }
    }
}

impl MapperHost {
    /// Publishes the map (with the frame counts) and the exploration grid at simulated time `t`.
    fn publish(&mut self, t: u64) -> Result<(), HostError> {
        let mut m = self.map_pub.loan()?;
        self.mapper.write_map(&mut m, t);
        m.frames_integrated = self.counts.integrated;
        // Invalid samples are dropped on receipt by the ports; the mapper's own checks catch
        // the rest (e.g. a frame and detections that disagree in size).
        let dropped = self.depth.invalid() + self.dets.invalid();
        m.frames_rejected = self.counts.rejected + u32::try_from(dropped).unwrap_or(u32::MAX);
        m.frames_unmatched = self.counts.unmatched;
        m.send(host::stamp(&self.clock, t))?;
        let mut g = self.grid_pub.loan()?;
        self.mapper.write_grid(&mut g);
        g.send(host::stamp(&self.clock, t))?;
        Ok(())
    }
}

impl NodeHost for MapperHost {
    fn step(&mut self, stop: &AtomicBool) -> Result<Flow, HostError> {
        let frame = match self.depth.wait(Duration::from_millis(200)) {
            Ok(Some(f)) => f,
            Ok(None) => return Ok(Flow::Idle),
            // A stop signal interrupts the wait: leave the loop cleanly.
            Err(_) if stop.load(Ordering::Relaxed) => return Ok(Flow::Done),
            Err(e) => return Err(e.into()),
        };
        if let Some(s) = self.state_sub.latest()? {
            self.state = *s;
        }
        match self.detections_of(frame.header.seq, stop)? {
            None => {
                eprintln!("mapper: no detections for frame {}", frame.header.seq);
                self.counts.unmatched += 1;
                self.mapper
                    .note_unmatched(frame.header.seq, self.state.header.seq);
            }
            Some(det) => match self.mapper.integrate(&frame, &det, &self.state) {
                Ok(_) => self.counts.integrated += 1,
                Err(e) => {
                    eprintln!("mapper: frame {}: {e}", frame.header.seq);
                    match e {
                        MapperError::Invalid { .. } => self.counts.rejected += 1,
                        _ => self.counts.unmatched += 1,
                    }
                }
            },
        }
        let t = frame.header.sim_time_ns;
        if t < self.last_t {
            // The robot's clock went back (a restarted sim starts at 0): publish at once and
            // keep the map period on the new clock.
            self.next_map = t;
        }
        self.last_t = t;
        if t >= self.next_map {
            self.publish(t)?;
            self.next_map = t + self.map_period;
        } else if self.mapper.receipts_full() {
            // Every frame consumed is named in a map (`ObjectMap::receipts`): publish early
            // rather than lose a receipt.
            self.publish(t)?;
        }
        Ok(Flow::Busy)
    }

    fn heartbeat(&self) -> Option<(&PortContext, Duration)> {
        Some((&self.ctx, self.health_period))
    }

    fn inputs(&self, h: &mut NodeHealth) {
        report_input(h, topics::DEPTH, &self.depth);
        report_input(h, topics::DETECTIONS, &self.dets);
        report_input(h, topics::STATE, &self.state_sub);
    }

    /// On a clean stop, one last map: what was integrated after the last periodic one, and the
    /// final frame counts, are not lost.
    fn finish(mut self) -> Result<(), HostError> {
        self.publish(self.last_t)
    }
}

/// The mapper's running account of the depth frames it received.
#[derive(Debug, Default)]
struct FrameCounts {
    integrated: u32,
    rejected: u32,
    unmatched: u32,
}
