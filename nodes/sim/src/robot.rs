//! The robot: a differential base following A* paths, a 360° neck with a noisy encoder, and a
//! visual-SLAM pose estimate.
//!
//! The base controller works on the ESTIMATED pose (as a real robot would); the true pose moves
//! by the commanded velocities. Odometry measures each motion with noise (σ² proportional to
//! the distance driven and the angle turned, multiplied while visual localization is lost) and
//! feeds it to the [`SlamEstimator`]'s prediction; [`Robot::visual_update`] (once per frame)
//! applies its keyframe, loop-closure and relocalization corrections. The neck encoder reads the
//! true neck yaw plus a per-seed offset and per-reading noise; [`PoseDelay`] keeps the recent
//! estimates so that a frame is stamped with the pose from `pose_delay_ms` earlier.

use super::config::RobotConfig;
use super::nav::{NavGrid, NavRefusal};
use super::slam::{PoseDelay, SlamEstimator, SlamEvent};
use geom::wrap_angle;
use glam::Vec2;
use rand::Rng;
use rand_distr::StandardNormal;
use rand_pcg::Pcg64;
use shm_types::{NavGoal, NeckGoal, nav_status};

/// Heading error (rad) above which the base turns in place before driving.
const TURN_IN_PLACE: f32 = 0.35;
/// Distance (m) at which an intermediate waypoint counts as passed.
const WAYPOINT_TOLERANCE: f32 = 0.1;

/// Base, neck, odometry and navigation state.
#[derive(Debug, Clone)]
pub struct Robot {
    cfg: RobotConfig,
    max_turn: f32,
    neck_rate: f32,
    pitch_range: (f32, f32),
    yaw_tol: f32,
    /// True base pose `[x, y, yaw]`.
    pub(crate) true_pose: [f32; 3],
    /// The visual-SLAM estimate of the base pose.
    slam: SlamEstimator,
    /// Recent `[x, y, yaw, measured neck yaw]` for the frames' delayed stamps.
    history: PoseDelay,
    /// Simulated time of this robot, s.
    time_s: f64,
    /// Constant neck-encoder offset, rad.
    encoder_bias: f32,
    /// Neck-encoder noise σ, rad.
    encoder_noise: f32,
    /// Neck yaw relative to the base, rad.
    pub(crate) neck_yaw: f32,
    /// Camera pitch, rad, positive down.
    pub(crate) neck_pitch: f32,
    neck_goal: (f32, f32),
    /// Last commanded linear speed, m/s.
    pub(crate) speed: f32,
    /// Last yaw rate of the camera (base + neck), rad/s.
    pub(crate) camera_turn_rate: f32,
    /// Distance driven (true), m.
    pub(crate) distance_true: f32,
    /// Distance driven (odometry), m.
    pub(crate) distance_est: f32,
    /// Current goal id (0 = none).
    pub(crate) goal_id: u64,
    /// One of `nav_status`.
    pub(crate) status: u8,
    refusal: Option<NavRefusal>,
    path: Vec<Vec2>,
    waypoint: usize,
    goal_yaw: f32,
    rng: Pcg64,
    /// Whether visual localization currently tracks.
    pub(crate) localized: bool,
    encoder: Pcg64,
}

impl Robot {
    /// A robot at `start = [x, y, yaw]` with the neck straight and the camera at `pitch` (rad,
    /// clamped to the configured range).
    pub fn new(cfg: &RobotConfig, start: [f32; 3], pitch: f32, seed: u64) -> Self {
        let pitch_range = (
            cfg.pitch_min_deg.to_radians(),
            cfg.pitch_max_deg.to_radians(),
        );
        let pitch = pitch.clamp(pitch_range.0, pitch_range.1);
        let mut encoder = Pcg64::new(
            super::mix(seed, &[0x6e65_636b]) as u128,
            0x0e4c_0de5_0000_0000_0000_0000_0000_0001,
        );
        let encoder_bias =
            cfg.neck_encoder_bias_deg.to_radians() * encoder.sample::<f32, _>(StandardNormal);
        Self {
            cfg: cfg.clone(),
            max_turn: cfg.max_turn_rate_deg_s.to_radians(),
            neck_rate: cfg.neck_rate_deg_s.to_radians(),
            pitch_range,
            yaw_tol: cfg.yaw_tolerance_deg.to_radians(),
            true_pose: start,
            slam: SlamEstimator::new(&cfg.slam, start, seed),
            history: PoseDelay::new(
                [start[0], start[1], start[2], encoder_bias],
                cfg.pose_delay_ms,
            ),
            time_s: 0.0,
            encoder_bias,
            encoder_noise: cfg.neck_encoder_noise_deg.to_radians(),
            neck_yaw: 0.0,
            neck_pitch: pitch,
            neck_goal: (0.0, pitch),
            speed: 0.0,
            camera_turn_rate: 0.0,
            distance_true: 0.0,
            distance_est: 0.0,
            goal_id: 0,
            status: nav_status::IDLE,
            refusal: None,
            path: Vec::new(),
            waypoint: 0,
            goal_yaw: 0.0,
            rng: Pcg64::new(
                super::mix(seed, &[0x6f64_6f6d]) as u128,
                0xcafe_f00d_d15e_a5e5_0000_0000_0000_0001,
            ),
            localized: true,
            encoder,
        }
    }

    /// The estimated base pose `[x, y, yaw]` (now).
    pub fn est_pose(&self) -> [f32; 3] {
        self.slam.pose()
    }

    /// The pose estimator.
    pub fn slam(&self) -> &SlamEstimator {
        &self.slam
    }

    /// The latest neck-encoder reading (true neck yaw + offset + noise), rad.
    pub fn neck_yaw_measured(&self) -> f32 {
        self.history.latest()[3]
    }

    /// The estimated base pose and neck-encoder reading `pose_delay_ms` ago: what a frame
    /// rendered now is stamped with.
    pub fn stamped_pose(&self) -> ([f32; 3], f32) {
        let [x, y, yaw, neck] = self.history.delayed();
        ([x, y, yaw], neck)
    }

    /// A frame's visual update: `tracking` is the failure model's verdict for it. Applies the
    /// estimator's keyframe / loop-closure / relocalization correction, if one is due.
    pub fn visual_update(&mut self, tracking: bool) -> SlamEvent {
        self.localized = tracking;
        let camera_yaw = wrap_angle(self.true_pose[2] + self.neck_yaw);
        let event = self
            .slam
            .frame(tracking, self.true_pose, camera_yaw, self.distance_true);
        if event != SlamEvent::None {
            self.history.correct_latest(self.slam.pose());
        }
        event
    }

    /// Why the current goal was refused or abandoned, if it was.
    pub fn refusal(&self) -> Option<&NavRefusal> {
        self.refusal.as_ref()
    }

    /// Accept a chassis goal: plan from the estimated pose on `grid`. A goal whose id equals the
    /// current one is ignored (returns the earlier outcome). On refusal the status becomes
    /// `UNREACHABLE` and the reason is returned (and kept, see [`Robot::refusal`]).
    pub fn set_nav_goal(&mut self, goal: &NavGoal, grid: &NavGrid) -> Result<(), NavRefusal> {
        if goal.goal_id != 0 && goal.goal_id == self.goal_id {
            return self.refusal.clone().map_or(Ok(()), Err);
        }
        self.goal_id = goal.goal_id;
        self.path.clear();
        self.waypoint = 0;
        let [x, y, yaw] = goal.pose;
        let [x0, y0, _] = self.est_pose();
        let start = Vec2::new(x0, y0);
        match grid.plan(start, Vec2::new(x, y)) {
            Ok(path) => {
                self.path = path;
                self.goal_yaw = wrap_angle(yaw);
                self.status = nav_status::MOVING;
                self.refusal = None;
                Ok(())
            }
            Err(e) => {
                self.status = nav_status::UNREACHABLE;
                self.refusal = Some(e.clone());
                Err(e)
            }
        }
    }

    /// Set the neck target (yaw relative to the base, any angle; pitch clamped to the range).
    pub fn set_neck_goal(&mut self, goal: &NeckGoal) {
        if goal.yaw.is_finite() && goal.pitch.is_finite() {
            self.neck_goal = (
                wrap_angle(goal.yaw),
                goal.pitch.clamp(self.pitch_range.0, self.pitch_range.1),
            );
        }
    }

    /// Advance by `dt` seconds in substeps. `collision` is the grid the TRUE base may not enter.
    pub fn step(&mut self, dt: f32, collision: &NavGrid) {
        let mut left = dt;
        let mut turned = 0.0;
        while left > 1e-9 {
            let h = left.min(self.cfg.substep_s);
            turned += self.substep(h, collision);
            left -= h;
            self.time_s += f64::from(h);
            let noise: f32 = self.encoder.sample(StandardNormal);
            let neck = wrap_angle(self.neck_yaw + self.encoder_bias + self.encoder_noise * noise);
            let [x, y, yaw] = self.slam.pose();
            self.history.record(self.time_s, [x, y, yaw, neck]);
        }
        if dt > 0.0 {
            self.camera_turn_rate = turned / dt;
        }
    }

    /// One substep; returns the camera yaw change (base + neck), rad.
    fn substep(&mut self, dt: f32, collision: &NavGrid) -> f32 {
        // Neck: shortest way round (the neck turns 360°).
        let err = wrap_angle(self.neck_goal.0 - self.neck_yaw);
        let d_neck = err.clamp(-self.neck_rate * dt, self.neck_rate * dt);
        self.neck_yaw = wrap_angle(self.neck_yaw + d_neck);
        let perr = self.neck_goal.1 - self.neck_pitch;
        self.neck_pitch += perr.clamp(-self.neck_rate * dt, self.neck_rate * dt);

        // Base.
        let (v, w) = self.control();
        let [x, y, yaw] = self.true_pose;
        let mid = yaw + 0.5 * w * dt;
        let next = [
            x + v * dt * mid.cos(),
            y + v * dt * mid.sin(),
            wrap_angle(yaw + w * dt),
        ];
        let blocked = |p: [f32; 3]| collision.is_blocked(Vec2::new(p[0], p[1]));
        let (v, w) = if v != 0.0 && blocked(next) && !blocked(self.true_pose) {
            self.path.clear();
            self.status = nav_status::UNREACHABLE;
            self.refusal = Some(NavRefusal::Blocked { x, y });
            (0.0, 0.0)
        } else {
            self.true_pose = next;
            (v, w)
        };
        self.speed = v;
        self.distance_true += (v * dt).abs();
        self.odometry(v * dt, w * dt);
        w * dt + d_neck
    }

    /// Velocity command `(v, ω)` from the estimated pose and the path.
    fn control(&mut self) -> (f32, f32) {
        if self.status != nav_status::MOVING {
            return (0.0, 0.0);
        }
        let [x, y, yaw] = self.est_pose();
        let here = Vec2::new(x, y);
        let turn = |err: f32, max: f32| (2.0 * err).clamp(-max, max);
        while self.waypoint < self.path.len() {
            let last = self.waypoint + 1 == self.path.len();
            let to = self.path[self.waypoint] - here;
            let tol = if last {
                self.cfg.goal_tolerance_m
            } else {
                WAYPOINT_TOLERANCE.max(self.cfg.goal_tolerance_m)
            };
            if to.length() < tol {
                self.waypoint += 1;
                continue;
            }
            let err = wrap_angle(to.y.atan2(to.x) - yaw);
            if err.abs() > TURN_IN_PLACE {
                return (0.0, turn(err, self.max_turn));
            }
            let v = (self.cfg.max_speed).min(1.2 * to.length()) * err.cos();
            return (v, turn(err, self.max_turn));
        }
        let err = wrap_angle(self.goal_yaw - yaw);
        if err.abs() < self.yaw_tol {
            self.status = nav_status::REACHED;
            return (0.0, 0.0);
        }
        (0.0, turn(err, self.max_turn))
    }

    /// Odometry: the noisy measurement of a motion `(dd, dθ)` drives the estimator's
    /// prediction (noise scaled by `lost_drift_factor` while localization is lost).
    fn odometry(&mut self, dd: f32, dth: f32) {
        let f = if self.localized {
            1.0
        } else {
            self.cfg.lost_drift_factor
        };
        let c = &self.cfg;
        let var_d = (c.odom_trans_noise * f).powi(2) * dd.abs();
        let var_th =
            (c.odom_rot_noise * f).powi(2) * dth.abs() + (c.odom_rot_per_m * f).powi(2) * dd.abs();
        let (n1, n2): (f32, f32) = (
            self.rng.sample(StandardNormal),
            self.rng.sample(StandardNormal),
        );
        let md = dd + var_d.sqrt() * n1;
        let mth = dth + var_th.sqrt() * n2;
        self.distance_est += md.abs();
        self.slam
            .predict(md.into(), mth.into(), var_d.into(), var_th.into());
    }
}
