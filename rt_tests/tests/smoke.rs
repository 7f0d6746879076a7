//! CI smoke: `vpsom-rt-tests smoke` runs wakeup (+cyclictest if installed), ipc and e2e --fake
//! for about a second each under the built-in stress load, and writes every report file. No
//! figure is bounded here (the machine may be busy): the reports carry them.

use std::path::Path;
use std::process::Command;

#[test]
fn smoke_writes_every_report_and_the_load_ends_with_the_harness() {
    let out = std::env::temp_dir().join(format!("vpsom-rt-tests-smoke-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    let st = Command::new(env!("CARGO_BIN_EXE_vpsom-rt-tests"))
        .args([
            "--config",
            concat!(env!("CARGO_MANIFEST_DIR"), "/../config/rt_tests.toml"),
        ])
        .arg("--out")
        .arg(&out)
        .arg("smoke")
        .output()
        .expect("run vpsom-rt-tests");
    let stderr = String::from_utf8_lossy(&st.stderr);
    assert!(st.status.success(), "smoke failed: {stderr}");
    for (dir, files) in [
        (
            "wakeup",
            &["report.md", "report.json", "samples.mcap", "wakeup.png"][..],
        ),
        (
            "ipc",
            &[
                "report.md",
                "report.json",
                "samples.mcap",
                "ipc_poll_flat.png",
            ][..],
        ),
        (
            "e2e",
            &["report.md", "report.json", "samples.mcap", "e2e.png"][..],
        ),
    ] {
        for f in files {
            let p = out.join(dir).join(f);
            let len = std::fs::metadata(&p).map(|m| m.len()).unwrap_or(0);
            assert!(len > 0, "{} missing or empty", p.display());
        }
    }
    let json = |dir: &str| -> serde_json::Value {
        let p = out.join(dir).join("report.json");
        serde_json::from_str(&std::fs::read_to_string(&p).unwrap()).unwrap()
    };
    let w = json("wakeup");
    assert_eq!(w["results"]["ours"]["threads"].as_array().unwrap().len(), 2);
    // Counts of work done in a fixed wall time depend on the machine's load, so only "measured
    // something" is asserted; the figures themselves are the report's.
    assert!(w["results"]["ours"]["all"]["count"].as_u64().unwrap() > 0);
    let i = json("ipc");
    let cases = i["results"]["cases"].as_array().unwrap();
    assert_eq!(
        cases.len(),
        32,
        "2 payloads × 2 modes × 2 rates × 2 fills × 2 layers"
    );
    for c in cases {
        assert_eq!(c["lost"], 0, "{c}");
        assert_eq!(c["reordered"], 0, "{c}");
        assert!(c["latency"]["p50"].as_u64().unwrap() > 0, "{c}");
    }
    let e = json("e2e");
    assert!(e["results"]["frame_to_map"]["count"].as_u64().unwrap() > 0);
    assert!(e["results"]["lbv_exec"]["count"].as_u64().unwrap() > 0);
    assert!(e["load"].as_str().unwrap().contains("built-in"));
    // The cyclictest probe ran beside the pipeline, or the report says why it did not.
    let probe = &e["results"]["probe"];
    assert!(
        probe["threads"].as_array().is_some_and(|t| !t.is_empty())
            || probe["error"].as_str().is_some_and(|w| !w.is_empty()),
        "{probe}"
    );
    assert!(e["results"]["lbv_backup_wakes"].is_u64(), "{e}");
    // The stress workers exited with the harness (they are our children's children: none left).
    let ps = Command::new("ps").args(["-eo", "args"]).output().unwrap();
    let me = Path::new(env!("CARGO_BIN_EXE_vpsom-rt-tests"));
    let text = String::from_utf8_lossy(&ps.stdout);
    assert!(
        !text
            .lines()
            .any(|l| l.contains(&*me.to_string_lossy()) && l.contains("stress-worker")),
        "stress worker still running"
    );
    let _ = std::fs::remove_dir_all(&out);
}
