//! The tunnel's lifecycle as the launcher drives it: [`Link::start`] (configuration checks,
//! the tunnel thread), [`Link::wait_for_peer`], [`Link::quiesce`], [`Link::finish`].

use super::endpoints::{channel_qos, parse_endpoint, zenoh_config};
use super::throttle::relay_topic;
use super::tunnel;
use super::watch::RUN_TOPICS;
use super::{LinkArgs, LinkError, LinkReport};
use crate::config::Config;
use runtime::ports::{Overflow, PortsConfig};
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

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
    pub(super) namespace: String,
    pub(super) ports: PortsConfig,
    pub(super) zenoh: zenoh::Config,
    /// Full names of the services that cross.
    pub(super) allow: Vec<String>,
    /// Topics published on this host.
    pub(super) local: Vec<&'static str>,
    /// Rate-limited topics and their limits.
    pub(super) limited: Vec<(&'static str, f64)>,
    pub(super) poll_ms: u64,
    pub(super) linger: Duration,
    /// Each run topic's subscriber depth ([`super::watch::service_depths`]).
    pub(super) depths: Vec<(&'static str, usize)>,
    /// Each run topic's wall rate at the run's time scale ([`super::wall_hz`]), for the report.
    pub(super) rates: Vec<(&'static str, Option<f64>)>,
}

impl Spec {
    pub(super) fn limited_topics(&self) -> Vec<&'static str> {
        self.limited.iter().map(|(t, _)| *t).collect()
    }
}

/// State shared by the tunnel thread and the launcher.
#[derive(Debug)]
pub(crate) struct Shared {
    pub(super) stop: AtomicBool,
    /// The thread has its zenoh session and tunnel and entered its loop.
    pub(super) started: AtomicBool,
    /// Both hosts have bridged every topic.
    pub(super) ready: AtomicBool,
    /// The other host has been connected at least once.
    pub(super) peer_seen: AtomicBool,
    /// When a sample last came over the link, ns since `epoch` (0 = never).
    pub(super) last_inbound_ns: AtomicU64,
    pub(super) epoch: Instant,
}

impl Shared {
    pub(super) fn mark_inbound(&self) {
        let ns = self.epoch.elapsed().as_nanos().max(1) as u64;
        self.last_inbound_ns.store(ns, Ordering::Relaxed);
    }

    /// Time since a sample last came over the link (`None`: never).
    pub(super) fn since_inbound(&self) -> Option<Duration> {
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

/// A running tunnel (see the module docs).
#[derive(Debug)]
pub struct Link {
    shared: Arc<Shared>,
    thread: Option<JoinHandle<Result<LinkReport, LinkError>>>,
    quiet: Duration,
    drain: Duration,
}

impl Link {
    /// Start the tunnel for a run in `namespace` hosting `roles`, at `time_scale` simulated
    /// seconds per wall second (`--time-scale`: it sets each topic's wall rate, hence the
    /// depths the tunnel creates the services with).
    pub fn start(
        args: &LinkArgs,
        namespace: &str,
        roles: &[&'static str],
        cfg: &Config,
        time_scale: f64,
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
        let mut zenoh = zenoh_config(file.as_deref(), &endpoints)?;
        let local: Vec<&'static str> = RUN_TOPICS
            .into_iter()
            .filter(|t| {
                roles
                    .iter()
                    .any(|r| super::super::external::outputs(r).contains(t))
            })
            .collect();
        let limited: Vec<(&'static str, f64)> = RUN_TOPICS
            .into_iter()
            .filter_map(|t| cfg.link.limit(t).map(|hz| (t, hz)))
            .collect();
        let service = |t: &str| format!("{}/{namespace}/{t}", runtime::ports::SERVICE_ROOT);
        let allow = RUN_TOPICS
            .iter()
            .map(|t| match limited.iter().any(|(l, _)| l == t) {
                true => service(&relay_topic(t)),
                false => service(t),
            })
            .collect();
        // Small topics ahead of the large ones in zenoh's transmit queues (see channel_qos).
        let (mut small, mut high) = (Vec::new(), Vec::new());
        for t in RUN_TOPICS {
            if limited.iter().any(|(l, _)| *l == t) {
                continue;
            }
            if super::watch::is_small(t) {
                small.push(service(t));
            } else if [
                crate::topics::MAP,
                crate::topics::MAP_GRID,
                crate::topics::NAV_GRID,
            ]
            .contains(&t)
            {
                high.push(service(t));
            }
        }
        channel_qos(&mut zenoh, &small, &high)?;
        let spec = Spec {
            namespace: namespace.into(),
            ports: cfg.ports.clone(),
            zenoh,
            allow,
            local,
            limited,
            poll_ms: cfg.link.poll_ms,
            depths: super::watch::service_depths(cfg, time_scale),
            rates: RUN_TOPICS
                .iter()
                .map(|&t| (t, super::wall_hz(t, cfg, time_scale)))
                .collect(),
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
