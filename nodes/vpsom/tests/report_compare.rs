//! `vpsom report --compare A B` on synthetic bench folders: a constant shift of one metric is
//! separated, the same folder or seed noise is not, other seeds pair on room means, and a
//! folder with nothing to pair is named in the error.

use serde_json::json;
use std::path::{Path, PathBuf};
use std::process::Command;
use vpsom::eval::METRICS_FILE;
use vpsom::eval::compare::{COMPARE_FILE, Pairing, compare_dirs};

fn tmp(name: &str) -> PathBuf {
    let d = PathBuf::from(env!("CARGO_TARGET_TMPDIR"))
        .join("report_compare")
        .join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A deterministic noise in [-0.5, 0.5) from (run, salt): SplitMix64's finalizer.
fn noise(i: u64, salt: u64) -> f64 {
    let mut z = (i ^ (salt << 32)).wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    (z >> 11) as f64 / (1u64 << 53) as f64 - 0.5
}

/// Write a bench folder: `scenes` × planner vpsom × seeds, metrics with seed-to-seed spread;
/// `precision_shift` is added to precision, `salt` changes the noise.
fn bench(dir: &Path, scenes: usize, seeds: std::ops::Range<u64>, precision_shift: f64, salt: u64) {
    for s in 0..scenes {
        for seed in seeds.clone() {
            let i = s as u64 * 100 + seed;
            let precision = 0.6 + 0.2 * noise(i, salt) + precision_shift;
            let v = json!({
                "scene": format!("room-{s}"), "planner": "vpsom", "seed": seed,
                "terminated": true, "objects_gt": 10, "objects_estimated": 10,
                "precision": precision, "recall": 0.7 + 0.2 * noise(i, salt + 1),
                "iou": 0.5 + 0.1 * noise(i, salt + 2), "cde_m": 0.08 + 0.02 * noise(i, salt + 3),
                "path_length_m": 40.0 + 5.0 * noise(i, salt + 4), "time_s": 300.0,
                "non_occlusion": 0.5, "localization_failures": 0, "deadline_misses": 0
            });
            let run = dir
                .join(format!("room-{s}"))
                .join("vpsom")
                .join(seed.to_string());
            std::fs::create_dir_all(&run).unwrap();
            std::fs::write(run.join(METRICS_FILE), v.to_string()).unwrap();
        }
    }
}

#[test]
fn a_constant_shift_is_separated_and_nothing_else() {
    let root = tmp("shift");
    let (a, b) = (root.join("a"), root.join("b"));
    bench(&a, 3, 1..5, 0.0, 0);
    bench(&b, 3, 1..5, 0.05, 0);
    let c = compare_dirs(&a, &b).unwrap();
    assert_eq!(c.pairing, Pairing::BySeed);
    assert_eq!((c.runs, c.unpaired), ((12, 12), (0, 0)));
    let (planner, rows) = &c.planners[0];
    assert_eq!(planner, "vpsom");
    for r in rows {
        if r.def.key == "precision" {
            assert_eq!(r.verdict(), "separated: B better");
            assert!((r.diff.ci.mean - 0.05).abs() < 1e-9);
            assert!(r.diff.ci.lo > 0.04 && r.diff.ci.hi < 0.06);
            assert!((r.mean_b - r.mean_a - 0.05).abs() < 1e-9);
        } else {
            assert_eq!(r.verdict(), "within seed spread", "{}", r.def.key);
        }
    }

    // The command line prints the same and writes compare.md where --out says.
    let out = root.join("out");
    let o = Command::new(env!("CARGO_BIN_EXE_vpsom"))
        .args(["report", "--compare"])
        .args([&a, &b])
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let stdout = String::from_utf8(o.stdout).unwrap();
    let md = std::fs::read_to_string(out.join(COMPARE_FILE)).unwrap();
    assert!(stdout.starts_with(&md), "{stdout}");
    assert!(stdout.contains(&format!("comparison: {}", out.join(COMPARE_FILE).display())));
    let line = md.lines().find(|l| l.starts_with("| Precision |")).unwrap();
    assert!(
        line.contains("| +0.050 [+0.050, +0.050] |")
            && line.ends_with("| 12 | **separated: B better** |"),
        "{line}"
    );
    assert_eq!(md.matches("separated:").count(), 1, "{md}");
}

#[test]
fn the_same_folder_or_seed_noise_is_within_seed_spread() {
    let root = tmp("same");
    let (a, b) = (root.join("a"), root.join("b"));
    bench(&a, 3, 1..5, 0.0, 0);
    // Itself: every difference zero.
    let c = compare_dirs(&a, &a).unwrap();
    assert!(c.planners[0].1.iter().all(|r| !r.separated()));
    assert!(c.planners[0].1.iter().all(|r| r.diff.test.p == 1.0));
    // The same seeds with other noise (another code path with the same means).
    bench(&b, 3, 1..5, 0.0, 7);
    let c = compare_dirs(&a, &b).unwrap();
    let rows = &c.planners[0].1;
    assert!(rows.iter().all(|r| !r.separated()), "{}", c.markdown());
    assert!(rows.iter().any(|r| r.diff.ci.mean != 0.0));
}

#[test]
fn other_seeds_pair_on_room_means() {
    let root = tmp("seeds");
    let (a, b) = (root.join("a"), root.join("b"));
    bench(&a, 3, 1..3, 0.0, 0);
    bench(&b, 3, 3..5, 0.5, 0);
    let c = compare_dirs(&a, &b).unwrap();
    assert_eq!(c.pairing, Pairing::ByRoomMean);
    let p = c.planners[0]
        .1
        .iter()
        .find(|r| r.def.key == "precision")
        .unwrap();
    // Three rooms: even a shift of 0.5 in every room cannot reach p < 0.05 (2/2³ = 0.25).
    assert_eq!(p.diff.test.n, 3);
    assert_eq!(p.diff.test.p, 0.25);
    assert_eq!(p.verdict(), "within seed spread");
    let md = c.markdown();
    assert!(md.contains("on each room's mean over its seeds"), "{md}");
    assert!(
        md.contains("With 3 pairs the exact test's smallest p is 0.250"),
        "{md}"
    );
}

#[test]
fn nothing_to_pair_names_the_folder() {
    let root = tmp("empty");
    let (a, b, c) = (root.join("a"), root.join("b"), root.join("c"));
    std::fs::create_dir_all(&a).unwrap();
    bench(&b, 2, 1..3, 0.0, 0);
    let e = compare_dirs(&a, &b).unwrap_err().to_string();
    assert!(
        e.contains(&a.display().to_string()) && e.contains("no run under this folder"),
        "{e}"
    );
    // Other scenes: nothing shares a (scene, planner).
    for (i, entry) in std::fs::read_dir(&b).unwrap().enumerate() {
        let from = entry.unwrap().path();
        let to = c.join(format!("kitchen-{i}"));
        std::fs::create_dir_all(&c).unwrap();
        copy_tree(&from, &to);
    }
    let e = compare_dirs(&b, &c).unwrap_err().to_string();
    assert!(
        e.starts_with(&c.display().to_string())
            && e.contains(&format!("no run pairs with {}", b.display()))
            && e.contains("room-0/vpsom"),
        "{e}"
    );
}

/// Copy a run tree, rewriting nothing (the scene name inside stays that of the source, which
/// is what pairs; so rename it too).
fn copy_tree(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for entry in std::fs::read_dir(from).unwrap() {
        let p = entry.unwrap().path();
        let q = to.join(p.file_name().unwrap());
        if p.is_dir() {
            copy_tree(&p, &q);
        } else {
            let text = std::fs::read_to_string(&p)
                .unwrap()
                .replace("\"room-", "\"kitchen-");
            std::fs::write(q, text).unwrap();
        }
    }
}
