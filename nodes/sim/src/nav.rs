//! The pre-built navigation map (obstacle footprints and walls inflated by the robot radius) and
//! an 8-connected A* planner on it (`pathfinding`'s A*, octile heuristic).

use super::scene::Scene;
use glam::Vec2;
use pathfinding::directed::astar::astar;
use pathfinding::num_traits::Zero;
use shm_types::{MAX_GRID_CELLS, OccupancyGrid, grid_cell};
use std::cmp::Ordering;

/// Why a navigation goal was refused (reported with `nav_status::UNREACHABLE`).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum NavRefusal {
    /// The goal lies outside the navigation map.
    #[error("goal ({x:.2}, {y:.2}) is outside the map")]
    OutOfMap {
        /// Goal x, metres.
        x: f32,
        /// Goal y, metres.
        y: f32,
    },
    /// The goal cell is an (inflated) obstacle.
    #[error("goal ({x:.2}, {y:.2}) is in an obstacle (inflated by the robot radius)")]
    GoalInObstacle {
        /// Goal x, metres.
        x: f32,
        /// Goal y, metres.
        y: f32,
    },
    /// No collision-free path joins the robot and the goal.
    #[error("no path to goal ({x:.2}, {y:.2})")]
    NoPath {
        /// Goal x, metres.
        x: f32,
        /// Goal y, metres.
        y: f32,
    },
    /// The base ran into an obstacle on the way (odometry drift) and stopped.
    #[error("blocked by an obstacle at ({x:.2}, {y:.2})")]
    Blocked {
        /// True base x where it stopped, metres.
        x: f32,
        /// True base y where it stopped, metres.
        y: f32,
    },
}

/// Why a navigation map could not be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error(
    "room of {width} × {height} cells at {resolution} m exceeds the grid capacity {MAX_GRID_CELLS}"
)]
pub struct GridTooLarge {
    /// Cells along x.
    pub width: usize,
    /// Cells along y.
    pub height: usize,
    /// Cell edge, metres.
    pub resolution: f32,
}

/// A boolean obstacle grid over the room.
#[derive(Debug, Clone, PartialEq)]
pub struct NavGrid {
    /// World `[x, y]` of the corner of cell (0, 0).
    pub origin: Vec2,
    /// Cell edge, metres.
    pub resolution: f32,
    /// Cells along x.
    pub width: usize,
    /// Cells along y.
    pub height: usize,
    /// `true` = obstacle, row-major `iy * width + ix`.
    pub occupied: Vec<bool>,
}

impl NavGrid {
    /// Grid over the scene's room: a cell is occupied if its centre is within `inflation` of an
    /// object's footprint, of a partition wall or of a room wall.
    pub fn build(scene: &Scene, inflation: f32, resolution: f32) -> Result<NavGrid, GridTooLarge> {
        let r = scene.room;
        let width = ((r.max.x - r.min.x) / resolution).ceil() as usize;
        let height = ((r.max.y - r.min.y) / resolution).ceil() as usize;
        if width * height > MAX_GRID_CELLS || width == 0 || height == 0 {
            return Err(GridTooLarge {
                width,
                height,
                resolution,
            });
        }
        let mut occupied = vec![false; width * height];
        for iy in 0..height {
            for ix in 0..width {
                let p = r.min + (Vec2::new(ix as f32, iy as f32) + 0.5) * resolution;
                occupied[iy * width + ix] = !r.contains(p, inflation)
                    || scene
                        .objects
                        .iter()
                        .any(|o| o.footprint_distance(p) <= inflation)
                    || scene
                        .partitions
                        .iter()
                        .any(|w| w.footprint_distance(p) <= inflation);
            }
        }
        Ok(NavGrid {
            origin: r.min,
            resolution,
            width,
            height,
            occupied,
        })
    }

    /// Cell `(ix, iy)` of a world point, `None` outside the grid.
    pub fn cell(&self, p: Vec2) -> Option<(usize, usize)> {
        let c = (p - self.origin) / self.resolution;
        (c.x >= 0.0 && c.y >= 0.0 && (c.x as usize) < self.width && (c.y as usize) < self.height)
            .then_some((c.x as usize, c.y as usize))
    }

    /// World centre of a cell.
    pub fn center(&self, ix: usize, iy: usize) -> Vec2 {
        self.origin + (Vec2::new(ix as f32, iy as f32) + 0.5) * self.resolution
    }

    /// Whether a world point is in an obstacle cell (or outside the grid).
    pub fn is_blocked(&self, p: Vec2) -> bool {
        self.cell(p)
            .is_none_or(|(ix, iy)| self.occupied[iy * self.width + ix])
    }

    /// Write the grid into a message (`FREE` / `OCCUPIED`; header left to the caller).
    pub fn write(&self, out: &mut OccupancyGrid) {
        out.origin = self.origin.to_array();
        out.resolution = self.resolution;
        out.width = self.width as u32;
        out.height = self.height as u32;
        out.reserved = 0;
        for (c, o) in out.cells.iter_mut().zip(&self.occupied) {
            *c = if *o {
                grid_cell::OCCUPIED
            } else {
                grid_cell::FREE
            };
        }
        out.cells[self.occupied.len()..].fill(grid_cell::FREE);
    }

    /// Shortest 8-connected path from `start` to `goal` (world points) avoiding occupied cells,
    /// shortened by line-of-sight, as world waypoints ending exactly at `goal`. The start cell
    /// counts as free (the robot may stand in an inflated margin).
    pub fn plan(&self, start: Vec2, goal: Vec2) -> Result<Vec<Vec2>, NavRefusal> {
        let (x, y) = (goal.x, goal.y);
        let (gx, gy) = self.cell(goal).ok_or(NavRefusal::OutOfMap { x, y })?;
        let g = gy * self.width + gx;
        if self.occupied[g] {
            return Err(NavRefusal::GoalInObstacle { x, y });
        }
        let (sx, sy) = self.cell(start).ok_or(NavRefusal::NoPath { x, y })?;
        let s = sy * self.width + sx;
        // Octile distance: admissible and consistent on this 8-connected grid.
        let h = |i: usize| {
            let (dx, dy) = (
                (i % self.width).abs_diff(gx) as f32,
                (i / self.width).abs_diff(gy) as f32,
            );
            dx.max(dy) + (std::f32::consts::SQRT_2 - 1.0) * dx.min(dy)
        };
        let (cells, _) = astar(
            &s,
            |&i| self.steps(i),
            |&i| Cost { len: h(i), cell: i },
            |&i| i == g,
        )
        .ok_or(NavRefusal::NoPath { x, y })?;
        let mut points: Vec<Vec2> = cells
            .iter()
            .map(|&i| self.center(i % self.width, i / self.width))
            .collect();
        points[0] = start;
        if let Some(last) = points.last_mut() {
            *last = goal;
        }
        Ok(self.shortcut(&points))
    }

    /// The free 8-neighbours of cell `i` and the step lengths to them (1 or √2, in cells), in
    /// `NEIGHBOURS` order; no corner cutting between two obstacles.
    fn steps(&self, i: usize) -> impl Iterator<Item = (usize, Cost)> + '_ {
        let (ix, iy) = ((i % self.width) as isize, (i / self.width) as isize);
        NEIGHBOURS.into_iter().filter_map(move |(dx, dy)| {
            let (nx, ny) = (ix + dx, iy + dy);
            if nx < 0 || ny < 0 || nx >= self.width as isize || ny >= self.height as isize {
                return None;
            }
            let j = ny as usize * self.width + nx as usize;
            if self.occupied[j] {
                return None;
            }
            let diagonal = dx != 0 && dy != 0;
            if diagonal
                && (self.occupied[iy as usize * self.width + nx as usize]
                    || self.occupied[ny as usize * self.width + ix as usize])
            {
                return None;
            }
            let len = if diagonal {
                std::f32::consts::SQRT_2
            } else {
                1.0
            };
            Some((j, Cost { len, cell: 0 }))
        })
    }

    /// Drop waypoints that a straight free segment can skip.
    fn shortcut(&self, points: &[Vec2]) -> Vec<Vec2> {
        let mut out = Vec::new();
        let mut i = 0;
        while i + 1 < points.len() {
            let mut j = points.len() - 1;
            while j > i + 1 && !self.segment_free(points[i], points[j]) {
                j -= 1;
            }
            out.push(points[j]);
            i = j;
        }
        out
    }

    /// Whether the segment `a`–`b` crosses only free cells (sampled at a quarter cell; the
    /// cell containing `a` is not checked).
    pub fn segment_free(&self, a: Vec2, b: Vec2) -> bool {
        let len = (b - a).length();
        let steps = (len / (self.resolution * 0.25)).ceil().max(1.0) as usize;
        let start = self.cell(a);
        (1..=steps).all(|k| {
            let p = a + (b - a) * (k as f32 / steps as f32);
            self.cell(p) == start || !self.is_blocked(p)
        })
    }
}

const NEIGHBOURS: [(isize, isize); 8] = [
    (1, 0),
    (-1, 0),
    (0, 1),
    (0, -1),
    (1, 1),
    (1, -1),
    (-1, 1),
    (-1, -1),
];

/// An A* cost: a path length in cells, plus (in the heuristic, hence in the estimate `g + h`
/// that orders the open list) the cell index, so that among equal estimates the lowest cell is
/// expanded first — a deterministic tie-break. Path costs themselves carry `cell == 0`, so they
/// compare by length alone.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Cost {
    len: f32,
    cell: usize,
}

impl std::ops::Add for Cost {
    type Output = Cost;
    fn add(self, o: Cost) -> Cost {
        Cost {
            len: self.len + o.len,
            cell: self.cell + o.cell,
        }
    }
}

impl Zero for Cost {
    fn zero() -> Cost {
        Cost { len: 0.0, cell: 0 }
    }
    fn is_zero(&self) -> bool {
        *self == Cost::zero()
    }
}

impl Eq for Cost {}

impl Ord for Cost {
    fn cmp(&self, other: &Self) -> Ordering {
        self.len
            .total_cmp(&other.len)
            .then(self.cell.cmp(&other.cell))
    }
}

impl PartialOrd for Cost {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    /// 6 × 4 m room split by a wall-to-wall box at x = 0 with a 1 m gap at the top.
    fn scene(gap: bool) -> Scene {
        let y = if gap { -0.5 } else { 0.0 };
        let len = if gap { 3.0 } else { 4.0 };
        Scene::parse(
            Path::new("t.toml"),
            &format!(
                "name = \"t\"\n[room]\nmin = [-3.0, -2.0]\nmax = [3.0, 2.0]\nheight = 2.5\n\
                 [robot]\nstart = [-2.0, 0.0, 0.0]\n\
                 [[object]]\nname = \"wall\"\nclass = \"couch\"\ncenter = [0.0, {y}, 0.5]\n\
                 size = [0.2, {len}, 1.0]\n"
            ),
        )
        .unwrap()
    }

    #[test]
    fn grid_inflates_footprints_and_walls() {
        let g = NavGrid::build(&scene(true), 0.3, 0.1).unwrap();
        assert_eq!((g.width, g.height), (60, 40));
        assert!(g.is_blocked(Vec2::new(0.35, 0.0)), "within 0.3 of the box");
        assert!(!g.is_blocked(Vec2::new(0.45, 0.0)));
        assert!(
            g.is_blocked(Vec2::new(-2.75, 0.0)),
            "within 0.3 of the wall"
        );
        assert!(g.is_blocked(Vec2::new(10.0, 0.0)), "outside");
        let mut msg = shm_types::boxed_zeroed::<OccupancyGrid>();
        g.write(&mut msg);
        use shm_types::Validate;
        assert_eq!(msg.validate(), Ok(()));
        let (ix, iy) = g.cell(Vec2::new(0.0, 0.0)).unwrap();
        assert_eq!(msg.cells[iy * 60 + ix], grid_cell::OCCUPIED);
        assert_eq!(
            msg.used().iter().filter(|c| **c == grid_cell::FREE).count(),
            g.occupied.iter().filter(|o| !**o).count()
        );
    }

    #[test]
    fn plans_around_the_obstacle_or_refuses_with_a_reason() {
        let g = NavGrid::build(&scene(true), 0.3, 0.1).unwrap();
        let (a, b) = (Vec2::new(-2.0, 0.0), Vec2::new(2.0, 0.0));
        let path = g.plan(a, b).unwrap();
        assert_eq!(*path.last().unwrap(), b);
        let mut prev = a;
        let mut len = 0.0;
        for p in &path {
            assert!(g.segment_free(prev, *p), "{prev} -> {p}");
            len += (*p - prev).length();
            prev = *p;
        }
        // Must pass through the gap (y > 1.3): longer than the straight 4 m.
        assert!(len > 4.5 && len < 6.5, "{len}");
        assert!(path.iter().any(|p| p.y > 1.2), "{path:?}");

        assert_eq!(
            g.plan(a, Vec2::new(7.0, 0.0)),
            Err(NavRefusal::OutOfMap { x: 7.0, y: 0.0 })
        );
        assert_eq!(
            g.plan(a, Vec2::new(0.0, -1.0)),
            Err(NavRefusal::GoalInObstacle { x: 0.0, y: -1.0 })
        );
        let closed = NavGrid::build(&scene(false), 0.3, 0.1).unwrap();
        assert_eq!(
            closed.plan(a, b),
            Err(NavRefusal::NoPath { x: 2.0, y: 0.0 })
        );
    }
}
