//! Row kernels of the depth camera: all the camera rays of one image row (a packet) against the
//! room, one box or one cylinder, written without branches so that the compiler vectorises them.
//!
//! A row's ray through pixel column `u` is `base + xs[u] · col` (any frame: world for the room,
//! the object's frame for a solid), with `xs[u] = (u + ½ − cx) / fx`, so its z in the camera
//! frame is 1 and its hit time is the pixel's depth. Each kernel keeps, per pixel, the nearest
//! hit so far (`t`, 0 = none yet, then up to `far`), its instance and the cosine between the
//! ray and the surface normal. The arithmetic is that of [`World::cast`](super::World::cast)
//! (same slab test, same cylinder equations), so the render equals ray casting pixel by pixel.

use glam::Vec3;

/// The nearest hits of one row of rays (slices of the row's columns being cast).
pub(super) struct RowHits<'a> {
    /// Ray parameters `x` of the columns.
    pub xs: &'a [f32],
    /// Hit time (= depth) per column; 0 = nothing hit yet.
    pub t: &'a mut [f32],
    /// Instance per column.
    pub inst: &'a mut [u8],
    /// Cosine of the incidence angle per column.
    pub cos: &'a mut [f32],
}

/// A row's rays in some frame: origin and `dir(x) = base + x · col`.
#[derive(Debug, Clone, Copy)]
pub(super) struct RowRays {
    pub origin: Vec3,
    pub base: Vec3,
    pub col: Vec3,
}

/// `1 / |dir|` for a ray whose camera-frame direction is `(x, y, 1)`: `|dir|² = x² + y² + 1`
/// in any frame (rotations keep lengths).
#[inline(always)]
fn inv_len(x: f32, y2p1: f32) -> f32 {
    1.0 / (x * x + y2p1).sqrt()
}

/// The room (inside of the box `[lo, hi]`): where each ray leaves it, overwriting the row
/// (`t`, `inst` = `structure`, `cos`). If the origin is outside the room nothing is hit: `t` =
/// 0 and `cos` = 0. `y` is the row's camera-frame ray y.
#[inline(never)] // one call per row and object; keeps the kernels apart in profiles
pub(super) fn room(h: RowHits, r: &RowRays, y: f32, lo: Vec3, hi: Vec3, structure: u8) {
    let o = r.origin;
    let inside = !(o.cmplt(lo).any() || o.cmpgt(hi).any());
    if !inside {
        h.t.fill(0.0);
        h.inst.fill(structure);
        h.cos.fill(0.0);
        return;
    }
    // Per axis the exit plane is the one the ray heads for: 1/t = max(d/(hi − o), d/(lo − o)),
    // both factors finite unless the origin lies on a wall; the exit is the largest 1/t.
    let (rp, rn) = ((hi - o).recip(), (lo - o).recip());
    let (b, c) = (r.base, r.col);
    let y2p1 = y * y + 1.0;
    for (((&x, t), inst), cos) in
        h.xs.iter()
            .zip(h.t.iter_mut())
            .zip(h.inst.iter_mut())
            .zip(h.cos.iter_mut())
    {
        let d = b + c * x;
        let ix = (d.x * rp.x).max(d.x * rn.x);
        let iy = (d.y * rp.y).max(d.y * rn.y);
        let iz = (d.z * rp.z).max(d.z * rn.z);
        // Ties go to x, then y (as `World::room_exit`).
        let (mut inv, mut dn) = (ix, d.x.abs());
        if iy > inv {
            (inv, dn) = (iy, d.y.abs());
        }
        if iz > inv {
            (inv, dn) = (iz, d.z.abs());
        }
        let ok = inv > 0.0 && inv.is_finite();
        *t = if ok { 1.0 / inv } else { 0.0 };
        *cos = if ok { dn * inv_len(x, y2p1) } else { 0.0 };
        *inst = structure;
    }
}

/// The box `[-h, h]` (object frame): slab test; a hit nearer than the row's (or than `far` where
/// the row has none) replaces it with instance `id`.
#[inline(never)] // one call per row and object; keeps the kernels apart in profiles
pub(super) fn cuboid(h: RowHits, r: &RowRays, y: f32, half: Vec3, far: f32, id: u8) {
    let (o, b, c) = (r.origin, r.base, r.col);
    let (lo, hi) = (-half - o, half - o);
    let y2p1 = y * y + 1.0;
    for (((&x, tr), inst), cos) in
        h.xs.iter()
            .zip(h.t.iter_mut())
            .zip(h.inst.iter_mut())
            .zip(h.cos.iter_mut())
    {
        let d = b + c * x;
        let inv = d.recip();
        let (t1, t2) = (lo * inv, hi * inv);
        let near = t1.min(t2);
        let far_t = t1.max(t2);
        let t_in = near.x.max(near.y).max(near.z);
        let t_out = far_t.x.min(far_t.y).min(far_t.z);
        let t = t_in.max(0.0);
        let best = if *tr > 0.0 { *tr } else { far };
        let hit = t_out >= t && t < best && !t_in.is_nan();
        // The entry face is the axis of the largest near distance (ties: x, then y).
        let dn = if near.x >= near.y && near.x >= near.z {
            d.x
        } else if near.y >= near.z {
            d.y
        } else {
            d.z
        };
        // Selects rather than a branch: the loop vectorises.
        *tr = if hit { t } else { *tr };
        *inst = if hit { id } else { *inst };
        *cos = if hit {
            dn.abs() * inv_len(x, y2p1)
        } else {
            *cos
        };
    }
}

/// The cylinder of radius `radius` along the object's y axis, `|y| ≤ half_height`: side and the
/// cap facing the ray; a hit nearer than the row's replaces it with instance `id`.
#[allow(clippy::too_many_arguments)]
#[inline(never)] // one call per row and object; keeps the kernels apart in profiles
pub(super) fn cylinder(
    h: RowHits,
    r: &RowRays,
    y: f32,
    radius: f32,
    half_height: f32,
    far: f32,
    id: u8,
) {
    let (o, b, c) = (r.origin, r.base, r.col);
    let (rr, hh) = (radius * radius, half_height);
    let cc = o.x * o.x + o.z * o.z - rr;
    let y2p1 = y * y + 1.0;
    for (((&x, tr), inst), cos) in
        h.xs.iter()
            .zip(h.t.iter_mut())
            .zip(h.inst.iter_mut())
            .zip(h.cos.iter_mut())
    {
        let d = b + c * x;
        let best = if *tr > 0.0 { *tr } else { far };
        // Side: (ox + t dx)² + (oz + t dz)² = r², entry root.
        let a = d.x * d.x + d.z * d.z;
        let bb = o.x * d.x + o.z * d.z;
        let disc = bb * bb - a * cc;
        let ts = (-bb - disc.max(0.0).sqrt()) / a;
        let side_ok =
            a > 1e-12 && disc >= 0.0 && (o.y + ts * d.y).abs() <= hh && ts >= 0.0 && ts <= best;
        let side_dn = ((o.x + ts * d.x) * d.x + (o.z + ts * d.z) * d.z) / radius;
        // The cap the ray can enter: y = +hh going down, y = −hh going up.
        let cap = if d.y < 0.0 { hh } else { -hh };
        let tc = (cap - o.y) / d.y;
        let (px, pz) = (o.x + d.x * tc, o.z + d.z * tc);
        let cap_ok = d.y.abs() > 1e-12 && px * px + pz * pz <= rr && tc >= 0.0 && tc <= best;
        // The side wins ties (it is tried first in `World::cast`).
        let use_cap = cap_ok && !(side_ok && ts <= tc);
        let (t, dn) = if use_cap { (tc, d.y) } else { (ts, side_dn) };
        let hit = (side_ok || cap_ok) && t < best;
        *tr = if hit { t } else { *tr };
        *inst = if hit { id } else { *inst };
        *cos = if hit {
            dn.abs() * inv_len(x, y2p1)
        } else {
            *cos
        };
    }
}
