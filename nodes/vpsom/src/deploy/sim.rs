//! `vpsom node sim`: the simulator on a periodic executor thread.

use super::RunArgs;
use super::health::report_input;
use super::host::{self, Flow, HostError, NodeHost, Pace, Periodic};
use crate::config::Config;
use crate::sim::{Scene, Sim};
use crate::topics;
use runtime::clock::MonotonicClock;
use runtime::executor::{ExecutorConfig, SchedPolicy};
use runtime::ports::{PortContext, Publisher, Subscriber};
use shm_types::{
    DepthFrame, Detections, FrameVisibility, NavGoal, NeckGoal, NodeHealth, OccupancyGrid,
    RobotState,
};
use std::sync::atomic::AtomicBool;
use std::time::Duration;

/// `vpsom node sim`: steps the simulator at `rates.state_hz` (simulated), renders frames at
/// `rates.camera_hz` straight into loaned depth/detection samples, publishes robot state,
/// ground truth (true state, per-frame object visibility) and the navigation grid, and follows
/// nav/neck goals.
pub fn sim_node(args: &RunArgs, cfg: &Config) -> Result<(), HostError> {
    let stop = host::stop_on_signals()?;
    let scene = Scene::builtin_or_load(args.scene.as_deref().unwrap_or(&cfg.sim.scene))?;
    let pace = Pace::Periodic(Periodic {
        thread: "sim",
        period: host::wall_period(cfg.rates.state_hz, args.time_scale),
        config: ExecutorConfig {
            policy: SchedPolicy::Other,
            ..cfg.executor.clone()
        },
        events: None,
    });
    let (cfg, args) = (cfg.clone(), args.clone());
    host::drive("sim", &stop, pace, move || SimHost::new(scene, &cfg, &args))?;
    Ok(())
}

/// The simulator and its ports.
struct SimHost {
    clock: MonotonicClock,
    sim: Sim,
    depth: Publisher<DepthFrame>,
    dets: Publisher<Detections>,
    state_pub: Publisher<RobotState>,
    truth_pub: Publisher<RobotState>,
    vis_pub: Publisher<FrameVisibility>,
    grid_pub: Publisher<OccupancyGrid>,
    nav_sub: Subscriber<NavGoal>,
    neck_sub: Subscriber<NeckGoal>,
    ctx: PortContext,
    health_period: Duration,
    /// Simulated step, ns.
    dt_ns: u64,
    /// Camera period (simulated), ns.
    cam_ns: u64,
    next_cam: u64,
    next_grid: u64,
    /// The newest nav goal id followed.
    last_goal: u64,
}

impl SimHost {
    fn new(scene: Scene, cfg: &Config, args: &RunArgs) -> Result<Self, HostError> {
        let clock = MonotonicClock::new();
        let ctx = PortContext::with_namespace(&cfg.ports, "sim", &args.namespace)?;
        let sim = Sim::new(scene, cfg, args.seed)?;
        Ok(Self {
            clock,
            sim,
            depth: ctx.publisher(topics::DEPTH)?,
            dets: ctx.publisher(topics::DETECTIONS)?,
            state_pub: ctx.publisher(topics::STATE)?,
            truth_pub: ctx.publisher(topics::TRUTH)?,
            vis_pub: ctx.publisher(topics::VISIBILITY)?,
            grid_pub: ctx.publisher(topics::NAV_GRID)?,
            nav_sub: ctx.subscriber(topics::NAV_GOAL)?,
            neck_sub: ctx.subscriber(topics::NECK_GOAL)?,
            ctx,
            health_period: Duration::from_secs_f64(1.0 / cfg.run.health_hz),
            dt_ns: (1e9 / cfg.rates.state_hz).round() as u64,
            cam_ns: (1e9 / cfg.rates.camera_hz).round() as u64,
            next_cam: 0,
            next_grid: 0,
            last_goal: 0,
        })
    }
}

impl NodeHost for SimHost {
    fn step(&mut self, _stop: &AtomicBool) -> Result<Flow, HostError> {
        let (sim, clock) = (&mut self.sim, &self.clock);
        while let Some(g) = self.nav_sub.receive()? {
            if g.goal_id > self.last_goal {
                self.last_goal = g.goal_id;
                if let Err(why) = sim.set_nav_goal(&g) {
                    eprintln!("sim: goal {} refused: {why}", g.goal_id);
                }
            }
        }
        if let Some(n) = self.neck_sub.latest()? {
            sim.set_neck_goal(&n);
        }
        let t = sim.time_ns();
        if t >= self.next_cam {
            // No zero-fill (600 KB + 300 KB a frame): `render` overwrites every field of both
            // and all `width × height` pixels and labels (items past `count` too); the array
            // tails beyond `width × height` may hold an earlier frame's data (the size is fixed
            // per run, so in practice zeros), which consumers never read (`pixels()`,
            // `label_pixels()`).
            let mut frame = self.depth.loan_reused()?;
            let mut det = self.dets.loan_reused()?;
            sim.render(&mut frame, &mut det, t);
            let sent = frame.send(host::stamp(clock, t))?;
            det.frame_seq = sent.seq;
            det.send(host::stamp(clock, t))?;
            // Ground truth for the launcher's non-occlusion metric (2 KB).
            let mut vis = self.vis_pub.loan()?;
            *vis = *sim.visibility();
            vis.frame_seq = sent.seq;
            vis.send(host::stamp(clock, t))?;
            self.next_cam += self.cam_ns;
        }
        let mut s = self.state_pub.loan()?;
        sim.robot_state(&mut s);
        s.send(host::stamp(clock, t))?;
        let mut s = self.truth_pub.loan()?;
        *s = sim.true_state();
        s.send(host::stamp(clock, t))?;
        if t >= self.next_grid {
            let mut g = self.grid_pub.loan()?;
            sim.nav_grid(&mut g);
            g.send(host::stamp(clock, t))?;
            self.next_grid += 1_000_000_000;
        }
        sim.step(self.dt_ns);
        Ok(Flow::Busy)
    }

    fn heartbeat(&self) -> Option<(&PortContext, Duration)> {
        Some((&self.ctx, self.health_period))
    }

    fn inputs(&self, h: &mut NodeHealth) {
        report_input(h, topics::NAV_GOAL, &self.nav_sub);
        report_input(h, topics::NECK_GOAL, &self.neck_sub);
    }
}
