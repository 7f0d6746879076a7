//! Sparse fallback (an addition beyond the paper, `[mapper.extensions] sparse_fallback`): a
//! confident box-only detection whose box yields fewer than `[mapper] min_points` object points
//! — glass that drops out or reads the surface behind it, dark or shiny surfaces, a small object
//! far away — is still used when what little it has is consistent with the detection: at least
//! `[mapper.sparse] min_points` points, a score of at least `min_score`, their bottom at most
//! `max_above_support` above a mapped table top under their median (the object stands on it; its
//! lower part may have dropped out) and their extent fitting the class size prior at least
//! `min_prior_fit`. Each view adds its few points to the object's cloud, so the cuboid is
//! triangulated over the views instead of being lost in each.

use super::Mapper;
use super::priors::size_prior;
use glam::{Vec2, Vec3};
use shm_types::Detection;

impl Mapper {
    /// Whether a foreground detection with fewer than `min_points` points may still be used.
    pub(super) fn sparse_ok(&self, det: &Detection, pts: &[Vec3]) -> bool {
        let s = &self.cfg.sparse;
        if !self.cfg.extensions.sparse_fallback
            || pts.len() < s.min_points as usize
            || det.score < s.min_score
        {
            return false;
        }
        let median = |f: fn(&Vec3) -> f32| {
            let mut a: Vec<f32> = pts.iter().map(f).collect();
            let k = a.len() / 2;
            *a.select_nth_unstable_by(k, f32::total_cmp).1
        };
        let m = Vec2::new(median(|p| p.x), median(|p| p.y));
        let (lo, hi) = pts.iter().fold(
            (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
            |(lo, hi), p| (lo.min(*p), hi.max(*p)),
        );
        let on_support = self.supports.iter().any(|sp| {
            let above = lo.z - sp.height;
            sp.under(m.extend(sp.height))
                && above >= -self.cfg.support_margin
                && above <= s.max_above_support
        });
        let e = hi - lo;
        let prior = size_prior(det.class_id);
        on_support && prior.fit(e.x.max(e.y), e.x.min(e.y), e.z) >= s.min_prior_fit
    }
}
