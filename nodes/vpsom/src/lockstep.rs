//! The lockstep host: sim, mapper and planner stepped in one thread of one process on a
//! simulated clock, deterministic for a given seed, as fast as the CPU allows. Used by
//! `vpsom bench`, by the tests, and as the reference the multi-process host is compared with.
//!
//! Rates follow `config/default.toml` in simulated time: robot state at `rates.state_hz` (the
//! step), camera frames at `rates.camera_hz`, map publication at `rates.map_hz`, LBV at
//! `planner.lbv_hz`. GBV jobs run inline (the result is available on the same step), which is
//! what a host with an idle pool would see.
//!
//! A recorded session is complete: the recorder waits rather than drops
//! ([`Overflow::Wait`](runtime::recorder::Overflow::Wait)), so a step's messages are queued
//! before the simulated clock moves on, however far behind the writer is (a slow disk makes the
//! run slower, never the trace shorter), and `vpsom replay --check` has every input.

use crate::config::Config;
use crate::eval::{self, GtObject, MatchParams, Metrics, RunInfo, SessionLog};
use crate::planner::{self, PlannerKind, Summary, ViewPlanner};
use crate::sim::{Scene, Sim};
use crate::step::{NodeStep, Outputs};
use shm_types::{
    DepthFrame, Detections, NavGoal, NeckGoal, ObjectMap, OccupancyGrid, PlannerDecision,
    RobotState, boxed_zeroed,
};
use std::path::{Path, PathBuf};

/// Why a lockstep session could not run or be written.
#[derive(Debug, thiserror::Error)]
pub enum SessionError {
    /// The simulator could not be built.
    #[error(transparent)]
    Sim(#[from] crate::sim::SimError),
    /// A configuration section was refused (e.g. the mapper's).
    #[error(transparent)]
    Config(#[from] settings::ConfigError),
    /// The mapper refused a frame.
    #[error(transparent)]
    Mapper(#[from] crate::mapper::MapperError),
    /// The recorder failed.
    #[error(transparent)]
    Recorder(#[from] runtime::recorder::RecorderError),
    /// The metrics could not be serialized for the recorder.
    #[error(transparent)]
    Json(#[from] serde_json::Error),
    /// The outputs could not be written.
    #[error(transparent)]
    Eval(#[from] crate::eval::EvalError),
    /// Unknown planner in a label.
    #[error(transparent)]
    Planner(#[from] planner::UnknownPlanner),
    /// Unknown F(v) term in an ablation label.
    #[error(transparent)]
    Term(#[from] planner::UnknownTerm),
    /// Unknown sensing variant in a label.
    #[error(transparent)]
    Variant(#[from] crate::variants::UnknownVariant),
    /// The orbit experiment cannot run on this scene.
    #[error("orbit: {0}")]
    Orbit(String),
}

/// What to run.
#[derive(Debug, Clone)]
pub struct SessionSpec {
    /// The scene (ground truth; only the sim and the scoring see it).
    pub scene: Scene,
    /// Full configuration (`planner.kind` selects the planner).
    pub config: Config,
    /// Seed of every random process.
    pub seed: u64,
    /// Name of the planner in the outputs (e.g. `vpsom`, `vpsom-no-h_iou`).
    pub label: String,
    /// Give up after this much simulated time, seconds.
    pub max_sim_s: f64,
    /// Record the session to this MCAP file.
    pub record: Option<PathBuf>,
}

/// Messages the host handed to the recorder, per kind (to check a trace against).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Recorded {
    /// Depth frames.
    pub depth: u64,
    /// Estimated robot states.
    pub state: u64,
    /// True robot states.
    pub truth: u64,
    /// Object maps.
    pub map: u64,
    /// Planner decisions (GBV and LBV).
    pub decisions: u64,
    /// Nav goals.
    pub nav_goals: u64,
    /// Neck goals.
    pub neck_goals: u64,
}

/// Progress, reported about once per simulated second.
#[derive(Debug, Clone, Copy)]
pub struct Progress {
    /// Simulated time, seconds.
    pub sim_s: f64,
    /// Objects in the map (all classes).
    pub objects: u32,
    /// Foreground objects complete.
    pub complete: u32,
    /// Chassis goals issued so far.
    pub goals: u64,
}

/// Everything a session produced.
#[derive(Debug)]
pub struct SessionResult {
    /// The run's metrics (`metrics.json`).
    pub metrics: Metrics,
    /// The final map.
    pub map: Box<ObjectMap>,
    /// The logged trajectory and views.
    pub log: SessionLog,
    /// Planner summary.
    pub summary: Summary,
    /// Ground truth as scored.
    pub gt: Vec<GtObject>,
    /// Frames rendered.
    pub frames: u64,
    /// What was handed to the recorder (all zero without `record`).
    pub recorded: Recorded,
    /// The recorder's own summary (written, dropped), when recording.
    pub recorder: Option<runtime::recorder::RecorderSummary>,
    /// The final exploration grid (the mapper's, from depth).
    pub explore: Box<OccupancyGrid>,
    /// The navigation grid.
    pub nav: Box<OccupancyGrid>,
    /// The final estimated base pose.
    pub base: [f32; 3],
}

/// Ground truth of a scene in the scorer's terms.
pub fn ground_truth(scene: &Scene) -> Vec<GtObject> {
    scene
        .objects
        .iter()
        .map(|o| GtObject {
            name: o.name.clone(),
            class: o.class.clone(),
            background: o.background,
            center: o.center.to_array(),
            size: o.size.to_array(),
            yaw: o.yaw,
        })
        .collect()
}

/// The room outline for plots.
pub fn room(scene: &Scene) -> eval::Room {
    eval::Room {
        min: scene.room.min.into(),
        max: scene.room.max.into(),
    }
}

/// Run one session to termination (or `max_sim_s`), calling `progress` about once per second.
pub fn run_session(
    spec: &SessionSpec,
    progress: impl FnMut(&Progress),
) -> Result<SessionResult, SessionError> {
    session(spec, None, progress)
}

/// [`run_session`] with a hook that the recorder's writer thread calls before each message it
/// writes: tests make the writer slow with it (a busy disk) and check that the trace is still
/// complete. Without `spec.record` the hook is never called.
pub fn run_session_with_writer_hook(
    spec: &SessionSpec,
    hook: runtime::recorder::WriterHook,
    progress: impl FnMut(&Progress),
) -> Result<SessionResult, SessionError> {
    session(spec, Some(hook), progress)
}

fn session(
    spec: &SessionSpec,
    writer_hook: Option<runtime::recorder::WriterHook>,
    mut progress: impl FnMut(&Progress),
) -> Result<SessionResult, SessionError> {
    let cfg = &spec.config;
    let mut sim = Sim::new(spec.scene.clone(), cfg, spec.seed)?;
    let mut nodes = NodeStep::new(cfg)?;

    let mut frame = boxed_zeroed::<DepthFrame>();
    let mut dets = boxed_zeroed::<Detections>();
    let mut nav = boxed_zeroed::<OccupancyGrid>();
    let mut state = RobotState::default();
    sim.nav_grid(&mut nav);
    let recorder = match &spec.record {
        Some(path) => Some(runtime::recorder::Recorder::create(
            path,
            &cfg.recorder,
            runtime::recorder::RecorderSetup {
                host: "lockstep".into(),
                // The clock is simulated: wait for the writer, never drop.
                overflow: runtime::recorder::Overflow::Wait,
                writer_hook,
                ..super::deploy::recorder_setup(&spec.scene, cfg)
            },
        )?),
        None => None,
    };
    let rec = recorder.as_ref().map(|r| r.handle());
    let mut recorded = Recorded::default();
    if let Some(r) = &rec {
        r.record_nav_grid(&nav);
    }

    let period = |hz: f64| (1e9 / hz).round() as u64;
    let dt = period(cfg.rates.state_hz);
    let cam_p = period(cfg.rates.camera_hz);
    let (mut next_cam, mut next_report) = (0u64, 0u64);
    let max_ns = (spec.max_sim_s * 1e9) as u64;
    let mut log = SessionLog::starting_at(0);
    let mut frames = 0u64;
    let mut finished: Option<Summary> = None;

    // A writer that stopped (an I/O error) ends the session: `finish` below returns its error.
    let writing = |r: &Option<runtime::recorder::RecorderHandle>| {
        r.as_ref().is_none_or(|r| !r.writer_stopped())
    };
    while finished.is_none() && sim.time_ns() <= max_ns && writing(&rec) {
        let t = sim.time_ns();
        sim.robot_state(&mut state);
        if t >= next_cam {
            sim.render(&mut frame, &mut dets, t);
            log.observe_visibility(sim.visibility());
            frames += 1;
            sim.robot_state(&mut state);
            nodes.integrate(&frame, &dets, &state)?;
            if let Some(r) = &rec {
                r.record_depth(&frame);
                r.record_detections(&dets);
                recorded.depth += 1;
            }
            next_cam += cam_p;
        }
        let mut out = ToSim {
            sim: &mut sim,
            log: &mut log,
            rec: rec.as_ref(),
            recorded: &mut recorded,
        };
        finished = nodes.tick(t, &state, &nav, &mut out);
        let truth = sim.true_state();
        log.observe_truth(&truth);
        if let Some(r) = &rec {
            r.record_state(&state);
            r.record_true_state(&truth);
            recorded.state += 1;
            recorded.truth += 1;
        }
        if t >= next_report {
            progress(&progress_of(t, &nodes.map, nodes.planner.as_ref()));
            next_report += 1_000_000_000;
        }
        sim.step(dt);
    }

    let NodeStep {
        mut mapper,
        planner,
        mut map,
        explore,
        ..
    } = nodes;
    let end = sim.time_ns().min(max_ns);
    let summary = finished.unwrap_or_else(|| planner.summary());
    let terminated = summary.status == planner::PlannerStatus::Terminated;
    let reason = match finished {
        Some(s) => s.reason(),
        None => format!("time limit {} s", spec.max_sim_s),
    };
    mapper.write_map(&mut map, end);
    log.finish(end, terminated, &reason);
    log.planner_outcome(
        summary.explored,
        given_up_entries(&planner.given_up_objects()),
    );
    log.planner_recoveries(summary.recovery.started);
    let gt = ground_truth(&spec.scene);
    let run = RunInfo {
        scene: spec.scene.name.clone(),
        planner: spec.label.clone(),
        seed: spec.seed,
    };
    let est = eval::estimates_from_map(&map);
    let metrics = log.metrics(&run, &gt, &est, &MatchParams::default());
    if let Some(r) = &rec {
        r.record_metrics(end, serde_json::to_value(&metrics)?);
    }
    drop(rec);
    let recorder = recorder.map(|r| r.finish()).transpose()?;
    Ok(SessionResult {
        metrics,
        map,
        log,
        summary,
        gt,
        frames,
        recorded,
        recorder,
        explore,
        nav,
        base: state.base_pose,
    })
}

/// The lockstep host's [`Outputs`]: goals to the simulator, decisions and goals to the
/// session log, everything to the recorder (if any).
struct ToSim<'a> {
    sim: &'a mut Sim,
    log: &'a mut SessionLog,
    rec: Option<&'a runtime::recorder::RecorderHandle>,
    recorded: &'a mut Recorded,
}

impl Outputs for ToSim<'_> {
    fn map(&mut self, map: &ObjectMap) {
        if let Some(r) = self.rec {
            r.record_map(map);
            self.recorded.map += 1;
        }
    }

    fn neck(&mut self, neck: &NeckGoal) {
        self.sim.set_neck_goal(neck);
        if let Some(r) = self.rec {
            r.record_neck_goal(neck);
            self.recorded.neck_goals += 1;
        }
    }

    fn decision(&mut self, decision: &PlannerDecision) {
        self.log.observe_decision(decision);
        if let Some(r) = self.rec {
            r.record_decision(decision);
            self.recorded.decisions += 1;
        }
    }

    fn nav(&mut self, goal: &NavGoal) {
        // A refused goal is reported back through RobotState (UNREACHABLE).
        let _ = self.sim.set_nav_goal(goal);
        self.log.observe_goal(goal.kind);
        if let Some(r) = self.rec {
            r.record_nav_goal(goal);
            self.recorded.nav_goals += 1;
        }
    }
}

/// The planner's given-up objects as `metrics.json` lists them.
pub fn given_up_entries(objs: &[planner::GivenUpObject]) -> Vec<eval::GivenUpEntry> {
    objs.iter()
        .map(|g| eval::GivenUpEntry {
            map_id: g.map_id,
            cluster_id: g.cluster_id,
            label: g.label.to_string(),
            h_sopm: g.h_sopm,
            cause: g.cause.name().to_string(),
        })
        .collect()
}

fn progress_of(t: u64, map: &ObjectMap, planner: &dyn ViewPlanner) -> Progress {
    let objs = map.objects();
    Progress {
        sim_s: t as f64 * 1e-9,
        objects: objs.len() as u32,
        complete: objs
            .iter()
            .filter(|o| !o.is_background() && o.is_complete())
            .count() as u32,
        goals: planner.summary().goals_issued,
    }
}

/// Write `metrics.json`, `map.json`, `plot.json` and `map.png` of a session into `dir`.
pub fn write_outputs(
    spec: &SessionSpec,
    r: &SessionResult,
    dir: &Path,
) -> Result<(), SessionError> {
    let run = RunInfo {
        scene: spec.scene.name.clone(),
        planner: spec.label.clone(),
        seed: spec.seed,
    };
    let est = eval::estimates_from_map(&r.map);
    let plot = r
        .log
        .plot_input(&run, room(&spec.scene), &r.gt, &est, &r.metrics);
    // explore.png first: `write_run_outputs` writes metrics.json last, so a complete
    // metrics.json means every output of the run is there (`vpsom bench --resume`).
    std::fs::create_dir_all(dir).map_err(|e| eval::EvalError::Io {
        path: dir.to_path_buf(),
        source: e,
    })?;
    let frontier = planner::frontier::FrontierParams::new(&spec.config.planner);
    let nav = frontier.nav.flooded(&r.nav, [r.base[0], r.base[1]]);
    super::gridpng::write(&dir.join(EXPLORE_FILE), &r.explore, &frontier, &nav)?;
    eval::write_run_outputs(dir, &r.metrics, &est, &plot)?;
    Ok(())
}

/// The final exploration grid with its frontiers, written next to `metrics.json`.
pub const EXPLORE_FILE: &str = "explore.png";

/// The configuration of a planner label: `vpsom`, `coverage`, `frontier`, or `vpsom-no-<term>`
/// (an ablation of one F(v) term), each optionally followed by `@<variant>`: the sensing made
/// worse in one group ([`crate::variants`]).
pub fn config_for(base: &Config, label: &str) -> Result<Config, SessionError> {
    let mut cfg = base.clone();
    let (label, variant) = match label.split_once('@') {
        Some((l, v)) => (l, Some(v)),
        None => (label, None),
    };
    if let Some(v) = variant {
        crate::variants::apply(&mut cfg, v)?;
    }
    let (kind, ablate) = match label.split_once("-no-") {
        Some((k, term)) => (k, Some(term)),
        None => (label, None),
    };
    cfg.planner.kind = kind.parse::<PlannerKind>()?;
    if let Some(term) = ablate {
        cfg.planner.ablation.disable(term)?;
    }
    Ok(cfg)
}
