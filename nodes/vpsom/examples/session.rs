//! One lockstep session, printed: progress, the summary and the first lines of its metrics;
//! outputs go to `/tmp/sess-<scene>-<planner>-<seed>/`.
//!
//! `cargo run --release -p vpsom --example session -- [SCENE [PLANNER [SEED [WIDTH [HZ [MAX_SIM_S]]]]]]`
//! (defaults: paper-scene-1 vpsom 1 320 10 600). A smoke run of a few seconds (CI):
//! `cargo run --release -p vpsom --example session -- paper-scene-1 vpsom 1 160 5 20`.

use vpsom::config::Config;
use vpsom::lockstep::{self, SessionSpec};
use vpsom::sim::Scene;
fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let scene = args.get(1).map_or("paper-scene-1", |s| s.as_str());
    let label = args.get(2).map_or("vpsom", |s| s.as_str());
    let seed: u64 = args.get(3).map_or(1, |s| s.parse().unwrap());
    let w: u32 = args.get(4).map_or(320, |s| s.parse().unwrap());
    let hz: f64 = args.get(5).map_or(10.0, |s| s.parse().unwrap());
    let max_sim_s: f64 = args.get(6).map_or(600.0, |s| s.parse().unwrap());
    let base = Config::builtin().with_camera(w, w * 3 / 4, hz);
    let config = lockstep::config_for(&base, label)?;
    let spec = SessionSpec {
        scene: Scene::builtin_or_load(scene)?,
        config,
        seed,
        label: label.into(),
        max_sim_s,
        record: None,
    };
    let t = std::time::Instant::now();
    let r = lockstep::run_session(&spec, |p| {
        if (p.sim_s as u64).is_multiple_of(20) {
            eprintln!("{p:?}")
        }
    })?;
    eprintln!(
        "wall {:.1}s frames {} {}",
        t.elapsed().as_secs_f64(),
        r.frames,
        r.summary
    );
    println!(
        "{}",
        serde_json::to_string_pretty(&r.metrics)?
            .lines()
            .take(18)
            .collect::<Vec<_>>()
            .join("\n")
    );
    lockstep::write_outputs(
        &spec,
        &r,
        std::path::Path::new(&format!("/tmp/sess-{scene}-{label}-{seed}")),
    )?;
    Ok(())
}
