//! What the recorder is given, and the conversions it owns.
//!
//! - [`Converter`]: supplied by the app (`vpsom::recording`), it names the app's channels and
//!   turns each recorded shared-memory input (depth, detections, states, grids, maps, decisions,
//!   goals) into messages on them. It runs on the writer thread, so producers never convert.
//! - The producer-side copies of the large inputs into the recorder's pooled buffers (no
//!   allocation).
//! - The runtime's own inputs (deadline events, heartbeats, latency summaries, log lines,
//!   metrics) as [`super::messages`] and `foxglove.Log`.

use super::messages as own;
use super::schemas::ChannelDef;
use super::{Kind, LatencySummary, LogLevel, RecorderError, Sink};
use foxglove::messages::{Log, Timestamp};
use shm_types::{
    DeadlineEvent, DepthFrame, Detections, NavGoal, NeckGoal, NodeHealth, ObjectMap, OccupancyGrid,
    PlannerDecision, RobotState, miss_cause,
};

/// How the app's inputs become the messages of a trace: the channels they are written on and the
/// messages each input makes, written through a [`Sink`] (`sink.emit(topic, log_ns, publish_ns,
/// || message)`, which applies the profile's rate limit of the topic before building the
/// message). Called on the writer thread only, in the order the inputs were recorded; an `Err`
/// from the sink (an I/O error) is to be returned, and stops the recording.
///
/// The recorder adds its own channels (`/runtime/*`, `/log`, `/metrics`, `/recorder/stats`,
/// [`super::schemas::own_channels`]) after the converter's.
pub trait Converter: Send + std::fmt::Debug {
    /// The app's channels, in the order they are created.
    fn channels(&self) -> Vec<ChannelDef>;

    /// The topic that carries exactly one message per accepted input of `kind` (drops and offers
    /// are counted under it). Asked for the kinds the converter converts ([`Kind::converted`]).
    fn topic(&self, kind: Kind) -> &'static str;

    /// Entries of the session metadata record (the recorder adds `scene`, `profile`,
    /// `depth_decimation`, `host` and `overflow`).
    fn session_metadata(&self) -> Vec<(String, String)> {
        Vec::new()
    }

    /// Messages written once, when the file is opened (before any input).
    fn start(&mut self, _sink: &mut Sink) -> Result<(), RecorderError> {
        Ok(())
    }

    /// A depth frame ([`super::RecorderHandle::record_depth`]).
    fn depth(&mut self, f: &DepthFrame, sink: &mut Sink) -> Result<(), RecorderError>;
    /// Detections.
    fn detections(&mut self, d: &Detections, sink: &mut Sink) -> Result<(), RecorderError>;
    /// A navigation grid.
    fn nav_grid(&mut self, g: &OccupancyGrid, sink: &mut Sink) -> Result<(), RecorderError>;
    /// The estimated robot state.
    fn state(&mut self, s: &RobotState, sink: &mut Sink) -> Result<(), RecorderError>;
    /// The true robot state (simulation only).
    fn true_state(&mut self, s: &RobotState, sink: &mut Sink) -> Result<(), RecorderError>;
    /// An object map.
    fn map(&mut self, m: &ObjectMap, sink: &mut Sink) -> Result<(), RecorderError>;
    /// A planner decision.
    fn decision(&mut self, d: &PlannerDecision, sink: &mut Sink) -> Result<(), RecorderError>;
    /// A navigation goal.
    fn nav_goal(&mut self, g: &NavGoal, sink: &mut Sink) -> Result<(), RecorderError>;
    /// A neck goal.
    fn neck_goal(&mut self, g: &NeckGoal, sink: &mut Sink) -> Result<(), RecorderError>;
}

// ---- producer-side copies (no allocation) --------------------------------------------------

/// Copy the used part of `src` into `dst`.
pub fn copy_depth(src: &DepthFrame, dst: &mut DepthFrame) {
    dst.header = src.header;
    dst.width = src.width.min(shm_types::MAX_WIDTH as u32);
    dst.height = src.height.min(shm_types::MAX_HEIGHT as u32);
    dst.intrinsics = src.intrinsics;
    dst.camera_pose = src.camera_pose;
    let n = (dst.width * dst.height) as usize;
    dst.depth_mm[..n].copy_from_slice(&src.depth_mm[..n]);
}

/// Copy the used part of `src` into `dst` (the label mask only when it has one).
pub fn copy_detections(src: &Detections, dst: &mut Detections) {
    dst.header = src.header;
    dst.frame_seq = src.frame_seq;
    dst.width = src.width.min(shm_types::MAX_WIDTH as u32);
    dst.height = src.height.min(shm_types::MAX_HEIGHT as u32);
    dst.masks = src.masks;
    let n = (src.count as usize).min(shm_types::MAX_DETECTIONS);
    dst.count = n as u32;
    dst.items[..n].copy_from_slice(&src.items[..n]);
    if src.masks != 0 {
        let p = (dst.width * dst.height) as usize;
        dst.labels[..p].copy_from_slice(&src.labels[..p]);
    }
}

/// Copy the used part of `src` into `dst`.
pub fn copy_decision(src: &PlannerDecision, dst: &mut PlannerDecision) {
    dst.header = src.header;
    dst.map_seq = src.map_seq;
    dst.eval_ns = src.eval_ns;
    dst.cluster_id = src.cluster_id;
    dst.evaluated = src.evaluated;
    dst.kind = src.kind;
    dst.state = src.state;
    let c = src.candidates();
    dst.count = c.len() as u32;
    dst.candidates[..c.len()].copy_from_slice(c);
}

/// A Foxglove timestamp of `ns` nanoseconds.
pub fn time(ns: u64) -> Timestamp {
    Timestamp::new((ns / 1_000_000_000) as u32, (ns % 1_000_000_000) as u32)
}

// ---- the runtime's own inputs ------------------------------------------------------------------

/// `Log`.
pub fn log(time_ns: u64, level: LogLevel, name: &str, text: &str) -> Log {
    Log {
        timestamp: Some(time(time_ns)),
        level: level as i32,
        message: text.into(),
        name: name.into(),
        file: String::new(),
        line: 0,
    }
}

/// [`own::NodeHealth`].
pub fn health(h: &NodeHealth) -> own::NodeHealth {
    own::NodeHealth {
        seq: h.header.seq,
        stamp_ns: h.header.stamp_ns,
        sim_time_ns: h.header.sim_time_ns,
        node: h.node_name().into(),
        pid: h.pid,
        steps: h.steps,
        inputs: h
            .inputs()
            .iter()
            .map(|i| own::InputHealth {
                topic: i.topic_name().into(),
                received: i.received,
                invalid: i.invalid,
                overflow: i.overflow,
            })
            .collect(),
    }
}

/// [`own::DeadlineEvent`].
pub fn deadline(e: &DeadlineEvent) -> own::DeadlineEvent {
    own::DeadlineEvent {
        seq: e.header.seq,
        stamp_ns: e.header.stamp_ns,
        sim_time_ns: e.header.sim_time_ns,
        thread: e.thread_name().into(),
        cycle: e.cycle,
        period_ns: e.period_ns,
        budget_ns: e.budget_ns,
        lateness_ns: e.lateness_ns,
        exec_ns: e.exec_ns,
        cpu_ns: e.cpu_ns,
        run_wait_ns: e.run_wait_ns,
        sched_stats: e.sched_stats != 0,
        backup_wake: e.backup_wake != 0,
        consecutive_misses: e.consecutive_misses,
        miss: e.missed != 0,
        miss_cause: miss_cause::name(e.miss_cause).into(),
    }
}

/// [`own::LatencySummary`].
pub fn latency(s: &LatencySummary) -> own::LatencySummary {
    own::LatencySummary {
        time_ns: s.time_ns,
        period_ns: s.period_ns,
        nodes: s
            .nodes
            .iter()
            .map(|n| own::NodeLatencyMsg {
                node: n.node.clone(),
                count: n.count,
                min_ns: n.min_ns,
                p50_ns: n.p50_ns,
                p90_ns: n.p90_ns,
                p99_ns: n.p99_ns,
                max_ns: n.max_ns,
                mean_ns: n.mean_ns,
            })
            .collect(),
    }
}

/// [`own::Metrics`]: every numeric leaf of `v` by dotted path, and `v` as text.
pub fn metrics(v: &serde_json::Value) -> own::Metrics {
    fn walk(prefix: &str, v: &serde_json::Value, out: &mut Vec<own::MetricValue>) {
        let key = |k: &str| {
            if prefix.is_empty() {
                k.to_string()
            } else {
                format!("{prefix}.{k}")
            }
        };
        match v {
            serde_json::Value::Object(m) => m.iter().for_each(|(k, x)| walk(&key(k), x, out)),
            serde_json::Value::Array(a) => a
                .iter()
                .enumerate()
                .for_each(|(i, x)| walk(&key(&i.to_string()), x, out)),
            serde_json::Value::Number(n) => out.push(own::MetricValue {
                key: prefix.to_string(),
                value: n.as_f64().unwrap_or(f64::NAN),
            }),
            serde_json::Value::Bool(b) => out.push(own::MetricValue {
                key: prefix.to_string(),
                value: f64::from(u8::from(*b)),
            }),
            _ => {}
        }
    }
    let mut values = Vec::new();
    walk("", v, &mut values);
    own::Metrics {
        values,
        json: v.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn metrics_flatten_to_dotted_numbers() {
        let v = serde_json::json!({"a": 1.5, "b": {"c": 2, "d": true, "s": "x"}, "l": [3]});
        let m = metrics(&v);
        let got: Vec<(&str, f64)> = m.values.iter().map(|x| (x.key.as_str(), x.value)).collect();
        assert_eq!(got, [("a", 1.5), ("b.c", 2.0), ("b.d", 1.0), ("l.0", 3.0)]);
        assert_eq!(
            serde_json::from_str::<serde_json::Value>(&m.json).unwrap(),
            v
        );
    }
}
