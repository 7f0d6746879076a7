//! The baselines trace the views they choose like VP-SOM traces its GBVs: every chassis goal
//! comes with a decision whose chosen candidate carries the F(v) terms (H_IoU, objects in view)
//! of that view, computed by the same code (`evaluate_view`), so the planner's own H_IoU
//! (`planner_h_iou` in metrics.json; the non-occlusion metric itself is measured on ground
//! truth, `eval::occlusion`) compares the three planners on the same footing.

use glam::Vec3;
use shm_types::{
    NavGoal, ObjectMap, OccupancyGrid, PlannerDecision, RobotState, boxed_zeroed, decision_kind,
    grid_cell, nav_status,
};
use vpsom::config::CameraConfig;
use vpsom::eval::{MatchParams, RunInfo, SessionLog};
use vpsom::planner::clusters::{cluster_info, unfinished_centroid};
use vpsom::planner::synth::add_object;
use vpsom::planner::{
    EvalParams, PlannerConfig, PlannerInputs, PlannerKind, Step, Target, ViewPlanner, Weights,
    evaluate_view, make_planner,
};

/// A table (cluster 1) at x ≈ 2.5 m with three cups, two of them one behind the other as seen
/// from the west, so views from there have H_IoU < 1.
fn table_map() -> Box<ObjectMap> {
    let mut m = boxed_zeroed::<ObjectMap>();
    m.eps_sopm = 0.42;
    m.header.seq = 17;
    let west = [[0.0, 1.0]];
    add_object(
        &mut m,
        1,
        60,
        true,
        1,
        [2.6, 1.0, 0.375],
        [0.8, 1.2, 0.75],
        &west,
        1,
    );
    for (id, c) in [
        (2, [2.4, 1.0, 0.8]),
        (3, [2.8, 1.02, 0.8]),
        (4, [2.5, 1.4, 0.8]),
    ] {
        add_object(&mut m, id, 41, false, 1, c, [0.12, 0.12, 0.1], &west, 2);
    }
    m
}

/// 4 m × 2 m exploration grid at 0.1 m from x = 0: the western quarter known free, the rest
/// unknown, so the frontier is the column at x ≈ 0.95 m.
fn explore_grid() -> Box<OccupancyGrid> {
    let mut g = boxed_zeroed::<OccupancyGrid>();
    g.resolution = 0.1;
    g.width = 40;
    g.height = 20;
    for y in 0..20 {
        for x in 0..40 {
            g.cells[y * 40 + x] = if x < 10 {
                grid_cell::FREE
            } else {
                grid_cell::UNKNOWN
            };
        }
    }
    g
}

/// Run `planner` until it publishes a chassis goal (jobs inline); the goal and its decision.
fn goal_and_decision(
    planner: &mut dyn ViewPlanner,
    map: &ObjectMap,
    state: &RobotState,
    explore: &OccupancyGrid,
) -> (NavGoal, Box<PlannerDecision>) {
    let nav = boxed_zeroed::<OccupancyGrid>();
    let inputs = PlannerInputs {
        map,
        state,
        nav: &nav,
        explore,
    };
    let mut step = planner.next_goal(&inputs, 0);
    loop {
        step = match step {
            Step::Compute(job) => planner.job_done(job.run(), 0),
            Step::Goal(g) => {
                let d = planner.take_decision().expect("a decision with every goal");
                assert!(planner.take_decision().is_none(), "taken once");
                return (g, d);
            }
            other => panic!("expected a goal, got {other:?}"),
        }
    }
}

fn chosen(d: &PlannerDecision) -> shm_types::Candidate {
    assert_eq!(d.kind, decision_kind::GBV);
    let c: Vec<_> = d.candidates().iter().filter(|c| c.chosen == 1).collect();
    assert_eq!(c.len(), 1, "one chosen candidate");
    *c[0]
}

fn gbv_weights(cfg: &PlannerConfig) -> Weights {
    Weights {
        alpha: cfg.gbv.alpha,
        beta: cfg.gbv.beta,
    }
}

#[test]
fn frontier_goals_carry_the_h_iou_of_their_view() {
    let cfg = PlannerConfig {
        kind: PlannerKind::Frontier,
        ..Default::default()
    };
    let camera = CameraConfig::default();
    let mut planner = make_planner(&cfg, &camera);
    let map = table_map();
    let state = RobotState {
        base_pose: [0.2, 1.0, 0.0],
        ..Default::default()
    };
    let (g, d) = goal_and_decision(planner.as_mut(), &map, &state, &explore_grid());
    let c = chosen(&d);
    // The neck stays forward: the view is the goal pose's.
    let p = EvalParams::new(&cfg, &camera);
    let pose = p.mount.camera_pose(g.pose, 0.0, p.mount.pitch());
    let expect = evaluate_view(&map, &pose, None, gbv_weights(&cfg), &p);
    assert!(c.objects_in_view >= 2, "{c:?}");
    assert!(c.h_iou.is_finite() && c.h_iou < 1.0, "{c:?}");
    assert_eq!(c.h_iou, expect.h_iou);
    assert_eq!(c.objects_in_view, expect.objects_in_view);
    assert_eq!(c.position, expect.position);
    assert_eq!((d.map_seq, d.cluster_id), (17, -1));

    // The planner's own H_IoU of its views has a value for the frontier baseline too.
    let mut log = SessionLog::new();
    log.observe_decision(&d);
    let run = RunInfo {
        scene: "t".into(),
        planner: "frontier".into(),
        seed: 1,
    };
    let m = log.metrics(&run, &[], &[], &MatchParams::default());
    assert_eq!(m.planner_h_iou, Some(f64::from(c.h_iou)));
}

#[test]
fn coverage_waypoints_carry_the_h_iou_of_their_view() {
    let cfg = PlannerConfig {
        kind: PlannerKind::Coverage,
        ..Default::default()
    };
    let camera = CameraConfig::default();
    let mut planner = make_planner(&cfg, &camera);
    let map = table_map();
    let mut state = RobotState {
        base_pose: [0.5, 1.0, 0.0],
        ..Default::default()
    };
    let p = EvalParams::new(&cfg, &camera);
    let info = cluster_info(&map, 1, cfg.eps_sopm).unwrap();
    let target = Target {
        cluster_id: 1,
        centroid: unfinished_centroid(&map, &info, cfg.eps_sopm),
    };
    let mut seen = 0;
    for _ in 0..3 {
        let (g, d) = goal_and_decision(planner.as_mut(), &map, &state, &boxed_zeroed());
        let c = chosen(&d);
        // The camera is on the cluster centre at every waypoint.
        let neck = p.mount.neck_yaw_toward(g.pose, info.center);
        let pose = p.mount.camera_pose(g.pose, neck, p.mount.pitch());
        let expect = evaluate_view(&map, &pose, Some(&target), gbv_weights(&cfg), &p);
        assert!(c.h_iou.is_finite(), "{c:?}");
        assert_eq!(c.h_iou, expect.h_iou);
        assert_eq!(c.objects_in_view, expect.objects_in_view);
        assert_eq!(c.value, expect.value);
        assert_eq!((d.cluster_id, d.map_seq), (1, 17));
        let axis = Vec3::from(pose.matrix3.z_axis);
        let to_centre = (info.center - Vec3::from(pose.translation)).normalize();
        assert!(
            axis.truncate()
                .normalize()
                .dot(to_centre.truncate().normalize())
                > 0.999,
            "aimed at the centre"
        );
        seen += usize::from(c.objects_in_view > 0);
        state.base_pose = g.pose;
        state.nav_goal_id = g.goal_id;
        state.nav_status = nav_status::REACHED;
    }
    assert!(seen >= 2, "the cups are in view from the circle");
}
