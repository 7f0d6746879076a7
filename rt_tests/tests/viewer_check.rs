//! Issue 36: every Foxglove-protocol viewer connects, checked with the viewers' own client
//! libraries (the Node project in `rt_tests/viewer-check/`, see its README).
//!
//! A short `vpsom run --live` is watched by two `@foxglove/ws-protocol` `FoxgloveClient`s at once,
//! one offering `foxglove.sdk.v1` (Foxglove today) and one `foxglove.websocket.v1` (Lichtblick,
//! older Foxglove Studio: refused with HTTP 400 before the live view's front). Each subscribes to
//! every channel, decodes every message with its advertised schema and compares its per-topic
//! counts with the recorder's `/recorder/stats` for the same intervals (`live-check.mjs`). Then
//! `@mcap/core`'s indexed reader opens the run's trace and a recovered torn copy of it, CRCs
//! checked, and decodes every message (`trace-check.mjs`).
//!
//! Needs `node` on PATH, `npm ci` run in `rt_tests/viewer-check/`, and the `vpsom` binary of the
//! same profile (`cargo build --release --bin vpsom`). Without them it prints SKIPPED and the
//! reason, and passes; with `VPSOM_VIEWER_CHECK=required` (`.ci/run`, which installs them) a
//! missing one fails instead.

use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

const PROJECT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/viewer-check");
const SUBPROTOCOLS: [&str; 2] = ["foxglove.sdk.v1", "foxglove.websocket.v1"];

/// Written past the test harness's capture, so a skip shows in a plain `cargo test`.
fn say(text: &str) {
    let _ = writeln!(std::io::stderr(), "{text}");
}

/// Why the check cannot run here, if it cannot.
fn missing_precondition(vpsom: &Path) -> Option<String> {
    match Command::new("node").arg("--version").output() {
        Ok(o) if o.status.success() => {}
        _ => return Some("`node` is not on PATH (Node.js 20 or newer)".into()),
    }
    for pkg in [
        "@foxglove/ws-protocol",
        "@foxglove/crc",
        "@mcap/core",
        "@mcap/support",
        "protobufjs",
        "ws",
    ] {
        let p = Path::new(PROJECT).join("node_modules").join(pkg);
        if !p.is_dir() {
            return Some(format!(
                "{} is missing: run `npm ci` in rt_tests/viewer-check",
                p.display()
            ));
        }
    }
    if !vpsom.is_file() {
        return Some(format!(
            "no vpsom binary at {} (build it: cargo build --release --bin vpsom)",
            vpsom.display()
        ));
    }
    None
}

/// `target/<profile>/vpsom`, beside this test's `deps/` folder.
fn vpsom_binary() -> PathBuf {
    let me = std::env::current_exe().expect("the test's own path");
    let profile_dir = me
        .parent()
        .and_then(Path::parent)
        .expect("target/<profile>/deps/<test>");
    profile_dir.join("vpsom")
}

fn node(script: &str, args: &[&str]) -> Command {
    let mut c = Command::new("node");
    c.current_dir(PROJECT).arg(script).args(args);
    c
}

fn text(o: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

/// The `RESULT {json}` line a script prints last.
fn result(o: &Output) -> serde_json::Value {
    let out = String::from_utf8_lossy(&o.stdout);
    let line = out
        .lines()
        .rev()
        .find_map(|l| l.strip_prefix("RESULT "))
        .unwrap_or_else(|| panic!("no RESULT line:\n{}", text(o)));
    serde_json::from_str(line).unwrap()
}

/// Start `vpsom run --live 0` and read the port it serves from its stderr.
fn start_run(vpsom: &Path, out: &Path) -> (Child, u16, mpsc::Receiver<String>) {
    let mut run = Command::new(vpsom)
        .arg("--config")
        .arg(Path::new(PROJECT).join("run.toml"))
        .args(["run", "--live", "0", "--out"])
        .arg(out)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start vpsom run");
    let (tx, rx) = mpsc::channel();
    let stderr = run.stderr.take().expect("piped");
    std::thread::spawn(move || {
        for line in BufReader::new(stderr).lines().map_while(Result::ok) {
            let _ = tx.send(line);
        }
    });
    // Hang guard, generous for a loaded machine.
    let deadline = Instant::now() + Duration::from_secs(60);
    let mut seen = String::new();
    let port = loop {
        let left = deadline.saturating_duration_since(Instant::now());
        let Ok(line) = rx.recv_timeout(left) else {
            break None;
        };
        if let Some(port) = line
            .split("live view on ws://0.0.0.0:")
            .nth(1)
            .and_then(|s| s.split_whitespace().next())
            .and_then(|p| p.parse().ok())
        {
            break Some(port);
        }
        seen.push_str(&line);
        seen.push('\n');
    };
    let Some(port) = port else {
        let _ = run.kill();
        let _ = run.wait();
        panic!("no live-view port from vpsom run within 60 s:\n{seen}");
    };
    (run, port, rx)
}

#[test]
fn both_subprotocols_and_the_traces_pass_the_viewers_own_libraries() {
    let vpsom = vpsom_binary();
    if let Some(why) = missing_precondition(&vpsom) {
        assert!(
            std::env::var("VPSOM_VIEWER_CHECK").as_deref() != Ok("required"),
            "VPSOM_VIEWER_CHECK=required, but {why}"
        );
        say(&format!("SKIPPED viewer_check: {why}"));
        return;
    }
    let dir = std::env::temp_dir().join(format!("vpsom-viewer-check-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let run_dir = dir.join("run");

    // The live view: both clients at once, connected before the robot moves much.
    let started = Instant::now();
    let (mut run, port, run_log) = start_run(&vpsom, &run_dir);
    let url = format!("ws://127.0.0.1:{port}");
    let clients: Vec<Child> = SUBPROTOCOLS
        .iter()
        .map(|sp| {
            node(
                "live-check.mjs",
                &[
                    "--url",
                    &url,
                    "--subprotocol",
                    sp,
                    "--require-all",
                    "--min-intervals",
                    "3",
                    "--seconds",
                    "120",
                ],
            )
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("start node")
        })
        .collect();
    let status = run.wait().unwrap();
    let run_text: Vec<String> = run_log.try_iter().collect();
    assert!(
        status.success(),
        "vpsom run failed:\n{}",
        run_text.join("\n")
    );
    let outputs: Vec<Output> = clients
        .into_iter()
        .map(|c| c.wait_with_output().unwrap())
        .collect();
    say(&format!(
        "viewer_check: vpsom run --live took {:.1} s",
        started.elapsed().as_secs_f64()
    ));
    for (sp, o) in SUBPROTOCOLS.iter().zip(&outputs) {
        let t = text(o);
        say(&t
            .lines()
            .filter(|l| !l.starts_with("RESULT "))
            .collect::<Vec<_>>()
            .join("\n"));
        assert!(o.status.success(), "the {sp} client failed:\n{t}");
        let r = result(o);
        assert_eq!(r["negotiated"], *sp);
        assert_eq!(
            r["channels"].as_u64(),
            Some(vpsom::recording::channels().len() as u64),
            "{t}"
        );
    }

    // The traces: the run's, and a torn copy recovered. The torn copy is the finished file cut
    // in the middle of its data section, as a SIGKILL leaves one (no summary, no footer, a
    // partial last chunk); runtime/tests/recorder_crash.rs makes them with a real SIGKILL.
    let trace = run_dir.join("trace.mcap");
    let bytes = std::fs::read(&trace).unwrap();
    let torn = dir.join("torn.mcap");
    std::fs::write(&torn, &bytes[..bytes.len() * 3 / 5]).unwrap();
    let recovered = dir.join("recovered.mcap");
    let rec = Command::new(&vpsom)
        .args(["trace", "recover"])
        .args([&torn, &recovered])
        .output()
        .unwrap();
    assert!(rec.status.success(), "recover failed:\n{}", text(&rec));
    say(text(&rec).trim_end());
    let started = Instant::now();
    let o = node(
        "trace-check.mjs",
        &[trace.to_str().unwrap(), recovered.to_str().unwrap()],
    )
    .output()
    .unwrap();
    let t = text(&o);
    say(&t
        .lines()
        .filter(|l| !l.starts_with("RESULT "))
        .collect::<Vec<_>>()
        .join("\n"));
    say(&format!(
        "viewer_check: trace-check took {:.1} s",
        started.elapsed().as_secs_f64()
    ));
    assert!(o.status.success(), "trace-check failed:\n{t}");
    let r = result(&o);
    let (full, part) = (&r[0], &r[1]);
    assert_eq!(full["channels"].as_u64(), part["channels"].as_u64());
    let (n_full, n_part) = (
        full["messages"].as_u64().unwrap(),
        part["messages"].as_u64().unwrap(),
    );
    assert!(
        n_part > 0 && n_part < n_full,
        "the recovered trace keeps part of the run: {n_part} of {n_full}"
    );
    assert!(full["images"].as_u64() > Some(0) && part["images"].as_u64() > Some(0));

    // The torn file itself has no index: an indexed reader cannot open it (why `recover` exists).
    let o = node("trace-check.mjs", &[torn.to_str().unwrap()])
        .output()
        .unwrap();
    say(&format!(
        "viewer_check: the torn file itself, before recovery: {}",
        String::from_utf8_lossy(&o.stderr)
            .lines()
            .next()
            .unwrap_or("opened")
    ));
    let _ = std::fs::remove_dir_all(&dir);
}
