//! Rank-sum test: reference values, size and power.

use rand::SeedableRng;
use rand_distr::{Distribution, Normal};
use rand_pcg::Pcg64;
use vpsom::mapper::wilcoxon::RankScratch;

#[test]
fn matches_scipy_mannwhitneyu_with_ties() {
    // scipy 1.17.1:
    //   mannwhitneyu([0.12, 0.35, 0.35, 0.71, 0.9, 1.4, 2.2, 0.05],
    //                [0.4, 0.35, 1.9, 2.5, 3.1, 0.9, 2.8],
    //                use_continuity=False, alternative='two-sided', method='asymptotic')
    //   -> statistic 12.5, pvalue 0.07157083412648946
    let x = [0.12f32, 0.35, 0.35, 0.71, 0.9, 1.4, 2.2, 0.05];
    let y = [0.4f32, 0.35, 1.9, 2.5, 3.1, 0.9, 2.8];
    let r = RankScratch::default().test(x.into_iter(), y.into_iter());
    assert!((r.u - 12.5).abs() < 1e-9, "U = {}", r.u);
    assert!((r.p - 0.071_570_834_126_489_46).abs() < 1e-6, "p = {}", r.p);
}

fn cloud(rng: &mut Pcg64, n: usize, shift: [f32; 3]) -> Vec<[f32; 3]> {
    let d = Normal::new(0.0f32, 0.05).unwrap();
    (0..n)
        .map(|_| {
            [
                d.sample(rng) + shift[0],
                d.sample(rng) * 0.5 + shift[1],
                d.sample(rng) * 2.0 + shift[2],
            ]
        })
        .collect()
}

#[test]
fn same_distribution_is_accepted_in_at_least_90_percent_of_trials() {
    let mut rng = Pcg64::seed_from_u64(11);
    let mut s = RankScratch::default();
    let trials = 500;
    let accepted = (0..trials)
        .filter(|_| {
            let p = cloud(&mut rng, 300, [0.0; 3]);
            let q = cloud(&mut rng, 500, [0.0; 3]);
            s.test_points(&p, &q, 100).p > 0.05
        })
        .count();
    assert!(accepted * 100 >= trials * 90, "{accepted}/{trials}");
}

#[test]
fn three_sigma_shift_is_rejected_in_at_least_99_percent_of_trials() {
    let mut rng = Pcg64::seed_from_u64(12);
    let mut s = RankScratch::default();
    let trials = 500;
    let rejected = (0..trials)
        .filter(|k| {
            // 3σ of the shifted axis; the axis rotates through x, y, z.
            let axis = k % 3;
            let sigma = [0.05, 0.025, 0.1][axis];
            let mut shift = [0.0; 3];
            shift[axis] = 3.0 * sigma;
            let p = cloud(&mut rng, 300, shift);
            let q = cloud(&mut rng, 500, [0.0; 3]);
            s.test_points(&p, &q, 100).p < 0.05
        })
        .count();
    assert!(rejected * 100 >= trials * 99, "{rejected}/{trials}");
}

#[test]
fn shipped_test_size_keeps_size_and_power() {
    // The mapper subsamples to `max_test_points`; at that size the test must still accept the
    // same distribution ≥ 90 % of the time (α = 0.05) and reject a 3σ shift ≥ 99 % of the time.
    let a = vpsom::mapper::MapperConfig::default().association;
    let max = a.max_test_points as usize;
    let mut rng = Pcg64::seed_from_u64(13);
    let mut s = RankScratch::default();
    let trials = 300;
    let (mut same_ok, mut shift_rejected) = (0, 0);
    for k in 0..trials {
        let q = cloud(&mut rng, 500, [0.0; 3]);
        let p = cloud(&mut rng, 300, [0.0; 3]);
        same_ok += (s.test_points(&p, &q, max).p > a.alpha) as usize;
        let axis = k % 3;
        let mut shift = [0.0; 3];
        shift[axis] = 3.0 * [0.05, 0.025, 0.1][axis];
        let p = cloud(&mut rng, 300, shift);
        shift_rejected += (s.test_points(&p, &q, max).p < a.alpha) as usize;
    }
    assert!(same_ok * 100 >= trials * 90, "{same_ok}/{trials}");
    assert!(
        shift_rejected * 100 >= trials * 99,
        "{shift_rejected}/{trials}"
    );
}
