//! The runtime's own channels' messages: protobuf with schemas derived by `foxglove::Encode` (the
//! schema in the file is a `FileDescriptorSet` named `<lowercase name>.<Name>`, e.g.
//! `deadlineevent.DeadlineEvent`). Field numbers follow declaration order, so a field is only
//! ever appended. Every type also derives `Deserialize`: [`super::decode`] reads any of them back
//! (through the schema stored in the file), which is how `vpsom trace export` reads a trace.
//!
//! These are the messages of what the runtime itself produces (deadline events, heartbeats,
//! latency summaries, metrics, the recorder's counters); the app's channels have their own types
//! (`vpsom::recording::messages`).

use foxglove::Encode;
use serde::{Deserialize, Serialize};

/// One input of a node, as its heartbeat counts it ([`NodeHealth::inputs`]).
#[derive(Debug, Clone, Default, PartialEq, Encode, Serialize, Deserialize)]
pub struct InputHealth {
    /// Topic.
    pub topic: String,
    /// Valid samples received.
    pub received: u64,
    /// Samples dropped on receipt because they failed validation.
    pub invalid: u64,
    /// Samples overwritten before the node read them (sequence gaps).
    pub overflow: u64,
}

/// A node's heartbeat with its input counts (`/runtime/health`).
#[derive(Debug, Clone, Default, PartialEq, Encode, Serialize, Deserialize)]
pub struct NodeHealth {
    /// Sequence number (the heartbeat count of this node instance).
    pub seq: u64,
    /// Monotonic stamp, ns.
    pub stamp_ns: u64,
    /// Simulated/robot time, ns (the recorder's newest robot state).
    pub sim_time_ns: u64,
    /// Node role.
    pub node: String,
    /// Process id.
    pub pid: u32,
    /// Steps the node has run.
    pub steps: u64,
    /// Per input topic.
    pub inputs: Vec<InputHealth>,
}

/// A deadline-monitor event (`/runtime/deadline`).
#[derive(Debug, Clone, Default, PartialEq, Encode, Serialize, Deserialize)]
pub struct DeadlineEvent {
    /// Sequence number.
    pub seq: u64,
    /// Monotonic stamp, ns.
    pub stamp_ns: u64,
    /// Simulated/robot time, ns.
    pub sim_time_ns: u64,
    /// Thread name.
    pub thread: String,
    /// Cycle number.
    pub cycle: u64,
    /// Period, ns.
    pub period_ns: u64,
    /// Budget, ns.
    pub budget_ns: u64,
    /// Wake-up lateness, ns.
    pub lateness_ns: i64,
    /// Execution time (wall), ns.
    pub exec_ns: u64,
    /// CPU time of the cycle, ns.
    pub cpu_ns: u64,
    /// Run-queue wait in the cycle, ns.
    pub run_wait_ns: u64,
    /// Scheduler statistics were available.
    pub sched_stats: bool,
    /// Woken by the backup waker.
    pub backup_wake: bool,
    /// Misses in a row.
    pub consecutive_misses: u32,
    /// The deadline was missed.
    pub miss: bool,
    /// Cause of the miss.
    pub miss_cause: String,
}

/// Latency of one node or path over a period.
#[derive(Debug, Clone, Default, PartialEq, Encode, Serialize, Deserialize)]
pub struct NodeLatencyMsg {
    /// Node or path.
    pub node: String,
    /// Samples.
    pub count: u64,
    /// Minimum, ns.
    pub min_ns: u64,
    /// Median, ns.
    pub p50_ns: u64,
    /// 90th percentile, ns.
    pub p90_ns: u64,
    /// 99th percentile, ns.
    pub p99_ns: u64,
    /// Maximum, ns.
    pub max_ns: u64,
    /// Mean, ns.
    pub mean_ns: f64,
}

/// Per-period latency summary (`/runtime/latency`).
#[derive(Debug, Clone, Default, PartialEq, Encode, Serialize, Deserialize)]
pub struct LatencySummary {
    /// End of the period, ns.
    pub time_ns: u64,
    /// Length of the period, ns.
    pub period_ns: u64,
    /// One entry per node or path.
    pub nodes: Vec<NodeLatencyMsg>,
}

/// One number of `metrics.json`, by its dotted path (`completeness.recall`).
#[derive(Debug, Clone, Default, PartialEq, Encode, Serialize, Deserialize)]
pub struct MetricValue {
    /// Dotted path of the value in `metrics.json`.
    pub key: String,
    /// The value.
    pub value: f64,
}

/// The run's metrics (`/metrics`): the numbers, plottable, and the whole `metrics.json` text.
#[derive(Debug, Clone, Default, PartialEq, Encode, Serialize, Deserialize)]
pub struct Metrics {
    /// Every numeric leaf.
    pub values: Vec<MetricValue>,
    /// `metrics.json` as written.
    pub json: String,
}

/// Counts of one topic in the recorder (`/recorder/stats`).
#[derive(Debug, Clone, Default, PartialEq, Encode, Serialize, Deserialize)]
pub struct TopicCounts {
    /// Topic.
    pub topic: String,
    /// Inputs offered to the recorder (primary topics only, else 0).
    pub offered: u64,
    /// Inputs dropped because the recorder fell behind.
    pub dropped: u64,
    /// Messages left out on purpose by the profile's rate limit.
    pub throttled: u64,
    /// Messages written.
    pub written: u64,
}

/// The recorder's counters (`/recorder/stats`, every `stats_interval_s` and at finish).
#[derive(Debug, Clone, Default, PartialEq, Encode, Serialize, Deserialize)]
pub struct RecorderStats {
    /// `replay` or `view`.
    pub profile: String,
    /// One entry per topic.
    pub topics: Vec<TopicCounts>,
    /// Sum of the drops.
    pub dropped_total: u64,
    /// Sum of the throttled messages.
    pub throttled_total: u64,
    /// The last stats of the recording.
    pub last: bool,
}
