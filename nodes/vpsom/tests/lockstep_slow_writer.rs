//! Issue 37: a lockstep trace is always complete. The recorder's writer is made slow (a test hook
//! sleeps before every message it writes, as a busy disk would) and given the least room the
//! config allows, so it falls far behind the host; the lockstep host waits for it instead of
//! dropping. The trace has 0 drops, every message the session published, and `vpsom replay
//! --check` reproduces it exactly. (The live counterpart, a stalled writer that a publisher never
//! waits for, is `runtime/tests/recorder_backpressure.rs`.)

use runtime::recorder::{RecorderError, WriterHook, inspect};
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;
use vpsom::config::Config;
use vpsom::lockstep::{self, Progress, SessionSpec};
use vpsom::recording::topic;
use vpsom::replay::{self, ReplaySpec};
use vpsom::sim::Scene;

#[test]
fn a_slow_writer_makes_lockstep_wait_and_the_trace_is_complete_and_replays_exactly() {
    let dir = std::env::temp_dir().join(format!("vpsom-slow-writer-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let trace = dir.join("trace.mcap");
    let base = Config::ideal_sensing().with_camera(160, 120, 10.0);
    let mut cfg = lockstep::config_for(&base, "vpsom").unwrap();
    // The least room the config allows: 16 messages, one depth frame, one pooled copy each.
    cfg.recorder.queue_len = 16;
    cfg.recorder.depth_queue_len = 1;
    cfg.recorder.pool_len = 1;
    let spec = SessionSpec {
        scene: Scene::builtin("paper-scene-1").unwrap(),
        config: cfg.clone(),
        seed: 3,
        label: "vpsom".into(),
        max_sim_s: 12.0,
        record: Some(trace.clone()),
    };
    // A slow disk: 2 ms per message written (the session publishes ~2 500).
    let hooked = Arc::new(AtomicU64::new(0));
    let h = Arc::clone(&hooked);
    let hook = WriterHook::new(move || {
        h.fetch_add(1, Ordering::SeqCst);
        std::thread::sleep(Duration::from_millis(2));
    });
    // The host never runs further ahead of the writer than the recorder has room for (16 in
    // the channel, 2 depth buffers, 1 in the writer's hands): at every progress report, the
    // nav grid and one estimated and one true state per step so far have been offered.
    let room = 16 + 2 + 1;
    let dt = (1e9 / cfg.rates.state_hz).round() as u64;
    let mut reports = 0;
    let r = lockstep::run_session_with_writer_hook(&spec, hook, |p: &Progress| {
        let steps = (p.sim_s * 1e9).round() as u64 / dt + 1;
        let offered = 1 + 2 * steps;
        let reached = hooked.load(Ordering::SeqCst);
        assert!(
            reached + room >= offered,
            "at {:.1} s the host ran ahead: {reached} of at least {offered} messages reached the \
             writer",
            p.sim_s,
        );
        reports += 1;
    })
    .unwrap();
    assert!(reports >= 10, "{reports} progress reports");

    // 0 drops, and the trace holds what the session published, per topic.
    let rec = r.recorder.clone().expect("recorded");
    assert_eq!(rec.drops.total_dropped(), 0, "{:?}", rec.drops);
    let info = inspect::info(&trace).unwrap();
    assert!(info.end.complete, "{info}");
    assert_eq!(info.drops.as_ref().map(|d| d.total_dropped()), Some(0));
    let n = r.recorded;
    for (t, published) in [
        (topic::DEPTH, n.depth),
        (topic::DETECTIONS, n.depth),
        (topic::STATE, n.state),
        (topic::TF, n.state),
        (topic::TRUTH_TF, n.truth),
        (topic::MAP, n.map),
        (topic::DECISIONS, n.decisions),
        (topic::NECK_GOAL, n.neck_goals),
        (topic::NAV_GOAL, n.nav_goals),
        (topic::NAV_GRID, 1),
        (topic::METRICS, 1),
    ] {
        assert!(published > 0, "{t}: nothing published");
        assert_eq!(info.count(t), published, "{t}");
    }
    assert_eq!(
        info.metadata["session"].get("overflow").map(String::as_str),
        Some("wait")
    );

    // Waiting changed nothing the logic did: the same session unrecorded ends the same.
    let plain = lockstep::run_session(
        &SessionSpec {
            record: None,
            ..spec.clone()
        },
        |_| {},
    )
    .unwrap();
    assert_eq!(plain.metrics.path_length_m, r.metrics.path_length_m);
    assert_eq!(plain.metrics.objects_estimated, r.metrics.objects_estimated);
    assert_eq!(plain.metrics.cde_m, r.metrics.cde_m);

    // `vpsom replay --check` reproduces every map, decision and goal exactly.
    let check = replay::replay(&ReplaySpec {
        trace: trace.clone(),
        config: cfg,
        check: true,
        out: None,
    })
    .unwrap();
    assert_eq!(check.divergence, None, "{check}");
    for t in [
        topic::MAP,
        topic::DECISIONS,
        topic::NECK_GOAL,
        topic::NAV_GOAL,
    ] {
        assert_eq!(
            check.compared[t],
            info.count(t),
            "{t}: every output compared"
        );
    }
    assert_eq!(check.frames, info.count(topic::DEPTH));
    let _ = std::fs::remove_dir_all(&dir);
}

/// A writer that dies mid-session (here a panicking hook; on a robot an I/O error) ends a lockstep
/// session early with the recorder's error: the host neither waits forever nor runs to the end
/// for a trace that cannot be written.
#[test]
fn a_writer_that_dies_ends_the_lockstep_session_with_its_error() {
    let dir = std::env::temp_dir().join(format!("vpsom-dead-writer-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let base = Config::ideal_sensing().with_camera(160, 120, 10.0);
    let spec = SessionSpec {
        scene: Scene::builtin("paper-scene-1").unwrap(),
        config: lockstep::config_for(&base, "vpsom").unwrap(),
        seed: 3,
        label: "vpsom".into(),
        max_sim_s: 12.0,
        record: Some(dir.join("trace.mcap")),
    };
    let calls = Arc::new(AtomicU64::new(0));
    let c = Arc::clone(&calls);
    let hook = WriterHook::new(move || {
        if c.fetch_add(1, Ordering::SeqCst) == 200 {
            panic!("test: the writer dies on its 201st message");
        }
    });
    let mut last_s = 0.0;
    let r = lockstep::run_session_with_writer_hook(&spec, hook, |p| last_s = p.sim_s);
    match r {
        Err(lockstep::SessionError::Recorder(RecorderError::Panicked { path })) => {
            assert_eq!(path, dir.join("trace.mcap"));
        }
        other => panic!(
            "expected the recorder's error, got {:?}",
            other.map(|r| r.metrics)
        ),
    }
    assert!(last_s < 12.0, "the session ran to its end ({last_s} s)");
    let _ = std::fs::remove_dir_all(&dir);
}
