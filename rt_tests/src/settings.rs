//! `config/rt_tests.toml`: budgets and the defaults of every subcommand (flags override them).

use runtime::config::{Checker, ConfigError, Defaults, key, ranges};
use runtime::executor::{ExecutorConfig, SchedPolicy};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The built-in `config/rt_tests.toml`: the one statement of every default below (a file given
/// with `--config` is merged over it, key by key).
pub static RT_DEFAULTS: Defaults = Defaults::new(
    "config/rt_tests.toml",
    include_str!("../../config/rt_tests.toml"),
);

/// The whole file.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Settings {
    /// `[budgets]`.
    pub budgets: Budgets,
    /// `[wakeup]`.
    pub wakeup: WakeupSettings,
    /// `[ipc]`.
    pub ipc: IpcSettings,
    /// `[e2e]`.
    pub e2e: E2eSettings,
    /// `[stress]`.
    pub stress: StressSettings,
}

/// `[budgets]`: limits checked by `--check`.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Budgets {
    /// Wake-up lateness p99 of every executor thread, µs.
    pub wakeup_p99_us: f64,
    /// Our p99 and max over cyclictest's (with `--compare-cyclictest`).
    pub wakeup_vs_cyclictest: f64,
    /// One-way port latency p99 at a paced rate (every payload and mode), µs.
    pub ipc_p99_us: f64,
    /// Our ports' p50 over raw iceoryx2's p50, per case.
    pub ipc_overhead_p50: f64,
    /// Zero-copy flatness: p50 of the largest payload over the 8 KiB p50, minus 1.
    pub ipc_flatness: f64,
    /// LBV execution time p99, ms.
    pub lbv_exec_p99_ms: f64,
    /// LBV deadline misses allowed over the run.
    pub lbv_deadline_misses: u64,
    /// Frame → map and frame → LBV latency p99, ms.
    pub e2e_p99_ms: f64,
    /// Soak: RSS growth of every process after the warm-up, %.
    pub soak_rss_growth_pct: f64,
}

impl Default for Budgets {
    /// The `[budgets]` section of the built-in `config/rt_tests.toml`.
    fn default() -> Self {
        RT_DEFAULTS.section("budgets")
    }
}

impl Budgets {
    /// Range-check; `c` is at this table.
    fn validate(&self, c: &Checker) -> Result<(), ConfigError> {
        ranges!(c, self, {
            wakeup_p99_us: positive,
            wakeup_vs_cyclictest: in_range(0.1, 100.0),
            ipc_p99_us: positive,
            ipc_overhead_p50: in_range(0.1, 100.0),
            ipc_flatness: in_range(0.0, 100.0),
            [lbv_exec_p99_ms, e2e_p99_ms, soak_rss_growth_pct]: positive,
        });
        Ok(())
    }
}

/// Scheduling of a measuring thread.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Sched {
    /// `"fifo"` or `"other"`.
    pub policy: String,
    /// `SCHED_FIFO` priority, 1..=98.
    pub priority: i32,
    /// CPUs to pin to; empty = any.
    pub cpus: Vec<usize>,
    /// Lock memory when FIFO is granted.
    pub mlockall: bool,
}

impl Default for Sched {
    /// The `[wakeup.sched]` section of the built-in `config/rt_tests.toml` (the harness's
    /// default scheduling; `[ipc.sched]` states its own).
    fn default() -> Self {
        RT_DEFAULTS.section("wakeup.sched")
    }
}

impl Sched {
    /// An executor config with this scheduling and `spin_margin_us`.
    pub fn executor_config(&self, spin_margin_us: u64) -> ExecutorConfig {
        ExecutorConfig {
            policy: if self.policy == "other" {
                SchedPolicy::Other
            } else {
                SchedPolicy::Fifo
            },
            priority: self.priority,
            nice: 0,
            mlockall: self.mlockall,
            cpus: self.cpus.clone(),
            spin_margin_us,
            ..ExecutorConfig::default()
        }
    }

    /// Range-check; `c` is at this table (`wakeup.sched`, `ipc.sched`).
    fn validate(&self, c: &Checker) -> Result<(), ConfigError> {
        ranges!(c, self, {
            policy: require(
                self.policy == "fifo" || self.policy == "other",
                "must be \"fifo\" or \"other\"",
            ),
            priority: within(1, 98),
        });
        for &cpu in &self.cpus {
            c.require(cpu < 1024, &key!(c, cpus), cpu, "must be below 1024")?;
        }
        Ok(())
    }
}

/// `[wakeup]`.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WakeupSettings {
    /// Periodic threads.
    pub threads: usize,
    /// Period of thread 0, µs.
    pub period_us: u64,
    /// Thread k's period is `period_us + k · distance_us` (cyclictest's `-d`).
    pub distance_us: u64,
    /// Run time, s.
    pub duration_s: f64,
    /// Spin margin of the executor, µs (0 = pure sleep, as cyclictest).
    pub spin_margin_us: u64,
    /// cyclictest histogram range, µs (`-h`).
    pub hist_max_us: u64,
    /// Scheduling (thread k is pinned to `cpus[k % len]`).
    pub sched: Sched,
}

impl Default for WakeupSettings {
    /// The `[wakeup]` section of the built-in `config/rt_tests.toml`.
    fn default() -> Self {
        RT_DEFAULTS.section("wakeup")
    }
}

impl WakeupSettings {
    /// Range-check; `c` is at this table.
    fn validate(&self, c: &Checker) -> Result<(), ConfigError> {
        ranges!(c, self, {
            threads: count(1, 64),
            period_us: within(50, 1_000_000),
            distance_us: within(0, 1_000_000),
            duration_s: in_range(0.1, 86_400.0),
            spin_margin_us: within(0, 100_000),
            hist_max_us: within(10, 1_000_000),
            sched: section,
        });
        Ok(())
    }
}

/// `[ipc]`.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IpcSettings {
    /// Payloads: any of `"64B"`, `"8KiB"`, `"600KiB"`, `"4MiB"`.
    pub payloads: Vec<String>,
    /// Receive modes: `"poll"` (busy-poll) and/or `"event"` (woken by the paired event).
    pub modes: Vec<String>,
    /// Publish rates, Hz; 0 = flat out.
    pub rates_hz: Vec<f64>,
    /// How the publisher prepares each loan: `"zero"` (zero-filled, `Publisher::loan`) and/or
    /// `"reuse"` (as it is, `Publisher::loan_reused`).
    pub fills: Vec<String>,
    /// Messages per paced case = rate · this, s.
    pub paced_duration_s: f64,
    /// Messages per flat-out case.
    pub flat_messages: u64,
    /// Messages per flat-out case of `ipc --layer link` (the tunnel and plain zenoh).
    pub link_flat_messages: u64,
    /// Every case's messages are split into this many rounds, each running all cases in turn.
    pub rounds: u32,
    /// Unmeasured messages sent first (connection set-up).
    pub warmup_messages: u64,
    /// Subscriber buffer (backpressure: nothing is dropped).
    pub subscriber_buffer: usize,
    /// Also measure raw iceoryx2 (no runtime layer).
    pub raw: bool,
    /// Receiver scheduling.
    pub sched: Sched,
    /// Publisher (child process) CPUs; empty = any.
    pub publisher_cpus: Vec<usize>,
}

impl Default for IpcSettings {
    /// The `[ipc]` section of the built-in `config/rt_tests.toml`.
    fn default() -> Self {
        RT_DEFAULTS.section("ipc")
    }
}

impl IpcSettings {
    /// Range-check; `c` is at this table.
    fn validate(&self, c: &Checker) -> Result<(), ConfigError> {
        one_of(c, &key!(c, payloads), &self.payloads, &PAYLOADS)?;
        one_of(c, &key!(c, modes), &self.modes, &["poll", "event"])?;
        one_of(c, &key!(c, fills), &self.fills, &["zero", "reuse"])?;
        for &r in &self.rates_hz {
            c.in_range(&key!(c, rates_hz), r, 0.0, 100_000.0)?;
        }
        ranges!(c, self, {
            paced_duration_s: in_range(0.05, 86_400.0),
            flat_messages: within(1, 10_000_000),
            link_flat_messages: within(1, 1_000_000),
            rounds: within(1, 1000),
            warmup_messages: within(0, 1000),
            subscriber_buffer: count(1, 64),
            sched: section,
        });
        Ok(())
    }
}

/// The payload names `ipc` knows.
pub const PAYLOADS: [&str; 4] = ["64B", "8KiB", "600KiB", "4MiB"];

/// `[e2e]`.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct E2eSettings {
    /// Measured time, s (after the warm-up).
    pub duration_s: f64,
    /// Ignored start-up time, s.
    pub warmup_s: f64,
    /// `vpsom run --time-scale`.
    pub time_scale: f64,
    /// Path of the `vpsom` binary; empty = next to this executable.
    pub vpsom: String,
    /// Pipeline configuration (its `[ports]` must match the run's); empty = built-in.
    pub pipeline_config: String,
    /// Extra arguments passed to `vpsom run` (e.g. `["--scene", "f.toml"]`).
    pub run_args: Vec<String>,
    /// Run cyclictest beside the pipeline (one thread per CPU at the LBV's priority) as a
    /// probe of the platform's own wake-ups over the same time.
    pub probe: bool,
    /// Soak report: a row (LBV misses, GBV rounds, RSS per process) every this many measured
    /// seconds; 0 = none (`vpsom-rt-tests soak` sets 60).
    pub report_every_s: f64,
    /// Soak: RSS growth is computed over the rows after this much measured time, s.
    pub rss_warmup_s: f64,
}

impl Default for E2eSettings {
    /// The `[e2e]` section of the built-in `config/rt_tests.toml`.
    fn default() -> Self {
        RT_DEFAULTS.section("e2e")
    }
}

impl E2eSettings {
    /// Range-check; `c` is at this table.
    fn validate(&self, c: &Checker) -> Result<(), ConfigError> {
        ranges!(c, self, {
            duration_s: in_range(0.1, 86_400.0),
            warmup_s: in_range(0.0, 600.0),
            time_scale: in_range(0.01, 100.0),
            [report_every_s, rss_warmup_s]: in_range(0.0, 86_400.0),
        });
        Ok(())
    }
}

/// `[stress]`.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StressSettings {
    /// CPU busy-loop workers; 0 = one per online CPU.
    pub cpu_workers: usize,
    /// Memory touched continuously, MB (0 = none).
    pub memory_mb: usize,
    /// Use `stress-ng` when it is installed.
    pub use_stress_ng: bool,
}

impl Default for StressSettings {
    /// The `[stress]` section of the built-in `config/rt_tests.toml`.
    fn default() -> Self {
        RT_DEFAULTS.section("stress")
    }
}

impl StressSettings {
    /// Range-check; `c` is at this table.
    fn validate(&self, c: &Checker) -> Result<(), ConfigError> {
        ranges!(c, self, {
            cpu_workers: count(0, 1024),
            memory_mb: count(0, 1 << 20),
        });
        Ok(())
    }
}

impl Default for Settings {
    /// The built-in `config/rt_tests.toml`.
    fn default() -> Self {
        RT_DEFAULTS.section("")
    }
}

impl Settings {
    /// Load `file` (merged over the built-in defaults), or the built-in defaults when `file` is `None` and `config/rt_tests.toml`
    /// does not exist.
    pub fn load(file: Option<&Path>) -> Result<(Self, Option<PathBuf>), ConfigError> {
        let path = match file {
            Some(p) => Some(p.to_path_buf()),
            None => {
                let p = PathBuf::from("config/rt_tests.toml");
                p.exists().then_some(p)
            }
        };
        let s = match &path {
            Some(p) => RT_DEFAULTS.load::<Self>(p)?,
            None => Self::default(),
        };
        s.validate(&Checker::new(
            path.clone().unwrap_or_else(|| "<built-in>".into()),
        ))?;
        Ok((s, path))
    }

    /// Range-check every section.
    pub fn validate(&self, c: &Checker) -> Result<(), ConfigError> {
        ranges!(c, self, {
            [budgets, wakeup, ipc, e2e, stress]: section,
        });
        Ok(())
    }
}

/// `Ok` if every entry of the list `key` is one of `allowed`.
fn one_of(c: &Checker, key: &str, values: &[String], allowed: &[&str]) -> Result<(), ConfigError> {
    for v in values {
        c.require(
            allowed.contains(&v.as_str()),
            key,
            v,
            &format!("must be one of {}", allowed.join(", ")),
        )?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shipped_file_loads_partial_files_merge_and_bad_values_name_the_key() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../config/rt_tests.toml");
        let (shipped, _) = Settings::load(Some(&path)).unwrap();
        assert_eq!(shipped.ipc.sched.priority, 70);
        assert_eq!(Sched::default().priority, shipped.wakeup.sched.priority);
        let f = Path::new("x.toml");
        let partial: Settings = RT_DEFAULTS
            .parse(f, "[ipc.sched]\npriority = 60\n")
            .unwrap();
        assert_eq!(partial.ipc.sched.priority, 60);
        assert_eq!(partial.ipc.sched.policy, "fifo");
        assert_eq!(partial.wakeup.period_us, shipped.wakeup.period_us);
        let e = RT_DEFAULTS
            .parse::<Settings>(f, "[wakeup]\nperiod = 3\n")
            .unwrap_err();
        assert_eq!(e.key(), "wakeup.period", "{e}");
        assert!(
            e.to_string().starts_with("x.toml: wakeup.period: line 2"),
            "{e}"
        );
        let mut bad = Settings::default();
        bad.ipc.payloads.push("3MiB".into());
        let e = bad
            .validate(&Checker::new("x.toml"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("ipc.payloads") && e.contains("3MiB"), "{e}");
        let mut bad = Settings::default();
        bad.wakeup.sched.priority = 99;
        let e = bad
            .validate(&Checker::new("x.toml"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("wakeup.sched.priority"), "{e}");
    }
}
