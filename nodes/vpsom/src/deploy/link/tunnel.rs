//! The tunnel thread: iceoryx2-link's [`Link`] over a [`Tunnel`] on a [`ZenohCarrier`], driven
//! here (`discover()` every `poll_ms`, `propagate()` on every wake), plus the per-topic
//! [`Watch`], the rate-limit relays ([`Throttle`]) and the handshake with the other host's
//! tunnel (a zenoh liveliness token per tunnel that has bridged every topic).
//!
//! It wakes on the carrier's signal (data or offers from the other host), on a local publisher's
//! event (every topic published here), or after `poll_ms`. Nothing here can hold up a local
//! publisher: every bridged service overwrites (a `block` topic is refused before the thread
//! starts), so a tunnel that is slow, stalled or gone only loses its own samples.

use super::throttle::Throttle;
use super::watch::Watch;
use super::{LinkError, LinkReport, Shared, Spec};
use iceoryx2::prelude::*;
use iceoryx2_integrations_zenoh_link_carrier::ZenohCarrier;
use iceoryx2_link::Link;
use iceoryx2_link_tunnel::Tunnel;
use runtime::ports::PortContext;
use std::collections::{BTreeMap, HashSet};
use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};
use zenoh::Wait;

/// iceoryx2-link's `Link` over the zenoh tunnel, on `ipc` services.
pub type ZenohLink = Link<ipc::Service, Tunnel<ZenohCarrier>>;

/// Open a zenoh session with `zenoh` and, on it, a tunnel that bridges exactly the services
/// named in `allow` (full names), mirroring with `ports`' settings. The session is returned
/// too (the tunnel's carrier holds a clone of it) for the caller's own use of zenoh.
pub fn open_link(
    zenoh: zenoh::Config,
    allow: &[String],
    ports: &runtime::ports::PortsConfig,
) -> Result<(zenoh::Session, ZenohLink), LinkError> {
    let session = zenoh::open(zenoh)
        .wait()
        .map_err(|e| LinkError::Session(e.to_string()))?;
    let carrier = ZenohCarrier::open(session.clone())
        .map_err(|e| LinkError::Session(format!("the zenoh carrier: {e}")))?;
    let node = NodeBuilder::new()
        .config(&runtime::ports::iceoryx2_config())
        .create::<ipc::Service>()
        .map_err(|e| LinkError::Iceoryx(format!("the tunnel's node: {e:?}")))?;
    let filter: HashSet<String> = allow.iter().cloned().collect();
    let link = Link::new(node, Tunnel::new(carrier, &mirror_config(ports)))
        .with_filter(move |name: &ServiceName| filter.contains(name.as_str()));
    Ok((session, link))
}

/// Least interval between two log lines about one failing tunnel operation.
const ERROR_LOG_EVERY: Duration = Duration::from_secs(5);

/// Rate-limited log of a recurring tunnel error.
#[derive(Default)]
struct ErrorLog(BTreeMap<&'static str, (Instant, u64)>);

impl ErrorLog {
    fn log(&mut self, what: &'static str, e: &dyn std::fmt::Display, now: Instant) {
        let entry = self.0.entry(what).or_insert((now - ERROR_LOG_EVERY, 0));
        entry.1 += 1;
        if now.duration_since(entry.0) >= ERROR_LOG_EVERY {
            eprintln!("\nlink: {what} failed: {e} ({} times so far)", entry.1);
            entry.0 = now;
        }
    }
}

/// The iceoryx2 configuration the tunnel mirrors services with: the process's, with the
/// publish-subscribe defaults set to `[ports]` (every run topic is created beforehand with
/// its own settings, so this only matters for a service created in between).
fn mirror_config(ports: &runtime::ports::PortsConfig) -> iceoryx2::config::Config {
    let mut c = runtime::ports::iceoryx2_config();
    let p = &mut c.defaults.publish_subscribe;
    p.max_publishers = ports.max_publishers;
    p.max_subscribers = ports.max_subscribers;
    p.max_nodes = ports.max_nodes;
    p.subscriber_max_buffer_size = ports.subscriber_buffer;
    p.subscriber_max_borrowed_samples = ports.subscriber_max_borrowed;
    p.publisher_history_size = ports.history_size;
    p.enable_safe_overflow = true;
    c
}

/// Whether every allow-listed service of this side is bridged.
fn all_bridged(link: &ZenohLink, allow: &HashSet<String>) -> Result<bool, LinkError> {
    let mut found = 0usize;
    let mut bridged = 0usize;
    ipc::Service::list(&runtime::ports::iceoryx2_config(), |svc| {
        if allow.contains(svc.static_details.name().as_str()) {
            found += 1;
            bridged += usize::from(link.bridges().contains(svc.static_details.service_hash()));
        }
        CallbackProgression::Continue
    })
    .map_err(|e| LinkError::Iceoryx(format!("listing the services: {e:?}")))?;
    // Each topic is a publish-subscribe and an event service.
    Ok(found == 2 * allow.len() && bridged == found)
}

/// Run the tunnel until `shared.stop`, then for `linger` more; returns what it moved.
pub(super) fn run(spec: Spec, shared: Arc<Shared>) -> Result<LinkReport, LinkError> {
    let ports = super::watch::tunnel_ports(&spec.ports, &spec.depths);
    let ctx = PortContext::with_namespace(&ports, "link-ports", &spec.namespace)?;
    let rate = |topic: &str| spec.rates.iter().find(|r| r.0 == topic).and_then(|r| r.1);
    let mut watch = Watch::new(&ctx, &spec.local, &spec.limited_topics(), rate)?;
    let mut throttle = Throttle::new(&ctx, &spec.limited, &spec.local)?;

    let (session, mut link) = open_link(spec.zenoh.clone(), &spec.allow, &spec.ports)?;
    let allow: HashSet<String> = spec.allow.iter().cloned().collect();
    let wake = link
        .listener()
        .map_err(|e| LinkError::Iceoryx(format!("the tunnel's wake listener: {e}")))?;

    // Wake on every local publisher's event too, so outbound samples leave at once.
    let iox = runtime::ports::iceoryx2_config();
    let events_node = NodeBuilder::new()
        .config(&iox)
        .create::<ipc::Service>()
        .map_err(|e| LinkError::Iceoryx(format!("the tunnel's event node: {e:?}")))?;
    let mut listeners = Vec::new();
    for topic in &spec.local {
        let name = ServiceName::new(&ctx.service_name(topic))
            .map_err(|e| LinkError::Iceoryx(format!("service name of {topic}: {e:?}")))?;
        let service = events_node
            .service_builder(&name)
            .event()
            .open()
            .map_err(|e| LinkError::Iceoryx(format!("the event service of {topic}: {e:?}")))?;
        listeners.push(
            service
                .listener_builder()
                .create()
                .map_err(|e| LinkError::Iceoryx(format!("a listener on {topic}: {e:?}")))?,
        );
    }
    let waitset = WaitSetBuilder::new()
        .signal_handling_mode(SignalHandlingMode::Disabled)
        .create::<ipc::Service>()
        .map_err(|e| LinkError::Iceoryx(format!("the tunnel's wait set: {e:?}")))?;
    let mut guards = vec![
        waitset
            .attach_notification(&wake)
            .map_err(|e| LinkError::Iceoryx(format!("attaching the wake listener: {e:?}")))?,
    ];
    for l in &listeners {
        guards.push(
            waitset
                .attach_notification(l)
                .map_err(|e| LinkError::Iceoryx(format!("attaching a listener: {e:?}")))?,
        );
    }

    // The handshake: this side's token once every topic is bridged; the other side's tokens.
    let ready_prefix = format!("vpsom/{}/link-ready", spec.namespace);
    let peers = session
        .liveliness()
        .declare_subscriber(format!("{ready_prefix}/*"))
        .history(true)
        .wait()
        .map_err(|e| LinkError::Session(format!("the ready subscriber: {e}")))?;
    let own_key = format!("{ready_prefix}/{}", session.zid());
    let mut token = None;
    let mut remote_ready: HashSet<String> = HashSet::new();

    shared.started.store(true, Ordering::Relaxed);
    let poll = Duration::from_millis(spec.poll_ms);
    let mut errors = ErrorLog::default();
    let mut last_discover: Option<Instant> = None;
    let mut peer_lost_at: Option<Instant> = None;
    let mut gaps: Vec<Duration> = Vec::new();
    let mut stop_at: Option<Instant> = None;
    loop {
        let now = Instant::now();
        if stop_at.is_none() && shared.stop.load(Ordering::Relaxed) {
            stop_at = Some(now + spec.linger);
        }
        if stop_at.is_some_and(|t| now >= t) {
            break;
        }
        let timeout = throttle
            .next_due()
            .map_or(poll, |t| t.saturating_duration_since(now).min(poll))
            .max(Duration::from_millis(1));
        if let Err(e) =
            waitset.wait_and_process_once_with_timeout(|_| CallbackProgression::Continue, timeout)
        {
            errors.log("waiting", &format!("{e:?}"), now);
        }
        let _ = wake.try_wait(|_| {});
        for l in &listeners {
            let _ = l.try_wait(|_| {});
        }
        let now = Instant::now();
        if last_discover.is_none_or(|t| now.duration_since(t) >= poll) {
            last_discover = Some(now);
            if let Err(e) = link.discover() {
                errors.log("discovery", &e, now);
            }
            // Handshake and peer presence, at the discovery period.
            while let Ok(Some(s)) = peers.try_recv() {
                let key = s.key_expr().as_str().to_string();
                match s.kind() {
                    zenoh::sample::SampleKind::Put if key != own_key => {
                        remote_ready.insert(key);
                    }
                    zenoh::sample::SampleKind::Delete => {
                        remote_ready.remove(&key);
                    }
                    _ => {}
                }
            }
            let connected = session.info().peers_zid().wait().next().is_some();
            match (connected, peer_lost_at) {
                (false, None) if shared.peer_seen.load(Ordering::Relaxed) => {
                    eprintln!(
                        "\nlink: lost the other host; local nodes go on, samples for it are dropped"
                    );
                    peer_lost_at = Some(now);
                }
                (true, Some(t)) => {
                    let gap = now.duration_since(t);
                    eprintln!(
                        "\nlink: the other host is back after {:.1} s",
                        gap.as_secs_f64()
                    );
                    gaps.push(gap);
                    peer_lost_at = None;
                }
                _ => {}
            }
            if connected {
                shared.peer_seen.store(true, Ordering::Relaxed);
            }
            if token.is_none() && all_bridged(&link, &allow)? {
                token = Some(
                    session
                        .liveliness()
                        .declare_token(own_key.as_str())
                        .wait()
                        .map_err(|e| LinkError::Session(format!("the ready token: {e}")))?,
                );
            }
            let ready = token.is_some() && !remote_ready.is_empty();
            if ready && !shared.ready.swap(true, Ordering::Relaxed) {
                eprintln!("link: every topic is bridged on both hosts");
            }
        }
        if let Err(e) = link.propagate() {
            errors.log("propagation", &e, now);
        }
        if let Err(e) = throttle.poll(now) {
            errors.log("rate-limit relay", &e, now);
        }
        match watch.poll(now) {
            Ok(0) => {}
            Ok(_) => shared.mark_inbound(),
            Err(e) => errors.log("watching the topics", &e, now),
        }
    }
    if let Some(t) = peer_lost_at {
        gaps.push(t.elapsed());
    }
    // What arrived since the last pass (the nodes' final heartbeats among it).
    if let Err(e) = watch.poll(Instant::now()) {
        errors.log("watching the topics", &e, Instant::now());
    }
    drop(guards);
    drop(token);
    drop(link);
    // Close the session so the other host sees this one leave at once.
    if let Err(e) = session.close().wait() {
        eprintln!("link: closing the zenoh session: {e}");
    }
    let report = LinkReport {
        topics: watch.counts(|t| throttle.copied_of(t)),
        gaps,
        relayed: throttle.copied(),
        relays: throttle.counts(),
    };
    report.warn();
    Ok(report)
}
