//! Synthetic object maps for benchmarks and tests (fabricated maps, not ground truth): objects
//! with partly observed cylindrical SOPM grids whose `h_sopm` (eq. 10) and `l_best` (eq. 11)
//! are computed from the cells, and sample points with mean lines of sight.

use glam::Vec3;
use shm_types::{MAX_OBJECT_POINTS, MapObject, ObjectMap, boxed_zeroed, sopm_shape};
use std::f32::consts::TAU;

/// SOPM columns of the synthetic objects.
pub const COLS: usize = 18;
/// SOPM rows of the synthetic objects.
pub const ROWS: usize = 18;

fn entropy(p: f32) -> f32 {
    if p <= 0.0 || p >= 1.0 {
        0.0
    } else {
        -p * p.log2() - (1.0 - p) * (1.0 - p).log2()
    }
}

/// Add an object to `map` and return its index. `observed_from` lists world xy points the
/// object was seen from: SOPM columns facing one of them (within ±60°) are observed (occupied
/// 0.85 on the lower two thirds, free 0.15 above), the others unknown (0.5); the 64 sample
/// points lie on the visible side and top with mean LoS from the first such point (camera height
/// 1.4 m). `h_sopm`, `l_best` and `complete` follow from the cells.
#[allow(clippy::too_many_arguments)]
pub fn add_object(
    map: &mut ObjectMap,
    id: u32,
    class_id: u16,
    background: bool,
    cluster_id: i32,
    center: [f32; 3],
    size: [f32; 3],
    observed_from: &[[f32; 2]],
    first_seen_ns: u64,
) -> usize {
    let k = map.count as usize;
    map.count += 1;
    let o: &mut MapObject = &mut map.objects[k];
    o.id = id;
    o.class_id = class_id;
    o.background = background as u8;
    o.cluster_id = cluster_id;
    o.center = center;
    o.size = size;
    o.first_seen_ns = first_seen_ns;
    o.c_asso = 0.96;
    o.observations = 10 * observed_from.len() as u32;
    o.sopm_shape = sopm_shape::CYLINDER;
    o.sopm_cols = COLS as u16;
    o.sopm_rows = ROWS as u16;
    let c = Vec3::from(center);
    let r = 0.5 * (size[0] * size[0] + size[1] * size[1]).sqrt();
    let mut h_sum = 0.0;
    let mut l_best = Vec3::ZERO;
    for row in 0..ROWS {
        let z = c.z + size[2] * ((row as f32 + 0.5) / ROWS as f32 - 0.5);
        for col in 0..COLS {
            let a = TAU * (col as f32 + 0.5) / COLS as f32;
            let dir = Vec3::new(a.cos(), a.sin(), 0.0);
            let seen = observed_from.iter().any(|f| {
                let to = Vec3::new(f[0] - c.x, f[1] - c.y, 0.0).normalize_or_zero();
                to.dot(dir) > 0.5
            });
            let p = match (seen, row < 2 * ROWS / 3) {
                (false, _) => 0.5,
                (true, true) => 0.85,
                (true, false) => 0.15,
            };
            let h = entropy(p);
            o.sopm_prob[row * COLS + col] = p;
            o.sopm_obs[row * COLS + col] = seen as u16 * 3;
            h_sum += h;
            let g = Vec3::new(c.x + r * dir.x, c.y + r * dir.y, z);
            l_best += (g - c) * h;
        }
    }
    o.h_sopm = h_sum / (ROWS * COLS) as f32;
    o.complete = (!background && o.h_sopm < map.eps_sopm) as u8;
    o.l_best = l_best.to_array();
    if let Some(f) = observed_from.first() {
        let cam = Vec3::new(f[0], f[1], 1.4);
        let toward = Vec3::new(f[0] - c.x, f[1] - c.y, 0.0).normalize_or_zero();
        let h = Vec3::from(size) * 0.5;
        o.sample_count = MAX_OBJECT_POINTS as u16;
        for i in 0..MAX_OBJECT_POINTS {
            // 8 × 8 points: half on the top face, half on the side facing the viewer.
            let (u, v) = ((i % 8) as f32 / 7.0 - 0.5, (i / 8) as f32 / 7.0);
            let p = if i < 32 {
                c + Vec3::new(u * 2.0 * h.x, (v * 2.0 - 0.5) * h.y, h.z)
            } else {
                let side = Vec3::new(-toward.y, toward.x, 0.0);
                c + toward * h.x.min(h.y)
                    + side * u * 2.0 * h.x.max(h.y) * 0.5
                    + Vec3::Z * ((v - 0.5) * 2.0 * h.z)
            };
            o.points[i] = p.to_array();
            o.point_los[i] = (p - cam).normalize_or_zero().to_array();
        }
    }
    k
}

/// A scene-3-like map (the recipe): desk at (−1.617, 0.178) 0.559 × 1.829 × 0.762 with 6
/// objects, cafe table at (−3.753, −0.653) 0.913 × 0.913 × 0.785 with 4, chair at
/// (−3.745, 1.197) with a vase; SOPM grids partly observed from the robot's path near the
/// origin, 64 sample points each. Object ids: desk 1, table 10, chair 20.
pub fn scene3_map() -> Box<ObjectMap> {
    let mut m = boxed_zeroed::<ObjectMap>();
    m.eps_sopm = 0.42;
    m.header.seq = 1;
    let seen_a: &[[f32; 2]] = &[[0.0, 0.0]];
    let seen_b: &[[f32; 2]] = &[[0.0, 0.0], [-1.6, 2.0]];
    let (desk, table, chair) = (
        ([-1.617, 0.178], 0.559, 1.829, 0.762),
        ([-3.753, -0.653], 0.913, 0.913, 0.785),
        ([-3.745, 1.197], 0.45, 0.45, 0.45),
    );
    // COCO ids: 60 dining table, 56 chair, 41 cup, 39 bottle, 63 laptop, 73 book, 75 vase.
    add_object(
        &mut m,
        1,
        60,
        true,
        1,
        [desk.0[0], desk.0[1], desk.3 / 2.0],
        [desk.1, desk.2, desk.3],
        seen_b,
        1,
    );
    let desk_items: [(u16, [f32; 2], [f32; 3]); 6] = [
        (41, [-1.55, -0.45], [0.09, 0.09, 0.11]),
        (39, [-1.70, -0.15], [0.07, 0.07, 0.25]),
        (63, [-1.60, 0.20], [0.33, 0.24, 0.03]),
        (73, [-1.65, 0.55], [0.17, 0.24, 0.04]),
        (41, [-1.50, 0.80], [0.09, 0.09, 0.11]),
        (39, [-1.72, 0.95], [0.07, 0.07, 0.25]),
    ];
    for (i, (cls, xy, s)) in desk_items.iter().enumerate() {
        let from = if i % 2 == 0 { seen_a } else { seen_b };
        add_object(
            &mut m,
            2 + i as u32,
            *cls,
            false,
            1,
            [xy[0], xy[1], desk.3 + s[2] / 2.0],
            *s,
            from,
            2 + i as u64,
        );
    }
    add_object(
        &mut m,
        10,
        60,
        true,
        10,
        [table.0[0], table.0[1], table.3 / 2.0],
        [table.1, table.2, table.3],
        seen_a,
        20,
    );
    let table_items: [(u16, [f32; 2], [f32; 3]); 4] = [
        (41, [-3.60, -0.50], [0.09, 0.09, 0.11]),
        (39, [-3.90, -0.80], [0.07, 0.07, 0.25]),
        (73, [-3.70, -0.85], [0.17, 0.24, 0.04]),
        (41, [-3.85, -0.40], [0.09, 0.09, 0.11]),
    ];
    for (i, (cls, xy, s)) in table_items.iter().enumerate() {
        add_object(
            &mut m,
            11 + i as u32,
            *cls,
            false,
            10,
            [xy[0], xy[1], table.3 + s[2] / 2.0],
            *s,
            seen_a,
            21 + i as u64,
        );
    }
    add_object(
        &mut m,
        20,
        56,
        true,
        20,
        [chair.0[0], chair.0[1], chair.3 / 2.0],
        [chair.1, chair.2, chair.3],
        seen_a,
        30,
    );
    add_object(
        &mut m,
        21,
        75,
        false,
        20,
        [chair.0[0], chair.0[1], chair.3 + 0.1],
        [0.12, 0.12, 0.2],
        seen_a,
        31,
    );
    m
}

#[cfg(test)]
mod tests {
    use super::*;
    use shm_types::Validate;

    #[test]
    fn scene3_is_valid_and_l_best_points_away_from_the_viewer() {
        let m = scene3_map();
        assert_eq!(m.validate(), Ok(()));
        assert_eq!(m.count, 14);
        let cup = &m.objects[1];
        assert!(cup.h_sopm > 0.42 && cup.h_sopm < 1.0, "{}", cup.h_sopm);
        // Seen from the origin (east of the desk): the unobserved side is west.
        assert!(cup.l_best[0] < 0.0, "{:?}", cup.l_best);
    }
}
