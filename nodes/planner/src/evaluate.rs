//! The view-evaluation function F(v) = α f_a(v) + β f_c(v) (paper eq. 1) over an [`ObjectMap`]
//! snapshot and one candidate camera pose. Pure, allocation-free (scratch lives on the stack).
//!
//! - f_a (eq. 3) sums over the foreground objects "in view" that are relevant to the view: objects
//!   whose centre lies in the candidate's frustum and sensing range (`Camera::sees` of the
//!   centre), which belong to the target cluster or lie within `fa_radius` of the camera
//!   ([`FaRelevance`]), and which are not hidden by other map objects or walls ([`sight`]:
//!   at least `fa_min_visible` of their sample points unhidden). The filter is a [`FaFilter`]
//!   (GBV: the configured one; [`evaluate_view`] and the baselines' scoring: none).
//! - H_IoU (eq. 21) projects every foreground object's cuboid that lies (partly) in front of the
//!   camera; the occluders of `fo_i` are all other such objects ([`Occluders::All`], the paper's
//!   sum) or only those whose centre is nearer ([`Occluders::Closer`]).
//! - f_c (eq. 4) counts co-visible sample points of the tracked cluster ([`Target`]).
//! - A term whose weight is 0 is not computed and reported as 0 in the [`Candidate`] (the LBV
//!   runs with α = 0, so it never projects cuboids). Ablation switches replace a multiplicative
//!   factor by 1 and an additive one by 0 (see [`AblationConfig`]).

use crate::clusters::cuboid;
use crate::config::{AblationConfig, FaRelevance, Occluders, PlannerConfig};
use crate::sight::{self, Walls};
use crate::terms::{self, View};
use geom::CameraConfig;
use geom::{Camera, CameraMount, yaw_pitch_of};
use glam::{Affine3A, Vec3};
use shm_types::{Candidate, MAX_OBJECTS, ObjectMap, sopm_shape};

/// Everything the evaluation needs besides the map and the pose.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EvalParams {
    /// Camera model.
    pub camera: Camera,
    /// Camera mount on the robot.
    pub mount: CameraMount,
    /// ε_sopm.
    pub eps_sopm: f32,
    /// ε_cp of eq. (22).
    pub eps_cp: f32,
    /// cos θ_thresh.
    pub cos_thresh: f32,
    /// Occluders in H_IoU.
    pub occluders: Occluders,
    /// Term switches.
    pub ablation: AblationConfig,
}

/// Which objects in the frustum f_a's sum runs over (`[planner] fa_*`). Kept apart from
/// [`EvalParams`], which the baselines' job results carry by value.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FaFilter {
    /// Which objects in the frustum f_a counts.
    pub relevance: FaRelevance,
    /// Radius of [`FaRelevance::Radius`], metres.
    pub radius: f32,
    /// Whether hidden objects are out of view ([`sight`]).
    pub occlusion: bool,
    /// Least unhidden fraction of an object's sample points.
    pub min_visible: f32,
    /// Slack of [`Walls::slack`], metres.
    pub wall_slack: f32,
}

impl FaFilter {
    /// Every foreground object whose centre is in the frustum, hidden or not (the sum as it was
    /// before the filter; the baselines' scoring of their chosen views keeps it).
    pub const FRUSTUM: FaFilter = FaFilter {
        relevance: FaRelevance::Frustum,
        radius: f32::INFINITY,
        occlusion: false,
        min_visible: 0.0,
        wall_slack: 0.0,
    };

    /// From the configuration.
    pub fn new(planner: &PlannerConfig) -> Self {
        Self {
            relevance: planner.fa_relevance,
            radius: planner.fa_radius,
            occlusion: planner.fa_occlusion,
            min_visible: planner.fa_min_visible,
            wall_slack: planner.fa_wall_slack,
        }
    }
}

impl EvalParams {
    /// From the configuration.
    pub fn new(planner: &PlannerConfig, camera: &CameraConfig) -> Self {
        Self {
            camera: camera.camera(),
            mount: camera.mount,
            eps_sopm: planner.eps_sopm,
            eps_cp: planner.eps_cp,
            cos_thresh: planner.theta_thresh_deg.to_radians().cos(),
            occluders: planner.occluders,
            ablation: planner.ablation,
        }
    }
}

/// Weights α, β of eq. (1).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Weights {
    /// α (f_a).
    pub alpha: f32,
    /// β (f_c).
    pub beta: f32,
}

/// The tracked cluster for f_c.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Target {
    /// Cluster id (background object id).
    pub cluster_id: i32,
    /// Centroid of the cluster's unfinished objects (θ_c).
    pub centroid: Vec3,
}

/// f_a (eq. 3) and its traced means.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct AbundanceTerms {
    /// f_a.
    pub f_a: f32,
    /// Σ H_sopm over objects in view.
    pub h_sopm_sum: f32,
    /// Mean H_IoU.
    pub h_iou_mean: f32,
    /// Mean cos θ_sopm.
    pub cos_theta_sopm_mean: f32,
    /// Mean C_asso.
    pub c_asso_mean: f32,
    /// Foreground objects in view.
    pub in_view: u16,
}

/// f_c (eq. 4) and its factors.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ContinuityTerms {
    /// f_c.
    pub f_c: f32,
    /// N_cp (1 if ablated).
    pub n_cp: f32,
    /// cos θ_c (1 if ablated).
    pub cos_theta_c: f32,
    /// Co-visible points n_cp.
    pub covisible: u32,
}

/// Whether foreground object `i` of the map counts in f_a of the view: centre in the frustum and
/// range, relevant ([`FaRelevance`]; `Cluster` without a target counts every object) and, with
/// occlusion on, not hidden.
pub fn in_view(
    map: &ObjectMap,
    i: usize,
    view: &View,
    target: Option<&Target>,
    walls: Option<&Walls<'_>>,
    fa: &FaFilter,
    p: &EvalParams,
) -> bool {
    let o = &map.objects()[i];
    let c = Vec3::from(o.center);
    if o.is_background() || !view.sees(&p.camera, c) {
        return false;
    }
    let relevant = match fa.relevance {
        FaRelevance::Frustum => true,
        FaRelevance::Cluster => target.is_none_or(|t| o.cluster_id == t.cluster_id),
        FaRelevance::Radius => c.distance(view.position) <= fa.radius,
    };
    relevant && (!fa.occlusion || sight::is_visible(map, i, view.position, walls, fa.min_visible))
}

/// Information abundance f_a (eq. 3) of a view over every foreground object in the frustum
/// ([`FaFilter::FRUSTUM`]; see [`abundance_for`]).
pub fn abundance(map: &ObjectMap, view: &View, p: &EvalParams) -> AbundanceTerms {
    abundance_for(map, view, None, None, &FaFilter::FRUSTUM, p)
}

/// Information abundance f_a (eq. 3) of a view: the sum runs over the objects [`in_view`] for
/// the target and walls given.
pub fn abundance_for(
    map: &ObjectMap,
    view: &View,
    target: Option<&Target>,
    walls: Option<&Walls<'_>>,
    fa: &FaFilter,
    p: &EvalParams,
) -> AbundanceTerms {
    let objs = map.objects();
    // Image boxes and depths of every foreground object in front of the camera.
    let mut boxes = [[0.0f32; 4]; MAX_OBJECTS];
    let mut depth = [0.0f32; MAX_OBJECTS];
    let mut has_box = [false; MAX_OBJECTS];
    let ab = p.ablation;
    if ab.h_iou {
        for (k, o) in objs.iter().enumerate() {
            if o.is_background() {
                continue;
            }
            if let Some(b) = view.image_box(&p.camera, &cuboid(o)) {
                boxes[k] = b;
                depth[k] = view.depth(Vec3::from(o.center));
                has_box[k] = true;
            }
        }
    }
    let mut t = AbundanceTerms::default();
    for (i, o) in objs.iter().enumerate() {
        let c = Vec3::from(o.center);
        if !in_view(map, i, view, target, walls, fa, p) {
            continue;
        }
        let h_sopm = if ab.h_sopm { o.h_sopm } else { 0.0 };
        let h_iou = if !ab.h_iou {
            0.0
        } else if has_box[i] {
            let occ = (0..objs.len())
                .filter(|&j| j != i && has_box[j])
                .filter(|&j| p.occluders == Occluders::All || depth[j] < depth[i])
                .map(|j| &boxes[j]);
            terms::h_iou(&boxes[i], occ)
        } else {
            0.0
        };
        let cos_s = if ab.theta_sopm {
            let cyl = o.sopm_shape == sopm_shape::CYLINDER;
            terms::cos_theta_sopm(Vec3::from(o.l_best), c, view.position, cyl)
        } else {
            1.0
        };
        let c_asso = if ab.c_asso { o.c_asso } else { 1.0 };
        t.f_a += terms::f_a_object(h_sopm, h_iou, cos_s, c_asso);
        t.h_sopm_sum += h_sopm;
        t.h_iou_mean += h_iou;
        t.cos_theta_sopm_mean += cos_s;
        t.c_asso_mean += c_asso;
        t.in_view += 1;
    }
    if t.in_view > 0 {
        let n = t.in_view as f32;
        t.h_iou_mean /= n;
        t.cos_theta_sopm_mean /= n;
        t.c_asso_mean /= n;
    }
    t
}

/// Observation continuity f_c (eq. 4) of a view for the tracked cluster; all zero without one.
pub fn continuity(
    map: &ObjectMap,
    view: &View,
    target: Option<&Target>,
    p: &EvalParams,
) -> ContinuityTerms {
    let Some(target) = target else {
        return ContinuityTerms::default();
    };
    let mut t = ContinuityTerms::default();
    if p.ablation.n_cp {
        for o in map
            .objects()
            .iter()
            .filter(|o| o.cluster_id == target.cluster_id)
        {
            for (pt, los) in o.samples() {
                let ok = terms::is_covisible(
                    &p.camera,
                    view,
                    Vec3::from(*pt),
                    Vec3::from(*los),
                    p.cos_thresh,
                );
                t.covisible += ok as u32;
            }
        }
        t.n_cp = terms::n_cp(t.covisible as usize, p.eps_cp, true);
    } else {
        t.n_cp = 1.0;
    }
    t.cos_theta_c = if p.ablation.theta_c {
        terms::cos_theta_c(view, target.centroid)
    } else {
        1.0
    };
    t.f_c = terms::f_c(t.n_cp, t.cos_theta_c);
    t
}

/// Evaluate one candidate camera pose: F(v) with every term, as a traced [`Candidate`], f_a
/// over every object in the frustum ([`FaFilter::FRUSTUM`]; [`evaluate_view_in`] filters).
pub fn evaluate_view(
    map: &ObjectMap,
    world_from_camera: &Affine3A,
    target: Option<&Target>,
    w: Weights,
    p: &EvalParams,
) -> Candidate {
    evaluate_view_in(
        map,
        world_from_camera,
        target,
        None,
        &FaFilter::FRUSTUM,
        w,
        p,
    )
}

/// [`evaluate_view`] with f_a's sum filtered by `fa` (relevance, occlusion by the map's cuboids
/// and `walls`).
pub fn evaluate_view_in(
    map: &ObjectMap,
    world_from_camera: &Affine3A,
    target: Option<&Target>,
    walls: Option<&Walls<'_>>,
    fa: &FaFilter,
    w: Weights,
    p: &EvalParams,
) -> Candidate {
    let view = View::new(*world_from_camera);
    let a = if w.alpha != 0.0 {
        abundance_for(map, &view, target, walls, fa, p)
    } else {
        AbundanceTerms::default()
    };
    let c = if w.beta != 0.0 {
        continuity(map, &view, target, p)
    } else {
        ContinuityTerms::default()
    };
    candidate(&view, &a, &c, w)
}

/// The traced candidate of a view from its terms.
pub fn candidate(view: &View, a: &AbundanceTerms, c: &ContinuityTerms, w: Weights) -> Candidate {
    let (yaw, pitch) = yaw_pitch_of(&view.world_from_camera);
    Candidate {
        position: view.position.to_array(),
        yaw,
        pitch,
        value: terms::value(w.alpha, w.beta, a.f_a, c.f_c),
        f_a: a.f_a,
        f_c: c.f_c,
        h_sopm: a.h_sopm_sum,
        h_iou: a.h_iou_mean,
        cos_theta_sopm: a.cos_theta_sopm_mean,
        c_asso: a.c_asso_mean,
        n_cp: c.n_cp,
        cos_theta_c: c.cos_theta_c,
        objects_in_view: a.in_view,
        chosen: 0,
        dropped: 0,
    }
}

/// What a baseline planner needs to evaluate the views it chooses with the same F(v) terms as
/// VP-SOM (so that per-NBV metrics such as non-occlusion compare like with like): a map snapshot
/// and the parameters. Jobs carry it so the evaluation runs off the real-time thread, and hand
/// it back for reuse.
#[derive(Debug)]
pub struct Scoring {
    /// Map snapshot of the round.
    pub map: Box<ObjectMap>,
    /// Evaluation parameters.
    pub params: EvalParams,
    /// α, β (the GBV's).
    pub weights: Weights,
}

impl Scoring {
    /// The candidate of the camera pose a base at `base` with the neck at `neck_yaw` (mount
    /// pitch) gives, flagged as chosen; f_c is computed for `target` (0 without one).
    pub fn chosen(&self, base: [f32; 3], neck_yaw: f32, target: Option<&Target>) -> Candidate {
        let m = self.params.mount;
        let pose = m.camera_pose(base, neck_yaw, m.pitch());
        let mut c = evaluate_view(&self.map, &pose, target, self.weights, &self.params);
        c.chosen = 1;
        c
    }
}

/// For views that share one camera position (the neck turns about a vertical axis through the
/// optical centre's column, so all LBV candidates of a base pose do): the offsets `p − camera`
/// of the tracked cluster's sample points that pass the co-visibility angle test from there
/// (the angle test depends on the position only). Appends to `out` without reallocating if
/// `out` has room for all the map's sample points.
pub fn covisible_offsets(
    map: &ObjectMap,
    target: &Target,
    camera: Vec3,
    cos_thresh: f32,
    out: &mut Vec<Vec3>,
) {
    for o in map
        .objects()
        .iter()
        .filter(|o| o.cluster_id == target.cluster_id)
    {
        for (pt, los) in o.samples() {
            let d = Vec3::from(*pt) - camera;
            if terms::cos_between(d, Vec3::from(*los)).is_some_and(|c| c > cos_thresh) {
                out.push(d);
            }
        }
    }
}

/// [`continuity`] for a view at the position `offsets` were computed from: only the frustum
/// and range tests remain per point.
pub fn continuity_from_offsets(
    view: &View,
    offsets: &[Vec3],
    target: Option<&Target>,
    p: &EvalParams,
) -> ContinuityTerms {
    let Some(target) = target else {
        return ContinuityTerms::default();
    };
    let mut t = ContinuityTerms::default();
    if p.ablation.n_cp {
        let r = view.cam_from_world.matrix3;
        t.covisible = offsets
            .iter()
            .filter(|d| p.camera.sees(Vec3::from(r * glam::Vec3A::from(**d))))
            .count() as u32;
        t.n_cp = terms::n_cp(t.covisible as usize, p.eps_cp, true);
    } else {
        t.n_cp = 1.0;
    }
    t.cos_theta_c = if p.ablation.theta_c {
        terms::cos_theta_c(view, target.centroid)
    } else {
        1.0
    };
    t.f_c = terms::f_c(t.n_cp, t.cos_theta_c);
    t
}

#[cfg(test)]
mod tests {
    use super::*;
    use geom::optical_rotation;
    use shm_types::boxed_zeroed;

    fn params() -> EvalParams {
        EvalParams::new(&PlannerConfig::default(), &CameraConfig::default())
    }

    fn fg(map: &mut ObjectMap, id: u32, c: [f32; 3], s: [f32; 3]) -> usize {
        let k = map.count as usize;
        let o = &mut map.objects[k];
        o.id = id;
        o.cluster_id = 0;
        o.center = c;
        o.size = s;
        o.h_sopm = 0.5;
        o.c_asso = 1.0;
        map.count += 1;
        k
    }

    fn level_view(x: f32, yaw: f32) -> Affine3A {
        Affine3A::from_mat3_translation(optical_rotation(yaw, 0.0), Vec3::new(x, 0.0, 0.0))
    }

    /// Two identical cubes on the optical axis, one behind the other: the far one's box lies
    /// inside the near one's, so with "all" occluders the far one is fully occluded (0) and the
    /// near one loses |b_far| / |b_near| = (d_near / d_far)² = (2 / 3)²; with "closer" the near
    /// one is free (1).
    #[test]
    fn h_iou_hand_computed_on_two_cubes() {
        let mut m = boxed_zeroed::<ObjectMap>();
        fg(&mut m, 1, [2.2, 0.0, 0.0], [0.4, 0.4, 0.4]);
        fg(&mut m, 2, [3.2, 0.0, 0.0], [0.4, 0.4, 0.4]);
        let mut p = params();
        p.ablation.theta_sopm = false;
        let v = View::new(level_view(0.0, 0.0));
        let t = abundance(&m, &v, &p);
        assert_eq!(t.in_view, 2);
        // Front faces at 2.0 and 3.0 m: pixel extents scale as 1/d; the box of a cube is its
        // front face (the back face projects inside it).
        let near = 1.0 - (2.0f32 / 3.0).powi(2);
        assert!((t.h_iou_mean - (near + 0.0) / 2.0).abs() < 1e-4, "{t:?}");
        // f_a = (0.5 + near) + (0.5 + 0).
        assert!((t.f_a - (1.0 + near)).abs() < 1e-4);
        p.occluders = Occluders::Closer;
        let t = abundance(&m, &v, &p);
        assert!((t.h_iou_mean - 0.5).abs() < 1e-4, "{t:?}");
        p.ablation.h_iou = false;
        p.ablation.h_sopm = false;
        assert_eq!(abundance(&m, &v, &p).f_a, 0.0);
    }

    #[test]
    fn only_objects_in_frustum_and_range_count() {
        let mut m = boxed_zeroed::<ObjectMap>();
        fg(&mut m, 1, [2.0, 0.0, 0.0], [0.2, 0.2, 0.2]);
        fg(&mut m, 2, [-2.0, 0.0, 0.0], [0.2, 0.2, 0.2]); // behind
        fg(&mut m, 3, [6.0, 0.0, 0.0], [0.2, 0.2, 0.2]); // beyond 5 m
        fg(&mut m, 4, [2.0, 3.0, 0.0], [0.2, 0.2, 0.2]); // outside the 60° fov
        let v = View::new(level_view(0.0, 0.0));
        let t = abundance(&m, &v, &params());
        assert_eq!(t.in_view, 1);
        // Far object 3 is hidden behind object 1? Its box (0.2 m at 5.9 m) lies inside object
        // 1's box, so object 1 loses (1.9 / 5.9)² of its area under the paper's "all" rule.
        let expect = 1.0 - (1.9f32 / 5.9).powi(2);
        assert!((t.h_iou_mean - expect).abs() < 1e-4, "{t:?}");
    }

    /// Three objects in the frustum, each worth 0.5 (H_sopm only): A (cluster 0, 1.24 m away),
    /// B (cluster 5, 3.1 m), C (cluster 0, 2.52 m); none hides another. "frustum" counts all three, "cluster" with
    /// target 0 counts A and C (every object without a target), "radius" (1.5 m) only A.
    #[test]
    fn relevance_filter_hand_computed() {
        let mut m = boxed_zeroed::<ObjectMap>();
        fg(&mut m, 1, [1.2, 0.3, 0.0], [0.1, 0.1, 0.1]);
        let b = fg(&mut m, 2, [3.0, -0.8, 0.0], [0.1, 0.1, 0.1]);
        m.objects[b].cluster_id = 5;
        fg(&mut m, 3, [2.5, -0.3, 0.0], [0.1, 0.1, 0.1]);
        let mut p = params();
        p.ablation.h_iou = false;
        p.ablation.theta_sopm = false;
        let v = View::new(level_view(0.0, 0.0));
        let target = Target {
            cluster_id: 0,
            centroid: Vec3::new(2.0, 0.0, 0.0),
        };
        let mut fa = FaFilter::new(&PlannerConfig::default());
        assert_eq!(fa.radius, 1.5);
        let run = |rel, t: Option<&Target>, fa: &mut FaFilter| {
            fa.relevance = rel;
            let a = abundance_for(&m, &v, t, None, fa, &p);
            (a.in_view, a.f_a)
        };
        assert_eq!(run(FaRelevance::Frustum, Some(&target), &mut fa), (3, 1.5));
        assert_eq!(run(FaRelevance::Cluster, Some(&target), &mut fa), (2, 1.0));
        assert_eq!(run(FaRelevance::Cluster, None, &mut fa), (3, 1.5));
        assert_eq!(run(FaRelevance::Radius, Some(&target), &mut fa), (1, 0.5));
        fa.radius = 2.6;
        assert_eq!(run(FaRelevance::Radius, None, &mut fa), (2, 1.0));
    }

    /// A cup 3 m ahead with a background box (a wall of the map) between: out of view with
    /// occlusion on, in view with it off or with the box moved behind the cup.
    #[test]
    fn hidden_objects_are_not_in_view() {
        let mut m = boxed_zeroed::<ObjectMap>();
        let cup = fg(&mut m, 1, [3.0, 0.0, 0.0], [0.1, 0.1, 0.12]);
        let wall = fg(&mut m, 2, [2.0, 0.0, 0.0], [0.2, 1.0, 1.0]);
        m.objects[wall].background = 1;
        let p = params();
        let mut fa = FaFilter::new(&PlannerConfig::default());
        assert!(fa.occlusion);
        fa.relevance = FaRelevance::Frustum; // the cup is 3 m away, beyond the default radius
        let v = View::new(level_view(0.0, 0.0));
        assert!(!in_view(&m, cup, &v, None, None, &fa, &p));
        assert_eq!(abundance_for(&m, &v, None, None, &fa, &p).in_view, 0);
        m.objects[wall].center = [4.0, 0.0, 0.0];
        assert!(in_view(&m, cup, &v, None, None, &fa, &p));
        m.objects[wall].center = [2.0, 0.0, 0.0];
        fa.occlusion = false;
        assert!(in_view(&m, cup, &v, None, None, &fa, &p));
        assert_eq!(
            abundance(&m, &v, &p).in_view,
            1,
            "the unfiltered sum counts it"
        );
        assert!(
            !in_view(&m, wall, &v, None, None, &fa, &p),
            "background never counts"
        );
    }

    #[test]
    fn n_cp_counts_only_cluster_points_within_angle() {
        let mut m = boxed_zeroed::<ObjectMap>();
        let k = fg(&mut m, 1, [2.0, 0.0, 0.0], [0.4, 0.4, 0.4]);
        let other = fg(&mut m, 2, [2.0, 0.5, 0.0], [0.2, 0.2, 0.2]);
        m.objects[other].cluster_id = 9;
        for (obj, n) in [(k, 30usize), (other, 20)] {
            let o = &mut m.objects[obj];
            o.sample_count = n as u16;
            for i in 0..n {
                o.points[i] = [2.0, (i as f32 - 15.0) * 0.01, 0.0];
                o.point_los[i] = [1.0, 0.0, 0.0];
            }
        }
        // 10 of object 1's points were seen from the side (90° away): not co-visible.
        for i in 0..10 {
            m.objects[k].point_los[i] = [0.0, 1.0, 0.0];
        }
        let target = Target {
            cluster_id: 0,
            centroid: Vec3::new(2.0, 0.0, 0.0),
        };
        let mut p = params();
        p.eps_cp = 40.0;
        let v = View::new(level_view(0.0, 0.0));
        let c = continuity(&m, &v, Some(&target), &p);
        assert_eq!(c.covisible, 20);
        assert!((c.n_cp - 0.5).abs() < 1e-6 && (c.cos_theta_c - 1.0).abs() < 1e-6);
        p.eps_cp = 10.0;
        let c = continuity(&m, &v, Some(&target), &p);
        assert_eq!(c.n_cp, 1.0, "saturates at ε_cp");
        // Turned away by 90°: no point in the frustum, θ_c = 90°.
        let side = View::new(level_view(0.0, std::f32::consts::FRAC_PI_2));
        let c = continuity(&m, &side, Some(&target), &p);
        assert_eq!(c.covisible, 0);
        assert!(c.cos_theta_c.abs() < 1e-6 && c.f_c.abs() < 1e-6);
        p.ablation.n_cp = false;
        assert!((continuity(&m, &v, Some(&target), &p).f_c - 1.0).abs() < 1e-6);
    }

    #[test]
    fn candidate_carries_every_term() {
        let mut m = boxed_zeroed::<ObjectMap>();
        let k = fg(&mut m, 1, [2.0, 0.0, 0.0], [0.4, 0.4, 0.4]);
        m.objects[k].l_best = [-1.0, 0.0, 0.0];
        m.objects[k].c_asso = 0.5;
        m.objects[k].sample_count = 1;
        m.objects[k].points[0] = [1.8, 0.0, 0.0];
        m.objects[k].point_los[0] = [1.0, 0.0, 0.0];
        let target = Target {
            cluster_id: 0,
            centroid: Vec3::new(2.0, 0.0, 0.0),
        };
        let mut p = params();
        p.eps_cp = 2.0;
        let w = Weights {
            alpha: 1.0,
            beta: 0.2,
        };
        let c = evaluate_view(&m, &level_view(0.0, 0.0), Some(&target), w, &p);
        // f_a = (0.5 + 1) · 1 · 0.5; f_c = 0.5 · 1.
        assert!(
            (c.f_a - 0.75).abs() < 1e-5 && (c.f_c - 0.5).abs() < 1e-5,
            "{c:?}"
        );
        assert!((c.value - 0.85).abs() < 1e-5);
        assert_eq!(c.objects_in_view, 1);
        assert!((c.cos_theta_sopm - 1.0).abs() < 1e-5 && (c.c_asso - 0.5).abs() < 1e-6);
        let lbv = evaluate_view(
            &m,
            &level_view(0.0, 0.0),
            Some(&target),
            Weights {
                alpha: 0.0,
                beta: 1.0,
            },
            &p,
        );
        assert_eq!(lbv.f_a, 0.0);
        assert_eq!(lbv.objects_in_view, 0, "f_a is skipped when α = 0");
    }

    #[test]
    fn offsets_path_equals_the_generic_one() {
        let map = crate::synth::scene3_map();
        let p = params();
        let target = Target {
            cluster_id: 1,
            centroid: Vec3::new(-1.6, 0.2, 0.8),
        };
        let mount = p.mount;
        let base = [-0.5, 0.3, 3.0];
        let cam = Vec3::from(mount.camera_pose(base, 0.0, mount.pitch()).translation);
        let mut off = Vec::new();
        covisible_offsets(&map, &target, cam, p.cos_thresh, &mut off);
        let mut any = 0;
        for k in 0..36 {
            let pose = mount.camera_pose(base, k as f32 * 0.17, mount.pitch());
            let v = View::new(pose);
            let a = continuity(&map, &v, Some(&target), &p);
            let b = continuity_from_offsets(&v, &off, Some(&target), &p);
            assert_eq!(a.covisible, b.covisible, "yaw step {k}");
            assert_eq!(a.f_c, b.f_c);
            any += a.covisible;
        }
        assert!(any > 0);
    }
}
