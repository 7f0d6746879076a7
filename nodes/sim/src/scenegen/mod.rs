//! Scene generator: random rooms in the scene-file format, so that no planner is tuned to the
//! three paper scenes (`vpsom scene gen`, `vpsom bench --generated K`).
//!
//! | file | what |
//! |---|---|
//! | `mod.rs` | [`generate`]: attempts, validation round trip, statistics |
//! | `config.rs` | [`SceneGenConfig`], the `[scenegen]` section |
//! | `catalog.rs` | [`Kind`]s of room, their furniture and object classes, sizes with their sources, materials |
//! | `layout.rs` | one random layout: room, partition, supports, chairs, start, objects |
//! | `visibility.rs` | checks with the sim's ray casting: [`visibility::check`], [`visibility::clusters_out_of_start_view`] |
//! | `write.rs` | the scene file text |
//!
//! A room of `kind` (office, kitchen, living, lab; from the seed if not given) has sides of
//! `room_min_m`–`room_max_m`, sometimes a partition wall (`[[partition]]`), 1–4 support
//! clusters (desks, tables, counters, shelves 0.9–1.05 m high, coffee tables, couches; chairs at
//! desks and tables, sometimes carrying an object) placed against the walls or free-standing
//! with a `passage_m` gap, a start pose with `start_clearance_m` of free space around the robot
//! (facing the first cluster with probability `start_faces_cluster`, else any direction, and
//! seeing at least `start_min_features` of the simulated visual SLAM's features, so that
//! tracking starts: [`start_features`]), and
//! 5–25 foreground objects, each resting on a support top (z from the top), 15 mm apart at
//! least, with plausible materials. Furniture and object sizes come from the generator's own
//! catalogue of cited standards and product ranges ([`catalog`], `docs/simulator.md`), not from
//! anything the robot's nodes believe about a class.
//!
//! The layout is written as scene text and parsed back with [`Scene::parse`], so a generated
//! scene passes exactly the validation of hand-written ones. Then every foreground object must
//! be seen from some pose reachable from the start on the robot's navigation grid
//! ([`visibility::check`]: the sim's own [`crate::World`] ray casts from the configured
//! camera); an object no pose sees is dropped, and a layout left with too few objects or an
//! empty support is drawn again from the same stream. Everything is drawn from one PCG stream
//! seeded from `(seed, kind)`: the same seed, kind and configuration give byte-identical text.
//!
//! ```
//! use sim::{SimSetup, scenegen::{self, Kind}};
//! let g = scenegen::generate(7, Some(Kind::Kitchen), &SimSetup::default()).unwrap();
//! assert_eq!(g.scene.name, "gen-kitchen-7");
//! assert!(g.stats.objects >= 5 && g.stats.objects <= 25);
//! ```

pub mod catalog;
mod config;
mod layout;
pub mod visibility;
mod write;

pub use catalog::Kind;
pub use config::SceneGenConfig;
pub use visibility::Visibility;

use crate::SimSetup;
use crate::{Scene, SceneError};
use rand::SeedableRng;
use rand_pcg::Pcg64;
use std::path::Path;

/// A generated scene.
#[derive(Debug, Clone)]
pub struct Generated {
    /// The validated scene (parsed from [`Generated::toml`]).
    pub scene: Scene,
    /// The scene file text.
    pub toml: String,
    /// Its kind.
    pub kind: Kind,
    /// Its seed.
    pub seed: u64,
    /// What it holds.
    pub stats: GenStats,
}

/// Figures of a generated scene.
#[derive(Debug, Clone, PartialEq)]
pub struct GenStats {
    /// Room sides x, y, metres.
    pub room: [f32; 2],
    /// Partition walls.
    pub partitions: usize,
    /// Support clusters (background objects carrying foreground objects).
    pub clusters: usize,
    /// Background objects in all (supports and chairs).
    pub background: usize,
    /// Foreground objects.
    pub objects: usize,
    /// Foreground objects partly hidden by another object from some pose that sees them.
    pub occluded: usize,
    /// Support clusters the start view does not see.
    pub out_of_start_view: usize,
    /// Layouts drawn before this one was accepted.
    pub attempts: u32,
}

/// Why no scene was generated.
#[derive(Debug, thiserror::Error)]
pub enum GenError {
    /// No layout of the seed's stream met the constraints within `scenegen.max_attempts`.
    #[error("scene gen seed {seed} kind {kind}: no valid layout in {attempts} attempts")]
    Exhausted {
        /// The seed.
        seed: u64,
        /// The kind's name.
        kind: &'static str,
        /// Attempts made.
        attempts: u32,
    },
    /// A generated text failed the scene loader (a generator bug).
    #[error("scene gen produced an invalid scene: {0}")]
    Invalid(#[from] SceneError),
}

/// Localization features the simulator's visual-SLAM model tracks in the first frame at the
/// start (160 × 120 render of the configured camera, neck straight ahead).
pub fn start_features(scene: &Scene, cfg: impl Into<SimSetup>) -> u32 {
    let mut small: SimSetup = cfg.into();
    (small.camera.width, small.camera.height) = (160, 120);
    let Ok(mut sim) = crate::Sim::new(scene.clone(), small, 0) else {
        return 0;
    };
    let mut frame = shm_types::boxed_zeroed::<shm_types::DepthFrame>();
    let mut dets = shm_types::boxed_zeroed::<shm_types::Detections>();
    sim.render(&mut frame, &mut dets, 0);
    sim.localization().last_tracked()
}

/// The scene name of a seed and kind: `gen-<kind>-<seed>`.
pub fn scene_name(seed: u64, kind: Kind) -> String {
    format!("gen-{}-{seed}", kind.name())
}

/// Generate the room of `seed` (of `kind`, or [`Kind::for_seed`]) with the `[scenegen]`,
/// `[robot]` and `[camera]` sections of `cfg`.
pub fn generate(
    seed: u64,
    kind: Option<Kind>,
    cfg: impl Into<SimSetup>,
) -> Result<Generated, GenError> {
    let cfg = &cfg.into();
    let kind = kind.unwrap_or_else(|| Kind::for_seed(seed));
    let name = scene_name(seed, kind);
    let g = &cfg.scenegen;
    let stream = crate::mix(seed, &[0x5ce9_e9e9, kind as u64]);
    let mut rng = Pcg64::seed_from_u64(stream);
    for attempt in 1..=g.max_attempts {
        let Some(mut draft) = layout::layout(&mut rng, kind, g, cfg.robot.radius) else {
            continue;
        };
        let file = Path::new(&name);
        // The start must give visual SLAM enough features to track (a start facing a bare wall
        // leaves the mapper without a frame): redraw the start pose until it does.
        let mut scene = Scene::parse(file, &write::scene_toml(&draft, &name, kind, seed))?;
        let mut tries = 0;
        while start_features(&scene, cfg) < g.start_min_features {
            tries += 1;
            let Some(start) = (tries <= 20)
                .then(|| layout::draw_start(&mut rng, &draft, g, cfg.robot.radius))
                .flatten()
            else {
                break;
            };
            draft.start = start;
            scene = Scene::parse(file, &write::scene_toml(&draft, &name, kind, seed))?;
        }
        if start_features(&scene, cfg) < g.start_min_features {
            continue;
        }
        let vis = visibility::check(&scene, cfg);
        // Drop what no reachable pose sees (objects and draft entries are in the same order).
        let keep: Vec<bool> = vis.visible.clone();
        if keep.iter().any(|k| !k) {
            let mut it = keep.iter();
            draft.objects.retain(|_| *it.next().unwrap_or(&true));
            let mut it = keep.iter();
            draft.support.retain(|_| *it.next().unwrap_or(&true));
        }
        let text = write::scene_toml(&draft, &name, kind, seed);
        let scene = Scene::parse(file, &text)?;
        let clusters = visibility::support_clusters(&scene);
        let objects = scene.foreground().count();
        let bare_support = (0..draft.objects.len())
            .filter(|&s| draft.support[s].is_none() && !draft.objects[s].name.starts_with("chair"))
            .any(|s| !clusters.iter().any(|(b, _)| *b == s));
        if objects < g.objects_min
            || objects > g.objects_max
            || clusters.len() < g.clusters_min
            || clusters.len() > g.clusters_max
            || bare_support
            || scene.foreground().any(|i| scene.cluster_of(i).is_none())
        {
            continue;
        }
        let vis = if keep.iter().all(|k| *k) {
            vis
        } else {
            visibility::check(&scene, cfg)
        };
        let size = scene.room.max - scene.room.min;
        let stats = GenStats {
            room: size.to_array(),
            partitions: scene.partitions.len(),
            clusters: clusters.len(),
            background: scene.objects.iter().filter(|o| o.background).count(),
            objects,
            occluded: vis.occluded.iter().filter(|o| **o).count(),
            out_of_start_view: visibility::clusters_out_of_start_view(&scene, cfg).len(),
            attempts: attempt,
        };
        return Ok(Generated {
            scene,
            toml: text,
            kind,
            seed,
            stats,
        });
    }
    Err(GenError::Exhausted {
        seed,
        kind: kind.name(),
        attempts: g.max_attempts,
    })
}
