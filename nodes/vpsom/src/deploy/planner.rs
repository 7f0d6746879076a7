//! `vpsom node planner`: the LBV on a deadline-monitored periodic executor thread (the real-time
//! path), chassis-goal rounds on the low-priority worker pool, and the GBV load used for
//! deadline testing ([`GbvLoad`]).

use super::RunArgs;
use super::health::report_input;
use super::host::{self, Flow, HostError, NodeHost, Pace, Periodic};
use crate::config::Config;
use crate::planner::gbv::{self, GbvParams};
use crate::planner::{self, JobOutput, PlannerInputs, Step, ViewPlanner};
use crate::step::gbv_cycle;
use crate::topics;
use runtime::clock::{Clock, MonotonicClock};
use runtime::executor::{EventTrace, ExecutorConfig};
use runtime::pool::WorkerPool;
use runtime::ports::{PortContext, Publisher, Received, Stamp, Subscriber};
use shm_types::{
    DeadlineEvent, NavGoal, NeckGoal, NodeHealth, ObjectMap, OccupancyGrid, PlannerDecision,
    RobotState, boxed_zeroed, decision_kind, planner_state,
};
use std::sync::atomic::AtomicBool;
use std::time::{Duration, Instant};

/// `vpsom node planner`: the LBV on a deadline-monitored periodic thread at `planner.lbv_hz`
/// (simulated); chassis-goal rounds (GBV evaluation) on the low-priority worker pool, polled
/// without waiting. Publishes neck goals, nav goals, decisions and deadline events; exits 0
/// when the planner finishes.
pub fn planner_node(args: &RunArgs, cfg: &Config) -> Result<(), HostError> {
    let stop = host::stop_on_signals()?;
    let (events_tx, events_rx) = crossbeam::channel::bounded::<DeadlineEvent>(1024);
    let (cfg2, ns, gbv_load) = (cfg.clone(), args.namespace.clone(), args.gbv_load);
    let outcome_file = args.out.join(OUTCOME_FILE);
    let period = host::wall_period(cfg.planner.lbv_hz, args.time_scale);
    // The budget is execution time on this machine: wall milliseconds, whatever the time scale.
    let budget_fraction = (cfg.planner.lbv_budget_ms * 1e-3 / period.as_secs_f64()).min(1.0);
    let pace = Pace::Periodic(Periodic {
        thread: "lbv",
        period,
        config: lbv_executor_config(cfg, budget_fraction),
        events: Some(events_tx),
    });
    let ended = host::drive("planner", &stop, pace, move || {
        PlannerHost::new(&cfg2, &ns, gbv_load, events_rx, outcome_file)
    })?;
    if !ended.finished && !ended.interrupted {
        return Err(HostError::EndedEarly);
    }
    Ok(())
}

/// The LBV thread's executor settings: `[executor]` with every cycle traced, the LBV budget, and
/// `[run] lbv_cpu` / `lbv_backup_cpu` when set.
fn lbv_executor_config(cfg: &Config, budget_fraction: f64) -> ExecutorConfig {
    let mut e = ExecutorConfig {
        trace: EventTrace::All,
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
        buf.copy_from(map);
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

/// The file (in the run's output directory) where the planner node leaves its [`PlannerOutcome`]
/// for the launcher.
pub const OUTCOME_FILE: &str = "planner-outcome.json";

/// How the planner ended, as the planner node reports it to the launcher (the same fields the
/// lockstep host puts into `metrics.json`).
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct PlannerOutcome {
    /// Whether the planner's end condition holds (`Terminated`).
    pub terminated: bool,
    /// [`planner::Summary::reason`].
    pub reason: String,
    /// Whether the room was explored.
    pub explored: bool,
    /// Objects given up.
    pub objects_given_up: Vec<crate::eval::GivenUpEntry>,
}

/// How long the planner waits for its inputs' publishers before its first cycle.
const INPUT_WAIT: Duration = Duration::from_secs(10);

/// The planner, its pool and its ports.
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
    neck_pub: Publisher<NeckGoal>,
    nav_pub: Publisher<NavGoal>,
    decision_pub: Publisher<PlannerDecision>,
    deadline_pub: Publisher<DeadlineEvent>,
    events: crossbeam::channel::Receiver<DeadlineEvent>,
    outcome_file: std::path::PathBuf,
    ctx: PortContext,
    health_period: Duration,
}

impl PlannerHost {
    fn new(
        cfg: &Config,
        ns: &str,
        gbv_load: usize,
        events: crossbeam::channel::Receiver<DeadlineEvent>,
        outcome_file: std::path::PathBuf,
    ) -> Result<Self, HostError> {
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
            outcome_file,
            ctx,
            health_period: Duration::from_secs_f64(1.0 / cfg.run.health_hz),
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
}

impl NodeHost for PlannerHost {
    fn start(&mut self) {
        self.connect_inputs(INPUT_WAIT);
    }

    /// One LBV cycle; [`Flow::Done`] when the session is over.
    fn step(&mut self, _stop: &AtomicBool) -> Result<Flow, HostError> {
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
            return Ok(Flow::Idle);
        };
        self.state = *s;
        drop(s);
        let t = self.state.header.sim_time_ns;
        let map: &ObjectMap = self.map.as_deref().unwrap_or(&self.empty_map);

        // A finished chassis-goal round, taken after the LBV (polled first, so that the neck goal
        // can say so: `vpsom replay --check` follows the cycle's inputs).
        let mut round = None;
        while let Some(done) = self.pool.try_recv() {
            match done.result.map_err(|p| HostError::JobPanicked(p.0))? {
                Work::Round(out) => {
                    self.job_ns = self.clock.now_ns().saturating_sub(self.submitted_ns);
                    self.job_outstanding = false;
                    round = Some(out);
                }
                Work::Load(buffer) => {
                    if let Some(l) = self.load.as_mut() {
                        l.done(buffer);
                    }
                }
            }
        }

        // Local best view: never waits for the pool, no allocation in steady state.
        let start = self.clock.now_ns();
        let neck = self.planner.neck_goal(map, &self.state, t);
        let eval_ns = self.clock.now_ns() - start;
        let mut n = self.neck_pub.loan()?;
        *n = neck;
        n.map_seq = map.header.seq;
        n.frame_stamp_ns = map.last_frame_stamp_ns;
        n.round_done = round.is_some() as u32;
        n.state_seq = self.state.header.seq;
        n.nav_seq = self.nav.as_ref().map_or(0, |g| g.header.seq);
        n.explore_seq = self.explore.as_ref().map_or(0, |g| g.header.seq);
        n.send(host::stamp(&self.clock, t))?;
        let mut d = self.decision_pub.loan()?;
        if self.planner.lbv_decision(&mut d) {
            d.map_seq = map.header.seq;
            d.eval_ns = eval_ns;
            d.send(host::stamp(&self.clock, t))?;
        } else {
            drop(d);
        }

        // Chassis goals: rounds computed on the low-priority pool.
        let busy = self.pending.is_some() || self.job_outstanding;
        let inputs = || PlannerInputs {
            map,
            state: &self.state,
            nav: self.nav.as_deref().unwrap_or(&self.empty_grid),
            explore: self.explore.as_deref().unwrap_or(&self.empty_grid),
        };
        let step = gbv_cycle(&mut *self.planner, round, busy, inputs, t);
        // A load job never takes the last slot, so a planning job always finds room.
        if let Some(l) = self.load.as_mut()
            && self.pool.outstanding() + 1 < self.pool.capacity()
            && let Some(work) = l.next(map)
            && self.pool.try_submit(work).is_err()
        {
            return Err(HostError::LoadRefused);
        }
        // A late-joining base controller (a restarted sim) gets the current goal from the
        // topic's history, which iceoryx2 delivers only from the publisher's side.
        self.nav_pub.update_connections()?;
        let go_on = self.handle(step, t)?;
        if let Some(job) = self.pending.take() {
            self.submitted_ns = self.clock.now_ns();
            match self.pool.try_submit(move || Work::Round(job.run())) {
                Ok(_) => self.job_outstanding = true,
                Err(_) => {
                    return Err(HostError::JobRefused {
                        outstanding: self.pool.outstanding(),
                        capacity: self.pool.capacity(),
                    });
                }
            }
        }
        Ok(if go_on { Flow::Busy } else { Flow::Done })
    }

    /// Deadline events of the LBV thread, forwarded to their topic.
    fn health(&mut self) -> Result<(), HostError> {
        self.forward_events()
    }

    fn heartbeat(&self) -> Option<(&PortContext, Duration)> {
        Some((&self.ctx, self.health_period))
    }

    fn inputs(&self, h: &mut NodeHealth) {
        report_input(h, topics::MAP, &self.map_sub);
        report_input(h, topics::STATE, &self.state_sub);
        report_input(h, topics::NAV_GRID, &self.nav_sub);
        report_input(h, topics::MAP_GRID, &self.explore_sub);
    }
}

impl PlannerHost {
    fn handle(&mut self, step: Step, t: u64) -> Result<bool, HostError> {
        match step {
            Step::Wait => {}
            Step::Compute(job) => self.pending = Some(job),
            Step::Goal(goal) => {
                let mut g = self.nav_pub.loan()?;
                *g = goal;
                g.send(host::stamp(&self.clock, t))?;
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
                self.write_outcome(&summary);
                self.publish_gbv_decision(t, Some(summary.status.code()))?;
                return Ok(false);
            }
        }
        Ok(true)
    }

    /// Leave the outcome for the launcher (a failure to write is reported, not fatal: the
    /// launcher then falls back to the final state code).
    fn write_outcome(&self, summary: &planner::Summary) {
        let outcome = PlannerOutcome {
            terminated: summary.status == planner::PlannerStatus::Terminated,
            reason: summary.reason(),
            explored: summary.explored,
            objects_given_up: crate::lockstep::given_up_entries(&self.planner.given_up_objects()),
        };
        let written = serde_json::to_vec_pretty(&outcome)
            .map_err(std::io::Error::other)
            .and_then(|b| std::fs::write(&self.outcome_file, b));
        if let Err(e) = written {
            eprintln!("planner: writing {}: {e}", self.outcome_file.display());
        }
    }

    fn publish_gbv_decision(&mut self, t: u64, final_state: Option<u8>) -> Result<(), HostError> {
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
        d.send(host::stamp(&self.clock, t))?;
        Ok(())
    }

    fn forward_events(&mut self) -> Result<(), HostError> {
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
