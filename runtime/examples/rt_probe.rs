//! Quick measurement of what the runtime gets on this machine:
//! 1. periodic-executor wake-up lateness at 1 kHz with and without the spin margin;
//! 2. in-process zero-copy `DepthFrame` loan → fill header → send → receive latency.
//!
//! ```text
//! cargo run --release -p runtime --example rt_probe -- [--seconds S]
//! ```
//! Each executor run lasts `S` seconds (default 2; `S × 1000` cycles), the port probe at most
//! 2000 round trips. The jitter harness in `rt_tests` is the reference; this is a smoke-level
//! probe.

use runtime::executor::{Control, Cycle, Executor, ExecutorConfig};
use runtime::ports::{PortContext, PortsConfig, Stamp};
use shm_types::{DepthFrame, Intrinsics, Pose3};
use std::time::{Duration, Instant};

mod common;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let usage = "rt_probe [--seconds S]   (each executor run: S s at 1 kHz)";
    let Some(args) = common::parse(usage, 2.0, false)? else {
        return Ok(());
    };
    let cycles = ((args.seconds * 1000.0).round() as u64).max(1);
    for margin_us in [0u64, 200] {
        let cfg = ExecutorConfig {
            spin_margin_us: margin_us,
            ..ExecutorConfig::default()
        };
        let h = Executor::builder("probe-1khz", Duration::from_millis(1))
            .config(&cfg)
            .max_cycles(cycles)
            .spawn(|| |_: &Cycle| Control::Continue)?;
        let s = h.wait()?;
        println!("spin margin {margin_us} µs: {s}");
    }

    let ns = format!("probe{}", std::process::id());
    let ctx = PortContext::with_namespace(&PortsConfig::default(), "probe", &ns)?;
    let sub = ctx.subscriber::<DepthFrame>("depth")?;
    let publ = ctx.publisher::<DepthFrame>("depth")?;
    let mut hist = hdrhistogram::Histogram::<u64>::new_with_bounds(1, 1_000_000_000, 3)?;
    for k in 0..cycles.min(2000) {
        let t0 = Instant::now();
        let mut f = publ.loan()?; // includes zero-filling 600 KB in place
        f.width = 640;
        f.height = 480;
        // The subscriber validates on receipt: a frame without intrinsics or pose is dropped.
        f.intrinsics = Intrinsics {
            fx: 525.0,
            fy: 525.0,
            cx: 320.0,
            cy: 240.0,
            min_range: 0.5,
            max_range: 4.5,
        };
        f.camera_pose = Pose3::IDENTITY;
        f.send(Stamp {
            source_ns: k,
            sim_ns: k,
        })?;
        let r = sub.wait(Duration::from_secs(1))?.ok_or("lost")?;
        std::hint::black_box(r.header().seq);
        hist.saturating_record(t0.elapsed().as_nanos() as u64);
    }
    println!(
        "DepthFrame loan+zero+send+receive (in-process): {}",
        runtime::executor::Stats::of(&hist)
    );
    Ok(())
}
