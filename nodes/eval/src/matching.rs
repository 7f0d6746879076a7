//! One-to-one assignment of estimated objects to ground-truth objects of the same class.

use super::metrics::{EstObject, GtObject};
use pathfinding::kuhn_munkres::kuhn_munkres;
use pathfinding::matrix::Matrix;
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

/// Largest `max_pair_dist_m` taken into account, metres.
const MAX_GATE_M: f64 = 1e9;

/// Assign estimates to ground-truth objects of the same class, each at most once.
///
/// Objective (solved exactly with the Hungarian algorithm, class by class, centre distances
/// rounded to micrometres), in strict priority:
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
        // (Capped far beyond any room, so the integer weights below cannot overflow.)
        let gate = params.max_pair_dist_m.max(0.0); // NaN → 0
        let gate = gate.min(MAX_GATE_M);
        // Lexicographic integer weights (distances in micrometres, so the matching is exact):
        // a pair is worth A·correct + B − d (see the priorities above), a pair beyond the gate 0.
        let um = |m: f64| (m * 1e6).round() as i128;
        let n = gi.len().min(ei.len()) as i128;
        let b = (n + 1) * um(gate) + 1;
        let a = n * b + 1;
        let weights = Matrix::from_fn(gi.len(), ei.len(), |(i, j)| {
            let d = dist(i, j);
            if d <= gate {
                let correct = if d < params.success_dist_m { a } else { 0 };
                correct + b - um(d)
            } else {
                0
            }
        });
        for (i, j) in max_weight_assignment(&weights).into_iter().enumerate() {
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

/// Maximum-weight assignment of rows to columns (Kuhn–Munkres, `pathfinding`). Every row is
/// assigned a distinct column when there are at least as many columns as rows, otherwise every
/// column gets a distinct row and the remaining rows get `None`. Returns, per row, its column.
pub fn max_weight_assignment(weights: &Matrix<i128>) -> Vec<Option<usize>> {
    let (rows, cols) = (weights.rows, weights.columns);
    if rows == 0 || cols == 0 {
        return vec![None; rows];
    }
    if rows <= cols {
        kuhn_munkres(weights).1.into_iter().map(Some).collect()
    } else {
        let mut out = vec![None; rows];
        for (c, r) in kuhn_munkres(&weights.transposed())
            .1
            .into_iter()
            .enumerate()
        {
            out[r] = Some(c);
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn total(w: &Matrix<i128>, a: &[Option<usize>]) -> i128 {
        a.iter()
            .enumerate()
            .filter_map(|(i, j)| j.map(|j| w[(i, j)]))
            .sum()
    }

    /// Brute force over all injective maps of the rows (rows ≤ columns).
    fn brute(w: &Matrix<i128>) -> i128 {
        fn rec(w: &Matrix<i128>, i: usize, used: &mut Vec<bool>) -> i128 {
            if i == w.rows {
                return 0;
            }
            let mut best = i128::MIN;
            for j in 0..used.len() {
                if !used[j] {
                    used[j] = true;
                    best = best.max(w[(i, j)] + rec(w, i + 1, used));
                    used[j] = false;
                }
            }
            best
        }
        rec(w, 0, &mut vec![false; w.columns])
    }

    #[test]
    fn kuhn_munkres_is_optimal_on_small_matrices() {
        // Deterministic pseudo-random matrices of shapes up to 5 × 6, and their transposes.
        let mut s = 12345u64;
        let mut next = || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((s >> 33) % 1000) as i128 - 500
        };
        for rows in 1..=5 {
            for cols in rows..=6 {
                let w = Matrix::from_fn(rows, cols, |_| next());
                let a = max_weight_assignment(&w);
                let mut cols_used: Vec<usize> = a.iter().map(|j| j.unwrap()).collect();
                cols_used.sort_unstable();
                cols_used.dedup();
                assert_eq!(cols_used.len(), rows, "columns must be distinct");
                assert_eq!(total(&w, &a), brute(&w));
                let t = w.transposed();
                let at = max_weight_assignment(&t);
                assert_eq!(at.iter().flatten().count(), rows, "one row per column");
                assert_eq!(total(&t, &at), brute(&w));
            }
        }
    }

    #[test]
    fn more_rows_than_columns_leaves_rows_unassigned() {
        let w = Matrix::from_rows([[-5], [-1], [-3]]).unwrap();
        assert_eq!(max_weight_assignment(&w), vec![None, Some(0), None]);
        assert_eq!(
            max_weight_assignment(&Matrix::<i128>::new(0, 0, 0)),
            Vec::<Option<usize>>::new()
        );
    }
}
