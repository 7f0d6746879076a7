//! Online calibration of a constant camera-yaw offset (`[mapper.yaw_calibration]`): the
//! neck encoder's zero error, estimated from the objects the mapper already holds.
//!
//! With a yaw offset `b` (believed camera yaw = true + b), a point at `P` seen from the camera at
//! `C` is placed at `C + Rz(b)(P − C)`: displaced by `b · u` with `u = perp(P − C)` (the line of
//! sight turned 90° counter-clockwise, length the range). An object's view centroid `x_i` is then
//! `c + b · u_i + e_i`, where the pose noise `e_i` averages out and the visible-side offset lies
//! along the line of sight, orthogonal to `u_i`. With each object's own unknown centre `c`, the
//! least-squares `b` is the within-object regression
//! `b = Σ_objects Σ_i (x_i − x̄)·(u_i − ū) / Σ_objects Σ_i |u_i − ū|²`:
//! an object seen from one direction only (all `u_i` alike) carries no weight, one seen from
//! around carries much. The centroids are recorded as the uncorrected pose would have placed
//! them, so the estimate is of the full offset whatever correction was applied when.
//!
//! Once its standard error is below `max_sd_deg`, the estimate (bounded by `max_offset_deg`) is
//! applied to every new frame's pose as a yaw about the camera.

use glam::{Affine3A, DVec2, Quat, Vec3};
use std::collections::HashMap;

/// `[mapper.yaw_calibration]` parameters.
#[derive(Debug, Clone, Copy, PartialEq, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct YawCalibrationConfig {
    /// On / off.
    pub enabled: bool,
    /// Views of an object before it takes part.
    pub min_views: u32,
    /// The estimate is applied once its standard error is at most this, degrees.
    pub max_sd_deg: f32,
    /// Bound on the applied offset, degrees.
    pub max_offset_deg: f32,
}

impl YawCalibrationConfig {
    /// Range-check; `c` is at this table.
    pub fn validate(&self, c: &settings::Checker) -> Result<(), settings::ConfigError> {
        settings::ranges!(c, self, {
            min_views: count(2, 1_000_000),
            max_sd_deg: in_range(0.001, 10.0),
            max_offset_deg: in_range(0.0, 10.0),
        });
        Ok(())
    }
}

/// Running sums of one object's views.
#[derive(Debug, Clone, Copy, Default)]
struct Sums {
    n: f64,
    x: DVec2,
    u: DVec2,
    xu: f64,
    uu: f64,
    xx: f64,
}

impl Sums {
    /// Within-object `(Sxu, Suu, Sxx)`.
    fn centred(&self) -> (f64, f64, f64) {
        let n = self.n;
        (
            self.xu - self.x.dot(self.u) / n,
            self.uu - self.u.length_squared() / n,
            self.xx - self.x.length_squared() / n,
        )
    }
}

/// The estimate: offset and its standard error, radians, from `views` views of `objects`
/// objects.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct YawOffset {
    /// Offset `b`, radians (believed camera yaw − true).
    pub offset: f64,
    /// Its standard error, radians.
    pub sd: f64,
    /// Views used.
    pub views: u32,
}

/// The calibration state.
#[derive(Debug, Clone, Default)]
pub struct YawCalibration {
    objects: HashMap<u32, Sums>,
    /// The offset applied to new frames, radians.
    applied: f32,
}

impl YawCalibration {
    /// The correction to premultiply a frame's `world_from_camera` with: a yaw of minus the
    /// applied offset about the camera.
    pub fn correction(&self, pose: &Affine3A) -> Affine3A {
        let c: Vec3 = pose.translation.into();
        Affine3A::from_translation(c)
            * Affine3A::from_quat(Quat::from_rotation_z(-self.applied))
            * Affine3A::from_translation(-c)
    }

    /// The offset applied to new frames, radians.
    pub fn applied(&self) -> f32 {
        self.applied
    }

    /// Record a view of object `id`: its points' centroid `centroid` (world, placed with the
    /// corrected pose) seen from the camera at `camera`.
    pub fn record(&mut self, id: u32, centroid: Vec3, camera: Vec3) {
        let c = camera.truncate().as_dvec2();
        // As the uncorrected pose would have placed it.
        let x = c + DVec2::from_angle(f64::from(self.applied))
            .rotate(centroid.truncate().as_dvec2() - c);
        let u = (x - c).perp();
        let s = self.objects.entry(id).or_default();
        s.n += 1.0;
        s.x += x;
        s.u += u;
        s.xu += x.dot(u);
        s.uu += u.length_squared();
        s.xx += x.length_squared();
    }

    /// The least-squares offset over the objects with at least `cfg.min_views` views.
    pub fn estimate(&self, cfg: &YawCalibrationConfig) -> Option<YawOffset> {
        let (mut sxu, mut suu, mut sxx, mut n, mut k) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for s in self
            .objects
            .values()
            .filter(|s| s.n >= f64::from(cfg.min_views))
        {
            let (a, b, c) = s.centred();
            sxu += a;
            suu += b;
            sxx += c;
            n += s.n;
            k += 1.0;
        }
        // Two coordinates per view; a centre (2) per object and the offset (1) estimated.
        let dof = 2.0 * n - 2.0 * k - 1.0;
        if suu <= 0.0 || dof < 1.0 {
            return None;
        }
        let b = sxu / suu;
        let rss = (sxx - b * sxu).max(0.0);
        Some(YawOffset {
            offset: b,
            sd: (rss / dof / suu).sqrt(),
            views: n as u32,
        })
    }

    /// Update the applied offset from the estimate (once it is certain enough).
    pub fn update(&mut self, cfg: &YawCalibrationConfig) {
        if let Some(e) = self.estimate(cfg)
            && e.sd <= f64::from(cfg.max_sd_deg).to_radians()
        {
            let max = cfg.max_offset_deg.to_radians();
            self.applied = (e.offset as f32).clamp(-max, max);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cfg() -> YawCalibrationConfig {
        YawCalibrationConfig {
            enabled: true,
            min_views: 3,
            max_sd_deg: 0.1,
            max_offset_deg: 2.0,
        }
    }

    /// Views of two objects from around them, with offset `b` and a deterministic jitter.
    fn views(cal: &mut YawCalibration, b: f32) {
        let objects = [Vec3::new(1.0, 1.0, 0.8), Vec3::new(1.3, 0.9, 0.8)];
        for k in 0..48 {
            let a = k as f32 * std::f32::consts::TAU / 48.0;
            let cam = Vec3::new(1.1, 1.0, 1.4) + 2.0 * Vec3::new(a.cos(), a.sin(), 0.0);
            for (id, p) in objects.iter().enumerate() {
                // The visible side is nearer the camera; plus ±5 mm jitter.
                let near = *p + (cam - *p).normalize() * 0.03;
                let jitter = 0.005 * Vec3::new((k as f32 * 2.7).sin(), (k as f32 * 1.9).cos(), 0.0);
                let placed = cam + Quat::from_rotation_z(b - cal.applied()) * (near - cam) + jitter;
                cal.record(id as u32, placed, cam);
            }
        }
    }

    #[test]
    fn the_offset_is_found_from_objects_seen_from_around() {
        let b = 0.6f32.to_radians();
        let mut cal = YawCalibration::default();
        views(&mut cal, b);
        let e = cal.estimate(&cfg()).unwrap();
        assert!(
            (e.offset - f64::from(b)).abs() < 0.02f64.to_radians(),
            "{:?}",
            e
        );
        assert!(e.sd < 0.08f64.to_radians(), "{e:?}");
        cal.update(&cfg());
        assert!((cal.applied() - b).abs() < 0.02f32.to_radians());
        // Corrected views keep the estimate (recorded as the uncorrected pose placed them).
        views(&mut cal, b);
        let e = cal.estimate(&cfg()).unwrap();
        assert!(
            (e.offset - f64::from(b)).abs() < 0.02f64.to_radians(),
            "{e:?}"
        );
        // The correction undoes the offset: a point placed with it lands back where it is.
        let cam = Vec3::new(3.0, 1.0, 1.4);
        let pose =
            Affine3A::from_translation(cam) * Affine3A::from_quat(Quat::from_rotation_z(0.3 + b));
        let fixed = cal.correction(&pose) * pose;
        let truth =
            Affine3A::from_translation(cam) * Affine3A::from_quat(Quat::from_rotation_z(0.3));
        let p = Vec3::new(2.0, 0.0, 0.0);
        assert!((fixed.transform_point3(p) - truth.transform_point3(p)).length() < 1e-3);
    }

    #[test]
    fn views_from_one_direction_give_no_estimate() {
        let mut cal = YawCalibration::default();
        for k in 0..10 {
            let p = Vec3::new(1.0 + 0.001 * k as f32, 1.0, 0.8);
            cal.record(0, p, Vec3::new(3.0, 1.0, 1.4));
        }
        let e = cal.estimate(&cfg());
        assert!(e.is_none_or(|e| e.sd > 0.1f64.to_radians()), "{e:?}");
        cal.update(&cfg());
        assert_eq!(cal.applied(), 0.0);
    }
}
