//! Recovering a trace cut short by a crash, and the segments of a run whose recorder restarted.
//!
//! [`recover`] streams a torn file (a recorder killed by SIGKILL leaves no summary, no footer and
//! usually a partial last chunk) with the linear reader, CRCs checked, and re-writes every
//! schema, channel, metadata record and message of its *complete* chunks with the
//! [`mcap::Writer`]: the result is a finished, indexed MCAP that any reader opens (Python
//! `mcap`'s indexed reader finds nothing in the torn file). The partial chunk is lost: with the
//! recorder's age-bounded chunks that is at most about `recorder.flush_interval_s` of data plus
//! what was still queued.
//!
//! # Segments
//! A recorder restarted during a run (the launcher restarts a killed node) must not truncate what
//! the earlier instance wrote. [`super::Recorder::resume`] continues at once in the segment after
//! the run's last one, and recovers every torn earlier segment in place ([`recover_in_place`]) on
//! a background thread (a 30 MB segment takes about a second; recording meanwhile loses
//! nothing):
//!
//! | segment | file |
//! |---|---|
//! | 0 | `trace.mcap` (the path given to the recorder) |
//! | 1 | `trace.1.mcap` |
//! | k | `trace.k.mcap` |
//!
//! [`segments`] lists a run's segments in order (stopping at the first missing index);
//! [`super::inspect::info`] and [`super::inspect::export_csv`] read all of them as one run when
//! given the first segment or the directory holding `trace.mcap`. Each segment is a complete
//! MCAP on its own (schemas, channels, session metadata and what the converter writes at start
//! repeated; channel sequence numbers and drop counts restart with each recorder instance).

use super::RecorderError;
use mcap::records::{MessageHeader, Record};
use mcap::sans_io::linear_reader::{LinearReadEvent, LinearReader, LinearReaderOptions};
use std::collections::hash_map::Entry;
use std::collections::{BTreeMap, HashMap};
use std::fmt;
use std::io::{BufWriter, Read};
use std::path::{Path, PathBuf};

/// The file name of a run's first segment inside a run directory.
pub const FIRST_SEGMENT: &str = "trace.mcap";

/// What [`recover`] kept.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Recovery {
    /// Messages written to the output.
    pub messages: u64,
    /// Messages per topic.
    pub per_topic: BTreeMap<String, u64>,
    /// Metadata records written.
    pub metadata: u64,
    /// The input was already finished (footer present): copied record by record all the same.
    pub input_complete: bool,
    /// Why reading the input stopped early (the torn tail), if it did.
    pub truncation: Option<String>,
}

impl fmt::Display for Recovery {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} messages in {} topics, {} metadata records; input {}",
            self.messages,
            self.per_topic.len(),
            self.metadata,
            match (&self.truncation, self.input_complete) {
                (Some(t), _) => format!("torn ({t})"),
                (None, true) => "finished".to_string(),
                (None, false) => "without footer".to_string(),
            }
        )
    }
}

fn read_err(path: &Path, message: impl Into<String>) -> RecorderError {
    RecorderError::Read {
        path: path.to_path_buf(),
        message: message.into(),
    }
}

/// Write a finished, indexed MCAP to `output` holding every complete record of `input` (a file
/// cut short by a crash, or a finished one). `input` and `output` must differ.
pub fn recover(input: &Path, output: &Path) -> Result<Recovery, RecorderError> {
    if input
        .canonicalize()
        .ok()
        .is_some_and(|i| output.canonicalize().ok().is_some_and(|o| o == i))
    {
        return Err(read_err(
            input,
            "recover: input and output are the same file",
        ));
    }
    let mut file =
        std::fs::File::open(input).map_err(|e| read_err(input, format!("cannot open: {e}")))?;
    let out = std::fs::File::create(output).map_err(|source| RecorderError::Create {
        path: output.to_path_buf(),
        source,
    })?;
    let mcap_err = |source| RecorderError::Mcap {
        path: output.to_path_buf(),
        source,
    };
    let mut w = mcap::WriteOptions::new()
        .profile("")
        .library(format!(
            "vpsom-rt {} (recovered)",
            env!("CARGO_PKG_VERSION")
        ))
        .compression(Some(mcap::Compression::Zstd))
        .compression_threads(0)
        .create(BufWriter::with_capacity(1 << 20, out))
        .map_err(mcap_err)?;
    let mut reader = LinearReader::new_with_options(
        LinearReaderOptions::default()
            .with_skip_end_magic(false)
            .with_validate_chunk_crcs(true)
            .with_prevalidate_chunk_crcs(true),
    );
    // Input id → output id; channels are listed in the data and again in the summary.
    let mut schemas: HashMap<u16, u16> = HashMap::new();
    let mut channels: HashMap<u16, (u16, String)> = HashMap::new();
    let mut r = Recovery::default();
    let mut records = 0u64;
    while let Some(event) = reader.next_event() {
        let event = match event {
            Ok(e) => e,
            Err(e) if records == 0 => {
                return Err(read_err(input, format!("not an MCAP file: {e}")));
            }
            Err(e) => {
                r.truncation = Some(format!("stopped after {records} records: {e}"));
                break;
            }
        };
        match event {
            LinearReadEvent::ReadRequest(need) => {
                let n = file
                    .read(reader.insert(need))
                    .map_err(|e| read_err(input, format!("read failed: {e}")))?;
                reader.notify_read(n);
            }
            LinearReadEvent::Record { opcode, data } => {
                records += 1;
                let rec = match mcap::parse_record(opcode, data) {
                    Ok(rec) => rec,
                    Err(e) => {
                        r.truncation = Some(format!("bad record after {records} records: {e}"));
                        break;
                    }
                };
                match rec {
                    Record::Schema { header, data } => {
                        if let Entry::Vacant(slot) = schemas.entry(header.id) {
                            slot.insert(
                                w.add_schema(&header.name, &header.encoding, &data)
                                    .map_err(mcap_err)?,
                            );
                        }
                    }
                    Record::Channel(c) => {
                        if let Entry::Vacant(slot) = channels.entry(c.id) {
                            // Schema id 0 means "no schema" in both files.
                            let sid = match c.schema_id {
                                0 => 0,
                                s => *schemas.get(&s).ok_or_else(|| {
                                    read_err(
                                        input,
                                        format!("channel {} before its schema", c.topic),
                                    )
                                })?,
                            };
                            let id = w
                                .add_channel(sid, &c.topic, &c.message_encoding, &c.metadata)
                                .map_err(mcap_err)?;
                            slot.insert((id, c.topic));
                        }
                    }
                    Record::Message { header, data } => {
                        let Some((id, topic)) = channels.get(&header.channel_id) else {
                            return Err(read_err(
                                input,
                                format!("message on unknown channel {}", header.channel_id),
                            ));
                        };
                        w.write_to_known_channel(
                            &MessageHeader {
                                channel_id: *id,
                                ..header
                            },
                            &data,
                        )
                        .map_err(mcap_err)?;
                        r.messages += 1;
                        *r.per_topic.entry(topic.clone()).or_insert(0) += 1;
                    }
                    Record::Metadata(m) => {
                        w.write_metadata(&m).map_err(mcap_err)?;
                        r.metadata += 1;
                    }
                    Record::Footer(_) => r.input_complete = true,
                    // Chunks are opened by the reader; indexes, statistics and summary records
                    // are rebuilt by the writer; the recorder writes no attachments.
                    _ => {}
                }
            }
        }
    }
    w.finish().map_err(mcap_err)?;
    drop(w);
    Ok(r)
}

/// Whether `path` ends with a footer (was finished). A file that is not MCAP at all is an error.
pub fn is_finished(path: &Path) -> Result<bool, RecorderError> {
    Ok(super::inspect::scan(path, |_| {})?.complete)
}

/// Replace a torn `path` by its recovered version (written beside it, then renamed over it, so
/// a crash during recovery leaves the torn file as it was). A finished file is left alone
/// (`Ok(None)`); an empty file or one holding only part of the MCAP header (killed while
/// starting) becomes an empty, finished trace.
pub fn recover_in_place(path: &Path) -> Result<Option<Recovery>, RecorderError> {
    let len = std::fs::metadata(path)
        .map_err(|e| read_err(path, format!("cannot open: {e}")))?
        .len();
    let tmp = path.with_extension("mcap.recovering");
    let r = if len <= 8 {
        // Nothing recorded yet: an empty trace says so honestly.
        let out = std::fs::File::create(&tmp).map_err(|source| RecorderError::Create {
            path: tmp.clone(),
            source,
        })?;
        let mcap_err = |source| RecorderError::Mcap {
            path: tmp.clone(),
            source,
        };
        mcap::WriteOptions::new()
            .profile("")
            .create(BufWriter::new(out))
            .and_then(|mut w| w.finish().map(|_| ()))
            .map_err(mcap_err)?;
        Recovery {
            truncation: Some(format!("{len} bytes: killed while starting")),
            ..Recovery::default()
        }
    } else {
        if is_finished(path)? {
            return Ok(None);
        }
        recover(path, &tmp)?
    };
    std::fs::rename(&tmp, path).map_err(|e| read_err(path, format!("cannot replace: {e}")))?;
    Ok(Some(r))
}

/// Segment `k` of the run whose first segment is `first` (`trace.mcap` → `trace.k.mcap`).
pub fn segment_path(first: &Path, k: usize) -> PathBuf {
    if k == 0 {
        return first.to_path_buf();
    }
    let stem = first
        .file_stem()
        .map_or_else(|| "trace".to_string(), |s| s.to_string_lossy().into_owned());
    let ext = first
        .extension()
        .map_or_else(|| "mcap".to_string(), |e| e.to_string_lossy().into_owned());
    first.with_file_name(format!("{stem}.{k}.{ext}"))
}

/// The existing segments of the run whose first segment is `first`, in order. A directory
/// stands for its `trace.mcap`. Stops at the first missing index.
pub fn segments(first: &Path) -> Vec<PathBuf> {
    let first = run_first_segment(first);
    (0..)
        .map(|k| segment_path(&first, k))
        .take_while(|p| p.exists())
        .collect()
}

/// The first segment a path names: `DIR/trace.mcap` for a directory, else the path itself.
pub fn run_first_segment(path: &Path) -> PathBuf {
    if path.is_dir() {
        path.join(FIRST_SEGMENT)
    } else {
        path.to_path_buf()
    }
}

/// Remove every segment after the first of the run whose first segment is `first` (a new run
/// starting in a directory used before; the first segment is truncated by its new recorder).
/// Returns how many were removed.
pub fn remove_later_segments(first: &Path) -> std::io::Result<usize> {
    let mut n = 0;
    for k in 1.. {
        let p = segment_path(first, k);
        match std::fs::remove_file(&p) {
            Ok(()) => n += 1,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => break,
            Err(e) => return Err(e),
        }
    }
    Ok(n)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn segment_names_follow_the_first() {
        let first = Path::new("/run/out/trace.mcap");
        assert_eq!(segment_path(first, 0), first);
        assert_eq!(segment_path(first, 1), Path::new("/run/out/trace.1.mcap"));
        assert_eq!(segment_path(first, 12), Path::new("/run/out/trace.12.mcap"));
    }
}
