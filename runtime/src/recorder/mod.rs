//! The MCAP recorder: every topic of a session into one file that Foxglove and any MCAP tool can
//! open, and that `vpsom replay` can re-run the robot's logic on.
//!
//! The recorder writes what it is given: the app supplies a [`Converter`] ([`RecorderSetup`])
//! that names its channels (topics and schemas) and turns each recorded input into messages on
//! them. The recorder owns the rest: the producer side, the writer thread, channel and schema
//! registration, rate limits, overflow, stats, the live view, recovery, and reading traces back.
//!
//! | file | what |
//! |---|---|
//! | `mod.rs` | [`Recorder`], [`RecorderHandle`], [`RecorderSetup`], config and profiles, drop counting |
//! | `writer.rs` | the writer thread and its [`Sink`]: encoding, rate limits, chunks, flushing, stats |
//! | `convert.rs` | [`Converter`] (what the app supplies), the producer-side copies, the runtime's own messages' conversion |
//! | `messages.rs` | the runtime's own channels' types (protobuf, schemas derived by `foxglove::Encode`) |
//! | `schemas.rs` | [`schemas::ChannelDef`], the runtime's own topics and their schemas |
//! | `decode.rs` | reading any channel back through the schema in the file |
//! | `inspect.rs` | reading traces back: `info`, CSV export (all segments of a run) |
//! | `recover.rs` | torn-file recovery and the run's segments |
//! | `live.rs`, `live_front.rs` | the live view (Foxglove's WebSocket protocol, both its names) |
//!
//! # Threading
//! [`Recorder::create`] opens the file and starts one named writer thread (`recorder`) that owns
//! the [`mcap::Writer`]. Producers hold a cloneable [`RecorderHandle`] whose `record_*` methods
//! never block and never allocate for the real-time kinds (state, goals, deadline events, planner
//! decisions): small messages are copied by value into a bounded crossbeam channel; large ones
//! (`DepthFrame`, `Detections`, `ObjectMap`, `PlannerDecision`) are copied into preallocated
//! boxes taken from a pool. Conversion (by the [`Converter`]) and encoding happen on the writer
//! thread, which also publishes every encoded message to the live view ([`live`]) when one is
//! attached.
//!
//! # Profiles: `replay` and `view`
//! `recorder.profile = "replay"` (the default) writes every message the converter makes (an app
//! converts every input of its logic losslessly, so a trace can be replayed). `"view"` is for
//! long runs: every topic named in `[recorder.view.max_hz]` is written at most that often
//! (simulated time; 0 = not at all), and the converter is to decimate depth by
//! [`RecorderConfig::depth_decimation`]. What a rate limit leaves out is
//! counted per topic as `throttled` (not a drop) in `/recorder/stats` and the final metadata.
//!
//! # Falling behind
//! Depth frames do not go through the channel: they wait in a small ring of
//! `recorder.depth_queue_len` slots where a new frame replaces the *oldest* queued one, and the
//! writer serves every other message before the next depth frame, so depth is what is lost first.
//! Any other message is dropped only if the channel or its pool is full. Every drop is counted
//! per topic ([`RecorderHandle::dropped`]) and written into the file: periodically on
//! `/recorder/stats` and at finish as the MCAP Metadata record `recorder_stats`.
//!
//! That is [`Overflow::Drop`], the default and what a live host uses: no real-time thread ever
//! waits for a disk. A host on a simulated clock (lockstep, replay) chooses [`Overflow::Wait`] in
//! [`RecorderSetup::overflow`] (in code, never from a config key): a `record_*` call then waits
//! until the channel, the pool or the depth ring has room, so nothing is dropped however far the
//! writer falls behind, and the host's clock does not advance until the step's messages are
//! queued. A message is then dropped (and counted) only once the writer thread has stopped (an
//! I/O error, which [`Recorder::finish`] returns; [`RecorderHandle::writer_stopped`] tells the
//! host to stop early).
//!
//! # Crash safety
//! Chunks are bounded by size (`chunk_size_kb`) and by age (`flush_interval_s`): the writer
//! finishes and flushes a chunk once it is older than the interval, so after SIGKILL everything up
//! to the last completed chunk reads back (`inspect` reads truncated files), and
//! [`recover::recover`] (`vpsom trace recover IN OUT`) turns such a file into a finished, indexed
//! MCAP. On SIGINT/SIGTERM the host calls [`Recorder::finish`]; dropping the [`Recorder`]
//! finishes the file too. (This is why the recorder keeps its own [`mcap::Writer`] rather than
//! foxglove's `McapWriter`: that one has no age bound on chunks, no segments and no recovery.)
//!
//! # Segments: a restarted recorder never truncates
//! [`Recorder::create`] starts a new run (truncating `trace.mcap`); [`Recorder::resume`] is what a
//! recorder node restarted within a run calls: it continues at once in `trace.1.mcap`,
//! `trace.2.mcap`, ... and recovers the torn earlier segments in place on a background thread
//! (see [`recover`]). `inspect::info` and
//! `inspect::export_csv` read all segments of a run as one.
//!
//! # Encoding: protobuf, Foxglove's own schemas
//! Every channel is `protobuf` with a `FileDescriptorSet` schema. The Foxglove well-known types
//! are `foxglove::messages::*` (schema `foxglove.RawImage`, ...), so Foxglove shows them natively
//! and any protobuf reader (Python `mcap-protobuf-support`) decodes them; depth is raw `16UC1`
//! bytes. Our own types ([`messages`]) have schemas derived by `foxglove::Encode`.
//!
//! # Topics
//! The app's channels are its converter's (the app's are listed in `vpsom::recording`). Each
//! input kind ([`Kind`]) has one primary topic that carries one message per accepted input
//! ([`Converter::topic`]); offers and drops are counted under it. The runtime's own channels
//! follow the app's:
//!
//! | topic | schema | from |
//! |---|---|---|
//! | `/runtime/deadline` | [`messages::DeadlineEvent`] | [`RecorderHandle::record_deadline`] |
//! | `/runtime/health` | [`messages::NodeHealth`] | [`RecorderHandle::record_health`] |
//! | `/runtime/latency` | [`messages::LatencySummary`] | [`RecorderHandle::record_latency`] |
//! | `/log` | `foxglove.Log` | [`RecorderHandle::log`] |
//! | `/metrics` | [`messages::Metrics`] | [`RecorderHandle::record_metrics`] |
//! | `/recorder/stats` | [`messages::RecorderStats`] | the writer, every `stats_interval_s` |
//!
//! Log time of a message is its simulated/robot time (`header.sim_time_ns`), publish time its
//! monotonic stamp (`header.stamp_ns`), so lockstep and deployment traces share one time base.

pub mod convert;
pub mod decode;
pub mod inspect;
pub mod live;
mod live_front;
pub mod messages;
pub mod recover;
pub mod schemas;
mod writer;

pub use convert::Converter;
pub use writer::Sink;

/// The `foxglove` crate the recorder writes with (its messages decode a trace's Foxglove channels).
pub use foxglove;

use crate::config::{Checker, ConfigError};
use crossbeam::channel::{Receiver, RecvTimeoutError, Sender, TrySendError};
use crossbeam::queue::ArrayQueue;
use serde::{Deserialize, Serialize};
use shm_types::{
    DeadlineEvent, DepthFrame, Detections, NavGoal, NeckGoal, NodeHealth, ObjectMap, OccupancyGrid,
    PlannerDecision, RobotState, ZeroValid, boxed_zeroed,
};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::thread::JoinHandle;
use std::time::Duration;

/// Chunk compression.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Compression {
    /// zstd (best ratio; the default).
    Zstd,
    /// lz4 (fastest).
    Lz4,
    /// Uncompressed chunks.
    None,
}

/// What a recording keeps (`recorder.profile`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Profile {
    /// Every input of the mapper and planner, losslessly, and what they published.
    Replay,
    /// Per-topic rate limits and decimated depth, for long runs.
    View,
}

impl Profile {
    /// `replay` or `view`.
    pub fn name(self) -> &'static str {
        match self {
            Profile::Replay => "replay",
            Profile::View => "view",
        }
    }
}

/// What a `record_*` call does when the writer is behind and there is no room for the message
/// (the channel, its pool or the depth ring is full). The host chooses it
/// ([`RecorderSetup::overflow`]); no config key does.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum Overflow {
    /// Drop the message (for depth: the oldest queued frame) and count it; never wait. For live
    /// hosts, whose real-time threads record.
    #[default]
    Drop,
    /// Wait until the writer has made room; nothing is dropped while the writer runs. For hosts
    /// on a simulated clock (lockstep, replay), whose traces must hold every input.
    Wait,
}

impl Overflow {
    /// `drop` or `wait` (the session metadata's `overflow`).
    pub fn name(self) -> &'static str {
        match self {
            Overflow::Drop => "drop",
            Overflow::Wait => "wait",
        }
    }
}

/// For tests: a function the writer thread calls before it writes each message (a test makes
/// the writer slow, or stalls it, to see what the producers do when it falls behind).
#[derive(Clone)]
pub struct WriterHook(pub Arc<dyn Fn() + Send + Sync>);

impl WriterHook {
    /// A hook that calls `f`.
    pub fn new(f: impl Fn() + Send + Sync + 'static) -> Self {
        Self(Arc::new(f))
    }
}

impl std::fmt::Debug for WriterHook {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("WriterHook(..)")
    }
}

impl PartialEq for WriterHook {
    fn eq(&self, other: &Self) -> bool {
        Arc::ptr_eq(&self.0, &other.0)
    }
}

/// `[recorder.view]`: the limits of the `view` profile.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ViewProfile {
    /// Depth images (and their detection boxes) are decimated by this factor in x and y.
    pub depth_decimation: u32,
    /// Most messages per simulated second, per topic (0 = not recorded; a topic not listed is
    /// not limited).
    pub max_hz: std::collections::BTreeMap<String, f64>,
}

/// `[recorder]` section.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RecorderConfig {
    /// `replay` (lossless inputs) or `view` (rate-limited).
    pub profile: Profile,
    /// Chunk compression: "zstd", "lz4" or "none".
    pub compression: Compression,
    /// Compression level (0 = the codec's default).
    pub compression_level: u32,
    /// Target uncompressed chunk size, KiB.
    pub chunk_size_kb: u64,
    /// A chunk older than this is finished and flushed (bounds the loss after SIGKILL), seconds.
    pub flush_interval_s: f64,
    /// Capacity of the channel from producers to the writer thread (messages).
    pub queue_len: usize,
    /// Depth frames waiting for the writer; a new frame replaces the oldest when full.
    pub depth_queue_len: usize,
    /// Preallocated copies each of `Detections`, `ObjectMap` and `PlannerDecision` in flight.
    pub pool_len: usize,
    /// Period of the `/recorder/stats` messages, seconds.
    pub stats_interval_s: f64,
    /// For the app's converter: rate of its trajectory messages (simulated time), Hz.
    pub trajectory_hz: f64,
    /// For the app's converter: most poses kept in a trajectory message (older ones are thinned
    /// by 2 when exceeded).
    pub trajectory_max_poses: usize,
    /// For the app's converter: length of the drawn candidate-view frusta, metres.
    pub frustum_length_m: f64,
    /// Port of the live view when `vpsom run --live` names none.
    pub live_port: u16,
    /// Limits of the `view` profile.
    pub view: ViewProfile,
}

impl Default for RecorderConfig {
    /// The `[recorder]` section of the built-in `config/runtime.toml`.
    fn default() -> Self {
        crate::config::RUNTIME_DEFAULTS.section("recorder")
    }
}

impl RecorderConfig {
    /// Depth decimation in force: 1 (exact) in the `replay` profile.
    pub fn depth_decimation(&self) -> u32 {
        match self.profile {
            Profile::Replay => 1,
            Profile::View => self.view.depth_decimation,
        }
    }

    /// Rate limit of `topic` in force, Hz (`None`: every message; `Some(0.0)`: none).
    pub fn max_hz(&self, topic: &str) -> Option<f64> {
        match self.profile {
            Profile::Replay => None,
            Profile::View => self.view.max_hz.get(topic).copied(),
        }
    }

    /// Range-check the `[recorder]` section and `[recorder.view]`; `topics` are the channels a
    /// trace has (the app's and the runtime's own), which `[recorder.view.max_hz]` may name.
    pub fn validate(&self, c: &Checker, topics: &[&str]) -> Result<(), ConfigError> {
        let c = &c.at("recorder");
        settings::ranges!(c, self, {
            compression_level: count(0, 19),
            chunk_size_kb: count(16, 64 * 1024),
            flush_interval_s: in_range(0.05, 10.0),
            queue_len: count(16, 1 << 20),
            depth_queue_len: count(1, 64),
            pool_len: count(1, 256),
        });
        let view = c.at(stringify!(view));
        settings::ranges!(view, self.view, {
            depth_decimation: count(1, 16),
        });
        let max_hz = view.at(stringify!(max_hz));
        for (t, &hz) in &self.view.max_hz {
            let key = max_hz.key(&format!("\"{t}\""));
            c.require(
                topics.contains(&t.as_str()),
                &key,
                hz,
                &format!("no such topic; topics: {}", topics.join(", ")),
            )?;
            c.in_range(&key, hz, 0.0, 1000.0)?;
        }
        settings::ranges!(c, self, {
            stats_interval_s: in_range(0.05, 60.0),
            trajectory_hz: in_range(0.01, 100.0),
            trajectory_max_poses: count(2, 1_000_000),
            frustum_length_m: in_range(0.01, 10.0),
        });
        Ok(())
    }
}

/// What a recording is of: the app's [`Converter`] and static facts about the session, written
/// once at start.
#[derive(Debug)]
pub struct RecorderSetup {
    /// The app's channels and how its inputs become messages on them.
    pub converter: Box<dyn Converter>,
    /// Scene name (MCAP metadata `session`).
    pub scene: String,
    /// Serve the recorded channels live to Foxglove on this port ([`live`]; 0 = any free port).
    pub live_port: Option<u16>,
    /// The host that ran the logic (MCAP metadata `session`, key `host`): `lockstep` (one
    /// process, simulated clock: `vpsom replay --check` reproduces it exactly) or `live`
    /// (processes on real clocks: reproduced to a tolerance); empty if unknown.
    pub host: String,
    /// Drop (live hosts) or wait (simulated clocks) when the writer is behind (MCAP metadata
    /// `session`, key `overflow`).
    pub overflow: Overflow,
    /// For tests: called by the writer thread before each message it writes.
    pub writer_hook: Option<WriterHook>,
}

impl RecorderSetup {
    /// A setup with `converter`, no scene name, no live view, host unknown, [`Overflow::Drop`].
    pub fn new(converter: impl Converter + 'static) -> Self {
        Self {
            converter: Box::new(converter),
            scene: String::new(),
            live_port: None,
            host: String::new(),
            overflow: Overflow::Drop,
            writer_hook: None,
        }
    }
}

/// Latency of one node or path over the last summary period.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct NodeLatency {
    /// Node or path name, e.g. `lbv` or `frame->map`.
    pub node: String,
    /// Samples in the period.
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

impl NodeLatency {
    /// Summary of an hdrhistogram of nanosecond samples.
    pub fn from_histogram(node: &str, h: &hdrhistogram::Histogram<u64>) -> Self {
        Self {
            node: node.to_string(),
            count: h.len(),
            min_ns: if h.is_empty() { 0 } else { h.min() },
            p50_ns: h.value_at_quantile(0.5),
            p90_ns: h.value_at_quantile(0.9),
            p99_ns: h.value_at_quantile(0.99),
            max_ns: h.max(),
            mean_ns: if h.is_empty() { 0.0 } else { h.mean() },
        }
    }
}

/// A per-period latency summary of every node (`/runtime/latency`, ~1 Hz).
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct LatencySummary {
    /// Simulated/robot time at the end of the period, ns.
    pub time_ns: u64,
    /// Length of the period, ns.
    pub period_ns: u64,
    /// One entry per node or path.
    pub nodes: Vec<NodeLatency>,
}

/// Severity of a `/log` line (values of `foxglove.Log.level`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub enum LogLevel {
    /// Debug.
    Debug = 1,
    /// Info.
    Info = 2,
    /// Warning.
    Warning = 3,
    /// Error.
    Error = 4,
    /// Fatal.
    Fatal = 5,
}

/// Kinds of recorded input; each has one primary topic under which its offers and drops are
/// counted (the runtime's own for the runtime's kinds, [`Converter::topic`] for the others).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// Depth frames.
    Depth = 0,
    /// Detections.
    Detections,
    /// Navigation grids.
    NavGrid,
    /// Estimated robot state.
    State,
    /// True robot state.
    TrueState,
    /// Object maps.
    Map,
    /// Planner decisions.
    Decision,
    /// Navigation goals.
    NavGoal,
    /// Neck goals.
    NeckGoal,
    /// Deadline-monitor events.
    Deadline,
    /// Node heartbeats with their input counts.
    Health,
    /// Latency summaries.
    Latency,
    /// Log lines.
    Log,
    /// Final metrics.
    Metrics,
}

impl Kind {
    /// Every kind, in index order.
    pub const ALL: [Kind; 14] = [
        Kind::Depth,
        Kind::Detections,
        Kind::NavGrid,
        Kind::State,
        Kind::TrueState,
        Kind::Map,
        Kind::Decision,
        Kind::NavGoal,
        Kind::NeckGoal,
        Kind::Deadline,
        Kind::Health,
        Kind::Latency,
        Kind::Log,
        Kind::Metrics,
    ];

    /// Whether the app's [`Converter`] converts this kind (the shared-memory messages of the
    /// robot's logic), rather than the recorder (the runtime's own inputs).
    pub fn converted(self) -> bool {
        self.own_topic().is_none()
    }

    /// The runtime's own topic of this kind, `None` for the kinds the converter converts.
    fn own_topic(self) -> Option<&'static str> {
        use schemas::topic;
        match self {
            Kind::Deadline => Some(topic::DEADLINE),
            Kind::Health => Some(topic::HEALTH),
            Kind::Latency => Some(topic::LATENCY),
            Kind::Log => Some(topic::LOG),
            Kind::Metrics => Some(topic::METRICS),
            _ => None,
        }
    }
}

const KINDS: usize = Kind::ALL.len();

/// Counters shared by the handles and the writer.
#[derive(Debug, Default)]
struct Counters {
    offered: [AtomicU64; KINDS],
    dropped: [AtomicU64; KINDS],
}

impl Counters {
    fn offer(&self, k: Kind) {
        self.offered[k as usize].fetch_add(1, Ordering::Relaxed);
    }
    fn drop_one(&self, k: Kind) {
        self.dropped[k as usize].fetch_add(1, Ordering::Relaxed);
    }
}

/// Messages counted per topic: offered to the recorder and dropped by it.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct DropCounts {
    /// Inputs offered per primary topic.
    pub offered: std::collections::BTreeMap<String, u64>,
    /// Inputs dropped per primary topic (never written).
    pub dropped: std::collections::BTreeMap<String, u64>,
    /// Messages left out by the profile's rate limits, per topic (not drops).
    #[serde(default)]
    pub throttled: std::collections::BTreeMap<String, u64>,
}

impl DropCounts {
    /// Sum of all drops.
    pub fn total_dropped(&self) -> u64 {
        self.dropped.values().sum()
    }

    /// Sum of all throttled messages.
    pub fn total_throttled(&self) -> u64 {
        self.throttled.values().sum()
    }
}

/// How often a producer waiting for a pooled box ([`Overflow::Wait`]) looks whether the writer
/// has stopped (a box given back wakes it at once).
const STOPPED_POLL: Duration = Duration::from_millis(50);

/// A fixed set of preallocated boxes (a bounded channel of them, so a producer can wait for one).
#[derive(Debug)]
struct Pool<T> {
    give: Sender<Box<T>>,
    free: Receiver<Box<T>>,
}

impl<T: ZeroValid> Pool<T> {
    fn new(n: usize) -> Self {
        let (give, free) = crossbeam::channel::bounded(n);
        for _ in 0..n {
            // Cannot fail: the channel has exactly n slots.
            let _ = give.try_send(boxed_zeroed::<T>());
        }
        Self { give, free }
    }
    fn take(&self) -> Option<Box<T>> {
        self.free.try_recv().ok()
    }
    /// A box, waiting for one to be given back; `None` once `stopped` is set and none is free.
    fn take_waiting(&self, stopped: &AtomicBool) -> Option<Box<T>> {
        loop {
            if stopped.load(Ordering::Acquire) {
                return self.take();
            }
            match self.free.recv_timeout(STOPPED_POLL) {
                Ok(b) => return Some(b),
                // The pool holds its own sender: never disconnected.
                Err(RecvTimeoutError::Timeout | RecvTimeoutError::Disconnected) => {}
            }
        }
    }
    fn give(&self, b: Box<T>) {
        // The pool never holds more than it was built with, so this cannot be full; if it ever
        // were, the box is simply freed.
        let _ = self.give.try_send(b);
    }
}

/// State shared by the handles and the writer thread.
#[derive(Debug)]
struct Shared {
    counters: Counters,
    /// The primary topic of each kind (offers and drops are counted under it).
    topics: [&'static str; KINDS],
    overflow: Overflow,
    /// Set when the writer thread has ended (finished, failed or panicked).
    writer_stopped: AtomicBool,
    depth_ready: ArrayQueue<Box<DepthFrame>>,
    depth_pool: Pool<DepthFrame>,
    detections_pool: Pool<Detections>,
    map_pool: Pool<ObjectMap>,
    decision_pool: Pool<PlannerDecision>,
}

impl Shared {
    fn new(
        topics: [&'static str; KINDS],
        overflow: Overflow,
        depth_queue_len: usize,
        pool_len: usize,
    ) -> Self {
        Self {
            counters: Counters::default(),
            topics,
            overflow,
            writer_stopped: AtomicBool::new(false),
            // Waiting, the ring holds every depth buffer, so no queued frame is ever replaced.
            depth_ready: ArrayQueue::new(match overflow {
                Overflow::Drop => depth_queue_len,
                Overflow::Wait => depth_queue_len + 1,
            }),
            depth_pool: Pool::new(depth_queue_len + 1),
            detections_pool: Pool::new(pool_len),
            map_pool: Pool::new(pool_len),
            decision_pool: Pool::new(pool_len),
        }
    }

    /// A pooled box: at once or dropped ([`Overflow::Drop`]), or waiting for one.
    fn take<T: ZeroValid>(&self, pool: &Pool<T>) -> Option<Box<T>> {
        match self.overflow {
            Overflow::Drop => pool.take(),
            Overflow::Wait => pool.take_waiting(&self.writer_stopped),
        }
    }

    fn drop_counts(&self) -> DropCounts {
        let mut d = DropCounts::default();
        for k in Kind::ALL {
            let t = self.topics[k as usize].to_string();
            d.offered.insert(
                t.clone(),
                self.counters.offered[k as usize].load(Ordering::Relaxed),
            );
            d.dropped
                .insert(t, self.counters.dropped[k as usize].load(Ordering::Relaxed));
        }
        d
    }
}

/// What travels through the channel to the writer thread.
#[derive(Debug)]
enum Msg {
    State(RobotState),
    TrueState(RobotState),
    Detections(Box<Detections>),
    NavGrid(Box<OccupancyGrid>),
    Map(Box<ObjectMap>),
    Decision(Box<PlannerDecision>),
    NavGoal(NavGoal),
    NeckGoal(NeckGoal),
    Deadline(DeadlineEvent),
    Health(Box<NodeHealth>),
    Latency(LatencySummary),
    Log {
        time_ns: u64,
        level: LogLevel,
        name: String,
        text: String,
    },
    Metrics {
        time_ns: u64,
        value: serde_json::Value,
    },
    Finish,
}

/// Errors of the recorder.
#[derive(Debug, thiserror::Error)]
pub enum RecorderError {
    /// The output file could not be created.
    #[error("{path}: cannot create recording: {source}")]
    Create {
        /// The file.
        path: PathBuf,
        /// Cause.
        source: std::io::Error,
    },
    /// The MCAP writer failed (disk full, I/O error).
    #[error("{path}: MCAP write failed: {source}")]
    Mcap {
        /// The file.
        path: PathBuf,
        /// Cause.
        source: mcap::McapError,
    },
    /// The live-view server could not be started.
    #[error("cannot start the live view: {0}")]
    Live(String),
    /// The writer thread could not be started.
    #[error("cannot start the recorder thread: {0}")]
    Spawn(std::io::Error),
    /// The writer thread panicked.
    #[error("{path}: the recorder thread panicked")]
    Panicked {
        /// The file.
        path: PathBuf,
    },
    /// A trace file could not be read.
    #[error("{path}: {message}")]
    Read {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
}

/// What a finished recording contains.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RecorderSummary {
    /// Messages written per topic.
    pub written: std::collections::BTreeMap<String, u64>,
    /// Offered and dropped per primary topic.
    pub drops: DropCounts,
    /// CPU time used by the writer thread, ns (0 if unavailable).
    pub writer_cpu_ns: u64,
}

/// Cheap, cloneable producer side of a [`Recorder`]. With [`Overflow::Drop`] every method returns
/// at once and a message that cannot be queued is dropped and counted; with [`Overflow::Wait`] a
/// method waits for room (see the module docs, "Falling behind").
#[derive(Debug, Clone)]
pub struct RecorderHandle {
    tx: Sender<Msg>,
    /// Capacity-1 wake-up for the writer when a depth frame is queued (never uses `tx` room).
    wake: Sender<()>,
    shared: Arc<Shared>,
}

impl RecorderHandle {
    fn push(&self, kind: Kind, msg: Msg) {
        self.shared.counters.offer(kind);
        let refused = match self.shared.overflow {
            Overflow::Drop => match self.tx.try_send(msg) {
                Ok(()) => None,
                Err(TrySendError::Full(m) | TrySendError::Disconnected(m)) => Some(m),
            },
            // Fails only once the writer thread has ended.
            Overflow::Wait => self.tx.send(msg).err().map(|e| e.into_inner()),
        };
        if let Some(m) = refused {
            self.shared.counters.drop_one(kind);
            self.recycle(m);
        }
    }

    /// A pooled box for `kind`, or the drop counted.
    fn take<T: ZeroValid>(&self, kind: Kind, pool: &Pool<T>) -> Option<Box<T>> {
        let b = self.shared.take(pool);
        if b.is_none() {
            self.shared.counters.offer(kind);
            self.shared.counters.drop_one(kind);
        }
        b
    }

    fn recycle(&self, m: Msg) {
        match m {
            Msg::Map(b) => self.shared.map_pool.give(b),
            Msg::Detections(b) => self.shared.detections_pool.give(b),
            Msg::Decision(b) => self.shared.decision_pool.give(b),
            _ => {}
        }
    }

    /// Record a depth frame ([`Converter::depth`]). Copies the used pixels into a preallocated buffer;
    /// if all are queued, the oldest queued frame is dropped (and counted) to make room
    /// ([`Overflow::Drop`]), or the call waits until the writer has taken one ([`Overflow::Wait`]).
    pub fn record_depth(&self, frame: &DepthFrame) {
        let s = &*self.shared;
        s.counters.offer(Kind::Depth);
        if self.writer_stopped() {
            // Nothing would ever write it.
            s.counters.drop_one(Kind::Depth);
            return;
        }
        let buf = match s.overflow {
            Overflow::Drop => s.depth_pool.take().or_else(|| {
                let old = s.depth_ready.pop();
                if old.is_some() {
                    s.counters.drop_one(Kind::Depth);
                }
                old
            }),
            Overflow::Wait => s.depth_pool.take_waiting(&s.writer_stopped),
        };
        let mut buf = match buf {
            Some(b) => b,
            None => {
                // Every buffer is in the writer's or another producer's hands.
                s.counters.drop_one(Kind::Depth);
                return;
            }
        };
        convert::copy_depth(frame, &mut buf);
        if let Some(old) = s.depth_ready.force_push(buf) {
            s.counters.drop_one(Kind::Depth);
            s.depth_pool.give(old);
        }
        // Wake the writer; a pending wake-up already does.
        let _ = self.wake.try_send(());
    }

    /// Record detections ([`Converter::detections`]), copied into a pooled buffer.
    pub fn record_detections(&self, d: &Detections) {
        if let Some(mut b) = self.take(Kind::Detections, &self.shared.detections_pool) {
            convert::copy_detections(d, &mut b);
            self.push(Kind::Detections, Msg::Detections(b));
        }
    }

    /// Record the navigation grid ([`Converter::nav_grid`]). Allocates a copy: grids are rare (the sim
    /// publishes one a second); not for a real-time thread.
    pub fn record_nav_grid(&self, g: &OccupancyGrid) {
        let mut b = boxed_zeroed::<OccupancyGrid>();
        b.header = g.header;
        b.origin = g.origin;
        b.resolution = g.resolution;
        b.width = g.width;
        b.height = g.height;
        let n = (g.width as usize * g.height as usize).min(g.cells.len());
        b.cells[..n].copy_from_slice(&g.cells[..n]);
        self.push(Kind::NavGrid, Msg::NavGrid(b));
    }

    /// Record the estimated robot state ([`Converter::state`]).
    pub fn record_state(&self, state: &RobotState) {
        self.push(Kind::State, Msg::State(*state));
    }

    /// Record the true robot state ([`Converter::true_state`]); simulation only.
    pub fn record_true_state(&self, state: &RobotState) {
        self.push(Kind::TrueState, Msg::TrueState(*state));
    }

    /// Record an object map ([`Converter::map`]), copied into a pooled buffer.
    pub fn record_map(&self, map: &ObjectMap) {
        if let Some(mut b) = self.take(Kind::Map, &self.shared.map_pool) {
            b.copy_from(map);
            self.push(Kind::Map, Msg::Map(b));
        }
    }

    /// Record a planner decision ([`Converter::decision`]), copied into a pooled buffer.
    pub fn record_decision(&self, d: &PlannerDecision) {
        if let Some(mut b) = self.take(Kind::Decision, &self.shared.decision_pool) {
            convert::copy_decision(d, &mut b);
            self.push(Kind::Decision, Msg::Decision(b));
        }
    }

    /// Record a navigation goal ([`Converter::nav_goal`]).
    pub fn record_nav_goal(&self, g: &NavGoal) {
        self.push(Kind::NavGoal, Msg::NavGoal(*g));
    }

    /// Record a neck goal ([`Converter::neck_goal`]).
    pub fn record_neck_goal(&self, g: &NeckGoal) {
        self.push(Kind::NeckGoal, Msg::NeckGoal(*g));
    }

    /// Record a deadline-monitor event (`/runtime/deadline`).
    pub fn record_deadline(&self, e: &DeadlineEvent) {
        self.push(Kind::Deadline, Msg::Deadline(*e));
    }

    /// Record a node's heartbeat and input counts (`/runtime/health`), a few per second.
    pub fn record_health(&self, h: &NodeHealth) {
        self.push(Kind::Health, Msg::Health(Box::new(*h)));
    }

    /// Record a latency summary (`/runtime/latency`), about once a second.
    pub fn record_latency(&self, s: LatencySummary) {
        self.push(Kind::Latency, Msg::Latency(s));
    }

    /// Record a log line (`/log`) at time `time_ns` from `name` (node or thread).
    pub fn log(&self, time_ns: u64, level: LogLevel, name: &str, text: &str) {
        self.push(
            Kind::Log,
            Msg::Log {
                time_ns,
                level,
                name: name.to_string(),
                text: text.to_string(),
            },
        );
    }

    /// Record the final metrics (`/metrics`): the `metrics.json` object.
    pub fn record_metrics(&self, time_ns: u64, value: serde_json::Value) {
        self.push(Kind::Metrics, Msg::Metrics { time_ns, value });
    }

    /// Offered and dropped counts so far, per primary topic.
    pub fn drops(&self) -> DropCounts {
        self.shared.drop_counts()
    }

    /// Drops so far of one kind.
    pub fn dropped(&self, kind: Kind) -> u64 {
        self.shared.counters.dropped[kind as usize].load(Ordering::Relaxed)
    }

    /// Whether the writer thread has ended: finished, or failed (the error is what
    /// [`Recorder::finish`] returns). Nothing recorded afterwards is written.
    pub fn writer_stopped(&self) -> bool {
        self.shared.writer_stopped.load(Ordering::Acquire)
    }
}

/// A recording in progress: the writer thread and a handle. Finishes the file on drop.
#[derive(Debug)]
pub struct Recorder {
    handle: RecorderHandle,
    thread: Option<JoinHandle<Result<RecorderSummary, RecorderError>>>,
    path: PathBuf,
    live_port: Option<u16>,
    /// Recovery of the earlier segments, on a background thread ([`Recorder::resume`]).
    recovery: Option<JoinHandle<Vec<RecoveredSegment>>>,
    recovered: Vec<RecoveredSegment>,
}

/// One earlier segment [`Recorder::resume`] looked at: what recovery kept (`Ok(None)`: it was
/// finished, left alone), or why it failed.
pub type RecoveredSegment = (PathBuf, Result<Option<recover::Recovery>, RecorderError>);

impl Recorder {
    /// Create `path` (truncating it) as the first segment of a new run, removing the later
    /// segments of an earlier run there (`trace.1.mcap`, ...: they would be read as this run's),
    /// write the header, schemas, channels and the static `setup`, and start the writer thread.
    pub fn create(
        path: &Path,
        cfg: &RecorderConfig,
        setup: RecorderSetup,
    ) -> Result<Recorder, RecorderError> {
        recover::remove_later_segments(path).map_err(|source| RecorderError::Create {
            path: path.to_path_buf(),
            source,
        })?;
        Self::start(path, cfg, setup)
    }

    /// Continue the run whose first segment is `first`, as a restarted recorder does: nothing an
    /// earlier instance wrote is truncated. With no segment yet this is [`Recorder::create`];
    /// otherwise recording starts at once in the next segment (`trace.k.mcap`, see [`recover`]'s
    /// module docs), and a background thread at nice 19 recovers every earlier segment that is
    /// torn (no footer: its recorder was killed) in place, so the restart loses no more than the
    /// torn chunk while the recovery runs. [`Recorder::path`] is the segment being written;
    /// [`Recorder::wait_recovery`] waits for the recovery, [`Recorder::finish`] too.
    pub fn resume(
        first: &Path,
        cfg: &RecorderConfig,
        setup: RecorderSetup,
    ) -> Result<Recorder, RecorderError> {
        let existing = recover::segments(first);
        if existing.is_empty() {
            return Self::start(first, cfg, setup);
        }
        let mut rec = Self::start(&recover::segment_path(first, existing.len()), cfg, setup)?;
        let thread = std::thread::Builder::new()
            .name("recorder-recover".into())
            .spawn(move || {
                // Best effort: recovery is bulk work beside the nodes.
                let _ = crate::os::set_nice(19);
                existing
                    .into_iter()
                    .map(|seg| {
                        let r = recover::recover_in_place(&seg);
                        match &r {
                            Ok(Some(r)) => eprintln!("recorder: recovered {} ({r})", seg.display()),
                            Ok(None) => {}
                            Err(e) => eprintln!("recorder: cannot recover {}: {e}", seg.display()),
                        }
                        (seg, r)
                    })
                    .collect()
            })
            .map_err(RecorderError::Spawn)?;
        rec.recovery = Some(thread);
        Ok(rec)
    }

    /// Wait until [`Recorder::resume`]'s recovery of the earlier segments is done, and return
    /// what it did per segment (empty after [`Recorder::create`]).
    pub fn wait_recovery(&mut self) -> &[RecoveredSegment] {
        if let Some(t) = self.recovery.take() {
            match t.join() {
                Ok(r) => self.recovered = r,
                Err(_) => {
                    self.recovered = vec![(
                        self.path.clone(),
                        Err(RecorderError::Panicked {
                            path: self.path.clone(),
                        }),
                    )]
                }
            }
        }
        &self.recovered
    }

    fn start(
        path: &Path,
        cfg: &RecorderConfig,
        setup: RecorderSetup,
    ) -> Result<Recorder, RecorderError> {
        let (tx, rx): (Sender<Msg>, Receiver<Msg>) = crossbeam::channel::bounded(cfg.queue_len);
        let (wake, wake_rx) = crossbeam::channel::bounded(1);
        let conv = &setup.converter;
        let topics = Kind::ALL.map(|k| k.own_topic().unwrap_or_else(|| conv.topic(k)));
        let mut defs = conv.channels();
        defs.extend(schemas::own_channels());
        let shared = Arc::new(Shared::new(
            topics,
            setup.overflow,
            cfg.depth_queue_len,
            cfg.pool_len,
        ));
        let w = writer::WriterState::open(path, cfg, setup, &defs)?;
        let live_port = w.live_port();
        let sh = Arc::clone(&shared);
        let thread = std::thread::Builder::new()
            .name("recorder".into())
            .spawn(move || {
                // Tells waiting producers when the thread ends, also by a panic.
                let _stopped = StoppedOnDrop(Arc::clone(&sh));
                w.run(rx, wake_rx, sh)
            })
            .map_err(RecorderError::Spawn)?;
        Ok(Recorder {
            handle: RecorderHandle { tx, wake, shared },
            thread: Some(thread),
            path: path.to_path_buf(),
            live_port,
            recovery: None,
            recovered: Vec::new(),
        })
    }

    /// The port the live view serves on, if [`RecorderSetup::live_port`] asked for one.
    pub fn live_port(&self) -> Option<u16> {
        self.live_port
    }

    /// A producer handle (clone it freely).
    pub fn handle(&self) -> RecorderHandle {
        self.handle.clone()
    }

    /// The file being written.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Write everything queued, the final stats and the summary, and close the file. Messages
    /// recorded through handles afterwards are counted as dropped.
    pub fn finish(mut self) -> Result<RecorderSummary, RecorderError> {
        self.finish_inner()
    }

    fn finish_inner(&mut self) -> Result<RecorderSummary, RecorderError> {
        // The earlier segments are recovered before the run ends (errors were printed).
        self.wait_recovery();
        let Some(thread) = self.thread.take() else {
            return Ok(RecorderSummary::default());
        };
        // Blocking send: waits for room, fails only if the thread already ended (I/O error).
        let _ = self.handle.tx.send(Msg::Finish);
        match thread.join() {
            Ok(r) => r,
            Err(_) => Err(RecorderError::Panicked {
                path: self.path.clone(),
            }),
        }
    }
}

/// Sets [`Shared::writer_stopped`] when the writer thread's body ends (returns or unwinds).
struct StoppedOnDrop(Arc<Shared>);

impl Drop for StoppedOnDrop {
    fn drop(&mut self) {
        self.0.writer_stopped.store(true, Ordering::Release);
    }
}

impl Drop for Recorder {
    fn drop(&mut self) {
        if let Err(e) = self.finish_inner() {
            eprintln!("recorder: {e}");
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, Deserialize)]
    struct Root {
        recorder: RecorderConfig,
    }

    fn parse(f: &Path, text: &str) -> Result<Root, ConfigError> {
        crate::config::RUNTIME_DEFAULTS.parse(f, text)
    }

    /// Validate `r` as for a trace whose channels are those the shipped `[recorder.view.max_hz]`
    /// names (an app's) and the runtime's own.
    fn validate(r: &RecorderConfig, c: &Checker) -> Result<(), ConfigError> {
        let shipped = RecorderConfig::default().view.max_hz;
        let mut topics: Vec<&str> = shipped.keys().map(String::as_str).collect();
        topics.extend(schemas::own_channels().iter().map(|c| c.topic));
        r.validate(c, &topics)
    }

    #[test]
    fn shipped_section_validates() {
        validate(
            &RecorderConfig::default(),
            &Checker::new("config/runtime.toml"),
        )
        .unwrap();
    }

    #[test]
    fn bad_values_are_named() {
        let f = Path::new("bad.toml");
        let c = Checker::new("bad.toml");
        let r = parse(f, "[recorder.view]\ndepth_decimation = 0\n").unwrap();
        let e = validate(&r.recorder, &c).unwrap_err();
        assert_eq!(
            e.to_string(),
            "bad.toml: recorder.view.depth_decimation = 0: must be in [1, 16]"
        );
        let r = parse(f, "[recorder.view.max_hz]\n\"/camera/dept\" = 2.0\n").unwrap();
        let e = validate(&r.recorder, &c).unwrap_err();
        assert_eq!(e.key(), "recorder.view.max_hz.\"/camera/dept\"", "{e}");
        assert!(e.to_string().contains("no such topic"), "{e}");
        let r = parse(f, "[recorder.view.max_hz]\n\"/tf\" = -1.0\n").unwrap();
        assert!(validate(&r.recorder, &c).is_err());
        let e = parse(f, "[recorder]\nprofile = \"fast\"\n").unwrap_err();
        assert_eq!(e.key(), "recorder.profile", "{e}");
        let r = parse(f, "[recorder]\nflush_interval_s = 0.0\n").unwrap();
        assert_eq!(
            validate(&r.recorder, &c).unwrap_err().key(),
            "recorder.flush_interval_s"
        );
        let e = parse(f, "[recorder]\ncompression = \"gzip\"\n").unwrap_err();
        assert_eq!(e.key(), "recorder.compression", "{e}");
        let e = parse(f, "[recorder]\nqueue = 3\n").unwrap_err();
        assert!(e.to_string().contains("unknown field `queue`"), "{e}");
    }

    #[test]
    fn depth_ring_keeps_the_newest_frames_and_counts_the_replaced_ones() {
        // No writer thread: the handle alone, so the ring's behaviour is exact.
        let (tx, _rx) = crossbeam::channel::bounded(4);
        let (wake, _wake_rx) = crossbeam::channel::bounded(1);
        // An app's topic per converted kind (they come first in `Kind::ALL`).
        const APP: [&str; 9] = [
            "/d", "/det", "/ng", "/s", "/ts", "/m", "/dec", "/nav", "/neck",
        ];
        let topics = Kind::ALL.map(|k| k.own_topic().unwrap_or_else(|| APP[k as usize]));
        let shared = Arc::new(Shared::new(topics, Overflow::Drop, 2, 1));
        let h = RecorderHandle {
            tx,
            wake,
            shared: Arc::clone(&shared),
        };
        let mut f = boxed_zeroed::<DepthFrame>();
        f.width = 2;
        f.height = 2;
        for seq in 1..=6 {
            f.header.seq = seq;
            h.record_depth(&f);
        }
        let kept: Vec<u64> = std::iter::from_fn(|| shared.depth_ready.pop())
            .map(|b| b.header.seq)
            .collect();
        assert_eq!(kept, [5, 6]);
        assert_eq!(h.dropped(Kind::Depth), 4);
        assert_eq!(h.drops().offered["/d"], 6);
        // Pooled kinds: one box in the pool; the second map finds none and is dropped, counted.
        let m = boxed_zeroed::<ObjectMap>();
        h.record_map(&m);
        h.record_map(&m);
        assert_eq!(h.dropped(Kind::Map), 1);
        assert_eq!(h.drops().offered["/m"], 2);
        assert_eq!(h.drops().offered[schemas::topic::LOG], 0);
    }
}
