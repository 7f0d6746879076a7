//! Time-of-flight (Kinect v2) depth artefacts, applied to a rendered depth image.
//!
//! [`DepthCamera::render`](super::DepthCamera::render) gives every pixel the depth of the one
//! surface its centre ray hits, with σ(z) noise. A real time-of-flight pixel integrates the light
//! of its whole footprint, and its driver drops pixels whose returned light is too weak or
//! inconsistent. [`DepthArtefacts::apply`] post-processes the rendered `depth_mm` (never the
//! ground truth `depth_true` and `instance` of [`RenderBuffers`]) with:
//!
//! - **Mixed ("flying") pixels at depth edges.** A pixel within `edge_width_px` (4-neighbour
//!   steps along the row or the column) of a pixel whose TRUE depth differs from its own by at
//!   least `edge_min_jump_m` is an edge pixel. A valid edge pixel is removed (0) with probability
//!   `edge_invalid` (as the driver's edge filter does: libfreenect2's edge-aware filter looks for
//!   such jumps in the 3×3 neighbourhood), or else becomes a mixed pixel with probability
//!   `edge_mixed`: its depth is `z + α·(z_other − z)`, α uniform in [0, 1], `z_other` the depth
//!   across the largest jump, with σ(z) noise and the range limits applied (Sarbolandi et al.
//!   2015; Fankhauser et al. 2015). Away from edges nothing changes.
//! - **Materials** ([`Material`], per scene object). A valid pixel of a `dark` object is invalid
//!   with probability `dark_invalid`, of a `specular` object with probability
//!   `specular_invalid`. A valid pixel of a `glass` object is invalid with probability
//!   `glass_invalid`, or else reads the surface BEHIND the glass with probability
//!   `glass_through` (the ray is cast on past the object's far side, through further glass, with
//!   σ(z) noise and the range limits), or else keeps the glass surface's reading (reflections,
//!   labels). Material outcomes take precedence over edge outcomes for the same pixel.
//!
//! Outcomes are independent per pixel, drawn from a PCG stream per (seed, frame, row): the
//! result does not depend on the number of threads. Rows run in parallel on the current rayon
//! pool. No allocation per frame. Pixels already invalid (range, grazing angle, dropout) stay
//! invalid: artefacts only degrade valid readings.

use super::camera::RenderBuffers;
use super::config::SimConfig;
use super::scene::{Material, Scene};
use super::world::World;
use geom::Camera;
use geom::CameraConfig;
use glam::{Affine3A, Vec3};
use rand::Rng;
use rand_distr::StandardNormal;
use rand_pcg::Pcg64;
use rayon::prelude::*;

/// Fewest image rows a parallel task takes (the per-row work is light).
const ROWS_PER_TASK: usize = 16;

/// Up to this many objects of affected materials, candidates are found by comparing instance
/// ids (vectorised) rather than by a table lookup per pixel.
const AFFECTED_IDS: usize = 16;

/// Glass layers a see-through ray passes before it takes what it hits.
const MAX_GLASS_LAYERS: usize = 3;

/// Per-material outcome probabilities of one valid pixel.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
struct MaterialRates {
    /// Invalid (0).
    invalid: f32,
    /// Reads the surface behind (glass only).
    through: f32,
}

/// The depth-artefact post-process of one simulated camera (see the module docs).
#[derive(Debug, Clone)]
pub struct DepthArtefacts {
    camera: Camera,
    noise_a: f32,
    noise_b: f32,
    min_jump: f32,
    width: usize,
    edge_mixed: f32,
    edge_invalid: f32,
    /// Outcome probabilities per instance id (`k + 1` for object `k`; 0 = structure).
    rates: [MaterialRates; 256],
    /// Whether an instance's material has artefacts (some rate > 0).
    affected: [bool; 256],
    /// Instance ids of the objects whose material has artefacts.
    affected_ids: Vec<u8>,
    /// Material per instance id.
    material: [Material; 256],
    seed: u64,
}

impl DepthArtefacts {
    /// The artefacts of `scene`'s materials for a camera of the `[camera]` and `[sim]` sections,
    /// with a seed.
    pub fn new(scene: &Scene, cam: &CameraConfig, sim: &SimConfig, seed: u64) -> Self {
        let mut material = [Material::Default; 256];
        let mut rates = [MaterialRates::default(); 256];
        for (k, o) in scene.objects.iter().enumerate() {
            material[k + 1] = o.material;
            rates[k + 1] = match o.material {
                Material::Default => MaterialRates::default(),
                Material::Glass => MaterialRates {
                    invalid: sim.glass_invalid,
                    through: sim.glass_through,
                },
                Material::Dark => MaterialRates {
                    invalid: sim.dark_invalid,
                    through: 0.0,
                },
                Material::Specular => MaterialRates {
                    invalid: sim.specular_invalid,
                    through: 0.0,
                },
            };
        }
        Self {
            camera: cam.camera(),
            noise_a: sim.noise_a,
            noise_b: sim.noise_b,
            min_jump: sim.edge_min_jump_m,
            width: sim.edge_width_px.max(1) as usize,
            edge_mixed: sim.edge_mixed,
            edge_invalid: sim.edge_invalid,
            affected: rates.map(|r| r.invalid + r.through > 0.0),
            affected_ids: (1..=scene.objects.len())
                .filter(|&k| rates[k].invalid + rates[k].through > 0.0)
                .map(|k| k as u8)
                .collect(),
            rates,
            material,
            seed,
        }
    }

    /// Whether any artefact can happen (some probability is not zero).
    pub fn is_active(&self) -> bool {
        self.edge_active() || self.rates.iter().any(|r| r.invalid + r.through > 0.0)
    }

    fn edge_active(&self) -> bool {
        self.edge_mixed > 0.0 || self.edge_invalid > 0.0
    }

    /// Apply the artefacts of frame `frame_index` to `depth_mm` (the render's noisy depth,
    /// row-major, mm, 0 = invalid), reading the ground truth of the same render in `buf` and
    /// casting see-through rays in `world` from `world_from_camera` (the TRUE pose the frame was
    /// rendered from). Rows run in parallel on the current rayon pool.
    ///
    /// # Panics
    /// If `depth_mm` is shorter than `width × height`.
    pub fn apply(
        &self,
        world: &World,
        world_from_camera: &Affine3A,
        frame_index: u64,
        buf: &RenderBuffers,
        depth_mm: &mut [u16],
    ) {
        if !self.is_active() {
            return;
        }
        let w = self.camera.width as usize;
        let h = self.camera.height as usize;
        let n = w * h;
        let (truth, inst) = (&buf.depth_true[..n], &buf.instance[..n]);
        depth_mm[..n]
            .par_chunks_mut(w)
            .with_min_len(ROWS_PER_TASK)
            .enumerate()
            .for_each(|(v, row)| {
                let mut rng = row_rng(self.seed, frame_index, v as u64);
                let ray = Ray {
                    world,
                    pose: world_from_camera,
                    v,
                };
                self.apply_row(truth, inst, h, v, row, &mut rng, &ray);
            });
    }

    /// Row `v` of an image `h` rows high.
    #[allow(clippy::too_many_arguments)]
    fn apply_row(
        &self,
        truth: &[f32],
        inst: &[u8],
        h: usize,
        v: usize,
        row: &mut [u16],
        rng: &mut Pcg64,
        ray: &Ray<'_>,
    ) {
        let w = row.len();
        let base = v * w;
        // Largest true-depth jump to a 4-neighbour within `width` steps, per pixel (branch-free
        // passes over whole rows; the exact neighbour is looked up only where it is an edge).
        let mut jump = [0f32; shm_types::MAX_WIDTH];
        let jump = &mut jump[..w];
        if self.edge_active() {
            let here = &truth[base..base + w];
            let widen = |jump: &mut [f32], a: &[f32], b: &[f32]| {
                for ((j, a), b) in jump.iter_mut().zip(a).zip(b) {
                    let d = (a - b).abs();
                    *j = if d > *j { d } else { *j };
                }
            };
            for d in 1..=self.width.min(w - 1) {
                if v >= d {
                    widen(jump, here, &truth[base - d * w..][..w]);
                }
                if v + d < h {
                    widen(jump, here, &truth[base + d * w..][..w]);
                }
                widen(&mut jump[d..], &here[d..], &here[..w - d]);
                widen(&mut jump[..w - d], &here[..w - d], &here[d..]);
            }
        }
        // Pixels that may change: on an edge or of an affected material (vectorisable passes).
        let inst = &inst[base..base + w];
        let mut hot = [0u8; shm_types::MAX_WIDTH];
        let hot = &mut hot[..w];
        for (hot, j) in hot.iter_mut().zip(jump.iter()) {
            *hot = u8::from(*j >= self.min_jump);
        }
        if self.affected_ids.len() <= AFFECTED_IDS {
            for id in self.affected_ids.iter().copied() {
                for (hot, k) in hot.iter_mut().zip(inst) {
                    *hot |= u8::from(*k == id);
                }
            }
        } else {
            for (hot, k) in hot.iter_mut().zip(inst) {
                *hot |= u8::from(self.affected[*k as usize]);
            }
        }
        const BLOCK: usize = 16;
        for (b, block) in hot.chunks(BLOCK).enumerate() {
            if block.iter().fold(0, |a, h| a | h) == 0 {
                continue;
            }
            for (j, c) in block.iter().enumerate() {
                let u = b * BLOCK + j;
                if *c != 0 && row[u] != 0 {
                    row[u] = self.pixel(
                        truth,
                        inst[u],
                        jump[u] >= self.min_jump,
                        h,
                        v,
                        u,
                        row[u],
                        rng,
                        ray,
                    );
                }
            }
        }
    }

    /// New reading of pixel `(u, v)` (instance `inst`, valid reading `out`), a candidate: of an
    /// affected material or, if `edge`, on a depth edge.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    fn pixel(
        &self,
        truth: &[f32],
        inst: u8,
        edge: bool,
        h: usize,
        v: usize,
        u: usize,
        out: u16,
        rng: &mut Pcg64,
        ray: &Ray<'_>,
    ) -> u16 {
        let w = truth.len() / h;
        let z = truth[v * w + u];
        if self.affected[inst as usize] {
            let r = self.rates[inst as usize];
            let x: f32 = rng.random();
            if x < r.invalid {
                return 0;
            }
            if x < r.invalid + r.through {
                return self.measure(ray.behind(self, u, z, inst), rng);
            }
        }
        if !edge {
            return out;
        }
        let other = self.across_edge(truth, w, h, u, v, z);
        if other == z {
            return out;
        }
        let x: f32 = rng.random();
        if x < self.edge_invalid {
            0
        } else if x < self.edge_invalid + self.edge_mixed {
            let a: f32 = rng.random();
            self.measure(z + a * (other - z), rng)
        } else {
            out
        }
    }

    /// The true depth across the largest jump ≥ `min_jump` within `width` 4-neighbour steps of
    /// pixel `(u, v)` (true depth `z`), or `z` if there is none.
    #[inline]
    fn across_edge(&self, truth: &[f32], w: usize, h: usize, u: usize, v: usize, z: f32) -> f32 {
        let (mut best, mut other) = (self.min_jump, z);
        let mut consider = |zn: f32| {
            let d = (zn - z).abs();
            if d >= best && zn > 0.0 {
                (best, other) = (d, zn);
            }
        };
        let i = v * w + u;
        for d in 1..=self.width {
            if u >= d {
                consider(truth[i - d]);
            }
            if u + d < w {
                consider(truth[i + d]);
            }
            if v >= d {
                consider(truth[i - d * w]);
            }
            if v + d < h {
                consider(truth[i + d * w]);
            }
        }
        other
    }

    /// Depth reading (mm, 0 = invalid) of true depth `z`: range limits and σ(z) noise.
    fn measure(&self, z: f32, rng: &mut Pcg64) -> u16 {
        let k = &self.camera.k;
        if !(z >= k.min_range && z <= k.max_range) {
            return 0;
        }
        let sigma = self.noise_a + self.noise_b * z * z;
        let z = if sigma > 0.0 {
            z + sigma * rng.sample::<f32, _>(StandardNormal)
        } else {
            z
        };
        ((z * 1000.0 + 0.5) as u16).max(1)
    }
}

/// See-through ray casting for one image row.
struct Ray<'a> {
    world: &'a World,
    pose: &'a Affine3A,
    v: usize,
}

impl Ray<'_> {
    /// True depth of what pixel `(u, self.v)` sees behind the glass object (instance `obj`)
    /// it hits at depth `z` (further glass layers are passed too, up to [`MAX_GLASS_LAYERS`]);
    /// 0 if nothing.
    fn behind(&self, a: &DepthArtefacts, u: usize, z: f32, obj: u8) -> f32 {
        let origin = Vec3::from(self.pose.translation);
        // Depth = ray parameter: the ray's camera-frame z component is 1.
        let dir = self.pose.matrix3 * a.camera.ray(u as f32 + 0.5, self.v as f32 + 0.5);
        let (mut t, mut obj) = (z, obj as usize);
        for _ in 0..MAX_GLASS_LAYERS {
            if obj == 0 || a.material[obj] != Material::Glass {
                return t;
            }
            let k = obj - 1;
            // Leave the object: cast back at it from beyond its far side.
            let (lo, hi) = self.world.object_bounds(k);
            let far = t + (hi - lo).length() + 1e-2;
            let Some((back, _)) = self.world.cast_object(k, origin + dir * far, -dir, far) else {
                return t;
            };
            let exit = far - back + 1e-4;
            let Some(next) = self.world.cast(origin + dir * exit, dir, 1e4) else {
                return 0.0;
            };
            (t, obj) = (exit + next.t, next.instance as usize);
        }
        t
    }
}

/// A PCG stream for one row of one frame (distinct from the camera's noise streams).
fn row_rng(seed: u64, frame: u64, row: u64) -> Pcg64 {
    let s = super::mix(seed, &[0x6172_7466, frame, row]);
    Pcg64::new(
        s as u128 | ((row as u128) << 64),
        0x5851_f42d_4c95_7f2d_1405_7b7e_f767_814f,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::DepthCamera;
    use crate::SimSetup;
    use geom::optical_rotation;
    use std::path::Path;

    const ROOM: &str = "name = \"t\"\n[room]\nmin = [-6.0, -6.0]\nmax = [4.0, 6.0]\nheight = 3.0\n\
                        [robot]\nstart = [0.0, 0.0, 0.0]\n";

    fn scene(objects: &str) -> Scene {
        Scene::parse(Path::new("t.toml"), &format!("{ROOM}{objects}")).unwrap()
    }

    fn config(w: u32, h: u32, edit: impl FnOnce(&mut SimConfig)) -> SimSetup {
        let mut cfg = SimSetup::default();
        (cfg.camera.width, cfg.camera.height) = (w, h);
        (cfg.sim.noise_a, cfg.sim.noise_b, cfg.sim.dropout) = (0.0, 0.0, 0.0);
        edit(&mut cfg.sim);
        cfg
    }

    /// Camera at (0, 0, 1) looking along +x.
    fn pose() -> Affine3A {
        Affine3A::from_mat3_translation(optical_rotation(0.0, 0.0), Vec3::Z)
    }

    /// Per column: (invalid, mixed, unchanged) counts over `frames` frames of a synthetic image
    /// whose left half is 1 m deep and right half 3 m.
    fn edge_counts(cfg: &SimSetup, frames: u64) -> Vec<[usize; 3]> {
        let (w, h) = (cfg.camera.width as usize, cfg.camera.height as usize);
        let art = DepthArtefacts::new(&scene(""), &cfg.camera, &cfg.sim, 5);
        let world = World::new(&scene(""));
        let mut buf = RenderBuffers::new();
        for i in 0..w * h {
            buf.depth_true[i] = if i % w < w / 2 { 1.0 } else { 3.0 };
            buf.instance[i] = 0;
        }
        let before = buf.clone();
        let mut counts = vec![[0; 3]; w];
        let mut depth = vec![0u16; w * h];
        for frame in 0..frames {
            for (d, z) in depth.iter_mut().zip(&buf.depth_true) {
                *d = (z * 1000.0) as u16;
            }
            art.apply(&world, &pose(), frame, &buf, &mut depth);
            for (i, d) in depth.iter().enumerate() {
                let own = (buf.depth_true[i] * 1000.0) as u16;
                let k = match *d {
                    0 => 0,
                    d if d == own => 2,
                    d => {
                        assert!((1000..=3000).contains(&d), "mixed depth {d}");
                        1
                    }
                };
                counts[i % w][k] += 1;
            }
        }
        assert_eq!(buf.depth_true, before.depth_true, "ground truth untouched");
        assert_eq!(buf.instance, before.instance, "ground truth untouched");
        counts
    }

    #[test]
    fn depth_edges_get_mixed_and_removed_pixels_at_the_configured_rates_and_nowhere_else() {
        for width in [1usize, 2] {
            let cfg = config(64, 48, |s| {
                (s.edge_mixed, s.edge_invalid) = (0.3, 0.4);
                s.edge_width_px = width as u32;
            });
            let counts = edge_counts(&cfg, 40);
            let edge = 32 - width..32 + width;
            let (mut n, mut sum) = (0, [0; 3]);
            for (u, c) in counts.iter().enumerate() {
                if edge.contains(&u) {
                    n += c.iter().sum::<usize>();
                    (0..3).for_each(|k| sum[k] += c[k]);
                } else {
                    assert_eq!(
                        c[..2],
                        [0, 0],
                        "width {width}: column {u} is away from the edge"
                    );
                }
            }
            let rate = |k: usize| sum[k] as f32 / n as f32;
            assert!((rate(0) - 0.4).abs() < 0.04, "invalid {}", rate(0));
            assert!((rate(1) - 0.3).abs() < 0.04, "mixed {}", rate(1));
        }
        // A jump smaller than the threshold is no edge.
        let cfg = config(64, 48, |s| s.edge_min_jump_m = 2.5);
        assert!(edge_counts(&cfg, 5).iter().all(|c| c[..2] == [0, 0]));
    }

    /// Render the glass (or not) box in front of the wall at x = 4 m; per object pixel:
    /// (invalid, through = reads the wall, surface) counts and the render's instance image.
    fn glass_counts(material: &str, cfg: &SimSetup, frames: u64) -> [usize; 3] {
        let s = scene(&format!(
            "[[object]]\nname = \"g\"\nclass = \"wine glass\"\ncenter = [2.75, 0.0, 1.0]\n\
             size = [0.5, 1.0, 1.0]\nmaterial = \"{material}\"\n"
        ));
        let world = World::new(&s);
        let cam = DepthCamera::new(&cfg.camera, &cfg.sim, 3);
        let art = DepthArtefacts::new(&s, &cfg.camera, &cfg.sim, 4);
        let (w, h) = (cfg.camera.width as usize, cfg.camera.height as usize);
        let mut depth = vec![0u16; w * h];
        let mut buf = RenderBuffers::new();
        let mut counts = [0; 3];
        for frame in 0..frames {
            cam.render(&world, &pose(), frame, &mut depth, &mut buf);
            art.apply(&world, &pose(), frame, &buf, &mut depth);
            for i in (0..w * h).filter(|&i| buf.instance[i] == 1) {
                assert!((buf.depth_true[i] - 2.5).abs() < 1e-3, "truth is the glass");
                match depth[i] {
                    0 => counts[0] += 1,
                    d if d.abs_diff(4000) <= 1 => counts[1] += 1,
                    d => {
                        assert!(d.abs_diff(2500) <= 1, "{d}");
                        counts[2] += 1
                    }
                }
            }
        }
        counts
    }

    #[test]
    fn glass_pixels_are_invalid_or_see_through_at_the_configured_rates() {
        let cfg = config(48, 36, |s| {
            (s.edge_mixed, s.edge_invalid) = (0.0, 0.0);
            (s.glass_invalid, s.glass_through) = (0.5, 0.3);
        });
        let c = glass_counts("glass", &cfg, 10);
        let n = c.iter().sum::<usize>() as f32;
        assert!(n > 1000.0, "{n} glass pixels");
        let rate = |k: usize| c[k] as f32 / n;
        assert!((rate(0) - 0.5).abs() < 0.04, "invalid {}", rate(0));
        assert!((rate(1) - 0.3).abs() < 0.04, "see-through {}", rate(1));
        // Other materials' rates apply to theirs; a default object is untouched.
        let cfg = config(48, 36, |s| {
            (s.edge_mixed, s.edge_invalid) = (0.0, 0.0);
            (s.dark_invalid, s.specular_invalid) = (0.25, 0.6);
        });
        let dark = glass_counts("dark", &cfg, 5);
        let rate = dark[0] as f32 / dark.iter().sum::<usize>() as f32;
        assert!((rate - 0.25).abs() < 0.05 && dark[1] == 0, "{dark:?}");
        let spec = glass_counts("specular", &cfg, 5);
        let rate = spec[0] as f32 / spec.iter().sum::<usize>() as f32;
        assert!((rate - 0.6).abs() < 0.05 && spec[1] == 0, "{spec:?}");
        assert_eq!(glass_counts("default", &cfg, 2)[..2], [0, 0]);
    }

    #[test]
    fn see_through_passes_several_glass_layers_and_stops_at_an_opaque_one() {
        let objects = |second: &str| {
            format!(
                "[[object]]\nname = \"a\"\nclass = \"vase\"\ncenter = [1.5, 0.0, 1.0]\n\
                 size = [0.2, 0.4, 0.4]\nshape = \"box\"\nmaterial = \"glass\"\n\
                 [[object]]\nname = \"b\"\nclass = \"vase\"\ncenter = [2.5, 0.0, 1.0]\n\
                 size = [0.2, 0.4, 0.4]\nmaterial = \"{second}\"\n"
            )
        };
        let cfg = config(32, 24, |s| (s.glass_invalid, s.glass_through) = (0.0, 1.0));
        for (second, expect) in [("glass", 4.0), ("default", 2.4)] {
            let s = scene(&objects(second));
            let art = DepthArtefacts::new(&s, &cfg.camera, &cfg.sim, 1);
            let ray = Ray {
                world: &World::new(&s),
                pose: &pose(),
                v: 12,
            };
            let z = ray.behind(&art, 16, 1.4, 1);
            assert!((z - expect).abs() < 1e-3, "{second}: {z}");
        }
    }
}
