//! `vpsom run --nodes mapper,recorder` without the sim: the run waits for outside publishers of
//! `depth`, `detections` and `robot/state` and says which have none; a driver (here this test,
//! on the same services a C or Python driver opens through the topic contract) publishes
//! frames; the mapper maps from them; with no scene, scoring is skipped and the summary says so.

use nodes::app::topics;
use nodes::config::Config;
use runtime::ports::{PortContext, Stamp};
use shm_types::{DepthFrame, Detection, Detections, RobotState, class_id, mask_mode};
use std::io::Read;
use std::process::{Command, Stdio};
use std::sync::mpsc;
use std::time::Duration;

const FRAMES: u64 = 10;
const W: u32 = 320;
const H: u32 = 240;

/// Deep enough buffers that no subscriber (launcher, mapper, recorder) loses one of the
/// `FRAMES` samples however late it reads.
const OVERLAY: &str = r#"
[ports.topics.depth]
subscriber_buffer = 12
max_subscribers = 4
[ports.topics.detections]
subscriber_buffer = 12
max_subscribers = 4
"#;

/// Waits for a stderr line containing `what` (status lines end in `\r`, reports in `\n`).
fn wait_for(lines: &mpsc::Receiver<String>, log: &mut String, what: &str) {
    loop {
        let line = lines
            .recv_timeout(Duration::from_secs(120))
            .unwrap_or_else(|_| panic!("no {what:?} from vpsom run:\n{log}"));
        log.push_str(&line);
        log.push('\n');
        if line.contains(what) {
            return;
        }
    }
}

/// A 320 × 240 frame from a camera 1 m above the origin looking along +x: a wall at 3 m and,
/// in pixels x 120..200, y 80..160, a surface at 1.5 m.
fn fill_frame(f: &mut DepthFrame) {
    f.width = W;
    f.height = H;
    f.intrinsics.fx = 277.0;
    f.intrinsics.fy = 277.0;
    f.intrinsics.cx = 160.0;
    f.intrinsics.cy = 120.0;
    f.intrinsics.min_range = 0.3;
    f.intrinsics.max_range = 8.0;
    f.camera_pose.translation = [0.0, 0.0, 1.0];
    // world_from_camera for the optical frame (z forward = world x, x right = world -y).
    f.camera_pose.rotation = [-0.5, 0.5, -0.5, 0.5];
    for (i, d) in f.pixels_mut().iter_mut().enumerate() {
        let (u, v) = (i as u32 % W, i as u32 / W);
        *d = if (120..200).contains(&u) && (80..160).contains(&v) {
            1500
        } else {
            3000
        };
    }
}

#[test]
fn mapper_maps_frames_from_outside_and_scoring_is_skipped_without_a_scene() {
    let dir = std::env::temp_dir().join(format!("vpsom-run-external-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let overlay = dir.join("overlay.toml");
    std::fs::write(&overlay, OVERLAY).unwrap();
    let out = dir.join("out");
    let ns = format!("ext{}", std::process::id());
    let mut child = Command::new(env!("CARGO_BIN_EXE_vpsom"))
        .args(["run", "--nodes", "mapper,recorder", "--ns", &ns, "--config"])
        .arg(&overlay)
        .arg("--out")
        .arg(&out)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut stderr = child.stderr.take().unwrap();
    let (tx, lines) = mpsc::channel();
    let reader = std::thread::spawn(move || {
        let (mut buf, mut line) = ([0u8; 4096], Vec::new());
        while let Ok(n) = stderr.read(&mut buf) {
            if n == 0 {
                break;
            }
            for &b in &buf[..n] {
                if b == b'\n' || b == b'\r' {
                    let _ = tx.send(String::from_utf8_lossy(&line).into_owned());
                    line.clear();
                } else {
                    line.push(b);
                }
            }
        }
        let _ = tx.send(String::from_utf8_lossy(&line).into_owned());
    });
    let mut log = String::new();
    wait_for(
        &lines,
        &mut log,
        "no publisher yet on depth, detections, robot/state",
    );

    // The driver.
    let cfg = Config::load_or_default(Some(&overlay)).unwrap().0;
    let ctx = PortContext::with_namespace(&cfg.ports, "driver", &ns).unwrap();
    let state = ctx.publisher::<RobotState>(topics::STATE).unwrap();
    let depth = ctx.publisher::<DepthFrame>(topics::DEPTH).unwrap();
    let dets = ctx.publisher::<Detections>(topics::DETECTIONS).unwrap();
    wait_for(&lines, &mut log, "every topic has a publisher");
    for k in 1..=FRAMES {
        let stamp = Stamp {
            source_ns: k * 100_000_000,
            sim_ns: k * 100_000_000,
        };
        let mut s = state.loan().unwrap();
        s.localization_ok = 1;
        s.send(stamp).unwrap();
        let mut f = depth.loan().unwrap();
        fill_frame(&mut f);
        let seq = f.send(stamp).unwrap().seq;
        let mut d = dets.loan().unwrap();
        d.frame_seq = seq;
        d.width = W;
        d.height = H;
        d.masks = mask_mode::BOXES;
        d.count = 1;
        d.items[0] = Detection {
            class_id: class_id("chair").unwrap(),
            label: 1,
            score: 0.9,
            bbox: [120, 80, 200, 160],
            mask_pixels: 0,
        };
        d.send(stamp).unwrap();
        std::thread::sleep(Duration::from_millis(100));
    }
    // Let the mapper integrate the last frame, then stop the run as a user does.
    std::thread::sleep(Duration::from_secs(1));
    let kill = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(kill.success());
    let output = child.wait_with_output().unwrap();
    reader.join().unwrap();
    log.extend(lines.try_iter().map(|l| l + "\n"));
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(output.status.success(), "{stdout}\n{log}");
    for node in ["recorder", "mapper"] {
        assert!(log.contains(&format!("{node}: exit code 0")), "{log}");
    }
    assert!(!log.contains("sim: exit"), "the sim ran:\n{log}");
    assert!(stdout.contains("skipped: no scene given"), "{stdout}");
    for topic in [topics::DEPTH, topics::DETECTIONS, topics::STATE] {
        assert!(
            stdout.contains(&format!(
                "| samples received on {topic} (external) | {FRAMES} |"
            )),
            "{stdout}"
        );
    }
    // The mapper built the chair from the driver's frames: its front face is 1.5 m ahead.
    let map: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("map.json")).unwrap()).unwrap();
    let objects = map["objects"].as_array().unwrap();
    assert_eq!(objects.len(), 1, "{map}");
    assert_eq!(objects[0]["class"], "chair", "{map}");
    let x = objects[0]["center"][0].as_f64().unwrap();
    assert!((1.45..1.9).contains(&x), "{map}");
    assert!(!out.join("metrics.json").exists());
    let _ = std::fs::remove_dir_all(&dir);
}
