//! Shared helpers of the recorder tests: message builders, a test [`Converter`] (one message per
//! input on topics named as the app's) and a reader of every message, decoded through the
//! protobuf schema stored in the file. `nodes/vpsom/tests/recorder_*.rs` use them too (with the
//! app's converter).

#![allow(dead_code)]

use foxglove::bytes::Bytes;
use foxglove::messages::{Log, RawImage};
use runtime::recorder::convert::time;
use runtime::recorder::decode::MessageType;
use runtime::recorder::inspect::{Item, ScanEnd, scan};
use runtime::recorder::schemas::ChannelDef;
use runtime::recorder::{Converter, Kind, RecorderError, RecorderSetup, Sink};
use serde_json::Value;
use shm_types::*;
use std::collections::{BTreeMap, HashMap};
use std::path::Path;

/// Topics of [`TestConverter`] (named as the app's primary topics), and the runtime's own.
pub mod topic {
    #[allow(unused_imports)]
    pub use runtime::recorder::schemas::topic::*;
    /// Depth frames (`foxglove.RawImage`).
    pub const DEPTH: &str = "/camera/depth";
    /// Detections.
    pub const DETECTIONS: &str = "/detections";
    /// Navigation grids.
    pub const NAV_GRID: &str = "/nav/grid";
    /// Estimated states.
    pub const TF: &str = "/tf";
    /// True states.
    pub const TRUTH_TF: &str = "/truth/tf";
    /// Maps.
    pub const MAP: &str = "/map/objects";
    /// Decisions.
    pub const DECISIONS: &str = "/planner/decisions";
    /// Navigation goals.
    pub const NAV_GOAL: &str = "/planner/nav_goal";
    /// Neck goals.
    pub const NECK_GOAL: &str = "/planner/neck_goal";
}

/// An app's converter for the runtime's tests: a depth frame becomes its raw image (every
/// pixel), any other input one `foxglove.Log` naming it, on its kind's topic.
#[derive(Debug)]
pub struct TestConverter;

/// A setup with [`TestConverter`] and the defaults of [`RecorderSetup::new`].
pub fn test_setup() -> RecorderSetup {
    RecorderSetup::new(TestConverter)
}

fn note(sink: &mut Sink, topic: &'static str, h: &Header, what: &str) -> Result<(), RecorderError> {
    sink.emit(topic, h.sim_time_ns, h.stamp_ns, || Log {
        timestamp: Some(time(h.sim_time_ns)),
        level: 2,
        message: format!("{what} {}", h.seq),
        name: "test".into(),
        file: String::new(),
        line: 0,
    })
}

impl Converter for TestConverter {
    fn channels(&self) -> Vec<ChannelDef> {
        use topic::*;
        let mut c = vec![ChannelDef::of::<RawImage>(DEPTH)];
        for t in [
            DETECTIONS, NAV_GRID, TF, TRUTH_TF, MAP, DECISIONS, NAV_GOAL, NECK_GOAL,
        ] {
            c.push(ChannelDef::of::<Log>(t));
        }
        c
    }

    fn topic(&self, kind: Kind) -> &'static str {
        use topic::*;
        match kind {
            Kind::Depth => DEPTH,
            Kind::Detections => DETECTIONS,
            Kind::NavGrid => NAV_GRID,
            Kind::State => TF,
            Kind::TrueState => TRUTH_TF,
            Kind::Map => MAP,
            Kind::Decision => DECISIONS,
            Kind::NavGoal => NAV_GOAL,
            _ => NECK_GOAL,
        }
    }

    fn depth(&mut self, f: &DepthFrame, sink: &mut Sink) -> Result<(), RecorderError> {
        let h = &f.header;
        sink.emit(topic::DEPTH, h.sim_time_ns, h.stamp_ns, || RawImage {
            timestamp: Some(time(h.sim_time_ns)),
            frame_id: "camera".into(),
            width: f.width,
            height: f.height,
            encoding: "16UC1".into(),
            step: f.width * 2,
            data: Bytes::from(
                f.pixels()
                    .iter()
                    .flat_map(|p| p.to_le_bytes())
                    .collect::<Vec<u8>>(),
            ),
        })
    }
    fn detections(&mut self, d: &Detections, sink: &mut Sink) -> Result<(), RecorderError> {
        note(sink, topic::DETECTIONS, &d.header, "detections")
    }
    fn nav_grid(&mut self, g: &OccupancyGrid, sink: &mut Sink) -> Result<(), RecorderError> {
        note(sink, topic::NAV_GRID, &g.header, "grid")
    }
    fn state(&mut self, s: &RobotState, sink: &mut Sink) -> Result<(), RecorderError> {
        note(sink, topic::TF, &s.header, "state")
    }
    fn true_state(&mut self, s: &RobotState, sink: &mut Sink) -> Result<(), RecorderError> {
        note(sink, topic::TRUTH_TF, &s.header, "true state")
    }
    fn map(&mut self, m: &ObjectMap, sink: &mut Sink) -> Result<(), RecorderError> {
        note(sink, topic::MAP, &m.header, "map")
    }
    fn decision(&mut self, d: &PlannerDecision, sink: &mut Sink) -> Result<(), RecorderError> {
        note(sink, topic::DECISIONS, &d.header, "decision")
    }
    fn nav_goal(&mut self, g: &NavGoal, sink: &mut Sink) -> Result<(), RecorderError> {
        note(sink, topic::NAV_GOAL, &g.header, "nav goal")
    }
    fn neck_goal(&mut self, g: &NeckGoal, sink: &mut Sink) -> Result<(), RecorderError> {
        note(sink, topic::NECK_GOAL, &g.header, "neck goal")
    }
}

pub fn header(seq: u64) -> Header {
    Header {
        seq,
        stamp_ns: 1_000 + seq * 7,
        sim_time_ns: seq * 33_333_333,
    }
}

pub fn depth(seq: u64, w: u32, h: u32) -> Box<DepthFrame> {
    let mut f = boxed_zeroed::<DepthFrame>();
    f.header = header(seq);
    f.width = w;
    f.height = h;
    f.intrinsics = Intrinsics {
        fx: 500.0,
        fy: 500.0,
        cx: w as f32 / 2.0,
        cy: h as f32 / 2.0,
        min_range: 0.5,
        max_range: 5.0,
    };
    for (i, p) in f.pixels_mut().iter_mut().enumerate() {
        *p = 500 + ((i as u64 * 13 + seq * 101) % 4000) as u16;
    }
    f
}

pub fn state(seq: u64) -> RobotState {
    let t = seq as f32 * 0.02;
    RobotState {
        header: header(seq),
        base_pose: [t.cos() * 2.0, t.sin() * 2.0, t + 1.57],
        neck_yaw: (t * 3.0).sin(),
        neck_pitch: 0.49,
        localization_ok: 1,
        ..Default::default()
    }
}

pub fn map(seq: u64, objects: usize) -> Box<ObjectMap> {
    let mut m = boxed_zeroed::<ObjectMap>();
    m.header = header(seq);
    m.count = objects as u32;
    m.eps_sopm = 0.3;
    for (k, o) in m.objects[..objects].iter_mut().enumerate() {
        o.id = k as u32 + 1;
        o.class_id = (k * 7 % 80) as u16;
        o.center = [k as f32 * 0.5, -1.0, 0.4];
        o.size = [0.3, 0.2, 0.25];
        o.yaw = 0.1 * k as f32;
        o.h_sopm = 0.9 - 0.01 * k as f32;
        o.complete = u8::from(k % 3 == 0);
        o.cluster_id = -1;
    }
    m
}

pub fn decision(seq: u64, kind: u8, n: usize) -> Box<PlannerDecision> {
    let mut d = boxed_zeroed::<PlannerDecision>();
    d.header = header(seq);
    d.kind = kind;
    d.count = n as u32;
    d.evaluated = n as u32 * 2;
    d.cluster_id = 3;
    for (k, c) in d.candidates[..n].iter_mut().enumerate() {
        c.position = [k as f32 * 0.1, 0.5, 1.4];
        c.yaw = k as f32 * 0.3;
        c.pitch = 0.49;
        c.value = k as f32;
        c.f_a = 0.5;
        c.f_c = 0.25;
        c.h_sopm = 2.0;
        c.objects_in_view = k as u16;
        c.chosen = u8::from(k == n - 1);
        c.dropped = u8::from(k == 0);
    }
    d
}

pub fn deadline(seq: u64) -> DeadlineEvent {
    let mut e = DeadlineEvent {
        header: header(seq),
        cycle: seq,
        period_ns: 50_000_000,
        budget_ns: 20_000_000,
        lateness_ns: -5 + seq as i64,
        exec_ns: 1_000_000 + seq * 10,
        missed: u8::from(seq.is_multiple_of(10)),
        ..Default::default()
    };
    e.set_thread_name("lbv");
    e
}

pub fn detections(seq: u64, n: usize) -> Box<Detections> {
    let mut d = boxed_zeroed::<Detections>();
    d.header = header(seq);
    d.frame_seq = seq;
    d.width = 64;
    d.height = 48;
    d.count = n as u32;
    for (k, x) in d.items[..n].iter_mut().enumerate() {
        x.class_id = 56 + k as u16;
        x.label = k as u16 + 1;
        x.score = 0.5 + 0.1 * k as f32;
        x.bbox = [2 * k as u16, 4, 2 * k as u16 + 10, 20];
    }
    d
}

pub fn grid(seq: u64) -> Box<OccupancyGrid> {
    let mut g = boxed_zeroed::<OccupancyGrid>();
    g.header = header(seq);
    g.origin = [-3.0, -2.5];
    g.resolution = 0.05;
    g.width = 20;
    g.height = 10;
    for (i, c) in g.cells[..200].iter_mut().enumerate() {
        *c = (i % 3) as u8 * 100;
    }
    g
}

/// One message read back.
#[derive(Debug, Clone)]
pub struct ReadMessage {
    pub topic: String,
    pub schema_name: String,
    pub log_time: u64,
    /// The message in the protobuf JSON mapping (proto field names, defaults included).
    pub value: Value,
    /// The encoded message.
    pub data: Vec<u8>,
}

/// Every message of a file decoded through its channel's schema, and how the scan ended. Panics
/// on a channel that is not protobuf or a message its schema does not decode.
pub fn read_all(path: &Path) -> (Vec<ReadMessage>, ScanEnd) {
    let mut schemas: HashMap<u16, (String, MessageType)> = HashMap::new();
    let mut chans: HashMap<u16, (String, String, MessageType)> = HashMap::new();
    let mut out = Vec::new();
    let end = scan(path, |item| match item {
        Item::Schema {
            id,
            name,
            encoding,
            data,
        } => {
            let t = MessageType::from_schema(name, encoding, data)
                .unwrap_or_else(|e| panic!("{name}: {e}"));
            schemas.insert(id, (name.to_string(), t));
        }
        Item::Channel {
            id,
            topic,
            encoding,
            schema_id,
            ..
        } => {
            assert_eq!(encoding, "protobuf", "{topic}");
            let (n, t) = schemas
                .get(&schema_id)
                .cloned()
                .expect("schema before channel");
            chans.insert(id, (topic.to_string(), n, t));
        }
        Item::Message {
            channel,
            log_time,
            data,
        } => {
            let (topic, n, t) = chans.get(&channel).expect("channel before message");
            let value = t.to_json(data).unwrap_or_else(|e| panic!("{topic}: {e}"));
            out.push(ReadMessage {
                topic: topic.clone(),
                schema_name: n.clone(),
                log_time,
                value,
                data: data.to_vec(),
            });
        }
        Item::Metadata { .. } => {}
    })
    .expect("scan");
    (out, end)
}

/// The entry of `topic` in a `/recorder/stats` message.
pub fn stats_of<'a>(stats: &'a Value, topic: &str) -> &'a Value {
    stats["topics"]
        .as_array()
        .expect("topics")
        .iter()
        .find(|t| t["topic"] == topic)
        .unwrap_or_else(|| panic!("no {topic} in {stats}"))
}

pub fn counts(msgs: &[ReadMessage]) -> BTreeMap<String, u64> {
    let mut c = BTreeMap::new();
    for m in msgs {
        *c.entry(m.topic.clone()).or_insert(0) += 1;
    }
    c
}

/// Run `runtime/tests/py/check_mcap.py` on `path` with the python in `VPSOM_PYTHON`, expecting
/// `expect` messages per topic. Only the `#[ignore]`d Python tests call it (`.ci/run` runs them
/// with `--ignored` after making a venv); without `VPSOM_PYTHON` it fails, never skips.
pub fn python_check(path: &Path, expect: &BTreeMap<String, u64>) {
    let py = std::env::var_os("VPSOM_PYTHON").expect(
        "precondition: VPSOM_PYTHON must name a python with the `mcap` and \
         `mcap-protobuf-support` packages (.ci/run makes target/ci-venv)",
    );
    // In the runtime's tests and, through `#[path]`, the app's.
    let script = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/py/check_mcap.py")
        .canonicalize()
        .or_else(|_| {
            Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("../../runtime/tests/py/check_mcap.py")
                .canonicalize()
        })
        .expect("runtime/tests/py/check_mcap.py");
    let mut cmd = std::process::Command::new(py);
    cmd.arg(&script).arg(path);
    for (t, n) in expect {
        cmd.arg("--expect-topic").arg(format!("{t}={n}"));
    }
    let out = cmd.output().expect("run python");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "check_mcap.py failed:\n{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let counts: BTreeMap<String, u64> =
        serde_json::from_str(stdout.trim()).expect("check_mcap.py prints counts as JSON");
    assert_eq!(&counts, expect, "python counts");
}

/// Messages per topic read through the file's index (summary section → chunk indexes → chunks),
/// as an indexed reader does: a file without a summary (not finished) is an error.
pub fn indexed_counts(path: &Path) -> Result<BTreeMap<String, u64>, String> {
    let bytes = std::fs::read(path).map_err(|e| e.to_string())?;
    let summary = mcap::Summary::read(&bytes)
        .map_err(|e| e.to_string())?
        .ok_or("no summary section")?;
    if summary.chunk_indexes.is_empty() {
        return Err("no chunk index".into());
    }
    let mut c = BTreeMap::new();
    for index in &summary.chunk_indexes {
        for m in summary
            .stream_chunk(&bytes, index)
            .map_err(|e| e.to_string())?
        {
            let m = m.map_err(|e| e.to_string())?;
            *c.entry(m.channel.topic.clone()).or_insert(0) += 1;
        }
    }
    let total: u64 = c.values().sum();
    let stats = summary.stats.ok_or("no statistics")?;
    if stats.message_count != total {
        return Err(format!(
            "statistics say {} messages, the index gives {total}",
            stats.message_count
        ));
    }
    Ok(c)
}
