//! Reachability and collision on the navigation grid (obstacles only).
//!
//! Obstacles are cells with a value ≥ 50 other than UNKNOWN (UNKNOWN too unless
//! `nav_unknown_traversable`). The grid may already be a configuration-space map whose obstacles
//! are inflated by the robot radius (the simulator's pre-built map is: `planner.nav_inflated`);
//! otherwise the planner inflates them by the robot radius itself ([`NavParams`]). Inflating an
//! inflated map twice closes every corridor narrower than four robot radii that the base can in
//! fact drive (in paper-scene-2 the passages around the second desk), so the two cases are kept
//! apart. A pose is in collision when its cell is inflated; a pose is reachable when a path of
//! free 8-connected cells leads to it from the robot's cell (`pathfinding`'s Dijkstra with step
//! costs 1 and √2, giving path lengths). The robot may start inside the inflated band (e.g. after odometry
//! drift): cells within the robot radius of the start that are not obstacles themselves are
//! traversable. An empty grid (width or height 0) means "no obstacle information": everything
//! is reachable at straight-line distance.

use pathfinding::directed::dijkstra::dijkstra_all;
use shm_types::{OccupancyGrid, grid_cell};

/// Whether a grid value is an obstacle.
pub fn is_obstacle(v: u8, unknown_is_obstacle: bool) -> bool {
    if v == grid_cell::UNKNOWN {
        unknown_is_obstacle
    } else {
        v >= 50
    }
}

/// How the planner reads the navigation grid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NavParams {
    /// Robot footprint radius, metres: the escape radius around the start, and the inflation
    /// when the grid is not inflated yet.
    pub robot_radius: f32,
    /// Whether the grid's obstacles are already inflated by the robot radius (then the planner
    /// does not inflate them again).
    pub inflated: bool,
    /// Whether UNKNOWN cells are traversable.
    pub unknown_traversable: bool,
}

impl NavParams {
    /// From the `[planner]` configuration.
    pub fn new(cfg: &crate::config::PlannerConfig) -> Self {
        Self {
            robot_radius: cfg.robot_radius,
            inflated: cfg.nav_inflated,
            unknown_traversable: cfg.nav_unknown_traversable,
        }
    }

    /// The radius the planner inflates obstacles by: 0 for an inflated grid, else the robot's.
    pub fn inflation(&self) -> f32 {
        if self.inflated {
            0.0
        } else {
            self.robot_radius
        }
    }

    /// The grid as these parameters read it, flooded from `start` (world xy).
    pub fn flooded(&self, grid: &OccupancyGrid, start: [f32; 2]) -> NavMap {
        let mut m = NavMap::new(grid, self.inflation(), self.unknown_traversable);
        m.flood_from(start, self.robot_radius);
        m
    }
}

/// Inflated navigation grid with a distance field from the robot.
#[derive(Debug, Clone)]
pub struct NavMap {
    origin: [f32; 2],
    res: f32,
    w: usize,
    h: usize,
    /// Cell is an obstacle or within the robot radius of one.
    blocked: Vec<bool>,
    /// Cell is an obstacle.
    hard: Vec<bool>,
    /// Path length from the start (metres), `f32::INFINITY` if unreached.
    dist: Vec<f32>,
    start: [f32; 2],
}

impl NavMap {
    /// Inflate `grid`'s obstacles by `radius` metres.
    pub fn new(grid: &OccupancyGrid, radius: f32, unknown_traversable: bool) -> Self {
        let (w, h) = (grid.width as usize, grid.height as usize);
        let used = grid.used();
        let (w, h) = if used.len() == w * h { (w, h) } else { (0, 0) };
        let res = grid.resolution.max(1e-3);
        let hard: Vec<bool> = used
            .iter()
            .map(|v| is_obstacle(*v, !unknown_traversable))
            .collect();
        let mut blocked = hard.clone();
        let r = (radius / res).ceil() as isize;
        let r2 = (radius / res) * (radius / res);
        // Only obstacle cells with a free 8-neighbour are stamped: the obstacle cell nearest to
        // any free cell is always such a boundary cell, so the result is the same.
        let boundary = |ix: isize, iy: isize| {
            (-1..=1isize).any(|dy| {
                (-1..=1isize).any(|dx| {
                    let (x, y) = (ix + dx, iy + dy);
                    x >= 0
                        && y >= 0
                        && (x as usize) < w
                        && (y as usize) < h
                        && !hard[y as usize * w + x as usize]
                })
            })
        };
        for iy in 0..h as isize {
            for ix in 0..w as isize {
                if !hard[iy as usize * w + ix as usize] || !boundary(ix, iy) {
                    continue;
                }
                for dy in -r..=r {
                    for dx in -r..=r {
                        let (x, y) = (ix + dx, iy + dy);
                        if ((dx * dx + dy * dy) as f32) <= r2
                            && x >= 0
                            && y >= 0
                            && (x as usize) < w
                            && (y as usize) < h
                        {
                            blocked[y as usize * w + x as usize] = true;
                        }
                    }
                }
            }
        }
        Self {
            origin: grid.origin,
            res,
            w,
            h,
            blocked,
            hard,
            dist: vec![f32::INFINITY; w * h],
            start: [0.0, 0.0],
        }
    }

    /// Whether the map has no cells (no obstacle information).
    pub fn is_empty(&self) -> bool {
        self.w == 0 || self.h == 0
    }

    /// Cell index of a world point, `None` outside the grid.
    pub fn cell(&self, p: [f32; 2]) -> Option<usize> {
        let fx = ((p[0] - self.origin[0]) / self.res).floor();
        let fy = ((p[1] - self.origin[1]) / self.res).floor();
        (fx >= 0.0 && fy >= 0.0 && (fx as usize) < self.w && (fy as usize) < self.h)
            .then(|| fy as usize * self.w + fx as usize)
    }

    /// World centre of a cell.
    pub fn center(&self, idx: usize) -> [f32; 2] {
        [
            self.origin[0] + ((idx % self.w) as f32 + 0.5) * self.res,
            self.origin[1] + ((idx / self.w) as f32 + 0.5) * self.res,
        ]
    }

    /// Compute path lengths from `start` (world xy).
    pub fn flood_from(&mut self, start: [f32; 2], radius: f32) {
        self.start = start;
        self.dist.fill(f32::INFINITY);
        let Some(s) = self.cell(start) else {
            return;
        };
        let escape2 = (radius + self.res) * (radius + self.res);
        let traversable = |m: &Self, i: usize| {
            if m.hard[i] {
                return false;
            }
            if !m.blocked[i] {
                return true;
            }
            let c = m.center(i);
            let (dx, dy) = (c[0] - start[0], c[1] - start[1]);
            dx * dx + dy * dy <= escape2
        };
        // Integer costs (10 straight, 14 diagonal) keep the distances exact.
        let (w, h) = (self.w as isize, self.h as isize);
        let this = &*self;
        let steps = |&i: &usize| {
            let (x, y) = ((i % this.w) as isize, (i / this.w) as isize);
            [
                (1, 0, 10),
                (-1, 0, 10),
                (0, 1, 10),
                (0, -1, 10),
                (1, 1, 14),
                (1, -1, 14),
                (-1, 1, 14),
                (-1, -1, 14),
            ]
            .into_iter()
            .filter_map(move |(dx, dy, step)| {
                let (nx, ny) = (x + dx, y + dy);
                if nx < 0 || ny < 0 || nx >= w || ny >= h {
                    return None;
                }
                let j = ny as usize * this.w + nx as usize;
                // No corner cutting between two blocked cells.
                if dx != 0 && dy != 0 {
                    let a = y as usize * this.w + nx as usize;
                    let b = ny as usize * this.w + x as usize;
                    if !traversable(this, a) && !traversable(this, b) {
                        return None;
                    }
                }
                traversable(this, j).then_some((j, step))
            })
        };
        let cost: Vec<(usize, u32)> = dijkstra_all(&s, steps)
            .into_iter()
            .map(|(i, (_, c))| (i, c))
            .collect();
        self.dist[s] = 0.0;
        for (i, c) in cost {
            self.dist[i] = c as f32 / 10.0 * self.res;
        }
    }

    /// Whether a base at `p` would collide (its cell is an obstacle or inflated, or off-grid).
    pub fn in_collision(&self, p: [f32; 2]) -> bool {
        if self.is_empty() {
            return false;
        }
        self.cell(p).is_none_or(|i| self.blocked[i])
    }

    /// Path length from the flood start to `p`, `None` if unreachable.
    pub fn path_length(&self, p: [f32; 2]) -> Option<f32> {
        if self.is_empty() {
            return Some(((p[0] - self.start[0]).powi(2) + (p[1] - self.start[1]).powi(2)).sqrt());
        }
        let i = self.cell(p)?;
        let d = self.dist[i];
        d.is_finite().then_some(d)
    }

    /// Whether a base at `p` is collision-free and reachable from the flood start.
    pub fn reachable(&self, p: [f32; 2]) -> bool {
        !self.in_collision(p) && self.path_length(p).is_some()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use shm_types::boxed_zeroed;

    /// 4 m × 4 m room at 0.1 m with a wall at x = 2 m that has a gap at the top.
    pub(crate) fn room(gap: bool) -> Box<OccupancyGrid> {
        let mut g = boxed_zeroed::<OccupancyGrid>();
        g.resolution = 0.1;
        g.width = 40;
        g.height = 40;
        for iy in 0..40 {
            for ix in 0..40 {
                let edge = ix == 0 || iy == 0 || ix == 39 || iy == 39;
                let wall = ix == 20 && !(gap && iy > 30);
                if edge || wall {
                    g.cells[iy * 40 + ix] = grid_cell::OCCUPIED;
                }
            }
        }
        g
    }

    #[test]
    fn reachability_through_gap_only() {
        let mut m = NavMap::new(&room(true), 0.25, true);
        m.flood_from([1.0, 1.0], 0.25);
        assert!(m.reachable([3.0, 1.0]));
        let d = m.path_length([3.0, 1.0]).unwrap();
        assert!(d > 4.0 && d < 6.5, "detour through the gap: {d}");
        assert!(
            m.in_collision([2.05, 1.0])
                && m.in_collision([2.25, 1.0])
                && !m.in_collision([2.35, 1.0])
        );
        assert!(!m.reachable([5.0, 1.0]), "off the grid");
        let mut closed = NavMap::new(&room(false), 0.25, true);
        closed.flood_from([1.0, 1.0], 0.25);
        assert!(!closed.reachable([3.0, 1.0]));
        assert!((closed.path_length([1.0, 2.0]).unwrap() - 1.0).abs() < 0.11);
    }

    #[test]
    fn start_inside_inflation_can_escape_and_unknown_is_configurable() {
        let mut g = room(true);
        let mut m = NavMap::new(&g, 0.3, true);
        m.flood_from([0.25, 1.0], 0.3); // 0.15 m from the wall's inner face
        assert!(m.reachable([1.0, 1.0]));
        g.cells[10 * 40 + 10] = grid_cell::UNKNOWN;
        assert!(NavMap::new(&g, 0.0, false).in_collision([1.05, 1.05]));
        assert!(!NavMap::new(&g, 0.0, true).in_collision([1.05, 1.05]));
        let empty = NavMap::new(&boxed_zeroed::<OccupancyGrid>(), 0.3, true);
        assert!(empty.reachable([100.0, 0.0]));
    }

    /// A configuration-space grid (obstacles already inflated by the robot radius) is used as
    /// it is: a 0.5 m passage stays open (inflating it again by 0.3 m per side would close it).
    #[test]
    fn an_inflated_grid_is_not_inflated_again() {
        let mut g = room(false);
        for iy in 10..15 {
            g.cells[iy * 40 + 20] = grid_cell::FREE; // a 0.5 m passage in the wall
        }
        let mut p = NavParams {
            robot_radius: 0.3,
            inflated: true,
            unknown_traversable: true,
        };
        assert_eq!(p.inflation(), 0.0);
        let m = p.flooded(&g, [1.0, 1.25]);
        assert!(m.reachable([3.0, 1.25]) && !m.in_collision([2.05, 1.05]));
        p.inflated = false;
        let m = p.flooded(&g, [1.0, 1.25]);
        assert!(!m.reachable([3.0, 1.25]) && m.in_collision([2.05, 1.05]));
    }
}
