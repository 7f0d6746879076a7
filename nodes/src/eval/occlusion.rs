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
}

impl NonOcclusion {
    /// Add one rendered frame's visibility record.
    pub fn observe(&mut self, frame: &FrameVisibility) {
        self.frames += 1;
        let before = self.samples;
        for v in frame.items() {
            if let Some(x) = object_non_occlusion(v) {
                self.sum += x;
                self.samples += 1;
            }
        }
        self.frames_with_objects += u64::from(self.samples > before);
    }

    /// Mean over (frame, object) pairs; `None` if no frame had an object in view.
    pub fn mean(&self) -> Option<f64> {
        (self.samples > 0).then(|| self.sum / self.samples as f64)
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
}
