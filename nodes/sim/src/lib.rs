//! The built-in simulator: world, depth camera, detector and robot, stepped deterministically.
//!
//! [`Sim`] is a pure struct: it takes goals and time steps and writes messages in place
//! (`DepthFrame`, `Detections`, `RobotState`, `OccupancyGrid`); the hosts (`vpsom run` with real
//! rates, lockstep with a simulated clock) own the threads, clocks and IPC.
//!
//! ```
//! use sim::{Scene, Sim, SimSetup};
//! use shm_types::{boxed_zeroed, DepthFrame, Detections, NavGoal, RobotState};
//! let mut cfg = SimSetup::default();
//! (cfg.camera.width, cfg.camera.height) = (160, 120);
//! let mut sim = Sim::new(Scene::builtin("paper-scene-1").unwrap(), &cfg, 42).unwrap();
//! let (mut frame, mut dets) = (boxed_zeroed::<DepthFrame>(), boxed_zeroed::<Detections>());
//! sim.set_nav_goal(&NavGoal { goal_id: 1, pose: [-0.5, 0.0, 3.14], ..Default::default() })
//!     .unwrap();
//! for _ in 0..10 {
//!     sim.step(33_333_333);
//!     sim.render(&mut frame, &mut dets, sim.time_ns());
//! }
//! let mut state = RobotState::default();
//! sim.robot_state(&mut state);
//! assert_eq!(state.nav_goal_id, 1);
//! ```
//!
//! Ground truth ([`Sim::scene`], [`Sim::true_state`]) is for evaluation and recording only.
//!
//! Rendering's parallel work (depth ray casting, time-of-flight depth artefacts
//! ([`DepthArtefacts`]: flying pixels at edges, dark/specular/glass materials) and mask bleed, by
//! image rows) runs on the simulator's own named thread pool, [`SimPool`], not on rayon's global
//! pool.

/// The built-in `config/default.toml`, where this crate's sections (`[sim]`, `[detector]`,
/// `[robot]`, `[scenegen]`) have their defaults.
pub(crate) static DEFAULTS: settings::Defaults = settings::Defaults::new(
    "config/default.toml",
    include_str!("../../../config/default.toml"),
);

mod artefacts;
mod camera;
mod config;
mod detector;
mod localization;
mod nav;
mod partition;
#[cfg(test)]
mod render_pin;
mod robot;
mod rowcast;
mod scene;
pub mod scenegen;
mod slam;
mod visibility;
mod world;

pub use artefacts::DepthArtefacts;
pub use camera::{DepthCamera, RenderBuffers};
pub use config::{DetectorConfig, RobotConfig, SimConfig, SimSetup, SlamConfig};
pub use detector::Detector;
pub use localization::Localization;
pub use nav::{GridTooLarge, NavGrid, NavRefusal};
pub use partition::Partition;
pub use robot::Robot;
pub use scene::{
    BUILTIN_SCENES, Material, OVERLAP_TOLERANCE, Room, SUPPORT_TOLERANCE, Scene, SceneError,
    SceneObject, Shape,
};
pub use slam::{PoseDelay, SlamEstimator, SlamEvent};
pub use world::{Hit, STRUCTURE, World};

use geom::{CameraMount, affine_to_pose};
use glam::{Affine3A, Vec3};
use shm_types::{
    DepthFrame, Detections, FrameVisibility, NavGoal, NeckGoal, OccupancyGrid, RobotState,
    boxed_zeroed,
};
use std::sync::{Arc, OnceLock};

/// Fraction of the robot radius by which obstacles are inflated for the TRUE base's collision
/// check (the planner's grid uses the full radius; the margin absorbs small drift).
const COLLISION_INFLATION: f32 = 0.7;

/// Why a simulator could not be built.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    /// The navigation grid of the scene's room does not fit an [`OccupancyGrid`].
    #[error("scene {scene:?}: {source}")]
    Grid {
        /// The scene name.
        scene: String,
        /// Grid size details.
        source: GridTooLarge,
    },
}

/// The simulator's worker threads: [`Sim::render`] runs its row-parallel work (depth ray
/// casting, mask bleed) on this pool.
///
/// Threads are named `sim-<i>` and run at the default priority, `SCHED_OTHER` with the nice
/// value of the thread that builds the pool (Linux threads inherit it; `vpsom run` builds it in
/// the sim node's executor thread, lockstep hosts at nice 0): the simulator is not real-time and
/// must not compete with the planner's LBV thread. Frames do not depend on the number of threads
/// (every pixel's noise comes from a per-row stream). Cloning shares the pool.
#[derive(Debug, Clone)]
pub struct SimPool(Arc<rayon::ThreadPool>);

impl SimPool {
    /// A pool of `threads` workers (0 = one per CPU, or `RAYON_NUM_THREADS` if set).
    pub fn new(threads: usize) -> Result<Self, rayon::ThreadPoolBuildError> {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .thread_name(|i| format!("sim-{i}"))
            .build()
            .map(|pool| Self(Arc::new(pool)))
    }

    /// The process's simulator pool, built on first use with one thread per CPU: every [`Sim`]
    /// renders on it unless given another ([`Sim::set_pool`]). One pool per process, not per
    /// `Sim`, so that hosts running many sessions at once (`vpsom bench`) keep one thread per
    /// CPU, as rayon's global pool did.
    ///
    /// # Panics
    /// If the operating system refuses to start the threads.
    pub fn shared() -> Self {
        static SHARED: OnceLock<SimPool> = OnceLock::new();
        SHARED
            .get_or_init(|| SimPool::new(0).expect("start the simulator's thread pool"))
            .clone()
    }

    /// Run `f` on the pool: rayon's parallel iterators inside it use the pool's threads.
    pub fn install<R: Send>(&self, f: impl FnOnce() -> R + Send) -> R {
        self.0.install(f)
    }

    /// Worker threads.
    pub fn threads(&self) -> usize {
        self.0.current_num_threads()
    }
}

/// The whole simulated robot and world, stepped deterministically for a seed.
#[derive(Debug)]
pub struct Sim {
    pool: SimPool,
    scene: Scene,
    world: World,
    camera: DepthCamera,
    artefacts: DepthArtefacts,
    mount: CameraMount,
    detector: Detector,
    robot: Robot,
    grid: NavGrid,
    collision: NavGrid,
    loc: Localization,
    buf: RenderBuffers,
    visibility_model: visibility::VisibilityModel,
    visibility: Box<FrameVisibility>,
    time_ns: u64,
    frames: u64,
}

impl Sim {
    /// A simulator of `scene` with the `[camera]`, `[sim]`, `[detector]` and `[robot]` sections
    /// of `cfg`, rendering on [`SimPool::shared`]. Same scene, config and seed → identical frames,
    /// detections and states for the same sequence of calls (whatever the number of threads).
    pub fn new(scene: Scene, cfg: impl Into<SimSetup>, seed: u64) -> Result<Sim, SimError> {
        let cfg = &cfg.into();
        let grid_err = |source| SimError::Grid {
            scene: scene.name.clone(),
            source,
        };
        let r = &cfg.robot;
        let grid = NavGrid::build(&scene, r.radius, r.grid_resolution).map_err(grid_err)?;
        let collision = NavGrid::build(&scene, r.radius * COLLISION_INFLATION, r.grid_resolution)
            .map_err(grid_err)?;
        Ok(Sim {
            pool: SimPool::shared(),
            world: World::new(&scene),
            camera: DepthCamera::new(&cfg.camera, &cfg.sim, mix(seed, &[1])),
            artefacts: DepthArtefacts::new(&scene, &cfg.camera, &cfg.sim, mix(seed, &[1, 1])),
            mount: cfg.camera.mount,
            detector: Detector::new(&scene, &cfg.detector, mix(seed, &[2])),
            robot: Robot::new(
                r,
                scene.robot_start,
                cfg.camera.mount.pitch(),
                mix(seed, &[3]),
            ),
            loc: Localization::new(&scene, &cfg.sim),
            grid,
            collision,
            buf: RenderBuffers::new(),
            visibility_model: visibility::VisibilityModel::new(&scene, cfg.detector.min_pixels),
            visibility: boxed_zeroed(),
            time_ns: 0,
            frames: 0,
            scene,
        })
    }

    /// Render on `pool` from now on (e.g. a pool with a given number of threads).
    pub fn set_pool(&mut self, pool: SimPool) {
        self.pool = pool;
    }

    /// The pool rendering runs on.
    pub fn pool(&self) -> &SimPool {
        &self.pool
    }

    /// Accept a chassis goal (planned with A* on the navigation grid from the estimated pose).
    /// Re-sending the current goal id is a no-op. A refused goal sets `nav_status` to
    /// `UNREACHABLE` and returns the reason (also kept in [`Sim::nav_refusal`]).
    pub fn set_nav_goal(&mut self, goal: &NavGoal) -> Result<(), NavRefusal> {
        self.robot.set_nav_goal(goal, &self.grid)
    }

    /// Why the current navigation goal was refused or abandoned, if it was.
    pub fn nav_refusal(&self) -> Option<&NavRefusal> {
        self.robot.refusal()
    }

    /// Set the neck target (yaw relative to the base; pitch clamped to the robot's range).
    pub fn set_neck_goal(&mut self, goal: &NeckGoal) {
        self.robot.set_neck_goal(goal);
    }

    /// Advance the simulated time by `dt_ns`: base, neck and odometry move.
    pub fn step(&mut self, dt_ns: u64) {
        self.robot.step(dt_ns as f32 * 1e-9, &self.collision);
        self.time_ns += dt_ns;
    }

    /// Simulated time, ns (sum of the steps).
    pub fn time_ns(&self) -> u64 {
        self.time_ns
    }

    /// Render a depth frame and detections from the current TRUE camera pose, in place (the
    /// outputs may be loaned shared-memory samples). Fills sizes, intrinsics, `camera_pose`
    /// (the ESTIMATED base pose and neck-encoder reading from `robot.pose_delay_ms` earlier),
    /// headers (`seq` = frame number from 1, `stamp_ns` and
    /// `sim_time_ns` = `now_ns`; a host may overwrite `stamp_ns`/`seq`, keeping
    /// `dets.frame_seq` equal to the frame's `seq`) and updates the localization model.
    /// The depth carries the camera's noise and then the [`DepthArtefacts`]; the ground truth
    /// ([`Sim::last_render`]) is left untouched by both.
    /// Runs on the sim's [`SimPool`]. No heap allocation after the first call.
    pub fn render(&mut self, frame: &mut DepthFrame, dets: &mut Detections, now_ns: u64) {
        let cam = *self.camera.camera();
        let r = &self.robot;
        let true_pose = self.camera_pose(r.true_pose);
        let (est_base, est_neck) = r.stamped_pose();
        let est_pose = tilted(est_base, r.slam().tilt())
            * self.mount.camera_pose(est_base, est_neck, r.neck_pitch);
        self.frames += 1;
        frame.header.seq = self.frames;
        frame.header.stamp_ns = now_ns;
        frame.header.sim_time_ns = now_ns;
        frame.width = cam.width;
        frame.height = cam.height;
        frame.intrinsics = cam.k;
        frame.camera_pose = affine_to_pose(&est_pose);
        frame.reserved = 0;
        let (pool, frames) = (&self.pool, self.frames);
        let (camera, world, buf) = (&self.camera, &self.world, &mut self.buf);
        pool.install(|| camera.render(world, &true_pose, frames, frame.pixels_mut(), buf));
        pool.install(|| {
            self.artefacts
                .apply(world, &true_pose, frames, buf, frame.pixels_mut())
        });
        self.loc.count_visible(&cam, &true_pose, &self.buf);
        self.loc.update(
            self.robot.camera_turn_rate,
            self.robot.distance_true,
            self.time_ns,
        );
        self.robot.visual_update(self.loc.is_ok());
        let (detector, instance) = (&mut self.detector, &self.buf.instance);
        pool.install(|| detector.detect(instance, &cam, &true_pose, frames, dets));
        dets.header = frame.header;
        dets.frame_seq = frame.header.seq;
        let vis = &mut *self.visibility;
        let visible = self.detector.visible_pixels();
        self.visibility_model.fill(&cam, &true_pose, visible, vis);
        vis.header = frame.header;
        vis.frame_seq = frame.header.seq;
    }

    /// Ground truth of the latest [`render`](Self::render): the visibility of every foreground
    /// object in the camera's view (which objects count: `sim/visibility.rs`), the input of the
    /// non-occlusion metric (`eval::occlusion`). Headers as the frame's; evaluation only.
    pub fn visibility(&self) -> &FrameVisibility {
        &self.visibility
    }

    /// `world_from_camera` for a base pose with the current neck.
    fn camera_pose(&self, base: [f32; 3]) -> Affine3A {
        self.mount
            .camera_pose(base, self.robot.neck_yaw, self.robot.neck_pitch)
    }

    /// The robot's state as it believes it (estimated pose and its covariance, neck-encoder
    /// reading), for `robot/state`. Header: `sim_time_ns` = `stamp_ns` = simulated time; `seq`
    /// is the host's.
    pub fn robot_state(&self, out: &mut RobotState) {
        let r = &self.robot;
        self.fill_state(out, r.est_pose(), r.distance_est);
        out.neck_yaw = r.neck_yaw_measured();
        out.odom_cov = r.slam().covariance_f32();
    }

    /// The true state (same type; ground truth for evaluation and recording only).
    pub fn true_state(&self) -> RobotState {
        let mut s = RobotState::default();
        self.fill_state(&mut s, self.robot.true_pose, self.robot.distance_true);
        s.odom_cov = [0.0; 9];
        s
    }

    fn fill_state(&self, out: &mut RobotState, pose: [f32; 3], distance: f32) {
        let r = &self.robot;
        out.header.stamp_ns = self.time_ns;
        out.header.sim_time_ns = self.time_ns;
        out.nav_goal_id = r.goal_id;
        out.base_pose = pose;
        out.neck_yaw = r.neck_yaw;
        out.neck_pitch = r.neck_pitch;
        out.odom_cov = [0.0; 9];
        out.speed = r.speed;
        out.distance_m = distance;
        out.localization_ok = u8::from(self.loc.is_ok());
        out.nav_status = r.status;
        out.reserved = [0; 2];
        out.localization_failures = self.loc.failures();
    }

    /// The pre-built navigation map (obstacle footprints and walls inflated by the robot
    /// radius; `FREE`/`OCCUPIED` only). Header: `sim_time_ns` = simulated time.
    pub fn nav_grid(&self, out: &mut OccupancyGrid) {
        self.grid.write(out);
        out.header.stamp_ns = self.time_ns;
        out.header.sim_time_ns = self.time_ns;
    }

    /// The navigation grid itself.
    pub fn grid(&self) -> &NavGrid {
        &self.grid
    }

    /// The ground-truth scene (evaluation only).
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// The ray-casting world (ground truth; tests and tools).
    pub fn world(&self) -> &World {
        &self.world
    }

    /// The localization model (feature tracking and failure count).
    pub fn localization(&self) -> &Localization {
        &self.loc
    }

    /// The visual-SLAM pose estimator (corrections, loop closures, relocalizations).
    pub fn slam(&self) -> &SlamEstimator {
        self.robot.slam()
    }

    /// The latest render's scratch images (instance ids, noise-free depth; ground truth).
    pub fn last_render(&self) -> &RenderBuffers {
        &self.buf
    }

    /// TRUE `world_from_camera` of the current state (ground truth).
    pub fn true_camera_pose(&self) -> Affine3A {
        self.camera_pose(self.robot.true_pose)
    }
}

/// Mix a seed with stream words (splitmix64 finaliser) into an independent 64-bit seed.
pub(crate) fn mix(seed: u64, words: &[u64]) -> u64 {
    let mut z = seed ^ 0x9e37_79b9_7f4a_7c15;
    for w in words {
        z = z.wrapping_add(*w).wrapping_add(0x9e37_79b9_7f4a_7c15);
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^= z >> 31;
    }
    z
}

/// The SLAM's out-of-plane error `[z, roll, pitch]` of a base at `[x, y, yaw]`, as a world
/// transform: roll about the base's forward axis and pitch about its left axis, both through
/// the base's floor point, then a lift by `z`.
fn tilted(base: [f32; 3], tilt: [f32; 3]) -> Affine3A {
    let [x, y, yaw] = base;
    let [z, roll, pitch] = tilt;
    let at = Vec3::new(x, y, 0.0);
    let heading = glam::Quat::from_rotation_z(yaw);
    let r = heading
        * glam::Quat::from_rotation_x(roll)
        * glam::Quat::from_rotation_y(pitch)
        * heading.inverse();
    Affine3A::from_translation(at + Vec3::Z * z)
        * Affine3A::from_quat(r)
        * Affine3A::from_translation(-at)
}
