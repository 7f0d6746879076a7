//! `vpsom run` as a user runs it: separate processes over iceoryx2 on the real clock. The session
//! terminates with every process exited, writes metrics.json and a readable MCAP, leaves no
//! services behind, and maps as well as the lockstep host does on the same scene.

use std::io::Write as _;
use std::path::Path;
use std::process::Command;

fn vpsom(args: &[&str]) -> std::process::Output {
    let out = Command::new(env!("CARGO_BIN_EXE_vpsom"))
        .args(args)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "vpsom {args:?} failed:\n{}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

fn metrics(dir: &Path) -> serde_json::Value {
    let text = std::fs::read_to_string(dir.join("metrics.json")).unwrap();
    serde_json::from_str(&text).unwrap()
}

#[test]
fn multi_process_run_terminates_and_matches_lockstep_quality() {
    let root = std::env::temp_dir().join(format!("vpsom-run-{}", std::process::id()));
    let (live, lock) = (root.join("live"), root.join("lockstep"));
    let ns = format!("test{}", std::process::id());
    // Under GBV load (the pool kept busy with extra evaluations), planning rounds must still
    // get through and end the session.
    // Ideal sensing: this compares the hosts, not the sensing (see config/sensing-ideal.toml).
    let ideal = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../config/sensing-ideal.toml"
    );
    let run = vpsom(&[
        "run",
        "--config",
        ideal,
        "--ns",
        &ns,
        "--out",
        live.to_str().unwrap(),
        "--gbv-load",
        "300",
    ]);
    let stderr = String::from_utf8_lossy(&run.stderr);
    let load_jobs: u64 = stderr
        .split("GBV load: ")
        .nth(1)
        .and_then(|s| s.split_whitespace().next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no GBV load report:\n{stderr}"));
    assert!(
        load_jobs > 10,
        "the load did not run: {load_jobs} jobs\n{stderr}"
    );
    for node in ["recorder", "sim", "mapper", "planner"] {
        assert!(
            stderr.contains(&format!("{node}: exit code 0")),
            "{node} did not exit 0:\n{stderr}"
        );
    }
    let m = metrics(&live);
    // The planner ended the session itself (section 3.4 termination, or no reachable candidate
    // left), not a time limit, an interruption or a node failure.
    let reason = m["termination_reason"].as_str().unwrap();
    assert!(reason.starts_with("planner"), "{m}");
    assert!(live.join("map.json").is_file() && live.join("map.png").is_file());
    let info = runtime::recorder::inspect::info(&live.join("trace.mcap")).unwrap();
    assert!(info.end.complete, "{info}");
    assert!(
        info.count("/camera/depth") > 10 && info.count("/map/objects") > 5,
        "{info}"
    );
    assert!(
        runtime::ports::list_services(&ns).unwrap().is_empty(),
        "services left behind"
    );
    // The live trace replays exactly: following the maps' frame receipts, a fresh mapper
    // reproduces every recorded map bit for bit.
    let trace = live.join("trace.mcap");
    let check = Command::new(env!("CARGO_BIN_EXE_vpsom"))
        .args(["replay", "--config", ideal, "--check"])
        .arg(&trace)
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&check.stdout);
    let (identical, maps): (u64, u64) = text
        .split("live trace: ")
        .nth(1)
        .and_then(|s| {
            let mut w = s.split_whitespace();
            Some((w.next()?.parse().ok()?, w.nth(1)?.parse().ok()?))
        })
        .unwrap_or_else(|| {
            panic!(
                "no live-trace check:\n{text}\n{}",
                String::from_utf8_lossy(&check.stderr)
            )
        });
    assert_eq!(maps, info.count("/map/objects"), "{text}");
    let dropped: u64 = text
        .split(" messages dropped by the recorder")
        .next()
        .and_then(|s| s.rsplit(' ').next()?.parse().ok())
        .unwrap_or_else(|| panic!("no drop count:\n{text}"));
    if dropped == 0 {
        assert_eq!(identical, maps, "{text}");
        assert!(check.status.success(), "{text}");
    } else {
        // A recorder that lost messages under load: the maps after a lost input differ, so
        // their exactness cannot be checked. Said on the real stderr (not captured by the
        // test harness), so the skip shows in every test log; VPSOM_RECORDER_EXACT=required
        // turns it into a failure.
        assert!(
            std::env::var("VPSOM_RECORDER_EXACT").as_deref() != Ok("required"),
            "VPSOM_RECORDER_EXACT=required, but the recorder dropped {dropped} messages\n{text}"
        );
        let _ = writeln!(
            std::io::stderr(),
            "SKIPPED run_process: the exactness of the live check (the recorder dropped \
             {dropped} messages under load; {identical} of {maps} maps identical)"
        );
    }

    vpsom(&[
        "run",
        "--config",
        ideal,
        "--lockstep",
        "--out",
        lock.to_str().unwrap(),
    ]);
    let l = metrics(&lock);
    assert_eq!(m["recall"], l["recall"], "live {m}\nlockstep {l}");
    // Both hosts measure non-occlusion on ground truth (the live one through `sim/visibility`).
    for v in [&m, &l] {
        let n = v["non_occlusion"].as_f64().unwrap_or(0.0);
        assert!(n > 0.0 && n <= 1.0, "live {m}\nlockstep {l}");
        assert!(v["non_occlusion_samples"].as_u64().unwrap_or(0) > 0, "{v}");
    }
    let cde = |v: &serde_json::Value| v["cde_m"].as_f64().unwrap();
    // Live timing differs from lockstep, so the paths differ too (a single session's CDE ranges
    // ~0.006–0.04 m over seeds on this scene): both must reach the same quality band.
    assert!(cde(&m) < 0.05 && cde(&l) < 0.05, "live {m}\nlockstep {l}");
    let _ = std::fs::remove_dir_all(&root);
}
