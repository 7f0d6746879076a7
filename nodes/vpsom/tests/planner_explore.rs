//! Exploration and termination on rooms the start pose does not show whole (issue #15, item 1):
//! a second table out of the start view is found and mapped by VP-SOM and by coverage, and an
//! object no reachable view sees from behind ends the session with a "given up" entry, not at the
//! time limit. Ideal sensing at 320 × 240 keeps the sessions deterministic and quick.

use std::path::Path;
use vpsom::config::Config;
use vpsom::lockstep::{self, SessionResult, SessionSpec};
use vpsom::planner::PlannerStatus;
use vpsom::sim::Scene;

/// Ideal sensing without the approach rule (`[planner.bootstrap] approach_m`): these tests pin
/// the exploration and give-up rules on their own. With the rule, the extra visit it makes
/// changes both sessions: on two-tables a spurious fifth estimate appears and is given up (P 0.8,
/// "objects given up: 1"); on corner-box the backpack completes and is not given up.
fn ideal() -> Config {
    let mut c = Config::ideal_sensing();
    c.planner.bootstrap.approach_m = f32::INFINITY;
    c
}

fn session(scene: &str, label: &str) -> (SessionSpec, SessionResult) {
    session_with(scene, label, ideal())
}

fn session_with(scene: &str, label: &str, base: Config) -> (SessionSpec, SessionResult) {
    let cfg = base.with_camera(320, 240, base.bench.camera_hz);
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("tests/scenes/{scene}.toml"));
    let spec = SessionSpec {
        scene: Scene::load(&path).unwrap(),
        config: lockstep::config_for(&cfg, label).unwrap(),
        seed: 1,
        label: label.into(),
        max_sim_s: base.bench.max_sim_s,
        record: None,
    };
    let r = lockstep::run_session(&spec, |_| {}).unwrap();
    (spec, r)
}

/// Every ground-truth foreground object of both tables was mapped (matched).
fn all_mapped(r: &SessionResult) -> bool {
    r.metrics.recall == 1.0 && r.metrics.objects_gt == 4
}

#[test]
fn vpsom_finds_the_table_out_of_the_start_view_and_terminates() {
    let (spec, r) = session("two-tables", "vpsom");
    let m = &r.metrics;
    assert_eq!(r.summary.status, PlannerStatus::Terminated, "{}", r.summary);
    assert!(m.terminated && m.time_s < spec.max_sim_s, "{m:?}");
    assert_eq!(r.summary.clusters, 2, "{}", r.summary);
    assert!(all_mapped(&r), "{m:?}");
    assert_eq!(m.explored, Some(true));
    assert_eq!(m.termination_reason, "complete and explored", "{m:?}");
    assert!(m.objects_given_up.is_empty(), "{:?}", m.objects_given_up);
}

#[test]
fn coverage_explores_too_and_circles_both_tables() {
    let (spec, r) = session("two-tables", "coverage");
    let m = &r.metrics;
    assert_eq!(r.summary.status, PlannerStatus::Terminated, "{}", r.summary);
    assert!(m.terminated && m.time_s < spec.max_sim_s, "{m:?}");
    assert_eq!(r.summary.clusters_done, 2, "{}", r.summary);
    assert!(all_mapped(&r), "{m:?}");
    assert_eq!(m.explored, Some(true));
}

#[test]
fn an_object_in_a_corner_is_given_up_not_timed_out() {
    // Every map object trusted (planner.min_observations = 0): with the default (3), a fragment
    // seen in one or two frames no longer pulls the GBV target centroid off the table, the
    // views aim better and the backpack's SOPM completes (H_sopm < ε_sopm in 10 goals, path 14.5 m
    // against 18.2 m), so the stall and out-of-views rules this test is about are not reached.
    let mut base = ideal();
    base.planner.min_observations = 0;
    let (spec, r) = session_with("corner-box", "vpsom", base);
    let m = &r.metrics;
    assert_eq!(r.summary.status, PlannerStatus::Terminated, "{}", r.summary);
    assert!(m.terminated && m.time_s < spec.max_sim_s, "{m:?}");
    assert!(
        m.termination_reason.starts_with("objects given up"),
        "{}",
        m.termination_reason
    );
    let backpack = m
        .objects_given_up
        .iter()
        .find(|g| g.label == "backpack")
        .unwrap_or_else(|| panic!("backpack not given up: {:?}", m.objects_given_up));
    assert!(backpack.h_sopm >= 0.42, "{backpack:?}");
    // The cup, seen from every side, is mapped correctly; the backpack is in the map (with its
    // hidden half unmeasured, its cuboid need not pass the 0.1 m centre test).
    let outcome = |name: &str| m.per_object.iter().find(|o| o.name == name).unwrap();
    assert!(outcome("cup").correct, "{:?}", m.per_object);
    assert!(outcome("backpack").estimate.is_some(), "{:?}", m.per_object);
    let json = serde_json::to_value(m).unwrap();
    assert!(json["objects_given_up"][0]["h_sopm"].is_number(), "{json}");
}
