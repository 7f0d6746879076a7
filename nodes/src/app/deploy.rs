//! The deployment host: `vpsom run` launches the sim, mapper, planner and recorder as separate
//! processes (`vpsom node <role>`) that talk through iceoryx2 shared memory on the real clock at
//! fixed rates, watches them (exit status, iceoryx2 dead nodes, restarts), and scores the session
//! from what it hears on the topics.
//!
//! Time: the sim advances `time_scale` simulated seconds per wall second; every rate in the
//! configuration is in simulated time, so wall periods are divided by `time_scale`. Message
//! headers carry both the producer's monotonic clock (`stamp_ns`, for latency) and the simulated
//! time (`sim_time_ns`).

use super::topics;
use crate::config::Config;
use crate::eval::{self, MatchParams, RunInfo, SessionLog};
use crate::mapper::Mapper;
use crate::planner::gbv::{self, GbvParams};
use crate::planner::{self, JobOutput, PlannerInputs, Step, ViewPlanner};
use crate::sim::{Scene, Sim};
use anyhow::{Context, bail};
use runtime::clock::{Clock, MonotonicClock};
use runtime::executor::{Control, Executor};
use runtime::launcher::{ChildEvent, ChildSpec, Launcher};
use runtime::pool::WorkerPool;
use runtime::ports::{PortContext, Received, Stamp, Subscriber};
use runtime::recorder::{MountGeometry, Recorder, RecorderSetup, TruthBox};
use shm_types::{
    DeadlineEvent, DepthFrame, Detections, NavGoal, NeckGoal, ObjectMap, OccupancyGrid,
    PlannerDecision, RobotState, boxed_zeroed, decision_kind, planner_state,
};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// Settings shared by the launcher and every node process of one run.
#[derive(Debug, Clone)]
pub struct RunArgs {
    /// Scene: built-in name or file.
    pub scene: String,
    /// Planner label (`vpsom`, `coverage`, `frontier`, `vpsom-no-<term>`).
    pub planner: String,
    /// Seed.
    pub seed: u64,
    /// Simulated seconds per wall second.
    pub time_scale: f64,
    /// Service namespace of the run.
    pub namespace: String,
    /// Output directory.
    pub out: PathBuf,
    /// Configuration file given on the command line (children load the same one).
    pub config_file: Option<PathBuf>,
    /// Deadline testing: keep the GBV pool saturated with this many extra candidate views
    /// (see `GbvLoad` in this module); 0 = off.
    pub gbv_load: usize,
}

impl RunArgs {
    fn child_args(&self, role: &str) -> Vec<String> {
        let mut a = vec![
            "node".into(),
            role.into(),
            "--scene".into(),
            self.scene.clone(),
            "--planner".into(),
            self.planner.clone(),
            "--seed".into(),
            self.seed.to_string(),
            "--time-scale".into(),
            self.time_scale.to_string(),
            "--ns".into(),
            self.namespace.clone(),
            "--out".into(),
            self.out.display().to_string(),
            "--gbv-load".into(),
            self.gbv_load.to_string(),
        ];
        if let Some(c) = &self.config_file {
            a.push("--config".into());
            a.push(c.display().to_string());
        }
        a
    }
}

/// The configuration a run uses: the file's, with `[run]`'s camera size and the planner label.
pub fn run_config(base: &Config, planner: &str) -> anyhow::Result<Config> {
    let cfg = base.with_camera(base.run.camera_width, base.run.camera_height, 0.0);
    super::lockstep::config_for(&cfg, planner)
}

/// Set by SIGINT/SIGTERM.
fn stop_flag() -> anyhow::Result<Arc<AtomicBool>> {
    let flag = Arc::new(AtomicBool::new(false));
    for sig in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
        signal_hook::flag::register(sig, Arc::clone(&flag)).context("installing signal handler")?;
    }
    Ok(flag)
}

fn wall_period(hz: f64, time_scale: f64) -> Duration {
    Duration::from_secs_f64(1.0 / (hz * time_scale))
}

fn now(clock: &MonotonicClock) -> u64 {
    clock.now_ns()
}

// ------------------------------------------------------------------------------------------
// Node processes
// ------------------------------------------------------------------------------------------

/// `vpsom node sim`: steps the simulator at `rates.state_hz` (simulated), renders frames at
/// `rates.camera_hz` straight into loaned depth/detection samples, publishes robot state,
/// ground truth and the navigation grid, and follows nav/neck goals.
pub fn sim_node(args: &RunArgs, cfg: &Config) -> anyhow::Result<()> {
    let stop = stop_flag()?;
    let scene = Scene::builtin_or_load(&args.scene)?;
    let (cfg, args2) = (cfg.clone(), args.clone());
    let dt_ns = (1e9 / cfg.rates.state_hz).round() as u64;
    let cam_ns = (1e9 / cfg.rates.camera_hz).round() as u64;
    let exec = Executor::builder("sim", wall_period(cfg.rates.state_hz, args.time_scale))
        .config(&runtime::executor::ExecutorConfig {
            policy: runtime::executor::SchedPolicy::Other,
            ..cfg.executor.clone()
        })
        .spawn(move || {
            let clock = MonotonicClock::new();
            let setup = || -> anyhow::Result<_> {
                let ctx = PortContext::with_namespace(&cfg.ports, "sim", &args2.namespace)?;
                let sim = Sim::new(scene, &cfg, args2.seed)?;
                Ok((
                    sim,
                    ctx.publisher::<DepthFrame>(topics::DEPTH)?,
                    ctx.publisher::<Detections>(topics::DETECTIONS)?,
                    ctx.publisher::<RobotState>(topics::STATE)?,
                    ctx.publisher::<RobotState>(topics::TRUTH)?,
                    ctx.publisher::<OccupancyGrid>(topics::NAV_GRID)?,
                    ctx.subscriber::<NavGoal>(topics::NAV_GOAL)?,
                    ctx.subscriber::<NeckGoal>(topics::NECK_GOAL)?,
                    ctx,
                ))
            };
            let mut parts = match setup() {
                Ok(p) => Some(p),
                Err(e) => {
                    eprintln!("sim: {e:#}");
                    None
                }
            };
            let (mut next_cam, mut next_grid, mut last_goal) = (0u64, 0u64, 0u64);
            move |_cycle| {
                let Some((
                    sim,
                    depth,
                    dets,
                    state_pub,
                    truth_pub,
                    grid_pub,
                    nav_sub,
                    neck_sub,
                    _ctx,
                )) = parts.as_mut()
                else {
                    return Control::Stop;
                };
                let result = (|| -> anyhow::Result<()> {
                    while let Some(g) = nav_sub.receive()? {
                        if g.goal_id > last_goal {
                            last_goal = g.goal_id;
                            if let Err(why) = sim.set_nav_goal(&g) {
                                eprintln!("sim: goal {} refused: {why}", g.goal_id);
                            }
                        }
                    }
                    if let Some(n) = neck_sub.latest()? {
                        sim.set_neck_goal(&n);
                    }
                    let t = sim.time_ns();
                    if t >= next_cam {
                        // No zero-fill (600 KB + 300 KB a frame): `render` overwrites every
                        // field of both and all `width × height` pixels and labels (items past
                        // `count` too); the array tails beyond `width × height` may hold an
                        // earlier frame's data (the size is fixed per run, so in practice
                        // zeros), which consumers never read (`pixels()`, `label_pixels()`).
                        let mut frame = depth.loan_reused()?;
                        let mut det = dets.loan_reused()?;
                        sim.render(&mut frame, &mut det, t);
                        let sent = frame.send(Stamp {
                            source_ns: now(&clock),
                            sim_ns: t,
                        })?;
                        det.frame_seq = sent.seq;
                        det.send(Stamp {
                            source_ns: now(&clock),
                            sim_ns: t,
                        })?;
                        next_cam += cam_ns;
                    }
                    let mut s = state_pub.loan()?;
                    sim.robot_state(&mut s);
                    s.send(Stamp {
                        source_ns: now(&clock),
                        sim_ns: t,
                    })?;
                    let mut s = truth_pub.loan()?;
                    *s = sim.true_state();
                    s.send(Stamp {
                        source_ns: now(&clock),
                        sim_ns: t,
                    })?;
                    if t >= next_grid {
                        let mut g = grid_pub.loan()?;
                        sim.nav_grid(&mut g);
                        g.send(Stamp {
                            source_ns: now(&clock),
                            sim_ns: t,
                        })?;
                        next_grid += 1_000_000_000;
                    }
                    sim.step(dt_ns);
                    Ok(())
                })();
                match result {
                    Ok(()) => Control::Continue,
                    Err(e) => {
                        eprintln!("sim: {e:#}");
                        Control::Stop
                    }
                }
            }
        })?;
    wait_for_stop(&stop, || exec.is_finished());
    let summary = exec.join()?;
    eprintln!("sim: {summary}");
    Ok(())
}

/// `vpsom node mapper`: integrates every depth frame (read in place) with its detections and
/// the newest estimated state; publishes the object map at `rates.map_hz` (simulated) and the
/// exploration grid, both written in place into loaned samples.
pub fn mapper_node(args: &RunArgs, cfg: &Config) -> anyhow::Result<()> {
    let stop = stop_flag()?;
    let sched = runtime::executor::apply_sched(
        "mapper",
        &runtime::executor::ExecutorConfig {
            policy: if cfg.run.mapper_priority > 0 {
                runtime::executor::SchedPolicy::Fifo
            } else {
                runtime::executor::SchedPolicy::Other
            },
            priority: cfg.run.mapper_priority.max(1),
            ..cfg.executor.clone()
        },
    );
    eprintln!("mapper: {sched}");
    let clock = MonotonicClock::new();
    let ctx = PortContext::with_namespace(&cfg.ports, "mapper", &args.namespace)?;
    let depth = ctx.subscriber::<DepthFrame>(topics::DEPTH)?;
    let dets = ctx.subscriber::<Detections>(topics::DETECTIONS)?;
    let state_sub = ctx.subscriber::<RobotState>(topics::STATE)?;
    let map_pub = ctx.publisher::<ObjectMap>(topics::MAP)?;
    let grid_pub = ctx.publisher::<OccupancyGrid>(topics::MAP_GRID)?;
    let mut mapper = Mapper::new(&cfg.mapper, &cfg.camera.camera())?;
    let map_period = (1e9 / cfg.rates.map_hz).round() as u64;
    let (mut state, mut next_map) = (RobotState::default(), 0u64);
    let mut pending: Option<Received<Detections>> = None;
    while !stop.load(Ordering::Relaxed) {
        let frame = match depth.wait(Duration::from_millis(200)) {
            Ok(Some(f)) => f,
            Ok(None) => continue,
            // A stop signal interrupts the wait: leave the loop cleanly.
            Err(_) if stop.load(Ordering::Relaxed) => break,
            Err(e) => return Err(e.into()),
        };
        if let Some(s) = state_sub.latest()? {
            state = *s;
        }
        // The detections of this frame follow it closely; older ones are skipped.
        let deadline = Instant::now() + Duration::from_millis(500);
        let seq = frame.header.seq;
        let det = loop {
            let candidate = match pending.take() {
                Some(d) => Some(d),
                None => dets.receive()?,
            };
            match candidate {
                Some(d) if d.frame_seq == seq => break Some(d),
                Some(d) if d.frame_seq > seq => {
                    pending = Some(d);
                    break None;
                }
                Some(_) => continue,
                None => {
                    if Instant::now() > deadline || stop.load(Ordering::Relaxed) {
                        break None;
                    }
                    pending = dets.wait(Duration::from_millis(20))?;
                }
            }
        };
        let Some(det) = det else {
            eprintln!("mapper: no detections for frame {}", frame.header.seq);
            continue;
        };
        if let Err(e) = mapper.integrate(&frame, &det, &state) {
            eprintln!("mapper: frame {}: {e}", frame.header.seq);
        }
        let t = frame.header.sim_time_ns;
        if t >= next_map {
            let mut m = map_pub.loan()?;
            mapper.write_map(&mut m, t);
            m.send(Stamp {
                source_ns: now(&clock),
                sim_ns: t,
            })?;
            let mut g = grid_pub.loan()?;
            mapper.write_grid(&mut g);
            g.send(Stamp {
                source_ns: now(&clock),
                sim_ns: t,
            })?;
            next_map = t + map_period;
        }
    }
    Ok(())
}

/// The LBV thread's executor settings: `[executor]` with every cycle traced, the LBV budget, and
/// `[run] lbv_cpu` / `lbv_backup_cpu` when set.
fn lbv_executor_config(cfg: &Config, budget_fraction: f64) -> runtime::executor::ExecutorConfig {
    let mut e = runtime::executor::ExecutorConfig {
        trace: runtime::executor::EventTrace::All,
        budget_fraction,
        ..cfg.executor.clone()
    };
    if let Ok(cpu) = usize::try_from(cfg.run.lbv_cpu) {
        e.cpus = vec![cpu];
    }
    if cfg.run.lbv_backup_cpu >= 0 {
        e.backup_cpu = cfg.run.lbv_backup_cpu;
    }
    e
}

/// `vpsom node planner`: the LBV on a deadline-monitored periodic thread at `planner.lbv_hz`
/// (simulated); chassis-goal rounds (GBV evaluation) on the low-priority worker pool, polled
/// without waiting. Publishes neck goals, nav goals, decisions and deadline events; exits 0
/// when the planner finishes.
pub fn planner_node(args: &RunArgs, cfg: &Config) -> anyhow::Result<()> {
    let stop = stop_flag()?;
    let (events_tx, events_rx) = crossbeam::channel::bounded::<DeadlineEvent>(1024);
    let (cfg2, ns, gbv_load) = (cfg.clone(), args.namespace.clone(), args.gbv_load);
    let finished = Arc::new(AtomicBool::new(false));
    let finished2 = Arc::clone(&finished);
    let period = wall_period(cfg.planner.lbv_hz, args.time_scale);
    // The budget is execution time on this machine: wall milliseconds, whatever the time scale.
    let budget_fraction = (cfg.planner.lbv_budget_ms * 1e-3 / period.as_secs_f64()).min(1.0);
    let exec = Executor::builder("lbv", period)
        .config(&lbv_executor_config(cfg, budget_fraction))
        .events(events_tx)
        .spawn(move || {
            let mut host = match PlannerHost::new(&cfg2, &ns, gbv_load, events_rx) {
                Ok(h) => {
                    h.connect_inputs(INPUT_WAIT);
                    Some(h)
                }
                Err(e) => {
                    eprintln!("planner: {e:#}");
                    None
                }
            };
            move |_cycle| {
                let Some(h) = host.as_mut() else {
                    return Control::Stop;
                };
                match h.cycle() {
                    Ok(true) => Control::Continue,
                    Ok(false) => {
                        finished2.store(true, Ordering::Relaxed);
                        Control::Stop
                    }
                    Err(e) => {
                        eprintln!("planner: {e:#}");
                        Control::Stop
                    }
                }
            }
        })?;
    wait_for_stop(&stop, || exec.is_finished());
    let summary = exec.join()?;
    eprintln!("planner: {summary}");
    if !finished.load(Ordering::Relaxed) && !stop.load(Ordering::Relaxed) {
        bail!("planner thread stopped before the session ended");
    }
    Ok(())
}

/// What the planner's worker pool returns.
enum Work {
    /// A planning round (GBV, frontier or coverage).
    Round(JobOutput),
    /// A [`GbvLoad`] evaluation, handing its map buffer back.
    Load(Box<ObjectMap>),
}

/// Full GBV load for deadline testing (`vpsom run --gbv-load N`): whenever no load job is in
/// the pool, `N` GBV candidates (full F(v) with the GBV's α, β) are evaluated there on a copy of
/// the newest map, on rings around its objects, and the results discarded. The pool's threads
/// then stay busy for the whole run, as with back-to-back GBV rounds, while the LBV thread
/// must keep its deadlines. Real planning rounds still run (queued beside the load).
struct GbvLoad {
    params: GbvParams,
    candidates: usize,
    /// The map buffer, `None` while a load job holds it.
    spare: Option<Box<ObjectMap>>,
    /// Load jobs finished.
    jobs: u64,
}

impl GbvLoad {
    fn new(cfg: &Config, candidates: usize) -> Self {
        Self {
            params: GbvParams {
                candidates,
                ..GbvParams::new(&cfg.planner, &cfg.camera)
            },
            candidates,
            spare: Some(boxed_zeroed()),
            jobs: 0,
        }
    }

    /// The next load job, if none is in the pool.
    fn next(&mut self, map: &ObjectMap) -> Option<impl FnOnce() -> Work + Send + 'static> {
        let mut buf = self.spare.take()?;
        copy_map(map, &mut buf);
        let (params, n) = (self.params, self.candidates);
        Some(move || {
            let poses = load_poses(&buf, n, params.safe_distance);
            std::hint::black_box(gbv::evaluate_poses(&buf, &poses, None, &params));
            Work::Load(buf)
        })
    }

    fn done(&mut self, buf: Box<ObjectMap>) {
        self.spare = Some(buf);
        self.jobs += 1;
    }
}

/// `n` base poses `[x, y, yaw]` on rings around the map's objects in turn (around the origin
/// if the map is empty), each facing its object's centre.
fn load_poses(map: &ObjectMap, n: usize, safe_distance: f32) -> Vec<[f32; 3]> {
    let objects = map.objects();
    (0..n)
        .map(|i| {
            let (c, r) = match objects.get(i % objects.len().max(1)) {
                Some(o) => (o.center, 0.5 * o.size[0].max(o.size[1]) + safe_distance),
                None => ([0.0; 3], 1.0 + safe_distance),
            };
            let a = std::f32::consts::TAU * i as f32 / n as f32;
            let (sin, cos) = a.sin_cos();
            let yaw = crate::geom::wrap_angle(a + std::f32::consts::PI);
            [c[0] + r * cos, c[1] + r * sin, yaw]
        })
        .collect()
}

/// How long the planner waits for its inputs' publishers before its first cycle.
const INPUT_WAIT: Duration = Duration::from_secs(10);

struct PlannerHost {
    clock: MonotonicClock,
    planner: Box<dyn ViewPlanner>,
    pool: WorkerPool<Work>,
    pending: Option<planner::PlannerJob>,
    /// A planning job is in the pool.
    job_outstanding: bool,
    load: Option<GbvLoad>,
    /// When the job in the pool was submitted (for the GBV round time), clock ns.
    submitted_ns: u64,
    /// Duration of the newest finished job (submission to result), ns.
    job_ns: u64,
    map_sub: Subscriber<ObjectMap>,
    state_sub: Subscriber<RobotState>,
    nav_sub: Subscriber<OccupancyGrid>,
    explore_sub: Subscriber<OccupancyGrid>,
    map: Option<Received<ObjectMap>>,
    nav: Option<Received<OccupancyGrid>>,
    explore: Option<Received<OccupancyGrid>>,
    empty_map: Box<ObjectMap>,
    empty_grid: Box<OccupancyGrid>,
    state: RobotState,
    neck_pub: runtime::ports::Publisher<NeckGoal>,
    nav_pub: runtime::ports::Publisher<NavGoal>,
    decision_pub: runtime::ports::Publisher<PlannerDecision>,
    deadline_pub: runtime::ports::Publisher<DeadlineEvent>,
    events: crossbeam::channel::Receiver<DeadlineEvent>,
    _ctx: PortContext,
}

impl PlannerHost {
    fn new(
        cfg: &Config,
        ns: &str,
        gbv_load: usize,
        events: crossbeam::channel::Receiver<DeadlineEvent>,
    ) -> anyhow::Result<Self> {
        let ctx = PortContext::with_namespace(&cfg.ports, "planner", ns)?;
        Ok(Self {
            clock: MonotonicClock::new(),
            planner: planner::make_planner(&cfg.planner, &cfg.camera),
            pool: WorkerPool::new("gbv", &cfg.executor.pool)?,
            pending: None,
            job_outstanding: false,
            load: (gbv_load > 0).then(|| GbvLoad::new(cfg, gbv_load)),
            submitted_ns: 0,
            job_ns: 0,
            map_sub: ctx.subscriber(topics::MAP)?,
            state_sub: ctx.subscriber(topics::STATE)?,
            nav_sub: ctx.subscriber(topics::NAV_GRID)?,
            explore_sub: ctx.subscriber(topics::MAP_GRID)?,
            map: None,
            nav: None,
            explore: None,
            empty_map: boxed_zeroed(),
            empty_grid: boxed_zeroed(),
            state: RobotState::default(),
            neck_pub: ctx.publisher(topics::NECK_GOAL)?,
            nav_pub: ctx.publisher(topics::NAV_GOAL)?,
            decision_pub: ctx.publisher(topics::DECISION)?,
            deadline_pub: ctx.publisher(topics::DEADLINE)?,
            events,
            _ctx: ctx,
        })
    }

    /// Before the first cycle: wait (up to `timeout`) for a publisher on every input and map
    /// its shared memory now, so no LBV cycle pays for connecting (which, under `mlockall`,
    /// faults in the whole segment: tens of ms). Inputs still missing connect lazily later.
    fn connect_inputs(&self, timeout: Duration) {
        let deadline = Instant::now() + timeout;
        loop {
            let counts = [
                self.state_sub.connect(),
                self.map_sub.connect(),
                self.nav_sub.connect(),
                self.explore_sub.connect(),
            ];
            let missing: Vec<&str> = counts
                .iter()
                .zip([
                    topics::STATE,
                    topics::MAP,
                    topics::NAV_GRID,
                    topics::MAP_GRID,
                ])
                .filter(|(c, _)| !matches!(c, Ok(n) if *n > 0))
                .map(|(_, topic)| topic)
                .collect();
            if missing.is_empty() {
                return;
            }
            if Instant::now() >= deadline {
                eprintln!(
                    "planner: no publisher yet on {} after {timeout:?}; connecting on first receive",
                    missing.join(", ")
                );
                return;
            }
            std::thread::sleep(Duration::from_millis(10));
        }
    }

    /// One LBV cycle; `Ok(false)` when the session is over.
    fn cycle(&mut self) -> anyhow::Result<bool> {
        // Newest inputs, held in place (zero-copy) until a newer sample arrives.
        if let Some(m) = self.map_sub.latest()? {
            self.map = Some(m);
        }
        if let Some(g) = self.nav_sub.latest()? {
            self.nav = Some(g);
        }
        if let Some(g) = self.explore_sub.latest()? {
            self.explore = Some(g);
        }
        let Some(s) = self.state_sub.latest()? else {
            self.forward_events()?;
            return Ok(true);
        };
        self.state = *s;
        drop(s);
        let t = self.state.header.sim_time_ns;
        let map: &ObjectMap = self.map.as_deref().unwrap_or(&self.empty_map);

        // Local best view: never waits for the pool, no allocation in steady state.
        let start = self.clock.now_ns();
        let neck = self.planner.neck_goal(map, &self.state, t);
        let eval_ns = self.clock.now_ns() - start;
        let mut n = self.neck_pub.loan()?;
        *n = neck;
        n.map_seq = map.header.seq;
        n.frame_stamp_ns = map.last_frame_stamp_ns;
        n.send(Stamp {
            source_ns: self.clock.now_ns(),
            sim_ns: t,
        })?;
        let mut d = self.decision_pub.loan()?;
        if self.planner.lbv_decision(&mut d) {
            d.map_seq = map.header.seq;
            d.eval_ns = eval_ns;
            d.send(Stamp {
                source_ns: self.clock.now_ns(),
                sim_ns: t,
            })?;
        } else {
            drop(d);
        }

        // Chassis goals: rounds computed on the low-priority pool.
        let mut step = None;
        while let Some(done) = self.pool.try_recv() {
            match done
                .result
                .map_err(|p| anyhow::anyhow!("planning job panicked: {}", p.0))?
            {
                Work::Round(out) => {
                    self.job_ns = self.clock.now_ns().saturating_sub(self.submitted_ns);
                    self.job_outstanding = false;
                    step = Some(self.planner.job_done(out, t));
                }
                Work::Load(buffer) => {
                    if let Some(l) = self.load.as_mut() {
                        l.done(buffer);
                    }
                }
            }
        }
        if step.is_none() && self.pending.is_none() && !self.job_outstanding {
            let nav: &OccupancyGrid = self.nav.as_deref().unwrap_or(&self.empty_grid);
            let explore: &OccupancyGrid = self.explore.as_deref().unwrap_or(&self.empty_grid);
            let inputs = PlannerInputs {
                map,
                state: &self.state,
                nav,
                explore,
            };
            step = Some(self.planner.next_goal(&inputs, t));
        }
        // A load job never takes the last slot, so a planning job always finds room.
        if let Some(l) = self.load.as_mut()
            && self.pool.outstanding() + 1 < self.pool.capacity()
            && let Some(work) = l.next(map)
            && self.pool.try_submit(work).is_err()
        {
            bail!("worker pool refused a load job although it had room");
        }
        let go_on = self.handle(step.unwrap_or(Step::Wait), t)?;
        if let Some(job) = self.pending.take() {
            self.submitted_ns = self.clock.now_ns();
            match self.pool.try_submit(move || Work::Round(job.run())) {
                Ok(_) => self.job_outstanding = true,
                Err(_) => bail!(
                    "worker pool refused a planning job with {} of {} slots taken",
                    self.pool.outstanding(),
                    self.pool.capacity()
                ),
            }
        }
        self.forward_events()?;
        Ok(go_on)
    }

    fn handle(&mut self, step: Step, t: u64) -> anyhow::Result<bool> {
        match step {
            Step::Wait => {}
            Step::Compute(job) => self.pending = Some(job),
            Step::Goal(goal) => {
                let mut g = self.nav_pub.loan()?;
                *g = goal;
                g.send(Stamp {
                    source_ns: self.clock.now_ns(),
                    sim_ns: t,
                })?;
                self.publish_gbv_decision(t, None)?;
            }
            Step::Finished(summary) => {
                eprintln!("planner: {summary}");
                if let Some(l) = &self.load {
                    eprintln!(
                        "planner: GBV load: {} jobs of {} candidates evaluated",
                        l.jobs, l.candidates
                    );
                }
                self.publish_gbv_decision(t, Some(summary.status.code()))?;
                return Ok(false);
            }
        }
        Ok(true)
    }

    fn publish_gbv_decision(&mut self, t: u64, final_state: Option<u8>) -> anyhow::Result<()> {
        let decision = self.planner.take_decision();
        if decision.is_none() && final_state.is_none() {
            return Ok(());
        }
        let mut d = self.decision_pub.loan()?;
        if let Some(src) = decision {
            let n = src.count as usize;
            d.candidates[..n].copy_from_slice(&src.candidates[..n]);
            (d.count, d.evaluated, d.cluster_id, d.map_seq, d.eval_ns) = (
                src.count,
                src.evaluated,
                src.cluster_id,
                src.map_seq,
                // The round time on the pool (submission to result), unless the planner
                // timed its own evaluation.
                if src.eval_ns > 0 {
                    src.eval_ns
                } else {
                    self.job_ns
                },
            );
        }
        d.kind = decision_kind::GBV;
        d.state = final_state.unwrap_or(planner_state::RUNNING);
        d.send(Stamp {
            source_ns: self.clock.now_ns(),
            sim_ns: t,
        })?;
        Ok(())
    }

    fn forward_events(&mut self) -> anyhow::Result<()> {
        while let Ok(e) = self.events.try_recv() {
            let mut l = self.deadline_pub.loan()?;
            *l = e;
            l.header.sim_time_ns = self.state.header.sim_time_ns;
            let sim_ns = self.state.header.sim_time_ns;
            l.send(Stamp {
                source_ns: e.header.stamp_ns,
                sim_ns,
            })?;
        }
        Ok(())
    }
}

/// `vpsom node recorder`: subscribes to every topic and records it to `OUT/trace.mcap`.
pub fn recorder_node(args: &RunArgs, cfg: &Config) -> anyhow::Result<()> {
    let stop = stop_flag()?;
    let scene = Scene::builtin_or_load(&args.scene)?;
    let setup = recorder_setup(&scene, cfg);
    std::fs::create_dir_all(&args.out)?;
    let rec = Recorder::create(&args.out.join("trace.mcap"), &cfg.recorder, setup)?;
    let h = rec.handle();
    let ctx = PortContext::with_namespace(&cfg.ports, "recorder", &args.namespace)?;
    let depth = ctx.subscriber::<DepthFrame>(topics::DEPTH)?;
    let state = ctx.subscriber::<RobotState>(topics::STATE)?;
    let truth = ctx.subscriber::<RobotState>(topics::TRUTH)?;
    let map = ctx.subscriber::<ObjectMap>(topics::MAP)?;
    let decision = ctx.subscriber::<PlannerDecision>(topics::DECISION)?;
    let nav = ctx.subscriber::<NavGoal>(topics::NAV_GOAL)?;
    let neck = ctx.subscriber::<NeckGoal>(topics::NECK_GOAL)?;
    let deadline = ctx.subscriber::<DeadlineEvent>(topics::DEADLINE)?;
    while !stop.load(Ordering::Relaxed) {
        let mut any = false;
        while let Some(s) = depth.receive()? {
            h.record_depth(&s);
            any = true;
        }
        while let Some(s) = state.receive()? {
            h.record_state(&s);
            any = true;
        }
        while let Some(s) = truth.receive()? {
            h.record_true_state(&s);
            any = true;
        }
        while let Some(s) = map.receive()? {
            h.record_map(&s);
            any = true;
        }
        while let Some(s) = decision.receive()? {
            h.record_decision(&s);
            any = true;
        }
        while let Some(s) = nav.receive()? {
            h.record_nav_goal(&s);
            any = true;
        }
        while let Some(s) = neck.receive()? {
            h.record_neck_goal(&s);
            any = true;
        }
        while let Some(s) = deadline.receive()? {
            h.record_deadline(&s);
            any = true;
        }
        if !any {
            std::thread::sleep(Duration::from_millis(2));
        }
    }
    let missed = depth.gaps() + state.gaps() + truth.gaps() + map.gaps() + decision.gaps();
    let summary = rec.finish()?;
    eprintln!(
        "recorder: wrote {} messages, dropped {} in the recorder, {} samples overwritten before \
         they were read",
        summary.written.values().sum::<u64>(),
        summary.drops.total_dropped(),
        missed
    );
    Ok(())
}

/// What the recorder needs to draw: the scene's true cuboids and the camera geometry.
pub fn recorder_setup(scene: &Scene, cfg: &Config) -> RecorderSetup {
    RecorderSetup {
        scene: scene.name.clone(),
        mount: MountGeometry {
            height: cfg.camera.mount.height,
            forward_offset: cfg.camera.mount.forward_offset,
            hfov_deg: cfg.camera.hfov_deg,
            vfov_deg: cfg.camera.vfov_deg,
        },
        truth: scene
            .objects
            .iter()
            .map(|o| TruthBox {
                name: o.name.clone(),
                class: o.class.clone(),
                center: o.center.to_array(),
                size: o.size.to_array(),
                yaw: o.yaw,
            })
            .collect(),
    }
}

fn wait_for_stop(stop: &AtomicBool, finished: impl Fn() -> bool) {
    while !stop.load(Ordering::Relaxed) && !finished() {
        std::thread::sleep(Duration::from_millis(20));
    }
}

// ------------------------------------------------------------------------------------------
// Launcher
// ------------------------------------------------------------------------------------------

/// What a run produced.
#[derive(Debug)]
pub struct RunOutcome {
    /// The metrics written to `metrics.json`.
    pub metrics: eval::Metrics,
    /// Why the run ended.
    pub reason: String,
    /// Whether a node failed for good.
    pub failed: bool,
}

/// `vpsom run`: launch the node processes, watch them, show a status line, score the session.
pub fn run(args: &RunArgs, cfg: &Config, exe: &Path) -> anyhow::Result<RunOutcome> {
    let stop = stop_flag()?;
    let scene = Scene::builtin_or_load(&args.scene)?;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating output directory {}", args.out.display()))?;
    let mut launcher = Launcher::new(
        &format!("launcher-{}", args.namespace),
        &runtime::ports::iceoryx2_config(),
    )?;
    if launcher.stale_nodes_removed_at_start() > 0 {
        eprintln!(
            "removed stale shared-memory resources of {} dead node(s) from earlier runs",
            launcher.stale_nodes_removed_at_start()
        );
    }
    // Subscribe before the nodes start so no decision or truth sample is missed.
    let ctx = PortContext::with_namespace(&cfg.ports, "run", &args.namespace)?;
    let truth = ctx.subscriber::<RobotState>(topics::TRUTH)?;
    let map_sub = ctx.subscriber::<ObjectMap>(topics::MAP)?;
    let decisions = ctx.subscriber::<PlannerDecision>(topics::DECISION)?;
    let deadline = ctx.subscriber::<DeadlineEvent>(topics::DEADLINE)?;
    let nav = ctx.subscriber::<NavGoal>(topics::NAV_GOAL)?;
    for role in ["recorder", "sim", "mapper", "planner"] {
        launcher.spawn(ChildSpec {
            name: role.into(),
            program: exe.to_path_buf(),
            args: args.child_args(role),
            max_restarts: cfg.run.max_restarts,
            inherit_stdout: false,
        })?;
    }
    let start = Instant::now();
    let mut log = SessionLog::starting_at(0);
    let mut map = boxed_zeroed::<ObjectMap>();
    let (mut sim_ns, mut misses, mut lbv_cycles, mut goal) = (0u64, 0u64, 0u64, None::<NavGoal>);
    let mut final_state = None;
    let mut failed = false;
    let mut last_status = Instant::now();
    let max_sim_ns = (cfg.run.max_sim_s * 1e9) as u64;
    let reason = loop {
        while let Some(s) = truth.receive()? {
            sim_ns = s.header.sim_time_ns;
            log.observe_truth(&s);
        }
        if let Some(m) = map_sub.latest()? {
            copy_map(&m, &mut map);
        }
        while let Some(d) = decisions.receive()? {
            log.observe_decision(&d);
            if d.kind == decision_kind::GBV && d.state != planner_state::RUNNING {
                final_state = Some(d.state);
            }
        }
        while let Some(e) = deadline.receive()? {
            if e.thread_name() == "lbv" {
                lbv_cycles += 1;
                misses += u64::from(e.missed);
            }
        }
        while let Some(g) = nav.receive()? {
            goal = Some(*g);
        }
        for ev in launcher.poll() {
            eprintln!("\n{ev}");
            match ev {
                ChildEvent::Failed { .. } => failed = true,
                ChildEvent::Finished { ref name } if name == "planner" && final_state.is_none() => {
                    final_state = Some(planner_state::NO_CANDIDATES);
                }
                _ => {}
            }
        }
        if failed {
            break "a node failed (see above)".to_string();
        }
        if let Some(s) = final_state {
            break if s == planner_state::TERMINATED {
                "planner terminated: every cluster complete".into()
            } else {
                "planner stopped: no reachable candidate".into()
            };
        }
        if stop.load(Ordering::Relaxed) {
            break "interrupted".into();
        }
        if sim_ns >= max_sim_ns {
            break format!("simulated-time limit {} s", cfg.run.max_sim_s);
        }
        if last_status.elapsed() >= Duration::from_secs(1) {
            last_status = Instant::now();
            let objs = map.objects();
            eprint!(
                "\r{:>5.0}s wall {:>6.1}s sim | objects {:>2} mapped, {:>2} complete | GBV {} | \
                 LBV deadline misses {}/{}   ",
                start.elapsed().as_secs_f64(),
                sim_ns as f64 * 1e-9,
                objs.iter().filter(|o| !o.is_background()).count(),
                objs.iter()
                    .filter(|o| !o.is_background() && o.is_complete())
                    .count(),
                goal.map_or("-".to_string(), |g| format!(
                    "#{} ({:.1}, {:.1})",
                    g.goal_id, g.pose[0], g.pose[1]
                )),
                misses,
                lbv_cycles
            );
            let _ = std::io::stderr().flush();
        }
        std::thread::sleep(Duration::from_millis(10));
    };
    eprintln!("\nstopping: {reason}");
    for (name, exit) in launcher.stop_all(Duration::from_secs_f64(cfg.run.stop_grace_s)) {
        if let Some(e) = exit {
            eprintln!("  {name}: {e}");
        }
    }
    // Read what arrived while the nodes stopped (the final map in particular).
    if let Some(m) = map_sub.latest()? {
        copy_map(&m, &mut map);
    }
    while let Some(s) = truth.receive()? {
        log.observe_truth(&s);
    }
    log.add_deadline_misses(misses);
    let terminated = final_state == Some(planner_state::TERMINATED);
    log.finish(sim_ns, terminated, &reason);
    let run = RunInfo {
        scene: scene.name.clone(),
        planner: args.planner.clone(),
        seed: args.seed,
    };
    let gt = super::lockstep::ground_truth(&scene);
    let est = eval::estimates_from_map(&map);
    let metrics = log.metrics(&run, &gt, &est, &MatchParams::default());
    let plot = log.plot_input(&run, super::lockstep::room(&scene), &gt, &est, &metrics);
    eval::write_run_outputs(&args.out, &metrics, &est, &plot)?;
    Ok(RunOutcome {
        metrics,
        reason,
        failed,
    })
}

fn copy_map(src: &ObjectMap, dst: &mut ObjectMap) {
    dst.header = src.header;
    dst.last_frame_seq = src.last_frame_seq;
    dst.last_frame_stamp_ns = src.last_frame_stamp_ns;
    dst.count = src.count;
    dst.eps_sopm = src.eps_sopm;
    let n = src.objects().len();
    dst.objects[..n].copy_from_slice(&src.objects[..n]);
}
