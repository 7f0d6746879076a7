//! `vpsom`: the vpsom-rt command line.

use anyhow::Context;
use clap::{Args, Parser, Subcommand};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use vpsom::config::Config;
use vpsom::sim::{BUILTIN_SCENES, Scene, scenegen};
use vpsom::{bench, deploy, lockstep, sensing};

/// Active sparse object mapping with VP-SOM view planning on a zero-copy real-time runtime.
///
/// With no subcommand, runs a full mapping session on the built-in scene (`vpsom run`).
#[derive(Debug, Parser)]
#[command(name = "vpsom", version, about, long_about = None)]
struct Cli {
    /// Configuration file (default: ./config/default.toml if present, else the built-in copy).
    #[arg(long, global = true)]
    config: Option<PathBuf>,
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Run a mapping session: sim, mapper, planner and recorder as processes over iceoryx2.
    Run(RunCmd),
    /// Reproduce the paper's experiments: scenes × planners × seeds on the lockstep host.
    Bench(BenchCmd),
    /// Measure the simulated sensing on a scripted tour: detector recall, false positives, box
    /// IoU, confusion, invalid depth, pose ATE/RPE; prints a table, writes sensing.json.
    Sensing(SensingCmd),
    /// The orbit experiment: circle one object cluster for some laps (no planner; the neck
    /// points at the cluster), scoring the map after each lap; prints the table, writes orbit.md.
    Orbit(OrbitCmd),
    /// Scene files: generate random rooms (`vpsom scene gen --seed N --out FILE`).
    #[command(subcommand)]
    Scene(SceneCmd),
    /// Re-render tables and plots from saved metrics.json files; or, with --compare A B, the
    /// paired differences B − A between two bench folders (compare.md).
    Report {
        /// Run directories or trees containing metrics.json files.
        #[arg(required_unless_present = "compare")]
        dirs: Vec<PathBuf>,
        /// Compare two bench folders: B − A on the runs of the same (scene, planner, seed), or
        /// on room means when they share no seed; says per metric whether the difference is
        /// separated from the seed spread.
        #[arg(long, num_args = 2, value_names = ["A", "B"], conflicts_with = "dirs")]
        compare: Option<Vec<PathBuf>>,
        /// Where to write report.md, CSVs and figures (default: the first directory), or
        /// compare.md (default: B).
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Inspect an MCAP trace.
    #[command(subcommand)]
    Trace(TraceCmd),
    /// Re-run the mapper and planner on a trace's recorded inputs (open loop: the robot moves
    /// as recorded).
    Replay(ReplayCmd),
    /// Print what the runtime can get on this machine (shared memory, scheduling, clocks, CPUs).
    Doctor,
    /// Run one node process of a `vpsom run` (started by the launcher).
    #[command(hide = true)]
    Node {
        /// sim | mapper | planner | recorder
        role: String,
        #[command(flatten)]
        session: SessionArgs,
        /// Service namespace.
        #[arg(long)]
        ns: String,
        /// Output directory.
        #[arg(long)]
        out: PathBuf,
        /// Simulated seconds per wall second.
        #[arg(long)]
        time_scale: f64,
        /// Extra GBV candidates kept in the pool (see `vpsom run --gbv-load`).
        #[arg(long, default_value_t = 0)]
        gbv_load: usize,
        /// The recorder serves the live view on this port (see `vpsom run --live`).
        #[arg(long)]
        live: Option<u16>,
    },
}

#[derive(Debug, Clone, Args)]
struct SessionArgs {
    /// Scene: a built-in name (paper-scene-1, -2, -3) or a scene file (default: `[sim] scene`
    /// when the sim runs; without the sim, none, and nothing is scored against ground truth).
    #[arg(long)]
    scene: Option<String>,
    /// View planner: vpsom | coverage | frontier (or vpsom-no-<term> for an ablation).
    #[arg(long, default_value = "vpsom")]
    planner: String,
    /// Seed of every random process.
    #[arg(long, default_value_t = 1)]
    seed: u64,
}

#[derive(Debug, Args)]
struct RunCmd {
    #[command(flatten)]
    session: SessionArgs,
    /// Simulated seconds per wall second (default: `[run] time_scale`; a real robot runs at 1).
    #[arg(long)]
    time_scale: Option<f64>,
    /// Output directory (default: out/<scene>-<planner>-<seed>).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Service namespace (default: run<pid>, so concurrent runs never collide; with --link,
    /// `[ports] namespace`, the same on both hosts).
    #[arg(long)]
    ns: Option<String>,
    /// Run in one process on the lockstep host instead (no IPC; deterministic).
    #[arg(long)]
    lockstep: bool,
    /// Deadline testing: keep the planner's GBV worker pool saturated by evaluating N extra
    /// candidate views of the current map whenever it has no such job (results discarded);
    /// the LBV deadline misses then show what full GBV load costs. 0 = off.
    #[arg(
        long,
        value_name = "N",
        default_value_t = 0,
        conflicts_with = "lockstep"
    )]
    gbv_load: usize,
    /// Start only these nodes (comma list of sim, mapper, planner, recorder; default all).
    /// Inputs none of them publishes must come from outside (a robot's drivers, see
    /// `shm_types/include/vpsom_topics.h`); the run reports which have no publisher yet.
    #[arg(long, value_delimiter = ',', conflicts_with = "lockstep")]
    nodes: Vec<String>,
    /// Serve the run's topics live to Foxglove over its WebSocket protocol (the recorder
    /// publishes; connect Foxglove to ws://HOST:PORT). PORT defaults to `[recorder] live_port`.
    #[arg(long, value_name = "PORT", num_args = 0..=1, conflicts_with = "lockstep")]
    live: Option<Option<u16>>,
    /// Bridge this run's topics to a run on another host with the same --ns, through
    /// iceoryx2's link tunnel over zenoh: zenoh endpoints, `listen:`/`connect:` or bare (an
    /// unspecified address such as tcp/0.0.0.0:7447 is listened on, any other connected to).
    /// See README "Running across two machines".
    #[arg(long, value_name = "ENDPOINT", num_args = 1.., conflicts_with = "lockstep")]
    link: Vec<String>,
    /// zenoh configuration file for --link (JSON5: endpoints, TLS, access control; default
    /// `[link] zenoh_config`, else built in); the --link endpoints replace its lists.
    #[arg(long, value_name = "FILE", requires = "link")]
    zenoh_config: Option<PathBuf>,
}

#[derive(Debug, Args)]
struct ReplayCmd {
    /// The trace (`out/<run>/trace.mcap`, or the run directory).
    trace: PathBuf,
    /// View planner of the replay (default: the config's `[planner] kind`; vpsom | coverage |
    /// frontier | vpsom-no-<term>).
    #[arg(long)]
    planner: Option<String>,
    /// Compare every map, decision and goal with the recorded one and report the first
    /// divergence (exit status 1 if there is one).
    #[arg(long)]
    check: bool,
    /// Output directory of the new trace (default: `<trace dir>/replay-<planner>`).
    #[arg(long, conflicts_with = "check")]
    out: Option<PathBuf>,
}

#[derive(Debug, Args)]
struct BenchCmd {
    /// Scenes (repeatable; default: the three paper scenes).
    #[arg(long = "scene")]
    scenes: Vec<String>,
    /// Planners (repeatable; default: vpsom, coverage, frontier).
    #[arg(long = "planner")]
    planners: Vec<String>,
    /// Seeds per scene and planner (default: `[bench] seeds`).
    #[arg(long)]
    seeds: Option<u64>,
    /// First seed: the runs use seeds N..N+seeds-1.
    #[arg(long, value_name = "N", default_value_t = 1)]
    first_seed: u64,
    /// Sessions at once (default: one per CPU).
    #[arg(long)]
    jobs: Option<usize>,
    /// Output directory.
    #[arg(long, default_value = "out/bench")]
    out: PathBuf,
    /// Add VP-SOM with each F(v) term disabled.
    #[arg(long)]
    ablation: bool,
    /// Add K generated rooms (`vpsom scene gen` seeds 1..=K, kind from the seed) to the scenes;
    /// their scene files are saved under DIR/scenes/.
    #[arg(long, value_name = "K", default_value_t = 0)]
    generated: u64,
    /// With --generated: run only the generated rooms (not the paper scenes).
    #[arg(long, requires = "generated")]
    generated_only: bool,
    /// A fixed scene set: `tune` (the paper scenes and generated rooms 1-20: develop, tune and
    /// diagnose on these) or `test` (generated rooms 1001-1030, the kinds balanced: held out,
    /// read as means once per change that is ready to land).
    #[arg(long, value_parser = ["tune", "test"], conflicts_with_all = ["scenes", "generated"])]
    split: Option<String>,
    /// Sensing sensitivity: the planners (default: vpsom only) under the default sensing and
    /// with each sensing group made twice as bad, one at a time; writes sensitivity.md.
    #[arg(long, conflicts_with = "ablation")]
    sensitivity: bool,
    /// Pose ablation: the planners (default: vpsom only) under the default sensing, with every
    /// pose-error source off, and with each source alone (odometry, SLAM residual, map drift,
    /// the SLAM's 6-DoF part, neck bias, neck noise, stamp delay); writes pose-ablation.md.
    #[arg(long, conflicts_with_all = ["ablation", "sensitivity"])]
    pose_ablation: bool,
    /// Run only part K of N of the run list (sorted by scene, planner, seed; the runs whose
    /// index modulo N is K − 1), e.g. one task of a Slurm array. Writes no report, since it
    /// would cover 1/N of the runs: merge the shards with `vpsom report DIR...` (the shards may
    /// share one --out). See docs/cluster.md.
    #[arg(long, value_name = "K/N")]
    shard: Option<bench::Shard>,
    /// Skip the runs whose metrics.json in --out is complete (a preempted or killed bench
    /// continues where it stopped; a torn or missing file is run again).
    #[arg(long)]
    resume: bool,
}

#[derive(Debug, Subcommand)]
enum SceneCmd {
    /// Generate a random room (office, kitchen, living room or lab) as a scene file: 4-9 m
    /// sides, maybe a partition, 1-4 support clusters, 5-25 objects each visible from a
    /// reachable pose. Same seed, kind and config → the same file.
    Gen {
        /// Seed of the room.
        #[arg(long)]
        seed: u64,
        /// office | kitchen | living | lab (default: from the seed).
        #[arg(long)]
        kind: Option<String>,
        /// Scene file to write.
        #[arg(long)]
        out: PathBuf,
    },
}

#[derive(Debug, Args)]
struct SensingCmd {
    /// Scenes: built-in names or scene files (default: the three paper scenes).
    scenes: Vec<String>,
    /// Seed of the simulator.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Frames per scene (default: `[sensing] frames`).
    #[arg(long)]
    frames: Option<u64>,
    /// Output directory.
    #[arg(long, default_value = "results/sensing")]
    out: PathBuf,
}

#[derive(Debug, Args)]
struct OrbitCmd {
    /// Scene: a built-in name or a scene file.
    #[arg(long, default_value = "paper-scene-1")]
    scene: String,
    /// Seed of the simulator.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Laps around the cluster.
    #[arg(long, default_value_t = 3)]
    laps: u32,
    /// Waypoints per lap.
    #[arg(long, default_value_t = 16)]
    waypoints: u32,
    /// A sensing variant applied to the configuration (a bench label's `@<variant>`, e.g.
    /// `pose-off`).
    #[arg(long)]
    variant: Option<String>,
    /// Output directory (orbit.md).
    #[arg(long, default_value = "results/orbit")]
    out: PathBuf,
}

#[derive(Debug, Subcommand)]
enum TraceCmd {
    /// Topics, message counts, time range and drop counts (all segments of a run when FILE is
    /// its first segment, trace.mcap, or its directory).
    Info {
        /// MCAP file, or a run directory.
        file: PathBuf,
    },
    /// Export any channel as CSV, decoded through its schema (one column per field, plus log_time_ns); all segments of a
    /// run as for `info`.
    Export {
        /// MCAP file, or a run directory.
        file: PathBuf,
        /// Topic, e.g. /runtime/deadline.
        #[arg(long)]
        topic: String,
        /// CSV file to write (default: stdout).
        #[arg(long, short)]
        out: Option<PathBuf>,
    },
    /// Write a finished, indexed MCAP holding every complete chunk of a file cut short by a
    /// crash (SIGKILL of the recorder).
    Recover {
        /// The torn MCAP file.
        input: PathBuf,
        /// The file to write (must differ from the input).
        output: PathBuf,
    },
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let config = cli.config.clone();
    let command = cli.command.unwrap_or(Command::Run(RunCmd {
        session: SessionArgs {
            scene: None,
            planner: "vpsom".into(),
            seed: 1,
        },
        time_scale: None,
        out: None,
        ns: None,
        lockstep: false,
        gbv_load: 0,
        nodes: Vec::new(),
        live: None,
        link: Vec::new(),
        zenoh_config: None,
    }));
    let result = match command {
        Command::Run(cmd) => run(config, cmd),
        Command::Bench(cmd) => bench_cmd(config, cmd),
        Command::Sensing(cmd) => sensing_cmd(config, cmd),
        Command::Orbit(cmd) => orbit_cmd(config, cmd),
        Command::Scene(cmd) => scene_cmd(config, cmd),
        Command::Report {
            compare: Some(ab),
            out,
            ..
        } => compare(&ab[0], &ab[1], out),
        Command::Report { dirs, out, .. } => report(&dirs, out),
        Command::Trace(cmd) => trace(cmd),
        Command::Replay(cmd) => replay_cmd(config, cmd),
        Command::Doctor => doctor(config),
        Command::Node {
            role,
            session,
            ns,
            out,
            time_scale,
            gbv_load,
            live,
        } => node(
            config,
            &role,
            session,
            ns,
            out,
            (time_scale, gbv_load, live),
        ),
    };
    match result {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {}", vpsom::error_report(&e));
            ExitCode::FAILURE
        }
    }
}

fn load_config(file: Option<&Path>) -> anyhow::Result<Config> {
    Ok(Config::load_or_default(file)?.0)
}

fn load_scene(name: &str) -> anyhow::Result<Scene> {
    Scene::builtin_or_load(name).with_context(|| {
        format!(
            "scene {name:?} (built-in scenes: {})",
            BUILTIN_SCENES.map(|(n, _)| n).join(", ")
        )
    })
}

fn run(config: Option<PathBuf>, cmd: RunCmd) -> anyhow::Result<ExitCode> {
    let (base, from) = Config::load_or_default(config.as_deref())?;
    runtime::ports::set_domain(&base.ports.domain)?;
    let s = &cmd.session;
    let nodes = deploy::parse_nodes(&cmd.nodes).map_err(anyhow::Error::msg)?;
    // The sim needs a scene (`[sim] scene` by default); without it, a scene is only named to
    // score the map against.
    let scene_name = match &s.scene {
        Some(name) => Some(name.clone()),
        None if cmd.lockstep || nodes.contains(&"sim") => Some(base.sim.scene.clone()),
        None => None,
    };
    let scene = scene_name.as_deref().map(load_scene).transpose()?;
    let scene_label = scene.as_ref().map_or("none", |sc| sc.name.as_str());
    let cfg = deploy::run_config(&base, &s.planner)?;
    let time_scale = cmd.time_scale.unwrap_or(cfg.run.time_scale);
    anyhow::ensure!(
        time_scale.is_finite() && time_scale > 0.0,
        "--time-scale {time_scale}: must be > 0"
    );
    let out = cmd
        .out
        .unwrap_or_else(|| PathBuf::from(format!("out/{scene_label}-{}-{}", s.planner, s.seed)));
    // Hosts joined by --link must agree on the namespace: without --ns they take
    // `[ports] namespace`, a run on its own host a fresh one.
    let ns = cmd.ns.unwrap_or_else(|| match cmd.link.is_empty() {
        true => format!("run{}", std::process::id()),
        false => base.ports.namespace.clone(),
    });
    eprintln!(
        "vpsom run: scene {} | planner {} | seed {} | camera {}x{} at {} Hz | time scale {} | \
         config {} | out {}{}{}",
        scene_label,
        s.planner,
        s.seed,
        cfg.camera.width,
        cfg.camera.height,
        cfg.rates.camera_hz,
        time_scale,
        from.display(),
        out.display(),
        if cmd.lockstep { " | lockstep" } else { "" },
        if nodes.len() < deploy::ROLES.len() {
            format!(" | nodes {}", nodes.join(","))
        } else {
            String::new()
        },
    );
    std::fs::create_dir_all(&out)
        .with_context(|| format!("creating output directory {}", out.display()))?;
    if cmd.lockstep {
        let spec = lockstep::SessionSpec {
            scene: scene.context("lockstep runs simulate a scene")?,
            config: cfg.clone(),
            seed: s.seed,
            label: s.planner.clone(),
            max_sim_s: cfg.run.max_sim_s,
            record: Some(out.join("trace.mcap")),
        };
        let r = lockstep::run_session(&spec, |p| {
            eprint!(
                "\r{:>6.1}s sim | objects {:>2} | complete {:>2} | goals {:>2}   ",
                p.sim_s, p.objects, p.complete, p.goals
            )
        })?;
        eprintln!();
        lockstep::write_outputs(&spec, &r, &out)?;
        print_metrics(&r.metrics);
    } else {
        let args = deploy::RunArgs {
            scene: scene_name,
            planner: s.planner.clone(),
            seed: s.seed,
            time_scale,
            namespace: ns,
            out: out.clone(),
            config_file: config,
            gbv_load: cmd.gbv_load,
            nodes,
            live: cmd.live.map(|p| p.unwrap_or(cfg.recorder.live_port)),
            link: (!cmd.link.is_empty()).then(|| deploy::link::LinkArgs {
                endpoints: cmd.link.clone(),
                zenoh_config: cmd.zenoh_config.clone(),
            }),
        };
        let exe = std::env::current_exe().context("locating the vpsom executable")?;
        let outcome = deploy::run(&args, &cfg, &exe)?;
        match &outcome.metrics {
            Some(m) => {
                print_metrics(m);
                print!("{}", outcome.input_rows());
            }
            None => print!("{}", outcome.unscored_summary()),
        }
        if outcome.failed {
            anyhow::bail!("{}; outputs saved in {}", outcome.reason, out.display());
        }
    }
    println!("outputs: {}", out.display());
    Ok(ExitCode::SUCCESS)
}

fn print_metrics(m: &vpsom::eval::Metrics) {
    let opt = |v: Option<f64>, d: usize| v.map_or("-".to_string(), |x| format!("{x:.d$}"));
    println!("| metric | value |\n|---|---|");
    println!(
        "| scene | {} |\n| planner | {} |\n| seed | {} |",
        m.scene, m.planner, m.seed
    );
    println!(
        "| terminated | {} ({}) |",
        m.terminated, m.termination_reason
    );
    println!(
        "| objects (gt / estimated) | {} / {} |",
        m.objects_gt, m.objects_estimated
    );
    println!(
        "| precision | {:.2} |\n| recall | {:.2} |",
        m.precision, m.recall
    );
    println!(
        "| IoU | {} |\n| CDE (m) | {} |",
        opt(m.iou, 3),
        opt(m.cde_m, 3)
    );
    println!(
        "| path length (m) | {:.2} |\n| time (s) | {:.1} |",
        m.path_length_m, m.time_s
    );
    println!("| non-occlusion | {} |", opt(m.non_occlusion, 3));
    println!("| localization failures | {} |", m.localization_failures);
    println!("| deadline misses | {} |", m.deadline_misses);
}

fn bench_cmd(config: Option<PathBuf>, cmd: BenchCmd) -> anyhow::Result<ExitCode> {
    let base = load_config(config.as_deref())?;
    let b = base.bench;
    let (seeds, paper): (Vec<u64>, bool) = match cmd.split.as_deref() {
        Some("tune") => ((1..=20).collect(), true),
        Some("test") => ((1001..=1030).collect(), false),
        _ => ((1..=cmd.generated).collect(), !cmd.generated_only),
    };
    let names: Vec<String> = if !paper {
        cmd.scenes
    } else if cmd.scenes.is_empty() {
        BUILTIN_SCENES.iter().map(|(n, _)| n.to_string()).collect()
    } else {
        cmd.scenes
    };
    let mut scenes: Vec<Scene> = names
        .iter()
        .map(|s| load_scene(s))
        .collect::<anyhow::Result<_>>()?;
    if !seeds.is_empty() {
        let dir = cmd.out.join("scenes");
        std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
        for seed in seeds {
            let g = scenegen::generate(seed, None, &base)?;
            let file = dir.join(format!("{}.toml", g.scene.name));
            std::fs::write(&file, &g.toml)
                .with_context(|| format!("writing {}", file.display()))?;
            scenes.push(g.scene);
        }
    }
    let mut planners = if !cmd.planners.is_empty() {
        cmd.planners
    } else if cmd.sensitivity || cmd.pose_ablation {
        vec!["vpsom".into()]
    } else {
        vec!["vpsom".into(), "coverage".into(), "frontier".into()]
    };
    let variants: &[&str] = if cmd.sensitivity {
        &vpsom::variants::SENSITIVITY
    } else if cmd.pose_ablation {
        &vpsom::variants::POSE_ABLATION
    } else {
        &[]
    };
    let base_planners: Vec<String> = planners.clone();
    for v in variants {
        planners.extend(base_planners.iter().map(|p| format!("{p}@{v}")));
    }
    if cmd.ablation {
        planners.extend(
            vpsom::planner::AblationConfig::TERMS
                .iter()
                .map(|t| format!("vpsom-no-{t}")),
        );
    }
    let jobs = cmd.jobs.unwrap_or(b.jobs);
    let jobs = if jobs == 0 {
        std::thread::available_parallelism().map_or(1, |n| n.get())
    } else {
        jobs
    };
    let spec = bench::BenchSpec {
        scenes,
        planners,
        seeds: cmd.seeds.unwrap_or(b.seeds),
        first_seed: cmd.first_seed,
        jobs,
        out: cmd.out,
        config: base.with_camera(b.camera_width, b.camera_height, b.camera_hz),
        max_sim_s: b.max_sim_s,
        shard: cmd.shard.unwrap_or(bench::Shard::ALL),
        resume: cmd.resume,
    };
    let part = match cmd.shard {
        Some(s) => format!(" (shard {s})"),
        None => String::new(),
    };
    eprintln!(
        "vpsom bench: {} scene(s) × {} planner(s) × {} seed(s) from {}{part}, {} at once, \
         camera {}x{} at {} Hz",
        spec.scenes.len(),
        spec.planners.len(),
        spec.seeds,
        spec.first_seed,
        spec.jobs,
        spec.config.camera.width,
        spec.config.camera.height,
        spec.config.rates.camera_hz
    );
    let start = std::time::Instant::now();
    let outcomes = bench::run_bench(&spec)?;
    let table = if cmd.sensitivity {
        Some(bench::SENSITIVITY_FILE)
    } else if cmd.pose_ablation {
        Some(bench::POSE_ABLATION_FILE)
    } else {
        None
    };
    if let (Some(table), Some(shard)) = (table, cmd.shard) {
        println!(
            "{table}: not written by shard {shard} (it would cover part of the runs); when every \
             shard is done, the same command with --resume and no --shard writes it"
        );
    } else if let Some(table) = table {
        let file = spec.out.join(table);
        std::fs::write(&file, bench::sensitivity_table(&outcomes))
            .with_context(|| format!("writing {}", file.display()))?;
        println!("{table}: {}", file.display());
    }
    let failed: Vec<_> = outcomes.iter().filter(|o| o.result.is_err()).collect();
    for f in &failed {
        eprintln!(
            "FAILED {}: {}",
            f.dir.display(),
            f.result.as_ref().err().map_or("", |e| e)
        );
    }
    let resumed = outcomes.iter().filter(|o| o.resumed).count();
    let runs = match resumed {
        0 => format!("{} runs", outcomes.len()),
        r => format!("{} runs ({r} already complete)", outcomes.len()),
    };
    let secs = start.elapsed().as_secs_f64();
    match cmd.shard {
        None => println!(
            "{runs} in {secs:.0} s; report: {}",
            spec.out.join("report.md").display()
        ),
        Some(shard) => println!(
            "shard {shard}: {runs} in {secs:.0} s in {}; no report (a shard's would cover 1/{} \
             of the runs): merge with `vpsom report DIR...` when every shard is done",
            spec.out.display(),
            shard.n
        ),
    }
    Ok(if failed.is_empty() {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}

fn orbit_cmd(config: Option<PathBuf>, cmd: OrbitCmd) -> anyhow::Result<ExitCode> {
    let mut base = load_config(config.as_deref())?;
    if let Some(v) = &cmd.variant {
        vpsom::variants::apply(&mut base, v)?;
    }
    let b = base.bench;
    let spec = vpsom::orbit::OrbitSpec {
        scene: load_scene(&cmd.scene)?,
        config: base.with_camera(b.camera_width, b.camera_height, b.camera_hz),
        seed: cmd.seed,
        laps: cmd.laps,
        waypoints: cmd.waypoints,
    };
    anyhow::ensure!(cmd.laps > 0, "--laps must be > 0");
    let r = vpsom::orbit::run_orbit(&spec)?;
    let table = r.table();
    println!("{table}");
    // Centre errors within half an object voxel (`[mapper] object_voxel` = 1 cm) are equal.
    let bad = r.regressions(0.02, 0.005);
    let verdict = if bad.is_empty() {
        "every object with ≥ 50 visible px: IoU after the last lap ≥ the first's − 0.02, centre error not grown by more than 5 mm\n".to_string()
    } else {
        format!(
            "worse after the last lap than after the first:\n- {}\n",
            bad.join("\n- ")
        )
    };
    println!("{verdict}");
    std::fs::create_dir_all(&cmd.out).with_context(|| format!("creating {}", cmd.out.display()))?;
    let file = cmd.out.join("orbit.md");
    std::fs::write(&file, format!("{table}\n{verdict}"))
        .with_context(|| format!("writing {}", file.display()))?;
    println!("orbit: {}", file.display());
    Ok(ExitCode::SUCCESS)
}

fn sensing_cmd(config: Option<PathBuf>, cmd: SensingCmd) -> anyhow::Result<ExitCode> {
    let cfg = load_config(config.as_deref())?;
    let names = if cmd.scenes.is_empty() {
        BUILTIN_SCENES.iter().map(|(n, _)| n.to_string()).collect()
    } else {
        cmd.scenes
    };
    let spec = sensing::SensingSpec {
        scenes: names
            .iter()
            .map(|s| load_scene(s))
            .collect::<anyhow::Result<_>>()?,
        frames: cmd.frames.unwrap_or(cfg.sensing.frames),
        seed: cmd.seed,
        config: cfg,
    };
    anyhow::ensure!(spec.frames > 0, "--frames must be > 0");
    let c = &spec.config;
    eprintln!(
        "vpsom sensing: {} scene(s) × {} frames, camera {}x{} at {} Hz, seed {}",
        spec.scenes.len(),
        spec.frames,
        c.camera.width,
        c.camera.height,
        sensing::camera_hz(c),
        spec.seed
    );
    let start = std::time::Instant::now();
    let report = sensing::run_sensing(&spec, |f| {
        eprintln!(
            "  {} done ({:.0} s)",
            f.scene,
            start.elapsed().as_secs_f64()
        )
    })?;
    let path = report.write(&cmd.out)?;
    print!("{}", report.table());
    println!("report: {}", path.display());
    Ok(ExitCode::SUCCESS)
}

fn scene_cmd(config: Option<PathBuf>, cmd: SceneCmd) -> anyhow::Result<ExitCode> {
    let cfg = load_config(config.as_deref())?;
    match cmd {
        SceneCmd::Gen { seed, kind, out } => {
            let kind = match kind.as_deref() {
                None => None,
                Some(k) => Some(scenegen::Kind::from_name(k).with_context(|| {
                    format!("--kind {k:?}: must be office, kitchen, living or lab")
                })?),
            };
            let start = std::time::Instant::now();
            let g = scenegen::generate(seed, kind, &cfg)?;
            std::fs::write(&out, &g.toml).with_context(|| format!("writing {}", out.display()))?;
            let s = &g.stats;
            eprintln!(
                "{}: {:.2} x {:.2} m, {} partition(s), {} cluster(s) ({} out of the start view), \
                 {} background and {} foreground objects ({} partly occluded), {} attempt(s), \
                 {:.0} ms",
                g.scene.name,
                s.room[0],
                s.room[1],
                s.partitions,
                s.clusters,
                s.out_of_start_view,
                s.background,
                s.objects,
                s.occluded,
                s.attempts,
                start.elapsed().as_secs_f64() * 1e3
            );
            println!("{}", out.display());
        }
    }
    Ok(ExitCode::SUCCESS)
}

fn report(dirs: &[PathBuf], out: Option<PathBuf>) -> anyhow::Result<ExitCode> {
    let out = out.unwrap_or_else(|| dirs[0].clone());
    let r = vpsom::eval::report::report_dirs(dirs, &out)?;
    println!(
        "{} runs; report: {}",
        r.runs,
        out.join("report.md").display()
    );
    Ok(ExitCode::SUCCESS)
}

fn compare(a: &Path, b: &Path, out: Option<PathBuf>) -> anyhow::Result<ExitCode> {
    use vpsom::eval::compare;
    let c = compare::compare_dirs(a, b)?;
    let md = c.markdown();
    let dir = out.unwrap_or_else(|| b.to_path_buf());
    std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
    let file = dir.join(compare::COMPARE_FILE);
    std::fs::write(&file, &md).with_context(|| format!("writing {}", file.display()))?;
    print!("{md}");
    println!("comparison: {}", file.display());
    Ok(ExitCode::SUCCESS)
}

fn trace(cmd: TraceCmd) -> anyhow::Result<ExitCode> {
    use runtime::recorder::inspect;
    match cmd {
        TraceCmd::Info { file } => println!("{}", inspect::info(&file)?),
        TraceCmd::Export { file, topic, out } => {
            let rows = match &out {
                Some(path) => {
                    let f = std::fs::File::create(path)
                        .with_context(|| format!("creating {}", path.display()))?;
                    let mut w = std::io::BufWriter::new(f);
                    let rows = inspect::export_csv(&file, &topic, &mut w)?;
                    std::io::Write::flush(&mut w)
                        .with_context(|| format!("writing {}", path.display()))?;
                    rows
                }
                None => inspect::export_csv(&file, &topic, &mut std::io::stdout().lock())?,
            };
            eprintln!("{rows} rows");
        }
        TraceCmd::Recover { input, output } => {
            let r = runtime::recorder::recover::recover(&input, &output)?;
            println!("{}: {r}", output.display());
        }
    }
    Ok(ExitCode::SUCCESS)
}

fn replay_cmd(config: Option<PathBuf>, cmd: ReplayCmd) -> anyhow::Result<ExitCode> {
    use vpsom::replay;
    let base = load_config(config.as_deref())?;
    let label = cmd
        .planner
        .clone()
        .unwrap_or_else(|| base.planner.kind.to_string());
    // The configuration `vpsom run` (lockstep or not) ran with: `[run]`'s camera size.
    let cfg = deploy::run_config(&base, &label)?;
    let dir = if cmd.trace.is_dir() {
        cmd.trace.clone()
    } else {
        cmd.trace
            .parent()
            .map(Path::to_path_buf)
            .unwrap_or_default()
    };
    let out = (!cmd.check).then(|| {
        cmd.out
            .clone()
            .unwrap_or_else(|| dir.join(format!("replay-{label}")))
    });
    let spec = replay::ReplaySpec {
        trace: cmd.trace.clone(),
        config: cfg,
        check: cmd.check,
        out: out.clone(),
    };
    let r = replay::replay(&spec)?;
    print!("{r}");
    if cmd.check {
        return Ok(match &r.divergence {
            None => {
                println!("identical: every map, decision and goal reproduced exactly");
                ExitCode::SUCCESS
            }
            Some(d) => {
                println!("first divergence: {d}");
                ExitCode::FAILURE
            }
        });
    }
    if let Some(o) = out {
        println!(
            "open loop (the robot moved as recorded): new trace, decisions.csv, map.json and \
             (with a built-in scene) metrics.json in {}",
            o.display()
        );
    }
    Ok(ExitCode::SUCCESS)
}

fn doctor(config: Option<PathBuf>) -> anyhow::Result<ExitCode> {
    let (_cfg, from) = Config::load_or_default(config.as_deref())?;
    println!("config: {}", from.display());
    print!("{}", runtime::doctor::Report::gather());
    println!();
    Ok(ExitCode::SUCCESS)
}

fn node(
    config: Option<PathBuf>,
    role: &str,
    s: SessionArgs,
    ns: String,
    out: PathBuf,
    (time_scale, gbv_load, live): (f64, usize, Option<u16>),
) -> anyhow::Result<ExitCode> {
    let cfg = deploy::run_config(&load_config(config.as_deref())?, &s.planner)?;
    runtime::ports::set_domain(&cfg.ports.domain)?;
    let args = deploy::RunArgs {
        scene: s.scene,
        planner: s.planner,
        seed: s.seed,
        time_scale,
        namespace: ns,
        out,
        config_file: config,
        gbv_load,
        nodes: vec![],
        live,
        link: None,
    };
    match role {
        "sim" => deploy::sim_node(&args, &cfg)?,
        "mapper" => deploy::mapper_node(&args, &cfg)?,
        "planner" => deploy::planner_node(&args, &cfg)?,
        "recorder" => deploy::recorder_node(&args, &cfg)?,
        other => anyhow::bail!("unknown node role {other:?} (sim, mapper, planner, recorder)"),
    }
    Ok(ExitCode::SUCCESS)
}
