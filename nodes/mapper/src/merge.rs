//! Duplicate merging (an addition beyond the paper, `[mapper.extensions] duplicate_merge`):
//! after each frame, two objects that are one object seen twice (compatible classes, strongly
//! overlapping cuboids) are merged into the older one. With `[mapper.extensions] cross_class`,
//! foreground objects of incompatible classes whose cuboids overlap with IoU ≥
//! `[mapper] cross_merge_iou` are one object labelled two ways and are merged too (the class is
//! the score vote of both). With `[mapper.extensions] cross_class_join`, foreground objects of
//! any classes are duplicates by the same rules as compatible ones (with `cross_class_mutual`
//! only when each centre lies inside the other's cuboid grown by `merge_margin`) (IoU ≥ `cross_merge_iou`, or
//! the smaller one's centre inside the larger with ≥ `merge_containment` of it inside): a
//! persistent label confusion or a false-positive box over a real object founds a wrong-label
//! object at the real one's place, and the merged votes give the label.

use super::points::rest_on_support;
use super::{Mapper, cuboid};

impl Mapper {
    /// Whether objects `i` and `j` are one object seen twice: same kind (background or not),
    /// compatible classes (background: equal), and strongly overlapping cuboids (background:
    /// footprints, whatever their plane heights: a side view of a table yields a sliver whose
    /// "plane" is any height of its front face): IoU ≥ `merge_iou`, or the smaller one's centre
    /// inside the larger one with ≥ `merge_containment` of its volume (area) inside.
    pub(super) fn duplicates(&self, i: usize, j: usize) -> bool {
        !self.detected_apart(i, j) && self.overlap_as_duplicates(i, j)
    }

    /// Whether foreground objects `i` and `j` were detected together (each by its own
    /// detection of one frame) often enough to be two objects (`[mapper.extensions]
    /// co_detection`): in `distinct_after` frames, and in at least `co_detection_min_share` of
    /// the frames in which either was detected while their cuboids overlapped. A detector
    /// sees two real neighbours together in most such frames; an object and the twin that its
    /// mislocalised duplicate boxes founded, only when such a box comes again.
    pub(super) fn detected_apart(&self, i: usize, j: usize) -> bool {
        let (a, b) = (&self.objects[i], &self.objects[j]);
        if !self.cfg.extensions.co_detection || a.background {
            return false;
        }
        let together = a.co_seen_with(b.id);
        let alone = a.co_apart_with(b.id);
        together >= self.cfg.distinct_after
            && together as f32 >= self.cfg.co_detection_min_share * (together + alone) as f32
    }

    /// Whether the cuboids of objects `i` and `j` overlap as one object's seen twice (the
    /// geometric part of [`Self::duplicates`]; see there).
    pub(super) fn overlap_as_duplicates(&self, i: usize, j: usize) -> bool {
        let (a, b) = (&self.objects[i], &self.objects[j]);
        if a.background != b.background || a.observations == 0 || b.observations == 0 {
            return false;
        }
        let (ca, cb) = (&a.cuboid, &b.cuboid);
        // Cheap reject: bounding circles apart.
        let (ra, rb) = (ca.size.truncate().length(), cb.size.truncate().length());
        if ca.center.truncate().distance(cb.center.truncate()) > 0.5 * (ra + rb) {
            return false;
        }
        let (inter, va, vb, iou_min) = if a.background {
            if a.class_id != b.class_id {
                return false;
            }
            let area = |c: &cuboid::Box3| c.size.x.max(0.0) * c.size.y.max(0.0);
            (
                ca.footprint_intersection(cb),
                area(ca),
                area(cb),
                self.cfg.merge_iou,
            )
        } else {
            if !self.groups.compatible(a.class_id, b.class_id) {
                // One object labelled two ways (a confusion outside the look-alike groups).
                let inter = ca.intersection_volume(cb);
                let union = ca.volume() + cb.volume() - inter;
                let iou_dup = union > 0.0 && inter / union >= self.cfg.cross_merge_iou;
                if !self.cfg.extensions.cross_class_join {
                    return self.cfg.extensions.cross_class && iou_dup;
                }
                // cross_class_mutual: each centre inside the other (grown by merge_margin).
                let m = self.cfg.merge_margin;
                let each_in_other = a.contains(cb.center, m) && b.contains(ca.center, m);
                if self.cfg.extensions.cross_class_mutual && !each_in_other {
                    return false;
                }
                if iou_dup {
                    return true;
                }
                // cross_class_join: also the containment rule below (no IoU rule).
                (inter, ca.volume(), cb.volume(), f32::INFINITY)
            } else {
                (
                    ca.intersection_volume(cb),
                    ca.volume(),
                    cb.volume(),
                    self.cfg.merge_iou,
                )
            }
        };
        if inter <= 0.0 {
            return false;
        }
        let union = va + vb - inter;
        if union > 0.0 && inter / union >= iou_min {
            return true;
        }
        let (small, large, v_small) = if va <= vb { (a, b, va) } else { (b, a, vb) };
        let mut probe = small.cuboid.center;
        if a.background {
            probe.z = large.cuboid.center.z;
        }
        let m = self.cfg.merge_margin;
        let grown = cuboid::Box3 {
            size: large.cuboid.size + glam::Vec3::splat(2.0 * m),
            ..large.cuboid
        };
        let inside = if a.background {
            small.cuboid.footprint_intersection(&grown)
        } else {
            small.cuboid.intersection_volume(&grown)
        };
        v_small > 0.0 && inside / v_small >= self.cfg.merge_containment && large.contains(probe, m)
    }

    /// Merge duplicate objects into the older one (see [`MappedObject::absorb`]); the cuboid is
    /// refitted from the merged cloud. Returns the number of objects merged away. Clusters follow
    /// automatically: a foreground object's cluster is looked up among the surviving background
    /// objects when the map is written.
    pub(super) fn merge_duplicates(&mut self) -> u32 {
        let mut merged = 0;
        let fit = self.fit_params();
        'outer: loop {
            for i in 0..self.objects.len() {
                for j in i + 1..self.objects.len() {
                    if !self.duplicates(i, j) {
                        continue;
                    }
                    let (oi, oj) = (&self.objects[i], &self.objects[j]);
                    let (keep, drop) = if (oi.first_seen_ns, oi.id) <= (oj.first_seen_ns, oj.id) {
                        (i, j)
                    } else {
                        (j, i)
                    };
                    let gone = self.objects.remove(drop);
                    let keep = if drop < keep { keep - 1 } else { keep };
                    let o = &mut self.objects[keep];
                    o.absorb(&gone);
                    o.views.absorb(&gone.views, &self.cfg.view_extents);
                    let dyaw = o.refit(&mut self.cuboid_scratch, &mut self.centroids, &fit);
                    if !o.background {
                        rest_on_support(&mut o.cuboid, &self.supports, self.cfg.support_margin);
                    }
                    o.follow_yaw(dyaw);
                    merged += 1;
                    continue 'outer;
                }
            }
            break;
        }
        merged
    }
}

#[cfg(test)]
mod tests {
    use super::super::object::MappedObject;
    use super::super::{Mapper, MapperConfig};
    use geom::Camera;
    use glam::Vec3;

    /// A table top: points on a plane at 0.72 m over `x0..x1 × y0..y1`.
    fn table_points(x0: f32, x1: f32, y0: f32, y1: f32) -> Vec<Vec3> {
        let mut v = Vec::new();
        let n = 30;
        for i in 0..=n {
            for j in 0..=n {
                let (fx, fy) = (i as f32 / n as f32, j as f32 / n as f32);
                v.push(Vec3::new(x0 + fx * (x1 - x0), y0 + fy * (y1 - y0), 0.72));
            }
        }
        v
    }

    fn cube_points(c: Vec3, half: f32) -> Vec<Vec3> {
        let mut v = Vec::new();
        for i in 0..8 {
            for j in 0..8 {
                for k in 0..8 {
                    let f = |t: i32| (t as f32 / 7.0 * 2.0 - 1.0) * half;
                    v.push(c + Vec3::new(f(i), f(j), f(k)));
                }
            }
        }
        v
    }

    #[test]
    fn duplicates_merge_into_the_older_object() {
        let cam = Camera::from_fov(64, 48, 60.0, 46.8, 0.5, 5.0);
        let mut m = Mapper::new(&MapperConfig::default(), &cam).unwrap();
        let id = |n| shm_types::class_id(n).unwrap();
        let table = id("dining table");
        let fit = m.fit_params();
        let sopm = m.cfg.sopm.params();
        let add = |m: &mut Mapper, class, bg: bool, t: u64, pts: &[Vec3], from: Vec3| {
            let mut o = MappedObject::new(
                m.next_id,
                class,
                0.9,
                bg,
                if bg { 0.03 } else { 0.01 },
                20000,
                (!bg).then_some(sopm),
                t,
            );
            m.next_id += 1;
            o.merge(pts, from);
            o.refit(&mut m.cuboid_scratch, &mut m.centroids, &fit);
            o.observations = 1;
            o.update_sopm(pts, from, 0.0);
            m.objects.push(o);
        };
        // The same table seen from two sides: two partial footprints overlapping by 70 %.
        add(
            &mut m,
            table,
            true,
            5,
            &table_points(0.0, 1.0, 0.0, 0.8),
            Vec3::ZERO,
        );
        add(
            &mut m,
            table,
            true,
            3,
            &table_points(0.3, 1.3, 0.0, 0.8),
            Vec3::ZERO,
        );
        // Its front face seen edge-on (8 cm deep band of points from 0.3 to 0.6 m high).
        let face: Vec<Vec3> = (0..400)
            .map(|k| {
                Vec3::new(
                    0.4 + (k % 20) as f32 * 0.02,
                    0.01 + (k % 5) as f32 * 0.02,
                    0.3 + (k / 20) as f32 * 0.015,
                )
            })
            .collect();
        add(&mut m, table, true, 8, &face, Vec3::ZERO);
        // A cup and a vase (confusable) at the same place, a bottle 30 cm away, a chair table.
        let c = Vec3::new(0.5, 0.4, 0.8);
        let left = Vec3::new(0.5, -1.0, 1.0);
        let right = Vec3::new(0.5, 2.0, 1.0);
        add(&mut m, id("cup"), false, 7, &cube_points(c, 0.04), left);
        add(
            &mut m,
            id("vase"),
            false,
            9,
            &cube_points(c + Vec3::X * 0.01, 0.04),
            right,
        );
        add(
            &mut m,
            id("bottle"),
            false,
            9,
            &cube_points(c + Vec3::X * 0.3, 0.04),
            left,
        );
        let cup_h = m.objects[3].sopm.as_ref().unwrap().h_sopm();
        assert!(m.objects[2].support_height.unwrap() < 0.65);
        assert_eq!(m.merge_duplicates(), 3);
        assert_eq!(m.objects.len(), 3);
        let t = &m.objects[0];
        // Id of the one seen first (id 2, t = 3), union of the footprints.
        assert_eq!((t.id, t.first_seen_ns, t.observations), (2, 3, 3));
        assert!((t.cuboid.size.x - 1.3).abs() < 0.05, "{:?}", t.cuboid);
        assert!((t.support_height.unwrap() - 0.72).abs() < 0.02);
        let cup = &m.objects[1];
        assert_eq!((cup.id, cup.observations), (4, 2));
        assert!([id("cup"), id("vase")].contains(&cup.class_id));
        // Both sides' evidence: the merged map is more certain than either half.
        assert!(cup.sopm.as_ref().unwrap().h_sopm() < cup_h - 0.1);
        assert_eq!(m.objects[2].class_id, id("bottle"));
        // The cup's cluster is the surviving table.
        m.refresh_supports();
        assert_eq!(m.cluster_of(&m.objects[1]), 2);
    }
}
