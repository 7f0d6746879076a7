//! Localization recovery, the same for every planner (`[planner.recovery]`, issue #33 item 5).
//!
//! A real robot that is lost turns until it tracks. [`Recovery`] is the pure state machine: fed
//! with the estimated [`RobotState`]'s tracking flag (`localization_ok`, what a visual SLAM
//! reports: 0 while lost), the neck yaw and the simulated time, it decides whether the planner
//! is in charge or the recovery is, and what the neck and base do meanwhile.
//!
//! ```text
//!   lost: lost_grace_s standing, or          tracking holds
//!   lost_grace_driving_s in all
//!  Idle ───────────────────────────▶ Sweep ────────────────────────▶ Hold ──(hold_s)──▶ Idle
//!   ▲                                 │  ▲                            │ lost again
//!   │                                 │  └────────────────────────────┘ (same sweep)
//!   │             all sweep_stops      ▼                     tracking holds
//!   │             done, still lost   Move ─────────────────────────▶ Hold
//!   │                                 │ drive done (reached, refused, superseded)
//!   │                                 └──────▶ Sweep (a new one)
//! ```
//!
//! - **Idle**: the recovery takes over once tracking has been lost, and the base has stood, for
//!   `lost_grace_s` (no goal, or its goal reached or refused, and the planner sent no new one:
//!   nothing will change the view), or once tracking has been lost for `lost_grace_driving_s`
//!   whatever the base does (a drive's own turns usually bring tracking back).
//! - **Sweep**: the neck visits `sweep_stops` stops over 360° from where it was, `stop_s` at each
//!   (slew and settle), so the camera is still at every stop whatever the base does.
//! - **Hold**: tracking is back; the neck stays where it tracks for `hold_s` (the mapper takes
//!   frames again), then the planner resumes. Lost again before that: the sweep goes on.
//! - **Move**: a full sweep found nothing to track; the host issues a drive of `move_m` to the
//!   reachable pose with most clearance, away from the nearest obstacle ([`escape_pose`]), facing
//!   the way it drives. When the base is done with it, a new sweep starts.
//!
//! The hosting (which planners and calls use it) is in [`crate::session`]: every planner's
//! `next_goal` waits while the recovery is active (`Session::begin`), and its `neck_goal` takes
//! the recovery's neck yaw ([`Session::recovery_neck`](crate::session)). No clock, no thread:
//! the time comes in with each call.

use crate::config::RecoveryConfig;
use crate::reach::{NavParams, is_obstacle};
use shm_types::{OccupancyGrid, RobotState};
use std::f32::consts::{PI, TAU};

/// Where the recovery stands.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Phase {
    /// Tracking holds (or was lost for less than the grace time): the planner is in charge.
    Idle,
    /// Sweeping the neck: stop `stop` of the sweep, commanded at `since_ns` to yaw `yaw`.
    Sweep {
        /// Index of the current stop (0-based).
        stop: usize,
        /// The stop's neck yaw, radians.
        yaw: f32,
        /// When it was commanded.
        since_ns: u64,
    },
    /// Tracking is back since `since_ns`: the neck stays at `yaw`. `resume` is the sweep to go
    /// on with if tracking is lost again (`None` after a move: a new sweep).
    Hold {
        /// Neck yaw held, radians.
        yaw: f32,
        /// Tracking back since.
        since_ns: u64,
        /// The sweep's stop index and yaw to continue from.
        resume: Option<(usize, f32)>,
    },
    /// A full sweep did not recover: drive (`issued` once the host sent the goal).
    Move {
        /// Whether the host issued the drive.
        issued: bool,
    },
}

/// What the recovery asks of its host on this call.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Action {
    /// Nothing: the planner is in charge.
    None,
    /// The planner waits; the neck goes to this yaw (radians, relative to the base).
    Neck(f32),
    /// The planner waits; the host should issue the drive now (see [`escape_pose`]) and report
    /// it with [`Recovery::drive_issued`], or [`Recovery::drive_done`] if there is nowhere to go.
    Drive,
    /// The planner waits for the drive; the neck looks ahead (yaw 0).
    Driving,
}

/// Counts for the summary and the tests.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct RecoveryStats {
    /// Recoveries started (lost longer than the grace time).
    pub started: u32,
    /// Recoveries that ended with tracking back.
    pub recovered: u32,
    /// Full sweeps that did not recover.
    pub failed_sweeps: u32,
    /// Drives issued.
    pub drives: u32,
}

/// The recovery state machine (see the module docs).
#[derive(Debug, Clone)]
pub struct Recovery {
    enabled: bool,
    grace_ns: u64,
    grace_driving_ns: u64,
    stops: usize,
    step: f32,
    stop_ns: u64,
    hold_ns: u64,
    /// Drive distance, metres.
    pub move_m: f32,
    lost_since: Option<u64>,
    standing_since: Option<u64>,
    phase: Phase,
    stats: RecoveryStats,
}

fn ns(s: f32) -> u64 {
    (f64::from(s) * 1e9).round() as u64
}

impl Recovery {
    /// A recovery with the `[planner.recovery]` settings, idle.
    pub fn new(cfg: &RecoveryConfig) -> Self {
        let stops = cfg.sweep_stops.max(1);
        Self {
            enabled: cfg.enabled,
            grace_ns: ns(cfg.lost_grace_s),
            grace_driving_ns: ns(cfg.lost_grace_driving_s),
            stops,
            step: TAU / stops as f32,
            stop_ns: ns(cfg.stop_s),
            hold_ns: ns(cfg.hold_s),
            move_m: cfg.move_m,
            lost_since: None,
            standing_since: None,
            phase: Phase::Idle,
            stats: RecoveryStats::default(),
        }
    }

    /// The current phase.
    pub fn phase(&self) -> Phase {
        self.phase
    }

    /// Whether the recovery is in charge (the planner waits).
    pub fn active(&self) -> bool {
        self.phase != Phase::Idle
    }

    /// The counts so far.
    pub fn stats(&self) -> RecoveryStats {
        self.stats
    }

    /// Take an observation: `tracking` (the state's `localization_ok`), whether the base is
    /// `driving` to a goal (`nav_status` MOVING), the measured neck yaw and the time. Idempotent
    /// for a repeated time; returns what to do now.
    pub fn observe(&mut self, tracking: bool, driving: bool, neck_yaw: f32, now_ns: u64) -> Action {
        if !self.enabled {
            return Action::None;
        }
        if tracking {
            self.lost_since = None;
        } else {
            self.lost_since.get_or_insert(now_ns);
        }
        if driving {
            self.standing_since = None;
        } else {
            self.standing_since.get_or_insert(now_ns);
        }
        self.phase = match self.phase {
            Phase::Idle => match (self.lost_since, self.standing_since) {
                (Some(lost), standing)
                    if now_ns.saturating_sub(lost) >= self.grace_driving_ns
                        || standing.is_some_and(|s| {
                            now_ns.saturating_sub(lost.max(s)) >= self.grace_ns
                        }) =>
                {
                    self.stats.started += 1;
                    self.sweep_from(0, neck_yaw, now_ns)
                }
                _ => Phase::Idle,
            },
            Phase::Sweep {
                stop,
                yaw,
                since_ns,
            } => {
                if tracking {
                    Phase::Hold {
                        yaw: neck_yaw,
                        since_ns: now_ns,
                        resume: Some((stop, yaw)),
                    }
                } else if now_ns.saturating_sub(since_ns) < self.stop_ns {
                    self.phase
                } else if stop + 1 < self.stops {
                    self.sweep_from(stop + 1, yaw, now_ns)
                } else {
                    self.stats.failed_sweeps += 1;
                    Phase::Move { issued: false }
                }
            }
            Phase::Hold {
                yaw,
                since_ns,
                resume,
            } => {
                if !tracking {
                    match resume {
                        Some((stop, stop_yaw)) => Phase::Sweep {
                            stop,
                            yaw: stop_yaw,
                            since_ns: now_ns,
                        },
                        None => self.sweep_from(0, neck_yaw, now_ns),
                    }
                } else if now_ns.saturating_sub(since_ns) >= self.hold_ns {
                    self.stats.recovered += 1;
                    Phase::Idle
                } else {
                    Phase::Hold {
                        yaw,
                        since_ns,
                        resume,
                    }
                }
            }
            Phase::Move { .. } if tracking => Phase::Hold {
                yaw: neck_yaw,
                since_ns: now_ns,
                resume: None,
            },
            moving @ Phase::Move { .. } => moving,
        };
        self.action()
    }

    /// What the current phase asks for.
    pub fn action(&self) -> Action {
        match self.phase {
            Phase::Idle => Action::None,
            Phase::Sweep { yaw, .. } | Phase::Hold { yaw, .. } => Action::Neck(yaw),
            Phase::Move { issued: false } => Action::Drive,
            Phase::Move { issued: true } => Action::Driving,
        }
    }

    /// The neck yaw the recovery commands, if it is in charge.
    pub fn neck(&self) -> Option<f32> {
        match self.action() {
            Action::None => None,
            Action::Neck(yaw) => Some(yaw),
            Action::Drive | Action::Driving => Some(0.0),
        }
    }

    /// The host issued the drive asked for by [`Action::Drive`].
    pub fn drive_issued(&mut self) {
        if self.phase == (Phase::Move { issued: false }) {
            self.phase = Phase::Move { issued: true };
            self.stats.drives += 1;
        }
    }

    /// The drive is over (reached, refused, superseded, or there was nowhere to go): a new
    /// sweep starts from the neck yaw `neck_yaw`.
    pub fn drive_done(&mut self, neck_yaw: f32, now_ns: u64) {
        if matches!(self.phase, Phase::Move { .. }) {
            // The first stop is where the neck is: after the drive the camera faces new ground.
            self.phase = Phase::Sweep {
                stop: 0,
                yaw: geom::wrap_angle(neck_yaw),
                since_ns: now_ns,
            };
        }
    }

    /// Stop `stop` of a sweep, one step on from `prev_yaw`.
    fn sweep_from(&self, stop: usize, prev_yaw: f32, now_ns: u64) -> Phase {
        Phase::Sweep {
            stop,
            yaw: geom::wrap_angle(prev_yaw + self.step),
            since_ns: now_ns,
        }
    }
}

/// The drive of a recovery from `state`'s base pose: among 16 directions, the pose `move_m` away
/// that is reachable on the navigation grid, keeping the most clearance (distance to the nearest
/// obstacle, up to 2 m), ties broken toward the side away from the obstacle nearest the robot;
/// the goal yaw faces the way the base drives (the camera on the open room). With no grid:
/// straight back. `None` when no direction is reachable.
pub fn escape_pose(
    nav: &OccupancyGrid,
    params: &NavParams,
    state: &RobotState,
    move_m: f32,
) -> Option<[f32; 3]> {
    let [x, y, yaw] = state.base_pose;
    let map = params.flooded(nav, [x, y]);
    if map.is_empty() {
        let back = geom::wrap_angle(yaw + PI);
        return Some([x + move_m * back.cos(), y + move_m * back.sin(), back]);
    }
    const REACH: f32 = 2.0;
    let away = nearest_obstacle(nav, params, [x, y], REACH).map(|o| (y - o[1]).atan2(x - o[0]));
    let mut best: Option<(f32, [f32; 3])> = None;
    for k in 0..16 {
        let dir = geom::wrap_angle(yaw + PI + TAU * k as f32 / 16.0);
        let p = [x + move_m * dir.cos(), y + move_m * dir.sin()];
        if !map.reachable(p) {
            continue;
        }
        let clearance = nearest_obstacle(nav, params, p, REACH)
            .map_or(REACH, |o| (o[0] - p[0]).hypot(o[1] - p[1]));
        // Clearance in 5 cm bins first, then the side away from the nearest obstacle.
        let bins = (clearance / 0.05).floor();
        let side = away.map_or(0.0, |a| geom::wrap_angle(dir - a).cos());
        let score = bins * 4.0 + side;
        if best.is_none_or(|(s, _)| score > s) {
            best = Some((score, [p[0], p[1], dir]));
        }
    }
    best.map(|(_, p)| p)
}

/// The centre of the obstacle cell nearest to `p` within `reach` metres, if any.
fn nearest_obstacle(
    nav: &OccupancyGrid,
    params: &NavParams,
    p: [f32; 2],
    reach: f32,
) -> Option<[f32; 2]> {
    let (w, h) = (nav.width as i64, nav.height as i64);
    let res = nav.resolution.max(1e-3);
    let cells = nav.used();
    if cells.len() as i64 != w * h {
        return None;
    }
    let cx = ((p[0] - nav.origin[0]) / res).floor() as i64;
    let cy = ((p[1] - nav.origin[1]) / res).floor() as i64;
    let r = (reach / res).ceil() as i64;
    let mut best: Option<(f32, [f32; 2])> = None;
    for iy in (cy - r).max(0)..=(cy + r).min(h - 1) {
        for ix in (cx - r).max(0)..=(cx + r).min(w - 1) {
            if !is_obstacle(cells[(iy * w + ix) as usize], !params.unknown_traversable) {
                continue;
            }
            let c = [
                nav.origin[0] + (ix as f32 + 0.5) * res,
                nav.origin[1] + (iy as f32 + 0.5) * res,
            ];
            let d = (c[0] - p[0]).hypot(c[1] - p[1]);
            if d <= reach && best.is_none_or(|(b, _)| d < b) {
                best = Some((d, c));
            }
        }
    }
    best.map(|(_, c)| c)
}

#[cfg(test)]
mod tests {
    use super::*;
    use shm_types::{boxed_zeroed, grid_cell};

    const S: u64 = 1_000_000_000;

    fn cfg() -> RecoveryConfig {
        RecoveryConfig {
            enabled: true,
            lost_grace_s: 2.0,
            lost_grace_driving_s: 5.0,
            sweep_stops: 4,
            stop_s: 1.0,
            hold_s: 1.0,
            move_m: 1.0,
        }
    }

    fn close(a: f32, b: f32) -> bool {
        geom::wrap_angle(a - b).abs() < 1e-4
    }

    #[test]
    fn sweeps_until_tracking_holds_then_resumes() {
        let mut r = Recovery::new(&cfg());
        assert_eq!(r.observe(true, false, 0.0, 0), Action::None);
        // Lost, within the grace time: the planner stays in charge.
        assert_eq!(r.observe(false, false, 0.0, S / 2), Action::None);
        assert_eq!(r.observe(false, false, 0.0, 2 * S), Action::None);
        // Grace over (lost since 0.5 s): the sweep's first stop, one step (90°) on.
        let Action::Neck(a) = r.observe(false, false, 0.0, 5 * S / 2) else {
            panic!("sweeping: {:?}", r.phase());
        };
        assert!(close(a, PI / 2.0), "{a}");
        assert!(r.active() && r.stats().started == 1);
        // The same stop until stop_s has passed, then the next.
        assert_eq!(r.observe(false, false, a, 3 * S), Action::Neck(a));
        let Action::Neck(b) = r.observe(false, false, a, 7 * S / 2) else {
            panic!();
        };
        assert!(close(b, PI), "{b}");
        // Tracking back: the neck holds where it is (not where it was going).
        assert_eq!(r.observe(true, false, 3.0, 4 * S), Action::Neck(3.0));
        // Lost again during the hold: the same sweep goes on at its stop.
        assert_eq!(r.observe(false, false, 3.0, 9 * S / 2), Action::Neck(b));
        assert_eq!(r.observe(true, false, 3.1, 5 * S), Action::Neck(3.1));
        // Held for hold_s: the planner resumes.
        assert_eq!(r.observe(true, false, 3.1, 11 * S / 2), Action::Neck(3.1));
        assert_eq!(r.observe(true, false, 3.1, 6 * S), Action::None);
        assert!(!r.active() && r.neck().is_none());
        assert_eq!(r.stats().recovered, 1);
        assert_eq!(r.stats().failed_sweeps, 0);
        // A short loss later: the grace time counts again from the new loss.
        assert_eq!(r.observe(false, false, 0.0, 10 * S), Action::None);
        assert_eq!(r.observe(true, false, 0.0, 11 * S), Action::None);
        assert_eq!(r.observe(false, false, 0.0, 12 * S), Action::None);
        assert_eq!(r.observe(false, false, 0.0, 13 * S), Action::None);
    }

    #[test]
    fn a_driving_base_gets_longer_to_track_again() {
        let mut r = Recovery::new(&cfg());
        // Lost while driving: not before lost_grace_driving_s.
        assert_eq!(r.observe(false, true, 0.0, 0), Action::None);
        assert_eq!(r.observe(false, true, 0.0, 4 * S), Action::None);
        assert!(matches!(
            r.observe(false, true, 0.0, 5 * S),
            Action::Neck(_)
        ));
        // Lost while driving, then the base stops: lost_grace_s after it stopped (the planner
        // may send it on first), or lost_grace_driving_s after the loss, whichever is first.
        let mut r = Recovery::new(&cfg());
        assert_eq!(r.observe(false, true, 0.0, 0), Action::None);
        assert_eq!(r.observe(false, false, 0.0, 2 * S), Action::None);
        assert_eq!(r.observe(false, true, 0.0, 3 * S), Action::None);
        assert_eq!(r.observe(false, false, 0.0, 3 * S), Action::None);
        assert!(matches!(
            r.observe(false, false, 0.0, 5 * S),
            Action::Neck(_)
        ));
        // Standing: lost_grace_s from the newest loss.
        let mut r = Recovery::new(&cfg());
        assert_eq!(r.observe(false, false, 0.0, 0), Action::None);
        assert_eq!(r.observe(true, false, 0.0, S), Action::None);
        assert_eq!(r.observe(false, false, 0.0, 2 * S), Action::None);
        assert_eq!(r.observe(false, false, 0.0, 3 * S), Action::None);
        assert!(matches!(
            r.observe(false, false, 0.0, 4 * S),
            Action::Neck(_)
        ));
    }

    #[test]
    fn a_failed_sweep_drives_then_sweeps_again() {
        let mut r = Recovery::new(&cfg());
        let mut yaws = Vec::new();
        let mut t = 0;
        // Never tracking: grace, then 4 stops of 1 s each, then a drive.
        let mut action = Action::None;
        while t <= 7 * S {
            action = r.observe(false, false, 0.0, t);
            if let Action::Neck(y) = action
                && yaws.last() != Some(&y)
            {
                yaws.push(y);
            }
            t += S / 10;
        }
        assert_eq!(yaws.len(), 4, "{yaws:?}");
        for (k, y) in yaws.iter().enumerate() {
            assert!(close(*y, (k + 1) as f32 * PI / 2.0), "{yaws:?}");
        }
        assert_eq!(action, Action::Drive, "{:?}", r.phase());
        assert_eq!(r.stats().failed_sweeps, 1);
        assert_eq!(
            r.neck(),
            Some(0.0),
            "the camera looks where the base drives"
        );
        r.drive_issued();
        assert_eq!(r.observe(false, false, 0.0, t), Action::Driving);
        assert_eq!(r.stats().drives, 1);
        // The drive ends: a new sweep from the neck's yaw.
        r.drive_done(0.2, t);
        assert!(
            matches!(r.phase(), Phase::Sweep { stop: 0, yaw, .. } if close(yaw, 0.2)),
            "{:?}",
            r.phase()
        );
        assert_eq!(r.observe(false, false, 0.2, t + S / 2), Action::Neck(0.2));
        // Tracking on the way of a later drive: hold, then resume.
        let mut r2 = r.clone();
        r2.phase = Phase::Move { issued: true };
        assert_eq!(r2.observe(true, false, 0.0, t), Action::Neck(0.0));
        assert_eq!(r2.observe(true, false, 0.0, t + S), Action::None);
        assert_eq!(r2.stats().recovered, 1);
    }

    #[test]
    fn disabled_does_nothing() {
        let mut r = Recovery::new(&RecoveryConfig {
            enabled: false,
            ..cfg()
        });
        for k in 0..100 {
            assert_eq!(r.observe(false, false, 0.0, k * S), Action::None);
        }
        assert_eq!(r.stats(), RecoveryStats::default());
    }

    /// A 4 m × 4 m room at 0.05 m, walls one cell thick, inflated by 0.3 m (as the sim's).
    fn room() -> Box<OccupancyGrid> {
        let mut g = boxed_zeroed::<OccupancyGrid>();
        g.resolution = 0.05;
        g.width = 80;
        g.height = 80;
        for iy in 0..80usize {
            for ix in 0..80usize {
                let d = ix.min(iy).min(79 - ix).min(79 - iy);
                if d <= 6 {
                    g.cells[iy * 80 + ix] = grid_cell::OCCUPIED;
                }
            }
        }
        g
    }

    #[test]
    fn the_drive_leaves_the_wall_and_faces_the_room() {
        let params = NavParams {
            robot_radius: 0.3,
            inflated: true,
            unknown_traversable: true,
        };
        // 0.7 m from the north wall (y = 4), facing it.
        let state = RobotState {
            base_pose: [2.0, 3.3, PI / 2.0],
            ..Default::default()
        };
        let p = escape_pose(&room(), &params, &state, 1.0).unwrap();
        assert!(p[1] < 2.6, "away from the wall: {p:?}");
        assert!(close(p[2], -PI / 2.0), "facing the room: {p:?}");
        // In a corner: out along the diagonal.
        let corner = RobotState {
            base_pose: [0.7, 0.7, PI],
            ..Default::default()
        };
        let q = escape_pose(&room(), &params, &corner, 1.0).unwrap();
        assert!(q[0] > 1.2 && q[1] > 1.2, "{q:?}");
        // No grid: straight back.
        let empty = boxed_zeroed::<OccupancyGrid>();
        let b = escape_pose(&empty, &params, &state, 1.0).unwrap();
        assert!((b[1] - 2.3).abs() < 1e-4 && close(b[2], -PI / 2.0), "{b:?}");
    }
}
