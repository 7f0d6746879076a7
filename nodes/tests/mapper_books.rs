//! The two books of paper scene 1 (5 cm apart on the desk) under the default sensing, end to
//! end: the simulator's box detector, Kinect-v2 depth artefacts and SLAM pose estimate feed the
//! mapper on a tour round the desk; both books must come out as separate objects.

use glam::Vec3;
use nodes::config::Config;
use nodes::mapper::Mapper;
use nodes::sim::{Scene, Sim};
use shm_types::{
    DepthFrame, Detections, NavGoal, NeckGoal, RobotState, boxed_zeroed, class_id, class_name,
    nav_status,
};
use std::f32::consts::PI;

const FRAME_NS: u64 = 100_000_000;
/// Paper scene 1: the desk's centre (x, y).
const DESK: [f32; 2] = [-1.937, -0.061];
const BOOK_A: Vec3 = Vec3::new(-1.976, 0.411, 0.739);
const BOOK_B: Vec3 = Vec3::new(-1.979, 0.140, 0.7385);

/// Drive round the desk looking at it for `seconds`; the mapper integrates every frame.
fn tour(cfg: &Config, seed: u64, seconds: f32, verbose: bool) -> Mapper {
    let mut sim = Sim::new(Scene::builtin("paper-scene-1").unwrap(), cfg, seed).unwrap();
    let mut mapper = Mapper::new(&cfg.mapper, &cfg.camera.camera()).unwrap();
    let (mut f, mut d) = (boxed_zeroed::<DepthFrame>(), boxed_zeroed::<Detections>());
    let mut s = RobotState::default();
    let goals: Vec<[f32; 3]> = (1..=8)
        .map(|k| {
            let a = k as f32 * PI / 4.0;
            [DESK[0] + 1.5 * a.cos(), DESK[1] + 1.5 * a.sin(), a + PI]
        })
        .collect();
    let book = class_id("book").unwrap();
    let mut next = 0;
    let mut last_books = String::new();
    for k in 0..(seconds * 10.0) as usize {
        sim.robot_state(&mut s);
        if s.nav_status != nav_status::MOVING {
            let g = goals[next % goals.len()];
            next += 1;
            let _ = sim.set_nav_goal(&NavGoal {
                goal_id: next as u64,
                pose: g,
                ..Default::default()
            });
        }
        let [x, y, yaw] = s.base_pose;
        // Look at the books' side of the desk.
        sim.set_neck_goal(&NeckGoal {
            yaw: (0.27 - y).atan2(-1.97 - x) - yaw,
            ..Default::default()
        });
        sim.step(FRAME_NS);
        sim.render(&mut f, &mut d, sim.time_ns());
        let st = mapper.integrate(&f, &d, &s).unwrap();
        if verbose {
            let books: Vec<String> = mapper
                .objects()
                .iter()
                .filter(|o| o.class_id == book)
                .map(|o| {
                    format!(
                        "#{} c({:.2},{:.2}) s({:.2},{:.2}) n{}",
                        o.id,
                        o.cuboid.center.x,
                        o.cuboid.center.y,
                        o.cuboid.size.x,
                        o.cuboid.size.y,
                        o.observations
                    )
                })
                .collect();
            let dets: Vec<String> = d
                .detections()
                .iter()
                .filter(|x| x.class_id == book || class_name(x.class_id) == "keyboard")
                .map(|x| format!("{}{:?}", class_name(x.class_id), x.bbox))
                .collect();
            let line = books.join(" | ");
            if line != last_books || st.merged > 0 {
                println!(
                    "frame {k}: merged {} created {} dets {:?}\n    {line}",
                    st.merged, st.created, dets
                );
                last_books = line;
            }
        }
    }
    mapper
}

fn books_found(m: &Mapper) -> (bool, bool) {
    let book = class_id("book").unwrap();
    let near = |p: Vec3| {
        m.objects()
            .iter()
            .any(|o| o.class_id == book && o.cuboid.center.truncate().distance(p.truncate()) < 0.1)
    };
    (near(BOOK_A), near(BOOK_B))
}

#[test]
#[ignore = "diagnostic"]
fn books_diag() {
    let cfg = Config::builtin();
    let seed: u64 = std::env::var("SEED").ok().and_then(|s| s.parse().ok()).unwrap_or(1);
    let m = tour(&cfg, seed, 60.0, true);
    println!("found {:?}", books_found(&m));
}
