//! Objects with little valid depth, placed from their box on the supporting surface (issue
//! #47): glass reads through or drops out of the depth image, a dark or shiny surface drops
//! out, so a box-only detection of such an object yields too few points of its own and the
//! object was never mapped (the paper scenes' glass bottles). It is placed by its box instead,
//! as a robot engineer would by eye: the object stands on a mapped table top, so the ray
//! through the middle of the box's bottom edge meets the table where the object's near side
//! stands. Its front face is the vertical plane through that point facing the camera; the
//! box's pixel rays meet that plane in the object's silhouette, and its back face lies the
//! class's depth (the mapper's size prior, [`super::priors`]) behind. Those points then go
//! through association, existence and merging like any detection's points, so an object placed
//! this way must earn its place like any other: views from around it accumulate, and a false
//! box is missed from the next viewpoint and decays.
//!
//! A box is placed only when it shows an object standing on a visible, free table top:
//! - its bottom edge is inside the image (a cut box hides where the object stands) and its
//!   middle ray meets a mapped supporting plane from above;
//! - the pixels just under the box (`below_px` rows) see that plane: at least
//!   `min_support_fraction` of those with valid depth lie on it, within `tolerance` in height
//!   (a wall's false positive has wall under it, an object on a shelf board behind a table's
//!   edge has the edge);
//! - at most `max_occluded_fraction` of the box's pixels with valid depth lie nearer than its
//!   front face by `front_margin` (something stands in front of it; its own depth is missing
//!   or behind).
//!
//! Where it stands is only as good as the box's bottom edge: seen from a camera h above the
//! table at distance d, one pixel of the edge moves the base by d² / (f h) along the line of
//! sight (2 cm at 2 m for a 640 × 480 camera 0.5 m above the table). Views from around the
//! object average these errors out, as they do a depth cloud's.

use super::Mapper;
use super::priors::size_prior;
use geom::Camera;
use glam::{Affine3A, Vec3};
use serde::Deserialize;
use shm_types::{DepthFrame, Detection};

/// `[mapper.standing]` section.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StandingConfig {
    /// Place box-only foreground detections with too few points of their own from their box.
    pub enabled: bool,
    /// Only detections scoring at least this are placed.
    pub min_score: f32,
    /// Rows of pixels under the box's bottom edge that must show the supporting plane.
    pub below_px: u32,
    /// Fraction of those rows' valid pixels that must lie on the plane.
    pub min_support_fraction: f32,
    /// A pixel under the box lies on the plane when its point is within this height of it, m.
    pub tolerance: f32,
    /// A box pixel nearer than the front face by more than this (along its ray) sees something
    /// in front of the object, m.
    pub front_margin: f32,
    /// At most this fraction of the box's valid pixels may see something in front.
    pub max_occluded_fraction: f32,
    /// Box samples per detection at most (front and back face points are twice this).
    pub max_samples: u32,
}

impl Default for StandingConfig {
    /// The `[mapper.standing]` section of the built-in `config/default.toml`.
    fn default() -> Self {
        crate::DEFAULTS.section("mapper.standing")
    }
}

impl StandingConfig {
    /// Range-check; `c` is at this table.
    pub fn validate(&self, c: &settings::Checker) -> Result<(), settings::ConfigError> {
        settings::ranges!(c, self, {
            min_score: in_range(0.0, 1.0),
            below_px: count(1, 64),
            [min_support_fraction, max_occluded_fraction]: in_range(0.0, 1.0),
            [tolerance, front_margin]: in_range(0.001, 1.0),
            max_samples: count(16, 100_000),
        });
        Ok(())
    }
}

/// Depth at pixel `(u, v)` in metres, `None` when invalid or outside the image.
fn depth_at(frame: &DepthFrame, u: f32, v: f32) -> Option<f32> {
    let (w, h) = (frame.width as usize, frame.height as usize);
    if u < 0.0 || v < 0.0 || u >= w as f32 || v >= h as f32 {
        return None;
    }
    let raw = frame.pixels()[v as usize * w + u as usize];
    (raw != 0).then_some(f32::from(raw) * 1e-3)
}

impl Mapper {
    /// The points of a standing object's box-only detection placed on the table top under it
    /// (see the module doc); `out` is cleared first. Returns the number of points (0: the box
    /// does not show an object standing on a visible, free, mapped table top).
    pub(super) fn standing_points(
        &self,
        frame: &DepthFrame,
        camera: &Camera,
        pose: &Affine3A,
        det: &Detection,
        out: &mut Vec<Vec3>,
    ) -> usize {
        out.clear();
        let s = &self.cfg.standing;
        if !s.enabled || det.score < s.min_score {
            return 0;
        }
        let cam: Vec3 = pose.translation.into();
        let [x0, y0, x1, y1] = det.bbox.map(f32::from);
        let (w, h) = (frame.width as f32, frame.height as f32);
        let border = self.cfg.view_extents.border_px.max(1.0);
        if x1 <= x0 || y1 <= y0 || y1 > h - border - s.below_px as f32 {
            return 0;
        }
        let world_ray = |u: f32, v: f32| pose.transform_vector3(camera.ray(u, v));
        // Where the object stands: the middle of the bottom edge on the highest mapped plane
        // below the camera whose footprint holds it.
        let uc = 0.5 * (x0 + x1);
        let bottom = world_ray(uc, y1 - 0.5);
        let Some(plane) = self.plane_hit_by(cam, bottom) else {
            return 0;
        };
        let base = cam + bottom * ((plane - cam.z) / bottom.z);
        // The table must show under the box.
        let step = ((x1 - x0) / 16.0).max(1.0);
        let (mut valid, mut on) = (0u32, 0u32);
        for row in 1..=s.below_px {
            let v = y1 + row as f32;
            let mut u = x0 + 0.5 * step;
            while u < x1 {
                let d = world_ray(u, v);
                if let (true, Some(z)) = (d.z < 0.0, depth_at(frame, u, v)) {
                    valid += 1;
                    on += ((cam.z + d.z * z - plane).abs() <= s.tolerance) as u32;
                }
                u += step;
            }
        }
        if valid < 3 || (on as f32) < s.min_support_fraction * valid as f32 {
            return 0;
        }
        // Front face: the vertical plane through the base facing the camera; back face the
        // class's depth behind it.
        let toward = (base - cam).truncate();
        if toward.length() < 1e-3 {
            return 0;
        }
        let n = toward.normalize().extend(0.0);
        let prior = size_prior(det.class_id).size;
        let depth = prior[0].min(prior[1]);
        let front = n.dot(base - cam);
        let area = (x1 - x0) * (y1 - y0);
        let step = (area / s.max_samples.max(1) as f32).sqrt().max(1.0);
        let (mut samples, mut occluded) = (0u32, 0u32);
        let mut v = y0 + 0.5 * step;
        while v < y1.min(h) {
            let mut u = x0.max(0.0) + 0.5 * step;
            while u < x1.min(w) {
                let (u0, d) = (u, world_ray(u, v));
                u += step;
                let along = d.dot(n);
                if along <= 1e-4 {
                    continue;
                }
                let t_front = front / along;
                let p = cam + d * t_front;
                if p.z < plane {
                    continue;
                }
                if let Some(z) = depth_at(frame, u0, v) {
                    samples += 1;
                    if z < t_front - s.front_margin {
                        occluded += 1;
                        continue;
                    }
                }
                out.push(p);
                out.push(p + n * depth);
            }
            v += step;
        }
        if (occluded as f32) > s.max_occluded_fraction * samples as f32 {
            out.clear();
        }
        out.len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::MapperConfig;
    use crate::cuboid::Box3;
    use crate::points::SupportPlane;
    use glam::Mat3;

    /// A 320 x 240 camera 1.5 m above the floor looking along world +x, a table top at 0.75 m
    /// from x = 0.5 to 3 m, and a glass bottle standing at x = 2 whose box has no valid depth.
    fn setup() -> (Mapper, Camera, Affine3A, Box<DepthFrame>, Detection) {
        let camera = Camera::from_fov(320, 240, 60.0, 46.8, 0.3, 6.0);
        let mut cfg = MapperConfig::default();
        cfg.standing.enabled = true;
        let mut m = Mapper::new(&cfg, &camera).unwrap();
        m.supports = vec![SupportPlane {
            height: 0.75,
            footprint: Box3 {
                center: Vec3::new(1.75, 0.0, 0.375),
                size: Vec3::new(2.5, 2.0, 0.75),
                yaw: 0.0,
            },
        }];
        // Camera x → world −y, camera y → world −z, camera z → world +x.
        let rot = Mat3::from_cols(Vec3::NEG_Y, Vec3::NEG_Z, Vec3::X);
        let pose = Affine3A::from_mat3_translation(rot, Vec3::new(0.0, 0.0, 1.5));
        let mut frame = shm_types::boxed_zeroed::<DepthFrame>();
        frame.width = camera.width;
        frame.height = camera.height;
        frame.intrinsics = camera.k;
        // The bottle's box: 8 cm wide, 0.75 to 1.05 m high, its front at x = 2 m.
        let px = |p: Vec3| camera.project(pose.inverse().transform_point3(p)).unwrap();
        let (lo, hi) = (
            px(Vec3::new(2.0, 0.04, 1.05)),
            px(Vec3::new(2.0, -0.04, 0.75)),
        );
        let bbox = [lo.x, lo.y, hi.x, hi.y].map(|v| v.round() as u16);
        let (w, h) = (frame.width as usize, frame.height as usize);
        for v in 0..h {
            for u in 0..w {
                let inside = (bbox[0] as usize..bbox[2] as usize).contains(&u)
                    && (bbox[1] as usize..bbox[3] as usize).contains(&v);
                let d = pose.transform_vector3(camera.ray(u as f32 + 0.5, v as f32 + 0.5));
                if inside || d.z >= 0.0 {
                    continue;
                }
                let t = (0.75 - 1.5) / d.z;
                if (0.5..3.0).contains(&(d.x * t)) {
                    frame.pixels_mut()[v * w + u] = (t * 1000.0).round() as u16;
                }
            }
        }
        let det = Detection {
            class_id: shm_types::class_id("bottle").unwrap(),
            label: 0,
            score: 0.8,
            bbox,
            mask_pixels: 0,
        };
        (m, camera, pose, frame, det)
    }

    #[test]
    fn a_glass_bottle_is_placed_where_it_stands_on_the_table() {
        let (m, camera, pose, frame, det) = setup();
        let mut pts = Vec::new();
        let n = m.standing_points(&frame, &camera, &pose, &det, &mut pts);
        assert!(n > 20, "{n} points");
        let depth = {
            let s = size_prior(det.class_id).size;
            s[0].min(s[1])
        };
        // Front face at x = 2 (the box's bottom edge rounds to a pixel: d² / (f h) = 2 cm per
        // pixel here), back face
        // the prior's depth behind; all between the table top and the box's top.
        let xs: Vec<f32> = pts.iter().map(|p| p.x).collect();
        let (x_min, x_max) = xs
            .iter()
            .fold((f32::MAX, f32::MIN), |(a, b), x| (a.min(*x), b.max(*x)));
        assert!((x_min - 2.0).abs() < 0.03, "front at {x_min}");
        assert!((x_max - (x_min + depth)).abs() < 1e-3, "back at {x_max}");
        assert!(
            pts.iter()
                .all(|p| p.z >= 0.75 - 1e-4 && p.z < 1.1 && p.y.abs() < 0.07)
        );
    }

    #[test]
    fn a_box_with_no_table_under_it_or_something_in_front_is_not_placed() {
        let (m, camera, pose, mut frame, det) = setup();
        let mut pts = Vec::new();
        // Something nearer (0.8 m) fills the box: the object is hidden, not glass.
        let w = frame.width as usize;
        let [x0, y0, x1, y1] = det.bbox.map(usize::from);
        for v in y0..y1 {
            for u in x0..x1 {
                frame.pixels_mut()[v * w + u] = 800;
            }
        }
        assert_eq!(m.standing_points(&frame, &camera, &pose, &det, &mut pts), 0);
        // A wall (3 m) under the box instead of the table: a wall's false positive.
        let (m, camera, pose, mut frame, det) = setup();
        for v in y1..(y1 + 6).min(frame.height as usize) {
            for u in x0..x1 {
                frame.pixels_mut()[v * w + u] = 3000;
            }
        }
        assert_eq!(m.standing_points(&frame, &camera, &pose, &det, &mut pts), 0);
        // Off: nothing placed.
        let (mut m, camera, pose, frame, det) = setup();
        m.cfg.standing.enabled = false;
        assert_eq!(m.standing_points(&frame, &camera, &pose, &det, &mut pts), 0);
        assert!(pts.is_empty());
    }
}
