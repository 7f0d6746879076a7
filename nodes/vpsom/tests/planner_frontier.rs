//! Frontier rules of the exploration (issue #15, path length): only unknown space the base can
//! reach makes a frontier, pockets too small to hide a cluster make none, a frontier goal whose
//! neighbourhood was seen on the way is no longer worth driving to, and an all-unknown grid is
//! not an explored room. Hand-built grids at 0.1 m.

use shm_types::{OccupancyGrid, boxed_zeroed, grid_cell};
use vpsom::planner::PlannerConfig;
use vpsom::planner::frontier::{FrontierParams, any_known, frontier_near, frontiers_in};
use vpsom::planner::reach::NavParams;

const W: usize = 40;

/// A 4 m × 4 m grid at 0.1 m, origin (0, 0), every cell `fill`.
fn grid(fill: u8) -> Box<OccupancyGrid> {
    let mut g = boxed_zeroed::<OccupancyGrid>();
    (g.resolution, g.width, g.height) = (0.1, W as u32, W as u32);
    g.cells[..W * W].fill(fill);
    g
}

fn set(g: &mut OccupancyGrid, x: usize, y: usize, v: u8) {
    g.cells[y * W + x] = v;
}

fn params(reachable_unknown: bool, min_unknown_area_m2: f32) -> FrontierParams {
    FrontierParams {
        min_cells: 3,
        blacklist_radius: 0.5,
        gain_weight: 0.0,
        min_unknown_area_m2,
        reachable_unknown,
        nav: NavParams {
            robot_radius: 0.2,
            inflated: false,
            unknown_traversable: true,
        },
    }
}

/// Navigation grid: a wall along x = 3.0 m (column 30); the robot at (1, 2).
fn nav_with_wall() -> Box<OccupancyGrid> {
    let mut nav = grid(grid_cell::FREE);
    for y in 0..W {
        set(&mut nav, 30, y, grid_cell::OCCUPIED);
    }
    nav
}

/// Exploration grid: known free up to the wall's inner face (columns 0..=27), unknown beyond
/// (the wall's face missed by the depth rays, and the space behind it).
fn explored_up_to_the_wall() -> Box<OccupancyGrid> {
    let mut g = grid(grid_cell::UNKNOWN);
    for y in 0..W {
        for x in 0..=27 {
            set(&mut g, x, y, grid_cell::FREE);
        }
    }
    g
}

#[test]
fn unknown_space_behind_a_wall_makes_no_frontier_when_only_reachable_unknown_counts() {
    let g = explored_up_to_the_wall();
    let p = params(true, 0.0);
    let nav = p.nav.flooded(&nav_with_wall(), [1.0, 2.0]);
    // Every UNKNOWN cell counts: the column x = 27 is a frontier.
    let all = frontiers_in(&g, &[], &params(false, 0.0), Some(&nav));
    assert_eq!(all.len(), 1);
    assert_eq!(all[0].cells.len(), W);
    // Column 28 is within the 0.2 m inflation of the wall (column 30 at 3.0-3.1 m; cell 28's
    // centre at 2.85 m is 0.15 m from it) and column 29 touches it: neither is reachable, the
    // space behind is not either. No frontier.
    assert!(frontiers_in(&g, &[], &p, Some(&nav)).is_empty());
    // An unknown strip wider than the inflation band is reachable space: a frontier again.
    let mut g2 = explored_up_to_the_wall();
    for y in 0..W {
        for x in 24..=27 {
            set(&mut g2, x, y, grid_cell::UNKNOWN);
        }
    }
    let f = frontiers_in(&g2, &[], &p, Some(&nav));
    assert_eq!(f.len(), 1, "column 23 borders reachable unknown cells");
    assert!(f[0].cells.iter().all(|&i| i % W == 23));
}

#[test]
fn a_pocket_too_small_for_a_cluster_makes_no_frontier() {
    // All known but a 3 × 3 unknown pocket (0.09 m²) and a 10 × 10 one (1 m²).
    let mut g = grid(grid_cell::FREE);
    for y in 5..8 {
        for x in 5..8 {
            set(&mut g, x, y, grid_cell::UNKNOWN);
        }
    }
    for y in 20..30 {
        for x in 20..30 {
            set(&mut g, x, y, grid_cell::UNKNOWN);
        }
    }
    assert_eq!(frontiers_in(&g, &[], &params(false, 0.0), None).len(), 2);
    let f = frontiers_in(&g, &[], &params(false, 0.5), None);
    assert_eq!(f.len(), 1, "only the 1 m² pocket");
    assert!((f[0].centroid[0] - 2.5).abs() < 0.01 && (f[0].centroid[1] - 2.5).abs() < 0.01);
}

#[test]
fn a_goal_is_near_a_frontier_until_its_neighbourhood_is_seen() {
    let mut g = explored_up_to_the_wall();
    // The frontier is column 27 (x 2.7-2.8 m).
    assert!(frontier_near(&g, [2.75, 2.0], 0.3));
    assert!(
        frontier_near(&g, [2.5, 2.0], 0.3),
        "0.25 m from the frontier"
    );
    assert!(!frontier_near(&g, [2.0, 2.0], 0.3), "0.75 m from it");
    // The cells beyond are seen: no frontier near the goal any more.
    for y in 0..W {
        for x in 28..W {
            set(&mut g, x, y, grid_cell::FREE);
        }
    }
    assert!(!frontier_near(&g, [2.75, 2.0], 0.3));
}

#[test]
fn an_all_unknown_grid_has_no_known_cell() {
    let mut g = grid(grid_cell::UNKNOWN);
    assert!(!any_known(&g));
    set(&mut g, 3, 3, grid_cell::FREE);
    assert!(any_known(&g));
    // The shipped defaults parse into these parameters.
    let p = FrontierParams::new(&PlannerConfig::default());
    assert!(p.min_cells >= 1);
}
