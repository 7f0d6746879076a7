//! The whole configuration of a session: one typed struct per section of `config/default.toml`
//! and `config/runtime.toml`.
//!
//! Every default is stated once: the runtime's sections (`[executor]`, `[ports]`, `[recorder]`)
//! in `config/runtime.toml` (built into the runtime, `settings::RUNTIME_DEFAULTS`), every other
//! in `config/default.toml` (built in here as [`DEFAULT_TOML`]). [`DEFAULTS`] layers the two; a
//! file is deep-merged over them, key by key, and the merged table is deserialised into these structs
//! (`deny_unknown_fields`, no `#[serde(default)]`), so a file sets only the keys it changes and an
//! unknown key is an error naming the file and the key. Each section's `Default` is its section
//! of the built-in file ([`settings::Defaults::section`]); each has a
//! `validate(&self, &Checker)` that range-checks it, its rules declared field by field with
//! [`settings::ranges!`] (keys from the field names).

pub use geom::CameraConfig;
use serde::Deserialize;
use settings::{Checker, ConfigError};
use std::path::{Path, PathBuf};

/// The shipped defaults of the app's and the logic's sections, built into the binary so it runs
/// from any directory.
pub const DEFAULT_TOML: &str = include_str!("../../../config/default.toml");
/// Their path relative to the repository root.
pub const DEFAULT_PATH: &str = "config/default.toml";

/// Every default: `config/default.toml` layered over the runtime's `config/runtime.toml`.
pub static DEFAULTS: settings::Defaults =
    settings::Defaults::layered(&settings::RUNTIME_DEFAULTS, DEFAULT_PATH, DEFAULT_TOML);

/// All sections of a configuration file.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Config {
    /// Depth camera and mount.
    pub camera: CameraConfig,
    /// Node rates.
    pub rates: RatesConfig,
    /// Periodic executor defaults (scheduling, spin margin, miss policy).
    pub executor: runtime::executor::ExecutorConfig,
    /// iceoryx2 service settings.
    pub ports: runtime::ports::PortsConfig,
    /// World simulation (noise, seed).
    pub sim: sim::SimConfig,
    /// Simulated detector.
    pub detector: sim::DetectorConfig,
    /// Simulated base and neck.
    pub robot: sim::RobotConfig,
    /// Sparse object mapping and SOPM.
    pub mapper: mapper::MapperConfig,
    /// View planning (VP-SOM and baselines).
    pub planner: planner::PlannerConfig,
    /// `vpsom run` (deployment host) settings.
    pub run: RunConfig,
    /// `vpsom bench` (lockstep experiments) settings.
    pub bench: BenchConfig,
    /// `vpsom sensing` (sensing report) settings.
    pub sensing: SensingConfig,
    /// Scene generator (`vpsom scene gen`, `vpsom bench --generated`).
    pub scenegen: sim::scenegen::SceneGenConfig,
    /// MCAP recorder.
    pub recorder: runtime::recorder::RecorderConfig,
    /// `vpsom run --link`: the tunnel to another host.
    pub link: LinkConfig,
}

/// Fixed rates of the deployment host (simulated seconds).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RatesConfig {
    /// Depth frames and detections, Hz (paper: 20–30).
    pub camera_hz: f64,
    /// Robot state, Hz.
    pub state_hz: f64,
    /// Object map publication, Hz.
    pub map_hz: f64,
}

impl Default for RatesConfig {
    /// The `[rates]` section of the built-in `config/default.toml`.
    fn default() -> Self {
        DEFAULTS.section("rates")
    }
}

impl RatesConfig {
    fn validate(&self, c: &Checker) -> Result<(), ConfigError> {
        let c = &c.at("rates");
        settings::ranges!(c, self, {
            camera_hz: in_range(0.1, 120.0),
            state_hz: in_range(0.1, 1000.0),
            map_hz: in_range(0.1, 120.0),
        });
        Ok(())
    }
}

/// `[run]`: the deployment host (`vpsom run`).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RunConfig {
    /// Simulated seconds per wall second (a real robot runs at 1).
    pub time_scale: f64,
    /// Camera width used by `vpsom run` (overrides `camera.width`; 0 = keep it).
    pub camera_width: u32,
    /// Camera height used by `vpsom run` (overrides `camera.height`; 0 = keep it).
    pub camera_height: u32,
    /// Give up after this much simulated time, seconds.
    pub max_sim_s: f64,
    /// Restarts allowed per node process after a crash.
    pub max_restarts: u32,
    /// Grace period for nodes to exit after SIGINT before SIGKILL, seconds.
    pub stop_grace_s: f64,
    /// `SCHED_FIFO` priority of the mapper's thread (below the LBV's `executor.priority`, so
    /// depth frames become maps promptly under CPU load); 0 = `SCHED_OTHER`.
    pub mapper_priority: i32,
    /// CPU the planner's LBV thread is pinned to (-1 = `executor.cpus`).
    pub lbv_cpu: i32,
    /// CPU of the LBV thread's backup waker (`executor.backup_cpu`; -1 = none): wakes the LBV
    /// there when its own CPU stalls at a release. Needs `lbv_cpu`, a different CPU.
    pub lbv_backup_cpu: i32,
    /// Rate of every node's heartbeat (`NodeHealth` on the `health` topic), wall Hz.
    pub health_hz: f64,
    /// A running node silent for longer than this is hung: killed and restarted, wall s.
    pub hang_timeout_s: f64,
    /// Longest wait for a (re)started node's first heartbeat before it counts as hung, wall s.
    pub start_timeout_s: f64,
    /// A restarted mapper resumes from the last map it published (the launcher hands its
    /// newest copy over on `map/resume`); `false` = it starts empty.
    pub resume_map: bool,
}

impl Default for RunConfig {
    /// The `[run]` section of the built-in `config/default.toml`.
    fn default() -> Self {
        DEFAULTS.section("run")
    }
}

impl RunConfig {
    fn validate(&self, c: &Checker) -> Result<(), ConfigError> {
        let c = &c.at("run");
        const CPU: &str = "must be a CPU index below 1024, or -1";
        settings::ranges!(c, self, {
            time_scale: in_range(0.01, 100.0),
            camera_width: count(0, shm_types::MAX_WIDTH),
            camera_height: count(0, shm_types::MAX_HEIGHT),
            max_sim_s: in_range(1.0, 86_400.0),
            max_restarts: count(0, 100),
            mapper_priority: require(
                (0..=98).contains(&self.mapper_priority),
                "must be in [0, 98] (0 = SCHED_OTHER)",
            ),
            lbv_cpu: require((-1..1024).contains(&self.lbv_cpu), CPU),
            lbv_backup_cpu: require((-1..1024).contains(&self.lbv_backup_cpu), CPU),
            lbv_backup_cpu: require(
                self.lbv_backup_cpu < 0
                    || (self.lbv_cpu >= 0 && self.lbv_cpu != self.lbv_backup_cpu),
                &format!("needs {} set to another CPU", settings::key!(c, lbv_cpu)),
            ),
            health_hz: in_range(0.5, 100.0),
            hang_timeout_s: in_range(0.5, 3600.0),
            start_timeout_s: in_range(1.0, 3600.0),
            hang_timeout_s: require(
                self.hang_timeout_s * self.health_hz >= 2.0,
                &format!(
                    "must span at least two heartbeats ({})",
                    settings::key!(c, health_hz)
                ),
            ),
            stop_grace_s: in_range(0.1, 600.0),
        });
        Ok(())
    }
}

/// `[link]`: the tunnel to another host (`vpsom run --link`, iceoryx2's link tunnel over
/// zenoh); see `nodes/vpsom/src/deploy/link/`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LinkConfig {
    /// zenoh configuration file (JSON5; endpoints, TLS, access control), "" = the built-in
    /// one. `--zenoh-config` overrides it.
    pub zenoh_config: String,
    /// The tunnel thread wakes at least this often (ms), besides on data.
    pub poll_ms: u64,
    /// Before starting its nodes, wait up to this long (s) for the other host's tunnel to
    /// bridge every topic; 0 = start at once.
    pub wait_for_peer_s: f64,
    /// At the end of a run, wait until no sample has come over the link for this long (ms)
    /// before stopping the nodes, so the other host's last samples are recorded here.
    pub quiet_ms: u64,
    /// Cap on that wait (s).
    pub drain_s: f64,
    /// After the nodes stopped, keep the tunnel up this long (ms) so their last samples leave.
    pub linger_ms: u64,
    /// Samples the tunnel's own subscribers buffer per small topic (see `link::watch`).
    pub buffer: usize,
    /// Per-topic rate limit across the link (Hz, 0 = every sample), for the large topics
    /// (`depth`, `detections`, `map`).
    pub max_hz: std::collections::BTreeMap<String, f64>,
}

/// Topics `[link.max_hz]` may limit: the large ones, which cross through a relay.
pub const LINK_LIMITABLE: [&str; 3] = ["depth", "detections", "map"];

impl Default for LinkConfig {
    /// The `[link]` section of the built-in `config/default.toml`.
    fn default() -> Self {
        DEFAULTS.section("link")
    }
}

impl LinkConfig {
    /// The rate limit of `topic` across the link, Hz (`None`: every sample, at full size).
    /// Detections without a key of their own follow depth's limit: a frame and its detections
    /// cross as one pair (`detections = 0` sends every detections sample instead).
    pub fn limit(&self, topic: &str) -> Option<f64> {
        let key = match (topic, self.max_hz.contains_key(topic)) {
            ("detections", false) => "depth",
            _ => topic,
        };
        self.max_hz.get(key).copied().filter(|&hz| hz > 0.0)
    }

    fn validate(&self, c: &Checker) -> Result<(), ConfigError> {
        let c = &c.at("link");
        settings::ranges!(c, self, {
            poll_ms: count(1, 10_000),
            wait_for_peer_s: in_range(0.0, 86_400.0),
            quiet_ms: count(1, 600_000),
            drain_s: in_range(0.0, 600.0),
            linger_ms: count(0, 600_000),
            buffer: count(1, 256),
        });
        let max_hz = c.at(stringify!(max_hz));
        for (topic, &hz) in &self.max_hz {
            c.require(
                LINK_LIMITABLE.contains(&topic.as_str()),
                &settings::key!(c, max_hz),
                topic,
                "only depth, detections and map can be rate-limited",
            )?;
            c.in_range(&max_hz.key(topic), hz, 0.0, 1000.0)?;
        }
        // Detections cross with their frame when both are limited (the mapper pairs them).
        let set = |t: &str| self.max_hz.get(t).copied().filter(|&hz| hz > 0.0);
        if let (Some(depth), Some(dets)) = (set("depth"), set("detections")) {
            c.require(
                dets == depth,
                &max_hz.key("detections"),
                dets,
                &format!(
                    "must equal depth's limit ({depth}): limited together, a frame and its \
                     detections cross as one pair"
                ),
            )?;
        }
        Ok(())
    }
}

/// `[bench]`: the lockstep experiments (`vpsom bench`).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BenchConfig {
    /// Camera width in the experiments (0 = keep `camera.width`).
    pub camera_width: u32,
    /// Camera height in the experiments (0 = keep `camera.height`).
    pub camera_height: u32,
    /// Camera rate in the experiments, Hz (0 = keep `rates.camera_hz`).
    pub camera_hz: f64,
    /// Give up a session after this much simulated time, seconds.
    pub max_sim_s: f64,
    /// Seeds per scene and planner.
    pub seeds: u64,
    /// Sessions run at once (0 = one per CPU).
    pub jobs: usize,
}

impl Default for BenchConfig {
    /// The `[bench]` section of the built-in `config/default.toml`.
    fn default() -> Self {
        DEFAULTS.section("bench")
    }
}

impl BenchConfig {
    fn validate(&self, c: &Checker) -> Result<(), ConfigError> {
        let c = &c.at("bench");
        settings::ranges!(c, self, {
            camera_width: count(0, shm_types::MAX_WIDTH),
            camera_height: count(0, shm_types::MAX_HEIGHT),
            camera_hz: in_range(0.0, 120.0),
            max_sim_s: in_range(1.0, 86_400.0),
            seeds: count(1, 1000),
            jobs: count(0, 256),
        });
        Ok(())
    }
}

/// `[sensing]`: the scripted tour of the sensing report (`vpsom sensing`).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SensingConfig {
    /// Frames per scene.
    pub frames: u64,
    /// Tour goals lie this far (m) outside each background object's footprint circle.
    pub ring_clearance: f32,
    /// Goals per ring around a background object.
    pub ring_points: usize,
    /// A goal not reached by then is skipped, s.
    pub goal_timeout_s: f64,
    /// Amplitude of the neck's yaw sweep, degrees.
    pub neck_amplitude_deg: f32,
    /// Period of the neck's yaw sweep, s.
    pub neck_period_s: f32,
    /// The bands the default sensing must land in on the paper scenes.
    pub bands: crate::eval::sensing::Acceptance,
}

impl Default for SensingConfig {
    /// The `[sensing]` section of the built-in `config/default.toml`.
    fn default() -> Self {
        DEFAULTS.section("sensing")
    }
}

impl SensingConfig {
    fn validate(&self, c: &Checker) -> Result<(), ConfigError> {
        let c = &c.at("sensing");
        settings::ranges!(c, self, {
            frames: count(1, 1_000_000),
            ring_clearance: in_range(0.0, 10.0),
            ring_points: count(1, 64),
            goal_timeout_s: in_range(0.1, 3600.0),
            neck_amplitude_deg: in_range(0.0, 180.0),
            neck_period_s: in_range(0.1, 3600.0),
        });
        if let Some(band) = self.bands.inverted() {
            c.require(
                false,
                &format!("{}.{band}", settings::key!(c, bands)),
                "max < min".to_string(),
                "must have min ≤ max",
            )?;
        }
        Ok(())
    }
}

impl From<&Config> for sim::SimSetup {
    /// The sections the simulator reads.
    fn from(c: &Config) -> Self {
        sim::SimSetup {
            camera: c.camera,
            sim: c.sim.clone(),
            detector: c.detector.clone(),
            robot: c.robot.clone(),
            scenegen: c.scenegen,
        }
    }
}

impl Default for Config {
    /// The built-in `config/default.toml` ([`Config::builtin`]).
    fn default() -> Self {
        Self::builtin()
    }
}

impl Config {
    /// A copy with the camera size (and rate) overridden where the override is non-zero.
    pub fn with_camera(&self, width: u32, height: u32, camera_hz: f64) -> Config {
        let mut c = self.clone();
        if width > 0 && height > 0 {
            (c.camera.width, c.camera.height) = (width, height);
        }
        if camera_hz > 0.0 {
            c.rates.camera_hz = camera_hz;
        }
        c
    }

    /// Parse configuration text that came from `file` over the built-in defaults (keys it does
    /// not set keep their default), and validate it.
    pub fn parse(file: &Path, text: &str) -> Result<Self, ConfigError> {
        let cfg: Config = DEFAULTS.parse(file, text)?;
        cfg.validate(file)?;
        Ok(cfg)
    }

    /// Load and validate a configuration file.
    pub fn load(file: &Path) -> Result<Self, ConfigError> {
        let text = std::fs::read_to_string(file).map_err(|source| ConfigError::Read {
            file: file.to_path_buf(),
            source,
        })?;
        Self::parse(file, &text)
    }

    /// `file` if given; else `config/default.toml` in the working directory if present; else the
    /// built-in copy of it; each merged over [`DEFAULTS`] (so the runtime's sections come from the
    /// built-in `config/runtime.toml` unless the file sets them). Returns the config and where it
    /// came from.
    pub fn load_or_default(file: Option<&Path>) -> Result<(Self, PathBuf), ConfigError> {
        match file {
            Some(f) => Ok((Self::load(f)?, f.to_path_buf())),
            None if Path::new(DEFAULT_PATH).is_file() => Ok((
                Self::load(Path::new(DEFAULT_PATH))?,
                PathBuf::from(DEFAULT_PATH),
            )),
            None => Ok((
                Self::builtin(),
                PathBuf::from("<built-in config/default.toml>"),
            )),
        }
    }

    /// The built-in configuration with `config/sensing-ideal.toml` merged over it: near-perfect
    /// sensing (instance masks, no false positives or confusion, no depth artefacts, no SLAM
    /// residuals), for tests of mapper and planner logic and for comparisons with the default.
    ///
    /// # Panics
    /// Never in a build whose embedded `config/sensing-ideal.toml` is valid (a test checks it).
    pub fn ideal_sensing() -> Self {
        Self::parse(
            Path::new("config/sensing-ideal.toml"),
            include_str!("../../../config/sensing-ideal.toml"),
        )
        .expect("config/sensing-ideal.toml is valid")
    }

    /// The built-in defaults (`config/default.toml` as compiled in).
    pub fn builtin() -> Self {
        Self::parse(Path::new(DEFAULT_PATH), DEFAULT_TOML)
            .expect("the shipped config/default.toml is valid")
    }

    /// Range-check every section.
    pub fn validate(&self, file: &Path) -> Result<(), ConfigError> {
        let c = Checker::new(file);
        self.camera.validate(&c)?;
        self.rates.validate(&c)?;
        self.executor.validate(&c)?;
        self.ports.validate(&c)?;
        self.sim.validate(&c)?;
        self.detector.validate(&c)?;
        self.robot.validate(&c)?;
        self.mapper.validate(&c)?;
        self.planner.validate(&c)?;
        self.run.validate(&c)?;
        self.bench.validate(&c)?;
        self.sensing.validate(&c)?;
        self.scenegen.validate(&c)?;
        self.recorder.validate(&c, &crate::recording::topics())?;
        self.link.validate(&c)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_partial_file_changes_only_its_keys() {
        let builtin = Config::builtin();
        let cfg = Config::parse(Path::new("p.toml"), "[camera]\nwidth = 320\n").unwrap();
        assert_eq!(cfg.camera.width, 320);
        assert_eq!(
            CameraConfig {
                width: builtin.camera.width,
                ..cfg.camera
            },
            builtin.camera
        );
        assert_eq!(cfg.rates, builtin.rates);
        assert_eq!(cfg.executor, builtin.executor);
        assert_eq!(
            cfg.ports, builtin.ports,
            "the shipped per-topic overrides stay"
        );
        assert_eq!(cfg.planner, builtin.planner);
        assert_eq!(cfg.mapper, builtin.mapper);
        assert_eq!(cfg.recorder, builtin.recorder);
        let empty = Config::parse(Path::new("e.toml"), "").unwrap();
        assert_eq!(format!("{empty:?}"), format!("{builtin:?}"));
        assert_eq!(format!("{:?}", Config::default()), format!("{builtin:?}"));
        let mount = Config::parse(Path::new("m.toml"), "[camera.mount]\nheight = 1.2\n").unwrap();
        assert_eq!(mount.camera.mount.height, 1.2);
        assert_eq!(mount.camera.mount.pitch_deg, builtin.camera.mount.pitch_deg);
    }

    #[test]
    fn bad_files_give_specific_errors() {
        let f = Path::new("bad.toml");
        let e = Config::parse(f, "[camera]\nwidht = 320\n").unwrap_err();
        assert_eq!(e.key(), "camera.widht", "{e}");
        assert!(
            e.to_string()
                .starts_with("bad.toml: camera.widht: line 2: "),
            "{e}"
        );
        let e = Config::parse(f, "[camra]\n").unwrap_err();
        assert!(e.to_string().contains("unknown field `camra`"), "{e}");
        let e = Config::parse(f, "[camera]\nwidth = 2000\n").unwrap_err();
        assert_eq!(
            e.to_string(),
            "bad.toml: camera.width = 2000: must be in [16, 640]"
        );
        let e = Config::parse(f, "[rates]\ncamera_hz = -3.0\n").unwrap_err();
        assert_eq!(e.key(), "rates.camera_hz");
        let e = Config::parse(f, "[camera]\nmin_range = 2.0\nmax_range = 1.0\n").unwrap_err();
        assert_eq!(e.key(), "camera.max_range");
        let e = Config::load(Path::new("/nonexistent/x.toml")).unwrap_err();
        assert!(matches!(e, ConfigError::Read { .. }), "{e}");
    }
}
