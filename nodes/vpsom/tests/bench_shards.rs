//! `vpsom bench --shard K/N` and `--resume` (issue 46): the shards partition the run list, merged
//! shard folders give the unsharded bench's metrics and report, a shard writes no report, a
//! resumed bench runs again exactly the runs whose `metrics.json` is missing or torn, and a bench
//! killed halfway and resumed gives the uninterrupted bench's report.

use std::path::{Path, PathBuf};
use std::process::Command;
use vpsom::bench::{RunKey, Shard, ShardError, run_list};

const SCENES: [&str; 3] = ["paper-scene-2", "kitchen-7", "paper-scene-1"];
const PLANNERS: [&str; 3] = ["vpsom", "frontier", "coverage"];

#[test]
fn shards_partition_the_sorted_run_list() {
    let all = run_list(&SCENES, &PLANNERS, 1..5, Shard::ALL);
    assert_eq!(all.len(), 36);
    assert!(all.windows(2).all(|w| w[0] < w[1]), "sorted, no duplicate");
    // The same command line with its flags in another order gives the same list.
    let mut scenes = SCENES;
    scenes.reverse();
    assert_eq!(
        run_list(
            &scenes,
            &["coverage", "vpsom", "frontier"],
            1..5,
            Shard::ALL
        ),
        all
    );
    for n in 1..=7 {
        let parts: Vec<Vec<RunKey>> = (1..=n)
            .map(|k| run_list(&SCENES, &PLANNERS, 1..5, Shard { k, n }))
            .collect();
        let (min, max) = parts.iter().fold((usize::MAX, 0), |(lo, hi), p| {
            (lo.min(p.len()), hi.max(p.len()))
        });
        assert!(max - min <= 1, "N = {n}: shard sizes {min}..{max}");
        let mut union: Vec<RunKey> = parts.concat();
        union.sort();
        assert_eq!(union, all, "N = {n}: every run in exactly one shard");
    }
    // Index modulo N: shard 2/4 takes runs 1, 5, 9, ...
    let second = run_list(&SCENES, &PLANNERS, 1..5, Shard { k: 2, n: 4 });
    assert_eq!(second[0], all[1]);
    assert_eq!(second[1], all[5]);
}

#[test]
fn shard_values_are_checked() {
    assert_eq!("3/4".parse(), Ok(Shard { k: 3, n: 4 }));
    assert_eq!("1/1".parse(), Ok(Shard::ALL));
    assert_eq!(
        "5/4".parse::<Shard>(),
        Err(ShardError::OutOfRange { k: 5, n: 4 })
    );
    assert_eq!(
        "0/4".parse::<Shard>(),
        Err(ShardError::OutOfRange { k: 0, n: 4 })
    );
    assert_eq!("1/0".parse::<Shard>(), Err(ShardError::ZeroParts));
    for bad in ["", "3", "3/", "/4", "a/4", "-1/4", "1/4/2"] {
        assert_eq!(bad.parse::<Shard>(), Err(ShardError::Syntax), "{bad:?}");
    }
    assert_eq!(
        ShardError::OutOfRange { k: 5, n: 4 }.to_string(),
        "K = 5 is not in 1..=4 (K counts from 1, like a Slurm array 1-N)"
    );
    // On the command line, the error names the flag and the value.
    let out = Command::new(env!("CARGO_BIN_EXE_vpsom"))
        .args(["bench", "--shard", "5/4", "--out"])
        .arg(std::env::temp_dir().join("vpsom-shard-never-written"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(
        stderr.contains(
            "invalid value '5/4' for '--shard <K/N>': K = 5 is not in 1..=4 (K counts from 1"
        ),
        "{stderr}"
    );
}

/// A small bench: paper-scene-1 × vpsom, coverage × 2 seeds at 160×120, 20 simulated seconds.
fn bench(config: &Path, out: &Path, extra: &[&str]) -> String {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_vpsom"));
    cmd.arg("bench")
        .arg("--config")
        .arg(config)
        .args(["--scene", "paper-scene-1", "--planner", "vpsom"])
        .args([
            "--planner",
            "coverage",
            "--seeds",
            "2",
            "--jobs",
            "2",
            "--out",
        ])
        .arg(out)
        .args(extra);
    let o = cmd.output().unwrap();
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(o.status.success(), "vpsom bench {extra:?} failed:\n{text}");
    text
}

fn metrics_files(root: &Path) -> Vec<PathBuf> {
    vpsom::eval::find_metrics_files(&[root.to_path_buf()])
        .unwrap()
        .into_iter()
        .map(|f| f.strip_prefix(root).unwrap().to_path_buf())
        .collect()
}

fn read(path: &Path) -> Vec<u8> {
    std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

#[test]
fn merged_shards_equal_the_whole_bench_and_resume_reruns_only_torn_runs() {
    let root = std::env::temp_dir().join(format!("vpsom-bench-shards-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&root);
    std::fs::create_dir_all(&root).unwrap();
    let config = root.join("bench.toml");
    std::fs::write(
        &config,
        "[bench]\ncamera_width = 160\ncamera_height = 120\nmax_sim_s = 20.0\n",
    )
    .unwrap();
    let (whole, shared) = (root.join("whole"), root.join("shared"));
    let (one, two, merged) = (root.join("one"), root.join("two"), root.join("merged"));

    let text = bench(&config, &whole, &[]);
    assert!(text.contains("4 runs in"), "{text}");
    let runs = metrics_files(&whole);
    assert_eq!(runs.len(), 4, "{runs:?}");

    // Two shards into one folder (a cluster's shared file system), then the merge.
    let text = bench(&config, &shared, &["--shard", "1/2"]);
    assert!(text.contains("shard 1/2: 2 runs in"), "{text}");
    assert!(text.contains("no report"), "{text}");
    assert!(!shared.join("report.md").exists(), "a shard wrote a report");
    bench(&config, &shared, &["--shard", "2/2"]);
    // Two shards into their own folders.
    bench(&config, &one, &["--shard", "1/2"]);
    bench(&config, &two, &["--shard", "2/2"]);
    assert_eq!(metrics_files(&one).len() + metrics_files(&two).len(), 4);
    let report = |dirs: &[&Path], out: &Path| {
        let o = Command::new(env!("CARGO_BIN_EXE_vpsom"))
            .arg("report")
            .args(dirs)
            .arg("--out")
            .arg(out)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    };
    report(&[&shared], &shared);
    report(&[&two, &one], &merged);
    assert_eq!(metrics_files(&shared), runs);
    for run in &runs {
        let want = read(&whole.join(run));
        assert_eq!(read(&shared.join(run)), want, "{}", run.display());
        let split = [one.join(run), two.join(run)];
        let got = split.iter().find(|f| f.is_file()).unwrap();
        assert_eq!(read(got), want, "{}", run.display());
    }
    for file in ["report.md", "table1.csv", "table2.csv", "health.csv"] {
        let want = read(&whole.join(file));
        assert_eq!(read(&shared.join(file)), want, "{file}: shared folder");
        assert_eq!(read(&merged.join(file)), want, "{file}: two folders");
    }

    // Resume after a kill: one run torn (half its metrics.json), one never written; the
    // complete runs are kept as they are (their files not rewritten).
    let (torn, missing) = (whole.join(&runs[1]), whole.join(&runs[2]));
    let full = read(&torn);
    std::fs::write(&torn, &full[..full.len() / 2]).unwrap();
    std::fs::remove_file(&missing).unwrap();
    let kept = whole.join(&runs[0]);
    let before = std::fs::metadata(&kept).unwrap().modified().unwrap();
    let text = bench(&config, &whole, &["--resume"]);
    assert!(text.contains("2 run(s) complete"), "{text}");
    assert!(text.contains("4 runs (2 already complete) in"), "{text}");
    assert_eq!(read(&torn), full, "the torn run was run again");
    assert_eq!(read(&missing), read(&shared.join(&runs[2])));
    assert_eq!(
        std::fs::metadata(&kept).unwrap().modified().unwrap(),
        before
    );
    assert_eq!(
        read(&whole.join("table1.csv")),
        read(&shared.join("table1.csv"))
    );
    // No temporary file is left beside a metrics.json.
    for run in &runs {
        let dir = whole.join(run).parent().unwrap().to_path_buf();
        assert!(!dir.join(".metrics.json.tmp").exists(), "{}", dir.display());
    }

    // A bench killed (SIGKILL) once its first run is written, then resumed: the same report.
    let killed = root.join("killed");
    let mut child = Command::new(env!("CARGO_BIN_EXE_vpsom"))
        .arg("bench")
        .arg("--config")
        .arg(&config)
        .args(["--scene", "paper-scene-1", "--planner", "vpsom"])
        .args([
            "--planner",
            "coverage",
            "--seeds",
            "2",
            "--jobs",
            "1",
            "--out",
        ])
        .arg(&killed)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(300);
    while !killed.is_dir() || metrics_files(&killed).is_empty() {
        assert!(std::time::Instant::now() < deadline, "no run finished");
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    let done = metrics_files(&killed).len();
    assert!(done < 4, "the bench finished before the kill");
    let text = bench(&config, &killed, &["--resume"]);
    assert!(text.contains(&format!("{done} run(s) complete")), "{text}");
    assert_eq!(metrics_files(&killed), runs);
    for run in &runs {
        assert_eq!(read(&killed.join(run)), read(&whole.join(run)));
    }
    for file in ["report.md", "table1.csv", "table2.csv", "health.csv"] {
        assert_eq!(read(&killed.join(file)), read(&whole.join(file)), "{file}");
    }
    let _ = std::fs::remove_dir_all(&root);
}
