//! Wilcoxon rank-sum (Mann–Whitney U) test, per axis and combined over x, y, z (paper §4.3).
//!
//! The paper's eqs. (16)/(18) are garbled; this is the standard large-sample test:
//! per axis, the pooled sample is ranked (ties get their average rank), the rank sum `R_P` of the
//! first sample gives `U = R_P − |P|(|P|+1)/2`, with mean `|P||Q|/2` and tie-corrected variance
//! `|P||Q|/12 · ((N+1) − Σ(t³−t)/(N(N−1)))`, `N = |P|+|Q|`; `z = (U − mean)/σ` (no continuity
//! correction) and the two-sided p-value is `2(1 − Φ(|z|)) = erfc(|z|/√2)`.
//!
//! **Combination over axes** (eq. 14 averages the rank sums of the three axes): we average the
//! per-axis z-scores, `z̄ = (z_x + z_y + z_z)/3`, and read `p = 2(1 − Φ(|z̄|))`. Without ties this is
//! exactly eqs. (14)–(17) (the three axes share mean and variance, so averaging the rank sums and
//! then normalising equals averaging the z-scores); with ties each axis is normalised by its own
//! tie-corrected σ. Under H0 each `z_k` is standard normal and `Var(z̄) ≤ 1` whatever the
//! correlation between axes, so the combined test is valid (conservative). Its known weakness:
//! opposite shifts on two axes cancel; the mapper's 3D overlap gate covers that case.

use statrs::function::erf::erfc;

/// Result of a rank-sum test.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RankSum {
    /// Mann–Whitney U of the first sample (averaged over axes for the combined test).
    pub u: f64,
    /// Standardised statistic.
    pub z: f64,
    /// Two-sided p-value.
    pub p: f64,
}

/// Two-sided p-value of a standard-normal statistic.
pub fn two_sided_p(z: f64) -> f64 {
    erfc(z.abs() / std::f64::consts::SQRT_2).clamp(0.0, 1.0)
}

/// Reusable buffers for rank computations (no allocation once warmed up).
#[derive(Debug, Clone, Default)]
pub struct RankScratch {
    pooled: Vec<(f32, bool)>,
}

impl RankScratch {
    /// One-axis rank-sum test of `a` against `b` (values of one coordinate).
    ///
    /// Returns `p = 1`, `z = 0` when either sample is empty or all values are tied.
    pub fn test(&mut self, a: impl Iterator<Item = f32>, b: impl Iterator<Item = f32>) -> RankSum {
        self.pooled.clear();
        self.pooled.extend(a.map(|v| (v, true)));
        let n1 = self.pooled.len();
        self.pooled.extend(b.map(|v| (v, false)));
        let n = self.pooled.len();
        let n2 = n - n1;
        if n1 == 0 || n2 == 0 {
            return RankSum {
                u: 0.0,
                z: 0.0,
                p: 1.0,
            };
        }
        self.pooled.sort_unstable_by(|x, y| x.0.total_cmp(&y.0));
        let mut rank_sum_a = 0.0f64;
        let mut tie_term = 0.0f64;
        let mut i = 0;
        while i < n {
            let mut j = i + 1;
            while j < n && self.pooled[j].0 == self.pooled[i].0 {
                j += 1;
            }
            // Ranks i+1 ..= j share their average.
            let avg_rank = (i + 1 + j) as f64 / 2.0;
            let t = (j - i) as f64;
            tie_term += t * t * t - t;
            let in_a = self.pooled[i..j].iter().filter(|v| v.1).count();
            rank_sum_a += avg_rank * in_a as f64;
            i = j;
        }
        let (n1f, n2f, nf) = (n1 as f64, n2 as f64, n as f64);
        let u = rank_sum_a - n1f * (n1f + 1.0) / 2.0;
        let mean = n1f * n2f / 2.0;
        let var = n1f * n2f / 12.0 * ((nf + 1.0) - tie_term / (nf * (nf - 1.0)));
        if var <= 0.0 {
            return RankSum { u, z: 0.0, p: 1.0 };
        }
        let z = (u - mean) / var.sqrt();
        RankSum {
            u,
            z,
            p: two_sided_p(z),
        }
    }

    /// Multivariate test of two point sets on x, y, z, combined by averaging the per-axis
    /// z-scores (see the module docs). Takes at most `max_points` of each set, chosen by a
    /// deterministic even stride.
    pub fn test_points(&mut self, p: &[[f32; 3]], q: &[[f32; 3]], max_points: usize) -> RankSum {
        let mut u = 0.0;
        let mut z = 0.0;
        for axis in 0..3 {
            let r = self.test(
                strided(p, max_points).map(|v| v[axis]),
                strided(q, max_points).map(|v| v[axis]),
            );
            u += r.u / 3.0;
            z += r.z / 3.0;
        }
        RankSum {
            u,
            z,
            p: two_sided_p(z),
        }
    }
}

/// At most `max` elements of `s`, evenly spread (deterministic).
pub fn strided<T>(s: &[T], max: usize) -> impl Iterator<Item = &T> {
    let n = s.len();
    let take = n.min(max.max(1));
    (0..take).map(move |k| &s[k * n / take])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normal_tail_values() {
        assert!((two_sided_p(0.0) - 1.0).abs() < 1e-12);
        assert!((two_sided_p(1.959_963_984_540_054) - 0.05).abs() < 1e-9);
        assert!((two_sided_p(-2.575_829_303_548_901) - 0.01).abs() < 1e-9);
    }

    #[test]
    fn hand_computed_small_case_with_ties() {
        // a = [1, 2, 2], b = [2, 3]: pooled ranks 1, 3, 3, 3, 5 (the three 2s share rank 3).
        // R_a = 1 + 3 + 3 = 7, U = 7 − 6 = 1, mean = 3, tie term = 3³ − 3 = 24,
        // var = 6/12 · (6 − 24/20) = 2.4, z = −2/√2.4.
        let mut s = RankScratch::default();
        let r = s.test([1.0, 2.0, 2.0].into_iter(), [2.0, 3.0].into_iter());
        assert!((r.u - 1.0).abs() < 1e-12);
        assert!((r.z + 2.0 / 2.4f64.sqrt()).abs() < 1e-12);
    }

    #[test]
    fn degenerate_inputs_give_p_one() {
        let mut s = RankScratch::default();
        assert_eq!(s.test([].into_iter(), [1.0].into_iter()).p, 1.0);
        assert_eq!(s.test([1.0, 1.0].into_iter(), [1.0].into_iter()).p, 1.0);
    }

    #[test]
    fn strided_is_even_and_bounded() {
        let v: Vec<u32> = (0..10).collect();
        let s: Vec<u32> = strided(&v, 4).copied().collect();
        assert_eq!(s, vec![0, 2, 5, 7]);
        assert_eq!(strided(&v, 100).count(), 10);
    }
}
