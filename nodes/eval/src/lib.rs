//! Evaluation of a session: map scoring, per-run metrics, `map.json`, the bench report and plots.
//!
//! Everything here is pure library code: hosts (`vpsom run`, `vpsom bench`, `vpsom report`)
//! feed it ground truth, the final [`shm_types::ObjectMap`] and the stream of robot states,
//! planner decisions and deadline events, then write the files it produces.
//!
//! The metric definitions follow `docs/formats.md` § "Metrics" (and the paper's section 7):
//! - [`matching`]: one-to-one same-class assignment of estimated to ground-truth objects
//!   (Hungarian algorithm, see [`matching::assign`] for the exact objective);
//! - [`metrics`]: precision, recall, IoU, CDE of a map ([`score_map`]), the run's
//!   [`Metrics`] (`metrics.json`) and the [`SessionLog`] accumulator;
//! - [`occlusion`]: non-occlusion measured on ground truth (visible fraction of every
//!   foreground object in view, over every rendered frame), [`NonOcclusion`];
//! - [`mapfile`]: `map.json` (write, read, re-score);
//! - [`diagnose`]: where a map goes wrong (every object sorted into one outcome);
//! - [`report`]: Tables 1 and 2 of the paper from many `metrics.json` (`report.md`, CSVs);
//! - [`stats`]: Wilcoxon signed-rank test, Holm correction, bootstrap CIs over rooms (the
//!   report's and [`compare`]'s statistics);
//! - [`compare`]: `vpsom report --compare A B`, paired differences between two bench folders;
//! - [`plot`]: Figure-10-style top-down PNGs;
//! - [`sensing`]: the sensing report (`vpsom sensing`: detector, depth and pose errors per frame).
//!
//! Ground truth enters only through the plain [`GtObject`] type, so `eval` does not depend on
//! the simulator's world types.
//!
//! A host typically does, per run:
//! ```no_run
//! # use eval::*;
//! # fn demo(gt: Vec<GtObject>, map: &shm_types::ObjectMap, room: Room) -> Result<(), EvalError> {
//! let mut log = SessionLog::new();
//! // ... for every true robot state: log.observe_truth(&state);
//! // ... for every planner decision: log.observe_decision(&decision);
//! // ... for every rendered frame:     log.observe_visibility(sim.visibility());
//! // ... for every deadline event:   log.observe_deadline(&event);
//! log.finish(123_000_000_000, true, "all clusters complete");
//! let estimates = estimates_from_map(map);
//! let run = RunInfo { scene: "paper-scene-1".into(), planner: "vpsom".into(), seed: 1 };
//! let metrics = log.metrics(&run, &gt, &estimates, &MatchParams::default());
//! let plot = log.plot_input(&run, room, &gt, &estimates, &metrics);
//! write_run_outputs(std::path::Path::new("out/paper-scene-1/vpsom/1"), &metrics, &estimates, &plot)?;
//! # Ok(()) }
//! ```

pub mod compare;
pub mod diagnose;
pub mod iou;
pub mod mapfile;
pub mod matching;
pub mod metrics;
pub mod occlusion;
pub mod plot;
pub mod report;
pub mod sensing;
pub mod stats;

pub use mapfile::{MapFile, MapFileObject, rescore_map_file};
pub use matching::{MatchParams, ObjectMatch};
pub use metrics::{
    EstObject, GivenUpEntry, GtObject, MapScore, Metrics, NbvKind, ObjectViews, RunInfo,
    SessionLog, estimates_from_map, score_map,
};
pub use occlusion::NonOcclusion;
pub use plot::{PlotInput, Room, ViewPose, render_bench_figures, render_png};
pub use report::{Report, find_metrics_files, load_metrics, write_report};

use std::path::{Path, PathBuf};

/// File name of a run's metrics.
pub const METRICS_FILE: &str = "metrics.json";
/// File name of a run's final map.
pub const MAP_FILE: &str = "map.json";
/// File name of a run's plot input (trajectory, views, maps), read back by the bench report.
pub const PLOT_FILE: &str = "plot.json";
/// File name of a run's top-down figure.
pub const FIGURE_FILE: &str = "map.png";

/// Errors of the evaluation code; each names the file and what went wrong.
#[derive(Debug, thiserror::Error)]
pub enum EvalError {
    /// A file or directory could not be read or written.
    #[error("{path}: {source}")]
    Io {
        /// The file or directory.
        path: PathBuf,
        /// The OS error.
        source: std::io::Error,
    },
    /// A JSON file could not be parsed or written.
    #[error("{path}: {source}")]
    Json {
        /// The file.
        path: PathBuf,
        /// The parser error (with line and column).
        source: serde_json::Error,
    },
    /// A file parsed but holds an invalid value.
    #[error("{path}: {field}: {reason}")]
    Invalid {
        /// The file.
        path: PathBuf,
        /// The offending field, e.g. `objects[3].size`.
        field: String,
        /// Why it is invalid.
        reason: String,
    },
    /// A figure could not be drawn or encoded.
    #[error("{path}: plotting failed: {reason}")]
    Plot {
        /// The output file.
        path: PathBuf,
        /// The backend's message.
        reason: String,
    },
}

impl EvalError {
    pub(crate) fn io(path: &Path, source: std::io::Error) -> Self {
        EvalError::Io {
            path: path.to_path_buf(),
            source,
        }
    }

    pub(crate) fn json(path: &Path, source: serde_json::Error) -> Self {
        EvalError::Json {
            path: path.to_path_buf(),
            source,
        }
    }
}

/// Write `value` as pretty JSON to `path` (creating parent directories).
pub(crate) fn write_json<T: serde::Serialize>(path: &Path, value: &T) -> Result<(), EvalError> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|e| EvalError::io(dir, e))?;
    }
    let mut text = serde_json::to_string_pretty(value).map_err(|e| EvalError::json(path, e))?;
    text.push('\n');
    std::fs::write(path, text).map_err(|e| EvalError::io(path, e))
}

/// Read and parse a JSON file.
pub(crate) fn read_json<T: serde::de::DeserializeOwned>(path: &Path) -> Result<T, EvalError> {
    let text = std::fs::read_to_string(path).map_err(|e| EvalError::io(path, e))?;
    serde_json::from_str(&text).map_err(|e| EvalError::json(path, e))
}

/// Write everything a run leaves behind into `dir`: `map.json`, `plot.json`, the figure
/// `map.png`, and last `metrics.json`, atomically ([`write_metrics`]). Creates `dir`. A
/// `metrics.json` that parses therefore means the run's other files are written too (what
/// `vpsom bench --resume` relies on).
pub fn write_run_outputs(
    dir: &Path,
    metrics: &Metrics,
    estimates: &[EstObject],
    plot: &PlotInput,
) -> Result<(), EvalError> {
    MapFile::from_estimates(&metrics.scene, estimates).write(&dir.join(MAP_FILE))?;
    write_json(&dir.join(PLOT_FILE), plot)?;
    render_png(plot, &dir.join(FIGURE_FILE), plot::RUN_FIGURE_SIZE)?;
    write_metrics(dir, metrics)
}

/// Write `dir/metrics.json` atomically: into `dir/.metrics.json.tmp` (a name the report does
/// not collect), synced, then renamed over `metrics.json`. A process killed at any point leaves
/// either the old file, no file, or the whole new one, never a torn `metrics.json`.
pub fn write_metrics(dir: &Path, metrics: &Metrics) -> Result<(), EvalError> {
    use std::io::Write as _;
    std::fs::create_dir_all(dir).map_err(|e| EvalError::io(dir, e))?;
    let path = dir.join(METRICS_FILE);
    let tmp = dir.join(format!(".{METRICS_FILE}.tmp"));
    let mut text = serde_json::to_string_pretty(metrics).map_err(|e| EvalError::json(&path, e))?;
    text.push('\n');
    let mut f = std::fs::File::create(&tmp).map_err(|e| EvalError::io(&tmp, e))?;
    f.write_all(text.as_bytes())
        .and_then(|()| f.sync_all())
        .map_err(|e| EvalError::io(&tmp, e))?;
    std::fs::rename(&tmp, &path).map_err(|e| EvalError::io(&path, e))
}

/// Read `dir/metrics.json` if it is complete: present and parsing fully as [`Metrics`]. `None`
/// for a missing, torn or otherwise unreadable file.
pub fn read_complete_metrics(dir: &Path) -> Option<Metrics> {
    read_json(&dir.join(METRICS_FILE)).ok()
}
