//! The final exploration grid of a run as a PNG (`explore.png` next to `metrics.json`), for
//! seeing where exploration went and why: unknown grey, free white, occupied black, and the
//! frontier cells the planners' exploration still sees (no blacklist; the navigation grid
//! flooded from the final base pose) red. North is up; one pixel per cell, scaled ×2.

use crate::eval::EvalError;
use crate::planner::frontier::{FrontierParams, frontiers_in};
use crate::planner::reach::NavMap;
use plotters::prelude::*;
use shm_types::{OccupancyGrid, grid_cell};
use std::path::Path;

const SCALE: u32 = 2;

/// Write `grid` with its frontiers (`params`, no blacklist, `nav` flooded) to `path`.
pub fn write(
    path: &Path,
    grid: &OccupancyGrid,
    params: &FrontierParams,
    nav: &NavMap,
) -> Result<(), EvalError> {
    let (w, h) = (grid.width, grid.height);
    let cells = grid.used();
    if w == 0 || h == 0 || cells.len() != (w * h) as usize {
        return Ok(());
    }
    let mut front = vec![false; cells.len()];
    for f in frontiers_in(grid, &[], params, Some(nav)) {
        for i in f.cells {
            front[i] = true;
        }
    }
    let fail = |e: String| EvalError::Plot {
        path: path.to_path_buf(),
        reason: e,
    };
    let root = BitMapBackend::new(path, (w * SCALE, h * SCALE)).into_drawing_area();
    for (i, &c) in cells.iter().enumerate() {
        let color = if front[i] {
            RGBColor(220, 30, 30)
        } else if c == grid_cell::UNKNOWN {
            RGBColor(150, 150, 150)
        } else if c < 50 {
            WHITE
        } else {
            BLACK
        };
        let (x, y) = (i as u32 % w, h - 1 - i as u32 / w);
        for dy in 0..SCALE {
            for dx in 0..SCALE {
                let p = ((x * SCALE + dx) as i32, (y * SCALE + dy) as i32);
                root.draw_pixel(p, &color)
                    .map_err(|e| fail(e.to_string()))?;
            }
        }
    }
    root.present().map_err(|e| fail(e.to_string()))
}
