//! The mapper on the real simulator (issue 4): a scripted camera path circles the desk of
//! paper-scene-1 with the neck on the desk centre; every object is mapped with its centre within
//! 5 cm and no duplicate remains. No planner is involved.

use nodes::config::Config;
use nodes::mapper::Mapper;
use nodes::sim::{Scene, Sim};
use shm_types::{
    DepthFrame, Detections, NavGoal, NeckGoal, ObjectMap, RobotState, boxed_zeroed, class_name,
    nav_status,
};

#[test]
fn circling_the_desk_maps_every_object_once_within_5_cm() {
    let cfg = Config::builtin().with_camera(320, 240, 10.0);
    let scene = Scene::builtin("paper-scene-1").unwrap();
    let desk = scene.objects.iter().find(|o| o.background).unwrap().center;
    let mut sim = Sim::new(scene.clone(), &cfg, 7).unwrap();
    let mut mapper = Mapper::new(&cfg.mapper, &cfg.camera.camera()).unwrap();
    let (mut frame, mut dets) = (boxed_zeroed::<DepthFrame>(), boxed_zeroed::<Detections>());
    let mut state = RobotState::default();

    // Twelve waypoints on a circle around the desk, visited in order.
    let (radius, n) = (1.7f32, 12);
    let waypoints: Vec<[f32; 3]> = (0..=n)
        .map(|k| {
            let a = std::f32::consts::TAU * k as f32 / n as f32;
            [
                desk.x + radius * a.cos(),
                desk.y + radius * a.sin(),
                a + std::f32::consts::PI,
            ]
        })
        .collect();
    let (dt, frame_every) = (20_000_000u64, 5u64);
    let mut goal = 0usize;
    let mut reached = 0;
    for step in 0..60_000u64 {
        sim.robot_state(&mut state);
        let current = goal as u64 + 1;
        if state.nav_goal_id != current
            || matches!(
                state.nav_status,
                nav_status::REACHED | nav_status::UNREACHABLE
            )
        {
            if state.nav_goal_id == current {
                reached += usize::from(state.nav_status == nav_status::REACHED);
                goal += 1;
                if goal == waypoints.len() {
                    break;
                }
            }
            let g = NavGoal {
                goal_id: goal as u64 + 1,
                pose: waypoints[goal],
                ..Default::default()
            };
            let _ = sim.set_nav_goal(&g);
        }
        // Neck on the desk centre (from the estimated pose: no ground truth for the robot).
        let [x, y, yaw] = state.base_pose;
        let neck_yaw = (desk.y - y).atan2(desk.x - x) - yaw;
        sim.set_neck_goal(&NeckGoal {
            yaw: neck_yaw,
            pitch: cfg.camera.mount.pitch(),
            ..Default::default()
        });
        if step % frame_every == 0 {
            sim.render(&mut frame, &mut dets, sim.time_ns());
            sim.robot_state(&mut state);
            mapper.integrate(&frame, &dets, &state).unwrap();
        }
        sim.step(dt);
    }
    assert!(
        reached >= 10,
        "only {reached} of {} waypoints reached",
        waypoints.len()
    );

    let mut map = boxed_zeroed::<ObjectMap>();
    mapper.write_map(&mut map, sim.time_ns());
    let est = map.objects();
    let listing: Vec<String> = est
        .iter()
        .map(|o| {
            format!(
                "{} {:.2?} size {:.2?}",
                class_name(o.class_id),
                o.center,
                o.size
            )
        })
        .collect();
    for gt in &scene.objects {
        let same: Vec<_> = est
            .iter()
            .filter(|o| class_name(o.class_id) == gt.class)
            .collect();
        let best = same
            .iter()
            .map(|o| (glam::Vec3::from(o.center) - gt.center).length())
            .fold(f32::INFINITY, f32::min);
        let limit = if gt.background { 0.10 } else { 0.05 };
        assert!(
            best < limit,
            "{} ({}): nearest estimate {best:.3} m away; map:\n{}",
            gt.name,
            gt.class,
            listing.join("\n")
        );
    }
    // No duplicates: no class has more estimates than ground-truth objects.
    for o in est {
        let class = class_name(o.class_id);
        let gt_n = scene.objects.iter().filter(|g| g.class == class).count();
        let est_n = est.iter().filter(|e| e.class_id == o.class_id).count();
        assert!(
            est_n <= gt_n,
            "{est_n} estimates of class {class} for {gt_n} objects:\n{}",
            listing.join("\n")
        );
    }
}
