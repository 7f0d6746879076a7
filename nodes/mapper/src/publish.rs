//! Publishing: the object map (objects seen often enough, with their SOPM, cluster and
//! sample points) and the exploration grid, written in place into shared-memory samples.

use super::Mapper;
use super::object::MappedObject;
use glam::Vec3;
use shm_types::{MAX_OBJECT_POINTS, MAX_OBJECTS, ObjectMap, OccupancyGrid};

impl Mapper {
    /// Observations needed before an object is published (1 without the extension).
    fn min_observations(&self) -> u32 {
        if self.cfg.extensions.min_observations {
            self.cfg.min_observations
        } else {
            1
        }
    }

    /// Write the whole map in place into `out` (e.g. a loaned shared-memory sample). Sets
    /// `header.sim_time_ns = now_ns`, `last_frame_seq`, `last_frame_stamp_ns`, `count`,
    /// `eps_sopm`, the objects (ordered by id; at most [`MAX_OBJECTS`]) and the receipts of the
    /// frames consumed since the last call (then cleared); the host sets `header.seq` and
    /// `header.stamp_ns`. Objects seen fewer than `min_observations` times are
    /// left out. Unused object slots are not touched.
    pub fn write_map(&mut self, out: &mut ObjectMap, now_ns: u64) {
        out.header.sim_time_ns = now_ns;
        out.last_frame_seq = self.last_frame_seq;
        out.last_frame_stamp_ns = self.last_frame_stamp_ns;
        out.eps_sopm = self.cfg.sopm.eps_sopm;
        out.receipt_count = std::mem::take(&mut self.receipt_count);
        out.receipts = Default::default();
        out.receipts[..self.receipts.len()].copy_from_slice(&self.receipts);
        self.receipts.clear();
        let mut count = 0usize;
        let mut samples = std::mem::take(&mut self.samples);
        for o in &self.objects {
            if count == MAX_OBJECTS {
                break;
            }
            if o.observations < self.min_observations() || o.point_count == 0 {
                continue;
            }
            let cluster_id = if o.background {
                o.id as i32
            } else {
                self.cluster_of(o)
            };
            if cluster_id < 0 && self.cfg.extensions.require_support {
                continue;
            }
            let m = &mut out.objects[count];
            m.first_seen_ns = o.first_seen_ns;
            m.id = o.id;
            m.class_id = o.class_id;
            m.background = o.background as u8;
            // Clamped: a flat cuboid's extent can round to -1e-6 (more far from the origin),
            // and a negative size fails `ObjectMap` validation, which drops the whole map.
            let size = self.published_size(o).max(Vec3::ZERO);
            // A fused height keeps the bottom (on the supporting plane) and lowers the top.
            let mut center = self.published_centre(o);
            center.z -= 0.5 * (o.cuboid.size.z - size.z).max(0.0);
            m.center = center.to_array();
            m.size = size.to_array();
            m.yaw = o.cuboid.yaw;
            m.point_count = o.point_count;
            m.cluster_id = cluster_id;
            m.observations = o.observations;
            m.c_asso = o.c_asso.clamp(0.0, 1.0);
            m.reserved = 0;
            m.support_height = o.support_height.filter(|_| o.background).unwrap_or(0.0);
            match &o.sopm {
                Some(s) => {
                    let h = s.h_sopm();
                    m.h_sopm = h;
                    m.complete = (h < self.cfg.sopm.eps_sopm) as u8;
                    m.l_best = s.l_best(&o.sopm_frame()).to_array();
                    m.sopm_shape = s.params().shape.code();
                    m.sopm_rows = s.params().rows as u16;
                    m.sopm_cols = s.params().cols as u16;
                    for g in 0..s.len() {
                        m.sopm_prob[g] = s.prob(g).clamp(0.0, 1.0);
                        m.sopm_obs[g] = s.obs(g).min(u16::MAX as u32) as u16;
                    }
                }
                None => {
                    m.h_sopm = 0.0;
                    m.complete = 0;
                    m.l_best = [0.0; 3];
                    m.sopm_shape = self.cfg.sopm.shape.code();
                    m.sopm_rows = 0;
                    m.sopm_cols = 0;
                }
            }
            o.samples(MAX_OBJECT_POINTS, &mut samples);
            m.sample_count = samples.len() as u16;
            for (k, (p, l)) in samples.iter().enumerate() {
                m.points[k] = p.to_array();
                m.point_los[k] = l.to_array();
            }
            count += 1;
        }
        self.samples = samples;
        out.count = count as u32;
    }

    /// The size an object is published with: with `[mapper.extensions] view_extents` a
    /// foreground object's footprint (and, with `[mapper.view_extents] height`, its height)
    /// comes from its per-view extents ([`super::extent`]).
    pub fn published_size(&self, o: &MappedObject) -> Vec3 {
        if o.background || !self.cfg.extensions.view_extents {
            return o.cuboid.size;
        }
        let ve = &self.cfg.view_extents;
        let mut size = o
            .views
            .size(o.cuboid.size, o.cuboid.yaw, self.cfg.support_margin, ve);
        // A restored object publishes its predecessor's fused height until its views fuse one.
        if let Some(h) = o.restored_height
            && ve.height
            && o.views.fused_height(ve).is_none()
        {
            size.z = size.z.min(h);
        }
        size
    }

    /// The centre an object is published with: with `[mapper.view_extents] centre` a foreground
    /// object's horizontal centre comes from its per-view midpoints ([`super::extent`]).
    pub fn published_centre(&self, o: &MappedObject) -> Vec3 {
        let ve = &self.cfg.view_extents;
        if o.background || !self.cfg.extensions.view_extents || !ve.centre {
            return o.cuboid.center;
        }
        o.views.centre(o.cuboid.center, o.cuboid.yaw, ve)
    }

    /// Background object supporting a foreground object: its footprint (grown by 5 cm) holds the
    /// object's centre and its plane is within 10 cm of the object's bottom; the closest plane
    /// wins. -1 if none.
    pub(super) fn cluster_of(&self, o: &MappedObject) -> i32 {
        let bottom = o.cuboid.center.z - o.cuboid.size.z * 0.5;
        let mut best: Option<(f32, u32)> = None;
        for b in self
            .objects
            .iter()
            .filter(|b| b.background && b.observations >= self.min_observations())
        {
            let Some(h) = b.support_height else { continue };
            let probe = Vec3::new(o.cuboid.center.x, o.cuboid.center.y, b.cuboid.center.z);
            let dz = (bottom - h).abs();
            if dz <= 0.10 && b.contains(probe, 0.05) && best.is_none_or(|(d, _)| dz < d) {
                best = Some((dz, b.id));
            }
        }
        best.map_or(-1, |(_, id)| id as i32)
    }

    /// Write the exploration grid in place; sets `header.sim_time_ns` to the newest frame's time
    /// (the host sets `seq` and `stamp_ns`).
    pub fn write_grid(&self, out: &mut OccupancyGrid) {
        out.header.sim_time_ns = self.last_sim_time_ns;
        self.grid.write(out);
    }
}
