//! Non-occlusion (the paper's Table 2), measured on ground-truth geometry: how much of each
//! foreground object the frames the robot took actually showed.
//!
//! **Definition.** For every rendered frame (every view at which a frame was taken and handed
//! to the mapper, while driving or turning the neck, whichever the planner: GBV and LBV views
//! alike) and every ground-truth foreground object in that frame's view (in front of the
//! camera within `camera.max_range`, its unoccluded silhouette covering at least the detector's
//! `min_pixels`; see `sim/visibility.rs`):
//!
//! `non_occlusion(object, frame) = min(1, visible_px / silhouette_px)`
//!
//! where `visible_px` are the pixels of the true instance render showing the object and
//! `silhouette_px` the pixels its unoccluded silhouette covers, both clipped to the image. It is
//! the physically visible fraction: 1 for an object nothing hides, 0 for one hidden entirely
//! behind other objects, background objects (tables, shelves) or walls. The part of an object
//! cut off by the image border counts in neither (truncation is not occlusion). The session's
//! **non-occlusion** is the mean over all (frame, object) pairs; frames with no object in view
//! do not enter it (undefined, JSON null, if no frame had one).
//!
//! Eq. 21's `H_IoU = 1 − Σ_j |b_i ∩ b_j| / |b_i|` measures the same thing on projected boxes of
//! the planner's estimated cuboids, which is what the planner can compute; with true geometry
//! the visible fraction replaces the box-overlap estimate (boxes overlap where silhouettes do
//! not, and eq. 21 ignores occluders that are not foreground objects). The planner's own H_IoU
//! of its chosen views is reported apart (`planner_h_iou*` in `metrics.json`).
//!
//! **Eq. 21 on true boxes** (`non_occlusion_eq21`, the paper's Table 2 definition: "the average
//! non-occlusion degree of the objects from all NBV perspectives according to (21)"), over the
//! same (frame, object) pairs: `b_i` is the bounding box of object `i`'s unoccluded silhouette
//! clipped to the image, the sum runs over every other foreground object in view (nearer or not,
//! as eq. 21 has it), and the value is clamped to [0, 1]. Boxes overlap where silhouettes do
//! not, and background objects and walls do not occlude in it, so it reads lower than the
//! visible fraction where objects crowd, and higher where a table hides them.
//!
//! The record is computed by the simulator during `Sim::render` (`Sim::visibility`) and reaches
//! the metric the same way in both hosts: the lockstep host feeds it per rendered frame, the
//! deployment host's sim node publishes it on `sim/visibility` and the launcher feeds it.

use serde::{Deserialize, Serialize};
use shm_types::{FrameVisibility, ObjectVisibility};

/// Non-occlusion of one object in one frame: `min(1, visible / silhouette)`; `None` for an
/// empty silhouette (not in view).
pub fn object_non_occlusion(v: &ObjectVisibility) -> Option<f64> {
    (v.silhouette_px > 0).then(|| (f64::from(v.visible_px) / f64::from(v.silhouette_px)).min(1.0))
}

/// Accumulates the session's non-occlusion over frames.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct NonOcclusion {
    /// Sum of the per-(frame, object) values.
    pub sum: f64,
    /// (Frame, object) pairs.
    pub samples: u64,
    /// Frames observed (with or without an object in view).
    pub frames: u64,
    /// Frames with at least one object in view.
    pub frames_with_objects: u64,
    /// Sum of the per-(frame, object) eq. 21 values on true boxes.
    pub eq21_sum: f64,
}

/// Area of a box `[u0, v0, u1, v1]`.
fn area(b: &[f32; 4]) -> f64 {
    f64::from((b[2] - b[0]).max(0.0)) * f64::from((b[3] - b[1]).max(0.0))
}

/// Eq. 21 for item `i` of a frame: `1 − Σ_{j≠i} |b_i ∩ b_j| / |b_i|`, clamped to [0, 1];
/// `None` for an empty box.
pub fn eq21_non_occlusion(items: &[ObjectVisibility], i: usize) -> Option<f64> {
    let bi = &items[i].bbox;
    let a = area(bi);
    if a <= 0.0 {
        return None;
    }
    let overlap: f64 = items
        .iter()
        .enumerate()
        .filter(|&(j, _)| j != i)
        .map(|(_, o)| {
            let b = &o.bbox;
            area(&[
                bi[0].max(b[0]),
                bi[1].max(b[1]),
                bi[2].min(b[2]),
                bi[3].min(b[3]),
            ])
        })
        .sum();
    Some((1.0 - overlap / a).clamp(0.0, 1.0))
}

impl NonOcclusion {
    /// Add one rendered frame's visibility record.
    pub fn observe(&mut self, frame: &FrameVisibility) {
        self.frames += 1;
        let before = self.samples;
        let items = frame.items();
        for (i, v) in items.iter().enumerate() {
            if let Some(x) = object_non_occlusion(v) {
                self.sum += x;
                self.samples += 1;
                // A non-empty silhouette has a non-empty box; 1 if it had none.
                self.eq21_sum += eq21_non_occlusion(items, i).unwrap_or(1.0);
            }
        }
        self.frames_with_objects += u64::from(self.samples > before);
    }

    /// Mean over (frame, object) pairs; `None` if no frame had an object in view.
    pub fn mean(&self) -> Option<f64> {
        (self.samples > 0).then(|| self.sum / self.samples as f64)
    }

    /// Mean eq. 21 value on true boxes over the same pairs; `None` if no frame had an object.
    pub fn mean_eq21(&self) -> Option<f64> {
        (self.samples > 0).then(|| self.eq21_sum / self.samples as f64)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use shm_types::boxed_zeroed;

    fn item(visible_px: u32, silhouette_px: u32) -> ObjectVisibility {
        ObjectVisibility {
            visible_px,
            silhouette_px,
            ..Default::default()
        }
    }

    #[test]
    fn pooled_over_frame_object_pairs_and_clamped() {
        let mut f = boxed_zeroed::<FrameVisibility>();
        let mut acc = NonOcclusion::default();
        f.count = 2;
        f.items[0] = item(50, 100);
        f.items[1] = item(105, 100); // rasterization can exceed the silhouette by a few pixels
        acc.observe(&f);
        f.count = 1;
        f.items[0] = item(0, 40); // hidden entirely
        acc.observe(&f);
        f.count = 0;
        acc.observe(&f); // nothing in view: not averaged
        assert_eq!(
            (acc.samples, acc.frames, acc.frames_with_objects),
            (3, 3, 2)
        );
        assert!((acc.mean().unwrap() - 0.5).abs() < 1e-12);
        assert_eq!(NonOcclusion::default().mean(), None);
        assert_eq!(object_non_occlusion(&item(3, 0)), None);
    }

    #[test]
    fn eq21_sums_box_overlaps_with_every_other_object() {
        let boxed = |bbox| ObjectVisibility {
            visible_px: 1,
            silhouette_px: 1,
            bbox,
            ..Default::default()
        };
        // b0 = 10×10; b1 covers its right half, b2 its bottom-left quarter: 1 − (50 + 25)/100.
        let items = [
            boxed([0.0, 0.0, 10.0, 10.0]),
            boxed([5.0, 0.0, 20.0, 10.0]),
            boxed([0.0, 5.0, 5.0, 10.0]),
        ];
        assert!((eq21_non_occlusion(&items, 0).unwrap() - 0.25).abs() < 1e-12);
        // b2 (25 px) lies inside b0 entirely: clamped to 0, not negative.
        assert_eq!(eq21_non_occlusion(&items, 2), Some(0.0));
        // b1 (150 px) overlaps b0 by 50: 1 − 50/150.
        assert!((eq21_non_occlusion(&items, 1).unwrap() - 2.0 / 3.0).abs() < 1e-12);
        assert_eq!(eq21_non_occlusion(&[boxed([1.0, 1.0, 1.0, 5.0])], 0), None);
        let mut f = boxed_zeroed::<FrameVisibility>();
        f.count = 3;
        f.items[..3].copy_from_slice(&items);
        let mut acc = NonOcclusion::default();
        acc.observe(&f);
        let want = (0.25 + 2.0 / 3.0 + 0.0) / 3.0;
        assert!((acc.mean_eq21().unwrap() - want).abs() < 1e-12);
    }
}
