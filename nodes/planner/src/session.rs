//! The planner interface shared by VP-SOM and the baselines: inputs, steps, jobs, status and
//! summary, plus the bookkeeping every planner needs (`Session`: status, goal ids, the job in
//! flight, reusable snapshot buffers, frontier exploration and whether the room is explored; the
//! look-around; the localization recovery, [`crate::recovery`]).

use crate::clusters::{self, SideTracker};
use crate::config::{PlannerConfig, PlannerKind};
use crate::coverage::{CoverageJob, CoverageResult};
use crate::evaluate::{EvalParams, Scoring, Weights};
use crate::frontier::{FrontierJob, FrontierParams, FrontierResult};
use crate::gbv::{GbvJob, GbvResult};
use crate::giveup::GivenUpObject;
use crate::recovery::{Action, Recovery, RecoveryStats, escape_pose};
use shm_types::{
    Candidate, NavGoal, NeckGoal, ObjectMap, OccupancyGrid, PlannerDecision, RobotState,
    boxed_zeroed, decision_kind, goal_kind, nav_status, planner_state,
};
use std::fmt;

/// What a planner reads: the newest map, estimated robot state and grids (by reference).
#[derive(Debug, Clone, Copy)]
pub struct PlannerInputs<'a> {
    /// Newest object map.
    pub map: &'a ObjectMap,
    /// Newest estimated robot state (pose, neck, navigation status).
    pub state: &'a RobotState,
    /// Navigation grid (obstacles only), for reachability and collision. Empty = no obstacles.
    pub nav: &'a OccupancyGrid,
    /// Exploration grid built from depth (with UNKNOWN cells), for frontiers. Empty = none.
    pub explore: &'a OccupancyGrid,
}

/// Where the session stands.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PlannerStatus {
    /// Exploring.
    Running,
    /// The planner's end condition holds (VP-SOM: every cluster done, section 3.4; coverage:
    /// every cluster circled; frontier: no reachable frontier left).
    Terminated,
    /// No reachable candidate remains although the end condition does not hold (e.g. a
    /// cluster could not be approached, or nothing was found to explore).
    NoCandidates,
}

impl PlannerStatus {
    /// The [`planner_state`] code.
    pub fn code(self) -> u8 {
        match self {
            PlannerStatus::Running => planner_state::RUNNING,
            PlannerStatus::Terminated => planner_state::TERMINATED,
            PlannerStatus::NoCandidates => planner_state::NO_CANDIDATES,
        }
    }

    /// Whether the session is over.
    pub fn is_finished(self) -> bool {
        self != PlannerStatus::Running
    }
}

/// End-of-session (or running) summary.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Summary {
    /// Planner.
    pub kind: PlannerKind,
    /// Status.
    pub status: PlannerStatus,
    /// Chassis goals issued.
    pub goals_issued: u64,
    /// Goals the base reported unreachable.
    pub goals_unreachable: u64,
    /// Planning rounds (jobs run: GBV, frontier or coverage planning).
    pub rounds: u64,
    /// Clusters in the last map seen.
    pub clusters: u32,
    /// Of which done (VP-SOM rule) or circled (coverage).
    pub clusters_done: u32,
    /// Clusters given up without a reachable view (never approached); VP-SOM still ends
    /// `Terminated` with them listed in [`Summary::reason`].
    pub clusters_given_up: u32,
    /// Foreground objects in the last map seen.
    pub foreground: u32,
    /// Of which complete.
    pub foreground_done: u32,
    /// Foreground objects given up (VP-SOM: entropy stalled or cluster out of views; see
    /// [`crate::giveup`]).
    pub objects_given_up: u32,
    /// Whether the room was explored: the last frontier round found no reachable frontier.
    pub explored: bool,
    /// Localization recoveries (`[planner.recovery]`): started, ended with tracking back, full
    /// sweeps that found nothing, drives.
    pub recovery: RecoveryStats,
    /// Time the session ended, ns.
    pub finished_ns: Option<u64>,
}

impl Summary {
    /// Why the session ended (or "running"), for `metrics.json`'s `termination_reason`.
    pub fn reason(&self) -> String {
        let explored = if self.explored {
            "explored"
        } else {
            "not explored"
        };
        match self.status {
            PlannerStatus::Running => "running".into(),
            PlannerStatus::Terminated => match self.kind {
                PlannerKind::Frontier => "explored (no reachable frontier)".into(),
                PlannerKind::Coverage => format!("every cluster circled, {explored}"),
                PlannerKind::Vpsom => {
                    let mut causes = Vec::new();
                    if self.objects_given_up > 0 {
                        causes.push(format!("objects given up: {}", self.objects_given_up));
                    }
                    if self.clusters_given_up > 0 {
                        causes.push(format!("clusters unreachable: {}", self.clusters_given_up));
                    }
                    if causes.is_empty() {
                        format!("complete and {explored}")
                    } else {
                        format!("{} (the rest complete, {explored})", causes.join(", "))
                    }
                }
            },
            PlannerStatus::NoCandidates if self.clusters == 0 => {
                format!("nothing found ({explored}, no cluster)")
            }
            PlannerStatus::NoCandidates if self.clusters_given_up > 0 => format!(
                "no reachable candidate: clusters given up: {} ({explored})",
                self.clusters_given_up
            ),
            PlannerStatus::NoCandidates => format!("no reachable candidate ({explored})"),
        }
    }
}

impl fmt::Display for Summary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{}: {:?}; goals {} ({} unreachable), rounds {}; clusters {}/{} done, {} given up; \
             foreground {}/{} complete, {} given up; explored {}; localization recoveries {} \
             ({} recovered, {} drives)",
            self.kind,
            self.status,
            self.goals_issued,
            self.goals_unreachable,
            self.rounds,
            self.clusters_done,
            self.clusters,
            self.clusters_given_up,
            self.foreground_done,
            self.foreground,
            self.objects_given_up,
            self.explored,
            self.recovery.started,
            self.recovery.recovered,
            self.recovery.drives
        )
    }
}

/// A planning computation to run off the real-time thread (e.g. on the low-priority pool):
/// owned, `Send + 'static`.
#[derive(Debug)]
pub enum PlannerJob {
    /// A VP-SOM GBV round.
    Gbv(GbvJob),
    /// A frontier selection.
    Frontier(FrontierJob),
    /// A coverage circle.
    Coverage(CoverageJob),
}

impl PlannerJob {
    /// Run it (rayon-parallel inside where useful).
    pub fn run(self) -> JobOutput {
        match self {
            PlannerJob::Gbv(j) => JobOutput::Gbv(j.run()),
            PlannerJob::Frontier(j) => JobOutput::Frontier(j.run()),
            PlannerJob::Coverage(j) => JobOutput::Coverage(j.run()),
        }
    }
}

/// Result of a [`PlannerJob`], to hand back with [`ViewPlanner::job_done`].
#[derive(Debug)]
pub enum JobOutput {
    /// GBV round result.
    Gbv(GbvResult),
    /// Frontier result.
    Frontier(FrontierResult),
    /// Coverage result.
    Coverage(CoverageResult),
}

/// What the host should do after [`ViewPlanner::next_goal`] or [`ViewPlanner::job_done`].
#[derive(Debug)]
pub enum Step {
    /// Nothing: the current goal is in progress, a job is pending, or the neck is still looking
    /// around.
    Wait,
    /// Publish this chassis goal (it supersedes any earlier one; ids increase).
    Goal(NavGoal),
    /// Run this job (e.g. on the low-priority pool) and pass its output to `job_done`.
    Compute(PlannerJob),
    /// The session is over.
    Finished(Summary),
}

/// A view planner: chassis goals on demand, neck goals at the LBV rate.
pub trait ViewPlanner: Send + fmt::Debug {
    /// Which planner this is.
    fn kind(&self) -> PlannerKind;

    /// Call on every new robot state (and map). Cheap while a goal is in progress; when the
    /// current goal is REACHED or UNREACHABLE (or there is none), it returns the next goal
    /// directly or a job to compute it. May allocate (at most once per goal).
    fn next_goal(&mut self, inputs: &PlannerInputs<'_>, now_ns: u64) -> Step;

    /// Hand back a finished job's output; returns the goal to publish, or `Finished`.
    fn job_done(&mut self, output: JobOutput, now_ns: u64) -> Step;

    /// The neck goal for the newest map and state. Never waits and, after the first call,
    /// never allocates (safe on the real-time LBV thread).
    fn neck_goal(&mut self, map: &ObjectMap, state: &RobotState, now_ns: u64) -> NeckGoal;

    /// Current status.
    fn status(&self) -> PlannerStatus;

    /// Summary so far (final once `status()` is finished).
    fn summary(&self) -> Summary;

    /// The foreground objects given up so far (VP-SOM; none for the baselines).
    fn given_up_objects(&self) -> Vec<GivenUpObject> {
        Vec::new()
    }

    /// The trace of the newest chassis-goal decision (GBV candidates), once.
    fn take_decision(&mut self) -> Option<Box<PlannerDecision>> {
        None
    }

    /// Write the trace of the newest neck decision (LBV candidates) into `d`; false if the
    /// planner has none. Does not allocate.
    fn lbv_decision(&self, _d: &mut PlannerDecision) -> bool {
        false
    }
}

/// Outcome of the current chassis goal.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Outcome {
    /// No goal issued yet (or the last one was consumed).
    None,
    /// The base has not finished it.
    Pending,
    /// Reached.
    Reached,
    /// Refused or unreachable.
    Unreachable,
}

/// Goal ids and counts.
#[derive(Debug, Clone, Default)]
pub(crate) struct Goals {
    next_id: u64,
    pub(crate) current: Option<NavGoal>,
    pub(crate) issued: u64,
    pub(crate) unreachable: u64,
}

impl Goals {
    pub(crate) fn new() -> Self {
        Self {
            next_id: 1,
            ..Default::default()
        }
    }

    /// The current goal's outcome per the robot state; a finished goal is consumed (so the
    /// outcome is reported once) and counted.
    pub(crate) fn poll(&mut self, state: &RobotState) -> Outcome {
        let Some(g) = self.current else {
            return Outcome::None;
        };
        if state.nav_goal_id != g.goal_id {
            return Outcome::Pending;
        }
        match state.nav_status {
            nav_status::REACHED => {
                self.current = None;
                Outcome::Reached
            }
            nav_status::UNREACHABLE => {
                self.current = None;
                self.unreachable += 1;
                Outcome::Unreachable
            }
            _ => Outcome::Pending,
        }
    }

    /// Issue a new goal (ids increase by one from 1).
    pub(crate) fn issue(
        &mut self,
        pose: [f32; 3],
        score: f32,
        cluster_id: i32,
        kind: u8,
        now_ns: u64,
    ) -> NavGoal {
        let g = NavGoal {
            goal_id: self.next_id,
            pose,
            score,
            cluster_id,
            kind,
            ..Default::default()
        };
        let mut g = g;
        g.header.sim_time_ns = now_ns;
        self.next_id += 1;
        self.issued += 1;
        self.current = Some(g);
        g
    }
}

/// Copy the valid part of a grid into a reusable buffer.
pub fn copy_grid(dst: &mut OccupancyGrid, src: &OccupancyGrid) {
    dst.header = src.header;
    dst.origin = src.origin;
    dst.resolution = src.resolution;
    dst.width = src.width;
    dst.height = src.height;
    let n = src.used().len();
    dst.cells[..n].copy_from_slice(&src.cells[..n]);
}

/// Snapshot buffers recycled between jobs (one allocation each per session).
#[derive(Debug, Default)]
pub(crate) struct Buffers {
    map: Option<Box<ObjectMap>>,
    nav: Option<Box<OccupancyGrid>>,
    explore: Option<Box<OccupancyGrid>>,
}

impl Buffers {
    pub(crate) fn map(&mut self, src: &ObjectMap) -> Box<ObjectMap> {
        let mut b = self.map.take().unwrap_or_else(boxed_zeroed);
        b.copy_from(src);
        b
    }
    pub(crate) fn nav(&mut self, src: &OccupancyGrid) -> Box<OccupancyGrid> {
        let mut b = self.nav.take().unwrap_or_else(boxed_zeroed);
        copy_grid(&mut b, src);
        b
    }
    pub(crate) fn explore(&mut self, src: &OccupancyGrid) -> Box<OccupancyGrid> {
        let mut b = self.explore.take().unwrap_or_else(boxed_zeroed);
        copy_grid(&mut b, src);
        b
    }
    pub(crate) fn put_map(&mut self, b: Box<ObjectMap>) {
        self.map = Some(b);
    }
    pub(crate) fn put_nav(&mut self, b: Box<OccupancyGrid>) {
        self.nav = Some(b);
    }
    pub(crate) fn put_explore(&mut self, b: Box<OccupancyGrid>) {
        self.explore = Some(b);
    }
}

/// In-place 360° look-around: neck stops evenly spaced, advanced when the neck gets within a
/// tolerance of the current stop.
#[derive(Debug, Clone)]
pub(crate) struct LookAround {
    steps: usize,
    tol: f32,
    k: usize,
    sweeps: u32,
}

impl LookAround {
    pub(crate) fn new(steps: usize, tol_rad: f32) -> Self {
        Self {
            steps: steps.max(1),
            tol: tol_rad,
            k: 0,
            sweeps: 0,
        }
    }

    /// The neck yaw to command given the current one (advances through the stops).
    pub(crate) fn target(&mut self, neck_yaw: f32) -> f32 {
        let stop =
            |k: usize, n: usize| geom::wrap_angle(std::f32::consts::TAU * k as f32 / n as f32);
        if geom::wrap_angle(neck_yaw - stop(self.k, self.steps)).abs() <= self.tol {
            self.k += 1;
            if self.k == self.steps {
                self.k = 0;
                self.sweeps += 1;
            }
        }
        stop(self.k, self.steps)
    }

    /// Whether at least one full sweep was completed.
    pub(crate) fn swept(&self) -> bool {
        self.sweeps > 0
    }
}

/// The neck while exploring: `amplitude · sin(2π t / period)` about the base's heading, slow
/// enough that a base turn on top of it keeps the camera trackable (see `[planner.bootstrap]`).
#[derive(Debug, Clone, Copy)]
pub(crate) struct ExploreSweep {
    amplitude: f32,
    period_ns: f64,
}

impl ExploreSweep {
    pub(crate) fn new(cfg: &PlannerConfig) -> Self {
        Self {
            amplitude: cfg.bootstrap.explore_neck_amplitude_deg.to_radians(),
            period_ns: f64::from(cfg.bootstrap.explore_neck_period_s) * 1e9,
        }
    }

    /// The neck yaw at time `now_ns`.
    pub(crate) fn yaw(&self, now_ns: u64) -> f32 {
        let phase = (now_ns as f64 / self.period_ns).fract() * std::f64::consts::TAU;
        self.amplitude * phase.sin() as f32
    }
}

/// The bookkeeping every planner shares: status and summary, goal ids, the planning job in
/// flight, recycled snapshot buffers, the sides tracker and frontier exploration (VP-SOM's and
/// coverage's bootstrap, the frontier baseline's only mode). Each planner keeps only its own
/// logic on top.
#[derive(Debug)]
pub(crate) struct Session {
    eps_sopm: f32,
    min_sides: usize,
    frontier: FrontierParams,
    seen_radius: f32,
    /// Goal ids and counts.
    pub(crate) goals: Goals,
    /// Snapshot buffers.
    pub(crate) buffers: Buffers,
    /// Sides each cluster was seen from (fed by planners that track it).
    pub(crate) sides: SideTracker,
    /// Clusters given up.
    pub(crate) given_up: Vec<i32>,
    /// Overrides the map-derived `clusters_done` (coverage: clusters circled).
    pub(crate) clusters_done: Option<u32>,
    /// Objects given up (set by the planner).
    pub(crate) objects_given_up: u32,
    /// The newest frontier round found no reachable frontier (cleared by a planner whose base
    /// has since gone elsewhere, so that the next exploration looks again).
    pub(crate) explored: bool,
    /// Evaluate the view of every frontier goal (the frontier baseline, whose NBVs they are).
    pub(crate) score_frontiers: Option<(EvalParams, Weights)>,
    /// The trace of the newest chassis-goal decision, until the host takes it.
    pub(crate) decision: Option<Box<PlannerDecision>>,
    /// The localization recovery (every planner).
    recovery: Recovery,
    blacklist: Vec<[f32; 2]>,
    pending: bool,
    status: PlannerStatus,
    summary: Summary,
    jobs: u64,
}

impl Session {
    /// A running session of planner `kind`; `min_sides` is the "seen from enough sides" rule of
    /// clusters without foreground objects (0: never done that way).
    pub(crate) fn new(kind: PlannerKind, cfg: &PlannerConfig, min_sides: usize) -> Self {
        Self {
            eps_sopm: cfg.eps_sopm,
            min_sides,
            frontier: FrontierParams::new(cfg),
            seen_radius: cfg.frontier.seen_radius,
            goals: Goals::new(),
            buffers: Buffers::default(),
            sides: SideTracker::new(cfg.bootstrap.sectors).with_approach(cfg.bootstrap.approach_m),
            given_up: Vec::with_capacity(shm_types::MAX_OBJECTS),
            clusters_done: None,
            objects_given_up: 0,
            explored: false,
            score_frontiers: None,
            decision: None,
            recovery: Recovery::new(&cfg.recovery),
            blacklist: Vec::new(),
            pending: false,
            status: PlannerStatus::Running,
            summary: Summary {
                kind,
                status: PlannerStatus::Running,
                goals_issued: 0,
                goals_unreachable: 0,
                rounds: 0,
                clusters: 0,
                clusters_done: 0,
                clusters_given_up: 0,
                foreground: 0,
                foreground_done: 0,
                objects_given_up: 0,
                explored: false,
                recovery: RecoveryStats::default(),
                finished_ns: None,
            },
            jobs: 0,
        }
    }

    /// The start of every `next_goal`: takes the map's counts for the summary, and returns the
    /// step to return at once (`Finished` once the session is over, `Wait` while a job is out,
    /// the recovery's drive or `Wait` while localization is being recovered: [`Self::recover`]).
    pub(crate) fn begin(&mut self, inputs: &PlannerInputs<'_>, now_ns: u64) -> Option<Step> {
        if self.status.is_finished() {
            return Some(Step::Finished(self.summary()));
        }
        let map = inputs.map;
        let cl = clusters::clusters(map, self.eps_sopm, &self.sides, self.min_sides);
        let s = &mut self.summary;
        s.clusters = cl.len() as u32;
        s.clusters_done = cl.iter().filter(|c| c.done).count() as u32;
        let fg = map.objects().iter().filter(|o| !o.is_background());
        s.foreground = fg.clone().count() as u32;
        s.foreground_done = fg.filter(|o| clusters::fg_done(o, self.eps_sopm)).count() as u32;
        let recovering = self.recover(inputs, now_ns);
        if self.pending {
            return Some(Step::Wait);
        }
        recovering
    }

    /// The localization recovery's part of `next_goal`, the same for every planner: `None` while
    /// tracking holds (the planner is in charge); else the planner waits (`Wait`), except for the
    /// recovery's drive, issued here with the planner's goal ids (kind RECOVERY). Once the
    /// recovery is over, a recovery goal still current is dropped so that the planner plans
    /// afresh (its own goal, if one was superseded, is not waited for).
    fn recover(&mut self, inputs: &PlannerInputs<'_>, now_ns: u64) -> Option<Step> {
        let state = inputs.state;
        let action = self
            .recovery
            .observe(tracking(state), driving(state), state.neck_yaw, now_ns);
        // The base's current goal is the recovery's drive.
        let own_drive = self
            .goals
            .current
            .is_some_and(|g| g.kind == goal_kind::RECOVERY);
        match action {
            Action::None => {
                if own_drive {
                    self.goals.current = None;
                }
                None
            }
            Action::Neck(_) => Some(Step::Wait),
            Action::Drive if self.pending => Some(Step::Wait),
            Action::Drive => {
                let nav = &self.frontier.nav;
                match escape_pose(inputs.nav, nav, state, self.recovery.move_m) {
                    Some(pose) => {
                        self.recovery.drive_issued();
                        let goal = self.goals.issue(pose, 0.0, -1, goal_kind::RECOVERY, now_ns);
                        Some(Step::Goal(goal))
                    }
                    None => {
                        self.recovery.drive_done(state.neck_yaw, now_ns);
                        Some(Step::Wait)
                    }
                }
            }
            Action::Driving => {
                // Over when the base is done with it, or when a goal of the planner (a job
                // that came back meanwhile) superseded it.
                if !own_drive || self.goals.poll(state) != Outcome::Pending {
                    self.recovery.drive_done(state.neck_yaw, now_ns);
                }
                Some(Step::Wait)
            }
        }
    }

    /// The neck yaw while the recovery is in charge (every planner's `neck_goal` starts here):
    /// `None` while tracking holds.
    pub(crate) fn recovery_neck(&mut self, state: &RobotState, now_ns: u64) -> Option<f32> {
        self.recovery
            .observe(tracking(state), driving(state), state.neck_yaw, now_ns);
        self.recovery.neck()
    }

    /// Hand a job to the host (one planning round).
    pub(crate) fn compute(&mut self, job: PlannerJob) -> Step {
        self.pending = true;
        self.jobs += 1;
        Step::Compute(job)
    }

    /// A frontier round on the exploration grid (earlier frontier goals blacklisted).
    pub(crate) fn frontier_job(&mut self, inputs: &PlannerInputs<'_>) -> Step {
        let scoring = self.score_frontiers.map(|(params, weights)| Scoring {
            map: self.buffers.map(inputs.map),
            params,
            weights,
        });
        let job = FrontierJob {
            explore: self.buffers.explore(inputs.explore),
            nav: self.buffers.nav(inputs.nav),
            base: inputs.state.base_pose,
            blacklist: self.blacklist.clone(),
            params: self.frontier,
            scoring,
        };
        self.compute(PlannerJob::Frontier(job))
    }

    /// Whether the current goal is a frontier goal whose neighbourhood has been seen since it
    /// was issued (no frontier cell within `frontier.seen_radius` of it): it need not be driven
    /// to any more, the next frontier round can start.
    pub(crate) fn frontier_goal_seen(&self, explore: &OccupancyGrid) -> bool {
        self.seen_radius > 0.0
            && self.goals.current.is_some_and(|g| {
                g.kind == goal_kind::FRONTIER
                    && !super::frontier::frontier_near(
                        explore,
                        [g.pose[0], g.pose[1]],
                        self.seen_radius,
                    )
            })
    }

    /// The start of every `job_done`: the job is back. A frontier round ends here: its goal is
    /// issued (and blacklisted), or, when no reachable frontier remains, the room is marked
    /// explored and [`Back::Explored`] returned (the planner decides whether the session ends).
    /// GBV and coverage rounds go back to the planner.
    pub(crate) fn job_back(&mut self, output: JobOutput, now_ns: u64) -> Back {
        self.pending = false;
        match output {
            JobOutput::Frontier(r) => {
                let blank = r.explore.width > 0 && !r.known;
                self.buffers.put_explore(r.explore);
                self.buffers.put_nav(r.nav);
                if let Some(sc) = r.scoring {
                    if let Some(view) = r.view {
                        self.decision = Some(chosen_decision(view, -1, sc.map.header.seq));
                    }
                    self.buffers.put_map(sc.map);
                }
                match r.goal {
                    Some((pose, _)) => {
                        self.blacklist.push([pose[0], pose[1]]);
                        self.explored = false;
                        Back::Step(Step::Goal(self.goals.issue(
                            pose,
                            0.0,
                            -1,
                            goal_kind::FRONTIER,
                            now_ns,
                        )))
                    }
                    // Nothing integrated into the grid yet (e.g. localization not tracking at the
                    // start): not explored, wait for the first frames.
                    None if blank => Back::Step(Step::Wait),
                    None => {
                        self.explored = true;
                        Back::Explored
                    }
                }
            }
            JobOutput::Gbv(r) => Back::Gbv(r),
            JobOutput::Coverage(r) => Back::Coverage(r),
        }
    }

    /// Take back the buffers of an output the planner has no use for.
    pub(crate) fn discard(&mut self, back: Back) -> Step {
        match back {
            Back::Step(s) => return s,
            Back::Explored => {}
            Back::Gbv(r) => {
                self.buffers.put_map(r.map);
                self.buffers.put_nav(r.nav);
            }
            Back::Coverage(r) => {
                self.buffers.put_nav(r.nav);
                self.buffers.put_map(r.scoring.map);
            }
        }
        Step::Wait
    }

    /// The newest chassis-goal decision, once, with the current state.
    pub(crate) fn take_decision(&mut self) -> Option<Box<PlannerDecision>> {
        let state = self.status.code();
        self.decision.take().map(|mut d| {
            d.state = state;
            d
        })
    }

    /// End the session.
    pub(crate) fn finish(&mut self, status: PlannerStatus, now_ns: u64) -> Step {
        self.status = status;
        self.summary.finished_ns = Some(now_ns);
        Step::Finished(self.summary())
    }

    /// Current status.
    pub(crate) fn status(&self) -> PlannerStatus {
        self.status
    }

    /// The summary so far.
    pub(crate) fn summary(&self) -> Summary {
        Summary {
            status: self.status,
            goals_issued: self.goals.issued,
            goals_unreachable: self.goals.unreachable,
            rounds: self.jobs,
            clusters_done: self.clusters_done.unwrap_or(self.summary.clusters_done),
            clusters_given_up: self.given_up.len() as u32,
            objects_given_up: self.objects_given_up,
            explored: self.explored,
            recovery: self.recovery.stats(),
            ..self.summary
        }
    }
}

/// Whether visual localization tracks (the recovery's input).
fn tracking(state: &RobotState) -> bool {
    state.localization_ok != 0
}

/// Whether the base is driving to a goal (the recovery gives it `lost_grace_driving_s`).
fn driving(state: &RobotState) -> bool {
    state.nav_status == nav_status::MOVING
}

/// A job output back at its planner (see [`Session::job_back`]).
#[derive(Debug)]
pub(crate) enum Back {
    /// What a frontier round led to: its goal.
    Step(Step),
    /// A frontier round found no reachable frontier: the room is explored.
    Explored,
    /// A GBV round.
    Gbv(GbvResult),
    /// A coverage round.
    Coverage(CoverageResult),
}

/// The trace of a chassis goal whose one evaluated candidate is its chosen view (baselines;
/// `c` comes from [`Scoring::chosen`], flagged chosen).
pub(crate) fn chosen_decision(c: Candidate, cluster_id: i32, map_seq: u64) -> Box<PlannerDecision> {
    let mut d = boxed_zeroed::<PlannerDecision>();
    d.kind = decision_kind::GBV;
    d.map_seq = map_seq;
    d.cluster_id = cluster_id;
    d.count = 1;
    d.evaluated = 1;
    d.candidates[0] = c;
    d
}

/// A neck goal for `map` with the mount's pitch (yaw 0, score 0).
pub(crate) fn neck_goal_for(map: &ObjectMap, pitch: f32) -> NeckGoal {
    NeckGoal {
        map_seq: map.header.seq,
        frame_stamp_ns: map.last_frame_stamp_ns,
        pitch,
        ..Default::default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn goal_ids_increase_and_outcomes_are_reported_once() {
        let mut g = Goals::new();
        let mut s = RobotState::default();
        assert_eq!(g.poll(&s), Outcome::None);
        let a = g.issue([1.0, 2.0, 0.0], 0.5, 3, 0, 10);
        assert_eq!(a.goal_id, 1);
        assert_eq!(g.poll(&s), Outcome::Pending, "base still on goal 0");
        s.nav_goal_id = 1;
        s.nav_status = nav_status::MOVING;
        assert_eq!(g.poll(&s), Outcome::Pending);
        s.nav_status = nav_status::UNREACHABLE;
        assert_eq!(g.poll(&s), Outcome::Unreachable);
        assert_eq!(g.poll(&s), Outcome::None);
        let b = g.issue([0.0; 3], 0.0, -1, 0, 20);
        assert!(b.goal_id > a.goal_id && g.unreachable == 1 && g.issued == 2);
    }

    #[test]
    fn look_around_visits_every_stop() {
        let mut l = LookAround::new(4, 0.05);
        let mut neck = 0.0;
        let mut stops = Vec::new();
        for _ in 0..4 {
            neck = l.target(neck);
            stops.push(neck);
        }
        assert!(l.swept());
        let expect = [
            std::f32::consts::FRAC_PI_2,
            std::f32::consts::PI,
            -std::f32::consts::FRAC_PI_2,
            0.0,
        ];
        for (a, b) in stops.iter().zip(expect) {
            assert!(geom::wrap_angle(a - b).abs() < 1e-5, "{stops:?}");
        }
    }

    #[test]
    fn session_waits_on_its_job_and_ends_once() {
        let cfg = PlannerConfig::default();
        let mut s = Session::new(PlannerKind::Frontier, &cfg, 0);
        let map = boxed_zeroed::<ObjectMap>();
        let grid = boxed_zeroed::<OccupancyGrid>();
        let state = RobotState::default();
        let inputs = PlannerInputs {
            map: &map,
            state: &state,
            nav: &grid,
            explore: &grid,
        };
        assert!(s.begin(&inputs, 0).is_none());
        let Step::Compute(job) = s.frontier_job(&inputs) else {
            panic!("a frontier job");
        };
        assert!(matches!(s.begin(&inputs, 0), Some(Step::Wait)), "job out");
        // An empty exploration grid has no frontier: the room counts as explored.
        let back = s.job_back(job.run(), 7);
        assert!(matches!(back, Back::Explored));
        assert!(s.explored && !s.status().is_finished());
        let Step::Finished(sum) = s.finish(PlannerStatus::Terminated, 7) else {
            panic!("finished");
        };
        assert_eq!(
            (sum.status, sum.rounds, sum.finished_ns, sum.explored),
            (PlannerStatus::Terminated, 1, Some(7), true)
        );
        assert_eq!(sum.reason(), "explored (no reachable frontier)");
        assert!(matches!(s.begin(&inputs, 7), Some(Step::Finished(_))));
        assert!(
            s.buffers.explore.is_some() && s.buffers.nav.is_some(),
            "buffers reclaimed"
        );
    }

    /// Every planner, lost at the start in a 4 m room: it waits while the neck sweeps (the
    /// recovery's stops), drives once a full sweep found nothing, sweeps again after the drive,
    /// and plans again once tracking holds.
    #[test]
    fn every_planner_recovers_the_same_way() {
        use crate::config::PlannerKind;
        use geom::CameraConfig;
        use shm_types::grid_cell;
        let mut nav = boxed_zeroed::<OccupancyGrid>();
        (nav.resolution, nav.width, nav.height) = (0.1, 40, 40);
        for iy in 0..40usize {
            for ix in 0..40usize {
                if ix.min(iy).min(39 - ix).min(39 - iy) <= 3 {
                    nav.cells[iy * 40 + ix] = grid_cell::OCCUPIED;
                }
            }
        }
        let mut explore = boxed_zeroed::<OccupancyGrid>();
        (explore.resolution, explore.width, explore.height) = (0.1, 40, 40);
        explore.cells[..1600].fill(grid_cell::UNKNOWN);
        let map = boxed_zeroed::<ObjectMap>();
        let ms = 1_000_000u64;
        for kind in [
            PlannerKind::Vpsom,
            PlannerKind::Coverage,
            PlannerKind::Frontier,
        ] {
            let cfg = PlannerConfig {
                kind,
                ..PlannerConfig::default()
            };
            let r = cfg.recovery;
            let mut p = crate::make_planner(&cfg, &CameraConfig::default());
            // 0.7 m from the north wall's inner face (y = 3.6), facing it; lost.
            let mut state = RobotState {
                base_pose: [2.0, 2.9, std::f32::consts::FRAC_PI_2],
                ..Default::default()
            };
            let mut necks = Vec::new();
            let mut drive = None;
            let mut t = 0;
            while t < 30_000 * ms {
                let neck = p.neck_goal(&map, &state, t);
                state.neck_yaw = neck.yaw; // the neck follows at once
                if necks.last() != Some(&neck.yaw) {
                    necks.push(neck.yaw);
                }
                let inputs = PlannerInputs {
                    map: &map,
                    state: &state,
                    nav: &nav,
                    explore: &explore,
                };
                let mut step = p.next_goal(&inputs, t);
                while let Step::Compute(job) = step {
                    step = p.job_done(job.run(), t);
                }
                match step {
                    Step::Goal(g) => {
                        assert_eq!(g.kind, goal_kind::RECOVERY, "{kind}: {g:?}");
                        drive = Some((g, t));
                        break;
                    }
                    Step::Finished(s) => panic!("{kind}: {s}"),
                    _ => {}
                }
                t += 50 * ms;
            }
            let (goal, at) = drive.unwrap_or_else(|| panic!("{kind}: no drive"));
            // After the grace time and a full sweep of sweep_stops stops.
            let sweep = r.lost_grace_s + r.sweep_stops as f32 * r.stop_s;
            assert!((at as f32 * 1e-9 - sweep).abs() < 0.2, "{kind}: {at}");
            assert!(necks.len() > r.sweep_stops, "{kind}: {necks:?}");
            assert!(
                goal.pose[1] < 2.4 && goal.pose[2] < 0.0,
                "{kind}: away from the wall, facing the room: {goal:?}"
            );
            let s = p.summary();
            assert_eq!((s.recovery.failed_sweeps, s.recovery.drives), (1, 1));
            // The drive is reached: a new sweep (the planner still waits).
            state.nav_goal_id = goal.goal_id;
            state.nav_status = nav_status::REACHED;
            state.base_pose = goal.pose;
            let inputs = PlannerInputs {
                map: &map,
                state: &state,
                nav: &nav,
                explore: &explore,
            };
            assert!(matches!(p.next_goal(&inputs, at + 100 * ms), Step::Wait));
            // Tracking holds: hold_s later the planner plans again (a frontier round: the grid
            // is still unknown, so it waits for frames; VP-SOM and coverage look around).
            state.localization_ok = 1;
            let held = at + 200 * ms + (f64::from(r.hold_s) * 1e9) as u64;
            let mut t = at + 200 * ms;
            while t <= held + 100 * ms {
                let inputs = PlannerInputs {
                    map: &map,
                    state: &state,
                    nav: &nav,
                    explore: &explore,
                };
                p.neck_goal(&map, &state, t);
                if let Step::Compute(job) = p.next_goal(&inputs, t) {
                    assert!(t >= held, "{kind}: planned while the neck held");
                    assert!(!matches!(p.job_done(job.run(), t), Step::Finished(_)));
                }
                t += 50 * ms;
            }
            let s = p.summary();
            assert_eq!((s.recovery.started, s.recovery.recovered), (1, 1), "{kind}");
            assert_eq!(s.goals_issued, 1, "{kind}: only the drive");
        }
    }
}
