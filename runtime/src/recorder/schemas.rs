//! Channels: a topic with its schema, the runtime's own topics and their schemas (Foxglove's
//! `foxglove.Log` and the ones `foxglove::Encode` derives for [`super::messages`]). Every
//! channel's message encoding is `protobuf`, its schema a `FileDescriptorSet`.

use super::messages as own;
use foxglove::messages as fg;
use foxglove::{Encode, Schema};

/// The runtime's own topics (the app names the rest: its [`super::Converter::channels`]).
pub mod topic {
    /// Deadline-monitor events.
    pub const DEADLINE: &str = "/runtime/deadline";
    /// Node heartbeats with their per-input counts.
    pub const HEALTH: &str = "/runtime/health";
    /// Per-node latency summaries.
    pub const LATENCY: &str = "/runtime/latency";
    /// Log lines.
    pub const LOG: &str = "/log";
    /// Final metrics.
    pub const METRICS: &str = "/metrics";
    /// The recorder's own counters.
    pub const STATS: &str = "/recorder/stats";
}

/// Name of the MCAP Metadata record with the final drop counts.
pub const STATS_METADATA: &str = "recorder_stats";
/// Name of the MCAP Metadata record with the session facts.
pub const SESSION_METADATA: &str = "session";

/// One channel of a trace.
#[derive(Debug, Clone)]
pub struct ChannelDef {
    /// Topic.
    pub topic: &'static str,
    /// Schema (name, encoding `protobuf`, `FileDescriptorSet`).
    pub schema: Schema,
    /// Message encoding (`protobuf`).
    pub encoding: String,
}

impl ChannelDef {
    /// The channel of `topic` carrying `T` (a Foxglove well-known type or one deriving
    /// `foxglove::Encode`).
    pub fn of<T: Encode>(topic: &'static str) -> Self {
        Self {
            topic,
            // Every type the recorder writes has a schema (the well-known ones and the derived
            // ones).
            schema: T::get_schema().unwrap_or_else(|| Schema::new("", "", Vec::new())),
            encoding: T::get_message_encoding(),
        }
    }
}

/// The runtime's own channels, created after the app's ([`super::Converter::channels`]).
pub fn own_channels() -> Vec<ChannelDef> {
    use topic::*;
    vec![
        ChannelDef::of::<own::DeadlineEvent>(DEADLINE),
        ChannelDef::of::<own::NodeHealth>(HEALTH),
        ChannelDef::of::<own::LatencySummary>(LATENCY),
        ChannelDef::of::<fg::Log>(LOG),
        ChannelDef::of::<own::Metrics>(METRICS),
        ChannelDef::of::<own::RecorderStats>(STATS),
    ]
}

/// True for the channels whose type is a Foxglove well-known schema (`foxglove.*`).
pub fn is_foxglove(c: &ChannelDef) -> bool {
    c.schema.name.starts_with("foxglove.")
}
