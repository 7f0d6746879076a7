//! Resuming from a published map ([`Mapper::resume_from`]): a restarted mapper process
//! continues from the last [`ObjectMap`] its predecessor published instead of from an empty
//! map. The published map is the checkpoint (nothing else is saved), so what it does not carry
//! is rebuilt from new frames:
//! - each object's merged cloud is reduced to its published sample points (at most
//!   [`MAX_OBJECT_POINTS`](shm_types::MAX_OBJECT_POINTS) voxels, each one point with its line
//!   of sight), so the next refit uses those plus the new points. The published cuboid is
//!   kept as the smallest the refits may give (`MappedObject::restored`; a background
//!   object's footprint only): fitted from 64 points plus one frame's partial view, a table's
//!   footprint shrank, objects near its edge left its cluster and were no longer published,
//!   and objects' bottoms rose off their table;
//! - the SOPM keeps each cell's probability side (occupied / free / unknown) and observation
//!   count ([`Sopm::restore`]);
//! - class votes restart from the published class; existence from the `max_log_odds` cap
//!   (only objects seen often enough are published); a background object's supporting plane
//!   is its published `support_height`;
//! - co-detection counts are not published, but every two restored objects were two objects
//!   to the predecessor. Two foreground objects whose bounding circles (grown by
//!   `merge_margin`) overlap are marked as detected together `distinct_after` times, so that
//!   the refits of the next frames do not merge them. (A predecessor could still have merged
//!   such a pair later if it had not been detected together yet; a restart keeps its
//!   judgement instead.)
//! - objects seen fewer than `min_observations` times were not published and are lost, as is
//!   the exploration grid (rebuilt from depth).

use super::Mapper;
use super::cuboid::Box3;
use super::object::MappedObject;
use super::sopm::Sopm;
use glam::Vec3;
use shm_types::ObjectMap;

impl Mapper {
    /// Replace the map with the objects of `map` (a map this mapper's configuration
    /// published; validated by the caller). Returns the number of objects restored. Ids are
    /// kept, and new objects get ids above them.
    pub fn resume_from(&mut self, map: &ObjectMap) -> usize {
        let sopm_params = self.cfg.sopm.params();
        self.objects.clear();
        for m in map.objects() {
            let fg = !m.is_background();
            let voxel = if fg {
                self.cfg.object_voxel
            } else {
                self.cfg.background_voxel
            };
            let mut o = MappedObject::new(
                m.id,
                m.class_id,
                1.0,
                !fg,
                voxel,
                self.cfg.max_object_voxels as usize,
                fg.then_some(sopm_params),
                m.first_seen_ns,
            );
            for (p, los) in m.samples() {
                let p = Vec3::from_array(*p);
                o.merge(&[p], p - Vec3::from_array(*los));
            }
            let mut cuboid = Box3 {
                center: Vec3::from_array(m.center),
                size: Vec3::from_array(m.size),
                yaw: m.yaw,
            };
            // A fused height ([`super::extent`]) is published with the bottom kept; the
            // cuboid the mapper works with spans its merged cloud, whose top the samples show.
            let top = m
                .samples()
                .map(|(p, _)| p[2])
                .fold(f32::NEG_INFINITY, f32::max);
            let bottom = cuboid.center.z - 0.5 * cuboid.size.z;
            if fg && top > bottom + cuboid.size.z {
                o.restored_height = Some(cuboid.size.z);
                cuboid.size.z = top - bottom;
                cuboid.center.z = bottom + 0.5 * cuboid.size.z;
            }
            o.cuboid = cuboid;
            o.restored = Some(o.cuboid);
            o.observations = m.observations;
            o.point_count = m.point_count;
            o.c_asso = m.c_asso;
            o.asso.c_asso = m.c_asso;
            o.existence = self.cfg.existence.max_log_odds;
            if !fg && m.support_height != 0.0 {
                o.support_height = Some(m.support_height);
            }
            if let Some(s) = o.sopm.as_mut()
                && usize::from(m.sopm_rows) * usize::from(m.sopm_cols) == s.len()
            {
                let n = s.len();
                s.restore(&m.sopm_prob[..n], &m.sopm_obs[..n]);
            }
            self.objects.push(o);
        }
        self.keep_restored_apart();
        self.next_id = self.objects.iter().map(|o| o.id + 1).max().unwrap_or(1);
        self.last_frame_seq = map.last_frame_seq;
        self.last_frame_stamp_ns = map.last_frame_stamp_ns;
        self.last_sim_time_ns = map.header.sim_time_ns;
        self.objects.len()
    }

    /// Mark every two restored foreground objects near each other as detected together
    /// `distinct_after` times (see the module documentation).
    fn keep_restored_apart(&mut self) {
        let (k, margin) = (self.cfg.distinct_after, self.cfg.merge_margin);
        let radius = |b: &Box3| 0.5 * b.size.truncate().length() + margin;
        for i in 0..self.objects.len() {
            for j in i + 1..self.objects.len() {
                let (a, b) = (&self.objects[i], &self.objects[j]);
                let gap = a
                    .cuboid
                    .center
                    .truncate()
                    .distance(b.cuboid.center.truncate());
                if !a.background && !b.background && gap <= radius(&a.cuboid) + radius(&b.cuboid) {
                    let (a, b) = (self.objects[i].id, self.objects[j].id);
                    self.objects[i].add_co_seen(b, k);
                    self.objects[j].add_co_seen(a, k);
                }
            }
        }
    }
}

impl Sopm {
    /// Set every cell from a published probability and observation count: a cell observed
    /// `n` times is occupied `n` times if its probability is above the prior, else free `n`
    /// times (the published map keeps no more than that).
    pub(super) fn restore(&mut self, prob: &[f32], obs: &[u16]) {
        let prior = self.params().p_prior;
        for g in 0..self.len().min(prob.len()).min(obs.len()) {
            let n = u32::from(obs[g]);
            let occupied = prob[g] > prior;
            self.set_cell(
                g,
                n > 0,
                if occupied { n } else { 0 },
                if occupied { 0 } else { n },
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use shm_types::{MAX_OBJECT_POINTS, boxed_zeroed};

    /// A map of a table (id 4) with a cup (id 9) on it, as a mapper publishes it.
    fn published() -> Box<ObjectMap> {
        let mut map = boxed_zeroed::<ObjectMap>();
        map.count = 2;
        map.last_frame_seq = 77;
        map.header.sim_time_ns = 5_000_000_000;
        let table = &mut map.objects[0];
        (table.id, table.class_id, table.background) =
            (4, shm_types::class_id("dining table").unwrap(), 1);
        (table.center, table.size, table.yaw) = ([1.0, 0.0, 0.375], [1.2, 0.8, 0.75], 0.1);
        (table.observations, table.point_count, table.c_asso) = (30, 4000, 0.9);
        (table.cluster_id, table.sample_count) = (4, MAX_OBJECT_POINTS as u16);
        table.support_height = 0.75;
        for k in 0..MAX_OBJECT_POINTS {
            let a = k as f32 / MAX_OBJECT_POINTS as f32 * std::f32::consts::TAU;
            table.points[k] = [1.0 + 0.6 * a.cos(), 0.4 * a.sin(), 0.75];
            table.point_los[k] = [0.0, 0.0, -1.0];
        }
        let cup = &mut map.objects[1];
        (cup.id, cup.class_id, cup.background) = (9, shm_types::class_id("cup").unwrap(), 0);
        (cup.center, cup.size) = ([1.1, 0.1, 0.8], [0.08, 0.08, 0.1]);
        (
            cup.observations,
            cup.point_count,
            cup.c_asso,
            cup.cluster_id,
        ) = (12, 300, 0.95, 4);
        cup.sample_count = 8;
        for k in 0..8 {
            let a = k as f32 / 8.0 * std::f32::consts::TAU;
            cup.points[k] = [1.1 + 0.04 * a.cos(), 0.1 + 0.04 * a.sin(), 0.8];
            cup.point_los[k] = [-1.0, 0.0, 0.0];
        }
        map
    }

    #[test]
    fn a_resumed_mapper_republishes_the_objects_it_was_given() {
        let cfg = crate::MapperConfig::default();
        let mut m = Mapper::new(&cfg, &geom::CameraConfig::default().camera()).unwrap();
        let mut map = published();
        // The cup's SOPM: one occupied and one free cell observed 3 times each.
        let cells = (cfg.sopm.rows * cfg.sopm.cols) as usize;
        let cup = &mut map.objects[1];
        (cup.sopm_rows, cup.sopm_cols) = (cfg.sopm.rows as u16, cfg.sopm.cols as u16);
        cup.sopm_prob[..cells].fill(cfg.sopm.p_prior);
        (cup.sopm_prob[0], cup.sopm_obs[0]) = (0.99, 3);
        (cup.sopm_prob[1], cup.sopm_obs[1]) = (0.01, 3);
        assert_eq!(m.resume_from(&map), 2);
        let mut out = boxed_zeroed::<ObjectMap>();
        m.write_map(&mut out, 6_000_000_000);
        let got: Vec<(u32, u16, i32)> = out
            .objects()
            .iter()
            .map(|o| (o.id, o.class_id, o.cluster_id))
            .collect();
        // Same ids and classes; the cup is still in the table's cluster.
        assert_eq!(
            got,
            vec![
                (4, map.objects[0].class_id, 4),
                (9, map.objects[1].class_id, 4)
            ]
        );
        let cup = &out.objects[1];
        assert_eq!(
            (cup.center, cup.size, cup.observations),
            ([1.1, 0.1, 0.8], [0.08, 0.08, 0.1], 12)
        );
        assert_eq!(cup.sample_count, 8);
        assert_eq!(
            (cup.sopm_obs[0], cup.sopm_obs[1], cup.sopm_obs[2]),
            (3, 3, 0)
        );
        // Each cell keeps its side of the prior; the probability follows from the 3 observations.
        let prior = cfg.sopm.p_prior;
        assert!(
            cup.sopm_prob[0] > prior && cup.sopm_prob[1] < prior && cup.sopm_prob[2] == prior,
            "{:?}",
            &cup.sopm_prob[..3]
        );
        assert_eq!(out.last_frame_seq, 77);
        // A new object gets an id above every restored one.
        assert_eq!(m.next_id, 10);
    }
}
