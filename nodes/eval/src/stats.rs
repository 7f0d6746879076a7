//! Statistics of the bench report: the Wilcoxon signed-rank test of paired differences, the
//! Holm–Bonferroni correction, and percentile-bootstrap confidence intervals of a mean that
//! resample rooms (clusters) with the seeds of a room kept together.
//!
//! Pure functions; the report ([`super::report`]) and `vpsom report --compare`
//! ([`super::compare`]) call them.
//!
//! | function | what |
//! |---|---|
//! | [`wilcoxon`] | two-sided signed-rank test of paired differences → [`SignedRank`] |
//! | [`holm`] | Holm–Bonferroni adjusted p-values of a family |
//! | [`bootstrap_mean_ci`], [`mean_ci`] | 95 % percentile CI of a mean, resampling clusters → [`Ci`] |
//! | [`paired`] | a paired difference: CI over rooms and the signed-rank test → [`Paired`] |
//!
//! Conventions (the same as `scipy.stats.wilcoxon`'s defaults, so its values are an oracle):
//! - Zero differences are dropped before ranking (Wilcoxon's convention, scipy's
//!   `zero_method="wilcox"`), not ranked and then dropped (Pratt's).
//! - Absolute differences equal within a relative 1e-9 are tied and get their average rank, so a
//!   difference computed as `x - y` in floating point does not split a tie (scipy's documentation
//!   shows that pitfall).
//! - The p-value is exact (the null distribution of W⁺ counted over all 2ⁿ sign patterns) when
//!   at most [`EXACT_MAX_N`] differences remain and none are tied; otherwise it is the normal
//!   approximation with the tie correction of the variance and a continuity correction of 0.5.
//! - The statistic reported is min(W⁺, W⁻), as scipy's two-sided statistic.
//!
//! The bootstrap draws with a fixed seed ([`BOOTSTRAP_SEED`], PCG64), so the same runs give the
//! same report.

use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use statrs::distribution::{ContinuousCDF, Normal};

/// Significance level of the report's verdicts (after the Holm correction).
pub const ALPHA: f64 = 0.05;
/// Confidence level of the intervals.
pub const CONFIDENCE: f64 = 0.95;
/// Bootstrap resamples per interval.
pub const BOOTSTRAP_RESAMPLES: usize = 4000;
/// Seed of every bootstrap (each interval starts from it, so an interval does not depend on
/// which others were computed before it).
pub const BOOTSTRAP_SEED: u64 = 46;
/// Largest number of non-zero differences for which the exact null distribution is used.
pub const EXACT_MAX_N: usize = 50;
/// Relative tolerance under which two absolute differences are tied.
const TIE_RTOL: f64 = 1e-9;

/// Result of the two-sided Wilcoxon signed-rank test.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SignedRank {
    /// Differences used (non-zero, finite).
    pub n: usize,
    /// Zero differences dropped.
    pub zeros: usize,
    /// Sum of the ranks of the positive differences.
    pub w_plus: f64,
    /// Sum of the ranks of the negative differences.
    pub w_minus: f64,
    /// Two-sided p-value (1 when no non-zero difference remains).
    pub p: f64,
    /// Whether `p` is exact (no ties, `n <= EXACT_MAX_N`) or the normal approximation.
    pub exact: bool,
}

impl SignedRank {
    /// The two-sided statistic min(W⁺, W⁻).
    pub fn statistic(&self) -> f64 {
        self.w_plus.min(self.w_minus)
    }

    /// Sign of the effect as the ranks see it: +1 when W⁺ > W⁻, −1 when W⁻ > W⁺, 0 otherwise.
    pub fn direction(&self) -> f64 {
        if self.w_plus > self.w_minus {
            1.0
        } else if self.w_minus > self.w_plus {
            -1.0
        } else {
            0.0
        }
    }
}

/// Average ranks (1-based) of `values` sorted ascending, ties within [`TIE_RTOL`]; returns the
/// ranks and the tie term Σ (t³ − t) over the tie groups.
fn average_ranks(sorted: &[f64]) -> (Vec<f64>, f64) {
    let mut ranks = vec![0.0; sorted.len()];
    let mut tie_term = 0.0;
    let mut i = 0;
    while i < sorted.len() {
        let mut j = i + 1;
        while j < sorted.len() && sorted[j] - sorted[i] <= TIE_RTOL * sorted[j].abs() {
            j += 1;
        }
        // Ranks i+1 ..= j share their mean.
        let r = (i + 1 + j) as f64 / 2.0;
        ranks[i..j].fill(r);
        let t = (j - i) as f64;
        tie_term += t * t * t - t;
        i = j;
    }
    (ranks, tie_term)
}

/// Number of sign patterns of ranks 1..=n whose positive rank sum is ≤ `t` (the exact null
/// distribution's CDF times 2ⁿ).
fn exact_count_at_most(n: usize, t: usize) -> f64 {
    let max = n * (n + 1) / 2;
    let mut counts = vec![0.0f64; max + 1];
    counts[0] = 1.0;
    for k in 1..=n {
        for s in (k..=max).rev() {
            counts[s] += counts[s - k];
        }
    }
    counts[..=t.min(max)].iter().sum()
}

/// Two-sided p of the normal approximation of W⁺ (`tie_term` = Σ (t³ − t)), with or without
/// the continuity correction.
fn normal_p(w_plus: f64, n: usize, tie_term: f64, continuity: bool) -> f64 {
    let nf = n as f64;
    let mean = nf * (nf + 1.0) / 4.0;
    let var = nf * (nf + 1.0) * (2.0 * nf + 1.0) / 24.0 - tie_term / 48.0;
    if var <= 0.0 {
        return 1.0;
    }
    let d = (w_plus - mean).abs() - if continuity { 0.5 } else { 0.0 };
    let z = d.max(0.0) / var.sqrt();
    let std_normal = Normal::new(0.0, 1.0).expect("unit normal");
    (2.0 * std_normal.sf(z)).min(1.0)
}

/// Two-sided Wilcoxon signed-rank test of paired differences (see the module docs for the
/// conventions). Non-finite differences are ignored; `None` when no finite difference is given.
pub fn wilcoxon(diffs: &[f64]) -> Option<SignedRank> {
    let finite: Vec<f64> = diffs.iter().copied().filter(|d| d.is_finite()).collect();
    if finite.is_empty() {
        return None;
    }
    let mut nonzero: Vec<f64> = finite.iter().copied().filter(|d| *d != 0.0).collect();
    let zeros = finite.len() - nonzero.len();
    let n = nonzero.len();
    if n == 0 {
        return Some(SignedRank {
            n,
            zeros,
            w_plus: 0.0,
            w_minus: 0.0,
            p: 1.0,
            exact: true,
        });
    }
    nonzero.sort_by(|a, b| a.abs().total_cmp(&b.abs()));
    let abs: Vec<f64> = nonzero.iter().map(|d| d.abs()).collect();
    let (ranks, tie_term) = average_ranks(&abs);
    let w_plus: f64 = nonzero
        .iter()
        .zip(&ranks)
        .filter(|(d, _)| **d > 0.0)
        .map(|(_, r)| r)
        .sum();
    let total = (n * (n + 1)) as f64 / 2.0;
    let w_minus = total - w_plus;
    let exact = tie_term == 0.0 && n <= EXACT_MAX_N;
    let p = if exact {
        // Without ties every rank sum is an integer.
        let t = w_plus.min(w_minus).round() as usize;
        (2.0 * exact_count_at_most(n, t) / 2f64.powi(n as i32)).min(1.0)
    } else {
        normal_p(w_plus, n, tie_term, true)
    };
    Some(SignedRank {
        n,
        zeros,
        w_plus,
        w_minus,
        p,
        exact,
    })
}

/// The smallest two-sided p the exact test can give with `n` non-zero differences (all of one
/// sign): 2 / 2ⁿ. Below about 6 pairs nothing can be significant at 5 %.
pub fn min_exact_p(n: usize) -> f64 {
    (2.0 / 2f64.powi(n as i32)).min(1.0)
}

/// Holm–Bonferroni adjusted p-values of a family, in the input order: the k-th smallest
/// (k = 1..m) becomes max over j ≤ k of min(1, (m − j + 1) p₍ⱼ₎). Rejecting where the adjusted
/// p < α controls the family-wise error rate at α.
pub fn holm(p: &[f64]) -> Vec<f64> {
    let m = p.len();
    let mut order: Vec<usize> = (0..m).collect();
    order.sort_by(|&a, &b| p[a].total_cmp(&p[b]));
    let mut adjusted = vec![0.0; m];
    let mut running = 0.0f64;
    for (k, &i) in order.iter().enumerate() {
        running = running.max(((m - k) as f64 * p[i]).min(1.0));
        adjusted[i] = running;
    }
    adjusted
}

/// A mean with its confidence interval.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ci {
    /// Mean of all values (pooled over the clusters).
    pub mean: f64,
    /// Lower bound.
    pub lo: f64,
    /// Upper bound.
    pub hi: f64,
    /// Clusters (rooms) resampled.
    pub clusters: usize,
    /// Values.
    pub n: usize,
}

impl Ci {
    /// Whether the interval excludes zero.
    pub fn excludes_zero(&self) -> bool {
        self.lo > 0.0 || self.hi < 0.0
    }
}

/// Linear-interpolation quantile of sorted values (numpy's default): position q·(len − 1).
fn quantile(sorted: &[f64], q: f64) -> f64 {
    let pos = q * (sorted.len() - 1) as f64;
    let (i, frac) = (pos.floor() as usize, pos.fract());
    if i + 1 < sorted.len() {
        sorted[i] + frac * (sorted[i + 1] - sorted[i])
    } else {
        sorted[i]
    }
}

/// Percentile-bootstrap [`CONFIDENCE`] interval of the pooled mean of `clusters`: each resample
/// draws as many clusters as there are, with replacement, keeping each cluster's values together
/// (the seeds of a room), and takes the mean of the values drawn. Bounds are the 2.5 % and
/// 97.5 % quantiles of the `resamples` means (linear interpolation). Empty clusters and
/// non-finite values are ignored; `None` when no value remains. With one cluster the interval is
/// the mean itself (nothing varies between rooms to resample).
pub fn bootstrap_mean_ci(clusters: &[Vec<f64>], resamples: usize, seed: u64) -> Option<Ci> {
    let sums: Vec<(f64, usize)> = clusters
        .iter()
        .map(|c| {
            let v: Vec<f64> = c.iter().copied().filter(|x| x.is_finite()).collect();
            (v.iter().sum::<f64>(), v.len())
        })
        .filter(|(_, n)| *n > 0)
        .collect();
    let k = sums.len();
    let n: usize = sums.iter().map(|s| s.1).sum();
    if n == 0 {
        return None;
    }
    let mean = sums.iter().map(|s| s.0).sum::<f64>() / n as f64;
    let mut rng = Pcg64::seed_from_u64(seed);
    let mut means: Vec<f64> = (0..resamples.max(1))
        .map(|_| {
            let (mut s, mut c) = (0.0, 0usize);
            for _ in 0..k {
                let (cs, cn) = sums[rng.random_range(0..k)];
                s += cs;
                c += cn;
            }
            s / c as f64
        })
        .collect();
    means.sort_by(f64::total_cmp);
    let tail = (1.0 - CONFIDENCE) / 2.0;
    // Resampling the clusters themselves cannot leave their range; clamping only removes
    // rounding (all values equal gives exactly the mean).
    let (lo, hi) = (quantile(&means, tail), quantile(&means, 1.0 - tail));
    Some(Ci {
        mean,
        lo: lo.min(mean),
        hi: hi.max(mean),
        clusters: k,
        n,
    })
}

/// [`bootstrap_mean_ci`] with the report's [`BOOTSTRAP_RESAMPLES`] and [`BOOTSTRAP_SEED`].
pub fn mean_ci(clusters: &[Vec<f64>]) -> Option<Ci> {
    bootstrap_mean_ci(clusters, BOOTSTRAP_RESAMPLES, BOOTSTRAP_SEED)
}

/// A paired difference: its mean with the CI over rooms, the signed-rank test over all pairs,
/// and the p-value after the Holm correction over its family (equal to `test.p` until
/// [`holm_in_place`] runs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Paired {
    /// Mean difference and its CI (bootstrap over rooms of the room's differences).
    pub ci: Ci,
    /// The signed-rank test of every pair's difference.
    pub test: SignedRank,
    /// Holm-adjusted p-value.
    pub p_holm: f64,
}

impl Paired {
    /// Significant after the Holm correction (p_holm < [`ALPHA`]).
    pub fn significant(&self) -> bool {
        self.p_holm < ALPHA
    }
}

/// The paired difference of `clusters` (one per room: the differences of its seeds); `None`
/// without a finite difference.
pub fn paired(clusters: &[Vec<f64>]) -> Option<Paired> {
    let all: Vec<f64> = clusters.iter().flatten().copied().collect();
    let test = wilcoxon(&all)?;
    let ci = mean_ci(clusters)?;
    Some(Paired {
        ci,
        test,
        p_holm: test.p,
    })
}

/// Set `p_holm` of a family of paired differences.
pub fn holm_in_place(family: &mut [&mut Paired]) {
    let p: Vec<f64> = family.iter().map(|d| d.test.p).collect();
    for (d, a) in family.iter_mut().zip(holm(&p)) {
        d.p_holm = a;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f64, b: f64, tol: f64) -> bool {
        (a - b).abs() <= tol
    }

    /// Darwin's Zea mays data (cross- minus self-fertilized heights, Fisher 1935), the example
    /// of the `scipy.stats.wilcoxon` documentation (scipy 1.11 onwards):
    /// `wilcoxon(d)` → (24.0, 0.041259765625), exact;
    /// `wilcoxon(d, alternative='greater')` → statistic 96.0 (= W⁺);
    /// `wilcoxon(d, method='asymptotic')` → (24.0, 0.04088813291185591), no continuity
    /// correction (scipy's default `correction=False`).
    const ZEA_MAYS: [f64; 15] = [
        6.0, 8.0, 14.0, 16.0, 23.0, 24.0, 28.0, 29.0, 41.0, -48.0, 49.0, 56.0, 60.0, -67.0, 75.0,
    ];

    #[test]
    fn wilcoxon_matches_scipy_documentation_example() {
        let r = wilcoxon(&ZEA_MAYS).unwrap();
        assert_eq!((r.n, r.zeros), (15, 0));
        assert!(r.exact);
        assert_eq!(r.statistic(), 24.0);
        assert_eq!(r.w_plus, 96.0);
        assert!(close(r.p, 0.041259765625, 1e-15), "{}", r.p);
        // 0.041259765625 = 2 · 676 / 2¹⁵.
        assert_eq!(exact_count_at_most(15, 24), 676.0);
        // The asymptotic p of scipy (no ties, no continuity correction); statrs' erf agrees with
        // scipy's to about 1e-11.
        let p = normal_p(96.0, 15, 0.0, false);
        assert!(close(p, 0.04088813291185591, 1e-9), "{p}");
    }

    #[test]
    fn wilcoxon_small_cases_by_hand() {
        // n = 3, all positive: W⁻ = 0; P(W⁻ ≤ 0) = 1/8, two-sided 1/4.
        let r = wilcoxon(&[1.0, 2.0, 3.0]).unwrap();
        assert_eq!((r.w_plus, r.w_minus, r.p), (6.0, 0.0, 0.25));
        assert_eq!(min_exact_p(3), 0.25);
        // n = 5 all negative: 2/32.
        let r = wilcoxon(&[-0.1, -0.2, -0.3, -0.4, -0.5]).unwrap();
        assert_eq!((r.w_plus, r.direction(), r.p), (0.0, -1.0, 0.0625));
        // Ranks 1..4 of |d| = 1, 2, 3, 4 with signs + − + +: W⁻ = 2. Subsets of {1,2,3,4}
        // with sum ≤ 2: {}, {1}, {2} → 3 of 16; p = 2 · 3/16 = 0.375.
        let r = wilcoxon(&[1.0, -2.0, 3.0, 4.0]).unwrap();
        assert_eq!((r.w_plus, r.w_minus, r.statistic()), (8.0, 2.0, 2.0));
        assert_eq!(r.p, 0.375);
        // Signs + − + −: W⁺ = 1 + 3 = 4, W⁻ = 6; sums ≤ 4: {}, {1}, {2}, {3}, {4}, {1,2}, {1,3}
        // → 7 of 16, p = 14/16.
        let r = wilcoxon(&[1.0, -1.5, 2.0, -2.5]).unwrap();
        assert_eq!(r.p, 0.875);
        // Balanced, W⁺ = W⁻ = 5: 9 of 16 sums ≤ 5, 2 · 9/16 clamped to 1.
        let r = wilcoxon(&[1.0, -2.0, -3.0, 4.0]).unwrap();
        assert_eq!((r.w_plus, r.p), (5.0, 1.0));
    }

    #[test]
    fn wilcoxon_drops_zeros_and_corrects_ties_by_hand() {
        // d = 0, 0, 1, 1, 2, −3, 4, 4, 5: the zeros are dropped (Wilcoxon), n = 7.
        // Ranks of |d| 1, 1, 2, 3, 4, 4, 5: 1.5, 1.5, 3, 4, 5.5, 5.5, 7; W⁻ = 4, W⁺ = 24.
        // Mean 7·8/4 = 14; variance 7·8·15/24 − (2³−2 + 2³−2)/48 = 35 − 0.25 = 34.75;
        // z = (|24 − 14| − 0.5)/√34.75 = 1.6115590; p = 2(1 − Φ(z)) = erfc(z/√2) = 0.1070579460
        // (Python's math.erfc).
        let r = wilcoxon(&[0.0, 0.0, 1.0, 1.0, 2.0, -3.0, 4.0, 4.0, 5.0]).unwrap();
        assert_eq!((r.n, r.zeros, r.w_plus, r.w_minus), (7, 2, 24.0, 4.0));
        assert!(!r.exact);
        assert!(close(r.p, 0.107_057_946, 1e-9), "{}", r.p);
        // All zero: nothing to test.
        let r = wilcoxon(&[0.0, 0.0]).unwrap();
        assert_eq!((r.n, r.p), (0, 1.0));
        assert!(wilcoxon(&[]).is_none());
        assert!(wilcoxon(&[f64::NAN]).is_none());
    }

    /// scipy's documentation shows `x - y` splitting a tie by rounding error
    /// (x = [0.5, 0.825, 0.375, 0.5], y = [0.525, 0.775, 0.325, 0.55]); with the tolerance the
    /// differences rank as d = [−0.025, 0.05, 0.05, −0.05] does: W⁺ = 6 (scipy's 'greater'
    /// statistic for the rounded d).
    #[test]
    fn wilcoxon_ties_survive_floating_point_differences() {
        let x = [0.5, 0.825, 0.375, 0.5];
        let y = [0.525, 0.775, 0.325, 0.55];
        let d: Vec<f64> = x.iter().zip(&y).map(|(a, b)| a - b).collect();
        let r = wilcoxon(&d).unwrap();
        assert_eq!((r.w_plus, r.w_minus), (6.0, 4.0));
        assert!(!r.exact);
    }

    #[test]
    fn holm_by_hand() {
        // Sorted 0.01, 0.02, 0.03, 0.04 (m = 4): 0.04, 0.06, 0.06 (monotone), 0.06 (max with
        // 1 · 0.04 = 0.04 and the running 0.06). Input order kept.
        let a = holm(&[0.03, 0.01, 0.04, 0.02]);
        let want = [0.06, 0.04, 0.06, 0.06];
        for (x, w) in a.iter().zip(want) {
            assert!(close(*x, w, 1e-12), "{a:?}");
        }
        // Capped at 1; one p is unchanged.
        assert_eq!(holm(&[0.5, 0.9]), [1.0, 1.0]);
        assert_eq!(holm(&[0.2]), [0.2]);
        assert!(holm(&[]).is_empty());
        let mut p1 = paired(&[vec![1.0, 2.0, 3.0]]).unwrap();
        let mut p2 = paired(&[vec![-1.0, 2.0]]).unwrap();
        holm_in_place(&mut [&mut p1, &mut p2]);
        assert_eq!((p1.p_holm, p2.p_holm), (0.5, 1.0));
    }

    #[test]
    fn bootstrap_two_rooms_by_hand() {
        // Rooms {0} and {1}: a resample is {0,0} (1/4), {0,1} (1/2) or {1,1} (1/4), mean 0, 0.5
        // or 1; the 2.5 % and 97.5 % quantiles of 4000 draws are 0 and 1.
        let ci = mean_ci(&[vec![0.0], vec![1.0]]).unwrap();
        assert_eq!(
            (ci.mean, ci.lo, ci.hi, ci.clusters, ci.n),
            (0.5, 0.0, 1.0, 2, 2)
        );
        // Seeds stay together: rooms {0, 0, 0} and {3} pool to mean 0.75, and a resample is
        // 0 (both the first), 3 (both the second) or 0.75 (one of each), never another value.
        let ci = mean_ci(&[vec![0.0, 0.0, 0.0], vec![3.0]]).unwrap();
        assert_eq!((ci.mean, ci.lo, ci.hi), (0.75, 0.0, 3.0));
    }

    #[test]
    fn bootstrap_contains_mean_is_deterministic_and_narrows_with_rooms() {
        // Rooms with two seeds each, values spread around 0.5.
        let rooms = |k: usize| -> Vec<Vec<f64>> {
            (0..k)
                .map(|i| {
                    let x = 0.5 + 0.2 * (((i * 7919) % 13) as f64 / 12.0 - 0.5);
                    vec![x, x + 0.05]
                })
                .collect()
        };
        let small = mean_ci(&rooms(5)).unwrap();
        assert!(small.lo <= small.mean && small.mean <= small.hi);
        assert!(small.lo < small.hi);
        assert_eq!(mean_ci(&rooms(5)), Some(small));
        let other_seed = bootstrap_mean_ci(&rooms(5), BOOTSTRAP_RESAMPLES, 7).unwrap();
        assert_eq!(other_seed.mean, small.mean);
        let large = mean_ci(&rooms(80)).unwrap();
        assert!(large.lo <= large.mean && large.mean <= large.hi);
        assert!(
            large.hi - large.lo < 0.6 * (small.hi - small.lo),
            "{small:?} {large:?}"
        );
        // All equal: degenerate.
        let ci = mean_ci(&[vec![0.3, 0.3], vec![0.3], vec![0.3, 0.3]]).unwrap();
        assert_eq!((ci.lo, ci.mean, ci.hi), (0.3, 0.3, 0.3));
        assert!(ci.excludes_zero());
        assert!(!mean_ci(&[vec![-0.1], vec![0.2]]).unwrap().excludes_zero());
        assert!(mean_ci(&[vec![], vec![f64::NAN]]).is_none());
        // One room: nothing to resample.
        let ci = mean_ci(&[vec![1.0, 2.0]]).unwrap();
        assert_eq!((ci.lo, ci.mean, ci.hi), (1.5, 1.5, 1.5));
    }

    #[test]
    fn paired_combines_ci_and_test() {
        // Twelve rooms, two seeds, every difference +0.1 ± small: significant, CI excludes 0.
        let clusters: Vec<Vec<f64>> = (0..12)
            .map(|i| vec![0.1 + 0.001 * i as f64, 0.1 - 0.0005 * i as f64])
            .collect();
        let p = paired(&clusters).unwrap();
        assert!(p.significant() && p.ci.excludes_zero());
        assert_eq!(p.test.n, 24);
        assert_eq!(p.test.direction(), 1.0);
    }
}
