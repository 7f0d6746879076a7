//! A scripted drive on the real simulator, shared by mapper tests: twelve waypoints on a
//! circle of 1.7 m around a desk, visited in order, the neck on the desk centre (aimed from
//! the estimated pose: no ground truth for the robot). No planner is involved.

use glam::Vec3;
use shm_types::{DepthFrame, Detections, NavGoal, NeckGoal, RobotState, boxed_zeroed, nav_status};
use vpsom::config::Config;
use vpsom::sim::Sim;

/// Drive `sim` round `desk` and call `on_frame` with every rendered frame (every 5th 20 ms
/// step: 10 Hz), the robot state at it and the simulated time (ns). Returns the number of waypoints reached.
pub fn circle_desk(
    sim: &mut Sim,
    cfg: &Config,
    desk: Vec3,
    mut on_frame: impl FnMut(&DepthFrame, &mut Detections, &RobotState, u64),
) -> usize {
    let (mut frame, mut dets) = (boxed_zeroed::<DepthFrame>(), boxed_zeroed::<Detections>());
    let mut state = RobotState::default();
    let (radius, n) = (1.7f32, 12);
    let waypoints: Vec<[f32; 3]> = (0..=n)
        .map(|k| {
            let a = std::f32::consts::TAU * k as f32 / n as f32;
            let (x, y) = (desk.x + radius * a.cos(), desk.y + radius * a.sin());
            [x, y, a + std::f32::consts::PI]
        })
        .collect();
    let (dt, frame_every) = (20_000_000u64, 5u64);
    let (mut goal, mut reached) = (0usize, 0usize);
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
        let [x, y, yaw] = state.base_pose;
        sim.set_neck_goal(&NeckGoal {
            yaw: (desk.y - y).atan2(desk.x - x) - yaw,
            pitch: cfg.camera.mount.pitch(),
            ..Default::default()
        });
        if step % frame_every == 0 {
            sim.render(&mut frame, &mut dets, sim.time_ns());
            sim.robot_state(&mut state);
            on_frame(&frame, &mut dets, &state, sim.time_ns());
        }
        sim.step(dt);
    }
    reached
}
