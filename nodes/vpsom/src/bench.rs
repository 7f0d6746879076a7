//! `vpsom bench`: the paper's experiments — scenes × planners × seeds on the lockstep host, in
//! parallel across cores, with a progress bar; one `metrics.json` per run under
//! `DIR/<scene>/<planner>/<seed>/`, then `report.md`, CSV tables and Figure-10 PNGs.
//!
//! Sharded and resumable (issue 46): the run list, sorted by (scene, planner, seed), is split
//! by [`Shard`] (`--shard K/N` takes the runs whose index modulo N is K − 1), and with
//! `resume` a run whose `metrics.json` is complete ([`eval::read_complete_metrics`]; it is
//! written last and atomically) is not run again. A shard writes no report: it would cover 1/N
//! of the runs; `vpsom report DIR...` merges the shards' folders (docs/cluster.md).

use super::lockstep::{self, SessionSpec};
use crate::config::Config;
use crate::eval;
use crate::sim::Scene;
use crossbeam::channel;
use indicatif::{ProgressBar, ProgressStyle};
use std::fmt;
use std::path::{Path, PathBuf};
use std::str::FromStr;
use std::time::Instant;

/// One of N equal parts of a bench's run list: `--shard K/N`, K in 1..=N.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Shard {
    /// This part, 1-based (a Slurm array's task id `1..=N`).
    pub k: usize,
    /// The number of parts.
    pub n: usize,
}

impl Shard {
    /// The whole list.
    pub const ALL: Shard = Shard { k: 1, n: 1 };

    /// Whether the run at `index` of the sorted run list belongs to this shard.
    pub fn contains(&self, index: usize) -> bool {
        index % self.n == self.k - 1
    }
}

impl fmt::Display for Shard {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}/{}", self.k, self.n)
    }
}

/// Why a `--shard` value was refused (clap prints `invalid value 'VALUE' for '--shard <K/N>': `
/// before it).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ShardError {
    /// Not two integers separated by `/`.
    #[error("expected K/N, two integers with 1 <= K <= N (e.g. 2/4)")]
    Syntax,
    /// N is 0.
    #[error("N = 0: there must be at least one shard")]
    ZeroParts,
    /// K is outside 1..=N.
    #[error("K = {k} is not in 1..={n} (K counts from 1, like a Slurm array 1-N)")]
    OutOfRange {
        /// The part asked for.
        k: usize,
        /// The number of parts.
        n: usize,
    },
}

impl FromStr for Shard {
    type Err = ShardError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let (k, n) = s
            .split_once('/')
            .and_then(|(k, n)| Some((k.trim().parse().ok()?, n.trim().parse().ok()?)))
            .ok_or(ShardError::Syntax)?;
        match (k, n) {
            (_, 0) => Err(ShardError::ZeroParts),
            (k, n) if k == 0 || k > n => Err(ShardError::OutOfRange { k, n }),
            (k, n) => Ok(Shard { k, n }),
        }
    }
}

/// One run of the list: what [`run_list`] orders and [`Shard`] splits.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord)]
pub struct RunKey {
    /// Scene name.
    pub scene: String,
    /// Planner label.
    pub planner: String,
    /// Seed.
    pub seed: u64,
}

impl RunKey {
    /// The run's folder under the bench directory: `<scene>/<planner>/<seed>`.
    pub fn dir(&self, out: &Path) -> PathBuf {
        out.join(&self.scene)
            .join(&self.planner)
            .join(self.seed.to_string())
    }
}

/// The bench's run list, sorted by (scene, planner, seed) and deduplicated, so that every shard
/// of the same command line computes the same list whatever order its flags came in; then the
/// runs of `shard`.
pub fn run_list(
    scenes: &[&str],
    planners: &[&str],
    seeds: std::ops::Range<u64>,
    shard: Shard,
) -> Vec<RunKey> {
    let mut all: Vec<RunKey> = scenes
        .iter()
        .flat_map(|scene| {
            let seeds = seeds.clone();
            planners.iter().flat_map(move |planner| {
                seeds.clone().map(move |seed| RunKey {
                    scene: scene.to_string(),
                    planner: planner.to_string(),
                    seed,
                })
            })
        })
        .collect();
    all.sort();
    all.dedup();
    all.into_iter()
        .enumerate()
        .filter(|(i, _)| shard.contains(*i))
        .map(|(_, r)| r)
        .collect()
}

/// The metrics of a run already done: its `metrics.json` is complete and names this run.
pub fn completed(key: &RunKey, out: &Path) -> Option<eval::Metrics> {
    eval::read_complete_metrics(&key.dir(out))
        .filter(|m| m.scene == key.scene && m.planner == key.planner && m.seed == key.seed)
}

/// What to run.
#[derive(Debug, Clone)]
pub struct BenchSpec {
    /// Scenes.
    pub scenes: Vec<Scene>,
    /// Planner labels (`vpsom`, `coverage`, `frontier`, `vpsom-no-<term>`).
    pub planners: Vec<String>,
    /// Seeds per scene and planner.
    pub seeds: u64,
    /// The first seed: runs use `first_seed..first_seed + seeds`.
    pub first_seed: u64,
    /// Sessions run at once.
    pub jobs: usize,
    /// Output directory.
    pub out: PathBuf,
    /// Configuration (camera and rates as the bench uses them).
    pub config: Config,
    /// Simulated-time limit per session, seconds.
    pub max_sim_s: f64,
    /// The part of the run list to run ([`Shard::ALL`]: every run, and the report).
    pub shard: Shard,
    /// Skip runs whose `metrics.json` is complete ([`completed`]).
    pub resume: bool,
}

/// One finished run.
#[derive(Debug)]
pub struct RunOutcome {
    /// Where its outputs are.
    pub dir: PathBuf,
    /// Its metrics, or why it failed.
    pub result: Result<eval::Metrics, String>,
    /// Wall time, seconds.
    pub wall_s: f64,
    /// Not run: its complete `metrics.json` was found (`resume`).
    pub resumed: bool,
}

/// Run every session of the spec's shard and, unsharded, write the report over the whole output
/// directory. Returns the per-run outcomes (with `resume`, the runs found complete first); a
/// failed session is reported (and counted) without stopping the others.
pub fn run_bench(spec: &BenchSpec) -> anyhow::Result<Vec<RunOutcome>> {
    let scenes: Vec<&str> = spec.scenes.iter().map(|s| s.name.as_str()).collect();
    let planners: Vec<&str> = spec.planners.iter().map(String::as_str).collect();
    let mut configs = std::collections::BTreeMap::new();
    for label in &spec.planners {
        configs.insert(label.as_str(), lockstep::config_for(&spec.config, label)?);
    }
    let mut work = Vec::new();
    let mut outcomes = Vec::new();
    for key in run_list(
        &scenes,
        &planners,
        spec.first_seed..spec.first_seed + spec.seeds,
        spec.shard,
    ) {
        if spec.resume
            && let Some(m) = completed(&key, &spec.out)
        {
            outcomes.push(RunOutcome {
                dir: key.dir(&spec.out),
                result: Ok(m),
                wall_s: 0.0,
                resumed: true,
            });
            continue;
        }
        let scene = spec
            .scenes
            .iter()
            .find(|s| s.name == key.scene)
            .expect("the run list is built from these scenes");
        work.push(SessionSpec {
            scene: scene.clone(),
            config: configs[key.planner.as_str()].clone(),
            seed: key.seed,
            label: key.planner,
            max_sim_s: spec.max_sim_s,
            record: None,
        });
    }
    if !outcomes.is_empty() {
        eprintln!(
            "vpsom bench --resume: {} run(s) complete in {}, {} to run",
            outcomes.len(),
            spec.out.display(),
            work.len()
        );
    }
    let bar = ProgressBar::new(work.len() as u64);
    bar.set_style(
        ProgressStyle::with_template("{elapsed_precise} [{bar:30}] {pos}/{len} runs  {msg}")
            .expect("valid template")
            .progress_chars("=> "),
    );
    let (tx, rx) = channel::bounded::<SessionSpec>(work.len());
    for w in work {
        tx.send(w).expect("channel sized for all work");
    }
    drop(tx);
    let (done_tx, done_rx) = channel::unbounded::<RunOutcome>();
    std::thread::scope(|s| {
        for i in 0..spec.jobs.max(1) {
            let (rx, done_tx, bar, out) = (rx.clone(), done_tx.clone(), bar.clone(), &spec.out);
            std::thread::Builder::new()
                .name(format!("bench-{i}"))
                .spawn_scoped(s, move || {
                    for session in rx.iter() {
                        let outcome = run_one(&session, out);
                        bar.set_message(format!(
                            "{}/{}/{} {}",
                            session.scene.name,
                            session.label,
                            session.seed,
                            match &outcome.result {
                                Ok(m) => format!("P {:.2} R {:.2}", m.precision, m.recall),
                                Err(e) => format!("FAILED: {e}"),
                            }
                        ));
                        bar.inc(1);
                        if done_tx.send(outcome).is_err() {
                            return;
                        }
                    }
                })
                .expect("spawn bench worker");
        }
    });
    drop(done_tx);
    bar.finish();
    outcomes.extend(done_rx.iter());
    if spec.shard == Shard::ALL {
        eval::report::report_dirs(std::slice::from_ref(&spec.out), &spec.out)?;
    }
    Ok(outcomes)
}

fn run_one(session: &SessionSpec, out: &Path) -> RunOutcome {
    let dir = RunKey {
        scene: session.scene.name.clone(),
        planner: session.label.clone(),
        seed: session.seed,
    }
    .dir(out);
    let start = Instant::now();
    let result = lockstep::run_session(session, |_| {})
        .and_then(|r| {
            lockstep::write_outputs(session, &r, &dir)?;
            Ok(r.metrics)
        })
        .map_err(|e| format!("{e:#}"));
    RunOutcome {
        dir,
        result,
        wall_s: start.elapsed().as_secs_f64(),
        resumed: false,
    }
}

/// The table `--sensitivity` writes into the output directory.
pub const SENSITIVITY_FILE: &str = "sensitivity.md";

/// The table `--pose-ablation` writes into the output directory (same columns as
/// [`sensitivity_table`]; the deltas are against the default pose errors).
pub const POSE_ABLATION_FILE: &str = "pose-ablation.md";

/// Mean P, R, IoU and CDE per label over the finished runs, and each `<planner>@<variant>`
/// label's change from its `<planner>` (Markdown).
pub fn sensitivity_table(outcomes: &[RunOutcome]) -> String {
    use std::collections::BTreeMap;
    let mut sums: BTreeMap<&str, [f64; 6]> = BTreeMap::new();
    for m in outcomes.iter().filter_map(|o| o.result.as_ref().ok()) {
        let s = sums.entry(m.planner.as_str()).or_default();
        s[0] += m.precision;
        s[1] += m.recall;
        if let (Some(iou), Some(cde)) = (m.iou, m.cde_m) {
            s[2] += iou;
            s[3] += cde;
            s[4] += 1.0;
        }
        s[5] += 1.0;
    }
    let mean = |s: &[f64; 6]| {
        let (n, k) = (s[5].max(1.0), s[4].max(1.0));
        [s[0] / n, s[1] / n, s[2] / k, s[3] / k]
    };
    let mut out = String::from(
        "| planner | sensing | runs | P | R | IoU | CDE (m) | ΔP | ΔR | ΔIoU | ΔCDE (m) |\n\
         |---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for (label, s) in &sums {
        let (planner, variant) = label.split_once('@').unwrap_or((label, "default"));
        let m = mean(s);
        let d = match (variant, sums.get(planner)) {
            ("default", _) | (_, None) => "| | | | |".to_string(),
            (_, Some(b)) => {
                let b = mean(b);
                format!(
                    "| {:+.3} | {:+.3} | {:+.3} | {:+.4} |",
                    m[0] - b[0],
                    m[1] - b[1],
                    m[2] - b[2],
                    m[3] - b[3]
                )
            }
        };
        out += &format!(
            "| {planner} | {variant} | {} | {:.3} | {:.3} | {:.3} | {:.4} {d}\n",
            s[5], m[0], m[1], m[2], m[3]
        );
    }
    out
}
