//! Per rendered frame, how much of each ground-truth foreground object in view the frame shows
//! ([`FrameVisibility`], ground truth for evaluation): the input of the non-occlusion metric
//! (`eval::occlusion`, where the metric and its averaging are defined).
//!
//! An object **is in view** of a frame when all of these hold:
//! - it is a foreground object of the scene (background objects are the supports, not what is
//!   mapped);
//! - its centre lies in front of the camera at a depth of at most `camera.max_range` (the depth
//!   sensor's range);
//! - no point of its outline is behind or at the camera (`z < 0.05 m`; then its silhouette is
//!   not defined);
//! - its unoccluded silhouette, clipped to the image, covers at least the detector's
//!   `min_pixels` (scaled to the image size as the detector scales it): an object the detector
//!   could not detect even unoccluded is not in view.
//!
//! For such an object the record holds `visible_px`, the pixels of the TRUE instance render
//! showing it (counted by the detector's run-length pass, no extra image pass), and
//! `silhouette_px`, the pixels whose centre lies inside its unoccluded silhouette clipped to the
//! image: the convex hull of its projected outline (a box's 8 corners, which is its exact
//! silhouette; a cylinder's two rim 16-gons of the disc's area), counted by scanline, one span
//! per image row it covers. Everything in the render occludes: other objects, background
//! objects (tables, chairs, shelves) and walls. The part cut by the image border is in neither
//! count (`truncated` says it was cut): truncation is not occlusion.
//!
//! Work per frame: for each foreground object, ≤ 32 point projections and a hull of ≤ 32
//! points; for each object in view, one span per covered image row (≤ 8–32 edge tests each).

use super::detector::{RIM_EQUAL_AREA, Silhouettes};
use super::scene::Scene;
use geom::Camera;
use glam::{Affine3A, Vec3};
use shm_types::{FrameVisibility, MAX_OBJECTS, ObjectVisibility};

/// Image area the detector's pixel counts refer to (640×480).
const REF_PIXELS: f32 = 640.0 * 480.0;

/// Builds a frame's [`FrameVisibility`] from the detector's visible-pixel counts.
#[derive(Debug, Clone)]
pub(super) struct VisibilityModel {
    silhouettes: Silhouettes,
    /// Scene indices and centres of the foreground objects.
    foreground: Vec<(usize, Vec3)>,
    /// `detector.min_pixels` at 640×480.
    min_pixels: u32,
}

impl VisibilityModel {
    /// The model of `scene`'s foreground objects; `min_pixels` is `detector.min_pixels`.
    pub(super) fn new(scene: &Scene, min_pixels: u32) -> Self {
        Self {
            silhouettes: Silhouettes::new(scene, RIM_EQUAL_AREA),
            foreground: scene
                .foreground()
                .map(|i| (i, scene.objects[i].center))
                .collect(),
            min_pixels,
        }
    }

    /// Fill `out`'s `count` and `items` for a frame rendered by `camera` from
    /// `world_from_camera` (true pose), `visible[k]` being scene object `k`'s visible pixels.
    /// Headers are the caller's. No allocation.
    pub(super) fn fill(
        &self,
        camera: &Camera,
        world_from_camera: &Affine3A,
        visible: &[u32],
        out: &mut FrameVisibility,
    ) {
        let cam_from_world = world_from_camera.inverse();
        let scale = (camera.width * camera.height) as f32 / REF_PIXELS;
        let min_px = ((self.min_pixels as f32 * scale).round() as u32).max(1);
        let mut n = 0;
        for &(k, center) in &self.foreground {
            let z = cam_from_world.transform_point3(center).z;
            if !(z > 0.0 && z <= camera.k.max_range) || n == MAX_OBJECTS {
                continue;
            }
            let Some((silhouette_px, truncated, bbox)) =
                self.silhouettes.pixels(k, camera, &cam_from_world)
            else {
                continue;
            };
            if silhouette_px < min_px {
                continue;
            }
            out.items[n] = ObjectVisibility {
                object: k as u32,
                visible_px: visible.get(k).copied().unwrap_or(0),
                silhouette_px,
                truncated: u8::from(truncated),
                reserved: [0; 3],
                bbox,
            };
            n += 1;
        }
        out.items[n..].fill(ObjectVisibility::default());
        out.count = n as u32;
        out.reserved = 0;
    }
}
