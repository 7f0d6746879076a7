//! Association of a new observation with the map's objects (paper §4.3).
//!
//! A detection's cleaned points `P` may join object `O` when
//! 1. the classes are compatible: equal, or both in one look-alike group of
//!    `[mapper.association] lookalike` (the mapper's own setting; `[]` = the label must match, as
//!    in the paper); a look-alike match adds a class vote and the object's class is the majority
//!    by summed score; background never matches foreground;
//! 2. they overlap in 3D: the centroid of `P` lies in `O`'s cuboid grown by `gate_margin`, or
//!    `O`'s centre lies in `P`'s bounding box grown by `gate_margin`;
//! 3. the multivariate Wilcoxon rank-sum test ([`super::wilcoxon`]) does not reject "same
//!    distribution": `p > α`.
//!
//! **Reference sample.** The test compares `P` (voxel centroids, same voxel size as the object's
//! cloud so densities match) with the part `Q'` of the object's merged cloud that the current view
//! can see: centroids that project into the detection's box and lie at the observed depth (not
//! hidden behind it by more than `visibility_tolerance`, nor in front of it by more than
//! `front_tolerance`: a reference point well in front of the observed surface is one this view
//! does not see either, e.g. a side at a grazing angle that returns no depth). Comparing a one-sided view with the whole object would reject every partial view of a
//! correct match (its centroid is shifted towards the camera). If `|Q'|` is below
//! `min_reference` (the view shows a side never seen before), the test has no comparable reference:
//! the observation is then accepted on the overlap gate alone when the centroid of `P` lies in the
//! grown cuboid, and `p` is taken from the test against the whole cloud, so `C_asso = 1 − p` stays
//! high and flags the object for another look.
//!
//! Each detection joins at most one object and each object takes at most one detection per
//! frame (greedy by descending `p`). An unmatched detection whose centroid lies inside an existing
//! compatible object's cuboid is treated as a rejected association of that object (its `C_asso`
//! is updated, no duplicate object is created); otherwise it founds a new object.

use glam::Vec3;
use shm_types::{ClassId, class_id};
use std::collections::HashMap;

/// Class compatibility table.
#[derive(Debug, Clone)]
pub struct ClassGroups {
    group_of: Vec<u16>,
}

impl ClassGroups {
    /// The table of look-alike groups (class names; unknown names are ignored — the config
    /// validation refuses them).
    pub fn new(groups: &[Vec<String>]) -> Self {
        let mut group_of = vec![0u16; shm_types::COCO_CLASSES.len()];
        for (g, names) in groups.iter().enumerate() {
            for name in names {
                if let Some(id) = class_id(name) {
                    group_of[id as usize] = g as u16 + 1;
                }
            }
        }
        Self { group_of }
    }

    /// Whether an observation of class `a` may join an object of class `b`.
    pub fn compatible(&self, a: ClassId, b: ClassId) -> bool {
        if a == b {
            return true;
        }
        let ga = self.group_of.get(a as usize).copied().unwrap_or(0);
        let gb = self.group_of.get(b as usize).copied().unwrap_or(0);
        ga != 0 && ga == gb
    }
}

/// One candidate pairing of a detection with an object.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Candidate {
    /// Index of the detection (in the frame's processing order).
    pub detection: usize,
    /// Index of the object.
    pub object: usize,
    /// p-value of the test.
    pub p: f64,
    /// Whether the association is accepted.
    pub accepted: bool,
    /// Centroid of the observation inside the object's cuboid (no margin).
    pub inside: bool,
}

/// Greedy one-to-one assignment of accepted candidates by descending p. Returns, per detection,
/// the chosen candidate (index into `cands`).
pub fn assign(cands: &mut [Candidate], detections: usize, out: &mut Vec<Option<usize>>) {
    out.clear();
    out.resize(detections, None);
    let mut order: Vec<usize> = (0..cands.len()).filter(|i| cands[*i].accepted).collect();
    order.sort_by(|a, b| cands[*b].p.total_cmp(&cands[*a].p).then(a.cmp(b)));
    let mut taken: Vec<usize> = Vec::new();
    for i in order {
        let c = cands[i];
        if out[c.detection].is_none() && !taken.contains(&c.object) {
            out[c.detection] = Some(i);
            taken.push(c.object);
        }
    }
}

/// Centroids of the occupied voxels of `pts` (edge `voxel`), in first-seen order.
pub fn voxel_centroids(
    pts: &[Vec3],
    voxel: f32,
    map: &mut HashMap<[i32; 3], (Vec3, u32)>,
    out: &mut Vec<[f32; 3]>,
) {
    map.clear();
    out.clear();
    let inv = 1.0 / voxel;
    let mut order: Vec<[i32; 3]> = Vec::new();
    for p in pts {
        let k = [
            (p.x * inv).floor() as i32,
            (p.y * inv).floor() as i32,
            (p.z * inv).floor() as i32,
        ];
        let e = map.entry(k).or_insert_with(|| {
            order.push(k);
            (Vec3::ZERO, 0)
        });
        e.0 += *p;
        e.1 += 1;
    }
    for k in order {
        let (s, n) = map[&k];
        out.push((s / n as f32).to_array());
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lookalike_groups() {
        let g = ClassGroups::new(&crate::mapper::AssociationConfig::default().lookalike);
        let id = |n| class_id(n).unwrap();
        assert!(g.compatible(id("cup"), id("vase")));
        assert!(g.compatible(id("book"), id("keyboard")));
        assert!(!g.compatible(id("cup"), id("book")));
        assert!(!g.compatible(id("chair"), id("dining table")));
        assert!(g.compatible(id("chair"), id("chair")));
        let strict = ClassGroups::new(&[]);
        assert!(!strict.compatible(id("cup"), id("vase")));
        assert!(strict.compatible(id("cup"), id("cup")));
    }

    #[test]
    fn assignment_is_one_to_one_by_p() {
        let c = |detection, object, p| Candidate {
            detection,
            object,
            p,
            accepted: true,
            inside: true,
        };
        let mut cands = vec![c(0, 0, 0.3), c(1, 0, 0.9), c(0, 1, 0.2), c(1, 1, 0.5)];
        let mut out = Vec::new();
        assign(&mut cands, 2, &mut out);
        assert_eq!(out, vec![Some(2), Some(1)]);
    }
}
