//! Object clusters (paper section 3): one background object and the foreground objects whose
//! `cluster_id` names it. Clusters are processed in order of first sighting.
//!
//! Completion (section 3.4): a foreground object is done when `complete` is set by the mapper or
//! `h_sopm < ε_sopm`; a cluster is done when all its foreground objects are done. A cluster of
//! which no foreground object is known yet counts as unfinished until its centre has been in view
//! from at least `bootstrap.empty_cluster_sectors` of `bootstrap.sectors` angular sectors around
//! it ([`SideTracker`]): an empty table is "looked at from enough sides" before it is left.
//! No cluster is done before it has been *approached*: in view from within
//! `bootstrap.approach_m` of its support's footprint circle. A table seen only from across the
//! room shows its large objects, which may complete from there, but not its small ones (an apple
//! at 3 m is ~15 px, below what a YOLO-class detector finds reliably), so without this rule its
//! cluster counted as done with most of its objects never mapped.
//! Foreground objects without a cluster (`cluster_id = −1`) count in f_a but not for termination.

use crate::terms::View;
use geom::{Camera, Cuboid};
use glam::{Vec2, Vec3};
use shm_types::{MAX_OBJECTS, MapObject, ObjectMap};

/// Whether a foreground object's modelling is complete.
pub fn fg_done(o: &MapObject, eps_sopm: f32) -> bool {
    o.is_complete() || o.h_sopm < eps_sopm
}

/// The cuboid of a map object.
pub fn cuboid(o: &MapObject) -> Cuboid {
    Cuboid {
        center: Vec3::from(o.center),
        size: Vec3::from(o.size),
        yaw: o.yaw,
    }
}

/// Members of cluster `id` (the background object and its foreground objects).
pub fn members(map: &ObjectMap, id: i32) -> impl Iterator<Item = &MapObject> {
    map.objects().iter().filter(move |o| o.cluster_id == id)
}

/// Summary of one cluster.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ClusterInfo {
    /// Cluster id = the background object's id.
    pub id: i32,
    /// Earliest `first_seen_ns` over the members.
    pub first_seen_ns: u64,
    /// Centre: middle of the members' footprint (xy), mean member centre height (z).
    pub center: Vec3,
    /// Radius of the members' footprint around `center` (xy), metres.
    pub radius: f32,
    /// Known foreground objects.
    pub foreground: u32,
    /// Of which done.
    pub foreground_done: u32,
    /// Whether the cluster is done (see module docs).
    pub done: bool,
    /// Sectors (bit mask, see [`SideTracker`]) from which the cluster was seen; filled by
    /// [`clusters`] and [`first_unfinished`], 0 from [`cluster_info`].
    pub sides_seen: u64,
    /// Whether the cluster was in view from near (see [`SideTracker`]); filled like
    /// `sides_seen`, false from [`cluster_info`].
    pub approached: bool,
}

/// Geometry of cluster `id` (centre, footprint radius, earliest sighting, fg counts); `None` if
/// it has no member. Does not allocate.
pub fn cluster_info(map: &ObjectMap, id: i32, eps_sopm: f32) -> Option<ClusterInfo> {
    let mut lo = Vec2::splat(f32::INFINITY);
    let mut hi = Vec2::splat(f32::NEG_INFINITY);
    let (mut zsum, mut n, mut first, mut fg, mut done) = (0.0, 0u32, u64::MAX, 0u32, 0u32);
    for o in members(map, id) {
        for c in cuboid(o).corners() {
            lo = lo.min(c.truncate());
            hi = hi.max(c.truncate());
        }
        zsum += o.center[2];
        n += 1;
        first = first.min(o.first_seen_ns);
        if !o.is_background() {
            fg += 1;
            done += fg_done(o, eps_sopm) as u32;
        }
    }
    if n == 0 {
        return None;
    }
    let mid = (lo + hi) * 0.5;
    Some(ClusterInfo {
        id,
        first_seen_ns: first,
        center: mid.extend(zsum / n as f32),
        radius: ((hi - lo) * 0.5).length(),
        foreground: fg,
        foreground_done: done,
        done: fg > 0 && done == fg,
        sides_seen: 0,
        approached: false,
    })
}

/// Whether background object `o` is a duplicate of an earlier-seen one: its centre lies inside
/// that object's cuboid footprint (xy; e.g. a table also mapped as "bed"). A cluster without
/// foreground objects whose background object is such a duplicate is done at once: its table is
/// the other cluster's, looked at with it. Does not allocate.
pub fn is_duplicate(map: &ObjectMap, o: &MapObject) -> bool {
    let c = Vec3::from(o.center);
    map.objects().iter().any(|b| {
        b.is_background()
            && b.id != o.id
            && (b.first_seen_ns, b.id) < (o.first_seen_ns, o.id)
            && cuboid(b).contains(Vec3::new(c.x, c.y, b.center[2]), 0.0)
    })
}

/// All clusters of the map sorted by first sighting (ties by id), with `done` decided by the
/// mapper's completion flags and, for clusters without foreground objects, by `sides` (or
/// [`is_duplicate`]).
pub fn clusters(
    map: &ObjectMap,
    eps_sopm: f32,
    sides: &SideTracker,
    min_sides: usize,
) -> Vec<ClusterInfo> {
    let mut out: Vec<ClusterInfo> = map
        .objects()
        .iter()
        .filter(|o| o.is_background())
        .filter_map(|o| Some((o, cluster_info(map, o.id as i32, eps_sopm)?)))
        .map(|(o, mut c)| {
            sides.judge(map, o, &mut c, min_sides);
            c
        })
        .collect();
    out.sort_by_key(|c| (c.first_seen_ns, c.id));
    out
}

/// The first (by sighting) cluster that is not done and not in `skip`, without allocating.
pub fn first_unfinished(
    map: &ObjectMap,
    eps_sopm: f32,
    sides: &SideTracker,
    min_sides: usize,
    skip: &[i32],
) -> Option<ClusterInfo> {
    let mut best: Option<ClusterInfo> = None;
    for o in map.objects().iter().filter(|o| o.is_background()) {
        let id = o.id as i32;
        if skip.contains(&id) {
            continue;
        }
        let Some(mut c) = cluster_info(map, id, eps_sopm) else {
            continue;
        };
        sides.judge(map, o, &mut c, min_sides);
        if !c.done && best.is_none_or(|b| (c.first_seen_ns, c.id) < (b.first_seen_ns, b.id)) {
            best = Some(c);
        }
    }
    best
}

/// The point the cluster should be watched at (θ_c, eq. 23): the centroid of its unfinished
/// foreground objects; if there is none (empty or finished cluster), the cluster centre.
pub fn unfinished_centroid(map: &ObjectMap, info: &ClusterInfo, eps_sopm: f32) -> Vec3 {
    let (mut sum, mut n) = (Vec3::ZERO, 0u32);
    for o in members(map, info.id) {
        if !o.is_background() && !fg_done(o, eps_sopm) {
            sum += Vec3::from(o.center);
            n += 1;
        }
    }
    if n == 0 { info.center } else { sum / n as f32 }
}

/// Remembers from which angular sectors each background object's centre has been in view, and
/// whether it was in view from near: from within `approach` of its footprint's bounding circle
/// (xy). Fixed capacity ([`MAX_OBJECTS`] clusters, 64 sectors): updating it never allocates.
#[derive(Debug, Clone)]
pub struct SideTracker {
    sectors: usize,
    approach: f32,
    ids: [i32; MAX_OBJECTS],
    masks: [u64; MAX_OBJECTS],
    near: [bool; MAX_OBJECTS],
    len: usize,
}

impl SideTracker {
    /// A tracker with `sectors` (1..=64) sectors around each cluster, without the approach rule
    /// (every cluster counts as approached; see [`SideTracker::with_approach`]).
    pub fn new(sectors: usize) -> Self {
        Self {
            sectors: sectors.clamp(1, 64),
            approach: f32::INFINITY,
            ids: [0; MAX_OBJECTS],
            masks: [0; MAX_OBJECTS],
            near: [false; MAX_OBJECTS],
            len: 0,
        }
    }

    /// Views count as near a background object when taken within `metres` of its footprint's
    /// bounding circle (xy).
    pub fn with_approach(mut self, metres: f32) -> Self {
        self.approach = metres;
        self
    }

    /// Fill `c`'s `sides_seen` and `approached` and decide its `done` (module docs): not before
    /// it was approached; without foreground objects, once seen from `min_sides` sectors (or at
    /// once if its background object `o` duplicates an earlier one).
    pub fn judge(&self, map: &ObjectMap, o: &MapObject, c: &mut ClusterInfo, min_sides: usize) {
        c.sides_seen = self.mask(c.id);
        c.approached = self.approached(c.id);
        // `is_duplicate` scans the map: only for clusters without foreground objects (the LBV
        // thread judges every cluster each cycle).
        if c.foreground > 0 {
            c.done &= c.approached;
        } else {
            c.done = is_duplicate(map, o) || c.approached && self.sides(c.id) >= min_sides;
        }
    }

    /// [`SideTracker::judge`] for the cluster of background object `c.id`, if it is in `map`.
    pub fn judge_by_id(&self, map: &ObjectMap, c: &mut ClusterInfo, min_sides: usize) {
        if let Some(o) = map.objects().iter().find(|o| o.id as i32 == c.id) {
            self.judge(map, o, c, min_sides);
        }
    }

    /// Whether cluster `id` was in view from near (always, without the approach rule).
    pub fn approached(&self, id: i32) -> bool {
        self.approach.is_infinite()
            || self.ids[..self.len]
                .iter()
                .position(|i| *i == id)
                .is_some_and(|k| self.near[k])
    }

    /// Number of sectors.
    pub fn sectors(&self) -> usize {
        self.sectors
    }

    /// Sector of a bearing `from − center` (xy).
    pub fn sector_of(&self, center: Vec3, from: Vec3) -> usize {
        let d = from - center;
        let a = d.y.atan2(d.x).rem_euclid(std::f32::consts::TAU);
        ((a / std::f32::consts::TAU * self.sectors as f32) as usize) % self.sectors
    }

    /// Record the view: every background object the view sees gets the sector of the camera's
    /// bearing from its centre marked. "Sees" = the centre of its top face is in the frustum and
    /// range (a pitched-down camera near a low object may not see the object's centre).
    pub fn observe(&mut self, map: &ObjectMap, camera: &Camera, view: &View) {
        for o in map.objects().iter().filter(|o| o.is_background()) {
            let c = Vec3::from(o.center);
            let top = c + Vec3::Z * (0.5 * o.size[2]);
            if !view.sees(camera, top) {
                continue;
            }
            let s = self.sector_of(c, view.position);
            self.mark(o.id as i32, s);
            let reach = 0.5 * Vec2::new(o.size[0], o.size[1]).length() + self.approach;
            if c.truncate().distance(view.position.truncate()) <= reach
                && let Some(k) = self.ids[..self.len].iter().position(|i| *i == o.id as i32)
            {
                self.near[k] = true;
            }
        }
    }

    /// Mark sector `s` of cluster `id` as seen.
    pub fn mark(&mut self, id: i32, s: usize) {
        let bit = 1u64 << (s % self.sectors);
        if let Some(k) = self.ids[..self.len].iter().position(|i| *i == id) {
            self.masks[k] |= bit;
        } else if self.len < MAX_OBJECTS {
            self.ids[self.len] = id;
            self.masks[self.len] = bit;
            self.near[self.len] = false;
            self.len += 1;
        }
    }

    /// Bit mask of the sectors cluster `id` was seen from.
    pub fn mask(&self, id: i32) -> u64 {
        self.ids[..self.len]
            .iter()
            .position(|i| *i == id)
            .map_or(0, |k| self.masks[k])
    }

    /// Number of distinct sectors cluster `id` was seen from.
    pub fn sides(&self, id: i32) -> usize {
        self.ids[..self.len]
            .iter()
            .position(|i| *i == id)
            .map_or(0, |k| self.masks[k].count_ones() as usize)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use geom::CameraMount;
    use shm_types::boxed_zeroed;

    fn put(map: &mut ObjectMap, id: u32, bg: bool, cluster: i32, c: [f32; 3], s: [f32; 3]) {
        let k = map.count as usize;
        let o = &mut map.objects[k];
        o.id = id;
        o.background = bg as u8;
        o.cluster_id = cluster;
        o.center = c;
        o.size = s;
        o.h_sopm = 1.0;
        o.first_seen_ns = 100 * id as u64;
        map.count += 1;
    }

    #[test]
    fn clusters_sorted_by_first_sighting_with_footprint() {
        let mut m = boxed_zeroed::<ObjectMap>();
        put(&mut m, 5, true, 5, [2.0, 0.0, 0.4], [1.0, 2.0, 0.8]);
        put(&mut m, 1, false, 5, [2.0, 0.5, 0.85], [0.1, 0.1, 0.1]);
        put(&mut m, 3, true, 3, [-2.0, 0.0, 0.4], [1.0, 1.0, 0.8]);
        let sides = SideTracker::new(8);
        let cs = clusters(&m, 0.42, &sides, 4);
        // Cluster 5 has a member first seen at 100 ns, cluster 3 at 300 ns.
        assert_eq!(cs.iter().map(|c| c.id).collect::<Vec<_>>(), vec![5, 3]);
        assert!((cs[0].center - Vec3::new(2.0, 0.0, 0.625)).length() < 1e-5);
        assert!((cs[0].radius - (0.25f32 + 1.0).sqrt()).abs() < 1e-5);
        assert!(!cs[0].done && cs[0].foreground == 1);
        assert!(
            !cs[1].done,
            "empty cluster is unfinished until seen from enough sides"
        );
        m.objects[1].h_sopm = 0.3;
        let first = first_unfinished(&m, 0.42, &sides, 4, &[]).unwrap();
        assert_eq!(first.id, 3, "cluster 5 is done now");
        let c0 = cluster_info(&m, 5, 0.42).unwrap();
        assert!(c0.done);
        assert_eq!(unfinished_centroid(&m, &c0, 0.42), c0.center);
    }

    #[test]
    fn empty_cluster_done_after_enough_sides() {
        let mut m = boxed_zeroed::<ObjectMap>();
        put(&mut m, 3, true, 3, [0.0, 0.0, 0.4], [1.0, 1.0, 0.8]);
        let cam = Camera::from_fov(640, 480, 60.0, 46.8, 0.5, 5.0);
        let mount = CameraMount::default();
        let mut t = SideTracker::new(8);
        for k in 0..4 {
            let a = k as f32 * std::f32::consts::FRAC_PI_2 + 0.1;
            let base = [2.0 * a.cos(), 2.0 * a.sin(), a + std::f32::consts::PI];
            t.observe(
                &m,
                &cam,
                &View::new(mount.camera_pose(base, 0.0, mount.pitch())),
            );
            assert_eq!(t.sides(3), k + 1);
        }
        assert!(first_unfinished(&m, 0.42, &t, 4, &[]).is_none());
        assert!(first_unfinished(&m, 0.42, &t, 5, &[]).is_some());
        assert!(first_unfinished(&m, 0.42, &t, 5, &[3]).is_none());
    }

    /// A desk whose one mapped object completed from across the room is not done until a view
    /// from near it: its small objects are not mapped from there.
    #[test]
    fn a_cluster_seen_only_from_afar_is_not_done() {
        let mut m = boxed_zeroed::<ObjectMap>();
        put(&mut m, 3, true, 3, [0.0, 0.0, 0.4], [1.0, 1.0, 0.8]);
        put(&mut m, 4, false, 3, [0.2, 0.0, 0.85], [0.1, 0.1, 0.1]);
        m.objects[1].complete = 1;
        let cam = Camera::from_fov(640, 480, 60.0, 46.8, 0.5, 8.0);
        let mount = CameraMount::default();
        let mut t = SideTracker::new(8).with_approach(1.0);
        let look_from = |t: &mut SideTracker, d: f32| {
            let base = [d, 0.0, std::f32::consts::PI];
            t.observe(
                &m,
                &cam,
                &View::new(mount.camera_pose(base, 0.0, mount.pitch())),
            );
        };
        // 4 m from the centre: 3.3 m from the footprint circle (radius 0.71 m).
        look_from(&mut t, 4.0);
        assert_eq!(t.sides(3), 1);
        assert!(!t.approached(3));
        let c = &clusters(&m, 0.42, &t, 4)[0];
        assert!(!c.done && !c.approached && c.foreground_done == 1);
        assert_eq!(first_unfinished(&m, 0.42, &t, 4, &[]).unwrap().id, 3);
        // 1.6 m from the centre: 0.9 m from the circle.
        look_from(&mut t, 1.6);
        assert!(t.approached(3));
        assert!(clusters(&m, 0.42, &t, 4)[0].done);
        assert!(first_unfinished(&m, 0.42, &t, 4, &[]).is_none());
        // Without the rule, the far view was enough.
        let mut off = SideTracker::new(8);
        look_from(&mut off, 4.0);
        assert!(clusters(&m, 0.42, &off, 4)[0].done);
    }
}
