//! `vpsom-rt-tests`: does the runtime hold its latency budgets on this machine?
//!
//! Subcommands `wakeup` (executor wake-up latency, optionally against `cyclictest`), `ipc`
//! (one-way latency of the ports vs raw iceoryx2; `--layer link`: across the link tunnel vs
//! plain zenoh), `e2e` (a live `vpsom run` pipeline, or
//! `--fake`) and `smoke` (all three, tiny, for CI). Each writes `report.md`, `report.json`, PNG
//! histograms and `samples.mcap` to `--out`; `--stress` adds CPU and memory load; `--check`
//! exits with status 2 naming every violated budget. See `rt_tests/README.md`.

mod e2e;
mod ipc;
#[cfg(feature = "link")]
mod link;
#[allow(unsafe_code)]
mod payload;
mod report;
mod settings;
mod soak;
mod stats;
mod stress;
mod wakeup;

use anyhow::{Context, Result, bail};
use clap::{Args, Parser, Subcommand};
use report::{BudgetCheck, SampleLog, budgets_markdown, write_reports};
use settings::{Sched, Settings};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::OnceLock;
use std::sync::atomic::{AtomicBool, Ordering};

/// What a subcommand produced.
#[derive(Debug)]
pub struct Outcome {
    /// Report body (markdown).
    pub markdown: String,
    /// Report data.
    pub json: serde_json::Value,
    /// Budget comparisons.
    pub checks: Vec<BudgetCheck>,
    /// Failures independent of `--check` (loss, reordering, missing samples).
    pub errors: Vec<String>,
}

static STOP: OnceLock<Arc<AtomicBool>> = OnceLock::new();

/// `true` once SIGINT or SIGTERM arrived.
pub fn interrupted() -> bool {
    STOP.get().is_some_and(|f| f.load(Ordering::Relaxed))
}

fn install_signal_handlers() -> Result<()> {
    let flag = STOP
        .get_or_init(|| Arc::new(AtomicBool::new(false)))
        .clone();
    for sig in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
        signal_hook::flag::register(sig, flag.clone()).context("install signal handler")?;
    }
    Ok(())
}

#[derive(Debug, Parser)]
#[command(
    name = "vpsom-rt-tests",
    version,
    about = "vpsom-rt latency and jitter harness"
)]
struct Cli {
    /// Settings file (default: config/rt_tests.toml if present, else built-in defaults).
    #[arg(long, global = true)]
    config: Option<PathBuf>,
    /// Output directory for report.md, report.json, PNGs and samples.mcap.
    #[arg(long, global = true, default_value = "rt_tests_out")]
    out: PathBuf,
    /// Run CPU and memory load ([stress]) in child processes during the measurement.
    #[arg(long, global = true)]
    stress: bool,
    /// Exit with status 2 if a budget is violated (named on stderr).
    #[arg(long, global = true)]
    check: bool,
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(Debug, Subcommand)]
enum Cmd {
    /// Wake-up latency of N periodic executor threads.
    Wakeup(WakeupArgs),
    /// One-way latency of ports and raw iceoryx2 between two processes.
    Ipc(IpcArgs),
    /// Latencies of a live `vpsom run` pipeline (or `--fake`).
    E2e(E2eArgs),
    /// Endurance: `e2e` under `--stress` (always) with `vpsom run --gbv-load 1000` sessions back
    /// to back, a row every `--every` s (LBV misses and causes, GBV rounds, RSS per process) and
    /// the RSS growth after the warm-up (budget `soak_rss_growth_pct`).
    Soak(SoakArgs),
    /// Every subcommand for ~1 s with tiny sizes (checks the harness works; no budgets).
    Smoke,
    #[command(hide = true)]
    IpcPub(IpcPubArgs),
    #[command(hide = true)]
    LinkPeer(LinkPeerArgs),
    #[command(hide = true)]
    StressWorker {
        #[arg(long)]
        cpu: usize,
        #[arg(long)]
        memory_mb: usize,
        /// The harness's pid: the worker exits as soon as it is no longer its parent.
        /// Without it (load started by hand) it runs until killed.
        #[arg(long)]
        parent: Option<u32>,
    },
    #[command(hide = true)]
    FakePipeline {
        #[arg(long)]
        ns: String,
    },
}

#[derive(Debug, Args, Default)]
struct SchedArgs {
    /// "fifo" or "other".
    #[arg(long)]
    policy: Option<String>,
    /// SCHED_FIFO priority.
    #[arg(long)]
    priority: Option<i32>,
    /// CPUs to pin to, comma-separated.
    #[arg(long, value_delimiter = ',')]
    cpus: Option<Vec<usize>>,
}

impl SchedArgs {
    fn apply(&self, s: &mut Sched) {
        if let Some(p) = &self.policy {
            s.policy = p.clone();
        }
        if let Some(p) = self.priority {
            s.priority = p;
        }
        if let Some(c) = &self.cpus {
            s.cpus = c.clone();
        }
    }
}

#[derive(Debug, Args)]
struct WakeupArgs {
    /// Threads.
    #[arg(long)]
    threads: Option<usize>,
    /// Period of thread 0, µs.
    #[arg(long)]
    period_us: Option<u64>,
    /// Period increment per thread, µs.
    #[arg(long)]
    distance_us: Option<u64>,
    /// Duration, s.
    #[arg(long)]
    duration: Option<f64>,
    /// Executor spin margin, µs.
    #[arg(long)]
    spin_margin_us: Option<u64>,
    /// Also run Debian's cyclictest with the same settings.
    #[arg(long)]
    compare_cyclictest: bool,
    #[command(flatten)]
    sched: SchedArgs,
}

#[derive(Debug, Args)]
struct IpcArgs {
    /// Payloads (64B, 8KiB, 600KiB, 4MiB), comma-separated.
    #[arg(long, value_delimiter = ',')]
    payloads: Option<Vec<String>>,
    /// Modes (poll, event), comma-separated.
    #[arg(long, value_delimiter = ',')]
    modes: Option<Vec<String>>,
    /// Rates in Hz (0 = flat out), comma-separated.
    #[arg(long, value_delimiter = ',')]
    rates: Option<Vec<f64>>,
    /// Loan fills (zero, reuse), comma-separated.
    #[arg(long, value_delimiter = ',')]
    fills: Option<Vec<String>>,
    /// Seconds per paced case.
    #[arg(long)]
    paced_duration: Option<f64>,
    /// Messages per flat-out case.
    #[arg(long)]
    flat_messages: Option<u64>,
    /// Split every case into this many interleaved rounds.
    #[arg(long)]
    rounds: Option<u32>,
    /// Skip the raw iceoryx2 comparison.
    #[arg(long)]
    no_raw: bool,
    /// `ports`: the runtime's ports vs raw iceoryx2 (shared memory); `link`: two iceoryx2
    /// domains joined by the link tunnel over zenoh vs plain zenoh pub/sub.
    #[arg(long, default_value = "ports", value_parser = ["ports", "link"])]
    layer: String,
    #[command(flatten)]
    sched: SchedArgs,
}

#[derive(Debug, Args)]
struct E2eArgs {
    /// Measure this binary's fake pipeline instead of `vpsom run`.
    #[arg(long)]
    fake: bool,
    /// Measured seconds.
    #[arg(long)]
    duration: Option<f64>,
    /// Ignored start-up seconds.
    #[arg(long)]
    warmup: Option<f64>,
    /// Path of the vpsom binary.
    #[arg(long)]
    vpsom: Option<String>,
    /// `vpsom run --time-scale`.
    #[arg(long)]
    time_scale: Option<f64>,
    /// Do not run the cyclictest probe beside the pipeline (`[e2e] probe`).
    #[arg(long)]
    no_probe: bool,
    /// Extra arguments for `vpsom run` (after `--`).
    #[arg(last = true)]
    run_args: Vec<String>,
}

#[derive(Debug, Args)]
struct LinkPeerArgs {
    #[arg(long)]
    transport: String,
    #[arg(long)]
    ns: String,
    #[arg(long)]
    domain: String,
    #[arg(long)]
    payload: String,
    #[arg(long)]
    rate_hz: f64,
    #[arg(long)]
    count: u64,
    #[arg(long)]
    warmup: u64,
    #[arg(long)]
    buffer: usize,
    #[arg(long)]
    port: u16,
}

#[derive(Debug, Args)]
struct SoakArgs {
    /// Measured seconds (default 1800: the 30-minute soak).
    #[arg(long, default_value_t = 1800.0)]
    duration: f64,
    /// Seconds between report rows.
    #[arg(long, default_value_t = 60.0)]
    every: f64,
    /// RSS growth is computed over the rows after this many measured seconds.
    #[arg(long)]
    rss_warmup: Option<f64>,
    /// `vpsom run --time-scale`.
    #[arg(long)]
    time_scale: Option<f64>,
    /// Path of the vpsom binary.
    #[arg(long)]
    vpsom: Option<String>,
    /// Do not run the cyclictest probe beside the pipeline.
    #[arg(long)]
    no_probe: bool,
    /// Arguments for `vpsom run` (after `--`); default `--gbv-load 1000`.
    #[arg(last = true)]
    run_args: Vec<String>,
}

#[derive(Debug, Args)]
struct IpcPubArgs {
    #[arg(long)]
    ns: String,
    #[arg(long)]
    payload: String,
    #[arg(long)]
    rate_hz: f64,
    #[arg(long)]
    count: u64,
    #[arg(long)]
    warmup: u64,
    #[arg(long)]
    buffer: usize,
    #[arg(long)]
    raw: bool,
    #[arg(long)]
    notify: bool,
    #[arg(long)]
    reuse: bool,
    #[command(flatten)]
    sched: SchedArgs,
}

fn main() -> std::process::ExitCode {
    match real_main() {
        Ok(code) => code,
        Err(e) => {
            eprintln!("vpsom-rt-tests: error: {}", vpsom::error_report(&e));
            std::process::ExitCode::from(1)
        }
    }
}

fn real_main() -> Result<std::process::ExitCode> {
    let cli = Cli::parse();
    install_signal_handlers()?;
    match &cli.cmd {
        Cmd::IpcPub(a) => {
            let mut sched = Sched::default();
            a.sched.apply(&mut sched);
            let wire = ipc::Wire {
                ns: a.ns.clone(),
                payload: a.payload.clone(),
                raw: a.raw,
                rate_hz: a.rate_hz,
                count: a.count,
                warmup: a.warmup,
                buffer: a.buffer,
                notify: a.notify,
                reuse: a.reuse,
            };
            ipc::publisher(&wire, &sched)?;
            return Ok(std::process::ExitCode::SUCCESS);
        }
        #[cfg(feature = "link")]
        Cmd::LinkPeer(a) => {
            link::peer(&link::PeerWire {
                transport: a.transport.clone(),
                ns: a.ns.clone(),
                domain: a.domain.clone(),
                payload: a.payload.clone(),
                rate_hz: a.rate_hz,
                count: a.count,
                warmup: a.warmup,
                buffer: a.buffer,
                port: a.port,
            })?;
            return Ok(std::process::ExitCode::SUCCESS);
        }
        #[cfg(not(feature = "link"))]
        Cmd::LinkPeer(_) => bail_no_link()?,
        Cmd::StressWorker {
            cpu,
            memory_mb,
            parent,
        } => {
            stress::worker(*cpu, *memory_mb, *parent)?;
            return Ok(std::process::ExitCode::SUCCESS);
        }
        Cmd::FakePipeline { ns } => {
            e2e::fake_pipeline(ns)?;
            return Ok(std::process::ExitCode::SUCCESS);
        }
        _ => {}
    }
    let (mut s, path) = Settings::load(cli.config.as_deref())?;
    let mut stress = cli.stress;
    let jobs: Vec<(&str, PathBuf)> = match &cli.cmd {
        Cmd::Wakeup(a) => {
            let w = &mut s.wakeup;
            set(&mut w.threads, a.threads);
            set(&mut w.period_us, a.period_us);
            set(&mut w.distance_us, a.distance_us);
            set(&mut w.duration_s, a.duration);
            set(&mut w.spin_margin_us, a.spin_margin_us);
            a.sched.apply(&mut w.sched);
            vec![(
                if a.compare_cyclictest {
                    "wakeup+cyclictest"
                } else {
                    "wakeup"
                },
                cli.out.clone(),
            )]
        }
        Cmd::Ipc(a) => {
            let i = &mut s.ipc;
            set(&mut i.payloads, a.payloads.clone());
            set(&mut i.modes, a.modes.clone());
            set(&mut i.rates_hz, a.rates.clone());
            set(&mut i.fills, a.fills.clone());
            set(&mut i.paced_duration_s, a.paced_duration);
            set(&mut i.flat_messages, a.flat_messages);
            set(&mut i.rounds, a.rounds);
            if a.no_raw {
                i.raw = false;
            }
            a.sched.apply(&mut i.sched);
            let job = if a.layer == "link" { "ipc-link" } else { "ipc" };
            vec![(job, cli.out.clone())]
        }
        Cmd::E2e(a) => {
            let e = &mut s.e2e;
            set(&mut e.duration_s, a.duration);
            set(&mut e.warmup_s, a.warmup);
            set(&mut e.vpsom, a.vpsom.clone());
            set(&mut e.time_scale, a.time_scale);
            e.probe &= !a.no_probe;
            if !a.run_args.is_empty() {
                e.run_args = a.run_args.clone();
            }
            vec![(if a.fake { "e2e-fake" } else { "e2e" }, cli.out.clone())]
        }
        Cmd::Soak(a) => {
            let e = &mut s.e2e;
            e.duration_s = a.duration;
            e.report_every_s = a.every;
            set(&mut e.rss_warmup_s, a.rss_warmup);
            set(&mut e.vpsom, a.vpsom.clone());
            set(&mut e.time_scale, a.time_scale);
            e.probe &= !a.no_probe;
            e.run_args = if a.run_args.is_empty() {
                vec!["--gbv-load".into(), "1000".into()]
            } else {
                a.run_args.clone()
            };
            stress = true;
            vec![("e2e", cli.out.clone())]
        }
        Cmd::Smoke => {
            smoke_settings(&mut s);
            stress = true;
            vec![
                ("wakeup+cyclictest", cli.out.join("wakeup")),
                ("ipc", cli.out.join("ipc")),
                ("e2e-fake", cli.out.join("e2e")),
            ]
        }
        _ => unreachable!("handled above"),
    };
    s.validate(&runtime::config::Checker::new(
        path.clone().unwrap_or_else(|| "<command line>".into()),
    ))?;
    let load = if stress {
        stress::Load::start(&s.stress)?
    } else {
        stress::Load::none()
    };
    let mut violated = Vec::new();
    let mut errors = Vec::new();
    for (job, dir) in jobs {
        std::fs::create_dir_all(&dir).with_context(|| format!("create {}", dir.display()))?;
        let mut log = SampleLog::create(&dir)?;
        let out = match job {
            "wakeup" | "wakeup+cyclictest" => {
                wakeup::run(&s.wakeup, job != "wakeup", &s.budgets, &dir, &mut log)
            }
            "ipc" => ipc::run(&s.ipc, &s.budgets, &dir, &mut log),
            #[cfg(feature = "link")]
            "ipc-link" => link::run(&s.ipc, &dir, &mut log),
            #[cfg(not(feature = "link"))]
            "ipc-link" => bail_no_link(),
            _ => e2e::run(&s.e2e, job == "e2e-fake", &s.budgets, &dir, &mut log),
        }?;
        log.finish()?;
        finish(&dir, job, &out, &load, path.as_deref())?;
        violated.extend(out.checks.iter().filter(|c| !c.ok).map(|c| c.name.clone()));
        errors.extend(out.errors.iter().cloned());
    }
    drop(load);
    for e in &errors {
        eprintln!("vpsom-rt-tests: FAILED: {e}");
    }
    if !errors.is_empty() {
        return Ok(std::process::ExitCode::from(1));
    }
    if cli.check && !matches!(cli.cmd, Cmd::Smoke) && !violated.is_empty() {
        for v in &violated {
            eprintln!("vpsom-rt-tests: budget violated: {v}");
        }
        return Ok(std::process::ExitCode::from(2));
    }
    Ok(std::process::ExitCode::SUCCESS)
}

fn set<T>(slot: &mut T, v: Option<T>) {
    if let Some(v) = v {
        *slot = v;
    }
}

/// Tiny sizes for `smoke`: each part runs for about a second.
fn smoke_settings(s: &mut Settings) {
    s.wakeup.threads = 2;
    s.wakeup.duration_s = 1.0;
    s.ipc.payloads = vec!["64B".into(), "8KiB".into()];
    s.ipc.rates_hz = vec![200.0, 0.0];
    s.ipc.fills = vec!["zero".into(), "reuse".into()];
    s.ipc.rounds = 2;
    s.ipc.paced_duration_s = 0.2;
    s.ipc.flat_messages = 200;
    s.ipc.warmup_messages = 3;
    s.e2e.duration_s = 1.5;
    s.e2e.warmup_s = 0.4;
    s.stress.cpu_workers = 1;
    s.stress.memory_mb = 16;
    s.stress.use_stress_ng = false;
}

fn finish(
    dir: &Path,
    job: &str,
    out: &Outcome,
    load: &stress::Load,
    config: Option<&Path>,
) -> Result<()> {
    let mut md = out.markdown.clone();
    md += &format!(
        "\nLoad: {}. Settings: {}. Host: {} CPUs.\n",
        load.description,
        config.map_or("built-in defaults".into(), |p| p.display().to_string()),
        std::thread::available_parallelism().map_or(0, |n| n.get())
    );
    md += &budgets_markdown(&out.checks);
    let json = serde_json::json!({
        "subcommand": job,
        "load": load.description,
        "results": out.json,
        "budgets": out.checks,
        "errors": out.errors,
    });
    write_reports(dir, &md, &json)?;
    println!("{md}");
    println!("report: {}", dir.join("report.md").display());
    if out.checks.iter().any(|c| !c.ok) {
        eprintln!(
            "{job}: {} budget(s) over limit (see report)",
            out.checks.iter().filter(|c| !c.ok).count()
        );
    }
    if job.is_empty() {
        bail!("no job");
    }
    Ok(())
}

/// `ipc --layer link` in a binary built without the tunnel.
#[cfg(not(feature = "link"))]
fn bail_no_link<T>() -> anyhow::Result<T> {
    anyhow::bail!(
        "ipc --layer link: vpsom-rt-tests was built without the `link` feature; build it with \
         `cargo build --release -p rt_tests --features link`"
    )
}
