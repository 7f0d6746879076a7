//! Paper scene 1's desk under the default sensing, end to end: the simulator's box detector,
//! Kinect-v2 depth artefacts and SLAM pose estimate feed the mapper on a 60 s tour round the
//! desk.
//! - Regression (issue #14): the two books, 5 cm apart, grew into each other (box jitter, NMS
//!   unions) and were merged into one 0.31 × 0.53 m object; with `co_detection` they stay two.
//! - Pose error between views smears the merged clouds; with `view_extents` the published
//!   sizes match the truth much better (aligned IoU, as the bench scores it).

use glam::Vec3;
use shm_types::{
    DepthFrame, Detections, NavGoal, NeckGoal, RobotState, boxed_zeroed, class_id, class_name,
    nav_status,
};
use std::f32::consts::PI;
use vpsom::config::Config;
use vpsom::eval::iou::aligned_iou;
use vpsom::mapper::Mapper;
use vpsom::sim::{Scene, Sim};

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

/// Mean aligned IoU (the bench's size-only IoU) of the published sizes of the desk's objects
/// other than the books, each against the nearest mapped object of its class within 0.1 m.
fn published_iou(m: &Mapper) -> f64 {
    let scene = Scene::builtin("paper-scene-1").unwrap();
    let mut ious = Vec::new();
    for g in scene
        .objects
        .iter()
        .filter(|g| !g.background && g.class != "book")
    {
        let best = m
            .objects()
            .iter()
            .filter(|o| o.class_id == g.class_id)
            .filter(|o| o.cuboid.center.distance(g.center) < 0.1)
            .map(|o| {
                let s = m.published_size(o);
                aligned_iou(g.size.to_array(), g.yaw, s.to_array(), o.cuboid.yaw)
            })
            .fold(0.0, f64::max);
        println!("{}: {best:.2}", g.name);
        ious.push(best);
    }
    ious.iter().sum::<f64>() / ious.len() as f64
}

#[test]
#[ignore = "under the sourced sensing of issue #33 book B is not mapped on this tour (co_detection on or off; also without the duplicates and confident false positives): mapper work of issue #34"]
fn two_books_stay_two_and_published_sizes_resist_pose_error() {
    let verbose = std::env::var("VERBOSE").is_ok();
    let on = tour(&Config::builtin(), 1, 60.0, verbose);
    let mut cfg = Config::builtin();
    cfg.mapper.extensions.co_detection = false;
    cfg.mapper.extensions.view_extents = false;
    let off = tour(&cfg, 1, 60.0, verbose);
    let (iou_on, iou_off) = (published_iou(&on), published_iou(&off));
    println!(
        "books found: co_detection on {:?}, off {:?}; IoU view_extents on {iou_on:.3}, off {iou_off:.3}",
        books_found(&on),
        books_found(&off)
    );
    assert_eq!(books_found(&on), (true, true));
    // Without the switch the bug shows: the books are one object between them.
    assert_ne!(books_found(&off), (true, true));
    assert!(
        iou_on > iou_off + 0.1,
        "IoU on {iou_on:.3}, off {iou_off:.3}"
    );
}
