//! The two baselines of the paper's section 7.1 behind the [`ViewPlanner`] interface.
//!
//! - [`CoveragePlanner`]: circles every cluster once (see [`crate::coverage`]) in order
//!   of first sighting, neck always on the centre of the cluster being circled (or, on the way
//!   to the first waypoint, of the next cluster). Whenever no cluster is left to circle (before,
//!   between and after its circles) it explores as VP-SOM does (look around before the first
//!   cluster, then frontier goals with the neck sweeping; a frontier goal is superseded as soon
//!   as an uncircled cluster appears). Ends (`Terminated`) once every known cluster has been
//!   circled and the room is explored; clusters without a reachable waypoint are given up and
//!   make the end `NoCandidates`.
//! - [`FrontierPlanner`]: Yamauchi frontier exploration (see [`crate::frontier`]),
//!   neck fixed forward (yaw 0); ends (`Terminated`) when no reachable frontier remains.
//!
//! Both trace every chassis goal like VP-SOM traces its GBV ([`ViewPlanner::take_decision`], kind
//! GBV): one candidate, flagged chosen, evaluated with VP-SOM's GBV terms and weights on the map
//! of the round that chose it: the coverage waypoint's view with the camera on the cluster
//! centre (f_c for that cluster), the frontier goal's view with the neck forward (no f_c). So
//! per-NBV metrics (non-occlusion: H_IoU and objects in view) are computed the same way for all
//! three planners. Bootstrap frontier goals (VP-SOM's and coverage's) are not NBVs and carry
//! none.

use crate::clusters::{self, ClusterInfo};
use crate::config::{PlannerConfig, PlannerKind};
use crate::coverage::{CoverageJob, CoverageParams};
use crate::evaluate::{EvalParams, Scoring, Weights};
use crate::reach::NavParams;
use crate::session::{
    Back, ExploreSweep, JobOutput, LookAround, Outcome, PlannerInputs, PlannerJob, PlannerStatus,
    Session, Step, Summary, ViewPlanner, chosen_decision, neck_goal_for,
};
use geom::CameraConfig;
use geom::CameraMount;
use shm_types::{Candidate, NeckGoal, ObjectMap, PlannerDecision, RobotState, goal_kind};
use std::collections::VecDeque;

/// How the baselines evaluate the views they choose: VP-SOM's GBV terms and weights.
fn scoring_params(cfg: &PlannerConfig, camera: &CameraConfig) -> (EvalParams, Weights) {
    let weights = Weights {
        alpha: cfg.gbv.alpha,
        beta: cfg.gbv.beta,
    };
    (EvalParams::new(cfg, camera), weights)
}

/// All-views coverage baseline.
#[derive(Debug)]
pub struct CoveragePlanner {
    eps_sopm: f32,
    params: CoverageParams,
    scoring: (EvalParams, Weights),
    mount: CameraMount,
    session: Session,
    look: LookAround,
    sweep: ExploreSweep,
    /// Whether the newest chassis round was a frontier round.
    exploring: bool,
    /// Waypoints left on the current circle, with their views.
    queue: VecDeque<([f32; 3], Candidate)>,
    /// `header.seq` of the map the circle was planned on.
    circle_map_seq: u64,
    current: Option<ClusterInfo>,
    circled: Vec<i32>,
    /// Circled or given up (the neck's skip list; fixed capacity).
    skip: Vec<i32>,
}

impl CoveragePlanner {
    /// A planner from the configuration.
    pub fn new(cfg: &PlannerConfig, camera: &CameraConfig) -> Self {
        let mut session = Session::new(PlannerKind::Coverage, cfg, 0);
        // "Done" means circled here.
        session.clusters_done = Some(0);
        Self {
            eps_sopm: cfg.eps_sopm,
            params: CoverageParams {
                waypoints: cfg.coverage.waypoints,
                safe_distance: cfg.gbv.safe_distance,
                nav: NavParams::new(cfg),
            },
            scoring: scoring_params(cfg, camera),
            mount: camera.mount,
            session,
            look: LookAround::new(
                cfg.bootstrap.look_around_steps,
                cfg.bootstrap.neck_tolerance_deg.to_radians(),
            ),
            sweep: ExploreSweep::new(cfg),
            exploring: false,
            queue: VecDeque::new(),
            circle_map_seq: 0,
            current: None,
            circled: Vec::with_capacity(shm_types::MAX_OBJECTS),
            skip: Vec::with_capacity(2 * shm_types::MAX_OBJECTS),
        }
    }

    fn finish(&mut self, any_cluster: bool, now_ns: u64) -> Step {
        let status = if any_cluster && self.session.given_up.is_empty() {
            PlannerStatus::Terminated
        } else {
            PlannerStatus::NoCandidates
        };
        self.session.finish(status, now_ns)
    }

    fn next_waypoint(&mut self, now_ns: u64) -> Option<Step> {
        let (w, view) = self.queue.pop_front()?;
        let id = self.current.map_or(-1, |c| c.id);
        self.session.decision = Some(chosen_decision(view, id, self.circle_map_seq));
        Some(Step::Goal(self.session.goals.issue(
            w,
            0.0,
            id,
            goal_kind::COVERAGE,
            now_ns,
        )))
    }
}

impl ViewPlanner for CoveragePlanner {
    fn kind(&self) -> PlannerKind {
        PlannerKind::Coverage
    }

    fn next_goal(&mut self, inputs: &PlannerInputs<'_>, now_ns: u64) -> Step {
        if let Some(step) = self.session.begin(inputs, now_ns) {
            return step;
        }
        let current = self.session.goals.current;
        let outcome = self.session.goals.poll(inputs.state);
        let all = clusters::clusters(inputs.map, self.eps_sopm, &self.session.sides, 0);
        let given_up = &self.session.given_up;
        let open: Vec<ClusterInfo> = all
            .iter()
            .filter(|c| !self.circled.contains(&c.id) && !given_up.contains(&c.id))
            // An empty duplicate of an earlier table (same footprint) is circled with it.
            .filter(|c| {
                c.foreground > 0
                    || !inputs
                        .map
                        .objects()
                        .iter()
                        .any(|o| o.id as i32 == c.id && clusters::is_duplicate(inputs.map, o))
            })
            .filter(|c| self.current.is_none_or(|cur| cur.id != c.id))
            .copied()
            .collect();
        self.skip.clear();
        self.skip.extend(self.circled.iter().chain(given_up.iter()));
        if outcome == Outcome::Pending {
            // A waypoint is kept; a frontier goal while no cluster is left to circle.
            let frontier = current.is_some_and(|g| g.kind == goal_kind::FRONTIER);
            if !frontier || open.is_empty() && !self.session.frontier_goal_seen(inputs.explore) {
                return Step::Wait;
            }
        }
        if let Some(s) = self.next_waypoint(now_ns) {
            return s;
        }
        if let Some(c) = self.current.take() {
            self.circled.push(c.id);
            self.session.clusters_done = Some(self.circled.len() as u32);
            // The circle showed the room from new places: look for frontiers again.
            self.session.explored = false;
        }
        if !open.is_empty() {
            self.exploring = false;
            let (params, weights) = self.scoring;
            let job = CoverageJob {
                nav: self.session.buffers.nav(inputs.nav),
                base: inputs.state.base_pose,
                clusters: open,
                params: self.params,
                scoring: Scoring {
                    map: self.session.buffers.map(inputs.map),
                    params,
                    weights,
                },
            };
            return self.session.compute(PlannerJob::Coverage(job));
        }
        if all.is_empty() && !self.look.swept() {
            return Step::Wait;
        }
        if !self.session.explored {
            self.exploring = true;
            return self.session.frontier_job(inputs);
        }
        self.finish(!all.is_empty(), now_ns)
    }

    fn job_done(&mut self, output: JobOutput, now_ns: u64) -> Step {
        let r = match self.session.job_back(output, now_ns) {
            Back::Coverage(r) => r,
            other => return self.session.discard(other),
        };
        self.session.buffers.put_nav(r.nav);
        self.circle_map_seq = r.scoring.map.header.seq;
        self.session.buffers.put_map(r.scoring.map);
        self.session.given_up.extend(r.unreachable);
        match r.circle {
            Some(c) => {
                self.current = Some(c.cluster);
                self.queue = c.waypoints.into_iter().zip(c.views).collect();
                self.next_waypoint(now_ns).unwrap_or(Step::Wait)
            }
            // No cluster left with a reachable waypoint: explore (or end) on the next call.
            None => Step::Wait,
        }
    }

    fn neck_goal(&mut self, map: &ObjectMap, state: &RobotState, now_ns: u64) -> NeckGoal {
        let mut goal = neck_goal_for(map, self.mount.pitch());
        if let Some(yaw) = self.session.recovery_neck(state, now_ns) {
            goal.yaw = yaw;
            return goal;
        }
        let centre = self.current.map(|c| c.center).or_else(|| {
            clusters::first_unfinished(
                map,
                self.eps_sopm,
                &self.session.sides,
                usize::MAX,
                &self.skip,
            )
            .map(|c| c.center)
        });
        goal.yaw = match centre {
            Some(c) => self.mount.neck_yaw_toward(state.base_pose, c),
            None if self.exploring => self.sweep.yaw(now_ns),
            None => self.look.target(state.neck_yaw),
        };
        goal
    }

    fn status(&self) -> PlannerStatus {
        self.session.status()
    }

    fn summary(&self) -> Summary {
        self.session.summary()
    }

    fn take_decision(&mut self) -> Option<Box<PlannerDecision>> {
        self.session.take_decision()
    }
}

/// Frontier-exploration baseline.
#[derive(Debug)]
pub struct FrontierPlanner {
    mount: CameraMount,
    session: Session,
}

impl FrontierPlanner {
    /// A planner from the configuration.
    pub fn new(cfg: &PlannerConfig, camera: &CameraConfig) -> Self {
        let mut session = Session::new(PlannerKind::Frontier, cfg, 0);
        // Its frontier goals are its NBVs: evaluate their views like VP-SOM's.
        session.score_frontiers = Some(scoring_params(cfg, camera));
        Self {
            mount: camera.mount,
            session,
        }
    }
}

impl ViewPlanner for FrontierPlanner {
    fn kind(&self) -> PlannerKind {
        PlannerKind::Frontier
    }

    fn next_goal(&mut self, inputs: &PlannerInputs<'_>, now_ns: u64) -> Step {
        if let Some(step) = self.session.begin(inputs, now_ns) {
            return step;
        }
        if self.session.goals.poll(inputs.state) == Outcome::Pending
            && !self.session.frontier_goal_seen(inputs.explore)
        {
            return Step::Wait;
        }
        self.session.frontier_job(inputs)
    }

    fn job_done(&mut self, output: JobOutput, now_ns: u64) -> Step {
        match self.session.job_back(output, now_ns) {
            Back::Explored => self.session.finish(PlannerStatus::Terminated, now_ns),
            back => self.session.discard(back),
        }
    }

    fn neck_goal(&mut self, map: &ObjectMap, state: &RobotState, now_ns: u64) -> NeckGoal {
        let mut goal = neck_goal_for(map, self.mount.pitch());
        // Forward, unless the localization recovery turns the neck.
        if let Some(yaw) = self.session.recovery_neck(state, now_ns) {
            goal.yaw = yaw;
        }
        goal
    }

    fn status(&self) -> PlannerStatus {
        self.session.status()
    }

    fn summary(&self) -> Summary {
        self.session.summary()
    }

    fn take_decision(&mut self) -> Option<Box<PlannerDecision>> {
        self.session.take_decision()
    }
}
