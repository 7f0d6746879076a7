//! Two processes exchange 1000 `DepthFrame`s (600 KB each) through the typed ports: every
//! sequence number arrives exactly once and in order, the payload read equals what was
//! written, and the subscriber reads the frame in place, from the iceoryx2 shared-memory
//! mapping, never from a local copy.
//!
//! The test re-runs its own binary as the publisher child (selected by an environment
//! variable), with a unique service namespace per run; the services disappear when both
//! processes drop their ports.

use runtime::ports::{Overflow, PortContext, PortsConfig, Stamp, TopicOverride};
use shm_types::{DepthFrame, MAX_HEIGHT, MAX_WIDTH, NeckGoal};
use std::process::{Child, Command};
use std::time::{Duration, Instant};

const ROLE_ENV: &str = "VPSOM_PORTS_IPC_ROLE";
const NS_ENV: &str = "VPSOM_PORTS_IPC_NS";
const TEST_NAME: &str = "two_processes_exchange_1000_depth_frames_in_place";
const FRAMES: u64 = 1000;

/// Pixel `i` of frame `seq`: differs between frames and along the row, never 0.
fn pattern(seq: u64, i: usize) -> u16 {
    ((seq as usize)
        .wrapping_mul(7919)
        .wrapping_add(i.wrapping_mul(31))
        % 65_000
        + 1) as u16
}

fn config() -> PortsConfig {
    let mut cfg = PortsConfig::default();
    // Backpressure on depth: nothing may be lost, the publisher waits for the subscriber.
    cfg.topics.insert(
        "depth".into(),
        TopicOverride {
            overflow: Some(Overflow::Block),
            subscriber_buffer: Some(4),
            block_timeout_ms: Some(30_000),
            ..TopicOverride::default()
        },
    );
    cfg
}

/// Kills the child (by its own pid) if the test fails before it exits.
struct ChildGuard(Option<Child>);

impl Drop for ChildGuard {
    fn drop(&mut self) {
        if let Some(mut c) = self.0.take()
            && c.try_wait().ok().flatten().is_none()
        {
            let _ = c.kill();
            let _ = c.wait();
        }
    }
}

/// Address ranges of this process's mappings of files in /dev/shm (iceoryx2 data segments).
fn shm_mappings() -> Vec<(usize, usize, String)> {
    let maps = std::fs::read_to_string("/proc/self/maps").expect("read /proc/self/maps");
    maps.lines()
        .filter_map(|l| {
            let mut f = l.split_whitespace();
            let range = f.next()?;
            let perms = f.next()?;
            let path = f.nth(3)?;
            if !path.starts_with("/dev/shm/") || !perms.contains('s') {
                return None;
            }
            let (a, b) = range.split_once('-')?;
            Some((
                usize::from_str_radix(a, 16).ok()?,
                usize::from_str_radix(b, 16).ok()?,
                path.to_string(),
            ))
        })
        .collect()
}

fn publisher_child(ns: &str) {
    let ctx = PortContext::with_namespace(&config(), "ipc-publisher", ns).unwrap();
    let publisher = ctx.publisher::<DepthFrame>("depth").unwrap();
    let go = ctx.subscriber::<NeckGoal>("go").unwrap();
    // Wait for the parent's "go": its subscriber is attached, so backpressure applies.
    go.wait(Duration::from_secs(30))
        .unwrap()
        .expect("no go from the parent");
    for k in 1..=FRAMES {
        let mut frame = publisher.loan().unwrap();
        frame.width = MAX_WIDTH as u32;
        frame.height = MAX_HEIGHT as u32;
        // A valid frame (subscribers drop invalid ones on receipt); fx carries k.
        frame.intrinsics.fx = k as f32;
        frame.intrinsics.fy = 1.0;
        frame.intrinsics.max_range = 5.0;
        frame.camera_pose.rotation = [0.0, 0.0, 0.0, 1.0];
        for (i, px) in frame.pixels_mut().iter_mut().enumerate() {
            *px = pattern(k, i);
        }
        let sent = frame
            .send(Stamp {
                source_ns: k * 10,
                sim_ns: k * 20,
            })
            .unwrap();
        assert_eq!(sent.seq, k);
        assert_eq!(sent.subscribers, 1);
    }
    // Stay until the parent has read everything and dropped its subscriber, then return
    // normally (dropping the node cleans up; no process::exit).
    let t0 = Instant::now();
    while publisher.subscriber_count() > 0 && t0.elapsed() < Duration::from_secs(60) {
        std::thread::sleep(Duration::from_millis(5));
    }
}

#[test]
fn two_processes_exchange_1000_depth_frames_in_place() {
    if std::env::var(ROLE_ENV).as_deref() == Ok("publisher") {
        let ns = std::env::var(NS_ENV).expect("namespace for the child");
        publisher_child(&ns);
        return;
    }
    let ns = format!(
        "ipc{}x{}",
        std::process::id(),
        std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.subsec_nanos())
    );
    let ctx = PortContext::with_namespace(&config(), "ipc-subscriber", &ns).unwrap();
    let sub = ctx.subscriber::<DepthFrame>("depth").unwrap();
    let go = ctx.publisher::<NeckGoal>("go").unwrap();
    assert_eq!(
        runtime::ports::list_services(&ns).unwrap().len(),
        4,
        "depth and go, each publish-subscribe + event"
    );
    let child = Command::new(std::env::current_exe().unwrap())
        .args([TEST_NAME, "--exact", "--nocapture", "--test-threads=1"])
        .env(ROLE_ENV, "publisher")
        .env(NS_ENV, &ns)
        .stdout(std::process::Stdio::null())
        .spawn()
        .expect("spawn the publisher process");
    let mut guard = ChildGuard(Some(child));

    // Attach to the child's publisher, then tell it to start.
    let t0 = Instant::now();
    while sub.publisher_count() == 0 || go.subscriber_count() == 0 {
        assert!(
            t0.elapsed() < Duration::from_secs(30),
            "child never connected"
        );
        assert!(sub.receive().unwrap().is_none());
        std::thread::sleep(Duration::from_millis(1));
    }
    assert!(sub.receive().unwrap().is_none());
    go.loan().unwrap().send(Stamp::default()).unwrap();

    let local = shm_types::boxed_zeroed::<DepthFrame>();
    let local_addr = &*local as *const DepthFrame as usize;
    let mut maps = shm_mappings();
    let n = MAX_WIDTH * MAX_HEIGHT;
    for k in 1..=FRAMES {
        let frame = sub
            .wait(Duration::from_secs(30))
            .unwrap()
            .unwrap_or_else(|| panic!("frame {k} did not arrive"));
        // Every seq once and in order, with the producer's stamps.
        assert_eq!(frame.header().seq, k);
        assert_eq!(frame.header().stamp_ns, k * 10);
        assert_eq!(frame.header().sim_time_ns, k * 20);
        // Read in place: the payload lies inside a shared /dev/shm mapping of this process.
        let addr = &*frame as *const DepthFrame as usize;
        let size = std::mem::size_of::<DepthFrame>();
        let inside = |maps: &[(usize, usize, String)]| {
            maps.iter().any(|(a, b, _)| addr >= *a && addr + size <= *b)
        };
        if !inside(&maps) {
            maps = shm_mappings(); // a segment mapped since the last look
        }
        assert!(
            inside(&maps),
            "frame {k} at {addr:#x} is not in a /dev/shm mapping: {maps:?}"
        );
        assert_ne!(addr, local_addr);
        // Payload equals what the other process wrote.
        assert_eq!(
            (frame.width as usize, frame.height as usize),
            (MAX_WIDTH, MAX_HEIGHT)
        );
        assert_eq!(frame.intrinsics.fx, k as f32);
        let pixels = frame.pixels();
        assert_eq!(pixels.len(), n);
        if let Some(i) = (0..n).find(|&i| pixels[i] != pattern(k, i)) {
            panic!("frame {k} pixel {i}: {} != {}", pixels[i], pattern(k, i));
        }
    }
    assert_eq!(sub.gaps(), 0);
    assert!(sub.receive().unwrap().is_none(), "nothing beyond {FRAMES}");
    drop(sub);

    // The child returns once our subscriber is gone; it must exit successfully.
    let mut child = guard.0.take().unwrap();
    let t0 = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if t0.elapsed() > Duration::from_secs(60) {
            let _ = child.kill();
            panic!("publisher process did not exit");
        }
        std::thread::sleep(Duration::from_millis(5));
    };
    assert!(status.success(), "publisher process failed: {status}");
    drop(go);
    drop(ctx);
    // The services of this run are gone once both processes dropped their ports.
    assert_eq!(
        runtime::ports::list_services(&ns).unwrap(),
        Vec::<String>::new()
    );
}
