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
//! | `watch.rs` | per topic: samples that crossed, sequence numbers lost, invalid samples ([`RUN_TOPICS`]) |
//! | `throttle.rs` | `[link.max_hz]`: large topics cross through a relay topic `link/<topic>` at a limited rate |
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
/// process off the CPU for a few hundred ms (the station recorder's losses of issue #35).
pub const STALL_S: f64 = 0.5;

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
    Some(match cfg.link.max_hz.get(topic) {
        Some(&limit) if limit > 0.0 => hz.min(limit),
        _ => hz,
    })
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
}

impl LinkReport {
    /// Table rows for the run's summary.
    pub fn rows(&self) -> String {
        let mut t = String::new();
        let total: f64 = self.gaps.iter().map(Duration::as_secs_f64).sum();
        t += &format!(
            "| link: times the other host was lost (total s) | {} ({total:.1}) |\n",
            self.gaps.len()
        );
        for c in &self.topics {
            let dir = if c.inbound {
                "received"
            } else {
                "published here"
            };
            t += &format!("| link: {} samples {dir} | {} |\n", c.topic, c.samples);
            if c.inbound {
                t += &format!(
                    "| link: {} samples lost across the link | {} |\n",
                    c.topic, c.lost
                );
            }
            if c.invalid > 0 {
                t += &format!(
                    "| link: {} invalid samples dropped | {} |\n",
                    c.topic, c.invalid
                );
            }
        }
        t
    }
}

/// What one topic moved, for the report.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TopicCount {
    /// Topic.
    pub topic: &'static str,
    /// `true`: came from the other host.
    pub inbound: bool,
    /// Samples seen here (inbound: received over the link; outbound: published here).
    pub samples: u64,
    /// Inbound: sequence numbers that never arrived (0 for rate-limited topics).
    pub lost: u64,
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
