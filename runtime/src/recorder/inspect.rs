//! Reading traces back: [`info`] (topics, counts, time range, drops) and [`export_csv`] for any
//! channel (decoded through the schema in the file, [`super::decode`]). Both stream the file with constant memory and accept a file cut short by a
//! crash (they read up to the last complete record and report the truncation). Given the first
//! segment of a run (`trace.mcap`) or its directory, both read every segment of the run
//! (`trace.1.mcap`, ...; see [`super::recover`]) as one trace.

use super::decode::MessageType;
use super::messages::RecorderStats;
use super::schemas::{STATS_METADATA, topic};
use super::{DropCounts, RecorderError};

/// Schema name `foxglove::Encode` derives for [`RecorderStats`].
const RECORDER_STATS_SCHEMA: &str = "recorderstats.RecorderStats";
use mcap::records::Record;
use mcap::sans_io::linear_reader::{LinearReadEvent, LinearReader, LinearReaderOptions};
use std::collections::{BTreeMap, HashMap};
use std::fmt;
use std::io::{Read, Write};
use std::path::{Path, PathBuf};

/// One record of interest met while scanning a file.
#[derive(Debug)]
pub enum Item<'a> {
    /// A schema.
    Schema {
        /// Schema id.
        id: u16,
        /// Schema name.
        name: &'a str,
        /// Schema encoding (`protobuf` for all of ours).
        encoding: &'a str,
        /// Schema text.
        data: &'a [u8],
    },
    /// A channel definition.
    Channel {
        /// Channel id.
        id: u16,
        /// Topic.
        topic: &'a str,
        /// Message encoding (`protobuf` for all of ours).
        encoding: &'a str,
        /// Schema id (0 = none).
        schema_id: u16,
        /// Schema name (empty if none).
        schema: &'a str,
    },
    /// A message.
    Message {
        /// Channel id.
        channel: u16,
        /// Log time, ns.
        log_time: u64,
        /// Payload.
        data: &'a [u8],
    },
    /// A metadata record.
    Metadata {
        /// Record name.
        name: &'a str,
        /// Key-value pairs.
        values: &'a BTreeMap<String, String>,
    },
}

/// How a scan ended.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ScanEnd {
    /// The file ended with a footer and end magic (it was finished).
    pub complete: bool,
    /// Why reading stopped early (a crash leaves a partial chunk), if it did.
    pub truncation: Option<String>,
}

fn read_err(path: &Path, message: impl Into<String>) -> RecorderError {
    RecorderError::Read {
        path: path.to_path_buf(),
        message: message.into(),
    }
}

/// Stream every record of `path` through `f`, validating chunk CRCs. A file cut short (crash)
/// yields everything up to its last complete chunk and `ScanEnd { complete: false, .. }`; a file
/// that is not MCAP at all is an error.
pub fn scan(path: &Path, mut f: impl FnMut(Item<'_>)) -> Result<ScanEnd, RecorderError> {
    let mut file =
        std::fs::File::open(path).map_err(|e| read_err(path, format!("cannot open: {e}")))?;
    let mut reader = LinearReader::new_with_options(
        LinearReaderOptions::default()
            .with_skip_end_magic(false)
            .with_validate_chunk_crcs(true)
            .with_prevalidate_chunk_crcs(true),
    );
    let mut schemas: HashMap<u16, String> = HashMap::new();
    let mut records = 0u64;
    let mut complete = false;
    while let Some(event) = reader.next_event() {
        let event = match event {
            Ok(e) => e,
            Err(e) if records == 0 => return Err(read_err(path, format!("not an MCAP file: {e}"))),
            Err(e) => {
                return Ok(ScanEnd {
                    complete: false,
                    truncation: Some(format!("stopped after {records} records: {e}")),
                });
            }
        };
        match event {
            LinearReadEvent::ReadRequest(need) => {
                let n = file
                    .read(reader.insert(need))
                    .map_err(|e| read_err(path, format!("read failed: {e}")))?;
                reader.notify_read(n);
            }
            LinearReadEvent::Record { opcode, data } => {
                records += 1;
                let rec = match mcap::parse_record(opcode, data) {
                    Ok(r) => r,
                    Err(e) => {
                        return Ok(ScanEnd {
                            complete: false,
                            truncation: Some(format!("bad record after {records} records: {e}")),
                        });
                    }
                };
                match rec {
                    Record::Schema { header, data } => {
                        f(Item::Schema {
                            id: header.id,
                            name: &header.name,
                            encoding: &header.encoding,
                            data: &data,
                        });
                        schemas.insert(header.id, header.name);
                    }
                    Record::Channel(c) => f(Item::Channel {
                        id: c.id,
                        topic: &c.topic,
                        encoding: &c.message_encoding,
                        schema_id: c.schema_id,
                        schema: schemas.get(&c.schema_id).map_or("", String::as_str),
                    }),
                    Record::Message { header, data } => f(Item::Message {
                        channel: header.channel_id,
                        log_time: header.log_time,
                        data: &data,
                    }),
                    Record::Metadata(m) => f(Item::Metadata {
                        name: &m.name,
                        values: &m.metadata,
                    }),
                    Record::Footer(_) => complete = true,
                    _ => {}
                }
            }
        }
    }
    Ok(ScanEnd {
        complete,
        truncation: None,
    })
}

/// One topic of a trace.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TopicInfo {
    /// Topic name.
    pub topic: String,
    /// Schema name.
    pub schema: String,
    /// Message encoding.
    pub encoding: String,
    /// Messages read.
    pub messages: u64,
    /// Log time of the earliest message, ns.
    pub first_ns: Option<u64>,
    /// Log time of the latest message, ns.
    pub last_ns: Option<u64>,
}

/// Summary of a trace file.
#[derive(Debug, Clone, PartialEq)]
pub struct TraceInfo {
    /// The file.
    pub path: PathBuf,
    /// Scan outcome (finished file or crash-truncated).
    pub end: ScanEnd,
    /// Topics in channel order.
    pub topics: Vec<TopicInfo>,
    /// Earliest log time, ns.
    pub start_ns: Option<u64>,
    /// Latest log time, ns.
    pub end_ns: Option<u64>,
    /// Drop counts: from the final `recorder_stats` metadata if present, else the newest
    /// `/recorder/stats` message.
    pub drops: Option<DropCounts>,
    /// Metadata records by name (a later segment's record replaces an earlier one's).
    pub metadata: BTreeMap<String, BTreeMap<String, String>>,
    /// The segments read, in order, with how each scan ended (one for a single file).
    pub segments: Vec<(PathBuf, ScanEnd)>,
}

impl TraceInfo {
    /// Messages on `topic` (0 if absent).
    pub fn count(&self, topic: &str) -> u64 {
        self.topics
            .iter()
            .find(|t| t.topic == topic)
            .map_or(0, |t| t.messages)
    }
}

fn drops_from_metadata(m: &BTreeMap<String, String>) -> DropCounts {
    let mut d = DropCounts::default();
    for (k, v) in m {
        let n = v.parse().unwrap_or(0);
        if let Some(t) = k.strip_prefix("offered:") {
            d.offered.insert(t.to_string(), n);
        } else if let Some(t) = k.strip_prefix("dropped:") {
            d.dropped.insert(t.to_string(), n);
        } else if let Some(t) = k.strip_prefix("throttled:") {
            d.throttled.insert(t.to_string(), n);
        }
    }
    d
}

/// The files to read for `path`: every segment of the run when it names a run's first segment
/// or directory, else the file itself.
fn files_of(path: &Path) -> Vec<PathBuf> {
    let segs = super::recover::segments(path);
    if segs.is_empty() {
        vec![super::recover::run_first_segment(path)]
    } else {
        segs
    }
}

/// Topics, message counts, time range and drop counts of a trace (finished or crash-truncated),
/// all segments of a run merged: counts and drops summed, time ranges joined.
pub fn info(path: &Path) -> Result<TraceInfo, RecorderError> {
    let mut parts = files_of(path).into_iter().map(|f| info_one(&f));
    let mut all = parts.next().expect("at least one file")?;
    for part in parts {
        let p = part?;
        for t in p.topics {
            match all.topics.iter_mut().find(|a| a.topic == t.topic) {
                Some(a) => {
                    a.messages += t.messages;
                    a.first_ns = a.first_ns.into_iter().chain(t.first_ns).min();
                    a.last_ns = a.last_ns.into_iter().chain(t.last_ns).max();
                }
                None => all.topics.push(t),
            }
        }
        all.start_ns = all.start_ns.into_iter().chain(p.start_ns).min();
        all.end_ns = all.end_ns.into_iter().chain(p.end_ns).max();
        // Each recorder instance counts its own drops from zero: the run's are the sum.
        all.drops = match (all.drops.take(), p.drops) {
            (Some(mut a), Some(b)) => {
                for (t, n) in b.offered {
                    *a.offered.entry(t).or_insert(0) += n;
                }
                for (t, n) in b.dropped {
                    *a.dropped.entry(t).or_insert(0) += n;
                }
                for (t, n) in b.throttled {
                    *a.throttled.entry(t).or_insert(0) += n;
                }
                Some(a)
            }
            (a, b) => a.or(b),
        };
        all.metadata.extend(p.metadata);
        all.segments.extend(p.segments);
    }
    if all.segments.len() > 1 {
        let torn: Vec<String> = all
            .segments
            .iter()
            .filter_map(|(p, e)| {
                e.truncation
                    .as_ref()
                    .map(|t| format!("{}: {t}", p.display()))
            })
            .collect();
        all.end = ScanEnd {
            complete: all.segments.iter().all(|(_, e)| e.complete),
            truncation: (!torn.is_empty()).then(|| torn.join("; ")),
        };
    }
    Ok(all)
}

fn info_one(path: &Path) -> Result<TraceInfo, RecorderError> {
    let mut topics: Vec<TopicInfo> = Vec::new();
    let mut by_id: HashMap<u16, usize> = HashMap::new();
    let mut metadata = BTreeMap::new();
    let mut last_stats: Option<Vec<u8>> = None;
    let mut stats_type: Option<(String, String, Vec<u8>)> = None;
    let end = scan(path, |item| match item {
        Item::Channel {
            id,
            topic,
            encoding,
            schema,
            ..
        } => {
            let i = match topics.iter().position(|t| t.topic == topic) {
                Some(i) => i,
                None => {
                    topics.push(TopicInfo {
                        topic: topic.to_string(),
                        schema: schema.to_string(),
                        encoding: encoding.to_string(),
                        messages: 0,
                        first_ns: None,
                        last_ns: None,
                    });
                    topics.len() - 1
                }
            };
            by_id.insert(id, i);
        }
        Item::Message {
            channel,
            log_time,
            data,
        } => {
            if let Some(&i) = by_id.get(&channel) {
                let t = &mut topics[i];
                t.messages += 1;
                t.first_ns = Some(t.first_ns.map_or(log_time, |f| f.min(log_time)));
                t.last_ns = Some(t.last_ns.map_or(log_time, |l| l.max(log_time)));
                if t.topic == topic::STATS {
                    last_stats = Some(data.to_vec());
                }
            }
        }
        Item::Metadata { name, values } => {
            metadata.insert(name.to_string(), values.clone());
        }
        Item::Schema {
            name,
            encoding,
            data,
            ..
        } => {
            if name == RECORDER_STATS_SCHEMA {
                stats_type = Some((name.to_string(), encoding.to_string(), data.to_vec()));
            }
        }
    })?;
    let drops = match metadata.get(STATS_METADATA) {
        Some(m) => Some(drops_from_metadata(m)),
        None => last_stats.and_then(|d| {
            let (name, enc, data) = stats_type?;
            let t = MessageType::from_schema(&name, &enc, &data).ok()?;
            let s: RecorderStats = t.to_value(&d).ok()?;
            let mut c = DropCounts::default();
            for x in s.topics {
                if x.offered > 0 || x.dropped > 0 {
                    c.offered.insert(x.topic.clone(), x.offered);
                    c.dropped.insert(x.topic.clone(), x.dropped);
                }
                if x.throttled > 0 {
                    c.throttled.insert(x.topic, x.throttled);
                }
            }
            Some(c)
        }),
    };
    let start_ns = topics.iter().filter_map(|t| t.first_ns).min();
    let end_ns = topics.iter().filter_map(|t| t.last_ns).max();
    Ok(TraceInfo {
        path: path.to_path_buf(),
        end: end.clone(),
        topics,
        start_ns,
        end_ns,
        drops,
        metadata,
        segments: vec![(path.to_path_buf(), end)],
    })
}

fn secs(ns: Option<u64>) -> String {
    ns.map_or("-".into(), |n| format!("{:.3}", n as f64 * 1e-9))
}

impl fmt::Display for TraceInfo {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "file:     {}", self.path.display())?;
        if self.segments.len() > 1 {
            writeln!(f, "segments: {} (read as one run)", self.segments.len())?;
            for (p, e) in &self.segments {
                let status = match (&e.truncation, e.complete) {
                    (None, true) => "finished".to_string(),
                    (None, false) => "no footer".to_string(),
                    (Some(t), _) => format!("truncated ({t})"),
                };
                writeln!(f, "  {}: {status}", p.display())?;
            }
        }
        match (&self.end.truncation, self.end.complete) {
            (None, true) => writeln!(f, "status:   finished")?,
            (None, false) => writeln!(f, "status:   no footer (not finished)")?,
            (Some(t), _) => writeln!(f, "status:   truncated ({t})")?,
        }
        let dur = match (self.start_ns, self.end_ns) {
            (Some(a), Some(b)) => format!(" ({:.3} s)", (b - a) as f64 * 1e-9),
            _ => String::new(),
        };
        writeln!(
            f,
            "time:     {} .. {} s{dur}",
            secs(self.start_ns),
            secs(self.end_ns)
        )?;
        if let Some(s) = self.metadata.get(super::schemas::SESSION_METADATA)
            && let Some(scene) = s.get("scene")
        {
            writeln!(f, "scene:    {scene}")?;
        }
        writeln!(
            f,
            "{:<22} {:>9} {:>10} {:>10} {:>8} {:>9}  schema",
            "topic", "messages", "first s", "last s", "dropped", "throttled"
        )?;
        for t in &self.topics {
            let dropped = self
                .drops
                .as_ref()
                .and_then(|d| d.dropped.get(&t.topic))
                .map_or("-".to_string(), u64::to_string);
            let throttled = self
                .drops
                .as_ref()
                .and_then(|d| d.throttled.get(&t.topic))
                .map_or("-".to_string(), u64::to_string);
            writeln!(
                f,
                "{:<22} {:>9} {:>10} {:>10} {:>8} {:>9}  {}",
                t.topic,
                t.messages,
                secs(t.first_ns),
                secs(t.last_ns),
                dropped,
                throttled,
                t.schema
            )?;
        }
        match &self.drops {
            Some(d) => write!(
                f,
                "dropped total: {}, throttled total: {}",
                d.total_dropped(),
                d.total_throttled()
            ),
            None => write!(f, "dropped total: unknown (no recorder stats in file)"),
        }
    }
}

fn scalar(v: &serde_json::Value) -> String {
    match v {
        serde_json::Value::Null => String::new(),
        serde_json::Value::String(s) => s.clone(),
        other => other.to_string(),
    }
}

/// Columns of one message: top-level keys, and the keys of top-level objects one level down
/// (`key.sub`); arrays and deeper objects stay JSON text.
fn flatten(v: &serde_json::Value) -> Vec<(String, String)> {
    let mut out = Vec::new();
    match v {
        serde_json::Value::Object(m) => {
            for (k, x) in m {
                match x {
                    serde_json::Value::Object(sub) => {
                        for (k2, y) in sub {
                            out.push((format!("{k}.{k2}"), scalar(y)));
                        }
                    }
                    _ => out.push((k.clone(), scalar(x))),
                }
            }
        }
        other => out.push(("value".into(), scalar(other))),
    }
    out
}

/// How the messages of one channel are read.
#[derive(Debug, Clone)]
enum Decoder {
    /// `json` messages.
    Json,
    /// `protobuf` messages of a schema in the file.
    Proto(MessageType),
}

impl Decoder {
    fn of(encoding: &str, schema: Option<&(String, String, Vec<u8>)>) -> Result<Self, String> {
        match (encoding, schema) {
            ("json", _) => Ok(Decoder::Json),
            ("protobuf", Some((name, enc, data))) => {
                MessageType::from_schema(name, enc, data).map(Decoder::Proto)
            }
            ("protobuf", None) => Err("protobuf channel without a schema".into()),
            (e, _) => Err(format!(
                "message encoding {e:?}: CSV export reads \"protobuf\" and \"json\""
            )),
        }
    }

    fn json(&self, data: &[u8]) -> Result<serde_json::Value, String> {
        match self {
            Decoder::Json => {
                serde_json::from_slice(data).map_err(|e| format!("message is not JSON: {e}"))
            }
            Decoder::Proto(t) => t.to_json(data),
        }
    }
}

/// Write the messages of `topic` as CSV (`log_time_ns` then one column per flattened key of the
/// message's JSON form, in first-seen order). Returns the number of rows. Two streaming passes,
/// constant memory.
pub fn export_csv(path: &Path, topic: &str, out: &mut dyn Write) -> Result<u64, RecorderError> {
    let files = files_of(path);
    // Decoders of `topic`'s channels, per segment (each segment numbers its channels itself).
    let mut decoders: Vec<HashMap<u16, Decoder>> = Vec::new();
    let mut topics = Vec::new();
    let mut columns: Vec<String> = Vec::new();
    let mut col_index: HashMap<String, usize> = HashMap::new();
    let mut bad: Option<String> = None;
    for file in &files {
        let mut seg: HashMap<u16, Decoder> = HashMap::new();
        let mut schemas: HashMap<u16, (String, String, Vec<u8>)> = HashMap::new();
        scan(file, |item| match item {
            Item::Schema {
                id,
                name,
                encoding,
                data,
            } => {
                schemas.insert(id, (name.into(), encoding.into(), data.to_vec()));
            }
            Item::Channel {
                id,
                topic: t,
                encoding: e,
                schema_id,
                ..
            } => {
                // Channels are listed in the data and again in the summary section.
                if !topics.iter().any(|x| x == t) {
                    topics.push(t.to_string());
                }
                if t == topic && !seg.contains_key(&id) {
                    match Decoder::of(e, schemas.get(&schema_id)) {
                        Ok(d) => {
                            seg.insert(id, d);
                        }
                        Err(e) => {
                            bad.get_or_insert(e);
                        }
                    }
                }
            }
            Item::Message { channel, data, .. } => {
                if let Some(d) = seg.get(&channel) {
                    match d.json(data) {
                        Ok(v) => {
                            for (k, _) in flatten(&v) {
                                if !col_index.contains_key(&k) {
                                    col_index.insert(k.clone(), columns.len());
                                    columns.push(k);
                                }
                            }
                        }
                        Err(e) => {
                            bad.get_or_insert(e);
                        }
                    }
                }
            }
            _ => {}
        })?;
        decoders.push(seg);
    }
    if let Some(b) = bad {
        return Err(read_err(path, format!("{topic}: {b}")));
    }
    if decoders.iter().all(HashMap::is_empty) {
        return Err(read_err(
            path,
            format!("no topic {topic}; topics: {}", topics.join(", ")),
        ));
    }
    let csv_err = |e: csv::Error| read_err(path, format!("cannot write CSV: {e}"));
    let mut csv = csv::Writer::from_writer(out);
    csv.write_record(std::iter::once("log_time_ns").chain(columns.iter().map(String::as_str)))
        .map_err(csv_err)?;
    let mut rows = 0u64;
    let mut failed = None;
    let mut row = vec![String::new(); columns.len() + 1];
    for (file, seg) in files.iter().zip(&decoders) {
        scan(file, |item| {
            if let Item::Message {
                channel,
                log_time,
                data,
            } = item
                && let Some(d) = seg.get(&channel)
                && failed.is_none()
            {
                let Ok(v) = d.json(data) else {
                    return;
                };
                row.iter_mut().for_each(String::clear);
                row[0] = log_time.to_string();
                for (k, x) in flatten(&v) {
                    if let Some(&i) = col_index.get(&k) {
                        row[i + 1] = x;
                    }
                }
                if let Err(e) = csv.write_record(&row) {
                    failed = Some(e);
                }
                rows += 1;
            }
        })?;
    }
    if let Some(e) = failed {
        return Err(csv_err(e));
    }
    csv.flush()
        .map_err(|e| read_err(path, format!("cannot write CSV: {e}")))?;
    Ok(rows)
}
