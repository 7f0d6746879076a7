//! `config/rt_tests.toml`: budgets and the defaults of every subcommand (flags override them).

use runtime::config::{Checker, ConfigError};
use runtime::executor::{ExecutorConfig, SchedPolicy};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The whole file.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
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
#[serde(deny_unknown_fields, default)]
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
}

impl Default for Budgets {
    fn default() -> Self {
        Self {
            wakeup_p99_us: 200.0,
            wakeup_vs_cyclictest: 1.2,
            ipc_p99_us: 1000.0,
            ipc_overhead_p50: 1.3,
            ipc_flatness: 0.2,
            lbv_exec_p99_ms: 5.0,
            lbv_deadline_misses: 0,
            e2e_p99_ms: 100.0,
        }
    }
}

/// Scheduling of a measuring thread.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
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
    fn default() -> Self {
        Self {
            policy: "fifo".into(),
            priority: 80,
            cpus: Vec::new(),
            mlockall: true,
        }
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

    fn validate(&self, c: &Checker, at: &str) -> Result<(), ConfigError> {
        c.require(
            self.policy == "fifo" || self.policy == "other",
            &format!("{at}.policy"),
            &self.policy,
            "must be \"fifo\" or \"other\"",
        )?;
        c.require(
            (1..=98).contains(&self.priority),
            &format!("{at}.priority"),
            self.priority,
            "must be in [1, 98]",
        )?;
        for &cpu in &self.cpus {
            c.require(cpu < 1024, &format!("{at}.cpus"), cpu, "must be below 1024")?;
        }
        Ok(())
    }
}

/// `[wakeup]`.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
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
    fn default() -> Self {
        Self {
            threads: 2,
            period_us: 1000,
            distance_us: 500,
            duration_s: 10.0,
            spin_margin_us: 0,
            hist_max_us: 10_000,
            sched: Sched::default(),
        }
    }
}

/// `[ipc]`.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
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
    fn default() -> Self {
        Self {
            payloads: PAYLOADS.iter().map(|s| s.to_string()).collect(),
            modes: vec!["poll".into(), "event".into()],
            rates_hz: vec![30.0, 0.0],
            fills: vec!["reuse".into()],
            paced_duration_s: 10.0,
            flat_messages: 3000,
            rounds: 5,
            warmup_messages: 10,
            subscriber_buffer: 4,
            raw: true,
            sched: Sched {
                priority: 70,
                ..Sched::default()
            },
            publisher_cpus: Vec::new(),
        }
    }
}

/// The payload names `ipc` knows.
pub const PAYLOADS: [&str; 4] = ["64B", "8KiB", "600KiB", "4MiB"];

/// `[e2e]`.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
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
}

impl Default for E2eSettings {
    fn default() -> Self {
        Self {
            duration_s: 60.0,
            warmup_s: 3.0,
            time_scale: 1.0,
            vpsom: String::new(),
            pipeline_config: "config/default.toml".into(),
            run_args: Vec::new(),
            probe: true,
        }
    }
}

/// `[stress]`.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct StressSettings {
    /// CPU busy-loop workers; 0 = one per online CPU.
    pub cpu_workers: usize,
    /// Memory touched continuously, MB (0 = none).
    pub memory_mb: usize,
    /// Use `stress-ng` when it is installed.
    pub use_stress_ng: bool,
}

impl Default for StressSettings {
    fn default() -> Self {
        Self {
            cpu_workers: 0,
            memory_mb: 256,
            use_stress_ng: true,
        }
    }
}

impl Settings {
    /// Load `file`, or the built-in defaults when `file` is `None` and `config/rt_tests.toml`
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
            Some(p) => runtime::config::load_toml::<Self>(p)?,
            None => Self::default(),
        };
        s.validate(&Checker::new(
            path.clone().unwrap_or_else(|| "<built-in>".into()),
        ))?;
        Ok((s, path))
    }

    /// Range-check every section.
    pub fn validate(&self, c: &Checker) -> Result<(), ConfigError> {
        let b = &self.budgets;
        c.positive("budgets.wakeup_p99_us", b.wakeup_p99_us)?;
        c.in_range(
            "budgets.wakeup_vs_cyclictest",
            b.wakeup_vs_cyclictest,
            0.1,
            100.0,
        )?;
        c.positive("budgets.ipc_p99_us", b.ipc_p99_us)?;
        c.in_range("budgets.ipc_overhead_p50", b.ipc_overhead_p50, 0.1, 100.0)?;
        c.in_range("budgets.ipc_flatness", b.ipc_flatness, 0.0, 100.0)?;
        c.positive("budgets.lbv_exec_p99_ms", b.lbv_exec_p99_ms)?;
        c.positive("budgets.e2e_p99_ms", b.e2e_p99_ms)?;
        let w = &self.wakeup;
        c.count("wakeup.threads", w.threads, 1, 64)?;
        c.require(
            (50..=1_000_000).contains(&w.period_us),
            "wakeup.period_us",
            w.period_us,
            "must be in [50, 1000000]",
        )?;
        c.require(
            w.distance_us <= 1_000_000,
            "wakeup.distance_us",
            w.distance_us,
            "must be in [0, 1000000]",
        )?;
        c.in_range("wakeup.duration_s", w.duration_s, 0.1, 86_400.0)?;
        c.require(
            w.spin_margin_us <= 100_000,
            "wakeup.spin_margin_us",
            w.spin_margin_us,
            "must be in [0, 100000]",
        )?;
        c.require(
            (10..=1_000_000).contains(&w.hist_max_us),
            "wakeup.hist_max_us",
            w.hist_max_us,
            "must be in [10, 1000000]",
        )?;
        w.sched.validate(c, "wakeup.sched")?;
        let i = &self.ipc;
        one_of(c, "ipc.payloads", &i.payloads, &PAYLOADS)?;
        one_of(c, "ipc.modes", &i.modes, &["poll", "event"])?;
        one_of(c, "ipc.fills", &i.fills, &["zero", "reuse"])?;
        for &r in &i.rates_hz {
            c.in_range("ipc.rates_hz", r, 0.0, 100_000.0)?;
        }
        c.in_range("ipc.paced_duration_s", i.paced_duration_s, 0.05, 86_400.0)?;
        c.require(
            (1..=10_000_000).contains(&i.flat_messages),
            "ipc.flat_messages",
            i.flat_messages,
            "must be in [1, 10000000]",
        )?;
        c.require(
            (1..=1000).contains(&i.rounds),
            "ipc.rounds",
            i.rounds,
            "must be in [1, 1000]",
        )?;
        c.require(
            i.warmup_messages <= 1000,
            "ipc.warmup_messages",
            i.warmup_messages,
            "must be in [0, 1000]",
        )?;
        c.count("ipc.subscriber_buffer", i.subscriber_buffer, 1, 64)?;
        i.sched.validate(c, "ipc.sched")?;
        let e = &self.e2e;
        c.in_range("e2e.duration_s", e.duration_s, 0.1, 86_400.0)?;
        c.in_range("e2e.warmup_s", e.warmup_s, 0.0, 600.0)?;
        c.in_range("e2e.time_scale", e.time_scale, 0.01, 100.0)?;
        c.count("stress.cpu_workers", self.stress.cpu_workers, 0, 1024)?;
        c.count("stress.memory_mb", self.stress.memory_mb, 0, 1 << 20)
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
    fn shipped_file_equals_the_defaults_and_bad_values_name_the_key() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../config/rt_tests.toml");
        let shipped: Settings = runtime::config::load_toml(&path).unwrap();
        shipped.validate(&Checker::new(&path)).unwrap();
        assert_eq!(
            serde_json::to_value(&shipped).unwrap(),
            serde_json::to_value(Settings::default()).unwrap()
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
