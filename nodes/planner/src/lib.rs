//! View planning: VP-SOM (paper sections 3–5, Algorithms 1 and 2) and the coverage and frontier
//! baselines, behind one interface ([`ViewPlanner`]).
//!
//! The planner sees no ground truth: only the [`ObjectMap`](shm_types::ObjectMap), the estimated
//! [`RobotState`](shm_types::RobotState), the navigation grid (obstacles only; reachability and
//! collision) and the exploration grid built from depth (UNKNOWN cells; frontiers).
//!
//! # Files
//! | file | content |
//! |---|---|
//! | [`terms`] | each term of F(v): H_IoU, cos θ_sopm, co-visibility, N_cp, cos θ_c, f_a, f_c |
//! | [`evaluate`] | F(v) of one camera pose over a map snapshot, as a traced `Candidate` |
//! | [`sight`] | occlusion in f_a's in-view test: ray casts against map cuboids and grid walls |
//! | [`clusters`] | clusters by first sighting, completion rule, sides-seen tracker |
//! | [`giveup`] | the stall rule: objects whose entropy stops falling are given up |
//! | [`gbv`] | global candidates on a ring, [`GbvJob`] (owned, parallel) |
//! | [`lbv`] | [`Lbv`]: neck candidates, allocation-free |
//! | [`reach`] | inflated navigation grid, reachability (Dijkstra) and collision |
//! | [`frontier`], [`coverage`] | baseline algorithms as jobs (frontiers: every planner's exploration) |
//! | [`vpsom`], [`baselines`] | the three planners (state machines) |
//! | [`recovery`] | what every planner does while localization is lost (neck sweep, drive) |
//! | [`session`] | the interface: inputs, [`Step`], jobs, status, [`Summary`] |
//! | [`synth`] | synthetic maps (scene-3-like) for benchmarks and tests |
//!
//! # Hosting (how the lead's host drives a planner)
//! ```text
//! let mut planner = make_planner(&cfg.planner, &cfg.camera);
//! // Real-time LBV thread, every 1 / planner.lbv_hz s, on the newest map and state (in place):
//! let neck = planner.neck_goal(&map, &state, now_ns);          // never waits, never allocates
//! publish(neck);
//! // On every new RobotState (same thread; cheap while a goal is in progress):
//! match planner.next_goal(&PlannerInputs { map, state, nav, explore }, now_ns) {
//!     Step::Wait => {}
//!     Step::Goal(g) => publish(g),                              // goal ids increase
//!     Step::Compute(job) => pool.spawn(move || tx.send(job.run())),  // low-priority rayon pool
//!     Step::Finished(summary) => stop(summary),
//! }
//! // When the pool's result arrives (poll the bounded channel with try_recv, never block):
//! if let Ok(out) = rx.try_recv() { /* same match */ planner.job_done(out, now_ns); }
//! // Tracing: planner.take_decision() (GBV, boxed), planner.lbv_decision(&mut loaned) (LBV).
//! ```
//! `next_goal` issues a new round when `RobotState.nav_status` is REACHED or UNREACHABLE for the
//! current goal id, or when no goal was issued yet; while a job is pending it returns `Wait`.
//! A lockstep host simply calls `job.run()` inline. Jobs own their snapshots (recycled
//! buffers handed back through `job_done`), so the map may change while they run.
//!
//! # Exploration
//! Whenever no unfinished cluster is known (before the first, between clusters, after the
//! last), VP-SOM and coverage explore: first (before any cluster) a look-around in place (neck
//! sweep through `bootstrap.look_around_steps` stops), then frontier goals on the exploration
//! grid ([`frontier`]: near and informative; too small, unreachable or already visited frontiers
//! are dropped, so exploration ends; unknown space the base cannot reach, e.g. behind a wall,
//! makes none), the neck sweeping. A frontier goal is superseded as soon as an unfinished cluster
//! appears, or once its neighbourhood was seen on the way (`frontier.seen_radius`); VP-SOM's last
//! GBV goal is superseded by exploration once no cluster needs it. The room is *explored* when a frontier round finds no reachable frontier.
//!
//! # Localization lost
//! Every planner runs the same recovery ([`recovery`], `[planner.recovery]`), from the shared
//! bookkeeping (`Session::begin` at the start of each `next_goal`, `Session::recovery_neck` at
//! the start of each `neck_goal`): once `RobotState.localization_ok` has been 0 for
//! `lost_grace_s` (at the start too), the planner waits and the neck sweeps 360° in stops until
//! tracking holds, holds there for `hold_s`, then the planner resumes; a sweep that found nothing
//! drives `move_m` away from the nearest obstacle (goal kind RECOVERY) and sweeps again.
//!
//! # Termination (section 3.4, Algorithm 2, plus exploration)
//! A foreground object is done when `complete` is set or `h_sopm < eps_sopm`, or when VP-SOM
//! gave it up ([`giveup`]: its entropy stopped falling, or its cluster ran out of GBV rounds or
//! new views); a cluster when all its foreground objects are; a cluster with no foreground object
//! yet when its centre has been in view from `bootstrap.empty_cluster_sectors` sectors. VP-SOM
//! ends `Terminated` when every cluster is done, given up or unreachable and the room is
//! explored (the causes listed in [`Summary::reason`]), `NoCandidates` only when nothing was
//! found at all. An ended cluster reopens for a new object (`gbv.reopen_rounds`, bounded by
//! `gbv.max_reopens`); objects with fewer than `planner.min_observations` detections open no
//! cluster.
//! [`Summary`] reports the counts and [`Summary::reason`] the reason.

/// The built-in `config/default.toml`, where this crate's sections (`[planner]`) have their defaults.
pub(crate) static DEFAULTS: settings::Defaults = settings::Defaults::new(
    "config/default.toml",
    include_str!("../../../config/default.toml"),
);

pub mod baselines;
pub mod clusters;
pub mod config;
pub mod coverage;
pub mod evaluate;
pub mod frontier;
pub mod gbv;
pub mod giveup;
pub mod lbv;
pub mod reach;
pub mod recovery;
pub mod session;
pub mod sight;
pub mod synth;
pub mod terms;
pub mod vpsom;

pub use baselines::{CoveragePlanner, FrontierPlanner};
pub use config::{
    AblationConfig, BootstrapConfig, CoverageConfig, FaRelevance, FrontierConfig, GbvConfig,
    GiveUpConfig, LbvConfig, Occluders, PlannerConfig, PlannerKind, RecoveryConfig, UnknownPlanner,
    UnknownTerm,
};
pub use evaluate::{EvalParams, FaFilter, Target, Weights, evaluate_view, evaluate_view_in};
pub use gbv::{GbvJob, GbvResult};
pub use giveup::{GiveUpCause, GivenUpObject};
pub use lbv::Lbv;
pub use recovery::{Recovery, RecoveryStats};
pub use session::{
    JobOutput, PlannerInputs, PlannerJob, PlannerStatus, Step, Summary, ViewPlanner,
};
pub use vpsom::VpsomPlanner;

use geom::CameraConfig;

/// The planner selected by `cfg.kind`.
pub fn make_planner(cfg: &PlannerConfig, camera: &CameraConfig) -> Box<dyn ViewPlanner> {
    match cfg.kind {
        PlannerKind::Vpsom => Box::new(VpsomPlanner::new(cfg, camera)),
        PlannerKind::Coverage => Box::new(CoveragePlanner::new(cfg, camera)),
        PlannerKind::Frontier => Box::new(FrontierPlanner::new(cfg, camera)),
    }
}
