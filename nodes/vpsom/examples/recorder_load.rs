//! Cost of recording everything at the default rates, in real time:
//! depth 640×480 at 30 Hz (full resolution: the default `replay` profile), object map (40 objects) at
//! 10 Hz, estimated and true state at 50 Hz, LBV decisions (64 candidates) at 20 Hz, GBV at
//! 0.5 Hz, deadline events at 20 Hz, neck goals at 20 Hz, a latency summary and a log line at 1 Hz.
//!
//! ```text
//! cargo run --release -p vpsom --example recorder_load -- [--seconds S] [--out OUT.mcap]
//! ```
//! Records for `S` seconds (default 10) into `OUT.mcap` (default `vpsom-recorder-load.mcap` in
//! the temporary directory). Prints the writer thread's CPU time as a share of one core, the
//! producer-side cost per call, drops, and the file rate.

use runtime::recorder::{
    LatencySummary, LogLevel, NodeLatency, Recorder, RecorderConfig, RecorderSetup,
};
use shm_types::*;
use std::time::{Duration, Instant};
use vpsom::recording::{MountGeometry, SceneConverter};

fn header(seq: u64, t: Duration) -> Header {
    Header {
        seq,
        stamp_ns: t.as_nanos() as u64,
        sim_time_ns: t.as_nanos() as u64,
    }
}

#[path = "../../../runtime/examples/common/mod.rs"]
mod common;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let usage = "recorder_load [--seconds S] [--out OUT.mcap]";
    let Some(args) = common::parse(usage, 10.0, true)? else {
        return Ok(());
    };
    let secs = args.seconds;
    let out = args.out.unwrap_or_else(|| {
        std::env::temp_dir()
            .join("vpsom-recorder-load.mcap")
            .display()
            .to_string()
    });
    let cfg = RecorderConfig::default();
    // The app's converter: the cost measured is the real conversion's.
    let conv = SceneConverter::new(&cfg, MountGeometry::default(), Vec::new());
    let rec = Recorder::create(out.as_ref(), &cfg, RecorderSetup::new(conv))?;
    let h = rec.handle();

    // Inputs shaped like the real ones: smooth depth with noise, a full map, full decisions.
    let mut depth = boxed_zeroed::<DepthFrame>();
    depth.width = 640;
    depth.height = 480;
    let mut map = boxed_zeroed::<ObjectMap>();
    map.count = 40;
    for (k, o) in map.objects[..40].iter_mut().enumerate() {
        o.id = k as u32;
        o.class_id = (k % 80) as u16;
        o.center = [k as f32 * 0.1, 1.0, 0.5];
        o.size = [0.3, 0.3, 0.3];
        o.h_sopm = 0.5;
    }
    let mut dec = boxed_zeroed::<PlannerDecision>();
    dec.count = 64;
    for (k, c) in dec.candidates.iter_mut().enumerate() {
        c.position = [k as f32 * 0.05, 0.0, 1.4];
        c.yaw = k as f32 * 0.1;
        c.value = k as f32;
        c.chosen = u8::from(k == 7);
    }
    let mut rng: u64 = 0x9E37_79B9_7F4A_7C15;
    let start = Instant::now();
    let mut producer = [Duration::ZERO; 3];
    let mut calls = [0u64; 3];
    let tick = Duration::from_millis(1);
    let mut n = 0u64;
    let (mut next_depth, mut next_state, mut next_map, mut next_lbv, mut next_sec) =
        (0u64, 0u64, 0u64, 0u64, 0u64);
    while start.elapsed().as_secs_f64() < secs {
        n += 1;
        let t = start.elapsed();
        let ms = t.as_millis() as u64;
        if ms >= next_depth {
            next_depth = ms + 33;
            for (i, p) in depth.depth_mm.iter_mut().enumerate() {
                rng ^= rng << 13;
                rng ^= rng >> 7;
                rng ^= rng << 17;
                *p = 1500 + ((i % 640) as u16 * 3) + (rng % 8) as u16;
            }
            depth.header = header(n, t);
            let c = Instant::now();
            h.record_depth(&depth);
            producer[0] += c.elapsed();
            calls[0] += 1;
        }
        if ms >= next_state {
            next_state = ms + 20;
            let s = RobotState {
                header: header(n, t),
                base_pose: [t.as_secs_f32() * 0.1, 0.0, t.as_secs_f32() * 0.05],
                neck_yaw: t.as_secs_f32().sin(),
                neck_pitch: 0.49,
                ..Default::default()
            };
            let c = Instant::now();
            h.record_state(&s);
            producer[1] += c.elapsed();
            calls[1] += 1;
            h.record_true_state(&s);
        }
        if ms >= next_map {
            next_map = ms + 100;
            map.header = header(n, t);
            h.record_map(&map);
        }
        if ms >= next_lbv {
            next_lbv = ms + 50;
            dec.header = header(n, t);
            dec.kind = if ms % 2000 < 50 {
                decision_kind::GBV
            } else {
                decision_kind::LBV
            };
            let c = Instant::now();
            h.record_decision(&dec);
            producer[2] += c.elapsed();
            calls[2] += 1;
            let mut e = DeadlineEvent {
                header: header(n, t),
                period_ns: 50_000_000,
                exec_ns: 2_000_000,
                ..Default::default()
            };
            e.set_thread_name("lbv");
            h.record_deadline(&e);
            h.record_neck_goal(&NeckGoal {
                header: header(n, t),
                ..Default::default()
            });
        }
        if ms >= next_sec {
            next_sec = ms + 1000;
            let mut hist = hdrhistogram::Histogram::<u64>::new(3)?;
            let _ = hist.record(2_000_000);
            h.record_latency(LatencySummary {
                time_ns: t.as_nanos() as u64,
                period_ns: 1_000_000_000,
                nodes: vec![NodeLatency::from_histogram("lbv", &hist)],
            });
            h.log(t.as_nanos() as u64, LogLevel::Info, "load", "tick");
        }
        std::thread::sleep(tick);
    }
    let wall = start.elapsed().as_secs_f64();
    let s = rec.finish()?;
    let size = std::fs::metadata(&out).map(|m| m.len()).unwrap_or(0);
    let us = |i: usize| producer[i].as_secs_f64() * 1e6 / calls[i].max(1) as f64;
    println!("recorded {wall:.1} s into {out}");
    println!(
        "writer thread CPU: {:.3} s = {:.1}% of one core",
        s.writer_cpu_ns as f64 * 1e-9,
        100.0 * s.writer_cpu_ns as f64 * 1e-9 / wall
    );
    println!(
        "producer cost per call: depth {:.1} us, state {:.2} us, decision {:.2} us",
        us(0),
        us(1),
        us(2)
    );
    println!("dropped: {} {:?}", s.drops.total_dropped(), s.drops.dropped);
    println!(
        "file: {:.1} MB ({:.2} MB/s); messages written: {}",
        size as f64 / 1e6,
        size as f64 / 1e6 / wall,
        s.written.values().sum::<u64>()
    );
    Ok(())
}
