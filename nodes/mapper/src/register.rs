//! Frame-to-map registration (`[mapper.registration]`): before a frame's detections are merged,
//! a small rigid correction of the frame's camera pose — a translation and a yaw about the camera —
//! is estimated that aligns the frame's associated object points with those objects' merged
//! clouds (voxel centroids), as object-SLAM back-ends refine the camera pose against their
//! landmarks. The robot's estimated pose drifts (SLAM residual, neck-encoder bias and noise,
//! pose/image stamp offset); without it each object's merged cloud is smeared across views.
//!
//! Trimmed point-to-point ICP: a few iterations, correspondences within `max_distance`, the
//! closest `trim` fraction kept, consensus over all associated objects of the frame. A detection
//! takes part only if at least `min_overlap` of its points have a correspondence (a view of an
//! unseen side must not pull the cloud inward), and the correction is accepted only with
//! `min_correspondences` in all and bounded by `max_translation` / `max_yaw_deg`. Background
//! objects (table tops) give the height only ([`Dof::Z`]); foreground objects give x, y, z and,
//! when their points spread wide enough to separate a yaw from a shift, the yaw ([`Dof::Full`]).
//!
//! The correction persists: the mapper keeps a filtered offset ([`Registration::offset`]) that
//! is applied to the next frame's pose before its points are extracted (the drift varies slowly).

use super::config::RegistrationConfig;
use super::object::MappedObject;
use glam::{Affine3A, Quat, Vec2, Vec3};
use std::collections::HashMap;

/// A rigid correction about a centre `c` (the camera position): `p ↦ Rz(yaw)(p − c) + c + t`.
/// Two corrections, the second about the first's corrected centre `c + t₁`, compose to
/// `(yaw₁ + yaw₂, t₁ + t₂)` about `c`.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Correction {
    /// Yaw, radians.
    pub yaw: f32,
    /// Translation, metres.
    pub t: Vec3,
}

impl Correction {
    /// Apply to a point, the correction being about `c`.
    pub fn apply(&self, p: Vec3, c: Vec3) -> Vec3 {
        let (s, co) = self.yaw.sin_cos();
        let d = p - c;
        Vec3::new(co * d.x - s * d.y, s * d.x + co * d.y, d.z) + c + self.t
    }

    /// The correction as a world-frame transform about `c` (to premultiply a camera pose).
    pub fn affine(&self, c: Vec3) -> Affine3A {
        Affine3A::from_translation(c + self.t)
            * Affine3A::from_quat(Quat::from_rotation_z(self.yaw))
            * Affine3A::from_translation(-c)
    }

    /// `self` then `o` (about the corrected centre).
    pub fn then(&self, o: &Correction) -> Correction {
        Correction {
            yaw: self.yaw + o.yaw,
            t: self.t + o.t,
        }
    }

    fn is_zero(&self) -> bool {
        self.yaw == 0.0 && self.t == Vec3::ZERO
    }
}

/// Degrees of freedom estimated.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Dof {
    /// Height only (supporting planes: table tops).
    Z,
    /// x, y, z and yaw (yaw only with enough spread).
    Full,
}

/// The registration state: the persistent offset and scratch.
#[derive(Debug, Clone, Default)]
pub struct Registration {
    /// The filtered correction applied to each new frame's pose before extraction.
    pub offset: Correction,
    /// This frame's correction so far (on top of `offset`).
    frame: Correction,
    /// Frames whose correction was accepted / estimated (diagnostics).
    pub accepted: u32,
    /// Coarse index of the reference clouds: (pair, cell) → reference points.
    cells: HashMap<(u32, [i32; 3]), Vec<Vec3>>,
    src: Vec<(u32, Vec3)>,
    corr: Vec<(Vec3, Vec3, f32, u32)>,
    per_pair: Vec<(u32, u32)>,
}

impl Registration {
    /// The camera pose of a new frame corrected by the persistent offset (about its own position).
    pub fn begin_frame(&mut self, pose: &Affine3A, cfg: &RegistrationConfig) -> Affine3A {
        self.frame = Correction::default();
        if !cfg.enabled || self.offset.is_zero() {
            return *pose;
        }
        self.offset.affine(pose.translation.into()) * *pose
    }

    /// Fold this frame's correction into the persistent offset.
    pub fn end_frame(&mut self, cfg: &RegistrationConfig) {
        if !cfg.enabled {
            return;
        }
        let g = cfg.persist_gain;
        let d = cfg.persist_decay;
        self.offset = Correction {
            yaw: d * (self.offset.yaw + g * self.frame.yaw),
            t: d * (self.offset.t + g * self.frame.t),
        };
    }

    /// Estimate a correction that aligns `points[i]` with `objects[j].voxels()` for the pairs
    /// `(i, j)`, about the camera position `c`. `None` if there is too little overlap. The
    /// accepted correction is added to this frame's correction.
    pub fn estimate(
        &mut self,
        objects: &[MappedObject],
        points: &[Vec<Vec3>],
        pairs: &[(usize, usize)],
        c: Vec3,
        dof: Dof,
        cfg: &RegistrationConfig,
    ) -> Option<Correction> {
        if !cfg.enabled || pairs.is_empty() {
            return None;
        }
        let cell = cfg.max_distance.max(1e-3);
        let inv = 1.0 / cell;
        let key = |p: Vec3| {
            [
                (p.x * inv).floor() as i32,
                (p.y * inv).floor() as i32,
                (p.z * inv).floor() as i32,
            ]
        };
        self.cells.values_mut().for_each(Vec::clear);
        self.src.clear();
        for (k, &(i, j)) in pairs.iter().enumerate() {
            let o = &objects[j];
            if o.observations < cfg.min_object_observations {
                continue;
            }
            for v in o.voxels() {
                let q = v.centroid();
                self.cells.entry((k as u32, key(q))).or_default().push(q);
            }
            let pts = &points[i];
            let step = pts
                .len()
                .div_ceil(cfg.max_points_per_detection.max(1) as usize);
            self.src
                .extend(pts.iter().step_by(step.max(1)).map(|p| (k as u32, *p)));
        }
        if self.src.len() < cfg.min_correspondences as usize {
            return None;
        }
        let max_d2 = cfg.max_distance * cfg.max_distance;
        let mut total = Correction::default();
        let mut ok = false;
        for _ in 0..cfg.iterations.max(1) {
            // Correspondences of the currently corrected points.
            self.corr.clear();
            self.per_pair.clear();
            self.per_pair.resize(pairs.len(), (0, 0));
            for &(k, p) in &self.src {
                let p = total.apply(p, c);
                let kk = key(p);
                let mut best = (max_d2, None);
                for dx in -1..=1 {
                    for dy in -1..=1 {
                        for dz in -1..=1 {
                            let Some(list) =
                                self.cells.get(&(k, [kk[0] + dx, kk[1] + dy, kk[2] + dz]))
                            else {
                                continue;
                            };
                            for q in list {
                                let d2 = p.distance_squared(*q);
                                if d2 < best.0 {
                                    best = (d2, Some(*q));
                                }
                            }
                        }
                    }
                }
                let e = &mut self.per_pair[k as usize];
                e.1 += 1;
                if let (d2, Some(q)) = best {
                    e.0 += 1;
                    self.corr.push((p, q, d2, k));
                }
            }
            // Drop detections that overlap their object too little.
            let per_pair = &self.per_pair;
            let overlaps = |k: u32| {
                per_pair[k as usize].0 as f32 >= cfg.min_overlap * per_pair[k as usize].1 as f32
            };
            self.corr.retain(|x| overlaps(x.3));
            let kept = &mut self.corr;
            if kept.len() < cfg.min_correspondences as usize {
                ok = false;
                break;
            }
            kept.sort_by(|a, b| a.2.total_cmp(&b.2));
            let n_keep = ((kept.len() as f32 * cfg.trim).ceil() as usize)
                .max(cfg.min_correspondences as usize)
                .min(kept.len());
            kept.truncate(n_keep);
            let step = solve(kept, c + total.t, dof, cfg);
            total = total.then(&step);
            ok = true;
            if step.t.length() < 1e-4 && step.yaw.abs() < 1e-5 {
                break;
            }
        }
        if !ok {
            return None;
        }
        let max_yaw = cfg.max_yaw_deg.to_radians();
        let len = total.t.length();
        if len > cfg.max_translation {
            total.t *= cfg.max_translation / len;
        }
        total.yaw = total.yaw.clamp(-max_yaw, max_yaw);
        self.frame = self.frame.then(&total);
        self.accepted += 1;
        Some(total)
    }
}

/// One least-squares step over the correspondences `(p, q, d², pair)` about the centre `c`.
fn solve(
    corr: &[(Vec3, Vec3, f32, u32)],
    c: Vec3,
    dof: Dof,
    cfg: &RegistrationConfig,
) -> Correction {
    let n = corr.len().max(1) as f32;
    let (mut ps, mut qs) = (Vec3::ZERO, Vec3::ZERO);
    for (p, q, _, _) in corr {
        ps += *p;
        qs += *q;
    }
    let (pm, qm) = (ps / n, qs / n);
    if dof == Dof::Z {
        return Correction {
            yaw: 0.0,
            t: Vec3::new(0.0, 0.0, qm.z - pm.z),
        };
    }
    // 2-D Procrustes in xy about the centroids, yaw only with enough spread.
    let (mut sxx, mut cross, mut dot) = (0.0f32, 0.0f32, 0.0f32);
    for (p, q, _, _) in corr {
        let a = Vec2::new(p.x - pm.x, p.y - pm.y);
        let b = Vec2::new(q.x - qm.x, q.y - qm.y);
        sxx += a.length_squared();
        cross += a.perp_dot(b);
        dot += a.dot(b);
    }
    let spread = (sxx / n).sqrt();
    let yaw = if cfg.estimate_yaw && spread >= cfg.yaw_min_spread {
        cross.atan2(dot)
    } else {
        0.0
    };
    // t such that Rz(yaw)(pm − c) + c + t = qm.
    let r = Correction { yaw, t: Vec3::ZERO };
    let t = qm - r.apply(pm, c);
    Correction { yaw, t }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Points on the faces of an axis-aligned box facing a camera at −y (front, top, +x side),
    /// on a grid of `step` shifted by `phase`.
    fn box_faces(center: Vec3, size: Vec3, step: f32, phase: f32, faces: &[u8]) -> Vec<Vec3> {
        let h = size * 0.5;
        let mut out = Vec::new();
        let n = |a: f32| ((2.0 * a) / step).floor() as i32;
        for &f in faces {
            let (nu, nv) = match f {
                0 => (n(h.x), n(h.z)),
                1 => (n(h.x), n(h.y)),
                _ => (n(h.y), n(h.z)),
            };
            for i in 0..nu {
                for j in 0..nv {
                    let (u, v) = (i as f32 * step + phase, j as f32 * step + phase);
                    out.push(
                        center
                            + match f {
                                0 => Vec3::new(u - h.x, -h.y, v - h.z),
                                1 => Vec3::new(u - h.x, v - h.y, h.z),
                                _ => Vec3::new(h.x, u - h.y, v - h.z),
                            },
                    );
                }
            }
        }
        out
    }

    fn object(points: &[Vec3], cam: Vec3) -> MappedObject {
        let mut o = MappedObject::new(1, 41, 0.9, false, 0.01, 20_000, None, 0);
        o.merge(points, cam);
        o.observations = 2;
        o
    }

    #[test]
    fn a_known_offset_of_3_cm_and_1_degree_is_recovered() {
        let cfg = RegistrationConfig {
            enabled: true,
            ..RegistrationConfig::default()
        };
        let cam = Vec3::new(0.0, -1.0, 1.1);
        let boxes = [
            (Vec3::new(-0.35, 0.0, 0.85), Vec3::new(0.2, 0.15, 0.2)),
            (Vec3::new(0.35, 0.05, 0.9), Vec3::new(0.15, 0.2, 0.3)),
            (Vec3::new(0.0, 0.2, 0.8), Vec3::new(0.25, 0.2, 0.1)),
        ];
        let err = Correction {
            yaw: 1f32.to_radians(),
            t: Vec3::new(0.03, 0.0, 0.0),
        };
        let objects: Vec<_> = boxes
            .iter()
            .map(|(c, s)| object(&box_faces(*c, *s, 0.004, 0.0, &[0, 1, 2]), cam))
            .collect();
        // The frame: the same faces sampled elsewhere, seen through a pose off by `err`.
        let frame: Vec<Vec<Vec3>> = boxes
            .iter()
            .map(|(c, s)| {
                box_faces(*c, *s, 0.006, 0.002, &[0, 1, 2])
                    .into_iter()
                    .map(|p| err.apply(p, cam))
                    .collect()
            })
            .collect();
        let pairs = [(0, 0), (1, 1), (2, 2)];
        let mut r = Registration::default();
        let cam_seen = cam + err.t;
        let d = r
            .estimate(&objects, &frame, &pairs, cam_seen, Dof::Full, &cfg)
            .expect("a correction");
        // The corrected frame points lie where the true ones are.
        let mut worst = 0.0f32;
        for (i, (c, s)) in boxes.iter().enumerate() {
            let truth = box_faces(*c, *s, 0.006, 0.002, &[0, 1, 2]);
            for (p, q) in frame[i].iter().zip(&truth) {
                worst = worst.max(d.apply(*p, cam_seen).distance(*q));
            }
        }
        println!("correction {d:?}, worst residual {worst:.4} m");
        assert!(worst < 0.006, "worst residual {worst} m, correction {d:?}");
        assert!((d.yaw + err.yaw).abs() < 0.3f32.to_radians(), "{d:?}");
    }

    #[test]
    fn a_view_of_an_unseen_side_gives_no_correction() {
        let cfg = RegistrationConfig {
            enabled: true,
            ..RegistrationConfig::default()
        };
        let cam = Vec3::new(0.0, -1.0, 1.1);
        let (c, s) = (Vec3::new(0.0, 0.0, 0.85), Vec3::new(0.3, 0.4, 0.3));
        // The map holds the front face only; the frame sees the +x side (and a sliver of
        // the front's edge), exactly where it is.
        let objects = vec![object(&box_faces(c, s, 0.004, 0.0, &[0]), cam)];
        let frame = vec![box_faces(c, s, 0.006, 0.002, &[2])];
        let mut r = Registration::default();
        let d = r.estimate(
            &objects,
            &frame,
            &[(0, 0)],
            Vec3::new(1.0, -0.2, 1.1),
            Dof::Full,
            &cfg,
        );
        println!("{d:?}");
        assert!(
            d.is_none_or(|d| d.t.length() < 0.005 && d.yaw.abs() < 0.2f32.to_radians()),
            "{d:?}"
        );
    }

    #[test]
    fn the_offset_persists_and_decays() {
        let cfg = RegistrationConfig {
            enabled: true,
            ..RegistrationConfig::default()
        };
        let mut r = Registration {
            frame: Correction {
                yaw: 0.01,
                t: Vec3::new(0.02, 0.0, 0.0),
            },
            ..Registration::default()
        };
        r.end_frame(&cfg);
        assert!(r.offset.t.x > 0.0 && r.offset.t.x < 0.02);
        let pose = Affine3A::from_translation(Vec3::new(1.0, 2.0, 1.0));
        let p = r.begin_frame(&pose, &cfg);
        let moved: Vec3 = p.translation.into();
        assert!((moved - Vec3::new(1.0, 2.0, 1.0) - r.offset.t).length() < 1e-6);
    }
}
