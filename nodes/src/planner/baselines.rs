//! The two baselines of the paper's section 7.1 behind the [`ViewPlanner`] interface.
//!
//! - [`CoveragePlanner`]: circles every cluster once (see [`crate::planner::coverage`]) in order
//!   of first sighting, neck always on the centre of the cluster being circled (or, on the way
//!   to the first waypoint, of the next cluster). Before any cluster is known it behaves like
//!   VP-SOM's bootstrap (look around, then frontier goals). Ends (`Terminated`) once every
//!   known cluster has been circled; clusters without a reachable waypoint are given up and
//!   make the end `NoCandidates`.
//! - [`FrontierPlanner`]: Yamauchi frontier exploration (see [`crate::planner::frontier`]),
//!   neck fixed forward (yaw 0); ends (`Terminated`) when no reachable frontier remains.

use crate::config::CameraConfig;
use crate::geom::{CameraMount, wrap_angle};
use crate::planner::clusters::{self, ClusterInfo, SideTracker};
use crate::planner::config::{PlannerConfig, PlannerKind};
use crate::planner::coverage::{CoverageJob, CoverageParams};
use crate::planner::frontier::{FrontierJob, FrontierParams};
use crate::planner::reach::NavParams;
use crate::planner::session::{
    Buffers, Goals, JobOutput, LookAround, Outcome, PlannerInputs, PlannerJob, PlannerStatus, Step,
    Summary, ViewPlanner, map_counts,
};
use crate::planner::vpsom::frontier_params;
use shm_types::{NeckGoal, ObjectMap, RobotState, goal_kind};
use std::collections::VecDeque;

fn empty_summary(kind: PlannerKind) -> Summary {
    Summary {
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
        finished_ns: None,
    }
}

/// All-views coverage baseline.
#[derive(Debug)]
pub struct CoveragePlanner {
    eps_sopm: f32,
    params: CoverageParams,
    frontier: FrontierParams,
    mount: CameraMount,
    goals: Goals,
    buffers: Buffers,
    look: LookAround,
    sides: SideTracker,
    queue: VecDeque<[f32; 3]>,
    current: Option<ClusterInfo>,
    circled: Vec<i32>,
    given_up: Vec<i32>,
    blacklist: Vec<[f32; 2]>,
    exploring: bool,
    pending: bool,
    status: PlannerStatus,
    summary: Summary,
    jobs: u64,
}

impl CoveragePlanner {
    /// A planner from the configuration.
    pub fn new(cfg: &PlannerConfig, camera: &CameraConfig) -> Self {
        Self {
            eps_sopm: cfg.eps_sopm,
            params: CoverageParams {
                waypoints: cfg.coverage.waypoints,
                safe_distance: cfg.gbv.safe_distance,
                nav: NavParams::new(cfg),
            },
            frontier: frontier_params(cfg),
            mount: camera.mount,
            goals: Goals::new(),
            buffers: Buffers::default(),
            look: LookAround::new(
                cfg.bootstrap.look_around_steps,
                cfg.bootstrap.neck_tolerance_deg.to_radians(),
            ),
            sides: SideTracker::new(cfg.bootstrap.sectors),
            queue: VecDeque::new(),
            current: None,
            circled: Vec::with_capacity(shm_types::MAX_OBJECTS),
            given_up: Vec::with_capacity(shm_types::MAX_OBJECTS),
            blacklist: Vec::new(),
            exploring: false,
            pending: false,
            status: PlannerStatus::Running,
            summary: empty_summary(PlannerKind::Coverage),
            jobs: 0,
        }
    }

    fn finish(&mut self, now_ns: u64) -> Step {
        self.status = if self.given_up.is_empty() {
            PlannerStatus::Terminated
        } else {
            PlannerStatus::NoCandidates
        };
        self.summary.finished_ns = Some(now_ns);
        Step::Finished(self.summary())
    }

    fn next_waypoint(&mut self, now_ns: u64) -> Option<Step> {
        let w = self.queue.pop_front()?;
        let id = self.current.map_or(-1, |c| c.id);
        Some(Step::Goal(self.goals.issue(
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
        if self.status.is_finished() {
            return Step::Finished(self.summary());
        }
        map_counts(inputs.map, self.eps_sopm, &self.sides, 0, &mut self.summary);
        if self.pending {
            return Step::Wait;
        }
        let any_cluster = inputs.map.objects().iter().any(|o| o.is_background());
        if self.goals.poll(inputs.state) == Outcome::Pending && !(self.exploring && any_cluster) {
            return Step::Wait;
        }
        self.exploring = false;
        if let Some(s) = self.next_waypoint(now_ns) {
            return s;
        }
        if let Some(c) = self.current.take() {
            self.circled.push(c.id);
        }
        let all = clusters::clusters(inputs.map, self.eps_sopm, &self.sides, 0);
        if all.is_empty() {
            if !self.look.swept() {
                return Step::Wait;
            }
            self.exploring = true;
            self.pending = true;
            self.jobs += 1;
            return Step::Compute(PlannerJob::Frontier(FrontierJob {
                explore: self.buffers.explore(inputs.explore),
                nav: self.buffers.nav(inputs.nav),
                base: inputs.state.base_pose,
                blacklist: self.blacklist.clone(),
                params: self.frontier,
            }));
        }
        let open: Vec<ClusterInfo> = all
            .into_iter()
            .filter(|c| !self.circled.contains(&c.id) && !self.given_up.contains(&c.id))
            .collect();
        if open.is_empty() {
            return self.finish(now_ns);
        }
        self.pending = true;
        self.jobs += 1;
        Step::Compute(PlannerJob::Coverage(CoverageJob {
            nav: self.buffers.nav(inputs.nav),
            base: inputs.state.base_pose,
            clusters: open,
            params: self.params,
        }))
    }

    fn job_done(&mut self, output: JobOutput, now_ns: u64) -> Step {
        self.pending = false;
        match output {
            JobOutput::Coverage(r) => {
                self.buffers.put_nav(r.nav);
                self.given_up.extend(r.unreachable);
                match r.circle {
                    Some((info, wps)) => {
                        self.current = Some(info);
                        self.queue = wps.into();
                        self.next_waypoint(now_ns).unwrap_or(Step::Wait)
                    }
                    None => self.finish(now_ns),
                }
            }
            JobOutput::Frontier(r) => {
                self.buffers.put_explore(r.explore);
                self.buffers.put_nav(r.nav);
                match r.goal {
                    Some((pose, _)) => {
                        self.blacklist.push([pose[0], pose[1]]);
                        Step::Goal(self.goals.issue(pose, 0.0, -1, goal_kind::FRONTIER, now_ns))
                    }
                    None => {
                        self.status = PlannerStatus::NoCandidates;
                        self.summary.finished_ns = Some(now_ns);
                        Step::Finished(self.summary())
                    }
                }
            }
            JobOutput::Gbv(r) => {
                self.buffers.put_map(r.map);
                self.buffers.put_nav(r.nav);
                Step::Wait
            }
        }
    }

    fn neck_goal(&mut self, map: &ObjectMap, state: &RobotState, _now_ns: u64) -> NeckGoal {
        let mut goal = NeckGoal {
            map_seq: map.header.seq,
            frame_stamp_ns: map.last_frame_stamp_ns,
            pitch: self.mount.pitch(),
            ..Default::default()
        };
        let centre = self.current.map(|c| c.center).or_else(|| {
            clusters::first_unfinished(map, self.eps_sopm, &self.sides, usize::MAX, &self.circled)
                .map(|c| c.center)
        });
        goal.yaw = match centre {
            Some(c) => {
                let cam = self.mount.camera_pose(state.base_pose, 0.0, goal.pitch);
                let d = c - glam::Vec3::from(cam.translation);
                wrap_angle(d.y.atan2(d.x) - state.base_pose[2])
            }
            None => self.look.target(state.neck_yaw),
        };
        goal
    }

    fn status(&self) -> PlannerStatus {
        self.status
    }

    fn summary(&self) -> Summary {
        Summary {
            status: self.status,
            goals_issued: self.goals.issued,
            goals_unreachable: self.goals.unreachable,
            rounds: self.jobs,
            clusters_done: self.circled.len() as u32,
            clusters_given_up: self.given_up.len() as u32,
            ..self.summary
        }
    }
}

/// Frontier-exploration baseline.
#[derive(Debug)]
pub struct FrontierPlanner {
    eps_sopm: f32,
    params: FrontierParams,
    mount: CameraMount,
    goals: Goals,
    buffers: Buffers,
    sides: SideTracker,
    blacklist: Vec<[f32; 2]>,
    pending: bool,
    status: PlannerStatus,
    summary: Summary,
    jobs: u64,
}

impl FrontierPlanner {
    /// A planner from the configuration.
    pub fn new(cfg: &PlannerConfig, camera: &CameraConfig) -> Self {
        Self {
            eps_sopm: cfg.eps_sopm,
            params: frontier_params(cfg),
            mount: camera.mount,
            goals: Goals::new(),
            buffers: Buffers::default(),
            sides: SideTracker::new(cfg.bootstrap.sectors),
            blacklist: Vec::new(),
            pending: false,
            status: PlannerStatus::Running,
            summary: empty_summary(PlannerKind::Frontier),
            jobs: 0,
        }
    }
}

impl ViewPlanner for FrontierPlanner {
    fn kind(&self) -> PlannerKind {
        PlannerKind::Frontier
    }

    fn next_goal(&mut self, inputs: &PlannerInputs<'_>, _now_ns: u64) -> Step {
        if self.status.is_finished() {
            return Step::Finished(self.summary());
        }
        map_counts(inputs.map, self.eps_sopm, &self.sides, 0, &mut self.summary);
        if self.pending || self.goals.poll(inputs.state) == Outcome::Pending {
            return Step::Wait;
        }
        self.pending = true;
        self.jobs += 1;
        Step::Compute(PlannerJob::Frontier(FrontierJob {
            explore: self.buffers.explore(inputs.explore),
            nav: self.buffers.nav(inputs.nav),
            base: inputs.state.base_pose,
            blacklist: self.blacklist.clone(),
            params: self.params,
        }))
    }

    fn job_done(&mut self, output: JobOutput, now_ns: u64) -> Step {
        self.pending = false;
        match output {
            JobOutput::Frontier(r) => {
                self.buffers.put_explore(r.explore);
                self.buffers.put_nav(r.nav);
                match r.goal {
                    Some((pose, _)) => {
                        self.blacklist.push([pose[0], pose[1]]);
                        Step::Goal(self.goals.issue(pose, 0.0, -1, goal_kind::FRONTIER, now_ns))
                    }
                    None => {
                        self.status = PlannerStatus::Terminated;
                        self.summary.finished_ns = Some(now_ns);
                        Step::Finished(self.summary())
                    }
                }
            }
            JobOutput::Gbv(r) => {
                self.buffers.put_map(r.map);
                self.buffers.put_nav(r.nav);
                Step::Wait
            }
            JobOutput::Coverage(r) => {
                self.buffers.put_nav(r.nav);
                Step::Wait
            }
        }
    }

    fn neck_goal(&mut self, map: &ObjectMap, _state: &RobotState, _now_ns: u64) -> NeckGoal {
        NeckGoal {
            map_seq: map.header.seq,
            frame_stamp_ns: map.last_frame_stamp_ns,
            yaw: 0.0,
            pitch: self.mount.pitch(),
            ..Default::default()
        }
    }

    fn status(&self) -> PlannerStatus {
        self.status
    }

    fn summary(&self) -> Summary {
        Summary {
            status: self.status,
            goals_issued: self.goals.issued,
            goals_unreachable: self.goals.unreachable,
            rounds: self.jobs,
            ..self.summary
        }
    }
}
