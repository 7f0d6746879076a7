//! Points of one detection: masked valid depth pixels (box-only detections: every pixel of the
//! box) back-projected to the world with the frame's (estimated) camera pose, then cleaned of
//! the mask's bleed onto the background.
//!
//! Cleaning, in order:
//! 1. depth outside the camera's valid range is rejected;
//! 2. points within `floor_margin` of the floor (z = 0) are rejected;
//! 3. for foreground objects, points on a known supporting plane (a background object's top
//!    surface, within `support_margin` of its height and inside its footprint) are rejected — the
//!    mask bleeds onto the table around an object;
//! 4. isolation: the sampled pixels form a grid; 4-neighbours are connected when their depths
//!    differ by at most `max(gap_min, gap_factor · z · stride / f)` (the depth step a surface
//!    inclined up to ~75° produces between neighbouring samples), and only the largest connected
//!    component is kept. Bleed onto a wall or an object behind lies across a depth jump, so it
//!    forms its own component. Working in the image (not in 3D voxels) keeps far, grazing surfaces
//!    such as a table top connected whatever the sampling stride.
//!
//! Box-only detections ([`shm_types::mask_mode::BOXES`]) take every pixel of the box; with
//! `[mapper.extensions] box_segmentation` the object is then segmented out of the box
//! ([`super::segment`]): supporting planes and what lies under them removed, the depth cluster
//! that fits the box and the class size prior chosen, outliers rejected.

use super::cuboid::Box3;
use geom::Camera;
use glam::{Affine3A, Vec3};
use shm_types::{DepthFrame, Detection};

/// Box-only detections of foreground objects: points down to this far (m) under a known
/// supporting plane, inside its footprint, are the support's own (apron, front face, legs).
const UNDER_SUPPORT: f32 = 0.3;

/// Parameters of the extraction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ExtractParams {
    /// Minimum pixel stride (1 = every pixel).
    pub stride: usize,
    /// The stride grows so that at most about this many pixels are sampled per detection.
    pub max_points: usize,
    /// Points lower than this above the floor are dropped, metres.
    pub floor_margin: f32,
    /// Half-thickness of a supporting plane, metres.
    pub support_margin: f32,
    /// Smallest depth step that still connects neighbouring samples, metres.
    pub gap_min: f32,
    /// Depth-step allowance in units of the lateral sample spacing (`z · stride / f`).
    pub gap_factor: f32,
    /// Box-only detections: every pixel of the box is a candidate (the label image is unused).
    pub boxes: bool,
    /// With `boxes`: segment the object out of the box (else the largest depth cluster).
    pub segment: Option<super::config::SegmentationConfig>,
}

/// A background object's supporting plane (top surface).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SupportPlane {
    /// Height of the plane, metres.
    pub height: f32,
    /// Footprint (the background object's cuboid).
    pub footprint: Box3,
}

impl SupportPlane {
    fn holds(&self, p: Vec3, margin: f32) -> bool {
        (p.z - self.height).abs() <= margin && self.under(p)
    }

    /// `p` lies on the plane or in the band of `depth` metres under it (the table's apron, front
    /// face and legs), inside the footprint.
    fn holds_or_under(&self, p: Vec3, margin: f32, depth: f32) -> bool {
        p.z - self.height <= margin && self.height - p.z <= depth && self.under(p)
    }

    /// Whether the footprint (grown by 2 cm) lies under `p` (x, y only).
    pub fn under(&self, p: Vec3) -> bool {
        let (s, c) = self.footprint.yaw.sin_cos();
        let d = p - self.footprint.center;
        let lx = c * d.x + s * d.y;
        let ly = -s * d.x + c * d.y;
        lx.abs() <= self.footprint.size.x * 0.5 + 0.02
            && ly.abs() <= self.footprint.size.y * 0.5 + 0.02
    }
}

/// A foreground object whose bottom lies just above a supporting plane under it (within the band
/// that bleed removal cut away) rests on that plane: extend its cuboid down to the plane.
pub fn rest_on_support(b: &mut Box3, supports: &[SupportPlane], margin: f32) {
    let bottom = b.center.z - b.size.z * 0.5;
    let top = bottom + b.size.z;
    let plane = supports
        .iter()
        .filter(|s| s.under(b.center))
        .map(|s| s.height)
        .find(|h| bottom - h >= -margin && bottom - h <= 2.0 * margin);
    if let Some(h) = plane {
        b.size.z = top - h;
        b.center.z = (top + h) * 0.5;
    }
}

/// Reusable buffers of the extraction.
#[derive(Debug, Clone, Default)]
pub struct PointScratch {
    /// Per grid sample: index into `raw` or `u32::MAX`.
    pub(super) grid: Vec<u32>,
    pub(super) raw: Vec<Vec3>,
    pub(super) depth: Vec<f32>,
    /// Grid index of each raw point.
    pub(super) cell: Vec<u32>,
    pub(super) parent: Vec<u32>,
    pub(super) weight: Vec<u32>,
}

pub(super) fn find(parent: &mut [u32], mut i: u32) -> u32 {
    while parent[i as usize] != i {
        let p = parent[i as usize];
        parent[i as usize] = parent[p as usize];
        i = p;
    }
    i
}

impl PointScratch {
    /// Extract and clean the points of `det` into `out` (cleared first). Returns the number of
    /// points kept.
    #[allow(clippy::too_many_arguments)]
    pub fn extract(
        &mut self,
        frame: &DepthFrame,
        labels: &[u8],
        camera: &Camera,
        world_from_camera: &Affine3A,
        det: &Detection,
        foreground: bool,
        supports: &[SupportPlane],
        params: &ExtractParams,
        out: &mut Vec<Vec3>,
    ) -> usize {
        out.clear();
        self.raw.clear();
        self.depth.clear();
        self.cell.clear();
        let (w, h) = (frame.width as usize, frame.height as usize);
        let depth = frame.pixels();
        if depth.len() < w * h
            || (!params.boxes && (labels.len() < w * h || det.label == 0 || det.label > 255))
        {
            return 0;
        }
        let label = det.label as u8;
        let [x0, y0, x1, y1] = det.bbox.map(|v| v as usize);
        let (x1, y1) = (x1.min(w), y1.min(h));
        let area = if det.mask_pixels > 0 && !params.boxes {
            det.mask_pixels as usize
        } else {
            (x1.saturating_sub(x0)) * (y1.saturating_sub(y0))
        };
        let mut stride = params.stride.max(1);
        while area / (stride * stride) > params.max_points.max(1) {
            stride += 1;
        }
        let (min_z, max_z) = (camera.k.min_range, camera.k.max_range);
        let gw = x1.saturating_sub(x0).div_ceil(stride);
        let gh = y1.saturating_sub(y0).div_ceil(stride);
        self.grid.clear();
        self.grid.resize(gw * gh, u32::MAX);
        for (gy, v) in (y0..y1).step_by(stride).enumerate() {
            let row = v * w;
            for (gx, u) in (x0..x1).step_by(stride).enumerate() {
                if !params.boxes && labels[row + u] != label {
                    continue;
                }
                let d = depth[row + u];
                if d == 0 {
                    continue;
                }
                let z = d as f32 * 1e-3;
                if z < min_z || z > max_z {
                    continue;
                }
                let p = world_from_camera.transform_point3(camera.unproject(
                    u as f32 + 0.5,
                    v as f32 + 0.5,
                    z,
                ));
                if p.z < params.floor_margin {
                    continue;
                }
                if foreground
                    && supports.iter().any(|s| {
                        if params.boxes {
                            s.holds_or_under(p, params.support_margin, UNDER_SUPPORT)
                        } else {
                            s.holds(p, params.support_margin)
                        }
                    })
                {
                    continue;
                }
                self.grid[gy * gw + gx] = self.raw.len() as u32;
                self.cell.push((gy * gw + gx) as u32);
                self.raw.push(p);
                self.depth.push(z);
            }
        }
        let spacing = stride as f32 / camera.k.fx.min(camera.k.fy);
        let gap_per_m = params.gap_factor * spacing;
        match (&params.segment, params.boxes) {
            (Some(seg), true) => {
                let prior = super::priors::size_prior(det.class_id);
                let geo = super::segment::Grid { gw, gh };
                self.segment_box(
                    geo,
                    &prior,
                    foreground,
                    seg,
                    params.gap_min,
                    gap_per_m,
                    spacing,
                    out,
                );
            }
            _ => self.largest_component(gw, gh, params.gap_min, gap_per_m, out),
        }
        out.len()
    }

    /// Union the depth-continuous 4-neighbours of the sample grid (`gw × gh`): afterwards
    /// `find(parent, i)` is the component of raw point `i` (points not in the grid stay alone).
    pub(super) fn connect(&mut self, gw: usize, gh: usize, gap_min: f32, gap_per_m: f32) {
        let n = self.raw.len();
        self.parent.clear();
        self.parent.extend(0..n as u32);
        for gy in 0..gh {
            for gx in 0..gw {
                let a = self.grid[gy * gw + gx];
                if a == u32::MAX {
                    continue;
                }
                for (nx, ny) in [(gx + 1, gy), (gx, gy + 1)] {
                    if nx >= gw || ny >= gh {
                        continue;
                    }
                    let b = self.grid[ny * gw + nx];
                    if b == u32::MAX {
                        continue;
                    }
                    let (za, zb) = (self.depth[a as usize], self.depth[b as usize]);
                    if (za - zb).abs() <= gap_min.max(gap_per_m * za.max(zb)) {
                        let (ra, rb) = (find(&mut self.parent, a), find(&mut self.parent, b));
                        if ra != rb {
                            self.parent[ra.max(rb) as usize] = ra.min(rb);
                        }
                    }
                }
            }
        }
    }

    /// Keep the largest depth-continuous component of the sample grid (`gw × gh`) in `out`.
    fn largest_component(
        &mut self,
        gw: usize,
        gh: usize,
        gap_min: f32,
        gap_per_m: f32,
        out: &mut Vec<Vec3>,
    ) {
        out.clear();
        if self.raw.is_empty() {
            return;
        }
        let n = self.raw.len();
        self.connect(gw, gh, gap_min, gap_per_m);
        self.weight.clear();
        self.weight.resize(n, 0);
        for i in 0..n as u32 {
            let r = find(&mut self.parent, i);
            self.weight[r as usize] += 1;
        }
        let best = self
            .weight
            .iter()
            .enumerate()
            .max_by_key(|(i, c)| (**c, std::cmp::Reverse(*i)))
            .map(|(i, _)| i as u32)
            .unwrap_or(0);
        for i in 0..n {
            if find(&mut self.parent, i as u32) == best {
                out.push(self.raw[i]);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn largest_component_splits_at_depth_jumps() {
        // A 10 × 1 sample row: 7 samples on a surface at 1.5 m, then 3 bleed samples at 2.5 m.
        let mut s = PointScratch::default();
        for i in 0..10 {
            let z = if i < 7 { 1.5 + i as f32 * 0.004 } else { 2.5 };
            s.grid.push(i);
            s.raw.push(Vec3::new(i as f32, 0.0, z));
            s.depth.push(z);
        }
        let mut out = Vec::new();
        s.largest_component(10, 1, 0.03, 0.0, &mut out);
        assert_eq!(out.len(), 7);
        assert!(out.iter().all(|p| p.z < 2.0));
        // A generous allowance joins them.
        s.largest_component(10, 1, 2.0, 0.0, &mut out);
        assert_eq!(out.len(), 10);
    }

    #[test]
    fn support_plane_membership() {
        let s = SupportPlane {
            height: 0.75,
            footprint: Box3 {
                center: Vec3::new(0.0, 0.0, 0.375),
                size: Vec3::new(1.0, 0.5, 0.75),
                yaw: std::f32::consts::FRAC_PI_2,
            },
        };
        assert!(s.holds(Vec3::new(0.2, 0.45, 0.755), 0.015));
        assert!(!s.holds(Vec3::new(0.45, 0.2, 0.755), 0.015));
        assert!(!s.holds(Vec3::new(0.0, 0.0, 0.80), 0.015));
    }
}
