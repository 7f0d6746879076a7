//! One-to-one assignment of estimated objects to ground-truth objects of the same class.

use super::metrics::{EstObject, GtObject};
use serde::{Deserialize, Serialize};

/// Matching thresholds.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MatchParams {
    /// An assigned pair counts as a correct model (precision, recall) when its centre distance is
    /// below this, metres (paper § 7.2: 0.1 m).
    pub success_dist_m: f64,
    /// Pairs farther apart than this are never assigned, metres. IoU and CDE average over every
    /// assigned pair (not only the correct ones: the paper's CDE of 0.534 m can only come from
    /// pairs beyond 0.1 m); this gate keeps an estimate from being paired with a same-class
    /// object across the room.
    pub max_pair_dist_m: f64,
}

impl Default for MatchParams {
    fn default() -> Self {
        Self {
            success_dist_m: 0.1,
            max_pair_dist_m: 1.0,
        }
    }
}

/// One assigned (ground truth, estimate) pair.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pair {
    /// Index into the ground-truth slice.
    pub gt: usize,
    /// Index into the estimate slice.
    pub est: usize,
    /// Centre distance, metres.
    pub distance_m: f64,
}

/// Outcome for one ground-truth object (the `per_object` list of `metrics.json`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ObjectMatch {
    /// Ground-truth name.
    pub name: String,
    /// Class name.
    pub class: String,
    /// Whether the ground-truth object is a background object.
    pub background: bool,
    /// Index of the assigned estimate in the scored list (`map.json` order), if any.
    pub estimate: Option<usize>,
    /// Centre distance to the assigned estimate, metres.
    pub distance_m: Option<f64>,
    /// Aligned 3D IoU with the assigned estimate.
    pub iou: Option<f64>,
    /// Assigned and closer than `success_dist_m` (a correct model).
    pub correct: bool,
}

/// Assign estimates to ground-truth objects of the same class, each at most once.
///
/// Objective (solved exactly with the Hungarian algorithm, class by class), in strict priority:
/// 1. most correct pairs (centre distance < `success_dist_m`), so one-to-one matching never
///    costs a correct model that a different pairing would have kept;
/// 2. most pairs within `max_pair_dist_m`;
/// 3. least total centre distance.
///
/// Returns the pairs sorted by ground-truth index.
pub fn assign(gt: &[GtObject], est: &[EstObject], params: &MatchParams) -> Vec<Pair> {
    let mut classes: Vec<&str> = gt.iter().map(|g| g.class.as_str()).collect();
    classes.sort_unstable();
    classes.dedup();
    let mut pairs = Vec::new();
    for class in classes {
        let gi: Vec<usize> = (0..gt.len()).filter(|&i| gt[i].class == class).collect();
        let ei: Vec<usize> = (0..est.len()).filter(|&j| est[j].class == class).collect();
        if ei.is_empty() {
            continue;
        }
        let dist = |i: usize, j: usize| distance(gt[gi[i]].center, est[ei[j]].center);
        let gate = params.max_pair_dist_m.max(0.0);
        let n = gi.len().min(ei.len()) as f64;
        // Lexicographic weights: a pair is worth A·correct + B − d (see the priorities above).
        let b = (n + 1.0) * gate + 1.0;
        let a = n * b + 1.0;
        let cost: Vec<Vec<f64>> = (0..gi.len())
            .map(|i| {
                (0..ei.len())
                    .map(|j| {
                        let d = dist(i, j);
                        if d <= gate {
                            let correct = if d < params.success_dist_m { a } else { 0.0 };
                            -(correct + b - d)
                        } else {
                            0.0
                        }
                    })
                    .collect()
            })
            .collect();
        for (i, j) in min_cost_assignment(&cost).into_iter().enumerate() {
            if let Some(j) = j {
                let d = dist(i, j);
                if d <= gate {
                    pairs.push(Pair {
                        gt: gi[i],
                        est: ei[j],
                        distance_m: d,
                    });
                }
            }
        }
    }
    pairs.sort_by_key(|p| p.gt);
    pairs
}

/// Euclidean distance of two points, metres, in f64.
pub fn distance(a: [f32; 3], b: [f32; 3]) -> f64 {
    (0..3)
        .map(|k| (f64::from(a[k]) - f64::from(b[k])).powi(2))
        .sum::<f64>()
        .sqrt()
}

/// Minimum-cost assignment of rows to columns (Hungarian algorithm with potentials,
/// O(n² m)). `cost` is a rectangular matrix (rows of equal length); every row is assigned a
/// distinct column when there are at least as many columns as rows, otherwise every column gets
/// a distinct row and the remaining rows get `None`. Returns, per row, its column.
pub fn min_cost_assignment(cost: &[Vec<f64>]) -> Vec<Option<usize>> {
    let rows = cost.len();
    let cols = cost.first().map_or(0, Vec::len);
    if rows == 0 || cols == 0 {
        return vec![None; rows];
    }
    if rows <= cols {
        hungarian(rows, cols, |i, j| cost[i][j])
            .into_iter()
            .map(Some)
            .collect()
    } else {
        let col_to_row = hungarian(cols, rows, |i, j| cost[j][i]);
        let mut out = vec![None; rows];
        for (c, r) in col_to_row.into_iter().enumerate() {
            out[r] = Some(c);
        }
        out
    }
}

/// Hungarian algorithm for `n ≤ m`: returns the column of each row.
fn hungarian(n: usize, m: usize, cost: impl Fn(usize, usize) -> f64) -> Vec<usize> {
    // 1-based potentials; column 0 is a virtual column holding the row being inserted.
    let mut u = vec![0.0f64; n + 1];
    let mut v = vec![0.0f64; m + 1];
    let mut row_of = vec![0usize; m + 1];
    let mut way = vec![0usize; m + 1];
    for i in 1..=n {
        row_of[0] = i;
        let mut j0 = 0usize;
        let mut minv = vec![f64::INFINITY; m + 1];
        let mut used = vec![false; m + 1];
        loop {
            used[j0] = true;
            let i0 = row_of[j0];
            let mut delta = f64::INFINITY;
            let mut j1 = 0usize;
            for j in 1..=m {
                if !used[j] {
                    let cur = cost(i0 - 1, j - 1) - u[i0] - v[j];
                    if cur < minv[j] {
                        minv[j] = cur;
                        way[j] = j0;
                    }
                    if minv[j] < delta {
                        delta = minv[j];
                        j1 = j;
                    }
                }
            }
            for j in 0..=m {
                if used[j] {
                    u[row_of[j]] += delta;
                    v[j] -= delta;
                } else {
                    minv[j] -= delta;
                }
            }
            j0 = j1;
            if row_of[j0] == 0 {
                break;
            }
        }
        loop {
            let j1 = way[j0];
            row_of[j0] = row_of[j1];
            j0 = j1;
            if j0 == 0 {
                break;
            }
        }
    }
    let mut col_of = vec![0usize; n];
    for j in 1..=m {
        if row_of[j] != 0 {
            col_of[row_of[j] - 1] = j - 1;
        }
    }
    col_of
}

#[cfg(test)]
mod tests {
    use super::*;

    fn total(cost: &[Vec<f64>], a: &[Option<usize>]) -> f64 {
        a.iter()
            .enumerate()
            .filter_map(|(i, j)| j.map(|j| cost[i][j]))
            .sum()
    }

    /// Brute force over all injective maps of the smaller side.
    fn brute(cost: &[Vec<f64>]) -> f64 {
        fn rec(cost: &[Vec<f64>], i: usize, used: &mut Vec<bool>) -> f64 {
            if i == cost.len() {
                return 0.0;
            }
            let mut best = f64::INFINITY;
            for j in 0..used.len() {
                if !used[j] {
                    used[j] = true;
                    best = best.min(cost[i][j] + rec(cost, i + 1, used));
                    used[j] = false;
                }
            }
            best
        }
        rec(cost, 0, &mut vec![false; cost[0].len()])
    }

    #[test]
    fn hungarian_is_optimal_on_small_matrices() {
        // Deterministic pseudo-random matrices of shapes up to 5 × 6.
        let mut s = 12345u64;
        let mut next = || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((s >> 33) % 1000) as f64 / 100.0
        };
        for rows in 1..=5 {
            for cols in rows..=6 {
                let cost: Vec<Vec<f64>> = (0..rows)
                    .map(|_| (0..cols).map(|_| next()).collect())
                    .collect();
                let a = min_cost_assignment(&cost);
                let mut cols_used: Vec<usize> = a.iter().map(|j| j.unwrap()).collect();
                cols_used.sort_unstable();
                cols_used.dedup();
                assert_eq!(cols_used.len(), rows, "columns must be distinct");
                assert!((total(&cost, &a) - brute(&cost)).abs() < 1e-9);
            }
        }
    }

    #[test]
    fn more_rows_than_columns_leaves_rows_unassigned() {
        let cost = vec![vec![5.0], vec![1.0], vec![3.0]];
        assert_eq!(min_cost_assignment(&cost), vec![None, Some(0), None]);
        assert_eq!(min_cost_assignment(&[]), Vec::<Option<usize>>::new());
    }
}
