//! Frontier exploration (Yamauchi 1997) on the exploration grid built from depth.
//!
//! Frontier cells are FREE cells with an UNKNOWN 4-neighbour. They are grouped into 8-connected
//! clusters; clusters smaller than `min_cells` are noise, and cells within `blacklist_radius` of
//! an earlier frontier goal are ignored (a frontier that survived a visit cannot be cleared from
//! there). For every remaining cluster the goal is its reachable cell (on the inflated navigation
//! grid) nearest its centroid; clusters without a reachable cell are dropped, and the least
//! `path − gain_weight × frontier length` wins (near and informative). Since every goal is
//! blacklisted when issued (reached or refused), exploration ends: no reachable frontier is left. The goal yaw points from
//! the robot to the goal, so a forward-fixed camera arrives looking at the frontier.
//!
//!
//! Three rules keep exploration from driving where nothing can be learnt (`[planner.frontier]`):
//! - `reachable_unknown`: an UNKNOWN cell makes a frontier only where the base could drive
//!   (finite path on the inflated navigation grid, [`frontiers_in`]). The face of a wall that no
//!   depth ray hit leaves free cells bordering the unknown space behind the wall; no drive can
//!   clear those.
//! - `min_unknown_area_m2`: unknown pockets smaller than this (4-connected) make no frontier.
//! - `seen_radius`: a frontier goal being driven to is dropped once no frontier cell is left
//!   within this distance of it ([`frontier_near`]): the camera saw it on the way, the next round
//!   chooses the next frontier.
//!
//! An exploration grid with no known cell at all (nothing integrated yet, e.g. SLAM not tracking
//! at the start) is not an explored room: the round waits ([`any_known`]).
//!
//! Used by the frontier baseline and by VP-SOM and coverage to explore whenever no unfinished
//! cluster is known (before, between and after their clusters).

use crate::evaluate::Scoring;
use crate::reach::{NavMap, NavParams};
use shm_types::{Candidate, OccupancyGrid, grid_cell};

/// Parameters of frontier selection.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrontierParams {
    /// Minimum cells of a frontier cluster.
    pub min_cells: usize,
    /// Blacklist radius around earlier goals, metres.
    pub blacklist_radius: f32,
    /// A frontier's length (cells × resolution) counts as this many metres less path.
    pub gain_weight: f32,
    /// Unknown regions (4-connected UNKNOWN cells) smaller than this, m², make no frontier: a
    /// pocket too small to hide a support cluster (0: every unknown cell counts).
    pub min_unknown_area_m2: f32,
    /// Only UNKNOWN cells the base can reach make frontiers ([`frontiers_in`]).
    pub reachable_unknown: bool,
    /// Reading of the navigation grid.
    pub nav: NavParams,
}

impl FrontierParams {
    /// From the `[planner]` configuration.
    pub fn new(cfg: &crate::config::PlannerConfig) -> Self {
        Self {
            min_cells: cfg.frontier.min_cells,
            blacklist_radius: cfg.frontier.blacklist_radius,
            gain_weight: cfg.frontier.gain_weight,
            min_unknown_area_m2: cfg.frontier.min_unknown_area_m2,
            reachable_unknown: cfg.frontier.reachable_unknown,
            nav: NavParams::new(cfg),
        }
    }
}

/// A frontier cluster.
#[derive(Debug, Clone, PartialEq)]
pub struct Frontier {
    /// Cell indices (exploration grid).
    pub cells: Vec<usize>,
    /// Centroid, world xy.
    pub centroid: [f32; 2],
}

fn is_free(v: u8) -> bool {
    v != grid_cell::UNKNOWN && v < 50
}

fn cell_center(g: &OccupancyGrid, i: usize) -> [f32; 2] {
    let w = g.width as usize;
    [
        g.origin[0] + ((i % w) as f32 + 0.5) * g.resolution,
        g.origin[1] + ((i / w) as f32 + 0.5) * g.resolution,
    ]
}

/// For every cell, whether it is UNKNOWN and part of a 4-connected unknown region of at least
/// `min_cells` cells.
fn large_unknown(cells: &[u8], w: usize, h: usize, min_cells: usize) -> Vec<bool> {
    let mut large = vec![false; w * h];
    let mut seen = vec![false; w * h];
    let (mut stack, mut region) = (Vec::new(), Vec::new());
    for s in 0..w * h {
        if seen[s] || cells[s] != grid_cell::UNKNOWN {
            continue;
        }
        seen[s] = true;
        stack.push(s);
        region.clear();
        while let Some(i) = stack.pop() {
            region.push(i);
            let (x, y) = (i % w, i / w);
            let mut visit = |j: usize| {
                if !seen[j] && cells[j] == grid_cell::UNKNOWN {
                    seen[j] = true;
                    stack.push(j);
                }
            };
            if x > 0 {
                visit(i - 1);
            }
            if x + 1 < w {
                visit(i + 1);
            }
            if y > 0 {
                visit(i - w);
            }
            if y + 1 < h {
                visit(i + w);
            }
        }
        if region.len() >= min_cells {
            for &i in &region {
                large[i] = true;
            }
        }
    }
    large
}

/// Whether the grid has any known (free or occupied) cell: an all-unknown grid (nothing
/// integrated yet, e.g. localization not yet tracking) is not an explored room.
pub fn any_known(g: &OccupancyGrid) -> bool {
    g.used().iter().any(|&c| c != grid_cell::UNKNOWN)
}

/// Whether a frontier cell lies within `radius` of `xy` (the goal of a frontier round is still
/// worth driving to; once its neighbourhood is seen, it is not).
pub fn frontier_near(g: &OccupancyGrid, xy: [f32; 2], radius: f32) -> bool {
    let (w, h) = (g.width as usize, g.height as usize);
    let cells = g.used();
    if cells.len() != w * h || w == 0 || h == 0 || g.resolution <= 0.0 {
        return false;
    }
    let to_cell = |v: f32, o: f32| ((v - o) / g.resolution).floor() as isize;
    let (cx, cy) = (to_cell(xy[0], g.origin[0]), to_cell(xy[1], g.origin[1]));
    let r = (radius / g.resolution).ceil() as isize;
    let unknown = |x: isize, y: isize| {
        x >= 0
            && y >= 0
            && (x as usize) < w
            && (y as usize) < h
            && cells[y as usize * w + x as usize] == grid_cell::UNKNOWN
    };
    for y in (cy - r).max(0)..=(cy + r).min(h as isize - 1) {
        for x in (cx - r).max(0)..=(cx + r).min(w as isize - 1) {
            if (x - cx).pow(2) + (y - cy).pow(2) > r * r {
                continue;
            }
            let v = cells[y as usize * w + x as usize];
            if is_free(v)
                && (unknown(x - 1, y)
                    || unknown(x + 1, y)
                    || unknown(x, y - 1)
                    || unknown(x, y + 1))
            {
                return true;
            }
        }
    }
    false
}

/// Frontier clusters of the exploration grid, without blacklisted cells, largest first (every
/// UNKNOWN cell counts: see [`frontiers_in`]).
pub fn frontiers(g: &OccupancyGrid, blacklist: &[[f32; 2]], p: &FrontierParams) -> Vec<Frontier> {
    frontiers_in(g, blacklist, p, None)
}

/// Frontier clusters of the exploration grid, without blacklisted cells, largest first. With
/// `nav` (flooded from the robot) and `frontier.reachable_unknown`, an UNKNOWN cell counts only
/// where the base could drive (finite path length on the inflated navigation grid): space
/// behind walls or inside an obstacle's inflation band cannot be explored, so a free cell
/// bordering only such cells (an outer wall whose face the depth rays missed) is no frontier.
pub fn frontiers_in(
    g: &OccupancyGrid,
    blacklist: &[[f32; 2]],
    p: &FrontierParams,
    nav: Option<&NavMap>,
) -> Vec<Frontier> {
    let (w, h) = (g.width as usize, g.height as usize);
    let cells = g.used();
    if cells.len() != w * h || w == 0 || h == 0 {
        return Vec::new();
    }
    let r2 = p.blacklist_radius * p.blacklist_radius;
    let min_unknown = (p.min_unknown_area_m2 / (g.resolution * g.resolution).max(1e-9)).ceil();
    let large = (min_unknown > 1.0).then(|| large_unknown(cells, w, h, min_unknown as usize));
    let mut front = vec![false; w * h];
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            if !is_free(cells[i]) {
                continue;
            }
            let unknown = |xx: usize, yy: usize| {
                let j = yy * w + xx;
                cells[j] == grid_cell::UNKNOWN
                    && large.as_ref().is_none_or(|l| l[j])
                    && nav.is_none_or(|n| {
                        !p.reachable_unknown
                            || n.is_empty()
                            || n.path_length(cell_center(g, j)).is_some()
                    })
            };
            let near_unknown = (x > 0 && unknown(x - 1, y))
                || (x + 1 < w && unknown(x + 1, y))
                || (y > 0 && unknown(x, y - 1))
                || (y + 1 < h && unknown(x, y + 1));
            if near_unknown {
                let c = cell_center(g, i);
                let banned = blacklist
                    .iter()
                    .any(|b| (b[0] - c[0]).powi(2) + (b[1] - c[1]).powi(2) <= r2);
                front[i] = !banned;
            }
        }
    }
    let mut seen = vec![false; w * h];
    let mut out = Vec::new();
    let mut stack = Vec::new();
    for s in 0..w * h {
        if !front[s] || seen[s] {
            continue;
        }
        seen[s] = true;
        stack.push(s);
        let mut members = Vec::new();
        while let Some(i) = stack.pop() {
            members.push(i);
            let (x, y) = ((i % w) as isize, (i / w) as isize);
            for dy in -1..=1isize {
                for dx in -1..=1isize {
                    let (nx, ny) = (x + dx, y + dy);
                    if nx < 0 || ny < 0 || nx >= w as isize || ny >= h as isize {
                        continue;
                    }
                    let j = ny as usize * w + nx as usize;
                    if front[j] && !seen[j] {
                        seen[j] = true;
                        stack.push(j);
                    }
                }
            }
        }
        if members.len() >= p.min_cells {
            let mut c = [0.0f32; 2];
            for i in &members {
                let m = cell_center(g, *i);
                c[0] += m[0];
                c[1] += m[1];
            }
            let n = members.len() as f32;
            out.push(Frontier {
                cells: members,
                centroid: [c[0] / n, c[1] / n],
            });
        }
    }
    out.sort_by_key(|f| std::cmp::Reverse(f.cells.len()));
    out
}

/// Choose the reachable frontier of least cost `path length − gain_weight × frontier length`
/// (near and informative; `gain_weight` 0: the nearest): goal `[x, y, yaw]` and path length.
/// A frontier none of whose cells is reachable is skipped.
pub fn choose(
    g: &OccupancyGrid,
    fronts: &[Frontier],
    nav: &NavMap,
    base: [f32; 3],
    gain_weight: f32,
) -> Option<([f32; 3], f32)> {
    let mut best_cost = f32::INFINITY;
    let mut best: Option<([f32; 2], f32)> = None;
    for f in fronts {
        let mut pick: Option<([f32; 2], f32)> = None;
        for &i in &f.cells {
            let c = cell_center(g, i);
            if !nav.reachable(c) {
                continue;
            }
            let d2 = (c[0] - f.centroid[0]).powi(2) + (c[1] - f.centroid[1]).powi(2);
            if pick.is_none_or(|(_, bd)| d2 < bd) {
                pick = Some((c, d2));
            }
        }
        if let Some((c, _)) = pick {
            let len = nav.path_length(c).unwrap_or(f32::INFINITY);
            let cost = len - gain_weight * f.cells.len() as f32 * g.resolution;
            if len.is_finite() && (best.is_none() || cost < best_cost) {
                best = Some((c, len));
                best_cost = cost;
            }
        }
    }
    best.map(|(c, len)| {
        let (dx, dy) = (c[0] - base[0], c[1] - base[1]);
        let yaw = if dx * dx + dy * dy > 1e-6 {
            dy.atan2(dx)
        } else {
            base[2]
        };
        ([c[0], c[1], yaw], len)
    })
}

/// One frontier selection as an owned job.
#[derive(Debug)]
pub struct FrontierJob {
    /// Exploration grid snapshot (with UNKNOWN cells).
    pub explore: Box<OccupancyGrid>,
    /// Navigation grid snapshot.
    pub nav: Box<OccupancyGrid>,
    /// Robot base pose.
    pub base: [f32; 3],
    /// Earlier frontier goals.
    pub blacklist: Vec<[f32; 2]>,
    /// Parameters.
    pub params: FrontierParams,
    /// Evaluate the goal's view (neck forward) for the trace, if given (the frontier baseline).
    pub scoring: Option<Scoring>,
}

/// Outcome of a [`FrontierJob`].
#[derive(Debug)]
pub struct FrontierResult {
    /// Goal pose and path length, `None` if no reachable frontier remains.
    pub goal: Option<([f32; 3], f32)>,
    /// Frontier clusters found (reachable or not).
    pub frontiers: usize,
    /// Whether the exploration grid had any known cell ([`any_known`]).
    pub known: bool,
    /// Buffers handed back for reuse.
    pub explore: Box<OccupancyGrid>,
    /// Buffers handed back for reuse.
    pub nav: Box<OccupancyGrid>,
    /// The goal's view evaluated with the job's scoring (no tracked cluster), if both exist.
    pub view: Option<Candidate>,
    /// The scoring, handed back for reuse.
    pub scoring: Option<Scoring>,
}

impl FrontierJob {
    /// Run the selection.
    pub fn run(self) -> FrontierResult {
        let p = self.params;
        let nav = p.nav.flooded(&self.nav, [self.base[0], self.base[1]]);
        let fronts = frontiers_in(&self.explore, &self.blacklist, &p, Some(&nav));
        let goal = choose(&self.explore, &fronts, &nav, self.base, p.gain_weight);
        let view = goal
            .zip(self.scoring.as_ref())
            .map(|((pose, _), s)| s.chosen(pose, 0.0, None));
        FrontierResult {
            goal,
            frontiers: fronts.len(),
            known: any_known(&self.explore),
            explore: self.explore,
            nav: self.nav,
            view,
            scoring: self.scoring,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use shm_types::boxed_zeroed;

    fn params() -> FrontierParams {
        FrontierParams {
            min_cells: 3,
            blacklist_radius: 0.5,
            gain_weight: 0.0,
            min_unknown_area_m2: 0.0,
            reachable_unknown: false,
            nav: NavParams {
                robot_radius: 0.2,
                inflated: false,
                unknown_traversable: true,
            },
        }
    }

    /// 3 m × 2 m at 0.1 m: the left third is known free, the rest unknown; a small unknown hole
    /// of one cell (frontier of 4 cells, noise-sized at min 5) sits in the free part.
    fn grid() -> Box<OccupancyGrid> {
        let mut g = boxed_zeroed::<OccupancyGrid>();
        g.resolution = 0.1;
        g.width = 30;
        g.height = 20;
        for y in 0..20 {
            for x in 0..30 {
                g.cells[y * 30 + x] = if x < 10 {
                    grid_cell::FREE
                } else {
                    grid_cell::UNKNOWN
                };
            }
        }
        g.cells[10 * 30 + 4] = grid_cell::UNKNOWN;
        g
    }

    #[test]
    fn frontier_cells_cluster_and_nearest_reachable_wins() {
        let g = grid();
        let mut p = params();
        let f = frontiers(&g, &[], &p);
        assert_eq!(f.len(), 2);
        assert_eq!(f[0].cells.len(), 20, "column x = 9");
        assert!((f[0].centroid[0] - 0.95).abs() < 1e-5 && (f[0].centroid[1] - 1.0).abs() < 1e-5);
        p.min_cells = 5;
        let f = frontiers(&g, &[], &p);
        assert_eq!(f.len(), 1, "the hole's 4 cells are noise");
        let nav = boxed_zeroed::<OccupancyGrid>();
        let mut m = NavMap::new(&nav, 0.2, true);
        m.flood_from([0.2, 1.0], 0.2);
        let (goal, len) = choose(&g, &f, &m, [0.2, 1.0, 2.0], 0.0).unwrap();
        assert!(
            (goal[0] - 0.95).abs() < 1e-5 && (goal[1] - 1.0).abs() < 0.06,
            "{goal:?}"
        );
        assert!(goal[2].abs() < 0.1 && (len - 0.75).abs() < 0.06);
        // Blacklisting around the goal splits the column; a wide radius removes everything.
        assert_eq!(frontiers(&g, &[[0.95, 1.0]], &p).len(), 2);
        let p5 = FrontierParams {
            blacklist_radius: 1.5,
            ..p
        };
        assert!(frontiers(&g, &[[0.95, 1.0]], &p5).is_empty());
    }
}
