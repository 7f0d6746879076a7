//! Depth artefacts (`vpsom::sim::DepthArtefacts`) through the public API: thread-count
//! independence, the built-in scenes' materials, and the `[sim]` keys' validation.

use vpsom::config::Config;
use vpsom::sim::{DepthArtefacts, DepthCamera, Material, RenderBuffers, Scene, SimConfig, World};

/// The built-in config with a `w × h` camera, no σ(z) noise and no random dropout.
fn config(w: u32, h: u32) -> Config {
    let mut cfg = Config::builtin();
    (cfg.camera.width, cfg.camera.height) = (w, h);
    (cfg.sim.noise_a, cfg.sim.noise_b, cfg.sim.dropout) = (0.0, 0.0, 0.0);
    cfg
}

#[test]
fn frames_do_not_depend_on_threads_and_defaults_are_active() {
    let cfg = Config::builtin();
    let art = DepthArtefacts::new(
        &Scene::builtin("paper-scene-1").unwrap(),
        &cfg.camera,
        &cfg.sim,
        9,
    );
    assert!(art.is_active());
    let s = Scene::builtin("paper-scene-1").unwrap();
    let glass: Vec<&str> = s
        .objects
        .iter()
        .filter(|o| o.material == Material::Glass)
        .map(|o| o.name.as_str())
        .collect();
    assert_eq!(glass, ["bottle_tall", "bottle_short"]);
    let cfg = config(160, 120);
    let world = World::new(&s);
    let cam = DepthCamera::new(&cfg.camera, &cfg.sim, 3);
    let art = DepthArtefacts::new(&s, &cfg.camera, &cfg.sim, 4);
    let pose = cfg
        .camera
        .mount
        .camera_pose(s.robot_start, 0.0, cfg.camera.mount.pitch());
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let mut depth = vec![0u16; 160 * 120];
        let mut buf = RenderBuffers::new();
        pool.install(|| {
            cam.render(&world, &pose, 2, &mut depth, &mut buf);
            art.apply(&world, &pose, 2, &buf, &mut depth);
        });
        depth
    };
    let one = run(1);
    assert_eq!(one, run(3));
    let mut plain = vec![0u16; 160 * 120];
    cam.render(&world, &pose, 2, &mut plain, &mut RenderBuffers::new());
    assert_ne!(one, plain, "the default scene view has artefacts");
}

#[test]
fn rates_that_sum_above_one_are_refused_naming_the_key() {
    let c = settings::Checker::new("x.toml");
    let mut sim = SimConfig::default();
    sim.validate(&c).unwrap();
    (sim.edge_mixed, sim.edge_invalid) = (0.6, 0.5);
    let e = sim.validate(&c).unwrap_err().to_string();
    assert!(e.contains("sim.edge_invalid"), "{e}");
    sim = SimConfig::default();
    sim.glass_through = 1.5;
    let e = sim.validate(&c).unwrap_err().to_string();
    assert!(e.contains("sim.glass_through"), "{e}");
}
