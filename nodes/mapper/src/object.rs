//! One object of the map: its merged points (voxel centroids with lines of sight), class votes,
//! cuboid and SOPM.

use super::cuboid::{Box3, CuboidScratch};
use super::sopm::{Frame, Sopm, SopmParams};
use geom::Camera;
use glam::{Affine3A, Vec3};
use shm_types::{ClassId, DepthFrame};
use std::collections::HashMap;

/// A voxel of an object's merged cloud.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Voxel {
    /// Sum of the points that fell in it.
    pub sum: Vec3,
    /// Number of points.
    pub n: u32,
    /// Sum of the unit lines of sight (camera → point) of those points.
    pub los: Vec3,
}

impl Voxel {
    /// Centroid.
    pub fn centroid(&self) -> Vec3 {
        self.sum / self.n.max(1) as f32
    }
}

/// Parameters the object needs to refit itself.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FitParams {
    /// Extent quantile (robust min/max).
    pub extent_quantile: f32,
    /// Extent quantile of background footprints.
    pub background_extent_quantile: f32,
    /// Relative rectangle-area tolerance under which the previous yaw is kept.
    pub yaw_keep_tolerance: f32,
    /// Half-thickness of a supporting plane (background footprint), metres.
    pub plane_tolerance: f32,
    /// Lowest supporting-plane height considered, metres.
    pub min_support_height: f32,
}

/// An object of the sparse map.
#[derive(Debug, Clone)]
pub struct MappedObject {
    /// Stable id (1-based).
    pub id: u32,
    /// Majority class.
    pub class_id: ClassId,
    /// Background (cluster-anchoring) object.
    pub background: bool,
    /// Class votes (class, summed detector score).
    votes: Vec<(ClassId, f32)>,
    voxel_size: f32,
    max_voxels: usize,
    index: HashMap<[i32; 3], u32>,
    voxels: Vec<Voxel>,
    /// Current cuboid.
    pub cuboid: Box3,
    /// Supporting plane height (background objects).
    pub support_height: Option<f32>,
    /// The cuboid a resumed object was published with ([`super::Mapper::resume_from`]): a
    /// refit never makes the cuboid smaller than it. A voxel cloud only grows, so the
    /// predecessor's would have held it; the resumed one holds only its 64 sample points.
    pub restored: Option<Box3>,
    /// Restored from a map whose height was fused from views ([`super::extent`]): that height,
    /// published until this mapper's own views fuse one.
    pub restored_height: Option<f32>,
    /// SOPM (foreground objects).
    pub sopm: Option<Sopm>,
    /// Associated detections.
    pub observations: u32,
    /// Time of the first observation, ns.
    pub first_seen_ns: u64,
    /// C_asso (eq. 20, see [`super::association`]): by default a confidence from the running rate
    /// of refused association tests. An object never tested yet has no evidence against its
    /// association, so it starts at 1 (f_a multiplies by C_asso, and 0 would make a new object
    /// invisible to the GBV).
    pub c_asso: f32,
    /// The running association record behind `c_asso`.
    pub asso: super::association::AssoRecord,
    /// Points merged.
    pub point_count: u32,
    /// Existence log-odds ([`super::existence`]).
    pub existence: f32,
    /// Associated with a detection in the current frame.
    pub hit: bool,
    /// Bounds (min, max) of the points that detection gave, while `hit`.
    pub hit_bounds: Option<(Vec3, Vec3)>,
    /// Camera position of the newest existence update.
    pub last_view: Option<Vec3>,
    /// Viewpoints whose existence update was a hit ([`super::existence`]).
    pub hit_views: u32,
    /// Per-view footprint extents ([`super::extent`]).
    pub views: super::extent::ViewExtents,
    /// Objects this one was detected together with (both hit by different detections of one
    /// frame), with the number of such frames: two objects co-detected often are two objects,
    /// never duplicates (`[mapper.extensions] co_detection`).
    pub co_seen: Vec<(u32, u32)>,
    /// Objects whose cuboid overlaps this one's as a duplicate's would, with the number of
    /// frames in which only one of the two was detected (`[mapper] co_detection_min_share`).
    pub co_apart: Vec<(u32, u32)>,
}

impl MappedObject {
    /// A new object from its first observation (the cuboid is fitted by [`Self::refit`]).
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        id: u32,
        class_id: ClassId,
        score: f32,
        background: bool,
        voxel_size: f32,
        max_voxels: usize,
        sopm: Option<SopmParams>,
        now_ns: u64,
    ) -> Self {
        Self {
            id,
            class_id,
            background,
            votes: vec![(class_id, score.max(1e-3))],
            voxel_size,
            max_voxels,
            index: HashMap::new(),
            voxels: Vec::new(),
            cuboid: Box3 {
                center: Vec3::ZERO,
                size: Vec3::ZERO,
                yaw: 0.0,
            },
            support_height: None,
            restored: None,
            restored_height: None,
            sopm: sopm.map(Sopm::new),
            observations: 0,
            first_seen_ns: now_ns,
            c_asso: 1.0,
            asso: Default::default(),
            point_count: 0,
            existence: 0.0,
            hit: false,
            hit_bounds: None,
            last_view: None,
            hit_views: 0,
            views: Default::default(),
            co_seen: Vec::new(),
            co_apart: Vec::new(),
        }
    }

    /// Count `n` more frames in which this object and object `id` were detected together
    /// (the larger count is kept when two records of `id` meet).
    pub fn add_co_seen(&mut self, id: u32, n: u32) {
        match self.co_seen.iter_mut().find(|c| c.0 == id) {
            Some(c) => c.1 = c.1.saturating_add(n),
            None => self.co_seen.push((id, n)),
        }
    }

    /// Frames in which this object and object `id` were detected together.
    pub fn co_seen_with(&self, id: u32) -> u32 {
        self.co_seen.iter().find(|c| c.0 == id).map_or(0, |c| c.1)
    }

    /// Count one more frame in which only one of this object and object `id` (overlapping
    /// it) was detected.
    pub fn add_co_apart(&mut self, id: u32, n: u32) {
        match self.co_apart.iter_mut().find(|c| c.0 == id) {
            Some(c) => c.1 = c.1.saturating_add(n),
            None => self.co_apart.push((id, n)),
        }
    }

    /// Frames in which only one of this object and object `id` was detected while their
    /// cuboids overlapped.
    pub fn co_apart_with(&self, id: u32) -> u32 {
        self.co_apart.iter().find(|c| c.0 == id).map_or(0, |c| c.1)
    }

    /// Add a class vote; the class becomes the majority (by summed score).
    pub fn vote(&mut self, class_id: ClassId, score: f32) {
        match self.votes.iter_mut().find(|v| v.0 == class_id) {
            Some(v) => v.1 += score.max(1e-3),
            None => self.votes.push((class_id, score.max(1e-3))),
        }
        if let Some(best) = self.votes.iter().max_by(|a, b| a.1.total_cmp(&b.1)) {
            self.class_id = best.0;
        }
    }

    /// The voxels of the merged cloud.
    pub fn voxels(&self) -> &[Voxel] {
        &self.voxels
    }

    /// Merge one observation's points seen from `camera`.
    pub fn merge(&mut self, points: &[Vec3], camera: Vec3) {
        let inv = 1.0 / self.voxel_size;
        for &p in points {
            let k = [
                (p.x * inv).floor() as i32,
                (p.y * inv).floor() as i32,
                (p.z * inv).floor() as i32,
            ];
            let los = (p - camera).normalize_or_zero();
            match self.index.get(&k) {
                Some(&i) => {
                    let v = &mut self.voxels[i as usize];
                    v.sum += p;
                    v.n += 1;
                    v.los += los;
                }
                None if self.voxels.len() < self.max_voxels => {
                    self.index.insert(k, self.voxels.len() as u32);
                    self.voxels.push(Voxel { sum: p, n: 1, los });
                }
                None => continue,
            }
            self.point_count = self.point_count.saturating_add(1);
        }
    }

    /// Merge a duplicate of this object into it (the caller then refits the cuboid): voxels
    /// (re-binned on this object's grid by their centroids, with their point and LoS sums),
    /// class votes, observation and point counts, `first_seen = min`, `C_asso = max` (the more
    /// doubtful association wins), and the SOPM evidence aligned by the yaw difference
    /// ([`Sopm::absorb`]). The id stays this object's.
    pub fn absorb(&mut self, other: &MappedObject) {
        let inv = 1.0 / self.voxel_size;
        for v in &other.voxels {
            let c = v.centroid();
            let k = [
                (c.x * inv).floor() as i32,
                (c.y * inv).floor() as i32,
                (c.z * inv).floor() as i32,
            ];
            match self.index.get(&k) {
                Some(&i) => {
                    let s = &mut self.voxels[i as usize];
                    s.sum += v.sum;
                    s.n += v.n;
                    s.los += v.los;
                }
                None if self.voxels.len() < self.max_voxels => {
                    self.index.insert(k, self.voxels.len() as u32);
                    self.voxels.push(*v);
                }
                None => continue,
            }
        }
        self.point_count = self.point_count.saturating_add(other.point_count);
        for &(class, score) in &other.votes {
            match self.votes.iter_mut().find(|v| v.0 == class) {
                Some(v) => v.1 += score,
                None => self.votes.push((class, score)),
            }
        }
        if let Some(best) = self.votes.iter().max_by(|a, b| a.1.total_cmp(&b.1)) {
            self.class_id = best.0;
        }
        self.observations = self.observations.saturating_add(other.observations);
        self.first_seen_ns = self.first_seen_ns.min(other.first_seen_ns);
        if other.c_asso > self.c_asso {
            self.c_asso = other.c_asso;
            self.asso = other.asso;
        }
        self.existence = self.existence.max(other.existence);
        for &(id, n) in &other.co_seen {
            if id != self.id {
                self.add_co_seen(id, n);
            }
        }
        self.co_seen.retain(|c| c.0 != other.id);
        for &(id, n) in &other.co_apart {
            if id != self.id {
                self.add_co_apart(id, n);
            }
        }
        self.co_apart.retain(|c| c.0 != other.id);
        self.hit_views = self.hit_views.max(other.hit_views);
        self.hit |= other.hit;
        if self.support_height.is_none() {
            self.support_height = other.support_height;
        }
        if self.restored.is_none() {
            self.restored = other.restored;
        }
        if let (Some(s), Some(o)) = (self.sopm.as_mut(), other.sopm.as_ref()) {
            let step = std::f32::consts::TAU / s.params().cols as f32;
            let dyaw = geom::wrap_angle(self.cuboid.yaw - other.cuboid.yaw);
            s.absorb(o, (dyaw / step).round() as i32);
        }
    }

    /// Refit the cuboid from the voxel centroids. Returns the yaw change (radians).
    pub fn refit(
        &mut self,
        scratch: &mut CuboidScratch,
        centroids: &mut Vec<Vec3>,
        p: &FitParams,
    ) -> f32 {
        centroids.clear();
        centroids.extend(self.voxels.iter().map(Voxel::centroid));
        let prev =
            (self.observations > 0 || self.cuboid.size != Vec3::ZERO).then_some(self.cuboid.yaw);
        let fitted = if self.background {
            scratch
                .support_height(centroids, p.min_support_height)
                .and_then(|h| {
                    self.support_height = Some(h);
                    scratch.fit_background(
                        centroids,
                        h,
                        p.plane_tolerance,
                        prev,
                        p.background_extent_quantile,
                        p.yaw_keep_tolerance,
                    )
                })
        } else {
            scratch.fit_foreground(centroids, prev, p.extent_quantile, p.yaw_keep_tolerance)
        };
        match fitted {
            Some(b) => {
                let b = self
                    .restored
                    .map_or(b, |r| b.grown_to_hold(&r, self.background));
                let dyaw = prev.map_or(0.0, |y| b.yaw - y);
                self.cuboid = b;
                dyaw
            }
            None => 0.0,
        }
    }

    /// The SOPM's frame (the cuboid).
    pub fn sopm_frame(&self) -> Frame {
        Frame {
            center: self.cuboid.center,
            size: self.cuboid.size.max(Vec3::splat(0.01)),
            yaw: self.cuboid.yaw,
        }
    }

    /// Integrate one frame's points into the SOPM (after [`Self::refit`] returned `dyaw`).
    pub fn update_sopm(&mut self, points: &[Vec3], camera: Vec3, dyaw: f32) {
        self.follow_yaw(dyaw);
        let frame = self.sopm_frame();
        if let Some(s) = self.sopm.as_mut() {
            s.update(&frame, camera, points);
        }
    }

    /// Rotate the SOPM after the cuboid's yaw changed by `dyaw`, so its cells keep pointing at
    /// the same world directions.
    pub fn follow_yaw(&mut self, dyaw: f32) {
        if let Some(s) = self.sopm.as_mut() {
            let step = std::f32::consts::TAU / s.params().cols as f32;
            // A yaw increase moves every world direction to a lower local angle.
            s.shift_columns((dyaw / step).round() as i32);
        }
    }

    /// Whether a world point lies inside the cuboid grown by `margin`.
    pub fn contains(&self, p: Vec3, margin: f32) -> bool {
        let (s, c) = self.cuboid.yaw.sin_cos();
        let d = p - self.cuboid.center;
        let h = self.cuboid.size * 0.5 + Vec3::splat(margin);
        (c * d.x + s * d.y).abs() <= h.x && (-s * d.x + c * d.y).abs() <= h.y && d.z.abs() <= h.z
    }

    /// The part of the merged cloud the current view can see inside `bbox` (pixels, grown by
    /// `margin_px`): voxel centroids that project into it and are not hidden behind the
    /// observed depth by more than `tolerance` metres nor in front of it by more than `front`
    /// metres. Written to `out` as arrays.
    #[allow(clippy::too_many_arguments)]
    pub fn visible_reference(
        &self,
        frame: &DepthFrame,
        camera: &Camera,
        camera_from_world: &Affine3A,
        bbox: [u16; 4],
        margin_px: f32,
        tolerance: f32,
        front: f32,
        out: &mut Vec<[f32; 3]>,
    ) {
        out.clear();
        let (w, h) = (frame.width as usize, frame.height as usize);
        let depth = frame.pixels();
        let [x0, y0, x1, y1] = bbox.map(|v| v as f32);
        for v in &self.voxels {
            let c = v.centroid();
            let pc = camera_from_world.transform_point3(c);
            if pc.z < camera.k.min_range {
                continue;
            }
            let Some(px) = camera.project(pc) else {
                continue;
            };
            if px.x < x0 - margin_px
                || px.x >= x1 + margin_px
                || px.y < y0 - margin_px
                || px.y >= y1 + margin_px
            {
                continue;
            }
            let (u, vv) = (px.x.floor(), px.y.floor());
            if u < 0.0 || vv < 0.0 || u as usize >= w || vv as usize >= h {
                continue;
            }
            let d = depth[vv as usize * w + u as usize];
            if d == 0 {
                continue;
            }
            let dz = pc.z - d as f32 * 1e-3;
            if dz <= tolerance && dz >= -front {
                out.push(c.to_array());
            }
        }
    }

    /// All voxel centroids, as arrays.
    pub fn all_reference(&self, out: &mut Vec<[f32; 3]>) {
        out.clear();
        out.extend(self.voxels.iter().map(|v| v.centroid().to_array()));
    }

    /// Up to `max` sample voxels spread over the object: one (the most observed) per stratum of
    /// 16 azimuth sectors × 4 height bands around the cuboid, topped up by an even stride.
    /// Writes `(point, mean unit LoS)` pairs into `out`.
    pub fn samples(&self, max: usize, out: &mut Vec<(Vec3, Vec3)>) {
        out.clear();
        if self.voxels.is_empty() || max == 0 {
            return;
        }
        const SECTORS: usize = 16;
        const BANDS: usize = 4;
        let mut best = [None::<(u32, usize)>; SECTORS * BANDS];
        let b = &self.cuboid;
        for (i, v) in self.voxels.iter().enumerate() {
            let d = v.centroid() - b.center;
            let phi = d.y.atan2(d.x) - b.yaw;
            let sector = ((phi.rem_euclid(std::f32::consts::TAU) / std::f32::consts::TAU
                * SECTORS as f32) as usize)
                .min(SECTORS - 1);
            let band = (((d.z / b.size.z.max(1e-3)) + 0.5) * BANDS as f32).floor();
            let band = (band.max(0.0) as usize).min(BANDS - 1);
            let slot = &mut best[band * SECTORS + sector];
            if slot.is_none_or(|(n, _)| v.n > n) {
                *slot = Some((v.n, i));
            }
        }
        let mut chosen: Vec<usize> = best.iter().flatten().map(|(_, i)| *i).collect();
        chosen.truncate(max);
        if chosen.len() < max {
            let n = self.voxels.len();
            let take = n.min(max);
            for k in 0..take {
                let i = k * n / take;
                if chosen.len() < max && !chosen.contains(&i) {
                    chosen.push(i);
                }
            }
        }
        chosen.sort_unstable();
        for i in chosen {
            let v = &self.voxels[i];
            out.push((v.centroid(), v.los.normalize_or_zero()));
        }
    }
}
