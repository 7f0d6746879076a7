//! `vpsom node recorder`: every topic to `OUT/trace.mcap`, polled on the main thread; and the
//! recorder's view of a scene ([`recorder_setup`], also used by the lockstep host).
//!
//! The receive loop drains by priority (issue #35): every pass drains the small topics (robot
//! states, goals, decisions, maps, deadline events, heartbeats) completely, then records at most
//! [`LARGE_PER_PASS`] sample of each large one (depth, detections, the navigation grid), draining
//! the small ones again after each. A burst of frames (from another host, or after the recorder
//! was off the CPU) therefore never keeps a state waiting behind it until it is overwritten. The
//! subscribers are as deep as the topics' rates ask for ([`recorder_ports`]).

use super::RunArgs;
use super::health::report_input;
use super::host::{self, Flow, HostError, NodeHost, Pace};
use crate::config::Config;
use crate::recording::{MountGeometry, SceneConverter, TruthBox};
use crate::sim::Scene;
use crate::topics;
use iceoryx2::prelude::{MessagingPattern, ServiceName, ipc};
use iceoryx2::service::Service as _;
use runtime::ports::{PortContext, PortsConfig, Subscriber};
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

/// Large samples recorded per large topic in one pass of the receive loop, between two drains of
/// the small topics (see the module docs).
pub const LARGE_PER_PASS: usize = 1;

/// The topics the recorder receives; `true`: large (drained with a budget, see the module docs).
const RECORDED: [(&str, bool); 11] = [
    (topics::STATE, false),
    (topics::TRUTH, false),
    (topics::MAP, false),
    (topics::DECISION, false),
    (topics::NAV_GOAL, false),
    (topics::NECK_GOAL, false),
    (topics::DEADLINE, false),
    (topics::HEALTH, false),
    (topics::DEPTH, true),
    (topics::DETECTIONS, true),
    (topics::NAV_GRID, true),
];

/// The subscriber depth a topic's existing service admits (`None`: no such service yet).
fn service_max_buffer(namespace: &str, topic: &str) -> Option<usize> {
    let full = format!("{}/{namespace}/{topic}", runtime::ports::SERVICE_ROOT);
    let name = ServiceName::new(&full).ok()?;
    let details = ipc::Service::details(
        &name,
        &runtime::ports::iceoryx2_config(),
        MessagingPattern::PublishSubscribe,
    )
    .ok()??;
    Some(
        details
            .static_details
            .publish_subscribe()
            .subscriber_max_buffer_size(),
    )
}

/// The recorder's `[ports]`: each recorded topic's subscriber holds
/// [`STALL_S`](super::link::STALL_S) of the topic at its wall rate (`[rates]` × `time_scale`,
/// `[link.max_hz]` for a rate-limited topic; see [`super::link::burst_depth`]), at least its
/// configured depth, and at most what the topic's service admits when it exists already: a
/// service the link tunnel created (`vpsom run --link`) admits that depth (the tunnel sizes them
/// the same way, small topics at least `[link] buffer`), one the launcher created only
/// `[ports]`' depth. A service not there yet is created with the configured depth (a node
/// opening it at the same moment asks for no more).
pub fn recorder_ports(cfg: &Config, time_scale: f64, namespace: &str) -> PortsConfig {
    let mut p = cfg.ports.clone();
    for (topic, large) in RECORDED {
        let configured = cfg.ports.topic(topic).subscriber_buffer;
        let Some(max) = service_max_buffer(namespace, topic) else {
            continue;
        };
        let want = super::link::burst_depth(
            super::link::wall_hz(topic, cfg, time_scale),
            configured,
            large,
        );
        // Never below the configured depth: a service that admits less fails to open as before.
        let depth = want.min(max).max(configured);
        if depth != configured {
            p.topics
                .entry(topic.to_string())
                .or_default()
                .subscriber_buffer = Some(depth);
        }
    }
    p
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
        let ports = recorder_ports(cfg, args.time_scale, &args.namespace);
        let ctx = PortContext::with_namespace(&ports, "recorder", &args.namespace)?;
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

impl RecorderHost {
    /// Record everything buffered on the small topics; whether there was anything.
    fn drain_small(&mut self) -> Result<bool, HostError> {
        let h = &self.h;
        let mut any = false;
        while let Some(s) = self.state.receive()? {
            self.sim_ns = s.header.sim_time_ns;
            h.record_state(&s);
            any = true;
        }
        while let Some(s) = self.truth.receive()? {
            h.record_true_state(&s);
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
        while let Some(s) = self.decision.receive()? {
            h.record_decision(&s);
            any = true;
        }
        while let Some(s) = self.map.receive()? {
            h.record_map(&s);
            any = true;
        }
        while let Some(s) = self.health.receive()? {
            // Stamped with the run's simulated time, so it sorts with the other topics.
            let mut beat = *s;
            beat.header.sim_time_ns = self.sim_ns;
            h.record_health(&beat);
            any = true;
        }
        Ok(any)
    }
}

impl NodeHost for RecorderHost {
    fn step(&mut self, _stop: &AtomicBool) -> Result<Flow, HostError> {
        // Small topics first, then a budget of each large one with the small ones drained again
        // after each large sample (see the module docs).
        let mut any = self.drain_small()?;
        for _ in 0..LARGE_PER_PASS {
            let mut large = false;
            if let Some(s) = self.depth.receive()? {
                self.h.record_depth(&s);
                large = true;
                self.drain_small()?;
            }
            if let Some(s) = self.detections.receive()? {
                self.h.record_detections(&s);
                large = true;
                self.drain_small()?;
            }
            if let Some(s) = self.grid.receive()? {
                self.h.record_nav_grid(&s);
                large = true;
                self.drain_small()?;
            }
            if !large {
                break;
            }
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
        let gaps = [
            (topics::STATE, self.state.gaps()),
            (topics::TRUTH, self.truth.gaps()),
            (topics::MAP, self.map.gaps()),
            (topics::DECISION, self.decision.gaps()),
            (topics::NAV_GOAL, self.nav.gaps()),
            (topics::NECK_GOAL, self.neck.gaps()),
            (topics::DEADLINE, self.deadline.gaps()),
            (topics::DEPTH, self.depth.gaps()),
            (topics::DETECTIONS, self.detections.gaps()),
            (topics::NAV_GRID, self.grid.gaps()),
        ];
        // A last heartbeat with the final input counts: the launcher's and the link tunnel's
        // accounts read the overflow of this recorder's subscribers from it (the periodic
        // ones are up to a heartbeat period old).
        match super::health::Heartbeat::of(&self) {
            Ok(Some(mut beat)) => {
                if let Err(e) = beat.tick("recorder", &self) {
                    eprintln!("recorder: the last heartbeat: {e}");
                }
            }
            Ok(None) => {}
            Err(e) => eprintln!("recorder: the last heartbeat: {e}"),
        }
        let missed: u64 = gaps.iter().map(|g| g.1).sum();
        let per_topic: Vec<String> = gaps
            .iter()
            .filter(|g| g.1 > 0)
            .map(|(t, n)| format!("{t} {n}"))
            .collect();
        let summary = self.rec.finish()?;
        eprintln!(
            "recorder: wrote {} messages, dropped {} in the recorder, {} samples overwritten \
             before they were read or lost before they reached this host (sequence gaps){}",
            summary.written.values().sum::<u64>(),
            summary.drops.total_dropped(),
            missed,
            if per_topic.is_empty() {
                String::new()
            } else {
                format!(": {}", per_topic.join(", "))
            }
        );
        Ok(())
    }
}
