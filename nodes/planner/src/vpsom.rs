//! The VP-SOM planner (paper Algorithms 1 and 2): GBV rounds for the chassis, LBV for the neck,
//! termination per section 3.4, and exploration whenever no unfinished cluster is known.
//!
//! Modes:
//! 1. **Look-around** (no cluster known yet, start of session): the neck sweeps 360° in place
//!    through `bootstrap.look_around_steps` stops; no chassis goal.
//! 2. **Explore** (no open cluster: none known after the sweep, or every known one done or given
//!    up): frontier goals on the exploration grid (kind FRONTIER), the neck sweeping. As soon as
//!    an open cluster appears the frontier goal is superseded by a GBV round. When a frontier
//!    round finds no reachable frontier the room is explored and the session ends.
//! 3. **GBV**: for the first open cluster by first sighting, a [`GbvJob`]; its best view is
//!    published (kind GBV). When the base reports REACHED or UNREACHABLE for it, the round ends:
//!    the stall rule samples the cluster's unfinished objects ([`GiveUps`]) and the next round
//!    starts. Each round's goal is remembered for its cluster: later rounds drop candidates
//!    within `gbv.revisit_radius` of it, so every round moves the base somewhere new. A cluster
//!    gets at most `gbv.max_rounds_per_cluster` rounds (rounds in which it had no reachable
//!    candidate count too). A cluster that was approached at least once and then runs out of
//!    rounds, or of new views, ends: its unfinished objects are given up. A cluster that never
//!    had a reachable candidate is given up as unreachable. A GBV goal still being driven to when
//!    no cluster is open any more is superseded by exploration. Among a round's candidates the
//!    one maximising `F(v) / F_max − gbv.distance_weight × path` is chosen ([`GbvJob`]).
//! 4. **Reopen**: an ended cluster in which a new open foreground object appears (one first seen
//!    late, hidden behind another) reopens with `gbv.reopen_rounds` more rounds, at most
//!    `gbv.max_reopens` times per cluster, so it cannot loop.
//!
//! Objects with fewer than `planner.min_observations` detections are not trusted: they open no
//! cluster and hold no session open ([`GiveUps::trusted`]).
//!
//! An open cluster is one that is not done, not ended, not unreachable, and has an unfinished
//! foreground object not given up (or, without foreground objects, was not yet seen from enough
//! sides). The LBV always tracks the cluster of the current GBV goal while it is open, else the
//! first open cluster; with none, the neck sweeps while exploring, and otherwise stays on the
//! last GBV goal's cluster (a 360° sweep on top of the base's turns loses localization).
//! Termination: no open cluster and the room explored → `Terminated` (objects given up are
//! listed in the summary and [`ViewPlanner::given_up_objects`], clusters given up as unreachable
//! counted in [`Summary::clusters_given_up`] and its reason); `NoCandidates` only if nothing was
//! found at all.

use crate::clusters::{self, ClusterInfo, members};
use crate::config::{PlannerConfig, PlannerKind};
use crate::evaluate::{EvalParams, Target};
use crate::gbv::{GbvJob, GbvParams};
use crate::giveup::{GiveUps, GivenUpObject, StallRule};
use crate::lbv::Lbv;
use crate::session::{
    Back, ExploreSweep, JobOutput, LookAround, Outcome, PlannerInputs, PlannerJob, PlannerStatus,
    Session, Step, Summary, ViewPlanner, neck_goal_for,
};
use crate::terms::View;
use geom::CameraConfig;
use geom::CameraMount;
use glam::Vec3;
use shm_types::{NeckGoal, ObjectMap, PlannerDecision, RobotState, goal_kind};

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Mode {
    LookAround,
    Explore,
    Gbv,
}

/// VP-SOM (see the module docs).
#[derive(Debug)]
pub struct VpsomPlanner {
    cfg: PlannerConfig,
    eval: EvalParams,
    gbv: GbvParams,
    mount: CameraMount,
    lbv: Lbv,
    last_lbv: Option<usize>,
    last_cluster: i32,
    session: Session,
    look: LookAround,
    sweep: ExploreSweep,
    mode: Mode,
    tracked: Option<i32>,
    rounds: Vec<(i32, u32)>,
    visited: Vec<(i32, [f32; 2])>,
    /// Clusters approached and then out of rounds or views.
    ended: Vec<i32>,
    /// Times each cluster reopened.
    reopens: Vec<(i32, u32)>,
    /// Clusters closed for the LBV (unreachable, ended, or every unfinished object given up);
    /// refreshed by `next_goal`, read on the LBV path (fixed capacity).
    closed: Vec<i32>,
    give_ups: GiveUps,
}

impl VpsomPlanner {
    /// A planner from the configuration.
    pub fn new(cfg: &PlannerConfig, camera: &CameraConfig) -> Self {
        let gbv = GbvParams::new(cfg, camera);
        let eval = gbv.eval;
        let rule = StallRule {
            rounds: cfg.give_up.rounds,
            min_drop: cfg.give_up.min_drop,
        };
        Self {
            cfg: cfg.clone(),
            eval,
            gbv,
            mount: camera.mount,
            lbv: Lbv::new(cfg, camera),
            last_lbv: None,
            last_cluster: -1,
            session: Session::new(PlannerKind::Vpsom, cfg, cfg.bootstrap.empty_cluster_sectors),
            look: LookAround::new(
                cfg.bootstrap.look_around_steps,
                cfg.bootstrap.neck_tolerance_deg.to_radians(),
            ),
            sweep: ExploreSweep::new(cfg),
            mode: Mode::LookAround,
            tracked: None,
            rounds: Vec::with_capacity(shm_types::MAX_OBJECTS),
            visited: Vec::new(),
            ended: Vec::with_capacity(shm_types::MAX_OBJECTS),
            reopens: Vec::new(),
            closed: Vec::with_capacity(shm_types::MAX_OBJECTS),
            give_ups: GiveUps::new(rule, cfg.eps_sopm, cfg.min_observations),
        }
    }

    fn min_sides(&self) -> usize {
        self.cfg.bootstrap.empty_cluster_sectors
    }

    fn approached(&self, id: i32) -> bool {
        self.visited.iter().any(|(c, _)| *c == id)
    }

    /// Cluster `id` has no view left: it ends (its unfinished objects given up) if it was
    /// approached before, else it is given up as unreachable.
    fn no_view_left(&mut self, map: &ObjectMap, id: i32) {
        if self.approached(id) {
            if !self.ended.contains(&id) {
                self.ended.push(id);
            }
            self.give_ups.cluster_ended(map, id);
        } else if !self.session.given_up.contains(&id) {
            self.session.given_up.push(id);
        }
        self.session.objects_given_up = self.give_ups.list().len() as u32;
    }

    fn count_round(&mut self, map: &ObjectMap, id: i32) {
        match self.rounds.iter_mut().find(|(c, _)| *c == id) {
            Some((_, n)) => *n += 1,
            None => self.rounds.push((id, 1)),
        }
        let n = self
            .rounds
            .iter()
            .find(|(c, _)| *c == id)
            .map_or(0, |r| r.1);
        if n >= self.cfg.gbv.max_rounds_per_cluster {
            self.no_view_left(map, id);
        }
    }

    /// Reopen every ended cluster with a new open foreground object (one that appeared after it
    /// ended), within the reopen budget: it gets `gbv.reopen_rounds` more rounds.
    fn reopen(&mut self, map: &ObjectMap) {
        let g = self.cfg.gbv;
        if g.reopen_rounds == 0 {
            return;
        }
        let mut k = 0;
        while k < self.ended.len() {
            let id = self.ended[k];
            let times = self
                .reopens
                .iter()
                .find(|(c, _)| *c == id)
                .map_or(0, |r| r.1);
            if times >= g.max_reopens || self.give_ups.open_members(map, id).next().is_none() {
                k += 1;
                continue;
            }
            self.ended.swap_remove(k);
            match self.reopens.iter_mut().find(|(c, _)| *c == id) {
                Some((_, n)) => *n += 1,
                None => self.reopens.push((id, 1)),
            }
            let left = g.max_rounds_per_cluster.saturating_sub(g.reopen_rounds);
            match self.rounds.iter_mut().find(|(c, _)| *c == id) {
                Some((_, n)) => *n = (*n).min(left),
                None => self.rounds.push((id, left)),
            }
        }
    }

    /// Whether a cluster needs more views.
    fn is_open(&self, map: &ObjectMap, c: &ClusterInfo) -> bool {
        !self.session.given_up.contains(&c.id)
            && !self.ended.contains(&c.id)
            && !self.give_ups.settled(map, c)
    }

    /// The centroid of the cluster's unfinished objects not given up (its centre if none);
    /// does not allocate.
    fn open_centroid(&self, map: &ObjectMap, info: &ClusterInfo) -> Vec3 {
        let (mut sum, mut n) = (Vec3::ZERO, 0u32);
        for o in members(map, info.id) {
            if self.give_ups.is_open(o) {
                sum += Vec3::from(o.center);
                n += 1;
            }
        }
        if n == 0 { info.center } else { sum / n as f32 }
    }

    fn target(&self, map: &ObjectMap) -> Option<Target> {
        let eps = self.cfg.eps_sopm;
        let (sides, closed) = (&self.session.sides, &self.closed);
        let open = |c: &ClusterInfo| !(c.done || self.give_ups.settled(map, c));
        let tracked = self
            .tracked
            .filter(|id| !closed.contains(id))
            .and_then(|id| clusters::cluster_info(map, id, eps))
            .map(|mut c| {
                sides.judge_by_id(map, &mut c, self.min_sides());
                c
            })
            .filter(open);
        let info = tracked.or_else(|| {
            clusters::first_unfinished(map, eps, sides, self.min_sides(), closed)
                .filter(|c| !self.give_ups.settled(map, c))
        })?;
        Some(Target {
            cluster_id: info.id,
            centroid: self.open_centroid(map, &info),
        })
    }

    fn finish(&mut self, map: &ObjectMap, all: &[ClusterInfo], now_ns: u64) -> Step {
        // Objects that appeared in an ended cluster after its reopen budget was spent are given
        // up with it.
        for id in self.ended.clone() {
            self.give_ups.cluster_ended(map, id);
        }
        self.session.objects_given_up = self.give_ups.list().len() as u32;
        // Clusters given up as unreachable are listed (summary); they end the session normally.
        let status = if all.is_empty() {
            PlannerStatus::NoCandidates
        } else {
            PlannerStatus::Terminated
        };
        self.session.finish(status, now_ns)
    }
}

impl ViewPlanner for VpsomPlanner {
    fn kind(&self) -> PlannerKind {
        PlannerKind::Vpsom
    }

    fn next_goal(&mut self, inputs: &PlannerInputs<'_>, now_ns: u64) -> Step {
        if let Some(step) = self.session.begin(inputs, now_ns) {
            return step;
        }
        let map = inputs.map;
        let eps = self.cfg.eps_sopm;
        let current = self.session.goals.current;
        let outcome = self.session.goals.poll(inputs.state);
        if let Some(g) = current
            && g.kind == goal_kind::GBV
            && matches!(outcome, Outcome::Reached | Outcome::Unreachable)
        {
            self.give_ups.round_ended(map, g.cluster_id);
            self.session.objects_given_up = self.give_ups.list().len() as u32;
        }
        self.reopen(map);
        let all: Vec<ClusterInfo> =
            clusters::clusters(map, eps, &self.session.sides, self.min_sides());
        let open: Vec<ClusterInfo> = all
            .iter()
            .filter(|c| self.is_open(map, c))
            .copied()
            .collect();
        let mut closed = std::mem::take(&mut self.closed);
        closed.clear();
        closed.extend(all.iter().filter(|c| !self.is_open(map, c)).map(|c| c.id));
        self.closed = closed;
        if outcome == Outcome::Pending {
            // A frontier goal is kept while no cluster is open, a GBV goal while one is; else
            // it is superseded.
            // A frontier goal whose neighbourhood has been seen on the way is not driven to
            // the end: the next frontier round starts (`frontier.seen_radius`).
            let frontier = current.is_some_and(|g| g.kind == goal_kind::FRONTIER);
            if frontier == open.is_empty()
                && !(frontier && self.session.frontier_goal_seen(inputs.explore))
            {
                return Step::Wait;
            }
        }
        if !open.is_empty() {
            self.mode = Mode::Gbv;
            let mut snapshot = self.session.buffers.map(map);
            self.give_ups.mark_complete(&mut snapshot);
            let job = GbvJob {
                map: snapshot,
                nav: self.session.buffers.nav(inputs.nav),
                base: inputs.state.base_pose,
                clusters: open,
                visited: self.visited.clone(),
                params: self.gbv,
            };
            return self.session.compute(PlannerJob::Gbv(job));
        }
        if all.is_empty() && !self.look.swept() {
            self.mode = Mode::LookAround;
            return Step::Wait;
        }
        if !self.session.explored {
            self.mode = Mode::Explore;
            return self.session.frontier_job(inputs);
        }
        self.finish(map, &all, now_ns)
    }

    fn job_done(&mut self, output: JobOutput, now_ns: u64) -> Step {
        let r = match self.session.job_back(output, now_ns) {
            Back::Gbv(r) => r,
            other => return self.session.discard(other),
        };
        self.session.decision = Some(r.decision);
        let Some(b) = r.best else {
            // No open cluster has a view left: each ends or is given up; exploration (or the
            // end) follows on the next call.
            for id in &r.unreachable {
                self.no_view_left(&r.map, *id);
            }
            self.session.buffers.put_map(r.map);
            self.session.buffers.put_nav(r.nav);
            return Step::Wait;
        };
        for id in &r.unreachable {
            self.count_round(&r.map, *id);
        }
        self.give_ups.start(&r.map, b.cluster_id);
        self.count_round(&r.map, b.cluster_id);
        self.session.buffers.put_map(r.map);
        self.session.buffers.put_nav(r.nav);
        self.tracked = Some(b.cluster_id);
        self.visited.push((b.cluster_id, [b.pose[0], b.pose[1]]));
        // The base goes somewhere new: the room is looked at again once no cluster is open.
        self.session.explored = false;
        Step::Goal(
            self.session
                .goals
                .issue(b.pose, b.score, b.cluster_id, goal_kind::GBV, now_ns),
        )
    }

    fn neck_goal(&mut self, map: &ObjectMap, state: &RobotState, now_ns: u64) -> NeckGoal {
        if let Some(yaw) = self.session.recovery_neck(state, now_ns) {
            // Localization lost: the recovery turns the neck (no LBV, no sides observed).
            self.last_lbv = None;
            return NeckGoal {
                yaw,
                ..neck_goal_for(map, self.mount.pitch())
            };
        }
        let pose = self
            .mount
            .camera_pose(state.base_pose, state.neck_yaw, state.neck_pitch);
        self.session
            .sides
            .observe(map, &self.eval.camera, &View::new(pose));
        let mut goal = neck_goal_for(map, self.mount.pitch());
        let target = self.target(map);
        self.last_cluster = target.map_or(-1, |t| t.cluster_id);
        match target {
            Some(t) => {
                let choice = self
                    .lbv
                    .evaluate(map, state.base_pose, state.neck_yaw, Some(&t));
                self.last_lbv = choice.map(|c| c.index);
                if let Some(c) = choice {
                    goal.yaw = c.neck_yaw;
                    goal.score = c.score;
                }
            }
            None => {
                self.last_lbv = None;
                // Exploring: the slow sweep about the heading. Otherwise (every known cluster
                // done while the last GBV goal is still being driven to) keep the camera on that
                // goal's cluster: a full-rate 360° sweep on top of the base's turns exceeds the
                // tracking rate and loses localization. Before anything is known: look around.
                let held = self
                    .tracked
                    .and_then(|id| clusters::cluster_info(map, id, self.cfg.eps_sopm));
                goal.yaw = match (self.mode, held) {
                    (Mode::Explore, _) => self.sweep.yaw(now_ns),
                    (_, Some(c)) => self.mount.neck_yaw_toward(state.base_pose, c.center),
                    (_, None) => self.look.target(state.neck_yaw),
                };
            }
        }
        goal
    }

    fn status(&self) -> PlannerStatus {
        self.session.status()
    }

    fn summary(&self) -> Summary {
        self.session.summary()
    }

    fn given_up_objects(&self) -> Vec<GivenUpObject> {
        self.give_ups.list().to_vec()
    }

    fn take_decision(&mut self) -> Option<Box<PlannerDecision>> {
        self.session.take_decision()
    }

    fn lbv_decision(&self, d: &mut PlannerDecision) -> bool {
        let Some(i) = self.last_lbv else {
            return false;
        };
        self.lbv.fill_decision(Some(i), d);
        d.cluster_id = self.last_cluster;
        d.state = self.session.status().code();
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synth::add_object;
    use shm_types::{OccupancyGrid, boxed_zeroed, grid_cell, nav_status};

    /// The default planner without the approach rule (`bootstrap.approach_m`): these tests
    /// never move the camera, so no cluster would ever be approached.
    fn planner() -> VpsomPlanner {
        let mut cfg = PlannerConfig::default();
        cfg.bootstrap.approach_m = f32::INFINITY;
        VpsomPlanner::new(&cfg, &CameraConfig::default())
    }

    /// A desk (cluster 1) at (2, 0) with a cup seen from `from` (complete if `done`).
    fn desk_map(from: &[[f32; 2]], done: bool) -> Box<ObjectMap> {
        let mut m = boxed_zeroed::<ObjectMap>();
        m.eps_sopm = 0.42;
        let all = [[4.0, 0.0], [2.0, 2.0], [0.0, 0.0], [2.0, -2.0]];
        add_object(
            &mut m,
            1,
            60,
            true,
            1,
            [2.0, 0.0, 0.36],
            [1.0, 0.8, 0.72],
            &all,
            1,
        );
        add_object(
            &mut m,
            2,
            41,
            false,
            1,
            [2.0, 0.1, 0.78],
            [0.09, 0.09, 0.11],
            from,
            2,
        );
        m.objects[1].complete = done as u8;
        m
    }

    /// 4 m × 4 m at 0.1 m: the left `known` columns free, the rest unknown.
    fn grid(known: usize) -> Box<OccupancyGrid> {
        let mut g = boxed_zeroed::<OccupancyGrid>();
        (g.resolution, g.width, g.height) = (0.1, 40, 40);
        g.origin = [-1.0, -2.0];
        for i in 0..1600 {
            g.cells[i] = if i % 40 < known {
                grid_cell::FREE
            } else {
                grid_cell::UNKNOWN
            };
        }
        g
    }

    fn inputs<'a>(
        map: &'a ObjectMap,
        state: &'a RobotState,
        nav: &'a OccupancyGrid,
        explore: &'a OccupancyGrid,
    ) -> PlannerInputs<'a> {
        PlannerInputs {
            map,
            state,
            nav,
            explore,
        }
    }

    /// Run jobs inline until the planner returns something else.
    fn settle(p: &mut VpsomPlanner, step: Step) -> Step {
        let mut step = step;
        while let Step::Compute(job) = step {
            step = p.job_done(job.run(), 0);
        }
        step
    }

    #[test]
    fn a_done_room_is_explored_before_it_terminates() {
        let mut p = planner();
        let map = desk_map(&[[4.0, 0.0], [2.0, 2.0], [0.0, 0.0], [2.0, -2.0]], true);
        assert!(map.objects[1].is_complete());
        let (state, empty) = (RobotState::default(), boxed_zeroed::<OccupancyGrid>());
        let mut explore = grid(20);
        // Every cluster done but unknown space left: a frontier goal, not the end.
        let step = p.next_goal(&inputs(&map, &state, &empty, &explore), 0);
        let Step::Compute(PlannerJob::Frontier(_)) = step else {
            panic!("explore first: {step:?}");
        };
        let Step::Goal(g) = settle(&mut p, step) else {
            panic!("a frontier goal");
        };
        assert_eq!(g.kind, goal_kind::FRONTIER);
        assert!(!p.status().is_finished());
        // The frontier goal is kept while it is driven to.
        let step = p.next_goal(&inputs(&map, &state, &empty, &explore), 1);
        assert!(matches!(step, Step::Wait), "{step:?}");
        // Reached, and nothing unknown is left: explored, then terminated.
        let reached = RobotState {
            nav_goal_id: g.goal_id,
            nav_status: nav_status::REACHED,
            ..Default::default()
        };
        explore = grid(40);
        let step = p.next_goal(&inputs(&map, &reached, &empty, &explore), 2);
        assert!(matches!(settle(&mut p, step), Step::Wait));
        let Step::Finished(s) = p.next_goal(&inputs(&map, &reached, &empty, &explore), 3) else {
            panic!("finished");
        };
        assert_eq!((s.status, s.explored), (PlannerStatus::Terminated, true));
        assert_eq!(s.reason(), "complete and explored");
    }

    #[test]
    fn a_done_cluster_seen_only_from_afar_gets_a_gbv_before_the_room_is_explored() {
        // The default approach rule; the desk's one object completed from 2 m away.
        let mut p = VpsomPlanner::new(&PlannerConfig::default(), &CameraConfig::default());
        let map = desk_map(&[[4.0, 0.0], [2.0, 2.0], [0.0, 0.0], [2.0, -2.0]], true);
        let (empty, explore) = (boxed_zeroed::<OccupancyGrid>(), grid(20));
        let mut state = RobotState {
            neck_pitch: p.mount.pitch(),
            ..Default::default()
        };
        // The camera at the origin looks at the desk: 1.36 m from its footprint circle.
        p.neck_goal(&map, &state, 0);
        let step = p.next_goal(&inputs(&map, &state, &empty, &explore), 0);
        let Step::Goal(g) = settle(&mut p, step) else {
            panic!("a GBV goal");
        };
        assert_eq!((g.kind, g.cluster_id), (goal_kind::GBV, 1));
        let d = (g.pose[0] - 2.0).hypot(g.pose[1]);
        assert!(d < 0.64 + 1.0, "the goal approaches the desk: {d} m");
        // There, looking at the desk: approached, so done; the room is explored next.
        state.base_pose = g.pose;
        state.nav_goal_id = g.goal_id;
        state.nav_status = nav_status::REACHED;
        p.neck_goal(&map, &state, 1);
        let step = p.next_goal(&inputs(&map, &state, &empty, &explore), 2);
        let Step::Goal(g) = settle(&mut p, step) else {
            panic!("a frontier goal");
        };
        assert_eq!(g.kind, goal_kind::FRONTIER);
    }

    #[test]
    fn an_open_cluster_supersedes_a_frontier_goal() {
        let mut p = planner();
        let done = desk_map(&[[4.0, 0.0], [2.0, 2.0], [0.0, 0.0], [2.0, -2.0]], true);
        let (state, empty, explore) = (
            RobotState::default(),
            boxed_zeroed::<OccupancyGrid>(),
            grid(20),
        );
        let step = p.next_goal(&inputs(&done, &state, &empty, &explore), 0);
        let Step::Goal(g) = settle(&mut p, step) else {
            panic!("a frontier goal");
        };
        assert_eq!(g.kind, goal_kind::FRONTIER);
        // While it is driven to, a cup seen from one side appears: a GBV round at once.
        let open = desk_map(&[[0.0, 0.0]], false);
        let step = p.next_goal(&inputs(&open, &state, &empty, &explore), 1);
        assert!(
            matches!(step, Step::Compute(PlannerJob::Gbv(_))),
            "{step:?}"
        );
        let Step::Goal(g) = settle(&mut p, step) else {
            panic!("a GBV goal");
        };
        assert_eq!((g.kind, g.cluster_id), (goal_kind::GBV, 1));
        // The GBV goal is kept while the cluster is open.
        let step = p.next_goal(&inputs(&open, &state, &empty, &explore), 2);
        assert!(matches!(step, Step::Wait));
    }

    #[test]
    fn a_stalled_object_is_given_up_and_the_session_terminates() {
        // The rule as written for this test (the defaults are 2 rounds, 0.05).
        let mut cfg = PlannerConfig::default();
        cfg.give_up.rounds = 3;
        cfg.give_up.min_drop = 0.02;
        cfg.bootstrap.approach_m = f32::INFINITY;
        let mut p = VpsomPlanner::new(&cfg, &CameraConfig::default());
        let mut map = desk_map(&[[0.0, 0.0]], false);
        let h = map.objects[1].h_sopm;
        assert!(h > 0.42, "{h}");
        let empty = boxed_zeroed::<OccupancyGrid>();
        let mut state = RobotState::default();
        let mut gbv_goals = 0;
        let summary = loop {
            let step = p.next_goal(&inputs(&map, &state, &empty, &empty), 0);
            match settle(&mut p, step) {
                Step::Goal(g) => {
                    assert_eq!(g.kind, goal_kind::GBV, "no frontier in an empty grid");
                    gbv_goals += 1;
                    // Reached; the cup was observed again, and its entropy did not fall.
                    state.nav_goal_id = g.goal_id;
                    state.nav_status = nav_status::REACHED;
                    map.objects[1].observations += 10;
                }
                Step::Wait => {}
                Step::Finished(s) => break s,
                Step::Compute(_) => unreachable!(),
            }
            assert!(
                gbv_goals < cfg.gbv.max_rounds_per_cluster,
                "given up before the round limit"
            );
        };
        // Three rounds that saw it without a fall of 0.02: given up; then explored and done.
        assert_eq!(gbv_goals, 3);
        assert_eq!(summary.status, PlannerStatus::Terminated, "{summary}");
        assert_eq!((summary.objects_given_up, summary.explored), (1, true));
        assert!(summary.reason().starts_with("objects given up: 1"));
        let g = &p.given_up_objects()[0];
        assert_eq!((g.map_id, g.label, g.cluster_id), (2, "cup", 1));
        assert!((g.h_sopm - h).abs() < 1e-6);
    }
}
