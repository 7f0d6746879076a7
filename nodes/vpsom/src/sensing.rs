//! `vpsom sensing`: drive a scripted tour of each scene with the simulator and measure its
//! sensing against the ground truth (`eval::sensing`): detector recall by size, occlusion and
//! truncation, false positives, box IoU, confusion, invalid depth, ATE and RPE.
//!
//! The tour is deterministic: from the start the base drives to the room centre, then to goals
//! on a ring around each background object (`[sensing] ring_points` goals, `ring_clearance`
//! outside its footprint circle, facing it; goals in obstacles are dropped), in scene order,
//! starting over when the list is done. A goal is left when reached, refused or after
//! `goal_timeout_s`. The neck sweeps `yaw = A·sin(2πt/T)` relative to the base all along.
//! One frame is rendered per camera period (`bench.camera_hz`, else `rates.camera_hz`) at the
//! `[camera]` size.

use crate::config::Config;
use crate::eval::sensing::{
    ErrorStats, Figures, PoseSample, SceneReport, SensingReport, Settings, Tally, ate, rpe,
    visible_objects,
};
use crate::geom::pose_to_affine;
use crate::sim::{Scene, Sim, SimError};
use glam::Vec2;
use shm_types::{DepthFrame, Detections, NavGoal, NeckGoal, boxed_zeroed, nav_status};

/// What to measure.
#[derive(Debug, Clone)]
pub struct SensingSpec {
    /// Scenes, in report order.
    pub scenes: Vec<Scene>,
    /// Configuration (camera, sensing models, `[sensing]` tour).
    pub config: Config,
    /// Seed of the simulator.
    pub seed: u64,
    /// Frames per scene.
    pub frames: u64,
}

/// The camera rate of the tour, Hz: `bench.camera_hz`, else `rates.camera_hz`.
pub fn camera_hz(cfg: &Config) -> f64 {
    if cfg.bench.camera_hz > 0.0 {
        cfg.bench.camera_hz
    } else {
        cfg.rates.camera_hz
    }
}

/// The tour's base goals `[x, y, yaw]` in a scene (see the module docs), never empty.
pub fn tour_goals(scene: &Scene, sim: &Sim, cfg: &Config) -> Vec<[f32; 3]> {
    let grid = sim.grid();
    let s = &cfg.sensing;
    let room = scene.room;
    let centre = (room.min + room.max) * 0.5;
    // The free cell nearest to the room centre (the start if none is free).
    let start = Vec2::new(scene.robot_start[0], scene.robot_start[1]);
    let free_centre = (0..grid.height)
        .flat_map(|iy| (0..grid.width).map(move |ix| (ix, iy)))
        .filter(|&(ix, iy)| !grid.occupied[iy * grid.width + ix])
        .map(|(ix, iy)| grid.center(ix, iy))
        .min_by(|a, b| a.distance(centre).total_cmp(&b.distance(centre)))
        .unwrap_or(start);
    let mut goals = vec![[free_centre.x, free_centre.y, 0.0]];
    for o in scene.objects.iter().filter(|o| o.background) {
        let c = o.center.truncate();
        let r = 0.5 * o.size.truncate().length() + s.ring_clearance;
        for j in 0..s.ring_points {
            let a = o.yaw + j as f32 * std::f32::consts::TAU / s.ring_points as f32;
            let p = c + Vec2::from_angle(a) * r;
            if !grid.is_blocked(p) {
                let to = c - p;
                goals.push([p.x, p.y, to.y.atan2(to.x)]);
            }
        }
    }
    goals
}

/// Drive the tour of one scene for `frames` frames and score every frame. Returns the
/// per-frame figures, the counts and the pose track.
pub fn run_tour(
    scene: &Scene,
    cfg: &Config,
    seed: u64,
    frames: u64,
) -> Result<
    (
        Vec<crate::eval::sensing::FrameStats>,
        Tally,
        Vec<PoseSample>,
    ),
    SimError,
> {
    let mut sim = Sim::new(scene.clone(), cfg, seed)?;
    let goals = tour_goals(scene, &sim, cfg);
    let camera = cfg.camera.camera();
    let dt_ns = (1e9 / camera_hz(cfg)).round() as u64;
    let timeout_ns = (cfg.sensing.goal_timeout_s * 1e9) as u64;
    let (amp, period) = (
        cfg.sensing.neck_amplitude_deg.to_radians(),
        cfg.sensing.neck_period_s,
    );
    let pitch = cfg.camera.mount.pitch();
    let (mut frame, mut dets) = (boxed_zeroed::<DepthFrame>(), boxed_zeroed::<Detections>());
    let (mut tally, mut per_frame, mut track) = (Tally::default(), Vec::new(), Vec::new());
    let (mut goal_id, mut goal_since) = (0u64, 0u64);
    for _ in 0..frames {
        let state = sim.true_state();
        let done = goal_id == 0
            || state.nav_status == nav_status::REACHED
            || state.nav_status == nav_status::UNREACHABLE
            || sim.time_ns() - goal_since >= timeout_ns;
        if done {
            let pose = goals[goal_id as usize % goals.len()];
            goal_id += 1;
            goal_since = sim.time_ns();
            // A refusal shows in nav_status (UNREACHABLE): the next frame moves on.
            let _ = sim.set_nav_goal(&NavGoal {
                goal_id,
                pose,
                cluster_id: -1,
                ..Default::default()
            });
        }
        let t = sim.time_ns() as f32 * 1e-9;
        sim.set_neck_goal(&NeckGoal {
            yaw: amp * (std::f32::consts::TAU * t / period).sin(),
            pitch,
            ..Default::default()
        });
        sim.step(dt_ns);
        let now = sim.time_ns();
        sim.render(&mut frame, &mut dets, now);
        let truth = sim.true_camera_pose();
        let est = pose_to_affine(&frame.camera_pose);
        let buf = sim.last_render();
        let visible = visible_objects(&buf.instance, scene, &camera, &truth);
        let n = dets.count as usize;
        let mut f = tally.add_frame(
            &visible,
            &dets.items[..n],
            &camera,
            frame.pixels(),
            &buf.depth_true,
        );
        f.t_s = now as f64 * 1e-9;
        f.position_error_m = f64::from((est.translation - truth.translation).length());
        per_frame.push(f);
        track.push(PoseSample {
            t_ns: now,
            est,
            truth,
        });
    }
    Ok((per_frame, tally, track))
}

/// Run the tour of every scene and build the report (pooled figures over all scenes).
/// `progress` is called after each scene with its figures.
pub fn run_sensing(
    spec: &SensingSpec,
    mut progress: impl FnMut(&Figures),
) -> Result<SensingReport, SimError> {
    let cfg = &spec.config;
    let cam = &cfg.camera;
    let mut settings = Settings::new(cam.width, cam.height, [cam.min_range, cam.max_range]);
    settings.camera_hz = camera_hz(cfg);
    settings.frames_per_scene = spec.frames;
    settings.seed = spec.seed;
    let s = &cfg.sensing;
    settings.tour = format!(
        "room centre, then {} goals per background object on a ring {} m outside its footprint \
         circle, facing it (goals in obstacles dropped), repeated; goal left when reached, \
         refused or after {} s; neck yaw = {}° sin(2πt / {} s)",
        s.ring_points, s.ring_clearance, s.goal_timeout_s, s.neck_amplitude_deg, s.neck_period_s
    );
    let delta_ns = (crate::eval::sensing::RPE_DELTA_S * 1e9) as u64;
    let (mut all, mut all_ate, mut all_rpe) = (
        Tally::default(),
        ErrorStats::default(),
        ErrorStats::default(),
    );
    let mut scenes = Vec::new();
    for scene in &spec.scenes {
        let (per_frame, tally, track) = run_tour(scene, cfg, spec.seed, spec.frames)?;
        let (a, r) = (ate(&track), rpe(&track, delta_ns));
        let figures = Figures::new(&scene.name, &tally, &a, &r);
        progress(&figures);
        all.merge(&tally);
        all_ate.merge(&a);
        all_rpe.merge(&r);
        scenes.push(SceneReport { figures, per_frame });
    }
    Ok(SensingReport {
        settings,
        acceptance: spec.config.sensing.bands,
        scenes,
        overall: Figures::new("overall", &all, &all_ate, &all_rpe),
    })
}
