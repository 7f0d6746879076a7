//! The writer thread: owns the `mcap::Writer` (in the [`Sink`]), has the app's [`Converter`]
//! convert its inputs and converts the runtime's own, encodes, applies the profile's rate limits,
//! bounds chunk age, writes stats, feeds the live view.

use super::convert::{self, Converter};
use super::live::LiveView;
use super::messages::{RecorderStats, TopicCounts};
use super::schemas::{ChannelDef, SESSION_METADATA, STATS_METADATA, topic};
use super::{
    Compression, DropCounts, Msg, RecorderConfig, RecorderError, RecorderSetup, RecorderSummary,
    Shared, WriterHook,
};
use crossbeam::channel::{Receiver, TryRecvError};
use foxglove::Encode;
use mcap::records::{MessageHeader, Metadata};
use shm_types::DepthFrame;
use std::collections::{BTreeMap, HashMap};
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// One channel of the file.
#[derive(Debug)]
struct Chan {
    topic: &'static str,
    id: u16,
    seq: u32,
    written: u64,
    throttled: u64,
    /// Least simulated time between two messages, ns (`None`: no limit; `u64::MAX`: none kept).
    min_period_ns: Option<u64>,
    last_ns: Option<u64>,
}

impl Chan {
    /// Whether a message at `t` passes the rate limit (counted if not).
    fn admit(&mut self, t: u64) -> bool {
        let Some(p) = self.min_period_ns else {
            return true;
        };
        let ok = p != u64::MAX
            && self
                .last_ns
                .is_none_or(|l| t >= l.saturating_add(p) || t < l);
        if ok {
            self.last_ns = Some(t);
        } else {
            self.throttled += 1;
        }
        ok
    }
}

/// Where messages go: the file's channels, the MCAP writer and the live view. A [`Converter`]
/// writes through it ([`Sink::emit`]) on the writer thread.
pub struct Sink {
    path: PathBuf,
    mcap: mcap::Writer<BufWriter<File>>,
    chans: Vec<Chan>,
    index: HashMap<&'static str, usize>,
    out: Vec<u8>,
    live: Option<LiveView>,
    /// Messages the live view gets again every stats interval (written once: truth, grid).
    live_static: Vec<(usize, u64, Vec<u8>)>,
    chunk_open_since: Option<Instant>,
    last_log_ns: u64,
}

impl std::fmt::Debug for Sink {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Sink")
            .field("path", &self.path)
            .finish_non_exhaustive()
    }
}

/// The writer thread's state.
#[derive(Debug)]
pub(super) struct WriterState {
    sink: Sink,
    conv: Box<dyn Converter>,
    cfg: RecorderConfig,
    last_stats: Instant,
    /// For tests: called before each message is written.
    hook: Option<WriterHook>,
}

/// CPU time of the calling thread, ns, from `/proc/thread-self/schedstat` (0 if unavailable).
pub(crate) fn thread_cpu_ns() -> u64 {
    crate::os::ThreadSchedStat::open_current()
        .and_then(|s| s.read())
        .map_or(0, |r| r.cpu_ns)
}

impl Sink {
    fn err(&self, source: mcap::McapError) -> RecorderError {
        RecorderError::Mcap {
            path: self.path.clone(),
            source,
        }
    }

    /// If `topic`'s rate limit admits a message at `log_ns` (simulated/robot time; `publish_ns`
    /// is the monotonic stamp), build it with `f`, encode it, write it and publish it live. A
    /// topic that is not a channel of the file is ignored. `Err` is an I/O error of the file.
    pub fn emit<T: Encode>(
        &mut self,
        topic: &'static str,
        log_ns: u64,
        publish_ns: u64,
        f: impl FnOnce() -> T,
    ) -> Result<(), RecorderError> {
        let Some(&i) = self.index.get(topic) else {
            return Ok(());
        };
        if !self.chans[i].admit(log_ns) {
            return Ok(());
        }
        let msg = f();
        self.out.clear();
        // Encoding into a growable Vec cannot run out of room.
        let _ = msg.encode(&mut self.out);
        let c = &mut self.chans[i];
        c.seq = c.seq.wrapping_add(1);
        c.written += 1;
        let header = MessageHeader {
            channel_id: c.id,
            sequence: c.seq,
            log_time: log_ns,
            publish_time: publish_ns,
        };
        self.last_log_ns = self.last_log_ns.max(log_ns);
        if let Err(e) = self.mcap.write_to_known_channel(&header, &self.out) {
            return Err(self.err(e));
        }
        self.chunk_open_since.get_or_insert_with(Instant::now);
        if let Some(l) = &self.live {
            l.publish(i, log_ns, &self.out);
        }
        Ok(())
    }

    /// Publish the message just emitted on `topic` live again every stats interval (for what is
    /// written once or rarely, such as a scene's ground truth or a map of the building), so a
    /// viewer that connects later sees it too.
    pub fn keep_for_live(&mut self, topic: &'static str, log_ns: u64) {
        if self.live.is_some()
            && let Some(&i) = self.index.get(topic)
        {
            self.live_static.retain(|(j, _, _)| *j != i);
            self.live_static.push((i, log_ns, self.out.clone()));
        }
    }

    fn written(&self) -> BTreeMap<&'static str, u64> {
        self.chans.iter().map(|c| (c.topic, c.written)).collect()
    }
}

impl WriterState {
    /// Open `path` and write the header, schemas, channels (`defs`: the converter's, then the
    /// runtime's own), the session metadata and what the converter writes at start.
    pub(super) fn open(
        path: &Path,
        cfg: &RecorderConfig,
        setup: RecorderSetup,
        defs: &[ChannelDef],
    ) -> Result<Self, RecorderError> {
        let file = File::create(path).map_err(|source| RecorderError::Create {
            path: path.to_path_buf(),
            source,
        })?;
        let mcap_err = |source| RecorderError::Mcap {
            path: path.to_path_buf(),
            source,
        };
        let mut opts = mcap::WriteOptions::new()
            .profile("")
            .library(format!("vpsom-rt {}", env!("CARGO_PKG_VERSION")))
            .chunk_size(Some(cfg.chunk_size_kb * 1024))
            .compression(match cfg.compression {
                Compression::Zstd => Some(mcap::Compression::Zstd),
                Compression::Lz4 => Some(mcap::Compression::Lz4),
                Compression::None => None,
            })
            .compression_level(cfg.compression_level)
            // The writer thread compresses alone: no zstd worker threads competing with nodes.
            .compression_threads(0);
        if cfg.compression == Compression::None {
            opts = opts.compression_level(0);
        }
        let mut mcap = opts
            .create(BufWriter::with_capacity(1 << 20, file))
            .map_err(mcap_err)?;
        let mut chans = Vec::new();
        let mut index = HashMap::new();
        let mut schema_ids: HashMap<String, u16> = HashMap::new();
        for d in defs {
            let sid = match schema_ids.get(&d.schema.name) {
                Some(&sid) => sid,
                None => {
                    let sid = mcap
                        .add_schema(&d.schema.name, &d.schema.encoding, &d.schema.data)
                        .map_err(mcap_err)?;
                    schema_ids.insert(d.schema.name.clone(), sid);
                    sid
                }
            };
            let id = mcap
                .add_channel(sid, d.topic, &d.encoding, &BTreeMap::new())
                .map_err(mcap_err)?;
            index.insert(d.topic, chans.len());
            chans.push(Chan {
                topic: d.topic,
                id,
                seq: 0,
                written: 0,
                throttled: 0,
                min_period_ns: cfg.max_hz(d.topic).map(|hz| {
                    if hz > 0.0 {
                        (1e9 / hz).round() as u64
                    } else {
                        u64::MAX
                    }
                }),
                last_ns: None,
            });
        }
        let live = match setup.live_port {
            Some(port) => Some(LiveView::start(port, defs)?),
            None => None,
        };
        let mut metadata = BTreeMap::from([
            ("scene".to_string(), setup.scene.clone()),
            ("profile".to_string(), cfg.profile.name().to_string()),
            (
                "depth_decimation".to_string(),
                cfg.depth_decimation().to_string(),
            ),
            ("host".to_string(), setup.host.clone()),
            ("overflow".to_string(), setup.overflow.name().to_string()),
        ]);
        metadata.extend(setup.converter.session_metadata());
        let session = Metadata {
            name: SESSION_METADATA.into(),
            metadata,
        };
        mcap.write_metadata(&session).map_err(mcap_err)?;
        let mut w = WriterState {
            sink: Sink {
                path: path.to_path_buf(),
                mcap,
                chans,
                index,
                out: Vec::with_capacity(1 << 16),
                live,
                live_static: Vec::new(),
                chunk_open_since: None,
                last_log_ns: 0,
            },
            conv: setup.converter,
            cfg: cfg.clone(),
            last_stats: Instant::now(),
            hook: setup.writer_hook,
        };
        w.conv.start(&mut w.sink)?;
        Ok(w)
    }

    /// The live view's port, if one is served.
    pub(super) fn live_port(&self) -> Option<u16> {
        self.sink.live.as_ref().map(LiveView::port)
    }

    /// Call the test hook, if any, before a message is written.
    fn before_write(&self) {
        if let Some(h) = &self.hook {
            (h.0)();
        }
    }

    fn handle(&mut self, m: Msg, shared: &Shared) -> Result<(), RecorderError> {
        if !matches!(m, Msg::Finish) {
            self.before_write();
        }
        let (conv, sink) = (&mut self.conv, &mut self.sink);
        match m {
            Msg::Finish => {}
            Msg::State(s) => conv.state(&s, sink)?,
            Msg::TrueState(s) => conv.true_state(&s, sink)?,
            Msg::Detections(b) => {
                let r = conv.detections(&b, sink);
                shared.detections_pool.give(b);
                r?;
            }
            Msg::NavGrid(g) => conv.nav_grid(&g, sink)?,
            Msg::Map(b) => {
                let r = conv.map(&b, sink);
                shared.map_pool.give(b);
                r?;
            }
            Msg::Decision(b) => {
                let r = conv.decision(&b, sink);
                shared.decision_pool.give(b);
                r?;
            }
            Msg::NavGoal(g) => conv.nav_goal(&g, sink)?,
            Msg::NeckGoal(g) => conv.neck_goal(&g, sink)?,
            Msg::Deadline(e) => {
                let (t, p) = (e.header.sim_time_ns, e.header.stamp_ns);
                sink.emit(topic::DEADLINE, t, p, || convert::deadline(&e))?;
            }
            Msg::Health(h) => {
                let (t, p) = (h.header.sim_time_ns, h.header.stamp_ns);
                sink.emit(topic::HEALTH, t, p, || convert::health(&h))?;
            }
            Msg::Latency(s) => {
                sink.emit(topic::LATENCY, s.time_ns, s.time_ns, || {
                    convert::latency(&s)
                })?;
            }
            Msg::Log {
                time_ns,
                level,
                name,
                text,
            } => {
                sink.emit(topic::LOG, time_ns, time_ns, || {
                    convert::log(time_ns, level, &name, &text)
                })?;
            }
            Msg::Metrics { time_ns, value } => {
                sink.emit(topic::METRICS, time_ns, time_ns, || {
                    convert::metrics(&value)
                })?;
            }
        }
        Ok(())
    }

    fn depth(&mut self, f: &DepthFrame) -> Result<(), RecorderError> {
        self.before_write();
        self.conv.depth(f, &mut self.sink)
    }

    fn throttled(&self) -> BTreeMap<String, u64> {
        self.sink
            .chans
            .iter()
            .filter(|c| c.min_period_ns.is_some())
            .map(|c| (c.topic.to_string(), c.throttled))
            .collect()
    }

    fn stats(&mut self, drops: &DropCounts, last: bool) -> Result<(), RecorderError> {
        let topics = self
            .sink
            .chans
            .iter()
            .map(|c| TopicCounts {
                topic: c.topic.to_string(),
                offered: drops.offered.get(c.topic).copied().unwrap_or(0),
                dropped: drops.dropped.get(c.topic).copied().unwrap_or(0),
                throttled: c.throttled,
                // The stats message being written counts itself.
                written: c.written + u64::from(c.topic == topic::STATS),
            })
            .collect();
        let msg = RecorderStats {
            profile: self.cfg.profile.name().to_string(),
            topics,
            dropped_total: drops.total_dropped(),
            throttled_total: self.sink.chans.iter().map(|c| c.throttled).sum(),
            last,
        };
        let t = self.sink.last_log_ns;
        self.sink.emit(topic::STATS, t, t, || msg)
    }

    /// Flush a chunk that is older than the interval; write stats when due.
    fn tick(&mut self, shared: &Shared) -> Result<(), RecorderError> {
        let now = Instant::now();
        if self.last_stats.elapsed().as_secs_f64() >= self.cfg.stats_interval_s {
            self.last_stats = now;
            self.stats(&shared.drop_counts(), false)?;
            if let Some(l) = &self.sink.live {
                for (i, t, data) in &self.sink.live_static {
                    l.publish(*i, *t, data);
                }
            }
        }
        if let Some(since) = self.sink.chunk_open_since
            && now.duration_since(since).as_secs_f64() >= self.cfg.flush_interval_s
        {
            if let Err(e) = self.sink.mcap.flush() {
                return Err(self.sink.err(e));
            }
            self.sink.chunk_open_since = None;
        }
        Ok(())
    }

    /// Time until the next tick is due.
    fn next_tick(&self) -> Duration {
        let stats = self.cfg.stats_interval_s - self.last_stats.elapsed().as_secs_f64();
        let flush = self.sink.chunk_open_since.map_or(f64::INFINITY, |s| {
            self.cfg.flush_interval_s - s.elapsed().as_secs_f64()
        });
        Duration::from_secs_f64(stats.min(flush).clamp(0.001, 1.0))
    }
    /// The thread body: serve the channel (all of it before each depth frame), tick, finish.
    pub(super) fn run(
        mut self,
        rx: Receiver<Msg>,
        wake: Receiver<()>,
        shared: Arc<Shared>,
    ) -> Result<RecorderSummary, RecorderError> {
        let drain_max = self.cfg.queue_len;
        'outer: loop {
            let first = if shared.depth_ready.is_empty() {
                crossbeam::channel::select! {
                    recv(rx) -> m => match m {
                        Ok(m) => Some(m),
                        Err(_) => break,
                    },
                    recv(wake) -> _ => None,
                    default(self.next_tick()) => None,
                }
            } else {
                let _ = wake.try_recv();
                None
            };
            if let Some(m) = first {
                if matches!(m, Msg::Finish) {
                    break;
                }
                self.handle(m, &shared)?;
            }
            for _ in 0..drain_max {
                match rx.try_recv() {
                    Ok(Msg::Finish) => break 'outer,
                    Ok(m) => self.handle(m, &shared)?,
                    Err(TryRecvError::Empty) => break,
                    Err(TryRecvError::Disconnected) => break 'outer,
                }
            }
            if let Some(f) = shared.depth_ready.pop() {
                let r = self.depth(&f);
                shared.depth_pool.give(f);
                r?;
            }
            self.tick(&shared)?;
        }
        // Finish: whatever is queued, then final stats, the metadata record and the summary.
        while let Ok(m) = rx.try_recv() {
            self.handle(m, &shared)?;
        }
        while let Some(f) = shared.depth_ready.pop() {
            let r = self.depth(&f);
            shared.depth_pool.give(f);
            r?;
        }
        let mut drops = shared.drop_counts();
        self.stats(&drops, true)?;
        drops.throttled = self.throttled();
        let mut meta = BTreeMap::new();
        for (t, n) in &drops.offered {
            meta.insert(format!("offered:{t}"), n.to_string());
        }
        for (t, n) in &drops.dropped {
            meta.insert(format!("dropped:{t}"), n.to_string());
        }
        for (t, n) in &drops.throttled {
            meta.insert(format!("throttled:{t}"), n.to_string());
        }
        for (t, n) in self.sink.written() {
            meta.insert(format!("written:{t}"), n.to_string());
        }
        meta.insert("dropped_total".into(), drops.total_dropped().to_string());
        meta.insert(
            "throttled_total".into(),
            drops.total_throttled().to_string(),
        );
        meta.insert("profile".into(), self.cfg.profile.name().into());
        let md = Metadata {
            name: STATS_METADATA.into(),
            metadata: meta,
        };
        if let Err(e) = self.sink.mcap.write_metadata(&md) {
            return Err(self.sink.err(e));
        }
        if let Err(e) = self.sink.mcap.finish() {
            return Err(self.sink.err(e));
        }
        let written = self
            .sink
            .written()
            .into_iter()
            .map(|(t, n)| (t.to_string(), n))
            .collect();
        let cpu = thread_cpu_ns();
        let path = self.sink.path.clone();
        // Stop serving before the file is closed: viewers see the run end with the file.
        drop(self.sink.live.take());
        let mut file = self.sink.mcap.into_inner();
        file.flush()
            .and_then(|()| file.get_ref().sync_all())
            .map_err(|source| RecorderError::Mcap {
                path,
                source: source.into(),
            })?;
        Ok(RecorderSummary {
            written,
            drops,
            writer_cpu_ns: cpu,
        })
    }
}
