//! Regression tests for paper-scene-2, where VP-SOM used to give up the second desk (it stands
//! 0.94 m from the top wall and 1.09 m from the first desk) and end `NoCandidates` in every
//! seed: the planner inflated the simulator's navigation map, which is already inflated by the
//! robot radius, a second time. That closed the passages north, south and west of the desk, left
//! only the east end of its GBV ring reachable, and those views all faced the sides already seen.

use glam::Vec2;
use shm_types::{ObjectMap, OccupancyGrid, boxed_zeroed};
use vpsom::config::{CameraConfig, Config};
use vpsom::lockstep::{self, SessionSpec};
use vpsom::planner::clusters::cluster_info;
use vpsom::planner::gbv::{GbvJob, GbvParams, ring_poses};
use vpsom::planner::reach::NavParams;
use vpsom::planner::synth::add_object;
use vpsom::planner::{EvalParams, PlannerConfig, PlannerStatus, Weights};
use vpsom::sim::{Scene, Sim};

/// Desk 2 of paper-scene-2 (cluster 12) with a book seen only from the east, so its unobserved
/// side faces west.
fn desk_2_map() -> Box<ObjectMap> {
    let mut m = boxed_zeroed::<ObjectMap>();
    m.eps_sopm = 0.42;
    let east = [[-0.8, 2.2]];
    add_object(
        &mut m,
        12,
        60,
        true,
        12,
        [-2.04, 2.195, 0.4555],
        [1.097, 0.729, 0.911],
        &east,
        1,
    );
    add_object(
        &mut m,
        13,
        73,
        false,
        12,
        [-2.05, 2.30, 0.93],
        [0.24, 0.17, 0.035],
        &east,
        2,
    );
    m
}

#[test]
fn gbv_reaches_around_the_desk_by_the_wall_on_the_simulators_map() {
    let cfg = Config::ideal_sensing();
    let scene = Scene::builtin("paper-scene-2").unwrap();
    let sim = Sim::new(scene, &cfg, 1).unwrap();
    let mut nav = boxed_zeroed::<OccupancyGrid>();
    sim.nav_grid(&mut nav);
    let planner = PlannerConfig::default();
    let map = desk_2_map();
    let info = cluster_info(&map, 12, planner.eps_sopm).unwrap();
    // Where the robot stood when the old planner gave the desk up: east of it, by the wall.
    let base = [-0.85, 2.7, -2.7];
    let params = GbvParams {
        eval: EvalParams::new(&planner, &CameraConfig::default()),
        weights: Weights {
            alpha: planner.gbv.alpha,
            beta: planner.gbv.beta,
        },
        candidates: planner.gbv.candidates,
        safe_distance: planner.gbv.safe_distance,
        nav: NavParams::new(&planner),
        revisit_radius: planner.gbv.revisit_radius,
        sectors: planner.bootstrap.sectors,
        neck: vpsom::planner::gbv::GbvNeck::new(&planner),
        fa: vpsom::planner::evaluate::FaFilter::new(&planner),
        distance_weight: planner.gbv.distance_weight,
    };
    // The ring as the planner reads the map, against what the simulated base accepts.
    let reach = params.nav.flooded(&nav, [base[0], base[1]]);
    let ring = ring_poses(
        &info,
        params.candidates,
        params.safe_distance,
        [base[0], base[1]],
    );
    let from = Vec2::new(base[0], base[1]);
    let mut reachable = 0;
    for p in &ring {
        if reach.reachable([p[0], p[1]]) {
            reachable += 1;
            assert!(
                sim.grid().plan(from, Vec2::new(p[0], p[1])).is_ok(),
                "the planner deems {p:?} reachable but the base refuses it"
            );
        }
    }
    // Twice inflated, 8 of the 36 ring poses were left, all at the east end.
    assert!(
        reachable >= 18,
        "only {reachable} of 36 ring poses reachable"
    );
    let r = GbvJob {
        map,
        nav,
        base,
        clusters: vec![info],
        visited: Vec::new(),
        params,
    }
    .run();
    assert_eq!(r.decision.evaluated, reachable);
    let best = r.best.expect("a reachable candidate");
    assert!(
        best.pose[0] < -2.6 && best.score > 0.0,
        "the view of the unobserved west side wins: {best:?}"
    );
}

#[test]
fn vpsom_terminates_on_paper_scene_2() {
    let base = Config::ideal_sensing();
    let b = base.bench;
    let cfg = base.with_camera(b.camera_width, b.camera_height, b.camera_hz);
    let spec = SessionSpec {
        scene: Scene::builtin("paper-scene-2").unwrap(),
        config: lockstep::config_for(&cfg, "vpsom").unwrap(),
        seed: 4,
        label: "vpsom".into(),
        max_sim_s: b.max_sim_s,
        record: None,
    };
    let r = lockstep::run_session(&spec, |_| {}).unwrap();
    // Section 3.4: both desks' foreground objects complete.
    assert_eq!(r.summary.status, PlannerStatus::Terminated, "{}", r.summary);
    assert_eq!(r.summary.clusters, 2, "{}", r.summary);
    assert_eq!(r.summary.clusters_given_up, 0, "{}", r.summary);
    assert_eq!(r.metrics.recall, 1.0, "{:?}", r.metrics);
}
