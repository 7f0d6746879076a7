//! Local best view (paper section 3.3, Algorithm 1 lines 14–21): `M` neck-yaw candidates spread
//! evenly over the neck's range at the current (estimated) base pose, evaluated with α = 0,
//! β = 1 (observation continuity of the tracked cluster only).
//!
//! [`Lbv`] keeps its candidate buffer preallocated: after construction, [`Lbv::evaluate`] does
//! not allocate (a counting-allocator test in `tests/planner_lbv_alloc.rs` proves it). It reads
//! the map and pose by reference, runs on the caller's thread (the real-time LBV thread) and
//! never waits for anything.
//!
//! Choice: the highest F(v); among values within 1e-6 of it, the yaw nearest the current neck
//! yaw (no needless neck motion). When no candidate has a positive value (no co-visible point
//! anywhere, e.g. while far from the cluster), the candidate with the largest cos θ_c is taken so
//! the camera keeps facing the cluster's unfinished objects.

use crate::config::PlannerConfig;
use crate::evaluate::{
    AbundanceTerms, ContinuityTerms, EvalParams, FaFilter, Target, Weights, abundance_for,
    candidate, continuity_from_offsets, covisible_offsets, evaluate_view,
};
use crate::terms::View;
use geom::CameraConfig;
use geom::wrap_angle;
use glam::Vec3;
use shm_types::{
    Candidate, MAX_CANDIDATES, MAX_OBJECT_POINTS, MAX_OBJECTS, ObjectMap, PlannerDecision,
    decision_kind,
};

/// The chosen neck goal.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LbvChoice {
    /// Neck yaw relative to the base, radians.
    pub neck_yaw: f32,
    /// Camera pitch, radians (the mount's).
    pub pitch: f32,
    /// F(v) of the choice.
    pub score: f32,
    /// Index of the choice in [`Lbv::candidates`].
    pub index: usize,
}

/// Evenly spread neck yaws over `[min, max]` (radians); a full circle does not repeat its end.
pub fn neck_yaws(min: f32, max: f32, m: usize) -> Vec<f32> {
    let span = max - min;
    let full = span >= std::f32::consts::TAU - 1e-3;
    (0..m)
        .map(|k| {
            if m == 1 {
                min + span / 2.0
            } else if full {
                wrap_angle(min + span * k as f32 / m as f32)
            } else {
                min + span * k as f32 / (m - 1) as f32
            }
        })
        .collect()
}

/// LBV evaluator with preallocated scratch.
#[derive(Debug, Clone)]
pub struct Lbv {
    params: EvalParams,
    fa: FaFilter,
    weights: Weights,
    yaws: Vec<f32>,
    cands: Vec<Candidate>,
    offsets: Vec<Vec3>,
}

impl Lbv {
    /// From the configuration (`[planner.lbv]`).
    pub fn new(planner: &PlannerConfig, camera: &CameraConfig) -> Self {
        let l = &planner.lbv;
        let mut lbv = Self::with(
            EvalParams::new(planner, camera),
            Weights {
                alpha: l.alpha,
                beta: l.beta,
            },
            neck_yaws(
                l.neck_min_deg.to_radians(),
                l.neck_max_deg.to_radians(),
                l.candidates,
            ),
        );
        lbv.fa = FaFilter::new(planner);
        lbv
    }

    /// With explicit parameters and candidate neck yaws (f_a, if α > 0, over every object in
    /// the frustum).
    pub fn with(params: EvalParams, weights: Weights, yaws: Vec<f32>) -> Self {
        let cands = Vec::with_capacity(yaws.len());
        Self {
            params,
            fa: FaFilter::FRUSTUM,
            weights,
            yaws,
            cands,
            offsets: Vec::with_capacity(MAX_OBJECTS * MAX_OBJECT_POINTS),
        }
    }

    /// The candidate neck yaws.
    pub fn yaws(&self) -> &[f32] {
        &self.yaws
    }

    /// The candidates of the last [`Lbv::evaluate`], in yaw order.
    pub fn candidates(&self) -> &[Candidate] {
        &self.cands
    }

    /// Evaluate every neck yaw at base pose `base` and choose one. `None` only without
    /// candidates (M = 0 cannot be configured).
    pub fn evaluate(
        &mut self,
        map: &ObjectMap,
        base: [f32; 3],
        current_neck_yaw: f32,
        target: Option<&Target>,
    ) -> Option<LbvChoice> {
        self.cands.clear();
        self.offsets.clear();
        let pitch = self.params.mount.pitch();
        let w = self.weights;
        // All neck yaws share the camera position: the angle test of co-visibility is done once.
        let origin = Vec3::from(self.params.mount.camera_pose(base, 0.0, pitch).translation);
        if let Some(t) = target.filter(|_| w.beta != 0.0 && self.params.ablation.n_cp) {
            covisible_offsets(map, t, origin, self.params.cos_thresh, &mut self.offsets);
        }
        for &yaw in &self.yaws {
            let pose = self.params.mount.camera_pose(base, yaw, pitch);
            let view = View::new(pose);
            if view.position.distance(origin) > 1e-5 {
                // A mount whose optical centre moves with the neck: generic path.
                self.cands
                    .push(evaluate_view(map, &pose, target, w, &self.params));
                continue;
            }
            let a = if w.alpha != 0.0 {
                abundance_for(map, &view, target, None, &self.fa, &self.params)
            } else {
                AbundanceTerms::default()
            };
            let c = if w.beta != 0.0 {
                continuity_from_offsets(&view, &self.offsets, target, &self.params)
            } else {
                ContinuityTerms::default()
            };
            self.cands.push(candidate(&view, &a, &c, w));
        }
        let max = self
            .cands
            .iter()
            .map(|c| c.value)
            .fold(f32::NEG_INFINITY, f32::max);
        let key: fn(&Candidate) -> f32 = if max > 0.0 || target.is_none() {
            |c| c.value
        } else {
            |c| c.cos_theta_c
        };
        let best = self.cands.iter().map(key).fold(f32::NEG_INFINITY, f32::max);
        let mut choice: Option<(usize, f32)> = None;
        for (i, c) in self.cands.iter().enumerate() {
            if key(c) < best - 1e-6 {
                continue;
            }
            let d = wrap_angle(self.yaws[i] - current_neck_yaw).abs();
            if choice.is_none_or(|(_, bd)| d < bd) {
                choice = Some((i, d));
            }
        }
        choice.map(|(i, _)| LbvChoice {
            neck_yaw: self.yaws[i],
            pitch,
            score: self.cands[i].value,
            index: i,
        })
    }

    /// Write the last evaluation into a trace message (best [`MAX_CANDIDATES`] by value, the
    /// chosen one flagged). Does not allocate.
    pub fn fill_decision(&self, chosen: Option<usize>, d: &mut PlannerDecision) {
        let n = self.cands.len().min(MAX_CANDIDATES);
        d.kind = decision_kind::LBV;
        d.evaluated = self.cands.len() as u32;
        d.count = n as u32;
        // Keep the chosen candidate even when M > 64: put it first, then the best of the rest.
        let mut k = 0;
        if let Some(c) = chosen.filter(|c| *c < self.cands.len()) {
            d.candidates[0] = self.cands[c];
            d.candidates[0].chosen = 1;
            k = 1;
        }
        for (i, c) in self.cands.iter().enumerate() {
            if Some(i) == chosen {
                continue;
            }
            if k < n {
                d.candidates[k] = *c;
                k += 1;
            } else if let Some(w) = (usize::from(chosen.is_some())..n)
                .min_by(|a, b| d.candidates[*a].value.total_cmp(&d.candidates[*b].value))
                .filter(|w| d.candidates[*w].value < c.value)
            {
                d.candidates[w] = *c;
            }
        }
        d.candidates[..n]
            .sort_unstable_by(|a, b| b.chosen.cmp(&a.chosen).then(b.value.total_cmp(&a.value)));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::clusters::{cluster_info, unfinished_centroid};
    use glam::Vec3;
    use shm_types::boxed_zeroed;

    #[test]
    fn yaws_spread_over_the_range() {
        let y = neck_yaws(-std::f32::consts::PI, std::f32::consts::PI, 4);
        let expect = [
            std::f32::consts::PI,
            -std::f32::consts::FRAC_PI_2,
            0.0,
            std::f32::consts::FRAC_PI_2,
        ];
        for (a, b) in y.iter().zip(expect) {
            assert!(wrap_angle(a - b).abs() < 1e-5, "{y:?}");
        }
        assert_eq!(neck_yaws(-1.0, 1.0, 3), vec![-1.0, 0.0, 1.0]);
    }

    /// A cluster (table + cup with sample points) to the robot's left (bearing 87°): the LBV
    /// turns the neck to the nearest candidate (80°; candidates every 20° from −180°) to keep it
    /// in view, whatever the current neck yaw.
    #[test]
    fn lbv_keeps_the_cluster_in_view() {
        let mut m = boxed_zeroed::<ObjectMap>();
        m.count = 2;
        let t = &mut m.objects[0];
        t.id = 7;
        t.background = 1;
        t.cluster_id = 7;
        t.center = [0.0, 2.0, 0.375];
        t.size = [1.0, 0.8, 0.75];
        let c = &mut m.objects[1];
        c.id = 8;
        c.cluster_id = 7;
        c.center = [0.1, 2.0, 0.8];
        c.size = [0.1, 0.1, 0.1];
        c.h_sopm = 0.9;
        c.sample_count = 64;
        for i in 0..64 {
            let p = Vec3::new(
                0.05 + (i % 8) as f32 * 0.0125,
                1.95 + (i / 8) as f32 * 0.0125,
                0.8,
            );
            c.points[i] = p.to_array();
            c.point_los[i] = (p - Vec3::new(0.0, 0.0, 1.4)).normalize().to_array();
        }
        let cfg = PlannerConfig::default();
        let mut lbv = Lbv::new(&cfg, &CameraConfig::default());
        let info = cluster_info(&m, 7, 0.42).unwrap();
        let target = Target {
            cluster_id: 7,
            centroid: unfinished_centroid(&m, &info, 0.42),
        };
        for current in [0.0, 3.0, -2.0] {
            let ch = lbv
                .evaluate(&m, [0.0, 0.0, 0.0], current, Some(&target))
                .unwrap();
            assert!((ch.neck_yaw - 80f32.to_radians()).abs() < 1e-5, "{ch:?}");
            assert!(ch.score > 0.5);
        }
        assert_eq!(lbv.candidates().len(), 18);
        // Far away (no point in range): fall back to facing the cluster.
        let ch = lbv
            .evaluate(&m, [0.0, -6.0, 0.0], 0.0, Some(&target))
            .unwrap();
        assert_eq!(ch.score, 0.0);
        assert!(
            (ch.neck_yaw - std::f32::consts::FRAC_PI_2).abs() < 0.2,
            "{ch:?}"
        );
        let mut d = boxed_zeroed::<PlannerDecision>();
        lbv.fill_decision(Some(ch.index), &mut d);
        assert_eq!(d.count, 18);
        assert_eq!(d.candidates[0].chosen, 1);
    }
}
