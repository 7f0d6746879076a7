//! Rate limits for the large topics (`[link.max_hz]`): a limited topic `T` is not bridged
//! itself; the host that publishes it copies its newest sample at most `max_hz` times a second
//! onto `link/T`, which is bridged, and the other host copies what arrives on `link/T` back onto
//! `T`. Both copies keep the publisher's header (sequence number, stamps), so a consumer sees the
//! frames that crossed as the producer numbered them. The sample is validated before either
//! copy (received through a typed [`Subscriber`] here; decoded and validated there). A slow
//! link then carries at most `max_hz × used bytes` a second of that topic, and the robot's
//! publisher never waits for it.
//!
//! `link/T` is a byte-slice service (`runtime::ports::SlicePublisher`, iceoryx2 `[u8]` payloads
//! with the [`Header`](shm_types::Header) as user header), not a `T`: each sample is the
//! [`Codec`] encoding of the used part of `T` (a 320×240 frame's pixels, not 640×480; the
//! detections' items and, only in mask mode, their label image; the map's objects), as long as
//! that and no longer. The slice publisher's maximum is `T`'s full encoding, so any camera size
//! fits. The tunnel carries a slice sample at its length (iceoryx2-link 0.10 relays a dynamic
//! payload's bytes and loans the same length on the other side). A slice that does not decode,
//! or decodes to an invalid `T`, is refused and counted (`| link: relay <topic> invalid samples
//! dropped |`), never published.
//!
//! Detections belong to a frame (`frame_seq`): a consumer across the link (the mapper) pairs
//! them. When both `depth` and `detections` are limited and published on this host, one relay
//! carries them as pairs: at each due time the newest detections and the frame they belong to
//! (a frame is published before its detections, so it is already there).
//!
//! Each relay counts the bytes it sent or received per topic and times each sample's receive
//! and copy (encode or decode) for the run summary ([`super::RelayCount`]).

use super::LinkError;
use super::codec::{Codec, DecodeError};
use runtime::ports::{
    PortContext, Publisher, ReceiveError, SendError, SlicePublisher, SliceSubscriber, Subscriber,
};
use shm_types::{DepthFrame, Detections, ObjectMap};
use std::collections::BTreeMap;
use std::time::{Duration, Instant};

/// Name of the bridged relay topic of a limited topic.
pub fn relay_topic(topic: &str) -> String {
    format!("link/{topic}")
}

/// What one topic's relay moved, and how long each copy took (for the run summary).
#[derive(Debug, Default)]
pub struct Moved {
    /// `link/<topic>` → `<topic>` (received from the other host).
    inbound: bool,
    samples: u64,
    bytes: u64,
    first: Option<Instant>,
    last: Option<Instant>,
    /// Per copied sample: receive and copy, ns.
    took_ns: Vec<u64>,
}

impl Moved {
    /// Count one copied sample of `bytes` on `link/<topic>` that took `took` to receive and copy.
    fn record(&mut self, bytes: usize, took: Duration) {
        let now = Instant::now();
        self.samples += 1;
        self.bytes += bytes as u64;
        self.first.get_or_insert(now);
        self.last = Some(now);
        self.took_ns.push(took.as_nanos() as u64);
    }

    /// The account of `topic` for the report.
    fn count(&self, topic: &'static str) -> super::RelayCount {
        let mut ns = self.took_ns.clone();
        ns.sort_unstable();
        let mean = if ns.is_empty() {
            0.0
        } else {
            ns.iter().sum::<u64>() as f64 / ns.len() as f64
        };
        let p99 = if ns.is_empty() {
            0.0
        } else {
            ns[((ns.len() as f64 * 0.99).ceil() as usize).clamp(1, ns.len()) - 1] as f64
        };
        let span = match (self.first, self.last) {
            (Some(a), Some(b)) => b.duration_since(a).as_secs_f64(),
            _ => 0.0,
        };
        super::RelayCount {
            topic,
            inbound: self.inbound,
            samples: self.samples,
            bytes: self.bytes,
            span_s: span,
            mean_us: mean / 1e3,
            p99_us: p99 / 1e3,
            // Filled in from the relay's subscribers (`Throttle::counts`).
            invalid: 0,
        }
    }
}

/// Per limited topic, what its relay moved.
type MovedMap = BTreeMap<&'static str, Moved>;

fn moved<'m>(m: &'m mut MovedMap, topic: &'static str) -> &'m mut Moved {
    m.entry(topic).or_default()
}

/// One direction of one limited topic (or of a frame and its detections).
trait Relay {
    /// Copy what is due, counting each copied sample under its topic in `moved`.
    fn poll(&mut self, now: Instant, moved: &mut MovedMap) -> Result<(), RelayError>;
    /// When the next copy may be due (outbound), if it waits for time.
    fn next_due(&self) -> Option<Instant>;
    /// Per topic it receives: samples refused on receipt so far.
    fn invalid(&self) -> Vec<(&'static str, u64)>;
}

/// Why a relay failed.
#[derive(Debug, thiserror::Error)]
pub enum RelayError {
    /// Receiving the sample to copy failed.
    #[error(transparent)]
    Receive(#[from] ReceiveError),
    /// Loaning the copy failed.
    #[error(transparent)]
    Loan(#[from] runtime::ports::LoanError),
    /// Sending the copy failed.
    #[error(transparent)]
    Send(#[from] SendError),
}

/// Why a sample from `link/<topic>` was refused.
#[derive(Debug, thiserror::Error)]
enum Refused {
    #[error(transparent)]
    Decode(#[from] DecodeError),
    #[error(transparent)]
    Invalid(#[from] shm_types::ValidationError),
}

/// Encode the used part of `s` into a loan of `to` as long as that ([`Codec`]) and send it
/// with `s`'s own header; returns the bytes sent.
fn forward<T: Codec>(s: &T, to: &SlicePublisher) -> Result<usize, RelayError> {
    let len = s.encoded_len();
    let mut loan = to.loan(len)?;
    s.encode(&mut loan);
    *loan.header_mut() = *s.header();
    loan.send_relayed()?;
    Ok(len)
}

/// Here → `link/T`: the newest sample of `T`, at most every `period`.
struct Outbound<T: Codec> {
    topic: &'static str,
    from: Subscriber<T>,
    to: SlicePublisher,
    period: Duration,
    next: Instant,
}

impl<T: Codec> Relay for Outbound<T> {
    fn poll(&mut self, now: Instant, moved: &mut MovedMap) -> Result<(), RelayError> {
        if now < self.next {
            return Ok(());
        }
        let t0 = Instant::now();
        let Some(s) = self.from.latest()? else {
            return Ok(());
        };
        let bytes = forward(&*s, &self.to)?;
        self::moved(moved, self.topic).record(bytes, t0.elapsed());
        self.next = now + self.period;
        Ok(())
    }

    fn next_due(&self) -> Option<Instant> {
        Some(self.next)
    }

    fn invalid(&self) -> Vec<(&'static str, u64)> {
        vec![(self.topic, self.from.invalid())]
    }
}

/// Here → `link/depth` and `link/detections`: the newest detections and their frame, at most
/// every `period`. Detections whose frame is no longer in `frames`' buffer do not cross.
struct FramePairs {
    dets: Subscriber<Detections>,
    frames: Subscriber<DepthFrame>,
    dets_to: SlicePublisher,
    frames_to: SlicePublisher,
    /// A frame newer than the detections last looked at, kept for its own detections.
    held: Option<runtime::ports::Received<DepthFrame>>,
    period: Duration,
    next: Instant,
}

impl Relay for FramePairs {
    fn poll(&mut self, now: Instant, moved: &mut MovedMap) -> Result<(), RelayError> {
        if now < self.next {
            return Ok(());
        }
        let t0 = Instant::now();
        let Some(d) = self.dets.latest()? else {
            return Ok(());
        };
        let frame = loop {
            let f = match self.held.take() {
                Some(f) => f,
                None => match self.frames.receive()? {
                    Some(f) => f,
                    None => break None,
                },
            };
            match f.header.seq.cmp(&d.frame_seq) {
                std::cmp::Ordering::Less => continue,
                std::cmp::Ordering::Equal => break Some(f),
                std::cmp::Ordering::Greater => {
                    self.held = Some(f);
                    break None;
                }
            }
        };
        let Some(f) = frame else {
            return Ok(());
        };
        // The frame first: the consumer waits for a frame's detections, not the reverse.
        // Receiving is timed with the frame (finding it is most of it), the detections' copy
        // on its own.
        let frame_bytes = forward(&*f, &self.frames_to)?;
        let frame_took = t0.elapsed();
        let t1 = Instant::now();
        let det_bytes = forward(&*d, &self.dets_to)?;
        self::moved(moved, crate::topics::DETECTIONS).record(det_bytes, t1.elapsed());
        self::moved(moved, crate::topics::DEPTH).record(frame_bytes, frame_took);
        self.next = now + self.period;
        Ok(())
    }

    fn next_due(&self) -> Option<Instant> {
        Some(self.next)
    }

    fn invalid(&self) -> Vec<(&'static str, u64)> {
        use crate::topics::{DEPTH, DETECTIONS};
        vec![
            (DEPTH, self.frames.invalid()),
            (DETECTIONS, self.dets.invalid()),
        ]
    }
}

/// `link/T` → `T` here: every sample that crossed, decoded ([`Codec::decode`]) into a loan
/// of `T` and validated; one that fails either is refused (counted, logged, not published).
struct Inbound<T: Codec> {
    topic: &'static str,
    from: SliceSubscriber,
    to: Publisher<T>,
}

impl<T: Codec> Relay for Inbound<T> {
    fn poll(&mut self, _now: Instant, moved: &mut MovedMap) -> Result<(), RelayError> {
        loop {
            let t0 = Instant::now();
            let Some(s) = self.from.receive()? else {
                return Ok(());
            };
            let mut loan = self.to.loan()?;
            let decoded = T::decode(s.header(), &s, &mut loan)
                .map_err(Refused::from)
                .and_then(|()| loan.validate().map_err(Refused::from));
            match decoded {
                Ok(()) => {
                    loan.send_relayed()?;
                    self::moved(moved, self.topic).record(s.len(), t0.elapsed());
                }
                Err(e) => {
                    drop(loan);
                    self.from.reject(s, &e);
                }
            }
        }
    }

    fn next_due(&self) -> Option<Instant> {
        None
    }

    fn invalid(&self) -> Vec<(&'static str, u64)> {
        vec![(self.topic, self.from.invalid())]
    }
}

/// The relays of a tunnel's limited topics.
pub struct Throttle {
    relays: Vec<Box<dyn Relay>>,
    /// What each limited topic's relay moved (one direction per topic on a host).
    moved: MovedMap,
}

impl std::fmt::Debug for Throttle {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Throttle")
            .field("relays", &self.relays.len())
            .field("copied", &self.copied())
            .finish()
    }
}

fn relay<T: Codec>(
    ctx: &PortContext,
    topic: &'static str,
    outbound: bool,
    max_hz: f64,
) -> Result<Box<dyn Relay>, LinkError> {
    let link = relay_topic(topic);
    Ok(if outbound {
        Box::new(Outbound {
            topic,
            from: ctx.subscriber::<T>(topic)?,
            to: ctx.slice_publisher(&link, T::MAX_ENCODED)?,
            period: Duration::from_secs_f64(1.0 / max_hz),
            next: Instant::now(),
        })
    } else {
        Box::new(Inbound {
            topic,
            from: ctx.slice_subscriber(&link)?,
            to: ctx.publisher::<T>(topic)?,
        })
    })
}

fn frame_pairs(ctx: &PortContext, max_hz: f64) -> Result<Box<dyn Relay>, LinkError> {
    use crate::topics::{DEPTH, DETECTIONS};
    Ok(Box::new(FramePairs {
        dets: ctx.subscriber(DETECTIONS)?,
        frames: ctx.subscriber(DEPTH)?,
        dets_to: ctx.slice_publisher(&relay_topic(DETECTIONS), Detections::MAX_ENCODED)?,
        frames_to: ctx.slice_publisher(&relay_topic(DEPTH), DepthFrame::MAX_ENCODED)?,
        held: None,
        period: Duration::from_secs_f64(1.0 / max_hz),
        next: Instant::now(),
    }))
}

impl Throttle {
    /// A relay per `(topic, max_hz)` in `limited`, outbound where the topic is in `local`;
    /// `depth` and `detections` both limited and both local: one relay of frame pairs (the
    /// configuration requires one rate for the two).
    pub fn new(
        ctx: &PortContext,
        limited: &[(&'static str, f64)],
        local: &[&'static str],
    ) -> Result<Self, LinkError> {
        use crate::topics::{DEPTH, DETECTIONS, MAP};
        let out = |t: &str| local.contains(&t);
        let is_limited = |t: &str| limited.iter().any(|&(l, _)| l == t);
        let paired = out(DEPTH) && out(DETECTIONS) && is_limited(DEPTH) && is_limited(DETECTIONS);
        let mut relays = Vec::new();
        let mut moved = MovedMap::new();
        for &(topic, hz) in limited {
            moved.insert(
                topic,
                Moved {
                    inbound: !out(topic),
                    ..Moved::default()
                },
            );
            relays.push(match topic {
                DEPTH if paired => frame_pairs(ctx, hz)?,
                DETECTIONS if paired => continue,
                DEPTH => relay::<DepthFrame>(ctx, topic, out(topic), hz)?,
                DETECTIONS => relay::<Detections>(ctx, topic, out(topic), hz)?,
                MAP => relay::<ObjectMap>(ctx, topic, out(topic), hz)?,
                other => unreachable!("{other} is not a limitable topic"),
            });
        }
        Ok(Self { relays, moved })
    }

    /// Copy what is due on every relay; returns the samples copied.
    pub fn poll(&mut self, now: Instant) -> Result<u64, RelayError> {
        let before = self.copied();
        for r in &mut self.relays {
            r.poll(now, &mut self.moved)?;
        }
        Ok(self.copied() - before)
    }

    /// The earliest time an outbound relay may copy again.
    pub fn next_due(&self) -> Option<Instant> {
        self.relays.iter().filter_map(|r| r.next_due()).min()
    }

    /// Samples copied so far (both directions).
    pub fn copied(&self) -> u64 {
        self.moved.values().map(|m| m.samples).sum()
    }

    /// Samples the relays copied of `topic` so far (outbound: onto `link/<topic>`, i.e. the
    /// samples that crossed; inbound: back onto `topic` here, i.e. the samples received).
    pub fn copied_of(&self, topic: &str) -> u64 {
        self.moved.get(topic).map_or(0, |m| m.samples)
    }

    /// Per limited topic: what its relay moved, for the report.
    pub fn counts(&self) -> Vec<super::RelayCount> {
        let mut invalid: BTreeMap<&str, u64> = BTreeMap::new();
        for r in &self.relays {
            for (t, n) in r.invalid() {
                *invalid.entry(t).or_default() += n;
            }
        }
        self.moved
            .iter()
            .map(|(t, m)| {
                let mut c = m.count(t);
                c.invalid = invalid.get(t).copied().unwrap_or(0);
                c
            })
            .collect()
    }
}
