//! Each term of the view-evaluation function F(v) (paper eqs. 1, 3, 4, 12, 21, 22, 23) as a small
//! pure function, so that each can be checked against hand-computed values.
//!
//! Conventions:
//! - A candidate view is a camera pose `world_from_camera` (optical frame, z forward); [`View`]
//!   caches its inverse, position and optical axis.
//! - "Line of sight" (LoS) vectors of the camera point from the camera to the target.
//! - `l_best` of an object (eq. 11, `MapObject::l_best`) points from the object centre toward its
//!   high-entropy (unobserved) side. A view observes that side when the camera stands on it, i.e.
//!   when the camera's LoS to the object is −l_best. We therefore compute
//!   `cos θ_sopm = cos ∠(l_best, camera − object)`, which is 1 when the view faces the unobserved
//!   side squarely and −1 when it looks at the well-observed side.

use geom::{Camera, Cuboid};
use glam::{Affine3A, Vec3};

/// A candidate view with its cached inverse.
#[derive(Debug, Clone, Copy)]
pub struct View {
    /// `world_from_camera`.
    pub world_from_camera: Affine3A,
    /// `camera_from_world`.
    pub cam_from_world: Affine3A,
    /// Optical centre, world frame.
    pub position: Vec3,
    /// Unit optical axis (camera +z), world frame.
    pub axis: Vec3,
}

impl View {
    /// A view from its `world_from_camera` pose.
    pub fn new(world_from_camera: Affine3A) -> Self {
        Self {
            world_from_camera,
            cam_from_world: world_from_camera.inverse(),
            position: world_from_camera.translation.into(),
            axis: Vec3::from(world_from_camera.matrix3.z_axis).normalize_or_zero(),
        }
    }

    /// Whether a world point is inside the frustum (image bounds) and the sensing range.
    pub fn sees(&self, camera: &Camera, p: Vec3) -> bool {
        camera.sees(self.cam_from_world.transform_point3(p))
    }

    /// Depth (camera z) of a world point.
    pub fn depth(&self, p: Vec3) -> f32 {
        self.cam_from_world.transform_point3(p).z
    }

    /// Image box of a cuboid (see [`Cuboid::image_box`]), computed with the cached inverse.
    pub fn image_box(&self, camera: &Camera, cuboid: &Cuboid) -> Option<[f32; 4]> {
        cuboid.image_box_in(camera, &self.cam_from_world)
    }
}

/// Area of a box `[x0, y0, x1, y1]` (0 if inverted).
pub fn box_area(b: &[f32; 4]) -> f32 {
    (b[2] - b[0]).max(0.0) * (b[3] - b[1]).max(0.0)
}

/// Area of the intersection of two boxes.
pub fn box_intersection(a: &[f32; 4], b: &[f32; 4]) -> f32 {
    box_area(&[
        a[0].max(b[0]),
        a[1].max(b[1]),
        a[2].min(b[2]),
        a[3].min(b[3]),
    ])
}

/// Non-occlusion H_IoU (eq. 21): `1 − Σ_j |b_i ∩ b_j| / |b_i|` over the occluders' boxes,
/// clamped at 0 (the sum can exceed 1 when several occluders overlap `b_i`).
pub fn h_iou<'a>(b_i: &[f32; 4], occluders: impl IntoIterator<Item = &'a [f32; 4]>) -> f32 {
    let area = box_area(b_i);
    if area <= 0.0 {
        return 0.0;
    }
    let covered: f32 = occluders
        .into_iter()
        .map(|b_j| box_intersection(b_i, b_j) / area)
        .sum();
    (1.0 - covered).max(0.0)
}

/// cos θ_sopm (eq. 12) with the sign convention of the module docs: the cosine of the angle
/// between `l_best` and `camera − object`. For a cylindrical SOPM (ground robots: the map's
/// columns are viewing directions about +z) both vectors are projected on the horizontal plane.
/// An undefined `l_best` (zero: uniform entropy, e.g. a never- or fully-observed object) or a
/// camera at the object's centre gives 1: every view is equally good.
pub fn cos_theta_sopm(l_best: Vec3, object_center: Vec3, camera: Vec3, cylinder: bool) -> f32 {
    let mut a = l_best;
    let mut b = camera - object_center;
    if cylinder {
        a.z = 0.0;
        b.z = 0.0;
    }
    cos_between(a, b).unwrap_or(1.0)
}

/// Cosine of the angle between two vectors, `None` if either is (nearly) zero.
pub fn cos_between(a: Vec3, b: Vec3) -> Option<f32> {
    let n = a.length() * b.length();
    (n > 1e-9).then(|| (a.dot(b) / n).clamp(-1.0, 1.0))
}

/// Whether a sample point is co-visible from the view (section 5.1): inside the frustum, within
/// the sensing range (depth along the optical axis in `[min_range, max_range]`), and seen at a
/// co-visibility angle θ_cp < θ_thresh from its old mean LoS `los` (camera → point, as stored in
/// `MapObject::point_los`). "Inside the tracked cluster" is the caller's filter. A point with an
/// undefined (zero) mean LoS is not co-visible.
pub fn is_covisible(camera: &Camera, view: &View, p: Vec3, los: Vec3, cos_thresh: f32) -> bool {
    if !view.sees(camera, p) {
        return false;
    }
    match cos_between(p - view.position, los) {
        Some(c) => c > cos_thresh,
        None => false,
    }
}

/// Co-visibility proportion N_cp (eq. 22): `min(n_cp / ε_cp, 1)`; with `clamp = false` the raw
/// ratio (as Table 3 of the paper was computed).
pub fn n_cp(count: usize, eps_cp: f32, clamp: bool) -> f32 {
    let r = count as f32 / eps_cp;
    if clamp { r.min(1.0) } else { r }
}

/// cos θ_c (eq. 23): the angle between the view's optical axis and the LoS from the camera to
/// the centroid of the cluster's unfinished objects; 1 if the camera is at the centroid.
pub fn cos_theta_c(view: &View, centroid: Vec3) -> f32 {
    cos_between(centroid - view.position, view.axis).unwrap_or(1.0)
}

/// One object's summand of f_a (eq. 3): `(H_sopm + H_IoU) · cos θ_sopm · C_asso`.
pub fn f_a_object(h_sopm: f32, h_iou: f32, cos_theta_sopm: f32, c_asso: f32) -> f32 {
    (h_sopm + h_iou) * cos_theta_sopm * c_asso
}

/// Observation continuity f_c (eq. 4): `N_cp · cos θ_c`.
pub fn f_c(n_cp: f32, cos_theta_c: f32) -> f32 {
    n_cp * cos_theta_c
}

/// F(v) (eq. 1): `α f_a + β f_c`.
pub fn value(alpha: f32, beta: f32, f_a: f32, f_c: f32) -> f32 {
    alpha * f_a + beta * f_c
}

#[cfg(test)]
mod tests {
    use super::*;
    use geom::optical_rotation;

    fn close(a: f32, b: f32, tol: f32) -> bool {
        (a - b).abs() <= tol
    }

    #[test]
    fn h_iou_of_two_overlapping_boxes() {
        // b_i = 100 × 100 px; b_j overlaps a 50 × 40 corner: 1 − 2000 / 10000 = 0.8.
        let bi = [0.0, 0.0, 100.0, 100.0];
        let bj = [50.0, 60.0, 150.0, 200.0];
        assert!(close(h_iou(&bi, [&bj]), 0.8, 1e-6));
        // From b_j's side: b_j = 100 × 140 = 14000, overlap 2000 → 1 − 1/7.
        assert!(close(h_iou(&bj, [&bi]), 1.0 - 2000.0 / 14000.0, 1e-6));
        // Fully covered twice: clamped at 0, not −1.
        assert_eq!(h_iou(&bi, [&bi, &bi]), 0.0);
        assert_eq!(h_iou(&bi, std::iter::empty()), 1.0);
    }

    #[test]
    fn theta_sopm_faces_the_unobserved_side() {
        let obj = Vec3::new(2.0, 0.0, 0.8);
        let l_best = Vec3::new(-1.0, 0.0, 0.0); // unobserved side faces −x
        let cam_on_that_side = Vec3::new(0.5, 0.0, 1.4);
        assert!(close(
            cos_theta_sopm(l_best, obj, cam_on_that_side, true),
            1.0,
            1e-6
        ));
        let behind = Vec3::new(3.5, 0.0, 1.4);
        assert!(close(cos_theta_sopm(l_best, obj, behind, true), -1.0, 1e-6));
        let side = Vec3::new(2.0, 1.5, 1.4);
        assert!(close(cos_theta_sopm(l_best, obj, side, true), 0.0, 1e-6));
        // 3D (sphere): elevation of the camera counts: the vector (-1.5, 0, 0.6).
        let c3 = cos_theta_sopm(l_best, obj, cam_on_that_side, false);
        assert!(close(c3, 1.5 / (1.5f32 * 1.5 + 0.36).sqrt(), 1e-5));
        assert_eq!(cos_theta_sopm(Vec3::ZERO, obj, behind, true), 1.0);
    }

    #[test]
    fn n_cp_saturates_at_eps_cp() {
        assert!(close(n_cp(50, 100.0, true), 0.5, 1e-6));
        assert_eq!(n_cp(100, 100.0, true), 1.0);
        assert_eq!(n_cp(250, 100.0, true), 1.0);
        assert!(close(n_cp(250, 100.0, false), 2.5, 1e-6));
    }

    #[test]
    fn theta_c_is_zero_when_looking_at_the_centroid() {
        let pose = Affine3A::from_mat3_translation(optical_rotation(0.3, 0.4), Vec3::ZERO);
        let v = View::new(pose);
        assert!(close(cos_theta_c(&v, v.axis * 2.5), 1.0, 1e-6));
        assert!(close(cos_theta_c(&v, -v.axis * 2.5), -1.0, 1e-6));
    }

    #[test]
    fn covisibility_needs_frustum_range_and_angle() {
        let cam = Camera::from_fov(640, 480, 60.0, 46.8, 0.5, 5.0);
        let v = View::new(Affine3A::from_mat3_translation(
            optical_rotation(0.0, 0.0),
            Vec3::ZERO,
        ));
        let p = Vec3::new(2.0, 0.0, 0.0);
        let cos30 = 30f32.to_radians().cos();
        assert!(is_covisible(&cam, &v, p, Vec3::X, cos30));
        // Old LoS 45° away: over θ_thresh = 30°.
        let los45 = Vec3::new(1.0, 1.0, 0.0).normalize();
        assert!(!is_covisible(&cam, &v, p, los45, cos30));
        assert!(!is_covisible(
            &cam,
            &v,
            Vec3::new(6.0, 0.0, 0.0),
            Vec3::X,
            cos30
        ));
        assert!(!is_covisible(
            &cam,
            &v,
            Vec3::new(2.0, 3.0, 0.0),
            Vec3::X,
            cos30
        ));
        assert!(!is_covisible(&cam, &v, p, Vec3::ZERO, cos30));
    }

    /// Table 3 of the paper (LBV candidates). Reading used here: the row labelled θ_c lists
    /// cos θ_c (e.g. 0.073 · 0.111 = 0.008, while cos(0.111 rad) would give 0.073), and the N_cp
    /// row was made without eq. (22)'s clamp (1.383 > 1). Taking both rows as given,
    /// f_c = N_cp · cos θ_c reproduces the listed evaluation values to 3 decimals, and with
    /// α = 0, β = 1 candidate 5 is the LBV.
    #[test]
    fn table_3_arithmetic() {
        let n_cp = [0.0, 0.073, 0.637, 0.9, 1.383, 0.773, 0.133];
        let cos_c = [-0.494, 0.111, 0.413, 0.674, 0.979, 0.994, 0.739];
        let listed = [0.0, 0.008, 0.263, 0.607, 1.354, 0.768, 0.098];
        let values: Vec<f32> = n_cp
            .iter()
            .zip(&cos_c)
            .map(|(n, c)| value(0.0, 1.0, 0.0, f_c(*n, *c)))
            .collect();
        for (v, l) in values.iter().zip(&listed) {
            assert!(close(*v, *l, 0.0005 + 1e-6), "{v} vs {l}");
        }
        let best = values
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.total_cmp(b.1))
            .map(|(i, _)| i + 1);
        assert_eq!(best, Some(5));
    }

    #[test]
    fn f_a_summand_and_value() {
        assert!(close(f_a_object(0.8, 0.5, 0.5, 0.9), 1.3 * 0.5 * 0.9, 1e-6));
        assert!(close(value(1.0, 0.2, 2.0, 0.5), 2.1, 1e-6));
    }
}
