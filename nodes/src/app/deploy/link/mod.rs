//! `vpsom run --nodes LIST --link ENDPOINT...`: this run's topics bridged to a run on another
//! host (same namespace) through iceoryx2's link tunnel (`iceoryx2-link` 0.10, a prototype
//! upstream) over zenoh. Not a transport of ours: the tunnel moves the samples, zenoh the bytes.
//!
//! # Files
//! | file | content |
//! |---|---|
//! | `mod.rs` | [`LinkArgs`], [`Link`] (start, wait for the peer, quiesce, finish), [`LinkReport`], [`LinkError`], [`check_overflow`] |
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

mod endpoints;
mod throttle;
mod tunnel;
mod watch;

pub use endpoints::{Direction, Endpoint, parse_endpoint, zenoh_config};
pub use throttle::relay_topic;
pub use tunnel::{ZenohLink, open_link};
pub use watch::{RUN_TOPICS, TopicCount};

use crate::config::Config;
use runtime::ports::{Overflow, PortsConfig};
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

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
}

/// A bridged topic must never make its publisher wait for the tunnel: `block` is refused.
pub fn check_overflow(ports: &PortsConfig) -> Result<(), LinkError> {
    for topic in RUN_TOPICS {
        if ports.topic(topic).overflow == Overflow::Block {
            let key = if ports
                .topics
                .get(topic)
                .is_some_and(|o| o.overflow.is_some())
            {
                format!("ports.topics.\"{topic}\".overflow")
            } else {
                "ports.overflow".to_string()
            };
            return Err(LinkError::Blocking {
                key,
                topic: topic.into(),
            });
        }
    }
    Ok(())
}

/// Everything the tunnel thread needs (plain data: the thread builds its own ports).
#[derive(Debug, Clone)]
pub(crate) struct Spec {
    namespace: String,
    ports: PortsConfig,
    zenoh: zenoh::Config,
    /// Full names of the services that cross.
    allow: Vec<String>,
    /// Topics published on this host.
    local: Vec<&'static str>,
    /// Rate-limited topics and their limits.
    limited: Vec<(&'static str, f64)>,
    poll_ms: u64,
    linger: Duration,
    /// `[link] buffer`.
    buffer: usize,
}

impl Spec {
    fn limited_topics(&self) -> Vec<&'static str> {
        self.limited.iter().map(|(t, _)| *t).collect()
    }
}

/// State shared by the tunnel thread and the launcher.
#[derive(Debug)]
pub(crate) struct Shared {
    stop: AtomicBool,
    /// The thread has its zenoh session and tunnel and entered its loop.
    started: AtomicBool,
    /// Both hosts have bridged every topic.
    ready: AtomicBool,
    /// The other host has been connected at least once.
    peer_seen: AtomicBool,
    /// When a sample last came over the link, ns since `epoch` (0 = never).
    last_inbound_ns: AtomicU64,
    epoch: Instant,
}

impl Shared {
    fn mark_inbound(&self) {
        let ns = self.epoch.elapsed().as_nanos().max(1) as u64;
        self.last_inbound_ns.store(ns, Ordering::Relaxed);
    }

    /// Time since a sample last came over the link (`None`: never).
    fn since_inbound(&self) -> Option<Duration> {
        match self.last_inbound_ns.load(Ordering::Relaxed) {
            0 => None,
            ns => Some(
                self.epoch
                    .elapsed()
                    .saturating_sub(Duration::from_nanos(ns)),
            ),
        }
    }
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

/// A running tunnel (see the module docs).
#[derive(Debug)]
pub struct Link {
    shared: Arc<Shared>,
    thread: Option<JoinHandle<Result<LinkReport, LinkError>>>,
    quiet: Duration,
    drain: Duration,
}

impl Link {
    /// Start the tunnel for a run in `namespace` hosting `roles`.
    pub fn start(
        args: &LinkArgs,
        namespace: &str,
        roles: &[&'static str],
        cfg: &Config,
    ) -> Result<Self, LinkError> {
        check_overflow(&cfg.ports)?;
        let endpoints = args
            .endpoints
            .iter()
            .map(|e| parse_endpoint(e))
            .collect::<Result<Vec<_>, _>>()?;
        let file = args.zenoh_config.clone().or_else(|| {
            (!cfg.link.zenoh_config.is_empty()).then(|| PathBuf::from(&cfg.link.zenoh_config))
        });
        let zenoh = zenoh_config(file.as_deref(), &endpoints)?;
        let local: Vec<&'static str> = RUN_TOPICS
            .into_iter()
            .filter(|t| {
                roles
                    .iter()
                    .any(|r| super::external::outputs(r).contains(t))
            })
            .collect();
        let limited: Vec<(&'static str, f64)> = RUN_TOPICS
            .into_iter()
            .filter_map(|t| cfg.link.max_hz.get(t).map(|&hz| (t, hz)))
            .filter(|&(_, hz)| hz > 0.0)
            .collect();
        let service = |t: &str| format!("{}/{namespace}/{t}", runtime::ports::SERVICE_ROOT);
        let allow = RUN_TOPICS
            .iter()
            .map(|t| match limited.iter().any(|(l, _)| l == t) {
                true => service(&relay_topic(t)),
                false => service(t),
            })
            .collect();
        let spec = Spec {
            namespace: namespace.into(),
            ports: cfg.ports.clone(),
            zenoh,
            allow,
            local,
            limited,
            poll_ms: cfg.link.poll_ms,
            buffer: cfg.link.buffer,
            linger: Duration::from_millis(cfg.link.linger_ms),
        };
        let shared = Arc::new(Shared {
            stop: AtomicBool::new(false),
            started: AtomicBool::new(false),
            ready: AtomicBool::new(false),
            peer_seen: AtomicBool::new(false),
            last_inbound_ns: AtomicU64::new(0),
            epoch: Instant::now(),
        });
        let s = shared.clone();
        let thread = std::thread::Builder::new()
            .name("link".into())
            .spawn(move || tunnel::run(spec, s))
            .map_err(|e| LinkError::Thread(e.to_string()))?;
        let link = Self {
            shared,
            thread: Some(thread),
            quiet: Duration::from_millis(cfg.link.quiet_ms),
            drain: Duration::from_secs_f64(cfg.link.drain_s),
        };
        // A tunnel that cannot start (a bad zenoh file, a port in use) fails the run here,
        // before any node starts.
        while !link.shared.started.load(Ordering::Relaxed) {
            if link.ended() {
                return Err(link
                    .finish()
                    .err()
                    .unwrap_or_else(|| LinkError::Thread("ended before it started".into())));
            }
            std::thread::sleep(Duration::from_millis(5));
        }
        eprintln!(
            "link: bridging {} topics of vpsom/{namespace}/ over zenoh ({})",
            RUN_TOPICS.len(),
            args.endpoints.join(", ")
        );
        Ok(link)
    }

    /// Whether the tunnel thread ended (it failed: see [`Link::finish`]).
    fn ended(&self) -> bool {
        self.thread.as_ref().is_none_or(|t| t.is_finished())
    }

    /// Wait up to `limit` until both hosts have bridged every topic (or `stop` is set, or the
    /// tunnel failed). Returns whether they have.
    pub fn wait_for_peer(&self, limit: Duration, stop: &AtomicBool) -> bool {
        let until = Instant::now() + limit;
        let mut said = false;
        while !self.shared.ready.load(Ordering::Relaxed) {
            if Instant::now() >= until || stop.load(Ordering::Relaxed) || self.ended() {
                if !limit.is_zero() {
                    eprintln!("link: the other host is not there yet; starting the nodes anyway");
                }
                return false;
            }
            if !said {
                eprintln!(
                    "link: waiting up to {:.0} s for the other host",
                    limit.as_secs_f64()
                );
                said = true;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        true
    }

    /// At the end of a run, before the nodes stop: wait until nothing has come over the link
    /// for `[link] quiet_ms` (at most `[link] drain_s`), so the other host's last samples reach
    /// the nodes here.
    pub fn quiesce(&self) {
        let until = Instant::now() + self.drain;
        while Instant::now() < until && !self.ended() {
            match self.shared.since_inbound() {
                Some(d) if d < self.quiet => std::thread::sleep(Duration::from_millis(20)),
                _ => return,
            }
        }
    }

    /// After the nodes stopped: keep the tunnel up for `[link] linger_ms`, close it, and
    /// report what it moved.
    pub fn finish(mut self) -> Result<LinkReport, LinkError> {
        self.shared.stop.store(true, Ordering::Relaxed);
        match self.thread.take().map(JoinHandle::join) {
            Some(Ok(r)) => r,
            Some(Err(_)) => Err(LinkError::Thread("panicked".into())),
            None => Ok(LinkReport::default()),
        }
    }
}

impl Drop for Link {
    fn drop(&mut self) {
        self.shared.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_blocking_topic_is_refused_naming_its_key() {
        let mut cfg = Config::builtin();
        cfg.ports.topics.entry("map".into()).or_default().overflow = Some(Overflow::Block);
        let e = check_overflow(&cfg.ports).unwrap_err().to_string();
        assert!(
            e.contains("ports.topics.\"map\".overflow") && e.contains("map"),
            "{e}"
        );
        let mut cfg = Config::builtin();
        cfg.ports.overflow = Overflow::Block;
        let e = check_overflow(&cfg.ports).unwrap_err().to_string();
        assert!(e.starts_with("ports.overflow"), "{e}");
        assert!(check_overflow(&Config::builtin().ports).is_ok());
    }
}
