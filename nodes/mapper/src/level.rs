//! Floor levelling (`[mapper.level]`): the camera's height, roll and pitch from the floor in its
//! own depth image.
//!
//! A visual SLAM without a gravity prior (ORB-SLAM2 RGB-D) estimates all six degrees of freedom
//! from features, so its camera pose carries a height, roll and pitch error that odometry on a
//! flat floor cannot correct. A pitch error of 0.5° moves a point 2 m away by 1.7 cm vertically,
//! and views taken at different keyframes disagree by that much: heights and footprints smear.
//! A ground robot knows where its floor is (z = 0), and most frames of a camera pitched down see
//! it. Before a frame is used, the mapper fits a plane to the depth points that the frame's pose
//! puts near the floor, and corrects the pose so that this plane is the floor: a rotation taking
//! the plane's normal to +z about the floor point under the camera (the SLAM's tilt pivots about
//! the base's floor point), then a lift putting that point at z = 0. The yaw and the horizontal
//! position are left alone (the floor says nothing about them).
//!
//! The fit is least squares `z = a·(x − x̄) + b·(y − ȳ) + c` over the points within `band` of
//! z = 0, refitted over the points near the last fit with the tolerance halving down to `inlier`
//! (the bottoms of walls and furniture, rugs and low objects drop out). It is used only with `min_points` inliers spread at
//! least `min_spread` (rms) along both horizontal axes, and only if the correction stays within
//! `max_tilt_deg` and `max_dz`; otherwise the frame keeps its pose.

use glam::{Affine3A, DVec3, Quat, Vec3};
use shm_types::DepthFrame;

/// `[mapper.level]` parameters.
#[derive(Debug, Clone, Copy, PartialEq, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LevelConfig {
    /// On / off.
    pub enabled: bool,
    /// Pixel stride of the depth sample.
    pub stride: u32,
    /// Candidates: points within this of z = 0 under the frame's pose, metres.
    pub band: f32,
    /// Inliers: points within this of the first fit, metres.
    pub inlier: f32,
    /// Depth beyond this is not used (noise grows with range), metres.
    pub max_depth: f32,
    /// Fewest inliers for a correction.
    pub min_points: u32,
    /// Smallest rms spread of the inliers along their narrower horizontal axis, metres.
    pub min_spread: f32,
    /// Largest tilt correction accepted, degrees.
    pub max_tilt_deg: f32,
    /// Largest height correction accepted, metres.
    pub max_dz: f32,
}

impl LevelConfig {
    /// Range-check; `c` is at this table.
    pub fn validate(&self, c: &settings::Checker) -> Result<(), settings::ConfigError> {
        settings::ranges!(c, self, {
            stride: count(1, 64),
            [band, max_dz]: in_range(0.001, 1.0),
            inlier: in_range(0.001, 0.5),
            max_depth: in_range(0.1, 20.0),
            min_points: count(3, 1_000_000),
            min_spread: in_range(0.0, 10.0),
            max_tilt_deg: in_range(0.0, 30.0),
        });
        Ok(())
    }
}

/// A floor fit: the plane's unit normal (up) and a point on it, world frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FloorFit {
    /// Unit normal, z > 0.
    pub normal: DVec3,
    /// A point of the plane (the inliers' centroid).
    pub point: DVec3,
    /// Inliers used.
    pub inliers: u32,
}

/// Least-squares plane `z = a·dx + b·dy + c` over `pts` (centred at their mean); `None` when the
/// horizontal spread along the narrower axis is below `min_spread` (rms).
fn fit(pts: &[DVec3], min_spread: f64) -> Option<(f64, f64, DVec3)> {
    let n = pts.len() as f64;
    if pts.len() < 3 {
        return None;
    }
    let mean = pts.iter().copied().sum::<DVec3>() / n;
    let (mut sxx, mut sxy, mut syy, mut sxz, mut syz) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for p in pts {
        let d = *p - mean;
        sxx += d.x * d.x;
        sxy += d.x * d.y;
        syy += d.y * d.y;
        sxz += d.x * d.z;
        syz += d.y * d.z;
    }
    // Smaller eigenvalue of the horizontal covariance.
    let (cxx, cxy, cyy) = (sxx / n, sxy / n, syy / n);
    let half_tr = 0.5 * (cxx + cyy);
    let lo = half_tr - (0.25 * (cxx - cyy).powi(2) + cxy * cxy).sqrt();
    let det = sxx * syy - sxy * sxy;
    if lo < min_spread * min_spread || det <= 0.0 {
        return None;
    }
    let a = (sxz * syy - syz * sxy) / det;
    let b = (syz * sxx - sxz * sxy) / det;
    Some((a, b, mean))
}

/// Fit the floor to `frame`'s depth placed with `pose` (`world_from_camera`), with `unproject`
/// giving a pixel's camera-frame point at a depth.
pub fn fit_floor(
    frame: &DepthFrame,
    unproject: impl Fn(f32, f32, f32) -> Vec3,
    pose: &Affine3A,
    cfg: &LevelConfig,
    scratch: &mut Vec<DVec3>,
) -> Option<FloorFit> {
    let (w, h) = (frame.width as usize, frame.height as usize);
    let depth = frame.pixels();
    let stride = cfg.stride.max(1) as usize;
    scratch.clear();
    for v in (stride / 2..h).step_by(stride) {
        for u in (stride / 2..w).step_by(stride) {
            let d = depth[v * w + u];
            let z = d as f32 * 1e-3;
            if d == 0 || z > cfg.max_depth {
                continue;
            }
            let p = pose.transform_point3(unproject(u as f32 + 0.5, v as f32 + 0.5, z));
            if p.z.abs() <= cfg.band {
                scratch.push(p.as_dvec3());
            }
        }
    }
    let spread = f64::from(cfg.min_spread);
    let (mut a, mut b, mut mean) = fit(scratch, spread)?;
    // Refit over the points near the last fit, the tolerance halving down to `inlier`: the
    // bottoms of walls and furniture inside the band pull the first fit, not the last.
    let mut tol = f64::from(cfg.band);
    while tol > f64::from(cfg.inlier) {
        tol = (0.5 * tol).max(f64::from(cfg.inlier));
        scratch.retain(|p| {
            let d = *p - mean;
            (d.z - a * d.x - b * d.y).abs() <= tol
        });
        if scratch.len() < cfg.min_points as usize {
            return None;
        }
        (a, b, mean) = fit(scratch, spread)?;
    }
    Some(FloorFit {
        normal: DVec3::new(-a, -b, 1.0).normalize(),
        point: mean,
        inliers: scratch.len() as u32,
    })
}

impl FloorFit {
    /// The world-frame correction (to premultiply the camera pose) that makes this plane the
    /// floor: a rotation of the normal to +z about the plane's point under `camera`, then a lift
    /// of that point to z = 0. `None` beyond `max_tilt_deg` / `max_dz`.
    pub fn correction(&self, camera: Vec3, cfg: &LevelConfig) -> Option<Affine3A> {
        let n = self.normal;
        let tilt = n.z.clamp(-1.0, 1.0).acos();
        // The plane's point under the camera, along the normal.
        let c = camera.as_dvec3();
        let foot = c - n * (c - self.point).dot(n);
        if tilt > f64::from(cfg.max_tilt_deg).to_radians() || foot.z.abs() > f64::from(cfg.max_dz) {
            return None;
        }
        let r = Quat::from_rotation_arc(n.as_vec3(), Vec3::Z);
        let f = foot.as_vec3();
        Some(
            Affine3A::from_translation(Vec3::new(f.x, f.y, 0.0))
                * Affine3A::from_quat(r)
                * Affine3A::from_translation(-f),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use shm_types::boxed_zeroed;

    fn cfg() -> LevelConfig {
        LevelConfig {
            enabled: true,
            stride: 4,
            band: 0.15,
            inlier: 0.02,
            max_depth: 4.0,
            min_points: 100,
            min_spread: 0.15,
            max_tilt_deg: 3.0,
            max_dz: 0.1,
        }
    }

    /// A pinhole camera 1.4 m up, pitched 28° down, facing +x (optical: z forward, y down).
    fn true_pose() -> Affine3A {
        let optical = glam::Mat3::from_cols(-Vec3::Y, -Vec3::Z, Vec3::X);
        let pitch = Quat::from_rotation_y(28f32.to_radians());
        Affine3A::from_translation(Vec3::new(1.0, 2.0, 1.4))
            * Affine3A::from_quat(pitch)
            * Affine3A::from_mat3(optical)
    }

    const F: f32 = 300.0;
    fn unproject(u: f32, v: f32, z: f32) -> Vec3 {
        Vec3::new((u - 160.0) / F * z, (v - 120.0) / F * z, z)
    }

    /// Depth of the floor (and a 0.3 m tall box, not floor) seen with the true pose.
    fn render(pose: &Affine3A) -> Box<DepthFrame> {
        let mut f = boxed_zeroed::<DepthFrame>();
        f.width = 320;
        f.height = 240;
        let c = Vec3::from(pose.translation);
        for v in 0..240 {
            for u in 0..320 {
                let dir = pose.transform_vector3(unproject(u as f32 + 0.5, v as f32 + 0.5, 1.0));
                // Ray's depth where it meets the floor (z = 0), or the box top at z = 0.3.
                if dir.z >= 0.0 {
                    continue;
                }
                let mut t = -c.z / dir.z;
                let hit = c + dir * t;
                if (2.5..3.0).contains(&hit.x) {
                    t = (0.3 - c.z) / dir.z;
                }
                f.pixels_mut()[v * 320 + u] = (t * 1000.0).round() as u16;
            }
        }
        f
    }

    #[test]
    fn the_floor_undoes_a_height_roll_and_pitch_error() {
        let truth = true_pose();
        let frame = render(&truth);
        // The estimate: tilted about the base's floor point and lifted, as the SLAM's error.
        let at = Vec3::new(1.0, 2.0, 0.0);
        let err = Affine3A::from_translation(at + Vec3::Z * 0.02)
            * Affine3A::from_quat(
                Quat::from_rotation_x(0.8f32.to_radians())
                    * Quat::from_rotation_y(-0.6f32.to_radians()),
            )
            * Affine3A::from_translation(-at);
        let est = err * truth;
        let mut scratch = Vec::new();
        let fit = fit_floor(&frame, unproject, &est, &cfg(), &mut scratch).expect("floor fit");
        assert!(fit.inliers >= 100, "{}", fit.inliers);
        let tilt = fit.normal.z.acos().to_degrees();
        assert!(
            (tilt - 1.0).abs() < 0.05,
            "fitted tilt {tilt}° (error 1.0°)"
        );
        let corr = fit.correction(est.translation.into(), &cfg()).unwrap();
        let fixed = corr * est;
        // A point 2 m ahead lands where the true pose puts it (mm), and so does the camera.
        let p = unproject(160.0, 120.0, 2.0);
        let d = (fixed.transform_point3(p) - truth.transform_point3(p)).length();
        assert!(d < 0.003, "point off by {d} m after the correction");
        let before = (est.transform_point3(p) - truth.transform_point3(p)).length();
        assert!(before > 0.03, "{before}");
        let cam = (Vec3::from(fixed.translation) - Vec3::from(truth.translation)).length();
        assert!(cam < 0.003, "camera off by {cam} m");
    }

    #[test]
    fn no_correction_without_enough_floor_or_beyond_the_bounds() {
        let truth = true_pose();
        let mut frame = render(&truth);
        // Only a narrow column of the image sees the floor: too little spread.
        for v in 0..240 {
            for u in 0..320 {
                if !(150..170).contains(&u) {
                    frame.pixels_mut()[v * 320 + u] = 0;
                }
            }
        }
        let mut s = Vec::new();
        let narrow = fit_floor(&frame, unproject, &truth, &cfg(), &mut s);
        assert!(narrow.is_none(), "{narrow:?}");
        assert!(
            s.len() >= 100,
            "enough points ({}), but in a column",
            s.len()
        );
        // A 5° error is beyond max_tilt_deg = 3.
        let frame = render(&truth);
        let at = Vec3::new(1.0, 2.0, 0.0);
        let err = Affine3A::from_translation(at)
            * Affine3A::from_quat(Quat::from_rotation_x(5f32.to_radians()))
            * Affine3A::from_translation(-at);
        let wide = LevelConfig {
            band: 0.25,
            ..cfg()
        };
        let fit = fit_floor(&frame, unproject, &(err * truth), &wide, &mut s).unwrap();
        assert!(fit.correction(truth.translation.into(), &wide).is_none());
    }
}
