//! Pins the default sensing: `vpsom sensing` on the three paper scenes (the built-in
//! configuration as shipped: 640×480, the `[sensing]` tour) lands in every band of
//! `[sensing.bands]`. A change that softens a sensing rate (or hardens it past its source)
//! moves a figure out of its band and fails here; the band and its source sit beside each other
//! in `config/default.toml`.

use vpsom::config::Config;
use vpsom::sensing::{SensingSpec, run_sensing};
use vpsom::sim::{BUILTIN_SCENES, Scene};

#[test]
fn the_default_sensing_lands_in_its_bands_on_the_paper_scenes() {
    let config = Config::builtin();
    let spec = SensingSpec {
        scenes: BUILTIN_SCENES
            .iter()
            .map(|(n, _)| Scene::builtin(n).unwrap())
            .collect(),
        frames: config.sensing.frames,
        seed: 1,
        config,
    };
    let report = run_sensing(&spec, |_| {}).unwrap();
    println!("{}", report.table());
    let failures = spec.config.sensing.bands.failures(&report.overall);
    assert!(failures.is_empty(), "outside [sensing.bands]: {failures:?}");
}

#[test]
fn a_figure_outside_its_band_is_reported_by_name() {
    let config = Config::builtin();
    let spec = SensingSpec {
        scenes: vec![Scene::builtin("paper-scene-1").unwrap()],
        frames: 20,
        seed: 1,
        config,
    };
    let report = run_sensing(&spec, |_| {}).unwrap();
    let named = |b: &vpsom::eval::sensing::Acceptance| {
        b.failures(&report.overall)
            .iter()
            .any(|f| f.starts_with("fp_confident_per_frame"))
    };
    let mut bands = spec.config.sensing.bands;
    bands.fp_confident_per_frame.min = 0.0;
    assert!(!named(&bands));
    bands.fp_confident_per_frame.min = 1e9;
    assert!(named(&bands));
}
