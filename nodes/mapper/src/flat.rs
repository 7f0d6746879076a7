//! Flat objects (an addition beyond the paper, `[mapper.extensions] flat_objects`): a box-only
//! detection of a class whose size prior is at most `[mapper.flat] max_height` high (a cell
//! phone, 1 cm) has no points of its own — its top lies inside the ±`support_margin` band that
//! removes the table top, and a dark surface drops out of the depth image. It is located by its
//! box instead: the rays of the box's sample pixels are intersected with the top of the mapped
//! table under the box's centre, lifted by the prior's height (for a flat object the box's edges
//! are its near and far edges on the plane). A sample whose depth lies nearer than that by more
//! than `stand_tolerance` sees something standing there and is skipped, as is one whose depth
//! lies beyond the table top (the ray leaves the table); at least `min_on_plane` of the samples
//! must see the table top (or drop out), else the box is not on a free table region. The points
//! then go through association and merging as any detection's points; views accumulate them.

use super::Mapper;
use super::priors::size_prior;
use geom::Camera;
use glam::{Affine3A, Vec3};
use shm_types::{DepthFrame, Detection};

/// Whether `class_id` is flat: its size prior is at most `max_height` high.
pub fn is_flat(class_id: shm_types::ClassId, max_height: f32) -> bool {
    size_prior(class_id).size[2] <= max_height
}

impl Mapper {
    /// The height of the highest mapped supporting plane below the camera at `cam` whose
    /// footprint holds the point where the world ray `ray` meets it; `None` when the ray does
    /// not point down or meets none.
    pub(super) fn plane_hit_by(&self, cam: Vec3, ray: Vec3) -> Option<f32> {
        if ray.z >= 0.0 {
            return None;
        }
        self.supports
            .iter()
            .filter(|s| s.height < cam.z && s.under(cam + ray * ((s.height - cam.z) / ray.z)))
            .map(|s| s.height)
            .max_by(f32::total_cmp)
    }

    /// The points of a flat object's box-only detection on the table top under it (see the
    /// module doc); `out` is cleared first. Returns the number of points (0: not a flat class,
    /// no mapped table under the box, or the box is not on a free table region).
    pub(super) fn flat_points(
        &self,
        frame: &DepthFrame,
        camera: &Camera,
        pose: &Affine3A,
        det: &Detection,
        out: &mut Vec<Vec3>,
    ) -> usize {
        out.clear();
        let f = &self.cfg.flat;
        if !self.cfg.extensions.flat_objects || !is_flat(det.class_id, f.max_height) {
            return 0;
        }
        let cam: Vec3 = pose.translation.into();
        let thickness = size_prior(det.class_id).size[2];
        let [x0, y0, x1, y1] = det.bbox.map(f32::from);
        let (w, h) = (frame.width as usize, frame.height as usize);
        let (x1, y1) = (x1.min(w as f32), y1.min(h as f32));
        if x1 <= x0 || y1 <= y0 {
            return 0;
        }
        // The table under the box's centre.
        let world_ray = |u: f32, v: f32| pose.transform_vector3(camera.ray(u, v));
        let centre = world_ray(0.5 * (x0 + x1), 0.5 * (y0 + y1));
        let Some(plane) = self.plane_hit_by(cam, centre) else {
            return 0;
        };
        let top = plane + thickness;
        let area = (x1 - x0) * (y1 - y0);
        let step = (area / f.max_samples.max(1) as f32).sqrt().max(1.0);
        let depth = frame.pixels();
        let (mut samples, mut on) = (0u32, 0u32);
        let mut v = y0 + 0.5 * step;
        while v < y1 {
            let mut u = x0 + 0.5 * step;
            while u < x1 {
                let (pu, pv) = ((u as usize).min(w - 1), (v as usize).min(h - 1));
                let d = world_ray(u, v);
                u += step;
                if d.z >= 0.0 {
                    continue;
                }
                samples += 1;
                // Hit times along the z = 1 ray are camera depths.
                let (t_top, t_plane) = ((top - cam.z) / d.z, (plane - cam.z) / d.z);
                let p = cam + d * t_top;
                if !self
                    .supports
                    .iter()
                    .any(|s| s.height == plane && s.under(p))
                {
                    continue;
                }
                let raw = depth[pv * w + pu];
                if raw != 0 {
                    let z = raw as f32 * 1e-3;
                    if z < t_top - f.stand_tolerance || z > t_plane + f.stand_tolerance {
                        continue;
                    }
                }
                on += 1;
                out.push(p);
            }
            v += step;
        }
        if samples == 0 || (on as f32) < f.min_on_plane * samples as f32 {
            out.clear();
        }
        out.len()
    }
}
