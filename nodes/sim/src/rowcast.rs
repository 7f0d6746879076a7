//! Row kernels of the depth camera: all the camera rays of one image row (a packet) against the
//! room, one box or one cylinder, written without branches so that the compiler vectorises them.
//!
//! A row's ray through pixel column `u` is `base + xs[u] · col` (any frame: world for the room,
//! the object's frame for a solid), with `xs[u] = (u + ½ − cx) / fx`, so its z in the camera
//! frame is 1 and its hit time is the pixel's depth. Each kernel keeps, per pixel, the nearest
//! hit so far (`t`, 0 = none yet, then up to `far`), its instance and `|n · dir|`, the surface
//! normal's component along the unnormalised ray; once every kernel has run on the row,
//! [`normalise_cos`] divides it by `|dir|`, giving the cosine between the ray and the normal
//! (one square root and division per pixel, not one per pixel and solid). The arithmetic is that
//! of [`World::cast`](super::World::cast) (same slab test, same cylinder equations), so the
//! render equals ray casting pixel by pixel.

use glam::Vec3;
use wide::f32x4;

/// The nearest hits of one row of rays (slices of the row's columns being cast).
pub(super) struct RowHits<'a> {
    /// Ray parameters `x` of the columns.
    pub xs: &'a [f32],
    /// Hit time (= depth) per column; 0 = nothing hit yet.
    pub t: &'a mut [f32],
    /// Instance per column.
    pub inst: &'a mut [u8],
    /// `|n · dir|` per column (the cosine of the incidence angle after [`normalise_cos`]).
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

/// Turn a row's `|n · dir|` (as the kernels leave it in `cos`) into the cosine of the incidence
/// angle: times `1 / |dir|` (`y` is the row's camera-frame ray y, `xs` the columns').
#[inline(never)]
pub(super) fn normalise_cos(xs: &[f32], cos: &mut [f32], y: f32) {
    let y2p1 = y * y + 1.0;
    for (c, &x) in cos.iter_mut().zip(xs) {
        *c *= inv_len(x, y2p1);
    }
}

/// The room (inside of the box `[lo, hi]`): where each ray leaves it, overwriting the row
/// (`t`, `inst` = `structure`, `cos`). If the origin is outside the room nothing is hit: `t` =
/// 0 and `cos` = 0.
#[inline(never)] // one call per row and object; keeps the kernels apart in profiles
pub(super) fn room(h: RowHits, r: &RowRays, lo: Vec3, hi: Vec3, structure: u8) {
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
        *cos = if ok { dn } else { 0.0 };
        *inst = structure;
    }
}

/// The box `[-h, h]` (object frame): slab test; a hit nearer than the row's (or than `far` where
/// the row has none) replaces it with instance `id`.
///
/// Four pixels at a time in [`wide::f32x4`] lanes, with compare-selects rather than
/// `f32::min` / `max` (the compiler does not vectorise a loop with their NaN rules): the same
/// numbers as the scalar slab test of [`World::cast`](super::World::cast). A slab distance is
/// NaN only if the ray is parallel to that slab (`d = 0`) and the origin lies on one of its
/// planes; the other plane's distance is then ±∞, and [`slab`] returns it for both ends, as
/// `min` / `max` of the pair did.
#[inline(never)] // one call per row and object; keeps the kernels apart in profiles
pub(super) fn cuboid(h: RowHits, r: &RowRays, half: Vec3, far: f32, id: u8) {
    let (o, b, c) = (r.origin, r.base, r.col);
    let (lo, hi) = (-half - o, half - o);
    let s = f32x4::splat;
    let (zero, far) = (s(0.0), s(far));
    // One block of 4 pixels: new depths and cosines, and which lanes hit.
    let block = |x: f32x4, tr: f32x4, cos: f32x4| {
        let (dx, dy, dz) = (
            s(b.x) + s(c.x) * x,
            s(b.y) + s(c.y) * x,
            s(b.z) + s(c.z) * x,
        );
        let (nx, fx) = slab(s(lo.x), s(hi.x), dx);
        let (ny, fy) = slab(s(lo.y), s(hi.y), dy);
        let (nz, fz) = slab(s(lo.z), s(hi.z), dz);
        let t_in = max(max(nx, ny), nz);
        let t_out = min(min(fx, fy), fz);
        let t = max(t_in, zero);
        let best = tr.simd_gt(zero).bitselect(tr, far);
        let hit = t_out.simd_ge(t) & t.simd_lt(best) & t_in.simd_eq(t_in);
        // The entry face is the axis of the largest near distance (ties: x, then y).
        let on_x = nx.simd_ge(ny) & nx.simd_ge(nz);
        let dn = on_x.bitselect(dx, ny.simd_ge(nz).bitselect(dy, dz));
        (
            hit.bitselect(t, tr),
            hit.bitselect(dn.abs(), cos),
            hit.to_bitmask(),
        )
    };
    for i in (0..h.xs.len()).step_by(4) {
        let lanes = |v: &[f32]| f32x4::new(load4(v, i));
        let (t, cos, hits) = block(lanes(h.xs), lanes(h.t), lanes(h.cos));
        store4(h.t, i, t.to_array());
        store4(h.cos, i, cos.to_array());
        if hits != 0 {
            for (j, inst) in h.inst[i..].iter_mut().take(4).enumerate() {
                if hits >> j & 1 != 0 {
                    *inst = id;
                }
            }
        }
    }
}

/// `v[i..i + 4]`, padded with zeros past the end of `v` (`i < v.len()`).
#[inline(always)]
pub(super) fn load4<T: Copy + Default>(v: &[T], i: usize) -> [T; 4] {
    match v.get(i..i + 4) {
        Some(s) => [s[0], s[1], s[2], s[3]],
        None => {
            let mut a = [T::default(); 4];
            a.iter_mut().zip(&v[i..]).for_each(|(a, x)| *a = *x);
            a
        }
    }
}

/// Write `a` to `v[i..i + 4]`, as much of it as `v` holds (`i < v.len()`).
#[inline(always)]
pub(super) fn store4<T: Copy>(v: &mut [T], i: usize, a: [T; 4]) {
    match v.get_mut(i..i + 4) {
        Some(s) => s.copy_from_slice(&a),
        None => v[i..].iter_mut().zip(a).for_each(|(x, a)| *x = a),
    }
}

/// Entry and exit distances `(min, max)` of the slab `[lo, hi]` (relative to the origin) along
/// direction component `d`, as `(t1.min(t2), t1.max(t2))` of `t1 = lo · (1/d)`, `t2 = hi · (1/d)`
/// (at most one of them is NaN: then both are the other).
#[inline(always)]
fn slab(lo: f32x4, hi: f32x4, d: f32x4) -> (f32x4, f32x4) {
    let inv = f32x4::splat(1.0) / d;
    let (t1, t2) = (lo * inv, hi * inv);
    let t2 = t2.is_nan().bitselect(t1, t2);
    // A NaN `t1` fails both comparisons and yields `t2`.
    (min(t1, t2), max(t1, t2))
}

/// Lanewise `a.min(b)` for `b` not NaN (`a` NaN gives `b`).
#[inline(always)]
fn min(a: f32x4, b: f32x4) -> f32x4 {
    a.simd_lt(b).bitselect(a, b)
}

/// Lanewise `a.max(b)` for `b` not NaN (`a` NaN gives `b`).
#[inline(always)]
fn max(a: f32x4, b: f32x4) -> f32x4 {
    a.simd_gt(b).bitselect(a, b)
}

/// The cylinder of radius `radius` along the object's y axis, `|y| ≤ half_height`: side and the
/// cap facing the ray; a hit nearer than the row's replaces it with instance `id`.
#[inline(never)] // one call per row and object; keeps the kernels apart in profiles
pub(super) fn cylinder(h: RowHits, r: &RowRays, radius: f32, half_height: f32, far: f32, id: u8) {
    let (o, b, c) = (r.origin, r.base, r.col);
    let (rr, hh) = (radius * radius, half_height);
    let cc = o.x * o.x + o.z * o.z - rr;
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
        *cos = if hit { dn.abs() } else { *cos };
    }
}
