//! `vpsom run --nodes LIST --link ENDPOINT...`: this run's topics bridged to a run on another
//! host (same namespace) through iceoryx2's link tunnel (`iceoryx2-link` 0.10, a prototype
//! upstream) over zenoh. Not a transport of ours: the tunnel moves the samples, zenoh the bytes.
//!
//! # Files
//! | file | content |
//! |---|---|
//! | `mod.rs` | [`LinkArgs`], [`LinkReport`], [`TopicCount`], [`LinkError`]: what the launcher sees, built with or without the `link` feature |
//! | `bridge.rs` | [`Link`] (start, wait for the peer, quiesce, finish), [`check_overflow`]; without the `link` cargo feature a [`Link`] that refuses to start ([`LinkError::NotBuilt`]) |
//! | `endpoints.rs` | `--link` endpoints ([`parse_endpoint`]) and the zenoh configuration ([`zenoh_config`]) |
//! | `tunnel.rs` | the tunnel thread: iceoryx2-link's `Link` over a zenoh carrier, the handshake, peer loss and return |
//! | `watch.rs` | per topic: published and crossed (sending host), received and lost in the tunnel (receiving host), dropped by the local nodes' subscribers (their heartbeats), invalid samples ([`RUN_TOPICS`]) |
//! | `throttle.rs` | `[link.max_hz]`: large topics cross through a relay topic `link/<topic>` at a limited rate, as the bytes of their used part |
//! | [`codec`] | the used part of a `DepthFrame`, `Detections` or `ObjectMap` as bytes, and back (built without the feature too) |
//!
//! Where it runs: a thread of the launcher process (`vpsom run`), not a node process. The
//! launcher is the one process that is neither real-time nor a node, so zenoh's runtime threads
//! never share a process with the LBV thread or the mapper; and the launcher alone knows when
//! the nodes have stopped, so it keeps the tunnel up until their last samples have left (and,
//! on the receiving host, keeps its nodes up until the other host's last samples arrived).
//!
//! What it guarantees and what not: only the allow-listed services `vpsom/<ns>/<topic>` (and
//! `vpsom/<ns>/link/<topic>` for a rate-limited topic) cross; a sample's bytes arrive as they
//! were written on the other host and are validated by the subscribers here, never by the
//! tunnel; zenoh carries them reliably while the connection holds, but a sample published while
//! the hosts are apart, or overwritten in the tunnel's buffers, is lost (counted per topic from
//! the sequence numbers). A local publisher never waits for the tunnel.
//!
//! The tunnel needs zenoh (about 300 crates), so it is the cargo feature `link` of `vpsom` and
//! `rt_tests`, off by default: `cargo build --release -p vpsom --features link`. Without it, `--link`
//! is refused with [`LinkError::NotBuilt`].

#[cfg(feature = "link")]
mod bridge;
pub mod codec;
#[cfg(feature = "link")]
mod endpoints;
#[cfg(feature = "link")]
mod throttle;
#[cfg(feature = "link")]
mod tunnel;
#[cfg(feature = "link")]
mod watch;

#[cfg(feature = "link")]
pub use bridge::{Link, check_overflow};
#[cfg(feature = "link")]
pub(crate) use bridge::{Shared, Spec};
#[cfg(feature = "link")]
pub use endpoints::{Direction, Endpoint, parse_endpoint, zenoh_config};
#[cfg(feature = "link")]
pub use throttle::relay_topic;
#[cfg(feature = "link")]
pub use tunnel::{ZenohLink, open_link};
#[cfg(feature = "link")]
pub use watch::RUN_TOPICS;

use std::path::PathBuf;
#[cfg(not(feature = "link"))]
use std::sync::atomic::AtomicBool;
use std::time::Duration;

/// How long (wall time) a subscriber sized by [`burst_depth`] may go unread without losing a
/// sample: samples from another host arrive in bursts, and a loaded 2-CPU machine leaves a
/// process off the CPU for hundreds of ms (the station recorder's losses of issue #35).
pub const STALL_S: f64 = 1.0;

/// A large topic's buffers are at most this deep: every slot of a 600 KB frame costs shared
/// memory for each possible subscriber.
pub const LARGE_DEPTH_MAX: usize = 8;

/// Samples `topic` brings per wall second in a run at `time_scale`: its configured rate
/// (`[rates]`, `[planner] lbv_hz`) × the time scale; for a topic `[link.max_hz]` limits, at most
/// the limit (what crosses). `None` for a topic without a configured rate.
pub fn wall_hz(topic: &str, cfg: &crate::config::Config, time_scale: f64) -> Option<f64> {
    use crate::topics;
    let sim_hz = match topic {
        topics::DEPTH | topics::DETECTIONS | topics::VISIBILITY => cfg.rates.camera_hz,
        topics::STATE | topics::TRUTH => cfg.rates.state_hz,
        topics::MAP | topics::MAP_GRID | topics::NAV_GRID => cfg.rates.map_hz,
        // At most one per LBV cycle.
        topics::NECK_GOAL | topics::DEADLINE | topics::NAV_GOAL | topics::DECISION => {
            cfg.planner.lbv_hz
        }
        // Heartbeats are on the wall clock, one stream per node.
        topics::HEALTH => return Some(cfg.run.health_hz * super::ROLES.len() as f64),
        _ => return None,
    };
    let hz = sim_hz * time_scale;
    Some(cfg.link.limit(topic).map_or(hz, |limit| hz.min(limit)))
}

/// The depth that holds [`STALL_S`] of `topic` at `wall_hz`, at least `configured`; a large
/// topic (`large`) at most [`LARGE_DEPTH_MAX`] (but never below `configured`), any at most 256
/// (`[ports] subscriber_buffer`'s range).
pub fn burst_depth(wall_hz: Option<f64>, configured: usize, large: bool) -> usize {
    let want = wall_hz.map_or(0, |hz| (hz * STALL_S).ceil() as usize);
    let cap = if large { LARGE_DEPTH_MAX } else { 256 };
    want.min(cap).max(configured).min(256)
}

/// `--link` and `--zenoh-config` as given.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LinkArgs {
    /// The `--link` values.
    pub endpoints: Vec<String>,
    /// `--zenoh-config` (overrides `[link] zenoh_config`).
    pub zenoh_config: Option<PathBuf>,
}

/// Why the link could not start or failed.
#[derive(Debug, thiserror::Error)]
pub enum LinkError {
    /// A `--link` value is not an endpoint.
    #[error("--link {value:?}: {reason}")]
    Endpoint {
        /// The value.
        value: String,
        /// What is wrong.
        reason: String,
    },
    /// The zenoh configuration could not be read or completed.
    #[error("zenoh configuration {file}: {key}: {reason}")]
    ZenohConfig {
        /// The file (or `<built-in>`).
        file: String,
        /// The key being set, or `(file)` for reading it.
        key: String,
        /// zenoh's reason.
        reason: String,
    },
    /// A bridged topic blocks its publisher on a full subscriber.
    #[error(
        "{key} = \"block\" with --link: a publisher of {topic} would wait for the tunnel; use \"overwrite\" or \"discard\""
    )]
    Blocking {
        /// The configuration key.
        key: String,
        /// The topic.
        topic: String,
    },
    /// The zenoh session or carrier failed.
    #[error("zenoh: {0}")]
    Session(String),
    /// An iceoryx2 operation of the tunnel failed.
    #[error("iceoryx2: {0}")]
    Iceoryx(String),
    /// The tunnel's ports.
    #[error(transparent)]
    Context(#[from] runtime::ports::ContextError),
    /// A subscriber of the tunnel.
    #[error(transparent)]
    Subscriber(#[from] runtime::ports::SubscriberError),
    /// A publisher of the tunnel (rate-limit relays).
    #[error(transparent)]
    Publisher(#[from] runtime::ports::PublisherError),
    /// The tunnel thread could not start or panicked.
    #[error("the tunnel thread: {0}")]
    Thread(String),
    /// This binary was built without the link (the `link` cargo feature: zenoh is large and
    /// only multi-host runs need it).
    #[error(
        "--link: this vpsom was built without the `link` feature; build it with `cargo build --release -p vpsom --features link`"
    )]
    NotBuilt,
}

/// What the tunnel moved in a run.
#[derive(Debug, Clone, Default)]
pub struct LinkReport {
    /// Per topic (topics that saw nothing are left out).
    pub topics: Vec<TopicCount>,
    /// How long each loss of the other host lasted (ended by its return or by the run's end).
    pub gaps: Vec<Duration>,
    /// Samples copied by the rate-limit relays.
    pub relayed: u64,
    /// Per rate-limited topic and direction: what its relay moved and how long each copy took.
    pub relays: Vec<RelayCount>,
}

/// What the rate-limit relay of one topic moved in one direction (see `throttle.rs`).
#[derive(Debug, Clone, PartialEq)]
pub struct RelayCount {
    /// Topic.
    pub topic: &'static str,
    /// `true`: `link/<topic>` → `<topic>` here (received); else `<topic>` → `link/<topic>` (sent).
    pub inbound: bool,
    /// Samples copied.
    pub samples: u64,
    /// Bytes of `link/<topic>` payload these samples were (what crossed the link for them).
    pub bytes: u64,
    /// Wall time from the first copy to the last, s (0 with fewer than two).
    pub span_s: f64,
    /// Per copied sample, the time to receive it and copy it on, µs: mean.
    pub mean_us: f64,
    /// ... and 99th percentile.
    pub p99_us: f64,
    /// Samples the relay refused on receipt (failed validation; inbound, or did not decode).
    pub invalid: u64,
}

impl RelayCount {
    /// Bytes per second from the first copy to the last, in MB/s (10⁶ bytes); 0 with fewer
    /// than two copies.
    pub fn mb_per_s(&self) -> f64 {
        if self.span_s > 0.0 && self.samples > 1 {
            // n samples span n - 1 intervals.
            self.bytes as f64 * (self.samples - 1) as f64 / self.samples as f64 / self.span_s / 1e6
        } else {
            0.0
        }
    }
}

impl LinkReport {
    /// Table rows for the run's summary: the gaps, then per topic its account (see
    /// [`TopicCount`]), then per rate-limit relay its bytes and copy time ([`RelayCount`]),
    /// then a warning row per topic that lost samples ([`Self::warnings`]).
    ///
    /// Rows: `| link: <topic> out, <hz> Hz: published / crossed / dropped by local subscribers |
    /// P / C / D (<node> <n>, ...) |` for a topic published here, `| link: <topic> in, <hz> Hz:
    /// received / lost in the tunnel / dropped by local subscribers | R / L / D (...) |` for one
    /// from the other host (`-` where a rate-limited topic has no such count); per relay `| link:
    /// bytes crossed, <topic> (sent|received) | N (X MB/s) |` and `| link: relay
    /// receive-and-copy, <topic> (sent|received), µs per sample mean / p99 | M / P |`.
    pub fn rows(&self) -> String {
        let mut t = String::new();
        // `+ 0.0`: an empty sum of f64 is -0.0.
        let total: f64 = self.gaps.iter().map(Duration::as_secs_f64).sum::<f64>() + 0.0;
        t += &format!(
            "| link: times the other host was lost (total s) | {} ({total:.1}) |\n",
            self.gaps.len()
        );
        for c in &self.topics {
            let hz =
                c.hz.map_or_else(|| "?".to_string(), |hz| format!("{hz:.0}"));
            let limited = if c.limited { ", rate-limited" } else { "" };
            let dropped: u64 = c.dropped.iter().map(|d| d.1).sum();
            let by_node = if c.dropped.is_empty() {
                String::new()
            } else {
                let v: Vec<String> = c.dropped.iter().map(|(n, k)| format!("{n} {k}")).collect();
                format!(" ({})", v.join(", "))
            };
            if c.inbound {
                let lost = if c.limited {
                    "-".to_string()
                } else {
                    c.lost.to_string()
                };
                let dropped = if c.limited {
                    "-".to_string()
                } else {
                    dropped.to_string()
                };
                t += &format!(
                    "| link: {} in, {hz} Hz{limited}: received / lost in the tunnel / dropped by local subscribers | {} / {lost} / {dropped}{by_node} |\n",
                    c.topic, c.received
                );
            } else {
                t += &format!(
                    "| link: {} out, {hz} Hz{limited}: published / crossed / dropped by local subscribers | {} / {} / {dropped}{by_node} |\n",
                    c.topic, c.published, c.crossed
                );
            }
            if c.invalid > 0 {
                t += &format!(
                    "| link: {} invalid samples dropped | {} |\n",
                    c.topic, c.invalid
                );
            }
        }
        for r in &self.relays {
            let dir = if r.inbound { "received" } else { "sent" };
            t += &format!(
                "| link: bytes crossed, {} ({dir}) | {} ({:.2} MB/s) |\n",
                r.topic,
                r.bytes,
                r.mb_per_s()
            );
            t += &format!(
                "| link: relay receive-and-copy, {} ({dir}), µs per sample mean / p99 | {:.1} / {:.1} |\n",
                r.topic, r.mean_us, r.p99_us
            );
            if r.invalid > 0 {
                t += &format!(
                    "| link: relay {} invalid samples dropped | {} |\n",
                    r.topic, r.invalid
                );
            }
        }
        for w in self.warnings() {
            t += &format!("| link: WARNING | {w} |\n");
        }
        t
    }

    /// One line per bridged topic that lost samples, naming the topic and the count: lost in
    /// the tunnel (inbound), not taken by the tunnel (outbound, not rate-limited), or dropped by
    /// a local subscriber.
    pub fn warnings(&self) -> Vec<String> {
        let mut w = Vec::new();
        for c in &self.topics {
            if c.inbound && c.lost > 0 {
                w.push(format!(
                    "{}: {} of {} samples lost in the tunnel (sequence gaps)",
                    c.topic,
                    c.lost,
                    c.lost + c.received
                ));
            }
            if !c.inbound && !c.limited && c.published > c.crossed {
                w.push(format!(
                    "{}: {} of {} samples published here never reached the tunnel",
                    c.topic,
                    c.published - c.crossed,
                    c.published
                ));
            }
            for (node, n) in &c.dropped {
                if *n > 0 {
                    w.push(format!(
                        "{}: {n} samples dropped by the {node}'s subscriber (overflow)",
                        c.topic
                    ));
                }
            }
        }
        w
    }

    /// Print [`Self::warnings`] on stderr.
    pub fn warn(&self) {
        for w in self.warnings() {
            eprintln!("link: WARNING: {w}");
        }
    }
}

/// What one topic moved, for the report. On the host that publishes it (`inbound == false`):
/// `published` and `crossed` (what the tunnel took to send; `published - crossed` never reached
/// it); on the other host: `received` and `lost` (the sequence numbers that arrived nowhere);
/// on both, `dropped` by the local nodes' subscribers. Across the two hosts' summaries, for a
/// topic that is not rate-limited: `published = received + lost` on the receiving side (every
/// sequence number is either received or a gap), and a node there read `received - dropped`.
#[derive(Debug, Clone, PartialEq)]
pub struct TopicCount {
    /// Topic.
    pub topic: &'static str,
    /// `true`: came from the other host.
    pub inbound: bool,
    /// Rate-limited (`[link.max_hz]`): crosses through the relay `link/<topic>`.
    pub limited: bool,
    /// Its wall rate, Hz (`[rates]` × the run's time scale, at most `[link.max_hz]`).
    pub hz: Option<f64>,
    /// Outbound: sequence numbers the publisher here used (summed over its restarts).
    pub published: u64,
    /// Outbound: samples the tunnel took to send (its subscriber here received them); for a
    /// rate-limited topic, the samples the relay copied onto `link/<topic>`.
    pub crossed: u64,
    /// Inbound: samples that came over the link (rate-limited: that the relay copied back).
    pub received: u64,
    /// Inbound: sequence numbers that never arrived here, before the first arrival and between
    /// two (0 for a rate-limited topic, whose gaps are the limit's).
    pub lost: u64,
    /// Per local node subscribed to the topic: samples it lost to overflow (its sequence gaps,
    /// less those lost in the tunnel). Empty for an inbound rate-limited topic.
    pub dropped: Vec<(String, u64)>,
    /// Samples that failed validation on receipt here.
    pub invalid: u64,
}

/// Without the `link` feature: a tunnel that cannot exist ([`Link::start`] refuses).
#[cfg(not(feature = "link"))]
#[derive(Debug)]
pub enum Link {}

#[cfg(not(feature = "link"))]
impl Link {
    /// Refuses: this binary has no tunnel ([`LinkError::NotBuilt`]).
    pub fn start(
        _args: &LinkArgs,
        _namespace: &str,
        _roles: &[&'static str],
        _cfg: &crate::config::Config,
        _time_scale: f64,
    ) -> Result<Self, LinkError> {
        Err(LinkError::NotBuilt)
    }

    /// Never called: no `Link` exists without the feature.
    pub fn wait_for_peer(&self, _limit: Duration, _stop: &AtomicBool) -> bool {
        match *self {}
    }

    /// Never called: no `Link` exists without the feature.
    pub fn quiesce(&self) {
        match *self {}
    }

    /// Never called: no `Link` exists without the feature.
    pub fn finish(self) -> Result<LinkReport, LinkError> {
        match self {}
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn burst_depths_hold_a_second_within_their_bounds() {
        assert_eq!(burst_depth(Some(100.0), 16, false), 100);
        assert_eq!(burst_depth(Some(40.0), 64, false), 64);
        assert_eq!(burst_depth(Some(1000.0), 2, false), 256);
        assert_eq!(burst_depth(Some(5.0), 4, true), 5);
        assert_eq!(burst_depth(Some(10.0), 4, true), LARGE_DEPTH_MAX);
        assert_eq!(burst_depth(Some(60.0), 12, true), 12);
        assert_eq!(burst_depth(None, 2, false), 2);
    }

    #[test]
    fn the_summary_gives_each_side_of_a_topic_and_warns_of_losses() {
        let count = |topic, inbound| TopicCount {
            topic,
            inbound,
            limited: false,
            hz: Some(100.0),
            published: 0,
            crossed: 0,
            received: 0,
            lost: 0,
            dropped: Vec::new(),
            invalid: 0,
        };
        let report = LinkReport {
            topics: vec![
                TopicCount {
                    published: 10,
                    crossed: 9,
                    dropped: vec![("recorder".into(), 0)],
                    ..count("robot/state", false)
                },
                TopicCount {
                    received: 7,
                    lost: 3,
                    dropped: vec![("recorder".into(), 2)],
                    ..count("sim/truth", true)
                },
            ],
            gaps: Vec::new(),
            relayed: 0,
            relays: vec![RelayCount {
                topic: "depth",
                inbound: false,
                samples: 11,
                bytes: 11_000_000,
                span_s: 1.0,
                mean_us: 12.34,
                p99_us: 56.78,
                invalid: 0,
            }],
        };
        let rows = report.rows();
        assert!(
            rows.contains("| link: times the other host was lost (total s) | 0 (0.0) |"),
            "{rows}"
        );
        assert!(
            rows.contains("| link: robot/state out, 100 Hz: published / crossed / dropped by local subscribers | 10 / 9 / 0 (recorder 0) |"),
            "{rows}"
        );
        assert!(
            rows.contains("| link: sim/truth in, 100 Hz: received / lost in the tunnel / dropped by local subscribers | 7 / 3 / 2 (recorder 2) |"),
            "{rows}"
        );
        assert!(
            rows.contains("| link: bytes crossed, depth (sent) | 11000000 (10.00 MB/s) |"),
            "{rows}"
        );
        assert!(
            rows.contains("| link: relay receive-and-copy, depth (sent), µs per sample mean / p99 | 12.3 / 56.8 |"),
            "{rows}"
        );
        let w = report.warnings();
        assert_eq!(w.len(), 3, "{w:?}");
        assert!(w[0].starts_with("robot/state: 1 of 10 "), "{w:?}");
        assert!(w[1].starts_with("sim/truth: 3 of 10 "), "{w:?}");
        assert!(
            w[2].starts_with("sim/truth: 2 samples dropped by the recorder"),
            "{w:?}"
        );
    }
}
