//! The visual-SLAM pose estimate: an EKF over the base pose `[x, y, yaw]` (nalgebra), never
//! pulled continuously toward the truth.
//!
//! - **Prediction** by odometry (the robot's noisy measurement of each substep's motion) with
//!   the motion model's Jacobians: the covariance grows with distance and angle.
//! - **Keyframe corrections**: while visual tracking holds, every `keyframe_distance_m` of
//!   camera translation or `keyframe_angle_deg` of camera rotation (from the reference keyframe)
//!   the SLAM measures the base pose as `truth + map error + residual` (residual ~ N(0, R)) and
//!   the filter fuses it (measurement update with covariance R): centimetre residuals remain.
//! - **Map drift and loop closures**: the map error random-walks with newly mapped travel (a
//!   keyframe at a new place); a keyframe at a place already mapped (within `reuse_radius_m`
//!   and `reuse_angle_deg` of a stored keyframe) takes that keyframe's map error instead: no new
//!   drift nearby, and a loop closure (the stored keyframe is ≥ `loop_min_travel_m` of travel
//!   old) brings back the smaller error of the older map.
//! - **Relocalization**: while tracking is lost, odometry only (the robot scales its noise by
//!   `lost_drift_factor`); on recovery a measurement update from a covariance grown large: the
//!   estimate jumps back to truth + map error + residual (a pose discontinuity for the mapper).
//!
//! Places are recognised by the TRUE camera position and viewing direction (the simulator
//! decides what a real SLAM would recognise). [`PoseDelay`] keeps a short history of estimates
//! and neck-encoder readings so that a frame is stamped with the pose from `pose_delay_ms`
//! earlier. All randomness comes from the estimator's own PCG stream.
//!
//! **Out of the plane** (6 DoF): the base drives on a flat floor, so odometry says nothing
//! about the camera's height, roll and pitch, but a visual SLAM estimates all six degrees of
//! freedom from the same features. Its error there, `[z, roll, pitch]` ([`SlamEstimator::tilt`]),
//! is the keyframe's map error plus a residual, with the in-plane sigmas (`residual_xy_m` for z,
//! `residual_yaw_deg` for roll and pitch; `map_drift_*` likewise): ORB-SLAM2 RGB-D has no
//! gravity prior, so its error is taken as isotropic. It changes only at keyframe corrections.

use super::config::SlamConfig;
use geom::wrap_angle;
use nalgebra::{Matrix2, Matrix3, Matrix3x2, Vector3};
use rand::Rng;
use rand_distr::StandardNormal;
use rand_pcg::Pcg64;

/// Largest accepted `robot.pose_delay_ms`.
pub const MAX_DELAY_MS: f64 = 200.0;

/// What a frame did to the estimate.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SlamEvent {
    /// Nothing (no keyframe due, or tracking lost).
    None,
    /// A keyframe correction (new place or a recently mapped one).
    Keyframe,
    /// A keyframe that closed a loop with a keyframe made long before.
    LoopClosure,
    /// The first tracked frame after a tracking failure.
    Relocalization,
}

/// A stored keyframe: true camera position and viewing yaw, and the map error there.
#[derive(Debug, Clone, Copy)]
struct Keyframe {
    x: f64,
    y: f64,
    yaw: f64,
    map_error: Vector3<f64>,
    /// The map's out-of-plane error there, `[z, roll, pitch]`.
    map_tilt: Vector3<f64>,
    /// Base travel (m) when it was made.
    travel: f64,
}

/// The EKF pose estimator with its keyframe map (see the module docs).
#[derive(Debug, Clone)]
pub struct SlamEstimator {
    cfg: SlamConfig,
    /// Estimated base pose `[x, y, yaw]`.
    x: Vector3<f64>,
    /// Covariance of the estimate.
    p: Matrix3<f64>,
    /// Measurement (residual) covariance R.
    r: Matrix3<f64>,
    /// The map's error at the current place (added to keyframe measurements).
    map_error: Vector3<f64>,
    /// The map's out-of-plane error `[z, roll, pitch]` at the current place.
    map_tilt: Vector3<f64>,
    /// The estimate's out-of-plane error `[z, roll, pitch]` (set at each correction).
    tilt: Vector3<f64>,
    keyframes: Vec<Keyframe>,
    /// The keyframe the camera's motion is measured from.
    reference: Keyframe,
    tracking: bool,
    rng: Pcg64,
    corrections: u32,
    loop_closures: u32,
    relocalizations: u32,
}

impl SlamEstimator {
    /// An estimator at the known start pose `[x, y, yaw]` (zero covariance, zero map error),
    /// camera looking along the base; randomness from `seed`.
    pub fn new(cfg: &SlamConfig, start: [f32; 3], seed: u64) -> Self {
        let (sxy, syaw) = (
            f64::from(cfg.residual_xy_m),
            f64::from(cfg.residual_yaw_deg).to_radians(),
        );
        let first = Keyframe {
            x: start[0].into(),
            y: start[1].into(),
            yaw: start[2].into(),
            map_error: Vector3::zeros(),
            map_tilt: Vector3::zeros(),
            travel: 0.0,
        };
        let mut keyframes = Vec::with_capacity(cfg.max_keyframes as usize);
        keyframes.push(first);
        Self {
            cfg: cfg.clone(),
            x: Vector3::new(start[0].into(), start[1].into(), start[2].into()),
            p: Matrix3::zeros(),
            r: Matrix3::from_diagonal(&Vector3::new(sxy * sxy, sxy * sxy, syaw * syaw)),
            map_error: Vector3::zeros(),
            map_tilt: Vector3::zeros(),
            tilt: Vector3::zeros(),
            keyframes,
            reference: first,
            tracking: true,
            rng: Pcg64::new(
                super::mix(seed, &[0x736c_616d]) as u128,
                0x5a4d_0000_0000_0000_0000_0000_0000_0001,
            ),
            corrections: 0,
            loop_closures: 0,
            relocalizations: 0,
        }
    }

    /// The estimate's error out of the floor plane, `[z (m), roll (rad), pitch (rad)]` of the
    /// base: what the SLAM believes of the camera's height and tilt, minus the truth (the
    /// truth is 0, 0, 0: the floor is flat).
    pub fn tilt(&self) -> [f32; 3] {
        [
            self.tilt[0] as f32,
            self.tilt[1] as f32,
            self.tilt[2] as f32,
        ]
    }

    /// The estimated base pose `[x, y, yaw]`.
    pub fn pose(&self) -> [f32; 3] {
        [self.x[0] as f32, self.x[1] as f32, self.x[2] as f32]
    }

    /// The estimate's state vector `[x, y, yaw]`.
    pub fn state(&self) -> &Vector3<f64> {
        &self.x
    }

    /// The estimate's covariance (of `[x, y, yaw]`).
    pub fn covariance(&self) -> &Matrix3<f64> {
        &self.p
    }

    /// The covariance as row-major `f32` (for `RobotState::odom_cov`).
    pub fn covariance_f32(&self) -> [f32; 9] {
        let mut out = [0.0; 9];
        for (k, o) in out.iter_mut().enumerate() {
            *o = self.p[(k / 3, k % 3)] as f32;
        }
        out
    }

    /// Keyframe corrections so far (loop closures and relocalizations included).
    pub fn corrections(&self) -> u32 {
        self.corrections
    }

    /// Loop closures so far.
    pub fn loop_closures(&self) -> u32 {
        self.loop_closures
    }

    /// Relocalizations so far.
    pub fn relocalizations(&self) -> u32 {
        self.relocalizations
    }

    /// Keyframes stored.
    pub fn keyframe_count(&self) -> usize {
        self.keyframes.len()
    }

    /// EKF prediction with an odometry measurement: `md` metres along the mid-step heading and
    /// `mth` radians of turn, with variances `var_d` and `var_th`.
    pub fn predict(&mut self, md: f64, mth: f64, var_d: f64, var_th: f64) {
        let mid = self.x[2] + 0.5 * mth;
        let (s, c) = mid.sin_cos();
        self.x += Vector3::new(md * c, md * s, mth);
        self.x[2] = wrap(self.x[2]);
        #[rustfmt::skip]
        let f = Matrix3::new(
            1.0, 0.0, -md * s,
            0.0, 1.0, md * c,
            0.0, 0.0, 1.0,
        );
        #[rustfmt::skip]
        let g = Matrix3x2::new(
            c, -0.5 * md * s,
            s, 0.5 * md * c,
            0.0, 1.0,
        );
        let q = Matrix2::new(var_d, 0.0, 0.0, var_th);
        self.p = f * self.p * f.transpose() + g * q * g.transpose();
        self.p = 0.5 * (self.p + self.p.transpose());
    }

    /// One frame's visual update: `tracking` is the failure model's verdict for the frame,
    /// `base` the TRUE base pose, `camera_yaw` the TRUE camera yaw (base + neck), `travel` the
    /// base's total driven distance (m).
    pub fn frame(
        &mut self,
        tracking: bool,
        base: [f32; 3],
        camera_yaw: f32,
        travel: f32,
    ) -> SlamEvent {
        let was = std::mem::replace(&mut self.tracking, tracking);
        if !tracking {
            return SlamEvent::None;
        }
        let here = Keyframe {
            x: base[0].into(),
            y: base[1].into(),
            yaw: camera_yaw.into(),
            map_error: self.map_error,
            map_tilt: self.map_tilt,
            travel: travel.into(),
        };
        let event = if !was {
            // Relocalization in the map: the error of the place recognised, if any.
            if let Some(k) = self.nearest(&here) {
                self.map_error = self.keyframes[k].map_error;
                self.map_tilt = self.keyframes[k].map_tilt;
            }
            self.relocalizations += 1;
            self.reference = Keyframe {
                map_error: self.map_error,
                map_tilt: self.map_tilt,
                ..here
            };
            SlamEvent::Relocalization
        } else {
            let moved = (here.x - self.reference.x).hypot(here.y - self.reference.y);
            let turned = wrap(here.yaw - self.reference.yaw).abs();
            if moved < f64::from(self.cfg.keyframe_distance_m)
                && turned < f64::from(self.cfg.keyframe_angle_deg).to_radians()
            {
                return SlamEvent::None;
            }
            match self.nearest(&here) {
                Some(k) => {
                    let kf = self.keyframes[k];
                    self.map_error = kf.map_error;
                    self.map_tilt = kf.map_tilt;
                    self.reference = kf;
                    if here.travel - kf.travel >= f64::from(self.cfg.loop_min_travel_m) {
                        self.loop_closures += 1;
                        SlamEvent::LoopClosure
                    } else {
                        SlamEvent::Keyframe
                    }
                }
                None => {
                    let d = moved + f64::from(self.cfg.turn_equiv_m_per_rad) * turned;
                    let sxy = f64::from(self.cfg.map_drift_xy_m) * d.sqrt();
                    let syaw = f64::from(self.cfg.map_drift_yaw_deg).to_radians() * d.sqrt();
                    let step = Vector3::new(
                        sxy * self.normal(),
                        sxy * self.normal(),
                        syaw * self.normal(),
                    );
                    self.map_error += step;
                    let tilt_step = Vector3::new(
                        sxy * self.normal(),
                        syaw * self.normal(),
                        syaw * self.normal(),
                    );
                    self.map_tilt += tilt_step;
                    let kf = Keyframe {
                        map_error: self.map_error,
                        map_tilt: self.map_tilt,
                        ..here
                    };
                    if self.keyframes.len() < self.keyframes.capacity() {
                        self.keyframes.push(kf);
                    }
                    self.reference = kf;
                    SlamEvent::Keyframe
                }
            }
        };
        self.correct(base);
        event
    }

    /// Measurement update with `z = truth + map error + residual`, residual ~ N(0, R).
    fn correct(&mut self, base: [f32; 3]) {
        let noise = Vector3::new(self.normal(), self.normal(), self.normal());
        let sd = self.r.diagonal().map(f64::sqrt);
        let truth = Vector3::new(base[0].into(), base[1].into(), base[2].into());
        let z = truth + self.map_error + sd.component_mul(&noise);
        // Out of the plane: no odometry to fuse with, the estimate is the measurement.
        let tilt_noise = Vector3::new(self.normal(), self.normal(), self.normal());
        let tilt_sd = Vector3::new(sd[0], sd[2], sd[2]);
        self.tilt = if self.cfg.out_of_plane {
            self.map_tilt + tilt_sd.component_mul(&tilt_noise)
        } else {
            Vector3::zeros()
        };
        let mut innovation = z - self.x;
        innovation[2] = wrap(innovation[2]);
        let Some(s_inv) = (self.p + self.r).try_inverse() else {
            return;
        };
        let k = self.p * s_inv;
        let i_k = Matrix3::identity() - k;
        self.x += k * innovation;
        self.x[2] = wrap(self.x[2]);
        // Joseph form: stays symmetric and positive semi-definite.
        self.p = i_k * self.p * i_k.transpose() + k * self.r * k.transpose();
        self.p = 0.5 * (self.p + self.p.transpose());
        self.corrections += 1;
    }

    /// The stored keyframe that best matches `here` (nearest within the reuse radius and angle).
    fn nearest(&self, here: &Keyframe) -> Option<usize> {
        let (r, a) = (
            f64::from(self.cfg.reuse_radius_m),
            f64::from(self.cfg.reuse_angle_deg).to_radians(),
        );
        self.keyframes
            .iter()
            .enumerate()
            .filter(|(_, k)| wrap(k.yaw - here.yaw).abs() <= a)
            .map(|(i, k)| (i, (k.x - here.x).hypot(k.y - here.y)))
            .filter(|&(_, d)| d <= r)
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(i, _)| i)
    }

    fn normal(&mut self) -> f64 {
        self.rng.sample(StandardNormal)
    }
}

fn wrap(a: f64) -> f64 {
    let a = (a + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI;
    if a <= -std::f64::consts::PI {
        a + std::f64::consts::TAU
    } else {
        a
    }
}

/// Entries of the [`PoseDelay`] ring.
const RING: usize = 128;
/// Minimum spacing of recorded entries, seconds (`RING` entries then span ≥ 2.5 × [`MAX_DELAY_MS`]).
const RECORD_SPACING_S: f64 = 0.004;

/// A fixed-size history of `(time, [x, y, yaw, neck yaw])` estimates (no allocation): a frame
/// takes the one from `delay` before the latest, linearly interpolated.
#[derive(Debug, Clone)]
pub struct PoseDelay {
    times: [f64; RING],
    poses: [[f32; 4]; RING],
    /// Index of the newest entry.
    head: usize,
    len: usize,
    delay_s: f64,
}

impl PoseDelay {
    /// A history holding `pose` at time 0, read `delay_ms` behind the latest entry.
    pub fn new(pose: [f32; 4], delay_ms: f32) -> Self {
        Self {
            times: [0.0; RING],
            poses: [pose; RING],
            head: 0,
            len: 1,
            delay_s: (f64::from(delay_ms) * 1e-3).clamp(0.0, MAX_DELAY_MS * 1e-3),
        }
    }

    /// Record the pose at time `t` (s, non-decreasing). Entries closer than a few milliseconds
    /// to the newest one replace it.
    pub fn record(&mut self, t: f64, pose: [f32; 4]) {
        if t - self.times[self.head] < RECORD_SPACING_S && self.len > 1 {
            self.times[self.head] = t;
            self.poses[self.head] = pose;
            return;
        }
        self.head = (self.head + 1) % RING;
        self.len = (self.len + 1).min(RING);
        self.times[self.head] = t;
        self.poses[self.head] = pose;
    }

    /// Replace the newest entry's base pose (a correction at the current time).
    pub fn correct_latest(&mut self, base: [f32; 3]) {
        self.poses[self.head][..3].copy_from_slice(&base);
    }

    /// The newest entry.
    pub fn latest(&self) -> [f32; 4] {
        self.poses[self.head]
    }

    /// The pose `delay` before the newest entry (the oldest one if the history is shorter).
    pub fn delayed(&self) -> [f32; 4] {
        let t = self.times[self.head] - self.delay_s;
        let mut newer = self.head;
        for back in 1..self.len {
            let i = (self.head + RING - back) % RING;
            if self.times[i] <= t {
                let span = self.times[newer] - self.times[i];
                let a = if span > 0.0 {
                    ((t - self.times[i]) / span) as f32
                } else {
                    1.0
                };
                let (p, q) = (self.poses[i], self.poses[newer]);
                return [
                    p[0] + a * (q[0] - p[0]),
                    p[1] + a * (q[1] - p[1]),
                    wrap_angle(p[2] + a * wrap_angle(q[2] - p[2])),
                    wrap_angle(p[3] + a * wrap_angle(q[3] - p[3])),
                ];
            }
            newer = i;
        }
        self.poses[newer]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn estimator() -> SlamEstimator {
        SlamEstimator::new(&SlamConfig::default(), [0.0, 0.0, 0.0], 7)
    }

    #[test]
    fn covariance_grows_with_odometry_and_shrinks_at_corrections() {
        let mut s = estimator();
        assert_eq!(*s.covariance(), Matrix3::zeros());
        let mut last = 0.0;
        for _ in 0..20 {
            s.predict(0.02, 0.001, 0.02f64.powi(2) * 0.02, 0.01f64.powi(2) * 0.02);
            let trace = s.covariance().trace();
            assert!(trace > last, "{trace} after {last}");
            last = trace;
        }
        // Lateral uncertainty from the heading: off-diagonal x-yaw / y-yaw terms appear.
        assert!(s.covariance()[(1, 2)].abs() > 0.0);
        // 0.4 m driven (true pose agrees): a keyframe correction.
        let before = *s.covariance();
        assert_eq!(
            s.frame(true, [0.4, 0.0, 0.0], 0.0, 0.4),
            SlamEvent::Keyframe
        );
        let after = s.covariance();
        for i in 0..3 {
            assert!(after[(i, i)] < before[(i, i)], "{i}: {after} vs {before}");
        }
        assert_eq!(after, &after.transpose());
        assert_eq!(s.corrections(), 1);
        // No keyframe is due until the camera moves on.
        assert_eq!(s.frame(true, [0.45, 0.0, 0.0], 0.0, 0.45), SlamEvent::None);
    }

    #[test]
    fn a_relocalization_jumps_back_near_the_truth() {
        let mut s = estimator();
        // Lost: odometry only, with a biased measurement (2 m measured as 2.3 m).
        assert_eq!(s.frame(false, [0.0, 0.0, 0.0], 0.0, 0.0), SlamEvent::None);
        for _ in 0..100 {
            s.predict(0.023, 0.0, 0.06f64.powi(2) * 0.02, 0.03f64.powi(2) * 0.02);
            assert_eq!(s.frame(false, [0.0, 0.0, 0.0], 0.0, 0.0), SlamEvent::None);
        }
        let before = s.pose();
        assert!((before[0] - 2.3).abs() < 1e-3, "{before:?}");
        let truth = [2.0, 0.0, 0.0];
        assert_eq!(s.frame(true, truth, 0.0, 2.0), SlamEvent::Relocalization);
        let after = s.pose();
        let jump = (after[0] - before[0]).hypot(after[1] - before[1]);
        let err = (after[0] - truth[0]).hypot(after[1] - truth[1]);
        assert!(jump > 0.25, "jump {jump}");
        assert!(err < 0.06, "residual {err}");
        assert_eq!(s.relocalizations(), 1);
    }

    #[test]
    fn revisiting_the_start_closes_a_loop_and_restores_its_map_error() {
        let mut s = estimator();
        // A 4 m square of new keyframes: the map error random-walks.
        let mut travel = 0.0;
        let corners = [[1.0, 0.0], [1.0, 1.0], [0.0, 1.0], [0.0, 0.0]];
        let mut at = [0.0f32, 0.0];
        for c in corners {
            for k in 1..=10 {
                let f = k as f32 / 10.0;
                let p = [at[0] + f * (c[0] - at[0]), at[1] + f * (c[1] - at[1])];
                travel += 0.1;
                s.frame(true, [p[0], p[1], 0.0], 0.0, travel);
            }
            at = c;
        }
        assert_eq!(s.loop_closures(), 1, "back at the start");
        assert_eq!(s.map_error, Vector3::zeros());
        assert!(s.keyframe_count() > 5);
    }

    #[test]
    fn the_delayed_pose_interpolates_the_history() {
        let mut h = PoseDelay::new([0.0; 4], 20.0);
        assert_eq!(h.delayed(), [0.0; 4]);
        for k in 1..=10 {
            let t = k as f64 * 0.01;
            h.record(t, [t as f32, 0.0, 0.0, 0.5]);
        }
        let d = h.delayed();
        assert!((d[0] - 0.08).abs() < 1e-5, "{d:?}");
        assert_eq!(h.latest()[0], 0.1);
        h.correct_latest([1.0, 2.0, 3.0]);
        assert_eq!(h.latest(), [1.0, 2.0, 3.0, 0.5]);
        // Long runs wrap the ring without allocating.
        for k in 11..=1000 {
            let t = k as f64 * 0.01;
            h.record(t, [t as f32, 0.0, 0.0, 0.0]);
        }
        assert!((h.delayed()[0] - 9.98).abs() < 1e-3);
    }
}
