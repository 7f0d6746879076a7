//! `e2e`: latencies of a live `vpsom run` pipeline, from the message headers.
//!
//! frame → map = `map.header.stamp_ns − map.last_frame_stamp_ns` at the first map that includes
//! the frame; frame → LBV = `neck_goal.header.stamp_ns − neck_goal.frame_stamp_ns` at the first
//! neck goal computed from such a map (each frame counted once; the same difference at every
//! neck goal is reported as the frame's age at the LBV); LBV execution time and misses from
//! the `deadline` topic (events whose thread name contains "lbv", or all events if none does);
//! GBV round time = `eval_ns` of GBV planner decisions. `--fake` runs this binary's own
//! `fake-pipeline` (same topics, realistic stamps, a real executor for the LBV) instead.

use crate::Outcome;
use crate::report::{BudgetCheck, SampleLog, Series, histogram_png};
use crate::settings::{Budgets, E2eSettings};
use crate::stats::{Stats, table_header, table_row};
use anyhow::{Context, Result, anyhow, bail};
use runtime::clock::{Clock, MonotonicClock};
use runtime::executor::{Control, Cycle, EventTrace, Executor, ExecutorConfig};
use runtime::ports::{PortContext, PortsConfig, Stamp};
use serde_json::json;
use shm_types::{DeadlineEvent, DepthFrame, NeckGoal, ObjectMap, PlannerDecision, decision_kind};
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
) -> Result<runtime::ports::Publisher<T>, runtime::ports::PortError> {
    match ctx.publisher::<T>(name) {
        Err(runtime::ports::PortError::Name { .. }) => ctx.publisher::<T>(&name.replace('/', "_")),
        r => r,
    }
}

fn subscriber<T: shm_types::Message>(
    ctx: &PortContext,
    name: &str,
) -> Result<runtime::ports::Subscriber<T>> {
    match ctx.subscriber::<T>(name) {
        Err(runtime::ports::PortError::Name { .. }) => {
            Ok(ctx.subscriber::<T>(&name.replace('/', "_"))?)
        }
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
            "no vpsom binary at {} (build it with `cargo build --release -p nodes` or pass --vpsom PATH)",
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
    neck_seen: u64,
    decisions_seen: [u64; 2],
    lost: u64,
    /// Measured time, summed over sessions.
    measured: Duration,
    /// Sessions run, and how many ended on their own (the planner finished).
    sessions: u32,
    sessions_finished: u32,
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
    let ports = if fake || e.pipeline_config.is_empty() {
        PortsConfig::default()
    } else {
        nodes::config::Config::load(Path::new(&e.pipeline_config))
            .with_context(|| format!("load {}", e.pipeline_config))?
            .ports
    };
    let duration = Duration::from_secs_f64(e.duration_s);
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
        neck_seen,
        decisions_seen,
        lost,
        measured,
        sessions,
        sessions_finished,
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
    md += &format!(
        "\nLBV deadline misses: {lbv_misses} over {} cycles. Samples lost to overwrite on the harness's \
         subscribers (not the pipeline's): {lost}. Received while measuring: {neck_seen} neck goals \
         (those with `frame_stamp_ns` = 0 are not counted above), {} GBV and {} LBV decisions.\n",
        lbv_exec.len(),
        decisions_seen[0],
        decisions_seen[1]
    );
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
    let mut errors = Vec::new();
    if frame_map.is_empty() || frame_lbv.is_empty() || lbv_exec.is_empty() {
        errors.push(format!(
            "e2e: too few samples (frame→map {}, frame→LBV {}, LBV cycles {})",
            frame_map.len(),
            frame_lbv.len(),
            lbv_exec.len()
        ));
    }
    let checks = vec![
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
    Ok(Outcome {
        markdown: md,
        json: json!({
            "settings": e, "fake": fake, "pipeline": cmdline, "namespace": ns,
            "sessions": sessions, "sessions_ended_by_planner": sessions_finished,
            "measured_s": measured.as_secs_f64(),
            "frame_to_map": p_map, "frame_to_lbv": p_lbv, "lbv_frame_age": p_age, "lbv_exec": p_exec,
            "lbv_threads": lbv_names, "lbv_deadline_misses": lbv_misses, "gbv_round": p_gbv,
            "harness_lost": lost,
        }),
        checks,
        errors,
    })
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
            let new_frame = g.frame_stamp_ns > lbv_frame;
            lbv_frame = lbv_frame.max(g.frame_stamp_ns);
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
                log.record(
                    &format!("/e2e/deadline/{name}"),
                    now,
                    &json!({"cycle": ev.cycle, "lateness_ns": ev.lateness_ns, "exec_ns": ev.exec_ns, "missed": ev.missed}),
                )?;
            }
        }
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
