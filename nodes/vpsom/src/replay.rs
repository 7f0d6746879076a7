//! `vpsom replay TRACE`: fresh mapper and planner structs fed the inputs a trace recorded, in the
//! recorded order, on a simulated clock (the trace's own times), as the lockstep host feeds them.
//!
//! Inputs (a trace of the `replay` profile has them all, losslessly): every robot state
//! (`/robot/state`, one per host step), the depth frames (`/camera/depth` + `/camera/depth/meta`),
//! the detections (`/detections`) and the navigation grid (`/nav/grid`). Each step `t` of the
//! recording is re-run: the frame stamped `t` (if any) is integrated with its detections and the
//! state; the map, the LBV and the chassis planner run when their rates (from the config) are
//! due, exactly as [`super::lockstep::run_session`] orders them.
//!
//! - `--check` (with the recorded config): every map (`/map/objects` and the frames it consumed,
//!   `/map/meta`), every decision with every F(v) term (`/planner/decisions`), every neck and nav
//!   goal is compared with the recorded one, bit for bit; the first divergence is reported. For a
//!   lockstep trace there is none.
//! - `--check` on a live trace (host `live`: processes on real clocks, so the mapper saw its
//!   frames at times of its own and the planner ran on whichever map was newest): the maps are
//!   reproduced bit for bit by following the frame receipts each map carries, and the
//!   planner's cycles by following the inputs each neck goal names, see [`live`].
//! - With another config or planner: the new maps, decisions and goals are written to a new trace
//!   (`OUT/trace.mcap`), the decisions also as `OUT/decisions.csv`, and the final map as
//!   `OUT/map.json` with its scores against the ground truth in `OUT/metrics.json` when the
//!   trace names a built-in scene. **Open loop**: the robot still moves as recorded, whatever the
//!   changed logic decides.
//!
//! Depth frames stream from a second reader thread (they are in time order in the file), so memory
//! stays bounded for long traces.

use crate::config::Config;
use crate::eval::{self, MatchParams};
use crate::recording::messages as rec;
use crate::recording::{MountGeometry, SceneConverter, convert, topic};
use crate::sim::Scene;
use crate::step::{NodeStep, Outputs};
use foxglove::Decode;
use foxglove::messages::{RawImage, SceneUpdate};
use runtime::recorder::decode::MessageType;
use runtime::recorder::inspect::{Item, scan};
use runtime::recorder::schemas::SESSION_METADATA;
use runtime::recorder::{Recorder, RecorderError, RecorderSetup};
use shm_types::{
    DepthFrame, Detections, Header, NavGoal, NeckGoal, ObjectMap, OccupancyGrid, PlannerDecision,
    RobotState, boxed_zeroed,
};
use std::collections::{BTreeMap, HashMap, VecDeque};
use std::fmt;
use std::path::{Path, PathBuf};
use std::sync::mpsc::{Receiver, sync_channel};

pub mod live;

/// Why a replay could not run.
#[derive(Debug, thiserror::Error)]
pub enum ReplayError {
    /// The trace could not be read or lacks an input.
    #[error("{path}: {message}")]
    Trace {
        /// The trace.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// The recorder (of the new trace) failed.
    #[error(transparent)]
    Recorder(#[from] RecorderError),
    /// The mapper refused its config.
    #[error(transparent)]
    Config(#[from] settings::ConfigError),
    /// The mapper refused a frame.
    #[error(transparent)]
    Mapper(#[from] crate::mapper::MapperError),
    /// Outputs could not be written.
    #[error(transparent)]
    Eval(#[from] eval::EvalError),
    /// An output file could not be written.
    #[error("{0}")]
    Io(String),
}

/// What to replay.
#[derive(Debug, Clone)]
pub struct ReplaySpec {
    /// The trace (first segment, or the run directory).
    pub trace: PathBuf,
    /// Configuration of the replayed mapper and planner (`planner.kind` selects the planner).
    pub config: Config,
    /// Compare every output with the recorded one.
    pub check: bool,
    /// Where the new trace goes (not with `check`).
    pub out: Option<PathBuf>,
}

/// The first output that differs from the recording.
#[derive(Debug, Clone, PartialEq)]
pub struct Divergence {
    /// Simulated time, ns.
    pub time_ns: u64,
    /// Topic of the output.
    pub topic: &'static str,
    /// Index of the output on its topic (0 = first).
    pub index: usize,
    /// What differs.
    pub detail: String,
}

impl fmt::Display for Divergence {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "t = {:.3} s: {} #{} differs: {}",
            self.time_ns as f64 * 1e-9,
            self.topic,
            self.index,
            self.detail
        )
    }
}

/// What a replay did.
#[derive(Debug, Clone, Default)]
pub struct ReplayReport {
    /// Steps (recorded states) replayed.
    pub steps: u64,
    /// Frames integrated.
    pub frames: u64,
    /// Outputs produced per topic.
    pub produced: BTreeMap<&'static str, u64>,
    /// Outputs compared per topic (`check`).
    pub compared: BTreeMap<&'static str, u64>,
    /// The first divergence (`check`), if any.
    pub divergence: Option<Divergence>,
    /// Simulated time replayed, ns.
    pub end_ns: u64,
    /// Why the replayed planner stopped, if it finished.
    pub finished: Option<String>,
    /// The check of a live trace (`check` on a trace of host `live`).
    pub live: Option<live::LiveCheck>,
}

impl fmt::Display for ReplayReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "replayed {} steps ({:.3} s simulated), {} frames",
            self.steps,
            self.end_ns as f64 * 1e-9,
            self.frames
        )?;
        for (t, n) in &self.produced {
            match self.compared.get(t) {
                Some(c) => writeln!(f, "  {t:<22} {n:>6} produced, {c:>6} compared")?,
                None => writeln!(f, "  {t:<22} {n:>6} produced")?,
            }
        }
        if let Some(r) = &self.finished {
            writeln!(f, "planner finished: {r}")?;
        }
        if let Some(l) = &self.live {
            write!(f, "{l}")?;
        }
        Ok(())
    }
}

/// The recorded outputs, per topic in time order, to compare with.
#[derive(Debug, Default)]
struct Recorded {
    maps: VecDeque<(u64, SceneUpdate)>,
    map_meta: VecDeque<(u64, rec::MapMeta)>,
    decisions: VecDeque<(u64, rec::PlannerDecision)>,
    neck: VecDeque<(u64, rec::NeckGoal)>,
    nav: VecDeque<(u64, rec::NavGoal)>,
}

/// Everything but the pixels, from one pass over the trace.
#[derive(Debug, Default)]
struct Inputs {
    states: Vec<rec::RobotStateRaw>,
    depth_meta: HashMap<u64, rec::DepthMeta>,
    detections: HashMap<u64, rec::DetectionsRaw>,
    grids: Vec<rec::OccupancyGridRaw>,
    outputs: Recorded,
    scene: Option<String>,
    profile: Option<String>,
    /// The host that recorded it (`lockstep`, `live`; `None` in traces from before the key).
    host: Option<String>,
    dropped: u64,
}

fn trace_err(path: &Path, message: impl Into<String>) -> ReplayError {
    ReplayError::Trace {
        path: path.to_path_buf(),
        message: message.into(),
    }
}

/// The files of a run: its segments, or the file itself.
fn files_of(path: &Path) -> Vec<PathBuf> {
    let segs = runtime::recorder::recover::segments(path);
    if segs.is_empty() {
        vec![runtime::recorder::recover::run_first_segment(path)]
    } else {
        segs
    }
}

/// Decoders of the channels of one file, by channel id (`topic`, message type).
#[derive(Debug, Default)]
struct Channels {
    schemas: HashMap<u16, (String, String, Vec<u8>)>,
    chans: HashMap<u16, (String, MessageType)>,
}

impl Channels {
    /// Track a schema or channel record; `Err` on a schema that does not load.
    fn learn(&mut self, item: &Item<'_>) -> Result<(), String> {
        match item {
            Item::Schema {
                id,
                name,
                encoding,
                data,
            } => {
                self.schemas
                    .insert(*id, (name.to_string(), encoding.to_string(), data.to_vec()));
            }
            Item::Channel {
                id,
                topic,
                schema_id,
                ..
            } if !self.chans.contains_key(id) => {
                if let Some((n, e, d)) = self.schemas.get(schema_id) {
                    let t = MessageType::from_schema(n, e, d)?;
                    self.chans.insert(*id, (topic.to_string(), t));
                }
            }
            _ => {}
        }
        Ok(())
    }
}

fn read_inputs(path: &Path) -> Result<Inputs, ReplayError> {
    let mut inp = Inputs::default();
    let mut err: Option<String> = None;
    for file in files_of(path) {
        let mut ch = Channels::default();
        scan(&file, |item| {
            if err.is_some() {
                return;
            }
            if let Err(e) = ch.learn(&item) {
                err = Some(e);
                return;
            }
            match item {
                Item::Metadata { name, values } => {
                    if name == SESSION_METADATA {
                        inp.scene = values.get("scene").cloned();
                        inp.profile = values.get("profile").cloned();
                        inp.host = values.get("host").cloned();
                    } else if name == runtime::recorder::schemas::STATS_METADATA {
                        inp.dropped += values
                            .get("dropped_total")
                            .and_then(|v| v.parse::<u64>().ok())
                            .unwrap_or(0);
                    }
                }
                Item::Message {
                    channel,
                    log_time,
                    data,
                } => {
                    let Some((t, ty)) = ch.chans.get(&channel) else {
                        return;
                    };
                    let r = read_one(&mut inp, t, ty, log_time, data);
                    if let Err(e) = r {
                        err = Some(format!("{t}: {e}"));
                    }
                }
                _ => {}
            }
        })?;
        if let Some(e) = err.take() {
            return Err(trace_err(&file, e));
        }
    }
    inp.states.sort_by_key(|s| s.sim_time_ns);
    Ok(inp)
}

fn read_one(
    inp: &mut Inputs,
    t: &str,
    ty: &MessageType,
    log_time: u64,
    data: &[u8],
) -> Result<(), String> {
    let o = &mut inp.outputs;
    match t {
        topic::STATE => inp.states.push(ty.to_value(data)?),
        topic::DEPTH_META => {
            let m: rec::DepthMeta = ty.to_value(data)?;
            inp.depth_meta.insert(m.sim_time_ns, m);
        }
        topic::DETECTIONS => {
            let d: rec::DetectionsRaw = ty.to_value(data)?;
            inp.detections.insert(d.sim_time_ns, d);
        }
        topic::NAV_GRID => inp.grids.push(ty.to_value(data)?),
        topic::MAP => o.maps.push_back((
            log_time,
            SceneUpdate::decode(data).map_err(|e| e.to_string())?,
        )),
        topic::MAP_META => o.map_meta.push_back((log_time, ty.to_value(data)?)),
        topic::DECISIONS => o.decisions.push_back((log_time, ty.to_value(data)?)),
        topic::NECK_GOAL => o.neck.push_back((log_time, ty.to_value(data)?)),
        topic::NAV_GOAL => o.nav.push_back((log_time, ty.to_value(data)?)),
        _ => {}
    }
    Ok(())
}

/// Depth frames of the run, in file (= time) order, from a reader thread.
fn depth_stream(path: &Path) -> Receiver<Result<(u64, RawImage), String>> {
    let (tx, rx) = sync_channel(4);
    let files = files_of(path);
    std::thread::spawn(move || {
        for file in files {
            let mut ch = Channels::default();
            let r = scan(&file, |item| {
                if ch.learn(&item).is_err() {
                    return;
                }
                if let Item::Message {
                    channel,
                    log_time,
                    data,
                } = item
                    && ch
                        .chans
                        .get(&channel)
                        .is_some_and(|(t, _)| t == topic::DEPTH)
                {
                    let m = RawImage::decode(data).map_err(|e| e.to_string());
                    // The receiver stops listening when the replay ends early.
                    let _ = tx.send(m.map(|m| (log_time, m)));
                }
            });
            if let Err(e) = r {
                let _ = tx.send(Err(e.to_string()));
                return;
            }
        }
    });
    rx
}

/// The depth image recorded at `t` from [`depth_stream`]'s `frames` (earlier ones, without
/// meta, are skipped).
fn image_at(
    frames: &Receiver<Result<(u64, RawImage), String>>,
    path: &Path,
    t: u64,
) -> Result<RawImage, ReplayError> {
    loop {
        match frames.recv() {
            Ok(Ok((ft, img))) if ft == t => return Ok(img),
            // A frame without meta (cannot happen in one recorder's file): skip it.
            Ok(Ok((ft, _))) if ft < t => continue,
            Ok(Ok((ft, _))) => {
                return Err(trace_err(
                    path,
                    format!("depth frame at {ft} ns missing before {t} ns"),
                ));
            }
            Ok(Err(e)) => return Err(trace_err(path, e)),
            Err(_) => return Err(trace_err(path, format!("no depth frame at {t} ns"))),
        }
    }
}

fn header(seq: u64, stamp_ns: u64, sim_time_ns: u64) -> Header {
    Header {
        seq,
        stamp_ns,
        sim_time_ns,
    }
}

fn state_of(s: &rec::RobotStateRaw) -> Result<RobotState, String> {
    let arr = |v: &[f32], n: usize, what: &str| {
        (v.len() == n)
            .then_some(())
            .ok_or_else(|| format!("{what} has {} values, not {n}", v.len()))
    };
    arr(&s.base_pose, 3, "base_pose")?;
    arr(&s.odom_cov, 9, "odom_cov")?;
    let mut r = RobotState {
        header: header(s.seq, s.stamp_ns, s.sim_time_ns),
        nav_goal_id: s.nav_goal_id,
        neck_yaw: s.neck_yaw,
        neck_pitch: s.neck_pitch,
        speed: s.speed,
        distance_m: s.distance_m,
        localization_ok: s.localization_ok as u8,
        nav_status: s.nav_status as u8,
        localization_failures: s.localization_failures,
        ..Default::default()
    };
    r.base_pose.copy_from_slice(&s.base_pose);
    r.odom_cov.copy_from_slice(&s.odom_cov);
    Ok(r)
}

fn frame_of(m: &rec::DepthMeta, img: &RawImage, f: &mut DepthFrame) -> Result<(), String> {
    if m.decimation != 1 || img.encoding != "16UC1" {
        return Err(format!(
            "depth recorded decimated by {} ({}): replay needs the lossless `replay` profile",
            m.decimation, img.encoding
        ));
    }
    let n = (m.width * m.height) as usize;
    if img.width != m.width || img.height != m.height || img.data.len() != 2 * n {
        return Err(format!(
            "depth image {}x{} ({} bytes) does not match its meta {}x{}",
            img.width,
            img.height,
            img.data.len(),
            m.width,
            m.height
        ));
    }
    if m.intrinsics.len() != 6 || m.camera_pose.len() != 7 {
        return Err("depth meta: intrinsics or camera pose incomplete".into());
    }
    f.header = header(m.seq, m.stamp_ns, m.sim_time_ns);
    f.width = m.width;
    f.height = m.height;
    let i = &m.intrinsics;
    f.intrinsics = shm_types::Intrinsics {
        fx: i[0],
        fy: i[1],
        cx: i[2],
        cy: i[3],
        min_range: i[4],
        max_range: i[5],
    };
    f.camera_pose
        .translation
        .copy_from_slice(&m.camera_pose[..3]);
    f.camera_pose.rotation.copy_from_slice(&m.camera_pose[3..]);
    for (p, b) in f.depth_mm[..n].iter_mut().zip(img.data.chunks_exact(2)) {
        *p = u16::from_le_bytes([b[0], b[1]]);
    }
    Ok(())
}

fn detections_of(d: &rec::DetectionsRaw, out: &mut Detections) -> Result<(), String> {
    if d.items.len() > shm_types::MAX_DETECTIONS {
        return Err(format!("{} detections", d.items.len()));
    }
    out.header = header(d.seq, d.stamp_ns, d.sim_time_ns);
    out.frame_seq = d.frame_seq;
    out.width = d.width;
    out.height = d.height;
    out.masks = d.masks;
    out.count = d.items.len() as u32;
    for (x, r) in out.items.iter_mut().zip(&d.items) {
        if r.bbox.len() != 4 {
            return Err("a detection without 4 box coordinates".into());
        }
        x.class_id = r.class_id as u16;
        x.label = r.label as u16;
        x.score = r.score;
        for (b, v) in x.bbox.iter_mut().zip(&r.bbox) {
            *b = *v as u16;
        }
        x.mask_pixels = r.mask_pixels;
    }
    let n = d.labels.len().min(out.labels.len());
    out.labels[..n].copy_from_slice(&d.labels[..n]);
    Ok(())
}

fn grid_of(g: &rec::OccupancyGridRaw, out: &mut OccupancyGrid) -> Result<(), String> {
    let n = g.width as usize * g.height as usize;
    if g.origin.len() != 2 || g.cells.len() != n || n > out.cells.len() {
        return Err(format!(
            "nav grid {}x{} with {} cells",
            g.width,
            g.height,
            g.cells.len()
        ));
    }
    out.header = header(g.seq, g.stamp_ns, g.sim_time_ns);
    out.origin.copy_from_slice(&g.origin);
    out.resolution = g.resolution;
    out.width = g.width;
    out.height = g.height;
    out.cells[..n].copy_from_slice(&g.cells);
    Ok(())
}

/// Compares outputs with the recording (in `check` mode) and records them (otherwise).
struct Sink<'a> {
    check: bool,
    recorded: Recorded,
    report: &'a mut ReplayReport,
    rec: Option<runtime::recorder::RecorderHandle>,
}

impl Sink<'_> {
    fn count(&mut self, topic: &'static str) -> usize {
        let n = self.report.produced.entry(topic).or_insert(0);
        *n += 1;
        (*n - 1) as usize
    }

    fn compare<T: PartialEq + fmt::Debug>(
        &mut self,
        topic: &'static str,
        index: usize,
        t: u64,
        got: T,
        want: Option<(u64, T)>,
    ) {
        if !self.check || self.report.divergence.is_some() {
            return;
        }
        *self.report.compared.entry(topic).or_insert(0) += 1;
        let detail = match want {
            None => Some(format!(
                "the replay produced one more than the recording: {got:?}"
            )),
            Some((rt, _)) if rt != t => Some(format!(
                "recorded at t = {:.3} s, replayed at t = {:.3} s",
                rt as f64 * 1e-9,
                t as f64 * 1e-9
            )),
            Some((_, w)) if w != got => Some(format!("recorded {w:?}, replayed {got:?}")),
            Some(_) => None,
        };
        if let Some(detail) = detail {
            self.report.divergence = Some(Divergence {
                time_ns: t,
                topic,
                index,
                detail,
            });
        }
    }

    /// Outputs the recording has and the replay never produced.
    fn leftovers(&mut self) {
        if !self.check || self.report.divergence.is_some() {
            return;
        }
        let r = &self.recorded;
        let left = [
            (topic::MAP, r.maps.front().map(|x| x.0)),
            (topic::DECISIONS, r.decisions.front().map(|x| x.0)),
            (topic::NECK_GOAL, r.neck.front().map(|x| x.0)),
            (topic::NAV_GOAL, r.nav.front().map(|x| x.0)),
        ];
        if let Some((topic, Some(t))) = left
            .into_iter()
            .filter(|(_, t)| t.is_some())
            .min_by_key(|(_, t)| *t)
        {
            self.report.divergence = Some(Divergence {
                time_ns: t,
                topic,
                index: self.report.produced.get(topic).copied().unwrap_or(0) as usize,
                detail: "recorded, never produced by the replay".into(),
            });
        }
    }
}

impl Outputs for Sink<'_> {
    fn map(&mut self, m: &ObjectMap) {
        let i = self.count(topic::MAP);
        let want = self.recorded.maps.pop_front();
        let t = m.header.sim_time_ns;
        self.compare(topic::MAP, i, t, convert::map_objects(m), want);
        let want = self.recorded.map_meta.pop_front();
        let mut meta = convert::map_meta(m);
        if let Some((_, w)) = &want {
            // The header seq and stamp are the publishing host's, not the logic's.
            meta.seq = w.seq;
            meta.stamp_ns = w.stamp_ns;
        }
        self.compare(topic::MAP_META, i, t, meta, want);
        if let Some(r) = &self.rec {
            r.record_map(m);
        }
    }

    fn decision(&mut self, d: &PlannerDecision) {
        let i = self.count(topic::DECISIONS);
        let want = self.recorded.decisions.pop_front();
        let t = d.header.sim_time_ns;
        self.compare(topic::DECISIONS, i, t, convert::decision(d), want);
        if let Some(r) = &self.rec {
            r.record_decision(d);
        }
    }

    fn neck(&mut self, g: &NeckGoal) {
        let i = self.count(topic::NECK_GOAL);
        let want = self.recorded.neck.pop_front();
        let t = g.header.sim_time_ns;
        self.compare(topic::NECK_GOAL, i, t, convert::neck_goal(g), want);
        if let Some(r) = &self.rec {
            r.record_neck_goal(g);
        }
    }

    fn nav(&mut self, g: &NavGoal) {
        let i = self.count(topic::NAV_GOAL);
        let want = self.recorded.nav.pop_front();
        let t = g.header.sim_time_ns;
        self.compare(topic::NAV_GOAL, i, t, convert::nav_goal(g), want);
        if let Some(r) = &self.rec {
            r.record_nav_goal(g);
        }
    }
}

/// Replay `spec.trace` (see the module docs).
pub fn replay(spec: &ReplaySpec) -> Result<ReplayReport, ReplayError> {
    let path = &spec.trace;
    let inp = read_inputs(path)?;
    if inp.states.is_empty() {
        return Err(trace_err(
            path,
            "no /robot/state messages: replay needs a trace of the `replay` profile",
        ));
    }
    let cfg = &spec.config;
    if spec.check && inp.host.as_deref() == Some("live") {
        return live::check(path, inp, cfg);
    }
    if spec.check && inp.dropped > 0 {
        return Err(trace_err(
            path,
            format!(
                "the recorder dropped {} messages: an exact check needs every input",
                inp.dropped
            ),
        ));
    }
    let mut nodes = NodeStep::new(cfg)?;
    let mut frame = boxed_zeroed::<DepthFrame>();
    let mut dets = boxed_zeroed::<Detections>();
    let mut nav = boxed_zeroed::<OccupancyGrid>();
    let mut grids = inp.grids.iter().peekable();

    let recorder = match (&spec.out, spec.check) {
        (Some(dir), false) => {
            std::fs::create_dir_all(dir)
                .map_err(|e| ReplayError::Io(format!("{}: {e}", dir.display())))?;
            let conv =
                SceneConverter::new(&cfg.recorder, MountGeometry::from(&cfg.camera), Vec::new());
            let setup = RecorderSetup {
                scene: inp.scene.clone().unwrap_or_default(),
                // Offline: the new trace waits for its writer rather than lose a message.
                overflow: runtime::recorder::Overflow::Wait,
                ..RecorderSetup::new(conv)
            };
            Some(Recorder::create(
                &dir.join("trace.mcap"),
                &cfg.recorder,
                setup,
            )?)
        }
        _ => None,
    };
    let mut report = ReplayReport::default();
    let mut sink = Sink {
        check: spec.check,
        recorded: inp.outputs,
        report: &mut report,
        rec: recorder.as_ref().map(Recorder::handle),
    };
    let frames = depth_stream(path);

    let mut end = 0;
    for s in &inp.states {
        let t = s.sim_time_ns;
        end = t;
        let state = state_of(s).map_err(|e| trace_err(path, format!("/robot/state: {e}")))?;
        while let Some(g) = grids.next_if(|g| g.sim_time_ns <= t) {
            grid_of(g, &mut nav).map_err(|e| trace_err(path, e))?;
        }
        if let Some(m) = inp.depth_meta.get(&t) {
            let img = image_at(&frames, path, t)?;
            if (m.width, m.height) != (cfg.camera.width, cfg.camera.height) {
                return Err(trace_err(
                    path,
                    format!(
                        "depth frames are {}x{}, the config's camera is {}x{} (give the config \
                         the trace was recorded with)",
                        m.width, m.height, cfg.camera.width, cfg.camera.height
                    ),
                ));
            }
            frame_of(m, &img, &mut frame).map_err(|e| trace_err(path, e))?;
            let d = inp
                .detections
                .get(&t)
                .ok_or_else(|| trace_err(path, format!("no detections for the frame at {t} ns")))?;
            detections_of(d, &mut dets).map_err(|e| trace_err(path, e))?;
            nodes.integrate(&frame, &dets, &state)?;
            report_frame(sink.report);
        }
        if let Some(summary) = nodes.tick(t, &state, &nav, &mut sink) {
            sink.report.finished = Some(summary.reason());
            break;
        }
        if let Some(r) = &sink.rec {
            r.record_state(&state);
        }
        sink.report.steps += 1;
    }
    sink.leftovers();
    drop(sink);
    report.end_ns = end;
    if let (Some(r), Some(dir)) = (recorder, &spec.out) {
        nodes.mapper.write_map(&mut nodes.map, end);
        r.finish()?;
        write_outputs(dir, inp.scene.as_deref(), &nodes.map)?;
    }
    Ok(report)
}

fn report_frame(r: &mut ReplayReport) {
    r.frames += 1;
}

/// `decisions.csv` of the new trace, and `map.json` + `metrics.json` (scores against the scene's
/// ground truth, when the trace names a built-in scene).
fn write_outputs(dir: &Path, scene: Option<&str>, map: &ObjectMap) -> Result<(), ReplayError> {
    let io = |p: &Path, e: &dyn fmt::Display| ReplayError::Io(format!("{}: {e}", p.display()));
    let csv = dir.join("decisions.csv");
    let mut f = std::fs::File::create(&csv).map_err(|e| io(&csv, &e))?;
    runtime::recorder::inspect::export_csv(&dir.join("trace.mcap"), topic::DECISIONS, &mut f)?;
    let name = scene.unwrap_or("none");
    let mf = eval::mapfile::MapFile::from_object_map(name, map);
    mf.write(&dir.join("map.json"))?;
    if let Ok(sc) = Scene::builtin_or_load(name) {
        let gt = super::lockstep::ground_truth(&sc);
        let scores = mf.score(&gt, &MatchParams::default());
        let p = dir.join("metrics.json");
        let v = serde_json::json!({
            "scene": name,
            "open_loop": true,
            "foreground": scores.foreground,
            "background": scores.background,
        });
        let text = serde_json::to_string_pretty(&v).map_err(|e| io(&p, &e))?;
        std::fs::write(&p, text).map_err(|e| io(&p, &e))?;
    }
    Ok(())
}
