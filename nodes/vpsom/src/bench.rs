//! `vpsom bench`: the paper's experiments — scenes × planners × seeds on the lockstep host, in
//! parallel across cores, with a progress bar; one `metrics.json` per run under
//! `DIR/<scene>/<planner>/<seed>/`, then `report.md`, CSV tables and Figure-10 PNGs.

use super::lockstep::{self, SessionSpec};
use crate::config::Config;
use crate::eval;
use crate::sim::Scene;
use crossbeam::channel;
use indicatif::{ProgressBar, ProgressStyle};
use std::path::{Path, PathBuf};
use std::time::Instant;

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
}

/// Run every session and write the report. Returns the per-run outcomes; a failed session is
/// reported (and counted) without stopping the others.
pub fn run_bench(spec: &BenchSpec) -> anyhow::Result<Vec<RunOutcome>> {
    let mut work = Vec::new();
    for scene in &spec.scenes {
        for label in &spec.planners {
            let config = lockstep::config_for(&spec.config, label)?;
            for seed in spec.first_seed..spec.first_seed + spec.seeds {
                work.push(SessionSpec {
                    scene: scene.clone(),
                    config: config.clone(),
                    seed,
                    label: label.clone(),
                    max_sim_s: spec.max_sim_s,
                    record: None,
                });
            }
        }
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
    let outcomes: Vec<RunOutcome> = done_rx.iter().collect();
    eval::report::report_dirs(std::slice::from_ref(&spec.out), &spec.out)?;
    Ok(outcomes)
}

fn run_one(session: &SessionSpec, out: &Path) -> RunOutcome {
    let dir = out
        .join(&session.scene.name)
        .join(&session.label)
        .join(session.seed.to_string());
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
