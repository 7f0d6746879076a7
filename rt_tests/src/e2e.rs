//! `e2e`: latencies of a live `vpsom run` pipeline, from the message headers.
//!
//! frame → map = `map.header.stamp_ns − map.last_frame_stamp_ns` at the first map that includes
//! the frame; frame → LBV = `neck_goal.header.stamp_ns − neck_goal.frame_stamp_ns` at the first
//! neck goal computed from such a map (each frame counted once; a session's very first such goal
//! measures start-up and is left out; the same difference at every neck goal is reported as the
//! frame's age at the LBV); LBV execution time and misses from
//! the `deadline` topic (events whose thread name contains "lbv", or all events if none does);
//! GBV round time = `eval_ns` of GBV planner decisions. Every miss carries its cause from the
//! thread's scheduler statistics (`runtime::executor::miss_cause_of`). With `probe`, cyclictest
//! runs beside the pipeline (one thread per CPU at the LBV's priority), so the report shows what
//! the platform's own wake-ups did over the same time. `--fake` runs this binary's own
//! `fake-pipeline` (same topics, realistic stamps, a real executor for the LBV) instead.

use crate::Outcome;
use crate::report::{BudgetCheck, SampleLog, Series, histogram_png};
use crate::settings::{Budgets, E2eSettings};
use crate::stats::{Stats, table_header, table_row};
use crate::wakeup::Cyclictest;
use anyhow::{Context, Result, anyhow, bail};
use runtime::clock::{Clock, MonotonicClock};
use runtime::executor::{Control, Cycle, EventTrace, Executor, ExecutorConfig};
use runtime::ports::{PortContext, PortsConfig, Stamp};
use serde_json::json;
use shm_types::{
    DeadlineEvent, DepthFrame, NeckGoal, ObjectMap, PlannerDecision, decision_kind, miss_cause,
};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

struct Pipeline(Child);

impl Drop for Pipeline {
    fn drop(&mut self) {
        if let Ok(None) = self.0.try_wait() {
            let _ = crate::payload::send_sigint(self.0.id());
            let t = Instant::now();
            while t.elapsed() < Duration::from_secs(10) {
                if let Ok(Some(_)) = self.0.try_wait() {
                    return;
                }
                std::thread::sleep(Duration::from_millis(20));
            }
            let _ = self.0.kill();
            let _ = self.0.wait();
        }
    }
}

/// `name` if the runtime accepts it as a topic, else with `/` replaced by `_` (the runtime's
/// topic names may not contain `/`; the pipeline's convention names `neck/goal`).
fn publisher<T: shm_types::Message>(
    ctx: &PortContext,
    name: &str,
) -> Result<runtime::ports::Publisher<T>, runtime::ports::PublisherError> {
    use runtime::ports::{PublisherError, ServiceError};
    match ctx.publisher::<T>(name) {
        Err(PublisherError::Service(
            ServiceError::Topic { .. } | ServiceError::ServiceName { .. },
        )) => ctx.publisher::<T>(&name.replace('/', "_")),
        r => r,
    }
}

fn subscriber<T: shm_types::Message>(
    ctx: &PortContext,
    name: &str,
) -> Result<runtime::ports::Subscriber<T>> {
    use runtime::ports::{ServiceError, SubscriberError};
    match ctx.subscriber::<T>(name) {
        Err(SubscriberError::Service(
            ServiceError::Topic { .. } | ServiceError::ServiceName { .. },
        )) => Ok(ctx.subscriber::<T>(&name.replace('/', "_"))?),
        r => Ok(r?),
    }
}

/// The `vpsom` binary: `e2e.vpsom` or next to this executable.
fn vpsom_path(e: &E2eSettings) -> Result<PathBuf> {
    if !e.vpsom.is_empty() {
        return Ok(PathBuf::from(&e.vpsom));
    }
    let me = std::env::current_exe()?;
    let p = me.with_file_name("vpsom");
    if p.is_file() {
        Ok(p)
    } else {
        bail!(
            "no vpsom binary at {} (build it with `cargo build --release -p vpsom` or pass --vpsom PATH)",
            p.display()
        )
    }
}

/// Samples gathered over one or more pipeline sessions.
#[derive(Default)]
struct Samples {
    frame_map: Vec<u64>,
    frame_lbv: Vec<u64>,
    /// Age of the newest frame in the map each LBV cycle used (every neck goal).
    lbv_age: Vec<u64>,
    gbv: Vec<u64>,
    exec: BTreeMap<String, Vec<u64>>,
    misses: BTreeMap<String, u64>,
    /// Every missed cycle, in arrival order.
    missed: Vec<DeadlineEvent>,
    /// Deadline budget per thread, ns.
    budget: BTreeMap<String, u64>,
    /// Cycles per thread that the executor's backup waker woke.
    backup_wakes: BTreeMap<String, u64>,
    neck_seen: u64,
    decisions_seen: [u64; 2],
    lost: u64,
    /// Measured time, summed over sessions.
    measured: Duration,
    /// Sessions run, and how many ended on their own (the planner finished).
    sessions: u32,
    sessions_finished: u32,
    /// Soak: the open interval and the closed rows.
    interval: crate::soak::Interval,
    rows: Vec<crate::soak::Row>,
}

/// The command for session `k` (0-based) and its printable form.
fn pipeline_command(
    e: &E2eSettings,
    fake: bool,
    ns: &str,
    dir: &Path,
    k: u32,
) -> Result<(Command, String)> {
    if fake {
        let mut c = Command::new(std::env::current_exe()?);
        c.args(["fake-pipeline", "--ns", ns]);
        return Ok((c, format!("vpsom-rt-tests fake-pipeline --ns {ns}")));
    }
    let exe = vpsom_path(e)?;
    let out = if k == 0 {
        dir.join("run")
    } else {
        dir.join(format!("run-{}", k + 1))
    };
    let mut c = Command::new(&exe);
    c.args(["run", "--ns", ns, "--time-scale", &e.time_scale.to_string()])
        .arg("--out")
        .arg(&out)
        .args(&e.run_args);
    let line = format!("{c:?}");
    Ok((c, line))
}

/// Run the pipeline (or the fake) and measure. A `vpsom run` session ends when its planner
/// finishes; if that happens before `duration_s` of measurement, the next session is started
/// (fresh namespace, `run-2`, `run-3`, … output directories) and measurement goes on, so the
/// figures always cover `duration_s` of pipeline operation. Each session's first `warmup_s`
/// (start-up) is not measured.
pub fn run(
    e: &E2eSettings,
    fake: bool,
    budgets: &Budgets,
    dir: &Path,
    log: &mut SampleLog,
) -> Result<Outcome> {
    let (ports, lbv_priority) = if fake || e.pipeline_config.is_empty() {
        (PortsConfig::default(), ExecutorConfig::default().priority)
    } else {
        let c = vpsom::config::Config::load(Path::new(&e.pipeline_config))
            .with_context(|| format!("load {}", e.pipeline_config))?;
        (c.ports, c.executor.priority)
    };
    let duration = Duration::from_secs_f64(e.duration_s);
    let probe = if e.probe {
        Some(Probe::start(lbv_priority, dir))
    } else {
        None
    };
    let mut acc = Samples::default();
    let mut cmdline = String::new();
    let mut ns = String::new();
    while acc.measured < duration {
        ns = format!("rtt-e2e-{}-{}", std::process::id(), acc.sessions + 1);
        let (cmd, line) = pipeline_command(e, fake, &ns, dir, acc.sessions)?;
        cmdline = line;
        let ended = session(e, &ports, cmd, &cmdline, &ns, duration, &mut acc, log)?;
        acc.sessions += 1;
        acc.sessions_finished += u32::from(ended);
        if !ended {
            break;
        }
    }
    let Samples {
        frame_map,
        frame_lbv,
        lbv_age,
        gbv,
        exec,
        misses,
        missed,
        budget,
        backup_wakes,
        neck_seen,
        decisions_seen,
        lost,
        measured,
        sessions,
        sessions_finished,
        interval: _,
        rows,
    } = acc;
    let lbv_names: Vec<String> = exec.keys().filter(|k| k.contains("lbv")).cloned().collect();
    let lbv_names = if lbv_names.is_empty() {
        exec.keys().cloned().collect()
    } else {
        lbv_names
    };
    let lbv_exec: Vec<u64> = lbv_names
        .iter()
        .flat_map(|n| exec[n].iter().copied())
        .collect();
    let lbv_misses: u64 = lbv_names.iter().map(|n| misses[n]).sum();
    let lbv_backup_wakes: u64 = lbv_names.iter().map(|n| backup_wakes[n]).sum();
    let lbv_missed: Vec<&DeadlineEvent> = missed
        .iter()
        .filter(|m| lbv_names.iter().any(|n| n == m.thread_name()))
        .collect();
    let lbv_budget_ns = lbv_names
        .iter()
        .filter_map(|n| budget.get(n).copied())
        .max()
        .unwrap_or(0);
    let probe = probe.map(|p| p.stop());
    let p_map = Stats::of_samples(&frame_map);
    let p_lbv = Stats::of_samples(&frame_lbv);
    let p_age = Stats::of_samples(&lbv_age);
    let p_exec = Stats::of_samples(&lbv_exec);
    let p_gbv = Stats::of_samples(&gbv);
    let mut md = format!(
        "# vpsom-rt-tests e2e\n\nPipeline: `{cmdline}` (namespace `{ns}`). {sessions} session(s) \
         ({sessions_finished} ended by the planner and were followed by a new one), each with \
         {} s of start-up unmeasured; measured {:.1} s in all. Latencies from message headers; \
         each frame counted once, at the first map and the first neck goal that include it.\n\n",
        e.warmup_s,
        measured.as_secs_f64()
    );
    md += &table_header(&["measurement"]);
    md += &table_row(&["frame → map".into()], &p_map);
    md += &table_row(&["frame → LBV (neck goal)".into()], &p_lbv);
    md += &table_row(&["newest frame's age at each LBV".into()], &p_age);
    md += &table_row(
        &[format!("LBV execution ({})", lbv_names.join(", "))],
        &p_exec,
    );
    md += &table_row(&["GBV round".into()], &p_gbv);
    let causes = count_causes(&lbv_missed);
    md += &format!(
        "\nLBV deadline misses: {lbv_misses}{} over {} cycles; {lbv_backup_wakes} cycles were woken by \
         the executor's backup waker (the LBV's own CPU had not woken it in time). Samples lost to overwrite on the harness's \
         subscribers (not the pipeline's): {lost}. Received while measuring: {neck_seen} neck goals \
         (those with `frame_stamp_ns` = 0 are not counted above), {} GBV and {} LBV decisions.\n",
        if causes.is_empty() {
            String::new()
        } else {
            format!(
                " ({})",
                causes
                    .iter()
                    .map(|(c, n)| format!("{c} {n}"))
                    .collect::<Vec<_>>()
                    .join(", ")
            )
        },
        lbv_exec.len(),
        decisions_seen[0],
        decisions_seen[1]
    );
    md += &misses_table(&lbv_missed);
    if let Some(p) = &probe {
        md += &p.markdown(lbv_budget_ns);
    }
    histogram_png(
        &dir.join("e2e.png"),
        "end-to-end latency",
        &[
            Series {
                label: "frame → map".into(),
                samples: &frame_map,
            },
            Series {
                label: "frame → LBV".into(),
                samples: &frame_lbv,
            },
        ],
    )?;
    md += "\n![e2e latency](e2e.png)\n";
    let growth = crate::soak::growth(&rows, e.rss_warmup_s);
    if e.report_every_s > 0.0 {
        md += &crate::soak::markdown(&rows, &growth, e.rss_warmup_s);
    }
    let mut errors = Vec::new();
    if frame_map.is_empty() || frame_lbv.is_empty() || lbv_exec.is_empty() {
        errors.push(format!(
            "e2e: too few samples (frame→map {}, frame→LBV {}, LBV cycles {})",
            frame_map.len(),
            frame_lbv.len(),
            lbv_exec.len()
        ));
    }
    let mut checks = vec![
        BudgetCheck::at_most(
            "e2e_p99_ms (frame → map)",
            p_map.p99 as f64 / 1e6,
            budgets.e2e_p99_ms,
            "ms",
        ),
        BudgetCheck::at_most(
            "e2e_p99_ms (frame → LBV)",
            p_lbv.p99 as f64 / 1e6,
            budgets.e2e_p99_ms,
            "ms",
        ),
        BudgetCheck::at_most(
            "lbv_exec_p99_ms",
            p_exec.p99 as f64 / 1e6,
            budgets.lbv_exec_p99_ms,
            "ms",
        ),
        BudgetCheck::at_most(
            "lbv_deadline_misses",
            lbv_misses as f64,
            budgets.lbv_deadline_misses as f64,
            "",
        ),
    ];
    checks.extend(crate::soak::checks(&growth, budgets.soak_rss_growth_pct));
    Ok(Outcome {
        markdown: md,
        json: json!({
            "settings": e, "fake": fake, "pipeline": cmdline, "namespace": ns,
            "sessions": sessions, "sessions_ended_by_planner": sessions_finished,
            "measured_s": measured.as_secs_f64(),
            "frame_to_map": p_map, "frame_to_lbv": p_lbv, "lbv_frame_age": p_age, "lbv_exec": p_exec,
            "lbv_threads": lbv_names, "lbv_deadline_misses": lbv_misses, "gbv_round": p_gbv,
            "lbv_backup_wakes": lbv_backup_wakes,
            "lbv_miss_causes": causes.iter().cloned().collect::<BTreeMap<_, _>>(),
            "lbv_missed_cycles": lbv_missed.iter().map(|m| json!({
                "thread": m.thread_name(), "cycle": m.cycle, "lateness_ns": m.lateness_ns,
                "exec_ns": m.exec_ns, "cpu_ns": m.cpu_ns, "run_wait_ns": m.run_wait_ns,
                "sched_stats": m.sched_stats != 0, "cause": miss_cause::name(m.miss_cause),
            })).collect::<Vec<_>>(),
            "probe": probe.as_ref().map(|p| p.json(lbv_budget_ns)),
            "harness_lost": lost,
            "soak_rows": rows, "soak_rss_growth": growth,
        }),
        checks,
        errors,
    })
}

/// Misses per cause name, most frequent first.
fn count_causes(missed: &[&DeadlineEvent]) -> Vec<(&'static str, u64)> {
    let mut n: BTreeMap<&'static str, u64> = BTreeMap::new();
    for m in missed {
        *n.entry(miss_cause::name(m.miss_cause)).or_default() += 1;
    }
    let mut v: Vec<_> = n.into_iter().collect();
    v.sort_by_key(|&(c, k)| (std::cmp::Reverse(k), c));
    v
}

/// Missed cycles shown in the report (all are in the JSON and the MCAP).
const MISSES_SHOWN: usize = 20;

/// A table of the missed cycles: where each one's time went.
fn misses_table(missed: &[&DeadlineEvent]) -> String {
    if missed.is_empty() {
        return String::new();
    }
    let ms = |ns: u64| format!("{:.2}", ns as f64 / 1e6);
    let mut md = String::from(
        "\nMissed cycles (ms; CPU time and run-queue wait are the thread's own, from the end of \
         the previous cycle; cause = the largest share of release → end):\n\n\
         | thread | cycle | lateness | execution | CPU | run-queue wait | cause |\n\
         |---|---|---|---|---|---|---|\n",
    );
    for m in missed.iter().take(MISSES_SHOWN) {
        let (cpu, wait) = if m.sched_stats != 0 {
            (ms(m.cpu_ns), ms(m.run_wait_ns))
        } else {
            ("–".into(), "–".into())
        };
        md += &format!(
            "| {} | {} | {} | {} | {cpu} | {wait} | {} |\n",
            m.thread_name(),
            m.cycle,
            ms(m.lateness_ns.max(0) as u64),
            ms(m.exec_ns),
            miss_cause::name(m.miss_cause)
        );
    }
    if missed.len() > MISSES_SHOWN {
        md += &format!("\n({} more in report.json.)\n", missed.len() - MISSES_SHOWN);
    }
    md
}

/// cyclictest's histogram range for the probe, µs (later wake-ups count at its max).
const PROBE_HIST_MAX_US: u64 = 50_000;
/// The probe's period, µs.
const PROBE_PERIOD_US: u64 = 1_000;

/// cyclictest running beside the pipeline: one thread per online CPU, pinned, at the LBV's
/// `SCHED_FIFO` priority, 1 ms period, until stopped.
enum Probe {
    Running(Cyclictest, Instant),
    /// Not started, and why.
    Absent(String),
}

/// What the probe measured, or why it did not.
enum ProbeOutcome {
    Measured {
        cmdline: String,
        seconds: f64,
        threads: Vec<Vec<u64>>,
    },
    Absent(String),
}

impl Probe {
    fn start(priority: i32, dir: &Path) -> Self {
        if !crate::stress::which("cyclictest") {
            return Self::Absent(
                "cyclictest not found (`sudo apt-get install rt-tests`); no probe".into(),
            );
        }
        let cpus = match online_cpus() {
            Ok(c) => c,
            Err(e) => return Self::Absent(format!("no probe: {e:#}")),
        };
        let list: Vec<String> = cpus.iter().map(|c| c.to_string()).collect();
        let args = vec![
            "-i".into(),
            PROBE_PERIOD_US.to_string(),
            "-t".into(),
            cpus.len().to_string(),
            "-a".into(),
            list.join(","),
            "-h".into(),
            PROBE_HIST_MAX_US.to_string(),
            "-p".into(),
            priority.to_string(),
            "--policy=fifo".into(),
            "-m".into(),
        ];
        match Cyclictest::spawn(args, cpus.len(), &dir.join("probe-cyclictest.txt")) {
            Ok(c) => Self::Running(c, Instant::now()),
            Err(e) => Self::Absent(format!("no probe: {e:#}")),
        }
    }

    fn stop(self) -> ProbeOutcome {
        match self {
            Self::Absent(why) => ProbeOutcome::Absent(why),
            Self::Running(c, t0) => {
                let cmdline = c.cmdline.clone();
                let seconds = t0.elapsed().as_secs_f64();
                match c.stop() {
                    Ok(threads) => ProbeOutcome::Measured {
                        cmdline,
                        seconds,
                        threads,
                    },
                    Err(e) => {
                        let why = format!("the probe failed: {e:#}");
                        eprintln!("e2e: {why}");
                        ProbeOutcome::Absent(why)
                    }
                }
            }
        }
    }
}

impl ProbeOutcome {
    /// Wake-ups at least `budget_ns` late, per thread.
    fn over(threads: &[Vec<u64>], budget_ns: u64) -> Vec<usize> {
        threads
            .iter()
            .map(|t| t.iter().filter(|&&l| l >= budget_ns).count())
            .collect()
    }

    fn markdown(&self, budget_ns: u64) -> String {
        match self {
            Self::Absent(why) => format!("\n**Platform probe: {why}.**\n"),
            Self::Measured {
                cmdline,
                seconds,
                threads,
            } => {
                let mut md = format!(
                    "\nPlatform probe over the same {seconds:.0} s (start-up included): `{cmdline}`: \
                     one thread per CPU at the LBV's priority. A wake-up of this probe later \
                     than the LBV budget ({:.1} ms) would have made an LBV cycle released at that \
                     moment miss, whatever the pipeline did.\n\n",
                    budget_ns as f64 / 1e6
                );
                md += &table_header(&["cyclictest thread"]);
                for (k, t) in threads.iter().enumerate() {
                    md += &table_row(&[format!("CPU {k}")], &Stats::of_samples(t));
                }
                let over = Self::over(threads, budget_ns);
                md += &format!(
                    "\nProbe wake-ups ≥ {:.1} ms late, per CPU: {over:?}.\n",
                    budget_ns as f64 / 1e6
                );
                md
            }
        }
    }

    fn json(&self, budget_ns: u64) -> serde_json::Value {
        match self {
            Self::Absent(why) => json!({"error": why}),
            Self::Measured {
                cmdline,
                seconds,
                threads,
            } => json!({
                "command": cmdline, "seconds": seconds,
                "threads": threads.iter().map(|t| Stats::of_samples(t)).collect::<Vec<_>>(),
                "late_by_lbv_budget_or_more": Self::over(threads, budget_ns),
            }),
        }
    }
}

/// The online CPUs (`/sys/devices/system/cpu/online`, e.g. `0-3,6`).
fn online_cpus() -> Result<Vec<usize>> {
    let path = "/sys/devices/system/cpu/online";
    let text = std::fs::read_to_string(path).with_context(|| format!("read {path}"))?;
    parse_cpu_list(text.trim()).with_context(|| format!("{path}: {:?}", text.trim()))
}

fn parse_cpu_list(s: &str) -> Result<Vec<usize>> {
    let mut cpus = Vec::new();
    for part in s.split(',').filter(|p| !p.is_empty()) {
        let (a, b) = part.split_once('-').unwrap_or((part, part));
        let (a, b): (usize, usize) = (a.parse()?, b.parse()?);
        if a > b {
            bail!("range {part} is reversed");
        }
        cpus.extend(a..=b);
    }
    if cpus.is_empty() {
        bail!("no CPUs");
    }
    Ok(cpus)
}

/// One pipeline session: start it, measure until the total measured time reaches `duration`
/// (then stop it: `Ok(false)`) or the pipeline ends with success (`Ok(true)`). A pipeline that
/// fails is an error.
#[allow(clippy::too_many_arguments)]
fn session(
    e: &E2eSettings,
    ports: &PortsConfig,
    mut cmd: Command,
    cmdline: &str,
    ns: &str,
    duration: Duration,
    acc: &mut Samples,
    log: &mut SampleLog,
) -> Result<bool> {
    let child = cmd
        .stdin(Stdio::null())
        .spawn()
        .with_context(|| format!("start {cmdline}"))?;
    let mut pipeline = Pipeline(child);
    // Open the pipeline's services rather than create them with our settings (per-topic
    // overrides of the run's config, e.g. a larger buffer, must win).
    let wanted = ["map", "neck/goal", "planner/decision", "deadline"];
    let t_wait = Instant::now();
    loop {
        let have = runtime::ports::list_services(ns)?;
        let exists = |t: &str| {
            let a = format!("vpsom/{ns}/{t}");
            let b = format!("vpsom/{ns}/{}", t.replace('/', "_"));
            have.iter().any(|h| *h == a || *h == b)
        };
        if wanted.iter().all(|t| exists(t)) {
            break;
        }
        if let Some(status) = pipeline.0.try_wait()? {
            bail!("the pipeline ({cmdline}) exited early: {status}");
        }
        if crate::interrupted() {
            bail!("interrupted");
        }
        if t_wait.elapsed() > Duration::from_secs(60) {
            let missing: Vec<&str> = wanted.iter().copied().filter(|t| !exists(t)).collect();
            bail!("the pipeline did not create {missing:?} in namespace {ns} within 60 s");
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    let ctx = PortContext::with_namespace(ports, "rtt-e2e", ns)?;
    let map = ctx.subscriber::<ObjectMap>("map")?;
    let neck = subscriber::<NeckGoal>(&ctx, "neck/goal")?;
    let dec = subscriber::<PlannerDecision>(&ctx, "planner/decision")?;
    let dl = ctx.subscriber::<DeadlineEvent>("deadline")?;
    let clock = MonotonicClock::new();
    let t0 = Instant::now();
    let warm = Duration::from_secs_f64(e.warmup_s);
    let before = acc.measured;
    let mut ended = false;
    // A frame is measured once: at the first map that includes it, and at the first neck goal
    // computed from such a map. (Maps republished without a new frame, e.g. while localization
    // is lost, would otherwise count the wait for the next frame as latency.)
    let (mut map_frame, mut lbv_frame) = (0u64, 0u64);
    loop {
        let measured = t0.elapsed().saturating_sub(warm);
        acc.measured = before + measured;
        if acc.measured >= duration {
            soak_tick(e, acc, pipeline.0.id());
            break;
        }
        if crate::interrupted() {
            bail!("interrupted");
        }
        let measuring = measured > Duration::ZERO;
        let now = clock.now_ns();
        while let Some(m) = map.receive()? {
            let new_frame = m.last_frame_stamp_ns > map_frame;
            map_frame = map_frame.max(m.last_frame_stamp_ns);
            if measuring && new_frame {
                let l = m.header.stamp_ns.saturating_sub(m.last_frame_stamp_ns);
                acc.frame_map.push(l);
                log.record(
                    "/e2e/frame_to_map",
                    now,
                    &json!({"seq": m.header.seq, "latency_ns": l}),
                )?;
            }
        }
        while let Some(g) = neck.receive()? {
            if measuring {
                acc.neck_seen += 1;
            }
            // The session's first goal computed from a map is start-up (the planner waited for
            // its inputs): its frame's age says nothing about the pipeline in operation.
            let steady = lbv_frame > 0;
            let new_frame = g.frame_stamp_ns > lbv_frame;
            lbv_frame = lbv_frame.max(g.frame_stamp_ns);
            let measuring = measuring && steady;
            if measuring && g.frame_stamp_ns > 0 {
                let l = g.header.stamp_ns.saturating_sub(g.frame_stamp_ns);
                acc.lbv_age.push(l);
            }
            if measuring && new_frame {
                let l = g.header.stamp_ns.saturating_sub(g.frame_stamp_ns);
                acc.frame_lbv.push(l);
                log.record(
                    "/e2e/frame_to_lbv",
                    now,
                    &json!({"seq": g.header.seq, "latency_ns": l}),
                )?;
            }
        }
        while let Some(d) = dec.receive()? {
            if measuring {
                acc.decisions_seen[usize::from(d.kind.min(1))] += 1;
            }
            if measuring && d.kind == decision_kind::GBV && d.eval_ns > 0 {
                acc.gbv.push(d.eval_ns);
                acc.interval.gbv.push(d.eval_ns);
                log.record(
                    "/e2e/gbv_round",
                    now,
                    &json!({"seq": d.header.seq, "eval_ns": d.eval_ns}),
                )?;
            }
        }
        while let Some(ev) = dl.receive()? {
            if measuring {
                let name = ev.thread_name().to_string();
                acc.exec.entry(name.clone()).or_default().push(ev.exec_ns);
                *acc.misses.entry(name.clone()).or_default() += ev.missed as u64;
                acc.budget.insert(name.clone(), ev.budget_ns);
                *acc.backup_wakes.entry(name.clone()).or_default() += u64::from(ev.backup_wake);
                if ev.missed != 0 {
                    acc.missed.push(*ev);
                }
                if name.contains("lbv") {
                    acc.interval.cycles += 1;
                    if ev.missed != 0 {
                        *acc.interval
                            .misses
                            .entry(miss_cause::name(ev.miss_cause).to_string())
                            .or_default() += 1;
                    }
                }
                log.record(
                    &format!("/e2e/deadline/{name}"),
                    now,
                    &json!({
                        "cycle": ev.cycle, "lateness_ns": ev.lateness_ns, "exec_ns": ev.exec_ns,
                        "cpu_ns": ev.cpu_ns, "run_wait_ns": ev.run_wait_ns,
                        "sched_stats": ev.sched_stats, "backup_wake": ev.backup_wake,
                        "missed": ev.missed,
                        "miss_cause": miss_cause::name(ev.miss_cause),
                    }),
                )?;
            }
        }
        soak_tick(e, acc, pipeline.0.id());
        // Checked after draining, so the samples a finished session left behind are counted.
        if let Some(status) = pipeline.0.try_wait()? {
            if !status.success() {
                bail!("the pipeline ({cmdline}) failed: {status}");
            }
            ended = true;
            break;
        }
        std::thread::sleep(Duration::from_millis(2));
    }
    acc.lost += map.gaps() + neck.gaps() + dl.gaps();
    drop((map, neck, dec, dl, ctx));
    drop(pipeline);
    Ok(ended)
}

/// Soak: close the interval every `report_every_s` of measured time (RSS of the pipeline whose
/// launcher is `launcher`).
fn soak_tick(e: &E2eSettings, acc: &mut Samples, launcher: u32) {
    if e.report_every_s <= 0.0 {
        return;
    }
    let due = Duration::from_secs_f64(e.report_every_s * (acc.rows.len() + 1) as f64);
    if acc.measured < due {
        return;
    }
    let rss = crate::soak::pipeline_rss(launcher);
    let row = acc.interval.close(due.as_secs_f64(), acc.sessions + 1, rss);
    eprintln!(
        "soak {:.0} s: session {}, LBV {} cycles, {} misses, GBV {} rounds (p50 {:.0} ms, max {:.0} ms), RSS kB {:?}",
        row.t_s,
        row.session,
        row.cycles,
        row.misses.values().sum::<u64>(),
        row.gbv_rounds,
        row.gbv_p50_ms,
        row.gbv_max_ms,
        row.rss_kb
    );
    acc.rows.push(row);
}

/// The hidden `fake-pipeline` subcommand: depth at 30 Hz, a "mapper" publishing the map 8 ms
/// after each third frame (10 Hz), and an LBV executor at 10 Hz (real executor, ~1 ms of work)
/// publishing neck goals and decisions from the newest map, its deadline events and a GBV
/// decision every 2 s. Runs until SIGINT/SIGTERM.
pub fn fake_pipeline(ns: &str) -> Result<()> {
    let ports = PortsConfig::default();
    let clock = MonotonicClock::new();
    let ctx = PortContext::with_namespace(&ports, "fake-sim", ns)?;
    let depth = ctx.publisher::<DepthFrame>("depth")?;
    let map = ctx.publisher::<ObjectMap>("map")?;
    let deadline = ctx.publisher::<DeadlineEvent>("deadline")?;
    let (ev_tx, ev_rx) = crossbeam::channel::bounded::<DeadlineEvent>(256);
    let ns2 = ns.to_string();
    let cfg = ExecutorConfig {
        trace: EventTrace::All,
        ..ExecutorConfig::default()
    };
    let lbv = Executor::builder("lbv", Duration::from_millis(100))
        .config(&cfg)
        .events(ev_tx)
        .spawn(move || {
            let ctx = PortContext::with_namespace(&PortsConfig::default(), "fake-planner", &ns2)
                .expect("fake planner ports");
            let map_sub = ctx.subscriber::<ObjectMap>("map").expect("map subscriber");
            let neck = publisher::<NeckGoal>(&ctx, "neck/goal").expect("neck publisher");
            let dec =
                publisher::<PlannerDecision>(&ctx, "planner/decision").expect("decision publisher");
            let clock = MonotonicClock::new();
            let mut last_gbv = 0u64;
            move |c: &Cycle| {
                let _keep = &ctx;
                let Ok(Some(m)) = map_sub.latest() else {
                    return Control::Continue;
                };
                let (frame, seq) = (m.last_frame_stamp_ns, m.header.seq);
                drop(m);
                // ~1 ms of "evaluation".
                let t = clock.now_ns();
                while clock.now_ns() < t + 1_000_000 {
                    std::hint::spin_loop();
                }
                if let Ok(mut g) = neck.loan() {
                    g.frame_stamp_ns = frame;
                    g.map_seq = seq;
                    let _ = g.send(Stamp {
                        source_ns: clock.now_ns(),
                        sim_ns: 0,
                    });
                }
                let gbv = c.wake_ns >= last_gbv + 2_000_000_000;
                if let Ok(mut d) = dec.loan() {
                    d.kind = if gbv {
                        decision_kind::GBV
                    } else {
                        decision_kind::LBV
                    };
                    d.eval_ns = if gbv { 40_000_000 } else { clock.now_ns() - t };
                    d.map_seq = seq;
                    let _ = d.send(Stamp {
                        source_ns: clock.now_ns(),
                        sim_ns: 0,
                    });
                }
                if gbv {
                    last_gbv = c.wake_ns;
                }
                Control::Continue
            }
        })
        .map_err(|e| anyhow!("{e}"))?;
    let period = 33_333_333u64;
    let start = clock.now_ns();
    let mut k = 0u64;
    while !crate::interrupted() {
        clock.sleep_until(start + k * period);
        let stamp = clock.now_ns();
        let mut f = depth.loan()?;
        f.width = 640;
        f.height = 480;
        f.send(Stamp {
            source_ns: stamp,
            sim_ns: k * period,
        })?;
        if k.is_multiple_of(3) {
            clock.sleep_until(stamp + 8_000_000);
            let mut m = map.loan()?;
            m.last_frame_seq = k + 1;
            m.last_frame_stamp_ns = stamp;
            m.send(Stamp {
                source_ns: clock.now_ns(),
                sim_ns: k * period,
            })?;
        }
        while let Ok(ev) = ev_rx.try_recv() {
            let mut d = deadline.loan()?;
            *d = ev;
            d.send(Stamp {
                source_ns: ev.header.stamp_ns,
                sim_ns: 0,
            })?;
        }
        k += 1;
    }
    let _ = lbv.join();
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cpu_lists_are_parsed() {
        assert_eq!(parse_cpu_list("0-1").unwrap(), vec![0, 1]);
        assert_eq!(parse_cpu_list("0-2,5,7-8").unwrap(), vec![0, 1, 2, 5, 7, 8]);
        assert!(parse_cpu_list("3-1").is_err());
        assert!(parse_cpu_list("a").is_err());
        assert!(parse_cpu_list("").is_err());
    }

    #[test]
    fn misses_are_counted_and_tabled_by_cause() {
        let ev = |cycle, cause, stats| {
            let mut e = DeadlineEvent {
                cycle,
                lateness_ns: 7_000_000,
                exec_ns: 250_000,
                cpu_ns: 260_000,
                run_wait_ns: 10_000,
                missed: 1,
                miss_cause: cause,
                sched_stats: stats,
                ..Default::default()
            };
            e.set_thread_name("planner-lbv");
            e
        };
        let a = ev(3, miss_cause::LATE_WAKEUP, 1);
        let b = ev(9, miss_cause::RUN_QUEUE, 1);
        let c = ev(12, miss_cause::LATE_WAKEUP, 1);
        let d = ev(15, miss_cause::UNKNOWN, 0);
        let all = [&a, &b, &c, &d];
        assert_eq!(
            count_causes(&all),
            vec![("late-wakeup", 2), ("run-queue", 1), ("unknown", 1)]
        );
        let md = misses_table(&all);
        assert!(
            md.contains("| planner-lbv | 3 | 7.00 | 0.25 | 0.26 | 0.01 | late-wakeup |"),
            "{md}"
        );
        assert!(
            md.contains("| planner-lbv | 15 | 7.00 | 0.25 | – | – | unknown |"),
            "{md}"
        );
        assert_eq!(misses_table(&[]), "");
        let many: Vec<DeadlineEvent> = (0..25).map(|k| ev(k, 3, 1)).collect();
        let refs: Vec<&DeadlineEvent> = many.iter().collect();
        assert!(misses_table(&refs).contains("(5 more in report.json.)"));
    }

    #[test]
    fn probe_counts_wake_ups_late_by_the_budget() {
        let t = vec![vec![1_000, 5_000_000, 4_999_999], vec![20_000_000, 7]];
        assert_eq!(ProbeOutcome::over(&t, 5_000_000), vec![1, 1]);
    }
}
