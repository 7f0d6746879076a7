//! A writer that falls behind (issue 37): a test hook ([`WriterHook`]) stalls or slows the
//! writer thread. With [`Overflow::Drop`] (live hosts) the publisher never waits for it and every
//! drop is counted; with [`Overflow::Wait`] (lockstep) nothing is dropped, the publisher is held
//! back instead, and a writer that dies releases a waiting publisher.
//!
//! No test bounds a run time: hang guards only (generous, for a loaded machine).

mod recorder_common;

use crossbeam::channel::{Receiver, Sender, bounded};
use recorder_common::*;
use runtime::recorder::inspect::info;
use runtime::recorder::{
    DropCounts, Overflow, Recorder, RecorderConfig, RecorderError, RecorderSetup, WriterHook,
};
use shm_types::decision_kind;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

/// Hang guard: how long a test waits for something that must happen.
const HANG: Duration = Duration::from_secs(120);

fn tmp(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("vpsom-backpressure-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

/// The smallest room the config allows: the writer is behind after a few messages.
fn small_room() -> RecorderConfig {
    RecorderConfig {
        queue_len: 16,
        depth_queue_len: 1,
        pool_len: 1,
        ..Default::default()
    }
}

/// A hook that stalls the writer in its first message until the returned sender is dropped,
/// after saying so on the returned receiver; it counts its calls.
fn stall() -> (WriterHook, Sender<()>, Receiver<()>, Arc<AtomicU64>) {
    let (release, gate) = bounded::<()>(0);
    let (entered_tx, entered) = bounded::<()>(1);
    let calls = Arc::new(AtomicU64::new(0));
    let c = Arc::clone(&calls);
    let hook = WriterHook::new(move || {
        c.fetch_add(1, Ordering::SeqCst);
        let _ = entered_tx.try_send(());
        // Returns once the test drops `release`.
        let _ = gate.recv();
    });
    (hook, release, entered, calls)
}

/// Run `f` on a thread and return its result; panics with `what` if it never returns.
fn returns<T: Send + 'static>(what: &str, f: impl FnOnce() -> T + Send + 'static) -> T {
    let (tx, rx) = bounded(1);
    std::thread::spawn(move || {
        let _ = tx.send(f());
    });
    rx.recv_timeout(HANG)
        .unwrap_or_else(|_| panic!("{what}: did not return within {HANG:?}"))
}

#[test]
fn a_stalled_writer_never_blocks_a_live_publisher_and_every_drop_is_counted() {
    const N: u64 = 100;
    let path = tmp("live-stalled.mcap");
    let (hook, release, entered, calls) = stall();
    let cfg = RecorderConfig {
        depth_queue_len: 2,
        pool_len: 2,
        ..small_room()
    };
    let setup = RecorderSetup {
        overflow: Overflow::Drop,
        writer_hook: Some(hook),
        ..test_setup()
    };
    let rec = Recorder::create(&path, &cfg, setup).unwrap();
    let h = rec.handle();
    h.record_state(&state(0));
    entered
        .recv_timeout(HANG)
        .expect("the writer never took the first message");

    // The writer is stuck in its first message; a publisher records N of three kinds.
    let drops: DropCounts = returns("the live publisher, writer stalled", move || {
        for i in 1..=N {
            h.record_state(&state(i));
        }
        for i in 1..=N {
            h.record_depth(&depth(i, 64, 48));
        }
        for i in 1..=N {
            h.record_map(&map(i, 3));
        }
        h.drops()
    });
    // It returned while the writer was still in its first message.
    assert_eq!(calls.load(Ordering::SeqCst), 1, "the writer moved on");
    // Exactly what there was room for: 16 states in the channel, the 2 newest frames in the
    // ring, no map (the channel was full).
    assert_eq!(drops.dropped[topic::TF], N - 16, "{drops:?}");
    assert_eq!(drops.dropped[topic::DEPTH], N - 2, "{drops:?}");
    assert_eq!(drops.dropped[topic::MAP], N, "{drops:?}");

    drop(release);
    let summary = rec.finish().unwrap();
    assert_eq!(summary.drops.dropped, drops.dropped);
    for t in [topic::TF, topic::DEPTH, topic::MAP] {
        assert_eq!(
            summary.written[t] + summary.drops.dropped[t],
            summary.drops.offered[t],
            "{t}: {summary:?}"
        );
    }
    let (msgs, end) = read_all(&path);
    assert!(end.complete, "{end:?}");
    let c = counts(&msgs);
    assert_eq!(c[topic::TF], 17);
    assert_eq!(c[topic::DEPTH], 2);
    assert_eq!(c.get(topic::MAP), None);
    let kept: Vec<u64> = msgs
        .iter()
        .filter(|m| m.topic == topic::DEPTH)
        .map(|m| m.log_time / 33_333_333)
        .collect();
    assert_eq!(kept, [N - 1, N], "the newest frames are kept");
    assert_eq!(info(&path).unwrap().drops, Some(summary.drops));
    let _ = std::fs::remove_file(&path);
}

#[test]
fn a_waiting_recorder_drops_nothing_behind_a_slow_writer() {
    const N: u64 = 150;
    const KINDS: u64 = 6;
    let path = tmp("wait-slow.mcap");
    let calls = Arc::new(AtomicU64::new(0));
    let c = Arc::clone(&calls);
    // A slow disk: 1 ms per message, with room for 16 messages and one depth frame.
    let setup = RecorderSetup {
        overflow: Overflow::Wait,
        writer_hook: Some(WriterHook::new(move || {
            c.fetch_add(1, Ordering::SeqCst);
            std::thread::sleep(Duration::from_millis(1));
        })),
        ..test_setup()
    };
    let rec = Recorder::create(&path, &small_room(), setup).unwrap();
    let h = rec.handle();
    let hooked_when_done = returns("the waiting publisher, slow writer", move || {
        for i in 1..=N {
            h.record_depth(&depth(i, 64, 48));
            h.record_detections(&detections(i, 2));
            h.record_state(&state(i));
            h.record_true_state(&state(i));
            h.record_map(&map(i, 3));
            h.record_decision(&decision(i, decision_kind::LBV, 4));
        }
        calls.load(Ordering::SeqCst)
    });
    // The publisher was held back: when it returned, all but what the recorder has room for
    // (16 in the channel, 2 depth buffers, 1 in the writer's hands) had reached the writer.
    assert!(
        hooked_when_done + 16 + 2 + 1 >= KINDS * N,
        "the publisher ran ahead: {hooked_when_done} of {} reached the writer",
        KINDS * N
    );
    let summary = rec.finish().unwrap();
    assert_eq!(summary.drops.total_dropped(), 0, "{:?}", summary.drops);
    for t in [
        topic::DEPTH,
        topic::DETECTIONS,
        topic::TF,
        topic::TRUTH_TF,
        topic::MAP,
        topic::DECISIONS,
    ] {
        assert_eq!(summary.drops.offered[t], N, "{t}");
        assert_eq!(summary.written[t], N, "{t}");
    }
    let (msgs, end) = read_all(&path);
    assert!(end.complete, "{end:?}");
    let c = counts(&msgs);
    for t in [topic::DEPTH, topic::TF, topic::MAP, topic::DECISIONS] {
        assert_eq!(c[t], N, "{t}");
    }
    let inf = info(&path).unwrap();
    assert_eq!(inf.drops.map(|d| d.total_dropped()), Some(0));
    assert_eq!(
        inf.metadata["session"].get("overflow").map(String::as_str),
        Some("wait")
    );
    let _ = std::fs::remove_file(&path);
}

#[test]
fn a_publisher_waiting_for_a_writer_that_dies_is_released_and_the_error_reported() {
    let path = tmp("wait-dies.mcap");
    let calls = Arc::new(AtomicU64::new(0));
    let c = Arc::clone(&calls);
    let setup = RecorderSetup {
        overflow: Overflow::Wait,
        writer_hook: Some(WriterHook::new(move || {
            if c.fetch_add(1, Ordering::SeqCst) == 4 {
                panic!("test: the writer dies on its 5th message");
            }
        })),
        ..test_setup()
    };
    let rec = Recorder::create(&path, &small_room(), setup).unwrap();
    let h = rec.handle();
    // More than the channel and the map pool hold: the publisher must wait, then be released.
    let (drops, stopped) = returns("a publisher waiting for a dead writer", move || {
        for i in 1..=100 {
            h.record_state(&state(i));
            h.record_map(&map(i, 3));
        }
        h.record_depth(&depth(1, 64, 48));
        (h.drops(), h.writer_stopped())
    });
    assert!(stopped);
    assert!(drops.dropped[topic::TF] > 0, "{drops:?}");
    assert!(drops.dropped[topic::MAP] > 0, "{drops:?}");
    assert_eq!(drops.dropped[topic::DEPTH], 1, "{drops:?}");
    match rec.finish() {
        Err(RecorderError::Panicked { path: p }) => assert_eq!(p, path),
        other => panic!("expected the writer's panic, got {other:?}"),
    }
    let _ = std::fs::remove_file(&path);
}
