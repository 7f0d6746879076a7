//! One step loop for the hosts that step the mapper and the planner on a simulated clock
//! (lockstep, replay): [`NodeStep`] owns the mapper, the planner and their outputs, and
//! [`NodeStep::tick`] runs what is due at a time `t`: the map at `rates.map_hz`, the LBV at
//! `planner.lbv_hz`, and the GBV, whose rounds run inline. [`gbv_cycle`] is the GBV part of a
//! cycle that every host shares, the deploy planner and the live check included. The host feeds frames
//! ([`NodeStep::integrate`]) and decides where the outputs go ([`Outputs`]): to the simulator
//! and the recorder (lockstep), or to the comparison with a recording (replay).
//!
//! Every output is stamped with `t`, as a deployment host's publisher stamps what it sends.

use crate::config::Config;
use crate::mapper::{FrameStats, Mapper, MapperError};
use crate::planner::{self, JobOutput, PlannerInputs, Step, Summary, ViewPlanner};
use shm_types::{
    DepthFrame, Detections, Header, NavGoal, NeckGoal, ObjectMap, OccupancyGrid, PlannerDecision,
    RobotState, boxed_zeroed,
};

/// Where a host puts what the nodes produce in a step (each already stamped).
pub trait Outputs {
    /// A published object map (and the exploration grid beside it in [`NodeStep::explore`]).
    fn map(&mut self, map: &ObjectMap);
    /// A neck goal (LBV).
    fn neck(&mut self, neck: &NeckGoal);
    /// A decision trace (LBV, or the GBV's with its goal).
    fn decision(&mut self, decision: &PlannerDecision);
    /// A chassis goal (GBV); its decision, if any, came just before.
    fn nav(&mut self, goal: &NavGoal);
}

/// The mapper and the planner of one session, with their outputs and their schedule.
#[derive(Debug)]
pub struct NodeStep {
    /// The mapper.
    pub mapper: Mapper,
    /// The planner (`planner.kind`).
    pub planner: Box<dyn ViewPlanner>,
    /// The latest published map.
    pub map: Box<ObjectMap>,
    /// The latest exploration grid (written with each map).
    pub explore: Box<OccupancyGrid>,
    lbv_trace: Box<PlannerDecision>,
    map_period: u64,
    lbv_period: u64,
    next_map: u64,
    next_lbv: u64,
}

impl NodeStep {
    /// The mapper and planner of `cfg`, with nothing due before time 0.
    pub fn new(cfg: &Config) -> Result<Self, settings::ConfigError> {
        let period = |hz: f64| (1e9 / hz).round() as u64;
        Ok(Self {
            mapper: Mapper::new(&cfg.mapper, &cfg.camera.camera())?,
            planner: planner::make_planner(&cfg.planner, &cfg.camera),
            map: boxed_zeroed(),
            explore: boxed_zeroed(),
            lbv_trace: boxed_zeroed(),
            map_period: period(cfg.rates.map_hz),
            lbv_period: period(cfg.planner.lbv_hz),
            next_map: 0,
            next_lbv: 0,
        })
    }

    /// The mapper takes a frame, its detections and the robot state it was taken at.
    pub fn integrate(
        &mut self,
        frame: &DepthFrame,
        dets: &Detections,
        state: &RobotState,
    ) -> Result<FrameStats, MapperError> {
        self.mapper.integrate(frame, dets, state)
    }

    /// What is due at `t`: the map, then the LBV, then the GBV (rounds computed inline until
    /// the planner waits, sends a goal or finishes). Returns the summary once it finished.
    pub fn tick(
        &mut self,
        t: u64,
        state: &RobotState,
        nav: &OccupancyGrid,
        out: &mut impl Outputs,
    ) -> Option<Summary> {
        if t >= self.next_map {
            self.mapper.write_map(&mut self.map, t);
            self.mapper.write_grid(&mut self.explore);
            out.map(&self.map);
            self.next_map += self.map_period;
        }
        if t >= self.next_lbv {
            let mut neck = self.planner.neck_goal(&self.map, state, t);
            stamp(&mut neck.header, t);
            if self.planner.lbv_decision(&mut self.lbv_trace) {
                stamp(&mut self.lbv_trace.header, t);
                out.decision(&self.lbv_trace);
            }
            out.neck(&neck);
            self.next_lbv += self.lbv_period;
        }
        let inputs = || PlannerInputs {
            map: &self.map,
            state,
            nav,
            explore: &self.explore,
        };
        let planner = &mut *self.planner;
        let mut step = gbv_cycle(planner, None, false, inputs, t);
        loop {
            step = match step {
                Step::Wait => return None,
                Step::Goal(mut goal) => {
                    stamp(&mut goal.header, t);
                    if let Some(mut d) = planner.take_decision() {
                        stamp(&mut d.header, t);
                        out.decision(&d);
                    }
                    out.nav(&goal);
                    return None;
                }
                Step::Compute(job) => gbv_cycle(planner, Some(job.run()), false, inputs, t),
                Step::Finished(summary) => return Some(summary),
            };
        }
    }
}

/// The GBV part of a planner cycle, the same in every host: a finished `round` goes to the
/// planner; else, unless a round is still out (`busy`), the planner is asked for its next step
/// with the cycle's `inputs`. What the host does with a [`Step::Compute`] is its own: run it
/// inline (lockstep, replay, the live check) or on the low-priority pool (the deploy planner).
pub fn gbv_cycle<'a>(
    planner: &mut dyn ViewPlanner,
    round: Option<JobOutput>,
    busy: bool,
    inputs: impl FnOnce() -> PlannerInputs<'a>,
    t: u64,
) -> Step {
    match round {
        Some(out) => planner.job_done(out, t),
        None if !busy => planner.next_goal(&inputs(), t),
        None => Step::Wait,
    }
}

/// Stamps a planner output with the simulated time it was made at, as a deployment host's
/// publisher does when it sends it (the logic leaves headers to its host).
pub(crate) fn stamp(h: &mut Header, t: u64) {
    h.stamp_ns = t;
    h.sim_time_ns = t;
}
