//! Segmentation of an object's points inside a detection box (box-only detections, as a
//! YOLO-class detector gives), after EAO-SLAM / QuadricSLAM practice: a box holds the object and
//! whatever lies around and behind it — the table it stands on, the floor, the wall, neighbours.
//!
//! On the box's sampled points (already off the floor and, for foreground objects, off the known
//! supporting planes and the band under them, see [`super::points`]):
//! 1. **planes** — a height histogram (bin `plane_bin`) finds the dominant horizontal plane.
//!    Tables (class prior `plane`): the densest plane at a plausible table height is the table
//!    top; only its points are kept. Foreground objects: a dominant plane with points above it is
//!    a support seen for the first time; it is removed with everything under it.
//!    Other background classes (chairs, couches, beds) keep their seat planes.
//! 2. **depth clusters** — 4-connected components of the image sample grid, neighbours joined
//!    when their depths are continuous (as in the mask path).
//! 3. **choice** — each cluster is scored by how much of the box it spans (width × height),
//!    how central it is (a box is centred on its object's visible part, in both axes), how near (an object occludes what is behind it), its share of the
//!    points and how well its 3D extent fits the class size prior ([`super::priors`]); the best
//!    one is the object.
//! 4. **split** (`[mapper.extensions] split_oversize`) — a chosen cluster longer along its
//!    horizontal principal axis than `split_factor` × the prior's long side, with a band of
//!    `split_gap` (and 2.5 sample spacings) across that axis holding under a quarter of the mean
//!    density (mixed pixels only) and ≥ 15 % of its points on each side, is two objects (same-class neighbours in one NMS-merged box, or overlapping
//!    boxes): it is cut there and the part scoring best as in step 3 is kept.
//! 5. **outliers** — points farther horizontally from the cluster's median than
//!    `outlier_factor` × the prior's half diagonal are dropped (mixed pixels, bridges).

use super::config::SegmentationConfig;
use super::points::{PointScratch, find};
use super::priors::SizePrior;
use glam::Vec3;

/// Sample-grid geometry of a box.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Grid {
    /// Samples along x.
    pub gw: usize,
    /// Samples along y.
    pub gh: usize,
}

/// Statistics of one depth cluster.
#[derive(Debug, Clone, Copy)]
struct Cluster {
    root: u32,
    n: u32,
    gx: [u32; 2],
    gy: [u32; 2],
    sum_gx: f32,
    sum_gy: f32,
    sum_depth: f32,
    lo: Vec3,
    hi: Vec3,
}

impl Cluster {
    /// A cluster with no member yet.
    fn empty(root: u32) -> Self {
        Self {
            root,
            n: 0,
            gx: [u32::MAX, 0],
            gy: [u32::MAX, 0],
            sum_gx: 0.0,
            sum_gy: 0.0,
            sum_depth: 0.0,
            lo: Vec3::splat(f32::INFINITY),
            hi: Vec3::splat(f32::NEG_INFINITY),
        }
    }

    /// Add one point: its sample-grid cell `(gx, gy)`, camera depth and world position.
    fn add(&mut self, gx: u32, gy: u32, depth: f32, p: Vec3) {
        self.n += 1;
        self.gx = [self.gx[0].min(gx), self.gx[1].max(gx)];
        self.gy = [self.gy[0].min(gy), self.gy[1].max(gy)];
        self.sum_gx += gx as f32;
        self.sum_gy += gy as f32;
        self.sum_depth += depth;
        self.lo = self.lo.min(p);
        self.hi = self.hi.max(p);
    }
}

/// Peak of a height histogram: (plane height, points within ± one bin of it).
fn height_peak(zs: impl Iterator<Item = f32> + Clone, bin: f32, lo: f32, hi: f32) -> (f32, u32) {
    let nb = (((hi - lo) / bin).ceil() as usize).clamp(1, 512);
    let mut hist = [0u32; 512];
    for z in zs.clone() {
        if z >= lo && z < hi {
            hist[(((z - lo) / bin) as usize).min(nb - 1)] += 1;
        }
    }
    let win = |b: usize| {
        hist[b.saturating_sub(1)..(b + 2).min(nb)]
            .iter()
            .sum::<u32>()
    };
    let best = (0..nb)
        .max_by_key(|b| (win(*b), std::cmp::Reverse(*b)))
        .unwrap_or(0);
    let (a, b) = (
        lo + best.saturating_sub(1) as f32 * bin,
        lo + (best + 2).min(nb) as f32 * bin,
    );
    let (mut s, mut n) = (0.0, 0u32);
    for z in zs.filter(|z| *z >= a && *z < b) {
        s += z;
        n += 1;
    }
    ((s / n.max(1) as f32), n)
}

impl PointScratch {
    fn drop_point(&mut self, i: usize) {
        self.grid[self.cell[i] as usize] = u32::MAX;
    }

    fn alive(&self, i: usize) -> bool {
        self.grid[self.cell[i] as usize] == i as u32
    }

    /// Step 1: plane handling (see the module docs).
    fn remove_planes(&mut self, prior: &SizePrior, foreground: bool, seg: &SegmentationConfig) {
        let n = self.raw.len();
        let zs = self.raw.iter().map(|p| p.z);
        if prior.plane && !foreground {
            let [lo, hi] = seg.table_heights;
            let (h, count) = height_peak(zs, seg.plane_bin, lo, hi);
            if (count as f32) < seg.plane_min_fraction * n as f32 {
                return;
            }
            let band = 1.5 * seg.plane_bin;
            for i in 0..n {
                if (self.raw[i].z - h).abs() > band {
                    self.drop_point(i);
                }
            }
        } else if foreground {
            let lo = self.raw.iter().map(|p| p.z).fold(f32::INFINITY, f32::min);
            let hi = self
                .raw
                .iter()
                .map(|p| p.z)
                .fold(f32::NEG_INFINITY, f32::max);
            let (h, count) = height_peak(zs, seg.plane_bin, lo, hi + 1e-3);
            let band = 1.5 * seg.plane_bin;
            let above = self.raw.iter().filter(|p| p.z > h + band).count();
            if (count as f32) < seg.plane_min_fraction * n as f32
                || (above as f32) < seg.above_min_fraction * n as f32
            {
                return;
            }
            for i in 0..n {
                if self.raw[i].z <= h + band {
                    self.drop_point(i);
                }
            }
        }
    }

    /// Segment the object out of its box into `out` (see the module docs).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn segment_box(
        &mut self,
        grid: Grid,
        prior: &SizePrior,
        foreground: bool,
        seg: &SegmentationConfig,
        gap_min: f32,
        gap_per_m: f32,
        spacing_per_m: f32,
        out: &mut Vec<Vec3>,
    ) {
        out.clear();
        let n = self.raw.len();
        if n == 0 {
            return;
        }
        self.remove_planes(prior, foreground, seg);
        self.connect(grid.gw, grid.gh, gap_min, gap_per_m);
        // Cluster statistics, indexed through `weight` (root → cluster slot + 1).
        self.weight.clear();
        self.weight.resize(n, 0);
        let mut clusters: Vec<Cluster> = Vec::new();
        let mut alive = 0u32;
        let mut near = f32::INFINITY;
        for i in 0..n {
            if !self.alive(i) {
                continue;
            }
            alive += 1;
            let r = find(&mut self.parent, i as u32);
            let slot = match self.weight[r as usize] {
                0 => {
                    clusters.push(Cluster::empty(r));
                    self.weight[r as usize] = clusters.len() as u32;
                    clusters.len() - 1
                }
                s => s as usize - 1,
            };
            let cell = self.cell[i] as usize;
            let (gx, gy) = ((cell % grid.gw) as u32, (cell / grid.gw) as u32);
            clusters[slot].add(gx, gy, self.depth[i], self.raw[i]);
        }
        let min_n = (alive as f32 * 0.02).max(3.0) as u32;
        for c in clusters.iter().filter(|c| c.n >= min_n) {
            near = near.min(c.sum_depth / c.n as f32);
        }
        let (cx, cy) = ((grid.gw as f32 - 1.0) * 0.5, (grid.gh as f32 - 1.0) * 0.5);
        let score = |c: &Cluster| {
            let cover_w = (c.gx[1] - c.gx[0] + 1) as f32 / grid.gw as f32;
            let cover_h = (c.gy[1] - c.gy[0] + 1) as f32 / grid.gh as f32;
            let (mx, my) = (c.sum_gx / c.n as f32, c.sum_gy / c.n as f32);
            // A box is centred on its object in both axes (its visible part).
            let off = |m: f32, c: f32| 1.0 - ((m - c).abs() / c.max(0.5)).min(1.0);
            let central = off(mx, cx) * off(my, cy);
            let nearness = near / (c.sum_depth / c.n as f32);
            let e = c.hi - c.lo;
            let (long, short) = (e.x.max(e.y), e.x.min(e.y));
            let fit = prior.fit(long, short, e.z);
            let share = (c.n as f32 / alive as f32).sqrt();
            cover_w * cover_h * central * nearness * fit * share
        };
        let Some(best) = clusters
            .iter()
            .filter(|c| c.n >= min_n)
            .max_by(|a, b| score(a).total_cmp(&score(b)).then(b.root.cmp(&a.root)))
            .map(|c| c.root)
        else {
            return;
        };
        let mut members: Vec<usize> = Vec::new();
        for i in 0..n {
            if self.alive(i) && find(&mut self.parent, i as u32) == best {
                members.push(i);
            }
        }
        if seg.split {
            let z = members.iter().map(|&i| self.depth[i]).sum::<f32>() / members.len() as f32;
            let gap = seg.split_gap.max(2.5 * spacing_per_m * z);
            if let Some(cut) = split_at_gap(
                &self.raw,
                &mut members,
                seg.split_factor * prior.size[0],
                gap,
            ) {
                let stats = |part: &[usize]| {
                    let mut c = Cluster::empty(0);
                    for &i in part {
                        let cell = self.cell[i] as usize;
                        let (gx, gy) = ((cell % grid.gw) as u32, (cell / grid.gw) as u32);
                        c.add(gx, gy, self.depth[i], self.raw[i]);
                    }
                    c
                };
                let (a, b) = members.split_at(cut);
                let keep_a = score(&stats(a)) >= score(&stats(b));
                members = if keep_a { a.to_vec() } else { b.to_vec() };
            }
        }
        out.extend(members.iter().map(|&i| self.raw[i]));
        reject_outliers(out, prior.half_diagonal() * seg.outlier_factor + 0.02);
    }
}

/// Smallest share of a split cluster's points on either side of the cut (a partly hidden
/// neighbour still shows its front face).
const MIN_PART: f32 = 0.15;

/// A split band holds at most this fraction of the cluster's mean point density.
const VALLEY: f32 = 0.25;

/// Split `members` (indices into `pts`) when their horizontal extent along the principal axis
/// exceeds `max_len` and a band of width `gap` across that axis, with ≥ [`MIN_PART`] of the
/// points on each side, holds at most [`VALLEY`] × the mean density (the sparsest such band). Sorts `members` along the axis and returns the
/// index of the first member of the second part.
fn split_at_gap(pts: &[Vec3], members: &mut [usize], max_len: f32, gap: f32) -> Option<usize> {
    let n = members.len();
    if n < 10 {
        return None;
    }
    let m = members
        .iter()
        .map(|&i| pts[i].truncate())
        .sum::<glam::Vec2>()
        / n as f32;
    let (mut sxx, mut sxy, mut syy) = (0.0f32, 0.0f32, 0.0f32);
    for &i in members.iter() {
        let d = pts[i].truncate() - m;
        sxx += d.x * d.x;
        sxy += d.x * d.y;
        syy += d.y * d.y;
    }
    // Principal axis of the 2 × 2 covariance.
    let angle = 0.5 * (2.0 * sxy).atan2(sxx - syy);
    let axis = glam::Vec2::from_angle(angle);
    let t = |i: usize| (pts[i].truncate() - m).dot(axis);
    members.sort_by(|a, b| t(*a).total_cmp(&t(*b)));
    let min_side = (n as f32 * MIN_PART).ceil() as usize;
    let (lo, hi) = (t(members[n / 50]), t(members[n - 1 - n / 50]));
    if hi - lo <= max_len {
        return None;
    }
    // The sparsest band of width `gap` between the two sides: a gap between two objects holds
    // at most a few mixed (flying) pixels, a quarter of the cluster's mean density at most.
    let mean = n as f32 * gap / (hi - lo);
    let mut best: Option<(usize, usize)> = None;
    let mut j = min_side;
    for k in min_side..n - min_side {
        // members[k..j] lie within `gap` after members[k - 1].
        j = j.max(k);
        while j < n && t(members[j]) - t(members[k - 1]) < gap {
            j += 1;
        }
        let inside = j - k;
        if j <= n - min_side && best.is_none_or(|(c, _)| inside < c) {
            best = Some((inside, k));
        }
    }
    let (count, k) = best?;
    (count as f32 <= VALLEY * mean).then_some(k + count / 2)
}

/// Drop points farther than `radius` (horizontally) from the median point.
fn reject_outliers(pts: &mut Vec<Vec3>, radius: f32) {
    if pts.len() < 5 {
        return;
    }
    let median = |f: fn(&Vec3) -> f32, v: &[Vec3]| {
        let mut a: Vec<f32> = v.iter().map(f).collect();
        let k = a.len() / 2;
        *a.select_nth_unstable_by(k, f32::total_cmp).1
    };
    let (mx, my) = (median(|p| p.x, pts), median(|p| p.y, pts));
    let r2 = radius * radius;
    pts.retain(|p| (p.x - mx).powi(2) + (p.y - my).powi(2) <= r2);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn height_peak_finds_the_plane() {
        let zs: Vec<f32> = (0..100)
            .map(|i| {
                if i < 60 {
                    0.75 + (i % 3) as f32 * 0.002
                } else {
                    0.8 + i as f32 * 0.001
                }
            })
            .collect();
        let (h, n) = height_peak(zs.iter().copied(), 0.01, 0.0, 1.2);
        assert!((h - 0.752).abs() < 0.005, "{h}");
        assert!(n >= 60, "{n}");
    }

    #[test]
    fn a_long_cluster_splits_at_its_gap_and_a_vase_does_not() {
        // Two books 0.2 m long, 5 cm apart along y (diagonal jitter in x).
        let mut pts = Vec::new();
        for k in 0..60 {
            let y = (k % 20) as f32 * 0.01 + if k < 40 { 0.0 } else { 0.25 };
            pts.push(Vec3::new(0.01 * (k % 3) as f32, y, 0.75));
        }
        let mut idx: Vec<usize> = (0..pts.len()).collect();
        let cut = split_at_gap(&pts, &mut idx, 0.36, 0.03).expect("split");
        assert_eq!(cut, 40);
        assert!(idx[..cut].iter().all(|&i| pts[i].y < 0.2));
        // A 0.25 m vase's front arc: long for a 0.12 m prior, but no gap.
        let arc: Vec<Vec3> = (0..40)
            .map(|k| {
                let a = k as f32 / 39.0 * std::f32::consts::PI;
                Vec3::new(0.125 * a.sin(), 0.125 * a.cos(), 0.9)
            })
            .collect();
        let mut idx: Vec<usize> = (0..arc.len()).collect();
        assert_eq!(split_at_gap(&arc, &mut idx, 0.18, 0.03), None);
        // Short enough: never split.
        let mut idx: Vec<usize> = (0..pts.len()).collect();
        assert_eq!(split_at_gap(&pts, &mut idx, 0.5, 0.03), None);
    }

    #[test]
    fn outliers_far_from_the_median_are_dropped() {
        let mut pts: Vec<Vec3> = (0..20)
            .map(|i| Vec3::new(i as f32 * 0.005, 0.0, 0.8))
            .collect();
        pts.push(Vec3::new(1.0, 0.0, 0.8));
        reject_outliers(&mut pts, 0.1);
        assert_eq!(pts.len(), 20);
    }
}
