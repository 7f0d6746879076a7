//! Occlusion in the "in view" test of f_a (eq. 3): a foreground object counts as in view of a
//! candidate only if enough of it is not hidden from the camera.
//!
//! An object is probed at [`SAMPLES`] points of its estimated cuboid (the centre and the eight
//! corners pulled in to [`INNER`] of the half extents, so that a ray does not graze the object's
//! own faces or the support it stands on). A ray from the camera's optical centre to a sample is
//! hidden when it
//! - enters the cuboid of another map object, foreground or background (parry3d ray casts), unless
//!   the sample lies inside that cuboid (an object on a shelf lies inside the shelf's box; two
//!   estimated cuboids may interpenetrate): a container does not hide what it contains;
//! - crosses a wall: an OCCUPIED cell of the navigation grid that no mapped object explains
//!   (the grid is 2D and also holds tables and chairs, which the map's cuboids already model
//!   with their height). A cell is explained when its centre lies within the footprint of a map
//!   object grown by the grid's inflation, one cell and `slack` (`[planner] fa_wall_slack`: an
//!   estimated cuboid, from a partial view, can be smaller than the object); the last
//!   `inflation + cell` of the ray
//!   (the target's own surroundings) is not tested. An obstacle the map has not found yet is
//!   taken for a wall: a conservative reading.
//!
//! Everything here is allocation-free (it reads the map and grid by reference), so the test could
//! run on the LBV thread; the LBV runs with α = 0 and never evaluates f_a, so in practice only
//! GBV rounds (with the navigation grid) use it. The baselines' scoring of their own views keeps
//! the unfiltered sum (`FaFilter::FRUSTUM`).

use crate::clusters::cuboid;
use geom::{Cuboid, GridTraversal};
use glam::{Vec2, Vec3};
use parry3d::math::{Pose, Rot3};
use parry3d::query::{Ray, RayCast};
use parry3d::shape::Cuboid as PCuboid;
use shm_types::{MapObject, ObjectMap, OccupancyGrid, grid_cell};

/// Sample points probed per object.
pub const SAMPLES: usize = 9;

/// The corner samples lie at this fraction of the half extents from the centre.
pub const INNER: f32 = 0.7;

/// Walls for the occlusion test: the OCCUPIED cells of a navigation grid that no mapped object
/// explains.
#[derive(Debug, Clone, Copy)]
pub struct Walls<'a> {
    /// The grid.
    pub grid: &'a OccupancyGrid,
    /// By how much the grid's obstacles are inflated (the robot radius for the simulator's
    /// pre-built map), metres.
    pub inflation: f32,
    /// Extra distance around a map object's estimated footprint within which occupied cells are
    /// taken for that object (an estimated cuboid can be smaller than the object), metres.
    pub slack: f32,
}

/// The [`SAMPLES`] probe points of a cuboid: its centre and its corners at [`INNER`].
pub fn sample_points(c: &Cuboid) -> [Vec3; SAMPLES] {
    let inner = Cuboid {
        center: c.center,
        size: c.size * INNER,
        yaw: c.yaw,
    };
    let k = inner.corners();
    [c.center, k[0], k[1], k[2], k[3], k[4], k[5], k[6], k[7]]
}

/// Whether map object `o`'s cuboid lies on the segment `from → to` (either end inside the
/// cuboid: not hidden by it, see the module docs).
pub fn cuboid_blocks(o: &MapObject, from: Vec3, to: Vec3) -> bool {
    let c = cuboid(o);
    if c.contains(to, 0.01) || c.contains(from, 0.0) {
        return false;
    }
    let half = (c.size * 0.5).max(Vec3::splat(1e-3));
    let pose = Pose::from_parts(c.center, Rot3::from_rotation_z(c.yaw));
    let ray = Ray::new(from, to - from);
    PCuboid::new(half)
        .cast_ray(&pose, &ray, 1.0 - 1e-4, true)
        .is_some()
}

/// Whether a wall cell of `walls` lies on the segment `from → to` (2D traversal of the grid
/// cells the segment's horizontal projection crosses, Amanatides–Woo).
pub fn wall_blocks(walls: &Walls<'_>, map: &ObjectMap, from: Vec3, to: Vec3) -> bool {
    let g = walls.grid;
    let (w, h, res) = (g.width as i64, g.height as i64, g.resolution);
    if w == 0 || h == 0 || res <= 0.0 {
        return false;
    }
    let cells = g.used();
    let o = Vec2::from(g.origin);
    let (a2, b2) = (from.truncate(), to.truncate());
    let len = (b2 - a2).length();
    let keep = len - (walls.inflation + res);
    if keep <= 0.0 {
        return false;
    }
    let end = a2 + (b2 - a2) * (keep / len);
    let margin = walls.inflation + res + walls.slack;
    for (ix, iy) in GridTraversal::new((a2 - o) / res, (end - o) / res) {
        if ix >= 0 && iy >= 0 && ix < w && iy < h {
            let i = (iy * w + ix) as usize;
            if cells.get(i) == Some(&grid_cell::OCCUPIED) {
                let c = o + (Vec2::new(ix as f32, iy as f32) + 0.5) * res;
                let explained = map
                    .objects()
                    .iter()
                    .any(|m| cuboid(m).contains(c.extend(m.center[2]), margin));
                if !explained {
                    return true;
                }
            }
        }
    }
    false
}

/// Whether the segment `from → to` is hidden by a map object other than `skip` or a wall.
pub fn hidden(
    map: &ObjectMap,
    skip: usize,
    from: Vec3,
    to: Vec3,
    walls: Option<&Walls<'_>>,
) -> bool {
    map.objects()
        .iter()
        .enumerate()
        .any(|(j, o)| j != skip && cuboid_blocks(o, from, to))
        || walls.is_some_and(|w| wall_blocks(w, map, from, to))
}

/// Fraction of map object `i`'s [`sample_points`] that the camera at `from` sees unhidden.
pub fn visible_fraction(map: &ObjectMap, i: usize, from: Vec3, walls: Option<&Walls<'_>>) -> f32 {
    let pts = sample_points(&cuboid(&map.objects()[i]));
    let seen = pts
        .iter()
        .filter(|p| !hidden(map, i, from, **p, walls))
        .count();
    seen as f32 / SAMPLES as f32
}

/// Whether at least `min_visible` of object `i`'s samples are unhidden from `from` (stops as
/// soon as the answer is known).
pub fn is_visible(
    map: &ObjectMap,
    i: usize,
    from: Vec3,
    walls: Option<&Walls<'_>>,
    min_visible: f32,
) -> bool {
    let need = (min_visible * SAMPLES as f32 - 1e-4).ceil().max(0.0) as usize;
    let pts = sample_points(&cuboid(&map.objects()[i]));
    let (mut seen, mut left) = (0usize, SAMPLES);
    for p in &pts {
        if seen >= need {
            return true;
        }
        if seen + left < need {
            return false;
        }
        seen += !hidden(map, i, from, *p, walls) as usize;
        left -= 1;
    }
    seen >= need
}

#[cfg(test)]
mod tests {
    use super::*;
    use shm_types::boxed_zeroed;

    fn obj(map: &mut ObjectMap, c: [f32; 3], s: [f32; 3], background: bool) -> usize {
        let k = map.count as usize;
        let o = &mut map.objects[k];
        o.id = k as u32 + 1;
        o.center = c;
        o.size = s;
        o.background = background as u8;
        map.count += 1;
        k
    }

    /// A cup at 3 m on the x axis, camera at the origin at the cup's height. A box between them
    /// that covers the cup's whole silhouette hides every sample; moved behind the cup, it hides
    /// none.
    #[test]
    fn an_object_behind_a_cuboid_is_hidden_in_front_it_is_not() {
        let mut m = boxed_zeroed::<ObjectMap>();
        let cup = obj(&mut m, [3.0, 0.0, 0.8], [0.1, 0.1, 0.12], false);
        let wall = obj(&mut m, [2.0, 0.0, 0.8], [0.2, 0.6, 0.6], true);
        let cam = Vec3::new(0.0, 0.0, 0.8);
        assert_eq!(visible_fraction(&m, cup, cam, None), 0.0);
        assert!(!is_visible(&m, cup, cam, None, 0.5));
        // The box itself is seen (the cup does not hide it).
        assert_eq!(visible_fraction(&m, wall, cam, None), 1.0);
        m.objects[wall].center = [4.0, 0.0, 0.8];
        assert_eq!(visible_fraction(&m, cup, cam, None), 1.0);
        assert!(is_visible(&m, cup, cam, None, 0.5));
        // Half-covering: a box covering y > 0 hides the centre? No: it covers y ≥ 0.005 only,
        // so the centre and the 4 corners at y = −0.035 are seen, the 4 at +0.035 hidden: 5/9.
        m.objects[wall].center = [2.0, 0.305, 0.8];
        assert!((visible_fraction(&m, cup, cam, None) - 5.0 / 9.0).abs() < 1e-6);
        assert!(is_visible(&m, cup, cam, None, 0.5));
        assert!(!is_visible(&m, cup, cam, None, 0.6));
    }

    /// A cup standing on a table and a bottle inside a shelf's box: their supports do not hide
    /// them from a camera above and in front.
    #[test]
    fn supports_and_containers_do_not_hide() {
        let mut m = boxed_zeroed::<ObjectMap>();
        let _table = obj(&mut m, [2.0, 0.0, 0.375], [1.0, 0.8, 0.75], true);
        let cup = obj(&mut m, [2.0, 0.0, 0.81], [0.1, 0.1, 0.12], false);
        let cam = Vec3::new(0.5, 0.0, 1.4);
        assert_eq!(visible_fraction(&m, cup, cam, None), 1.0);
        let _shelf = obj(&mut m, [0.0, 3.0, 0.9], [1.0, 0.4, 1.8], true);
        let bottle = obj(&mut m, [0.0, 2.95, 1.0], [0.08, 0.08, 0.25], false);
        assert_eq!(
            visible_fraction(&m, bottle, Vec3::new(0.0, 1.5, 1.4), None),
            1.0
        );
        // Seen from behind the shelf (through the shelf's back): hidden by the shelf? The
        // bottle lies inside the shelf's box, so the box does not count (documented limit).
        assert_eq!(
            visible_fraction(&m, bottle, Vec3::new(0.0, 4.5, 1.4), None),
            1.0
        );
    }

    /// A 4 m × 2 m grid (0.1 m cells) with a wall (x in [1.9, 2.1], full height) across it, not
    /// explained by any map object: a cup beyond it is hidden, a cup before it is not, and a
    /// table footprint in the grid (explained by the table's cuboid) hides nothing.
    #[test]
    fn walls_of_the_grid_hide_unless_a_map_object_explains_them() {
        let mut g = boxed_zeroed::<OccupancyGrid>();
        g.origin = [0.0, -1.0];
        g.resolution = 0.1;
        g.width = 40;
        g.height = 20;
        for iy in 0..20 {
            for ix in 19..21 {
                g.cells[iy * 40 + ix] = grid_cell::OCCUPIED;
            }
        }
        let walls = Walls {
            grid: &g,
            inflation: 0.0,
            slack: 0.0,
        };
        let mut m = boxed_zeroed::<ObjectMap>();
        let far = obj(&mut m, [3.0, 0.0, 0.8], [0.1, 0.1, 0.1], false);
        let near = obj(&mut m, [1.2, 0.0, 0.8], [0.1, 0.1, 0.1], false);
        let cam = Vec3::new(0.2, 0.0, 1.4);
        assert_eq!(visible_fraction(&m, far, cam, Some(&walls)), 0.0);
        assert_eq!(visible_fraction(&m, near, cam, Some(&walls)), 1.0);
        assert_eq!(
            visible_fraction(&m, far, cam, None),
            1.0,
            "no grid, no wall"
        );
        // A low table whose estimated cuboid ends 0.3 m short of the wall cells: with a slack of
        // 0.3 m (not 0.2) the cells are taken for the table.
        let table = obj(&mut m, [2.0, 0.0, 0.2], [0.2, 2.0, 0.4], true);
        m.objects[table].center = [1.5, 0.0, 0.2];
        m.objects[table].size = [0.2, 2.0, 0.4];
        // Footprint x in [1.4, 1.6]; wall cell centres at 1.95 and 2.05: 0.35 and 0.45 away.
        let slack = |s| Walls { slack: s, ..walls };
        assert_eq!(visible_fraction(&m, far, cam, Some(&slack(0.2))), 0.0);
        assert_eq!(visible_fraction(&m, far, cam, Some(&slack(0.36))), 1.0);
        // The same cells inside a (low) table's cuboid: no longer a wall.
        m.objects[table].center = [2.0, 0.0, 0.2];
        assert_eq!(visible_fraction(&m, far, cam, Some(&walls)), 1.0);
    }
}
