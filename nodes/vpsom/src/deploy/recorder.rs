//! `vpsom node recorder`: every topic to `OUT/trace.mcap`, polled on the main thread; and the
//! recorder's view of a scene ([`recorder_setup`], also used by the lockstep host).

use super::RunArgs;
use super::health::report_input;
use super::host::{self, Flow, HostError, NodeHost, Pace};
use crate::config::Config;
use crate::recording::{MountGeometry, SceneConverter, TruthBox};
use crate::sim::Scene;
use crate::topics;
use runtime::ports::{PortContext, Subscriber};
use runtime::recorder::{Overflow, Recorder, RecorderHandle, RecorderSetup};
use shm_types::{
    DeadlineEvent, DepthFrame, Detections, NavGoal, NeckGoal, NodeHealth, ObjectMap, OccupancyGrid,
    PlannerDecision, RobotState,
};
use std::sync::atomic::AtomicBool;
use std::time::Duration;

/// `vpsom node recorder`: subscribes to every topic and records it to `OUT/trace.mcap`.
pub fn recorder_node(args: &RunArgs, cfg: &Config) -> Result<(), HostError> {
    let stop = host::stop_on_signals()?;
    let (cfg, args) = (cfg.clone(), args.clone());
    let pace = Pace::Poll {
        idle: Duration::from_millis(2),
    };
    host::drive("recorder", &stop, pace, move || {
        RecorderHost::new(&args, &cfg)
    })?;
    Ok(())
}

/// What the recorder needs to draw: the scene's true cuboids and the camera geometry, in the
/// app's converter (host `live`: the lockstep host overrides it).
pub fn recorder_setup(scene: &Scene, cfg: &Config) -> RecorderSetup {
    let truth = scene
        .objects
        .iter()
        .map(|o| TruthBox {
            name: o.name.clone(),
            class: o.class.clone(),
            center: o.center.to_array(),
            size: o.size.to_array(),
            yaw: o.yaw,
        })
        .collect();
    RecorderSetup {
        scene: scene.name.clone(),
        ..live_setup(cfg, truth)
    }
}

/// A live host's setup: the camera of `cfg`, `truth` (empty: nothing true to draw), host
/// `live`, and drops rather than waits.
fn live_setup(cfg: &Config, truth: Vec<TruthBox>) -> RecorderSetup {
    let conv = SceneConverter::new(&cfg.recorder, MountGeometry::from(&cfg.camera), truth);
    RecorderSetup {
        host: "live".into(),
        // A live recorder never makes a real-time publisher wait: it drops and counts.
        overflow: Overflow::Drop,
        ..RecorderSetup::new(conv)
    }
}

/// The recorder and a subscriber per recorded topic.
struct RecorderHost {
    rec: Recorder,
    h: RecorderHandle,
    depth: Subscriber<DepthFrame>,
    detections: Subscriber<Detections>,
    grid: Subscriber<OccupancyGrid>,
    state: Subscriber<RobotState>,
    truth: Subscriber<RobotState>,
    map: Subscriber<ObjectMap>,
    decision: Subscriber<PlannerDecision>,
    nav: Subscriber<NavGoal>,
    neck: Subscriber<NeckGoal>,
    deadline: Subscriber<DeadlineEvent>,
    health: Subscriber<NodeHealth>,
    /// Simulated time of the newest robot state (heartbeats carry none).
    sim_ns: u64,
    ctx: PortContext,
    health_period: Duration,
}

impl RecorderHost {
    fn new(args: &RunArgs, cfg: &Config) -> Result<Self, HostError> {
        let setup = match &args.scene {
            Some(name) => recorder_setup(&Scene::builtin_or_load(name)?, cfg),
            // Sensors from outside, no scene: nothing true to draw.
            None => RecorderSetup {
                scene: "none".into(),
                ..live_setup(cfg, Vec::new())
            },
        };
        let setup = RecorderSetup {
            live_port: args.live,
            ..setup
        };
        std::fs::create_dir_all(&args.out)?;
        // Restarted within a run: continue in the next segment; the torn one is recovered in
        // the background (the launcher removed an earlier run's segments at start).
        let rec = Recorder::resume(&args.out.join("trace.mcap"), &cfg.recorder, setup)?;
        let h = rec.handle();
        if let Some(p) = rec.live_port() {
            eprintln!("recorder: live view on ws://0.0.0.0:{p} (Foxglove: Open connection)");
        }
        let ctx = PortContext::with_namespace(&cfg.ports, "recorder", &args.namespace)?;
        Ok(Self {
            rec,
            h,
            depth: ctx.subscriber(topics::DEPTH)?,
            detections: ctx.subscriber(topics::DETECTIONS)?,
            grid: ctx.subscriber(topics::NAV_GRID)?,
            state: ctx.subscriber(topics::STATE)?,
            truth: ctx.subscriber(topics::TRUTH)?,
            map: ctx.subscriber(topics::MAP)?,
            decision: ctx.subscriber(topics::DECISION)?,
            nav: ctx.subscriber(topics::NAV_GOAL)?,
            neck: ctx.subscriber(topics::NECK_GOAL)?,
            deadline: ctx.subscriber(topics::DEADLINE)?,
            health: ctx.subscriber(topics::HEALTH)?,
            sim_ns: 0,
            ctx,
            health_period: Duration::from_secs_f64(1.0 / cfg.run.health_hz),
        })
    }
}

impl NodeHost for RecorderHost {
    fn step(&mut self, _stop: &AtomicBool) -> Result<Flow, HostError> {
        let h = &self.h;
        let mut any = false;
        while let Some(s) = self.depth.receive()? {
            h.record_depth(&s);
            any = true;
        }
        while let Some(s) = self.detections.receive()? {
            h.record_detections(&s);
            any = true;
        }
        while let Some(s) = self.grid.receive()? {
            h.record_nav_grid(&s);
            any = true;
        }
        while let Some(s) = self.state.receive()? {
            self.sim_ns = s.header.sim_time_ns;
            h.record_state(&s);
            any = true;
        }
        while let Some(s) = self.truth.receive()? {
            h.record_true_state(&s);
            any = true;
        }
        while let Some(s) = self.map.receive()? {
            h.record_map(&s);
            any = true;
        }
        while let Some(s) = self.decision.receive()? {
            h.record_decision(&s);
            any = true;
        }
        while let Some(s) = self.nav.receive()? {
            h.record_nav_goal(&s);
            any = true;
        }
        while let Some(s) = self.neck.receive()? {
            h.record_neck_goal(&s);
            any = true;
        }
        while let Some(s) = self.deadline.receive()? {
            h.record_deadline(&s);
            any = true;
        }
        while let Some(s) = self.health.receive()? {
            // Stamped with the run's simulated time, so it sorts with the other topics.
            let mut beat = *s;
            beat.header.sim_time_ns = self.sim_ns;
            h.record_health(&beat);
            any = true;
        }
        Ok(if any { Flow::Busy } else { Flow::Idle })
    }

    fn heartbeat(&self) -> Option<(&PortContext, Duration)> {
        Some((&self.ctx, self.health_period))
    }

    fn inputs(&self, h: &mut NodeHealth) {
        report_input(h, topics::DEPTH, &self.depth);
        report_input(h, topics::DETECTIONS, &self.detections);
        report_input(h, topics::NAV_GRID, &self.grid);
        report_input(h, topics::STATE, &self.state);
        report_input(h, topics::TRUTH, &self.truth);
        report_input(h, topics::MAP, &self.map);
        report_input(h, topics::DECISION, &self.decision);
        report_input(h, topics::NAV_GOAL, &self.nav);
        report_input(h, topics::NECK_GOAL, &self.neck);
        report_input(h, topics::DEADLINE, &self.deadline);
    }

    fn finish(self) -> Result<(), HostError> {
        let missed = self.depth.gaps()
            + self.detections.gaps()
            + self.state.gaps()
            + self.truth.gaps()
            + self.map.gaps()
            + self.decision.gaps();
        let summary = self.rec.finish()?;
        eprintln!(
            "recorder: wrote {} messages, dropped {} in the recorder, {} samples overwritten \
             before they were read",
            summary.written.values().sum::<u64>(),
            summary.drops.total_dropped(),
            missed
        );
        Ok(())
    }
}
