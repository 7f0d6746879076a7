//! Surface occupancy probability map (SOPM, paper §4.1, Figures 3–4) and the best line of sight
//! l_best (§4.2, eq. 11).
//!
//! The map is a grid of `rows × cols` cells on a surface around the object's cuboid: a cylinder
//! (default, ground robots), an upper hemisphere or a sphere ([`SopmShape`]). Points are projected
//! onto it from the object's axis (cylinder: horizontal rays from the vertical centre axis) or its
//! centre (hemisphere: the bottom centre; sphere: the centre). The angular reference is the
//! object's own frame: angles are measured after rotating `p − centre` by `−yaw` (rotation only).
//!
//! **Inverse sensor model (eqs. 5–8) and how `n_o` accumulates.** The paper projects the
//! object's inner points onto the map and sets `n_o(g) = n_p(g)`. We accumulate `n_p` over frames,
//! with one guard so that an unseen back side is never declared free: in a frame, a cell takes part
//! only if it *faces the camera* (its outward normal makes an angle below acos(`visible_cos`) with
//! the direction to the camera), and its column counts as observed only if the camera-facing cells
//! received at least ε_n of the frame's points. For observed columns, the frame's points in the
//! camera-facing cells are added to the cells' accumulated counts `n_p(g)` and those cells become
//! *observed*. Then, per column:
//! - never-observed cell: unknown, `p = p_prior`, `n_o = 0`;
//! - observed, `n_p(g) > 0`: occupied, `n_o(g) = n_p(g)`, `l = l_0 + n_o · l_inv(p_occ)`;
//! - observed, `n_p(g) = 0`: free, `n_o(g) = min n_p` over the column's observed occupied cells,
//!   `l = l_0 + n_o · l_inv(p_free)`;
//!
//! with `l_0 = log2(p_prior/(1 − p_prior))` (0 for the default prior), i.e. eq. 8. Raw per-frame
//! points are accumulated (not the merged voxel cloud) so that rows finer than the point spacing
//! are filled as the sampling shifts between views. The counts grow every time a surface is seen
//! again, so entropy falls with repeated observation and stays 1 where the object was never seen.

use glam::{Mat3, Vec3};
use serde::Deserialize;
use shm_types::sopm_shape;

/// Shape of the map (paper Figure 3b–d).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SopmShape {
    /// Cylinder around the vertical axis through the cuboid centre; rows split the height.
    Cylinder,
    /// Upper hemisphere centred on the cuboid's bottom centre; rows split elevation 0..90°.
    Hemisphere,
    /// Sphere centred on the cuboid centre; rows split elevation −90..90°.
    Sphere,
}

impl SopmShape {
    /// The [`sopm_shape`] code carried in the map message.
    pub fn code(self) -> u8 {
        match self {
            SopmShape::Cylinder => sopm_shape::CYLINDER,
            SopmShape::Hemisphere => sopm_shape::HEMISPHERE,
            SopmShape::Sphere => sopm_shape::SPHERE,
        }
    }
}

/// Parameters of the inverse sensor model.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SopmParams {
    /// Shape.
    pub shape: SopmShape,
    /// Height / elevation cells.
    pub rows: usize,
    /// Angular cells.
    pub cols: usize,
    /// ε_n: minimum points in a column for a valid observation.
    pub eps_n: u32,
    /// Occupied inverse-sensor probability.
    pub p_occ: f32,
    /// Free inverse-sensor probability.
    pub p_free: f32,
    /// Prior probability (`l_0`), normally 0.5.
    pub p_prior: f32,
    /// A cell takes part in a frame only if `normal · dir_to_camera > visible_cos`.
    pub visible_cos: f32,
}

/// Where the map sits: the object's cuboid (centre, size, yaw).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frame {
    /// Cuboid centre, world.
    pub center: Vec3,
    /// Cuboid size.
    pub size: Vec3,
    /// Cuboid yaw.
    pub yaw: f32,
}

impl Frame {
    fn rot(&self) -> Mat3 {
        Mat3::from_rotation_z(self.yaw)
    }

    /// Origin of the projection for a shape, world frame.
    fn origin(&self, shape: SopmShape) -> Vec3 {
        match shape {
            SopmShape::Hemisphere => self.center - Vec3::Z * (self.size.z * 0.5),
            _ => self.center,
        }
    }

    fn radius(&self, shape: SopmShape) -> f32 {
        let h = self.size * 0.5;
        match shape {
            SopmShape::Cylinder => (h.x * h.x + h.y * h.y).sqrt(),
            SopmShape::Hemisphere => (h.x * h.x + h.y * h.y + self.size.z * self.size.z).sqrt(),
            SopmShape::Sphere => h.length(),
        }
        .max(1e-3)
    }
}

/// A surface occupancy probability map with its observation counts.
#[derive(Debug, Clone, PartialEq)]
pub struct Sopm {
    params: SopmParams,
    /// Whether each cell (row-major) has been observed.
    observed: Vec<bool>,
    /// `n_o` of occupied cells (0 if not occupied).
    occ: Vec<u32>,
    /// `n_o` of free cells (0 if not free).
    free: Vec<u32>,
    /// Accumulated projected points `n_p` per cell.
    hits: Vec<u32>,
    /// Scratch: this frame's points per cell.
    np: Vec<u32>,
}

fn log_odds(p: f32) -> f32 {
    (p / (1.0 - p)).log2()
}

/// Binary entropy (eq. 9), bits; 0 at p ∈ {0, 1}.
pub fn entropy(p: f32) -> f32 {
    let h = |x: f32| if x > 0.0 { -x * x.log2() } else { 0.0 };
    h(p) + h(1.0 - p)
}

impl Sopm {
    /// A fresh (all unknown) map.
    pub fn new(params: SopmParams) -> Self {
        let n = params.rows * params.cols;
        Self {
            params,
            observed: vec![false; n],
            occ: vec![0; n],
            free: vec![0; n],
            hits: vec![0; n],
            np: vec![0; n],
        }
    }

    /// The parameters.
    pub fn params(&self) -> &SopmParams {
        &self.params
    }

    /// Number of cells.
    pub fn len(&self) -> usize {
        self.occ.len()
    }

    /// Whether the map has no cells.
    pub fn is_empty(&self) -> bool {
        self.occ.is_empty()
    }

    /// `(row, col)` of a world point, or `None` if it coincides with the projection axis.
    pub fn cell_of(&self, frame: &Frame, p: Vec3) -> Option<(usize, usize)> {
        let (rows, cols) = (self.params.rows, self.params.cols);
        let q = frame.rot().transpose() * (p - frame.origin(self.params.shape));
        let horiz = (q.x * q.x + q.y * q.y).sqrt();
        let phi = q.y.atan2(q.x);
        let col = (((phi + std::f32::consts::PI) / std::f32::consts::TAU * cols as f32) as usize)
            .min(cols - 1);
        let frac = match self.params.shape {
            SopmShape::Cylinder => {
                if horiz < 1e-6 {
                    return None;
                }
                (q.z + frame.size.z * 0.5) / frame.size.z.max(1e-6)
            }
            SopmShape::Hemisphere => {
                if q.length() < 1e-6 {
                    return None;
                }
                q.z.atan2(horiz) / std::f32::consts::FRAC_PI_2
            }
            SopmShape::Sphere => {
                if q.length() < 1e-6 {
                    return None;
                }
                (q.z.atan2(horiz) + std::f32::consts::FRAC_PI_2) / std::f32::consts::PI
            }
        };
        // Clamp so that points on (or beyond) the top/bottom edge land in the edge rows.
        let row = ((frac * rows as f32).floor().max(0.0) as usize).min(rows - 1);
        Some((row, col))
    }

    /// Centre of a cell on the map surface and its outward unit normal, world frame.
    pub fn cell_center_normal(&self, frame: &Frame, row: usize, col: usize) -> (Vec3, Vec3) {
        let (rows, cols) = (self.params.rows as f32, self.params.cols as f32);
        let phi = -std::f32::consts::PI + (col as f32 + 0.5) * std::f32::consts::TAU / cols;
        let r = frame.radius(self.params.shape);
        let (sp, cp) = phi.sin_cos();
        let (local, normal) = match self.params.shape {
            SopmShape::Cylinder => {
                let z = -frame.size.z * 0.5 + (row as f32 + 0.5) * frame.size.z / rows;
                (Vec3::new(r * cp, r * sp, z), Vec3::new(cp, sp, 0.0))
            }
            SopmShape::Hemisphere | SopmShape::Sphere => {
                let el = if self.params.shape == SopmShape::Hemisphere {
                    (row as f32 + 0.5) / rows * std::f32::consts::FRAC_PI_2
                } else {
                    -std::f32::consts::FRAC_PI_2 + (row as f32 + 0.5) / rows * std::f32::consts::PI
                };
                let (se, ce) = el.sin_cos();
                let n = Vec3::new(ce * cp, ce * sp, se);
                (n * r, n)
            }
        };
        let rot = frame.rot();
        (frame.origin(self.params.shape) + rot * local, rot * normal)
    }

    /// Integrate one frame's points of the object seen from `camera` (world position).
    /// Returns the number of columns observed in this frame.
    pub fn update(&mut self, frame: &Frame, camera: Vec3, frame_points: &[Vec3]) -> usize {
        let observed = self.observe(frame, camera, frame_points);
        self.recompute();
        observed
    }

    /// Mark the cells observed by one frame (see the module docs).
    pub fn observe(&mut self, frame: &Frame, camera: Vec3, frame_points: &[Vec3]) -> usize {
        let (rows, cols) = (self.params.rows, self.params.cols);
        self.np.fill(0);
        for &p in frame_points {
            if let Some((r, c)) = self.cell_of(frame, p) {
                self.np[r * cols + c] += 1;
            }
        }
        let mut observed = 0;
        let mut visible = vec![false; rows];
        for c in 0..cols {
            let mut sum = 0u32;
            for (r, vis) in visible.iter_mut().enumerate() {
                let (centre, normal) = self.cell_center_normal(frame, r, c);
                let to_cam = (camera - centre).normalize_or_zero();
                *vis = normal.dot(to_cam) > self.params.visible_cos;
                if *vis {
                    sum += self.np[r * cols + c];
                }
            }
            if sum < self.params.eps_n.max(1) {
                continue; // unknown in this frame
            }
            observed += 1;
            for (r, vis) in visible.iter().enumerate() {
                if *vis {
                    let g = r * cols + c;
                    self.observed[g] = true;
                    self.hits[g] = self.hits[g].saturating_add(self.np[g]);
                }
            }
        }
        observed
    }

    /// Recompute `n_o` of every cell from the accumulated counts (eqs. 5–8, module docs).
    fn recompute(&mut self) {
        let (rows, cols) = (self.params.rows, self.params.cols);
        for c in 0..cols {
            let min_occ = (0..rows)
                .map(|r| r * cols + c)
                .filter(|g| self.observed[*g] && self.hits[*g] > 0)
                .map(|g| self.hits[g])
                .min();
            for r in 0..rows {
                let g = r * cols + c;
                (self.occ[g], self.free[g]) = match (self.observed[g], self.hits[g], min_occ) {
                    (false, _, _) | (true, 0, None) => (0, 0),
                    (true, 0, Some(m)) => (0, m),
                    (true, n, _) => (n, 0),
                };
            }
        }
    }

    /// Rotate the map by `shift` columns (used when the object's yaw estimate changes, so that
    /// cells keep pointing at the same world directions): new column `c` takes old `c + shift`.
    pub fn shift_columns(&mut self, shift: i32) {
        let cols = self.params.cols;
        let s = shift.rem_euclid(cols as i32) as usize;
        if s == 0 {
            return;
        }
        for r in 0..self.params.rows {
            let row = r * cols..(r + 1) * cols;
            self.observed[row.clone()].rotate_left(s);
            self.hits[row.clone()].rotate_left(s);
            self.occ[row.clone()].rotate_left(s);
            self.free[row].rotate_left(s);
        }
    }

    /// Add the evidence of `other` (a map of the same object, e.g. a duplicate being merged):
    /// `other`'s columns are first rotated by `shift` (as [`Self::shift_columns`] does, to express
    /// them in this map's angular reference), then per cell the observed flags are or-ed and the
    /// accumulated point counts `n_p` summed; `n_o` follows (module docs), so the log-odds of
    /// matching cells add up. Maps of different sizes or shapes are left unchanged (returns false).
    pub fn absorb(&mut self, other: &Sopm, shift: i32) -> bool {
        let p = &other.params;
        if (p.shape, p.rows, p.cols) != (self.params.shape, self.params.rows, self.params.cols) {
            return false;
        }
        let mut o = other.clone();
        o.shift_columns(shift);
        for g in 0..self.len() {
            self.observed[g] |= o.observed[g];
            self.hits[g] = self.hits[g].saturating_add(o.hits[g]);
        }
        self.recompute();
        true
    }

    /// Set cell `g`'s evidence directly: observed flag, occupied and free counts `n_o` (the
    /// accumulated points `n_p` are taken as the occupied count). For resuming from a
    /// published map (`resume.rs`).
    pub(super) fn set_cell(&mut self, g: usize, observed: bool, occ: u32, free: u32) {
        self.observed[g] = observed;
        self.occ[g] = occ;
        self.free[g] = free;
        self.hits[g] = occ;
    }

    /// Log-odds of a cell (eq. 8 summed over frames; `l_0` from `p_prior`).
    fn log_odds(&self, g: usize) -> f32 {
        let l = log_odds(self.params.p_prior)
            + self.occ[g] as f32 * log_odds(self.params.p_occ)
            + self.free[g] as f32 * log_odds(self.params.p_free);
        l.clamp(-60.0, 60.0)
    }

    /// Occupancy probability of a cell (eq. 5 inverted).
    pub fn prob(&self, g: usize) -> f32 {
        let e = self.log_odds(g).exp2();
        e / (1.0 + e)
    }

    /// Observation count `n_o` of a cell (occupied + free observations).
    pub fn obs(&self, g: usize) -> u32 {
        self.occ[g].saturating_add(self.free[g])
    }

    /// Entropy of a cell (eq. 9).
    pub fn cell_entropy(&self, g: usize) -> f32 {
        if self.occ[g] == 0 && self.free[g] == 0 {
            return entropy(self.params.p_prior);
        }
        entropy(self.prob(g))
    }

    /// H_sopm: mean cell entropy (eq. 10). A fresh map with `p_prior = 0.5` gives exactly 1.
    pub fn h_sopm(&self) -> f32 {
        if self.is_empty() {
            return 1.0;
        }
        let s: f32 = (0..self.len()).map(|g| self.cell_entropy(g)).sum();
        (s / self.len() as f32).clamp(0.0, 1.0)
    }

    /// Mean entropy of one column (diagnostics and tests).
    pub fn column_entropy(&self, col: usize) -> f32 {
        let (rows, cols) = (self.params.rows, self.params.cols);
        (0..rows)
            .map(|r| self.cell_entropy(r * cols + col))
            .sum::<f32>()
            / rows as f32
    }

    /// Best line of sight (eq. 11): `Σ_g (c(g) − c(f_o)) · H(g)`, world frame, with `c(g)` the
    /// cell centres on the map surface and `c(f_o)` the cuboid centre. It points from the object
    /// towards its most uncertain side (where a camera should look from).
    pub fn l_best(&self, frame: &Frame) -> Vec3 {
        let (rows, cols) = (self.params.rows, self.params.cols);
        let mut l = Vec3::ZERO;
        for r in 0..rows {
            for c in 0..cols {
                let (centre, _) = self.cell_center_normal(frame, r, c);
                l += (centre - frame.center) * self.cell_entropy(r * cols + c);
            }
        }
        l
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params(shape: SopmShape) -> SopmParams {
        SopmParams {
            shape,
            rows: 18,
            cols: 18,
            eps_n: 5,
            p_occ: 0.6,
            p_free: 0.4,
            p_prior: 0.5,
            visible_cos: 0.2,
        }
    }

    fn frame() -> Frame {
        Frame {
            center: Vec3::new(1.0, 2.0, 0.8),
            size: Vec3::new(0.1, 0.1, 0.2),
            yaw: 0.3,
        }
    }

    #[test]
    fn fresh_map_has_entropy_one_and_zero_l_best() {
        for shape in [
            SopmShape::Cylinder,
            SopmShape::Hemisphere,
            SopmShape::Sphere,
        ] {
            let m = Sopm::new(params(shape));
            assert_eq!(m.h_sopm(), 1.0);
            let l = m.l_best(&frame());
            // Horizontal components cancel by symmetry for every shape.
            assert!(l.truncate().length() < 1e-3, "{shape:?} {l}");
        }
    }

    #[test]
    fn cells_round_trip_through_their_centres() {
        for shape in [
            SopmShape::Cylinder,
            SopmShape::Hemisphere,
            SopmShape::Sphere,
        ] {
            let m = Sopm::new(params(shape));
            let f = frame();
            for r in 0..18 {
                for c in 0..18 {
                    let (centre, n) = m.cell_center_normal(&f, r, c);
                    assert!((n.length() - 1.0).abs() < 1e-4);
                    assert_eq!(m.cell_of(&f, centre), Some((r, c)), "{shape:?}");
                }
            }
        }
    }

    #[test]
    fn top_edge_points_stay_in_bounds() {
        let m = Sopm::new(params(SopmShape::Cylinder));
        let f = frame();
        let top = f.center + Vec3::new(0.05, 0.0, 0.1);
        assert_eq!(m.cell_of(&f, top).unwrap().0, 17);
        let above = f.center + Vec3::new(0.05, 0.0, 0.5);
        assert_eq!(m.cell_of(&f, above).unwrap().0, 17);
        let below = f.center + Vec3::new(0.05, 0.0, -0.5);
        assert_eq!(m.cell_of(&f, below).unwrap().0, 0);
    }

    #[test]
    fn angular_reference_follows_yaw_not_position() {
        let m = Sopm::new(params(SopmShape::Cylinder));
        let mut f = frame();
        // A point 10° left of the object's local +x axis falls in column 9 (0°..20°).
        let dir = Mat3::from_rotation_z(f.yaw + 10f32.to_radians()) * Vec3::X;
        let (_, c0) = m.cell_of(&f, f.center + dir * 0.05).unwrap();
        assert_eq!(c0, 9);
        f.center += Vec3::new(5.0, -3.0, 0.0);
        assert_eq!(m.cell_of(&f, f.center + dir * 0.05).unwrap().1, 9);
    }

    #[test]
    fn column_shift_keeps_world_directions() {
        let mut m = Sopm::new(params(SopmShape::Cylinder));
        m.occ[3] = 7;
        m.observed[3] = true;
        m.shift_columns(2);
        assert_eq!((m.occ[1], m.observed[1]), (7, true));
        m.shift_columns(-2);
        assert_eq!((m.occ[3], m.observed[3]), (7, true));
    }

    #[test]
    fn absorbing_a_rotated_duplicate_sums_matching_cells() {
        let mut a = Sopm::new(params(SopmShape::Cylinder));
        let mut b = Sopm::new(params(SopmShape::Cylinder));
        // Column 3 of `a` sees 4 points in row 0; `b` saw the same world direction in column 1
        // (its yaw is 2 columns larger), 6 points, and row 1 of that column empty (free).
        a.observed[3] = true;
        a.hits[3] = 4;
        b.observed[1] = true;
        b.hits[1] = 6;
        b.observed[18 + 1] = true;
        a.recompute();
        assert!(a.absorb(&b, -2));
        assert_eq!((a.obs(3), a.hits[3]), (10, 10));
        // The free cell came along with the minimum occupied count of its column.
        assert_eq!((a.occ[18 + 3], a.free[18 + 3]), (0, 10));
        assert!(a.observed.iter().filter(|o| **o).count() == 2);
        let other = Sopm::new(SopmParams {
            rows: 4,
            ..params(SopmShape::Cylinder)
        });
        assert!(!a.absorb(&other, 0));
    }

    #[test]
    fn log_odds_match_eq_8() {
        let mut m = Sopm::new(params(SopmShape::Cylinder));
        m.occ[0] = 3;
        // l = 3 · log2(0.6/0.4); p = 2^l / (1 + 2^l) = 1.5³ / (1 + 1.5³).
        let want = 3.375 / 4.375;
        assert!((m.prob(0) - want).abs() < 1e-6);
        m.free[0] = 3;
        assert!((m.prob(0) - 0.5).abs() < 1e-6);
        assert!((entropy(0.5) - 1.0).abs() < 1e-7);
    }
}
