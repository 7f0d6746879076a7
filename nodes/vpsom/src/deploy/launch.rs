//! The launcher: `vpsom run` starts the node processes (`vpsom node <role>`), watches them,
//! shows a status line and scores the session from what it hears on the topics.
//!
//! With `--nodes` naming a subset (e.g. `mapper,planner,recorder`), only those start; the inputs
//! they need that none of them publishes (without the sim: `depth`, `detections`, `robot/state`,
//! `nav/grid`) must come from outside, and the launcher reports every few seconds which of them
//! has no publisher yet ([`ExternalInputs`]). Without a scene there is no ground truth: the map is
//! written, scoring is skipped and the outcome says so.

use super::external::{self, ExternalInputs};
use super::health::{HealthWatch, InputAccount};
use super::host;
use crate::config::Config;
use crate::eval::{self, MatchParams, RunInfo, SessionLog};
use crate::sim::Scene;
use crate::{lockstep, topics};
use anyhow::Context;
use runtime::launcher::{ChildEvent, ChildSpec, Launcher, Liveness};
use runtime::ports::PortContext;
use shm_types::{
    DeadlineEvent, FrameVisibility, NavGoal, ObjectMap, PlannerDecision, RobotState, boxed_zeroed,
    decision_kind, planner_state,
};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

/// Settings shared by the launcher and every node process of one run.
#[derive(Debug, Clone)]
pub struct RunArgs {
    /// Scene: built-in name or file; `None` when no scene is given and the sim does not run
    /// (sensors from outside: no ground truth, no scoring).
    pub scene: Option<String>,
    /// Planner label (`vpsom`, `coverage`, `frontier`, `vpsom-no-<term>`).
    pub planner: String,
    /// Seed.
    pub seed: u64,
    /// Simulated seconds per wall second.
    pub time_scale: f64,
    /// Service namespace of the run.
    pub namespace: String,
    /// Output directory.
    pub out: PathBuf,
    /// Configuration file given on the command line (children load the same one).
    pub config_file: Option<PathBuf>,
    /// Deadline testing: keep the GBV pool saturated with this many extra candidate views
    /// (the planner host's GBV load, see [`planner_node`](super::planner_node)); 0 = off.
    pub gbv_load: usize,
    /// The roles the launcher starts, in launch order (see [`external::parse_nodes`]).
    pub nodes: Vec<&'static str>,
    /// The recorder serves the live view (Foxglove WebSocket) on this port.
    pub live: Option<u16>,
    /// `--link`: bridge this run's topics to another host (see [`super::link`]).
    pub link: Option<super::link::LinkArgs>,
}

impl RunArgs {
    fn child_args(&self, role: &str) -> Vec<String> {
        let mut a = vec![
            "node".into(),
            role.into(),
            "--planner".into(),
            self.planner.clone(),
            "--seed".into(),
            self.seed.to_string(),
            "--time-scale".into(),
            self.time_scale.to_string(),
            "--ns".into(),
            self.namespace.clone(),
            "--out".into(),
            self.out.display().to_string(),
            "--gbv-load".into(),
            self.gbv_load.to_string(),
        ];
        if let Some(scene) = &self.scene {
            a.push("--scene".into());
            a.push(scene.clone());
        }
        if let Some(c) = &self.config_file {
            a.push("--config".into());
            a.push(c.display().to_string());
        }
        if let (Some(p), "recorder") = (self.live, role) {
            a.push("--live".into());
            a.push(p.to_string());
        }
        a
    }
}

/// The configuration a run uses: the file's, with `[run]`'s camera size and the planner label.
pub fn run_config(base: &Config, planner: &str) -> Result<Config, lockstep::SessionError> {
    let cfg = base.with_camera(base.run.camera_width, base.run.camera_height, 0.0);
    lockstep::config_for(&cfg, planner)
}

/// What a run produced.
#[derive(Debug)]
pub struct RunOutcome {
    /// The metrics written to `metrics.json`; `None` when no scene was given (no ground truth
    /// to score against: only `map.json` is written).
    pub metrics: Option<eval::Metrics>,
    /// Objects in the final map: `(all, foreground, complete foreground)`.
    pub objects: (usize, usize, usize),
    /// Per input that came from outside the run: `(topic, valid samples the launcher saw,
    /// invalid samples it dropped)`.
    pub external: Vec<(&'static str, u64, u64)>,
    /// The mapper's account of the depth frames it received, from its last map:
    /// `(integrated, rejected as invalid, skipped for want of matching detections)`.
    pub mapper_frames: (u32, u32, u32),
    /// The planner's activity: `(LBV cycles, navigation goals published)`.
    pub planner_activity: (u64, u64),
    /// What the tunnel to the other host moved (`--link`).
    pub link: Option<super::link::LinkReport>,
    /// Every node's inputs from its heartbeats (`health`): received, invalid and overflow
    /// counts per topic, summed over the node's restarts.
    pub inputs: Vec<InputAccount>,
    /// What the launcher noticed about the nodes (deaths, hangs, restarts), in order.
    pub node_events: Vec<String>,
    /// Heartbeats the launcher received, and dropped as invalid.
    pub heartbeats: (u64, u64),
    /// Why the run ended.
    pub reason: String,
    /// Whether a node failed for good.
    pub failed: bool,
}

impl RunOutcome {
    /// The summary of a run without a scene (a Markdown table like the scored one): scoring
    /// skipped, how it ended, the map, and the samples each external input sent.
    pub fn unscored_summary(&self) -> String {
        let mut t = String::from("| metric | value |\n|---|---|\n");
        t += "| ground-truth scoring | skipped: no scene given (--scene names one) |\n";
        t += &format!("| end | {} |\n", self.reason);
        t += &format!(
            "| objects mapped (foreground / complete) | {} ({} / {}) |\n",
            self.objects.0, self.objects.1, self.objects.2
        );
        t + &self.input_rows()
    }

    /// Table rows on the inputs: what the mapper integrated, rejected and skipped, and the
    /// samples each external input sent (none when the sim ran here).
    pub fn input_rows(&self) -> String {
        let (integrated, rejected, unmatched) = self.mapper_frames;
        let mut t = format!("| depth frames integrated by the mapper | {integrated} |\n");
        t += &format!("| frames rejected by the mapper (failed validation) | {rejected} |\n");
        t += &format!("| frames skipped by the mapper (no matching detections) | {unmatched} |\n");
        let (cycles, goals) = self.planner_activity;
        t += &format!("| LBV cycles of the planner | {cycles} |\n");
        t += &format!("| navigation goals published by the planner | {goals} |\n");
        for (topic, n, invalid) in &self.external {
            t += &format!("| samples received on {topic} (external) | {n} |\n");
            t += &format!("| invalid samples dropped on {topic} (external) | {invalid} |\n");
        }
        if let Some(l) = &self.link {
            t += &l.rows();
        }
        for a in &self.inputs {
            t += &format!(
                "| {} ← {}: received / invalid / overflow | {} / {} / {} |\n",
                a.node, a.topic, a.received, a.invalid, a.overflow
            );
        }
        t += &format!(
            "| heartbeats received / invalid (launcher ← health) | {} / {} |\n",
            self.heartbeats.0, self.heartbeats.1
        );
        let events = if self.node_events.is_empty() {
            "none".to_string()
        } else {
            self.node_events.join("; ")
        };
        t + &format!("| node faults (deaths, hangs, restarts) | {events} |\n")
    }
}

/// `vpsom run`: launch the node processes, watch them, show a status line, score the session.
pub fn run(args: &RunArgs, cfg: &Config, exe: &Path) -> anyhow::Result<RunOutcome> {
    let stop = host::stop_on_signals()?;
    let scene = args
        .scene
        .as_deref()
        .map(Scene::builtin_or_load)
        .transpose()?;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating output directory {}", args.out.display()))?;
    let outcome_file = args.out.join(super::planner::OUTCOME_FILE);
    // A file left by an earlier run in the same directory must not be read as this run's.
    let _ = std::fs::remove_file(&outcome_file);
    // Likewise an earlier run's trace segments: the recorder continues a run's segments when
    // it is restarted, so a new run starts from none.
    let trace = args.out.join("trace.mcap");
    for seg in runtime::recorder::recover::segments(&trace).iter().rev() {
        std::fs::remove_file(seg).with_context(|| format!("removing {}", seg.display()))?;
    }
    let mut launcher = Launcher::new(
        &format!("launcher-{}", args.namespace),
        &runtime::ports::iceoryx2_config(),
    )?;
    if launcher.stale_nodes_removed_at_start() > 0 {
        eprintln!(
            "removed stale shared-memory resources of {} dead node(s) from earlier runs",
            launcher.stale_nodes_removed_at_start()
        );
    }
    // The tunnel first: it creates the run's services (see `link::watch`).
    let link = match &args.link {
        Some(l) => Some(super::link::Link::start(
            l,
            &args.namespace,
            &args.nodes,
            cfg,
            args.time_scale,
        )?),
        None => None,
    };
    // Subscribe before the nodes start so no decision or truth sample is missed.
    let ctx = PortContext::with_namespace(&cfg.ports, "run", &args.namespace)?;
    let truth = ctx.subscriber::<RobotState>(topics::TRUTH)?;
    let visibility = ctx.subscriber::<FrameVisibility>(topics::VISIBILITY)?;
    let map_sub = ctx.subscriber::<ObjectMap>(topics::MAP)?;
    let decisions = ctx.subscriber::<PlannerDecision>(topics::DECISION)?;
    let deadline = ctx.subscriber::<DeadlineEvent>(topics::DEADLINE)?;
    let nav = ctx.subscriber::<NavGoal>(topics::NAV_GOAL)?;
    let mut external = ExternalInputs::new(&ctx, &external::external_inputs(&args.nodes))?;
    if let Some(l) = &link {
        l.wait_for_peer(Duration::from_secs_f64(cfg.link.wait_for_peer_s), &stop);
    }
    let mut health = HealthWatch::new(&ctx)?;
    // A restarted mapper resumes from the newest map heard here (`[run] resume_map`).
    let resume = ctx.publisher::<ObjectMap>(topics::MAP_RESUME)?;
    let mut node_events = Vec::new();
    let liveness = Liveness {
        timeout: Duration::from_secs_f64(cfg.run.hang_timeout_s),
        startup: Duration::from_secs_f64(cfg.run.start_timeout_s),
    };
    for &role in &args.nodes {
        launcher.spawn(ChildSpec {
            name: role.into(),
            program: exe.to_path_buf(),
            args: args.child_args(role),
            max_restarts: cfg.run.max_restarts,
            inherit_stdout: false,
            liveness: Some(liveness),
        })?;
        if role == "recorder" {
            // The recorder (first in launch order) subscribes to every topic before anything
            // is published: the trace then holds every input the other nodes consume, from the
            // first (`vpsom replay --check` follows them).
            let until = Instant::now() + liveness.startup;
            while !health.all_up(&["recorder"])
                && Instant::now() < until
                && !stop.load(Ordering::Relaxed)
            {
                health.poll(&mut launcher)?;
                std::thread::sleep(Duration::from_millis(5));
            }
        }
    }
    let start = Instant::now();
    let mut log = SessionLog::starting_at(0);
    let mut map = boxed_zeroed::<ObjectMap>();
    let (mut sim_ns, mut misses, mut lbv_cycles, mut goal) = (0u64, 0u64, 0u64, None::<NavGoal>);
    let mut goals = 0u64;
    let mut final_state = None;
    let mut failed = false;
    let mut nodes_up = false;
    let mut last_status = Instant::now();
    let max_sim_ns = (cfg.run.max_sim_s * 1e9) as u64;
    let clock = if args.nodes.contains(&"sim") {
        "sim"
    } else {
        "robot"
    };
    let reason = loop {
        while let Some(s) = truth.receive()? {
            sim_ns = s.header.sim_time_ns;
            log.observe_truth(&s);
        }
        while let Some(v) = visibility.receive()? {
            log.observe_visibility(&v);
        }
        if let Some(m) = map_sub.latest()? {
            map.copy_from(&m);
        }
        while let Some(d) = decisions.receive()? {
            log.observe_decision(&d);
            if d.kind == decision_kind::GBV && d.state != planner_state::RUNNING {
                final_state = Some(d.state);
            }
        }
        while let Some(e) = deadline.receive()? {
            if e.thread_name() == "lbv" {
                lbv_cycles += 1;
                misses += u64::from(e.missed);
            }
        }
        while let Some(g) = nav.receive()? {
            goal = Some(*g);
            goals += 1;
        }
        if let Some(line) = external.poll(Instant::now())? {
            eprintln!("\n{line}");
        }
        if let Some(t) = external.robot_elapsed_ns() {
            // No sim: the robot's clock is the run's.
            sim_ns = sim_ns.max(t);
        }
        health.poll(&mut launcher)?;
        if !nodes_up && health.all_up(&args.nodes) {
            nodes_up = true;
            eprintln!(
                "\nnodes up (a heartbeat from each, so their ports are open): {}",
                args.nodes.join(", ")
            );
        }
        // Late joiners (a restarting mapper) get the history only from the publisher's side.
        resume.update_connections()?;
        for ev in launcher.poll() {
            eprintln!("\n{ev}");
            node_events.push(ev.to_string());
            if let ChildEvent::Restarted { ref name, .. } = ev
                && name == "mapper"
                && cfg.run.resume_map
            {
                let mut m = resume.loan()?;
                m.copy_from(&map);
                m.send(runtime::ports::Stamp {
                    source_ns: 0,
                    sim_ns: map.header.sim_time_ns,
                })?;
                eprintln!(
                    "handed the restarted mapper its last map: {} objects",
                    map.objects().len()
                );
            }
            match ev {
                ChildEvent::Failed { .. } => failed = true,
                ChildEvent::Finished { ref name } if name == "planner" && final_state.is_none() => {
                    final_state = Some(planner_state::NO_CANDIDATES);
                }
                _ => {}
            }
        }
        if failed {
            break "a node failed (see above)".to_string();
        }
        if let Some(s) = final_state {
            break if s == planner_state::TERMINATED {
                "planner terminated".into()
            } else {
                "planner stopped: no reachable candidate".into()
            };
        }
        if stop.load(Ordering::Relaxed) {
            break "interrupted".into();
        }
        if sim_ns >= max_sim_ns {
            break format!("simulated-time limit {} s", cfg.run.max_sim_s);
        }
        if last_status.elapsed() >= Duration::from_secs(1) {
            last_status = Instant::now();
            let objs = map.objects();
            eprint!(
                "\r{:>5.0}s wall {:>6.1}s {clock} | objects {:>2} mapped, {:>2} complete | GBV {} | \
                 LBV deadline misses {}/{}   ",
                start.elapsed().as_secs_f64(),
                sim_ns as f64 * 1e-9,
                objs.iter().filter(|o| !o.is_background()).count(),
                objs.iter()
                    .filter(|o| !o.is_background() && o.is_complete())
                    .count(),
                goal.map_or("-".to_string(), |g| format!(
                    "#{} ({:.1}, {:.1})",
                    g.goal_id, g.pose[0], g.pose[1]
                )),
                misses,
                lbv_cycles
            );
            let _ = std::io::stderr().flush();
        }
        std::thread::sleep(Duration::from_millis(10));
    };
    eprintln!("\nstopping: {reason}");
    if let Some(l) = &link {
        l.quiesce();
    }
    for (name, exit) in launcher.stop_all(Duration::from_secs_f64(cfg.run.stop_grace_s)) {
        if let Some(e) = exit {
            eprintln!("  {name}: {e}");
        }
    }
    // Read what arrived while the nodes stopped (the final map, the last heartbeats).
    health.poll(&mut launcher)?;
    if let Some(m) = map_sub.latest()? {
        map.copy_from(&m);
    }
    while let Some(s) = truth.receive()? {
        log.observe_truth(&s);
    }
    while let Some(v) = visibility.receive()? {
        log.observe_visibility(&v);
    }
    let est = eval::estimates_from_map(&map);
    let mapper_frames = (
        map.frames_integrated,
        map.frames_rejected,
        map.frames_unmatched,
    );
    let objects = (
        map.objects().len(),
        map.objects().iter().filter(|o| !o.is_background()).count(),
        map.objects()
            .iter()
            .filter(|o| !o.is_background() && o.is_complete())
            .count(),
    );
    // Count what the external inputs sent while the nodes stopped (the line is not news).
    let _ = external.poll(Instant::now())?;
    // A failed tunnel does not cost the run its outputs: it is reported, the rest is written.
    let link = link.and_then(|l| match l.finish() {
        Ok(r) => Some(r),
        Err(e) => {
            eprintln!("link: {e}");
            None
        }
    });
    // The planner's own account of its end (reason, explored, objects given up), if it left one.
    let outcome = std::fs::read(&outcome_file)
        .ok()
        .and_then(|b| serde_json::from_slice::<super::planner::PlannerOutcome>(&b).ok());
    let reason = match &outcome {
        Some(o) if final_state.is_some() && !failed => format!("planner: {}", o.reason),
        _ => reason,
    };
    // No scene, no ground truth: the map is written, nothing is scored.
    let Some(scene) = scene else {
        eval::MapFile::from_estimates("none", &est).write(&args.out.join(eval::MAP_FILE))?;
        return Ok(RunOutcome {
            metrics: None,
            objects,
            external: external.samples(),
            mapper_frames,
            planner_activity: (lbv_cycles, goals),
            link,
            inputs: health.accounts(),
            heartbeats: health.heartbeats(),
            node_events,
            reason,
            failed,
        });
    };
    log.add_deadline_misses(misses);
    let terminated = final_state == Some(planner_state::TERMINATED);
    log.finish(sim_ns, terminated, &reason);
    if let Some(o) = outcome {
        log.planner_outcome(o.explored, o.objects_given_up);
    }
    let run = RunInfo {
        scene: scene.name.clone(),
        planner: args.planner.clone(),
        seed: args.seed,
    };
    let gt = lockstep::ground_truth(&scene);
    let metrics = log.metrics(&run, &gt, &est, &MatchParams::default());
    let plot = log.plot_input(&run, lockstep::room(&scene), &gt, &est, &metrics);
    eval::write_run_outputs(&args.out, &metrics, &est, &plot)?;
    Ok(RunOutcome {
        metrics: Some(metrics),
        objects,
        external: external.samples(),
        mapper_frames,
        planner_activity: (lbv_cycles, goals),
        link,
        inputs: health.accounts(),
        heartbeats: health.heartbeats(),
        node_events,
        reason,
        failed,
    })
}
