//! A recorder killed mid-run and restarted by the launcher never truncates what it had written:
//! the new instance recovers the torn `trace.mcap` in place and continues in `trace.1.mcap`, and
//! the two segments read as one run hold every state offered except those of the torn chunk.
//!
//! The test runs itself as the recorder process (selected by `VPSOM_RECORDER_RESTART_CHILD=<dir>`,
//! set by a `sh -c ... exec` wrapper because the launcher passes no environment of its own). The
//! recorder child records states at ~100 Hz, numbered by the time since the run started (so a
//! restarted instance continues the numbering), and appends `<segment> <seq>` to
//! `offered.log` *before* handing each state to the recorder: the log is what was published.

mod recorder_common;

use recorder_common::*;
use runtime::launcher::{ChildEvent, ChildSpec, ExitReason, Launcher};
use runtime::recorder::inspect::{export_csv, info};
use runtime::recorder::recover::{segment_path, segments};
use runtime::recorder::{Recorder, RecorderConfig};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

const CHILD_ENV: &str = "VPSOM_RECORDER_RESTART_CHILD";
const TEST: &str = "a_restarted_recorder_continues_in_a_new_segment";
const FLUSH_S: f64 = 0.2;

fn unix_ns() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .unwrap()
        .as_nanos() as u64
}

/// The recorder process: returns (test passes, exit 0) once `stop` exists.
fn child(dir: &Path) {
    let first = dir.join("trace.mcap");
    let cfg = RecorderConfig {
        flush_interval_s: FLUSH_S,
        ..Default::default()
    };
    let rec = Recorder::resume(&first, &cfg, test_setup()).unwrap();
    let seg = (0..100)
        .find(|&k| segment_path(&first, k) == rec.path())
        .expect("a segment of the run");
    let h = rec.handle();
    let t0: u64 = std::fs::read_to_string(dir.join("t0"))
        .unwrap()
        .trim()
        .parse()
        .unwrap();
    let mut log = std::fs::OpenOptions::new()
        .append(true)
        .create(true)
        .open(dir.join("offered.log"))
        .unwrap();
    let start = Instant::now();
    let mut last = 0;
    loop {
        if dir.join("stop").exists() {
            rec.finish().unwrap();
            return;
        }
        let seq = (unix_ns() - t0) / 10_000_000 + 1;
        if seq > last {
            // One write(2) per line, O_APPEND: a kill never leaves half a line.
            log.write_all(format!("{seg} {seq}\n").as_bytes()).unwrap();
            h.record_state(&state(seq));
            last = seq;
        }
        std::thread::sleep(Duration::from_millis(10));
        // A lost parent must not leave this process running.
        assert!(
            start.elapsed() < Duration::from_secs(120),
            "recorder child never stopped"
        );
    }
}

/// Poll the launcher until an event matching `want` arrives (the limit only ends a hang).
fn poll_for(l: &mut Launcher, want: impl Fn(&ChildEvent) -> bool) -> ChildEvent {
    let t0 = Instant::now();
    loop {
        if let Some(e) = l.poll().into_iter().find(|e| want(e)) {
            return e;
        }
        assert!(t0.elapsed() < Duration::from_secs(60), "no such event");
        std::thread::sleep(Duration::from_millis(10));
    }
}

/// Wait until `segment` exists and holds at least `n` states in completed chunks.
fn wait_for_states(segment: &Path, n: u64) {
    let t0 = Instant::now();
    loop {
        let got = if segment.exists() {
            // Only this segment: `info` of a later segment reads that file alone.
            info(segment).map_or(0, |i| i.count(topic::TF))
        } else {
            0
        };
        if got >= n {
            return;
        }
        assert!(
            t0.elapsed() < Duration::from_secs(60),
            "{}: only {got} states",
            segment.display()
        );
        std::thread::sleep(Duration::from_millis(50));
    }
}

fn tf_seqs(path: &Path) -> Vec<u64> {
    let (msgs, end) = read_all(path);
    assert!(end.complete, "{}: {end:?}", path.display());
    msgs.iter()
        .filter(|m| m.topic == topic::TF)
        .map(|m| m.log_time / 33_333_333)
        .collect()
}

#[test]
fn a_restarted_recorder_continues_in_a_new_segment() {
    if let Some(dir) = std::env::var_os(CHILD_ENV) {
        child(Path::new(&dir));
        return;
    }
    let dir: PathBuf =
        std::env::temp_dir().join(format!("vpsom-recorder-restart-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("t0"), unix_ns().to_string()).unwrap();
    let first = dir.join("trace.mcap");

    let mut l = Launcher::new(
        &format!("recorder-restart-test-{}", std::process::id()),
        iceoryx2::config::Config::global_config(),
    )
    .unwrap();
    let exe = std::env::current_exe().unwrap();
    l.spawn(ChildSpec {
        name: "recorder".into(),
        program: "/bin/sh".into(),
        args: vec![
            "-c".into(),
            format!("{CHILD_ENV}=\"$1\" exec \"$0\" --exact {TEST} --nocapture --test-threads=1"),
            exe.display().to_string(),
            dir.display().to_string(),
        ],
        max_restarts: 1,
        inherit_stdout: false,
        liveness: None,
    })
    .unwrap();

    // Mid-run: 30 states in completed chunks of trace.mcap, then SIGKILL the recorder.
    wait_for_states(&first, 30);
    let pid = l.pids()["recorder"];
    let st = std::process::Command::new("kill")
        .args(["-KILL", &pid.to_string()])
        .status()
        .unwrap();
    assert!(st.success());
    let e = poll_for(&mut l, |e| matches!(e, ChildEvent::Restarted { .. }));
    assert!(
        matches!(
            e,
            ChildEvent::Restarted {
                reason: ExitReason::Signal(9),
                attempt: 1,
                ..
            }
        ),
        "{e}"
    );
    // The new instance recovered trace.mcap and records into trace.1.mcap; let it, then stop it.
    let second = segment_path(&first, 1);
    wait_for_states(&second, 30);
    std::fs::write(dir.join("stop"), "").unwrap();
    let e = poll_for(&mut l, |e| !matches!(e, ChildEvent::Restarted { .. }));
    assert_eq!(
        e,
        ChildEvent::Finished {
            name: "recorder".into()
        }
    );

    // Two segments, both finished and indexed (the first one by the background recovery,
    // which the restarted recorder waited for before it exited); no temporary file left.
    assert_eq!(segments(&dir), vec![first.clone(), second.clone()]);
    assert!(!dir.join("trace.mcap.recovering").exists());
    for seg in [&first, &second] {
        let c = indexed_counts(seg).unwrap_or_else(|e| panic!("{}: {e}", seg.display()));
        assert!(c[topic::TF] >= 30, "{}: {c:?}", seg.display());
    }
    // What was published, per recorder instance.
    let log = std::fs::read_to_string(dir.join("offered.log")).unwrap();
    let mut offered = [Vec::new(), Vec::new()];
    for line in log.lines() {
        let (seg, seq) = line.split_once(' ').unwrap();
        offered[seg.parse::<usize>().unwrap()].push(seq.parse::<u64>().unwrap());
    }
    let (s0, s1) = (tf_seqs(&first), tf_seqs(&second));
    // The killed instance: its file holds a prefix of what it was given (every state up to the
    // last complete chunk), nothing truncated by the restart; the loss is the tail.
    assert!(s0.len() >= 30);
    assert_eq!(s0[..], offered[0][..s0.len()]);
    // The restarted instance finished cleanly: everything it was given is in its segment.
    assert_eq!(s1, offered[1]);
    assert!(s1[0] > *offered[0].last().unwrap(), "numbering continues");
    let lost = offered[0].len() - s0.len();
    eprintln!(
        "published {} states ({} before the kill, {} after), recorded {} + {}; \
         lost {lost} (in the torn chunk or queued at the kill; flush interval {FLUSH_S} s)",
        offered[0].len() + offered[1].len(),
        offered[0].len(),
        offered[1].len(),
        s0.len(),
        s1.len()
    );

    // Read as one run, from the directory or the first segment.
    let total = (s0.len() + s1.len()) as u64;
    let inf = info(&dir).unwrap();
    assert_eq!(inf.count(topic::TF), total);
    assert_eq!(inf.segments.len(), 2);
    assert!(inf.end.complete, "{inf}");
    assert!(inf.to_string().contains("segments: 2"), "{inf}");
    assert_eq!(info(&first).unwrap().count(topic::TF), total);
    let mut csv = Vec::new();
    assert_eq!(export_csv(&first, topic::TF, &mut csv).unwrap(), total);
    let _ = std::fs::remove_dir_all(&dir);
}

/// A finished trace cut to `keep` of its length: a torn file as SIGKILL leaves it (no summary,
/// no footer, a partial chunk), with `n` states of which the first chunks are complete.
fn torn_trace(path: &Path, n: u64, keep: f64) {
    let cfg = RecorderConfig {
        chunk_size_kb: 16,
        ..Default::default()
    };
    let rec = Recorder::create(path, &cfg, test_setup()).unwrap();
    let h = rec.handle();
    for i in 1..=n {
        h.record_state(&state(i));
    }
    rec.finish().unwrap();
    let len = std::fs::metadata(path).unwrap().len();
    let f = std::fs::OpenOptions::new().write(true).open(path).unwrap();
    f.set_len((len as f64 * keep) as u64).unwrap();
}

/// Two crashes in a row leave two torn segments: the third instance recovers both (not only the
/// last) and the run reads as one; a new run (`create`) removes the old run's later segments.
#[test]
fn resume_recovers_every_torn_segment_and_create_starts_a_new_run() {
    let dir = std::env::temp_dir().join(format!("vpsom-recorder-resume-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let first = dir.join("trace.mcap");
    torn_trace(&first, 2000, 0.6);
    torn_trace(&segment_path(&first, 1), 2000, 0.5);
    // Each file alone (`info` of the first segment would read the whole run).
    let torn: Vec<u64> = [0, 1]
        .iter()
        .map(|&k| {
            let (msgs, end) = read_all(&segment_path(&first, k));
            assert!(!end.complete, "{end:?}");
            counts(&msgs)[topic::TF]
        })
        .collect();
    assert!(torn.iter().all(|&n| n > 0 && n < 2000), "{torn:?}");

    let mut rec = Recorder::resume(&first, &RecorderConfig::default(), test_setup()).unwrap();
    assert_eq!(rec.path(), segment_path(&first, 2));
    for i in 1..=10 {
        rec.handle().record_state(&state(i));
    }
    let done = rec.wait_recovery();
    assert_eq!(done.len(), 2);
    for ((seg, r), n) in done.iter().zip(&torn) {
        let r = r.as_ref().unwrap().as_ref().expect("torn, so recovered");
        assert_eq!(r.per_topic[topic::TF], *n, "{}", seg.display());
    }
    rec.finish().unwrap();
    let inf = info(&dir).unwrap();
    assert_eq!(inf.segments.len(), 3);
    assert!(inf.end.complete, "{inf}");
    assert_eq!(inf.count(topic::TF), torn[0] + torn[1] + 10);

    // A new run in the same directory starts from one segment again.
    drop(Recorder::create(&first, &RecorderConfig::default(), test_setup()).unwrap());
    assert_eq!(segments(&dir), vec![first.clone()]);
    let _ = std::fs::remove_dir_all(&dir);
}
