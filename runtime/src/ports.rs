//! Typed zero-copy ports over iceoryx2 (`ipc::Service`).
//!
//! A [`PortContext`] owns one iceoryx2 node and names every service `vpsom/<namespace>/<topic>`,
//! so two concurrent runs with different namespaces never see each other. Each topic is a
//! publish-subscribe service paired with an event service of the same name: the
//! [`Publisher`] notifies after every send, and [`Subscriber::wait`] blocks on that event with a
//! timeout instead of polling.
//!
//! Zero copy: [`Publisher::loan`] hands out a sample that lives in shared memory and has been
//! zero-filled **in place** (a `DepthFrame` is 600 KB; it is never built on the stack), or, for
//! [`AnyBitPattern`] messages whose producer overwrites everything it publishes,
//! [`Publisher::loan_reused`] hands it out as it is (an earlier sample's bytes, no fill); the
//! caller fills it through `DerefMut` and calls [`Loan::send`], which stamps the [`Header`]
//! (per-publisher sequence number starting at 1, caller's time stamps). A subscriber reads the
//! same memory through a borrowed [`Received`] sample (`Deref<Target = T>`).
//!
//! iceoryx2 configuration: the iceoryx2 `Config` is built **in code** from its built-in defaults
//! and handed to the node explicitly, so iceoryx2 never reads `config/iceoryx2.toml` (nor the
//! user's or system's copy): a stray file cannot change behaviour silently. Every service
//! setting that matters (history, buffers, port counts, overflow) comes from `[ports]`.
//!
//! Ports are not `Send` (iceoryx2's `ipc::Service` is single-threaded): create the context and
//! its ports on the thread that uses them (the periodic executor's `make_body` closure runs on
//! the executor thread for exactly this reason).

use crate::config::{Checker, ConfigError};
use iceoryx2::node::Node;
use iceoryx2::port::listener::Listener;
use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::{BackpressureAction, BackpressureInfo};
use iceoryx2::prelude::{
    BackpressureStrategy, NodeBuilder, NodeName, PortFactory as _, ServiceName, ipc,
};
use iceoryx2::sample::Sample;
use iceoryx2::sample_mut::SampleMut;
use iceoryx2::sample_mut_uninit::SampleMutUninit;
use iceoryx2::service::port_factory::{event, publish_subscribe};
use serde::Deserialize;
use shm_types::{AnyBitPattern, Header, Message};
use std::cell::Cell;
use std::collections::BTreeMap;
use std::fmt;
use std::mem::MaybeUninit;
use std::ops::{Deref, DerefMut};
use std::time::{Duration, Instant};

/// First element of every service name.
pub const SERVICE_ROOT: &str = "vpsom";

/// What a publisher does when a subscriber's buffer is full.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Overflow {
    /// Latest wins: the oldest unread sample in the subscriber's buffer is replaced; the
    /// publisher never blocks (real-time producers, sensor streams).
    Overwrite,
    /// Backpressure: the publisher retries until the subscriber has room (or `block_timeout_ms`
    /// passes, then `send` fails); nothing is lost (recording, tests). A subscriber attaches its
    /// end of the connection on its first `receive`/`wait`; until then a full buffer drops
    /// (iceoryx2 refuses to block on a receiver that is not attached).
    Block,
    /// The new sample is not delivered to a full subscriber; the publisher never blocks.
    Discard,
}

/// Declares every per-topic service setting once, as `field: type`, and derives from that list
/// [`TopicSettings`] (resolved values), [`TopicOverride`] (the same keys, each optional),
/// [`PortsConfig`] (`namespace`, the same keys as every topic's defaults, and `topics`) and the
/// merge `PortsConfig::settings_with`. The defaults are the `[ports]` section of
/// `config/default.toml` (`PortsConfig::default()`).
macro_rules! topic_settings {
    ($( $(#[doc = $doc:literal])+ $field:ident: $ty:ty, )+) => {
        /// Settings of one topic's services (the `[ports]` defaults merged with a per-topic
        /// override).
        #[derive(Debug, Clone, Copy, PartialEq, Eq)]
        pub struct TopicSettings {
            $( $(#[doc = $doc])+ pub $field: $ty, )+
        }

        /// A per-topic override in `[ports.topics.<topic>]`; every key is optional.
        #[derive(Debug, Clone, Default, PartialEq, Eq, Deserialize)]
        #[serde(deny_unknown_fields, default)]
        pub struct TopicOverride {
            $(
                #[doc = concat!("See [`TopicSettings::", stringify!($field), "`].")]
                pub $field: Option<$ty>,
            )+
        }

        /// `[ports]` section: iceoryx2 service settings shared by every topic, plus per-topic
        /// overrides.
        #[derive(Debug, Clone, PartialEq, Eq, Deserialize)]
        #[serde(deny_unknown_fields)]
        pub struct PortsConfig {
            /// Middle part of every service name, `vpsom/<namespace>/<topic>`: runs with
            /// different namespaces never collide. `[A-Za-z0-9_-]`, 1..=48 characters.
            pub namespace: String,
            $(
                #[doc = concat!("See [`TopicSettings::", stringify!($field), "`].")]
                pub $field: $ty,
            )+
            /// Per-topic overrides, keyed by topic name.
            pub topics: BTreeMap<String, TopicOverride>,
        }

        impl PortsConfig {
            /// The defaults merged with `o`.
            fn settings_with(&self, o: &TopicOverride) -> TopicSettings {
                TopicSettings {
                    $( $field: o.$field.unwrap_or(self.$field), )+
                }
            }
        }
    };
}

topic_settings! {
    /// Samples a late-joining subscriber receives on connection.
    history_size: usize,
    /// Unread samples a subscriber can buffer.
    subscriber_buffer: usize,
    /// Samples a subscriber can hold borrowed at once.
    subscriber_max_borrowed: usize,
    /// Samples a publisher can hold loaned at once.
    publisher_max_loaned: usize,
    /// Publishers per topic.
    max_publishers: usize,
    /// Subscribers per topic.
    max_subscribers: usize,
    /// Nodes (processes) that may open the topic.
    max_nodes: usize,
    /// Full-buffer behaviour.
    overflow: Overflow,
    /// With [`Overflow::Block`]: give up after this long (ms).
    block_timeout_ms: u64,
}

impl Default for PortsConfig {
    /// The `[ports]` section of the built-in `config/default.toml`, with its per-topic
    /// overrides (`[ports.topics.<topic>]`).
    fn default() -> Self {
        crate::config::DEFAULTS.section("ports")
    }
}

impl PortsConfig {
    /// Range-check.
    pub fn validate(&self, c: &Checker) -> Result<(), ConfigError> {
        check_namespace(&self.namespace)
            .map_err(|why| c.range("ports.namespace", &self.namespace, why))?;
        self.check_settings(c, "ports", &self.settings_with(&TopicOverride::default()))?;
        for (topic, o) in &self.topics {
            check_topic(topic).map_err(|why| c.range("ports.topics", topic, why))?;
            self.check_settings(c, &format!("ports.topics.{topic}"), &self.settings_with(o))?;
        }
        Ok(())
    }

    fn check_settings(&self, c: &Checker, at: &str, s: &TopicSettings) -> Result<(), ConfigError> {
        c.count(&format!("{at}.history_size"), s.history_size, 0, 64)?;
        c.count(
            &format!("{at}.subscriber_buffer"),
            s.subscriber_buffer,
            1,
            256,
        )?;
        c.count(
            &format!("{at}.subscriber_max_borrowed"),
            s.subscriber_max_borrowed,
            1,
            64,
        )?;
        c.count(
            &format!("{at}.publisher_max_loaned"),
            s.publisher_max_loaned,
            1,
            64,
        )?;
        c.count(&format!("{at}.max_publishers"), s.max_publishers, 1, 64)?;
        c.count(&format!("{at}.max_subscribers"), s.max_subscribers, 1, 64)?;
        c.count(&format!("{at}.max_nodes"), s.max_nodes, 2, 256)?;
        c.require(
            s.block_timeout_ms >= 1 && s.block_timeout_ms <= 600_000,
            &format!("{at}.block_timeout_ms"),
            s.block_timeout_ms,
            "must be in [1, 600000]",
        )
    }

    /// The settings for `topic`: the defaults merged with `[ports.topics.<topic>]` if present.
    pub fn topic(&self, topic: &str) -> TopicSettings {
        match self.topics.get(topic) {
            Some(o) => self.settings_with(o),
            None => self.settings_with(&TopicOverride::default()),
        }
    }
}

/// `Ok` if `s` is usable as one segment of a service name.
fn check_namespace(s: &str) -> Result<(), &'static str> {
    let ok_chars = s
        .chars()
        .all(|ch| ch.is_ascii_alphanumeric() || ch == '_' || ch == '-');
    if s.is_empty() || s.len() > 48 || !ok_chars {
        Err("must be 1..=48 characters of [A-Za-z0-9_-]")
    } else {
        Ok(())
    }
}

/// A topic name: like a namespace, plus `/` between non-empty parts (e.g. `robot/state`).
fn check_topic(s: &str) -> Result<(), &'static str> {
    if s.len() <= 96 && s.split('/').all(|part| check_namespace(part).is_ok()) {
        Ok(())
    } else {
        Err("must be 1..=96 characters of [A-Za-z0-9_-] parts joined by '/'")
    }
}

/// Why a port operation failed. Every variant names the service (or node) and carries
/// iceoryx2's reason.
#[derive(Debug, thiserror::Error)]
pub enum PortError {
    /// A namespace, topic or node name is not usable.
    #[error("invalid name {name:?}: {reason}")]
    Name {
        /// The name.
        name: String,
        /// Why.
        reason: String,
    },
    /// The iceoryx2 node could not be created (e.g. no shared memory, no permission).
    #[error("cannot create iceoryx2 node {node:?}: {reason}")]
    Node {
        /// The node name.
        node: String,
        /// iceoryx2's reason.
        reason: String,
    },
    /// The publish-subscribe or event service could not be opened or created (e.g. it exists
    /// with another payload type or incompatible settings).
    #[error("service {service}: cannot open or create the {pattern} service: {reason}")]
    Service {
        /// Full service name.
        service: String,
        /// `"publish-subscribe"`, `"event"` or `"any"` (listing).
        pattern: &'static str,
        /// iceoryx2's reason.
        reason: String,
    },
    /// A port could not be created (e.g. more publishers or subscribers than configured).
    #[error("service {service}: cannot create {port}: {reason}")]
    Port {
        /// Full service name.
        service: String,
        /// `"publisher"`, `"subscriber"`, `"notifier"` or `"listener"`.
        port: &'static str,
        /// iceoryx2's reason.
        reason: String,
    },
    /// No sample could be loaned (all loaned or still held by subscribers).
    #[error("service {service}: cannot loan a sample: {reason}")]
    Loan {
        /// Full service name.
        service: String,
        /// iceoryx2's reason.
        reason: String,
    },
    /// Sending failed (with [`Overflow::Block`]: a subscriber stayed full past the timeout).
    #[error("service {service}: send failed: {reason}")]
    Send {
        /// Full service name.
        service: String,
        /// iceoryx2's reason.
        reason: String,
    },
    /// The data was sent but the paired event could not be signalled.
    #[error("service {service}: notify failed: {reason}")]
    Notify {
        /// Full service name.
        service: String,
        /// iceoryx2's reason.
        reason: String,
    },
    /// Receiving failed (e.g. a corrupted connection or too many borrowed samples).
    #[error("service {service}: receive failed: {reason}")]
    Receive {
        /// Full service name.
        service: String,
        /// iceoryx2's reason.
        reason: String,
    },
    /// Waiting on the paired event failed (e.g. interrupted by a termination signal).
    #[error("service {service}: wait failed: {reason}")]
    Wait {
        /// Full service name.
        service: String,
        /// iceoryx2's reason.
        reason: String,
    },
}

/// The producer's time stamps written into a message [`Header`] on send.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Stamp {
    /// Producer's monotonic clock when the data was produced, ns (`Header::stamp_ns`).
    pub source_ns: u64,
    /// Simulation (or robot) time the data refers to, ns (`Header::sim_time_ns`).
    pub sim_ns: u64,
}

/// One iceoryx2 node plus the naming and settings of a run's services.
pub struct PortContext {
    node: Node<ipc::Service>,
    config: PortsConfig,
    namespace: String,
    node_name: String,
}

impl fmt::Debug for PortContext {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("PortContext")
            .field("node", &self.node_name)
            .field("namespace", &self.namespace)
            .finish_non_exhaustive()
    }
}

/// The iceoryx2 configuration used by every node we create: iceoryx2's built-in defaults, never
/// a file (see the module docs).
pub fn iceoryx2_config() -> iceoryx2::config::Config {
    iceoryx2::config::Config::default()
}

/// Names of the existing services (any process) under `vpsom/<namespace>/`, sorted; each topic
/// appears twice (publish-subscribe and event). Used to check that a run cleaned up.
pub fn list_services(namespace: &str) -> Result<Vec<String>, PortError> {
    use iceoryx2::prelude::{CallbackProgression, Service as _};
    let prefix = format!("{SERVICE_ROOT}/{namespace}/");
    let mut names = Vec::new();
    ipc::Service::list(&iceoryx2_config(), |svc| {
        let name = svc.static_details.name().as_str();
        if name.starts_with(&prefix) {
            names.push(name.to_string());
        }
        CallbackProgression::Continue
    })
    .map_err(|e| PortError::Service {
        service: prefix.clone(),
        pattern: "any",
        reason: format!("cannot list services: {e:?}"),
    })?;
    names.sort();
    Ok(names)
}

impl PortContext {
    /// A node named `node_name` using `config.namespace`.
    pub fn new(config: &PortsConfig, node_name: &str) -> Result<Self, PortError> {
        Self::with_namespace(config, node_name, &config.namespace)
    }

    /// A node named `node_name` whose services live under `vpsom/<namespace>/`.
    pub fn with_namespace(
        config: &PortsConfig,
        node_name: &str,
        namespace: &str,
    ) -> Result<Self, PortError> {
        check_namespace(namespace).map_err(|why| PortError::Name {
            name: namespace.into(),
            reason: why.into(),
        })?;
        let name = NodeName::new(node_name).map_err(|e| PortError::Name {
            name: node_name.into(),
            reason: format!("{e:?}"),
        })?;
        let node = NodeBuilder::new()
            .name(&name)
            .config(&iceoryx2_config())
            .create::<ipc::Service>()
            .map_err(|e| PortError::Node {
                node: node_name.into(),
                reason: e.to_string(),
            })?;
        Ok(Self {
            node,
            config: config.clone(),
            namespace: namespace.into(),
            node_name: node_name.into(),
        })
    }

    /// The namespace (`vpsom/<namespace>/<topic>`).
    pub fn namespace(&self) -> &str {
        &self.namespace
    }

    /// The settings in force.
    pub fn config(&self) -> &PortsConfig {
        &self.config
    }

    /// The iceoryx2 node (for `Node::list`, dead-node cleanup, signal handling).
    pub fn node(&self) -> &Node<ipc::Service> {
        &self.node
    }

    /// Full service name of `topic`.
    pub fn service_name(&self, topic: &str) -> String {
        format!("{SERVICE_ROOT}/{}/{topic}", self.namespace)
    }

    fn services<T: Message>(&self, topic: &str) -> Result<Services<T>, PortError> {
        check_topic(topic).map_err(|why| PortError::Name {
            name: topic.into(),
            reason: why.into(),
        })?;
        let s = self.config.topic(topic);
        let full = self.service_name(topic);
        let name = ServiceName::new(&full).map_err(|e| PortError::Name {
            name: full.clone(),
            reason: format!("{e:?}"),
        })?;
        let pubsub = self
            .node
            .service_builder(&name)
            .publish_subscribe::<T>()
            .history_size(s.history_size)
            .subscriber_max_buffer_size(s.subscriber_buffer)
            .subscriber_max_borrowed_samples(s.subscriber_max_borrowed)
            .max_publishers(s.max_publishers)
            .max_subscribers(s.max_subscribers)
            .max_nodes(s.max_nodes)
            .enable_safe_overflow(s.overflow == Overflow::Overwrite)
            .open_or_create()
            .map_err(|e| PortError::Service {
                service: full.clone(),
                pattern: "publish-subscribe",
                reason: e.to_string(),
            })?;
        let event = self
            .node
            .service_builder(&name)
            .event()
            .max_notifiers(s.max_publishers)
            .max_listeners(s.max_subscribers)
            .max_nodes(s.max_nodes)
            .open_or_create()
            .map_err(|e| PortError::Service {
                service: full.clone(),
                pattern: "event",
                reason: e.to_string(),
            })?;
        Ok(Services {
            pubsub,
            event,
            settings: s,
            name: full,
        })
    }

    /// A publisher on `topic` (creates the services if they do not exist yet).
    pub fn publisher<T: Message>(&self, topic: &str) -> Result<Publisher<T>, PortError> {
        let sv = self.services::<T>(topic)?;
        let s = sv.settings;
        let mut builder = sv
            .pubsub
            .publisher_builder()
            .max_loaned_samples(s.publisher_max_loaned);
        builder = match s.overflow {
            Overflow::Overwrite => builder,
            Overflow::Discard => builder.backpressure_strategy(BackpressureStrategy::DiscardData),
            Overflow::Block => {
                let timeout = Duration::from_millis(s.block_timeout_ms);
                builder
                    .backpressure_strategy(BackpressureStrategy::RetryUntilDelivered)
                    .set_backpressure_handler(move |info: &BackpressureInfo| {
                        if info.elapsed_time >= timeout {
                            BackpressureAction::DiscardDataAndFail
                        } else {
                            BackpressureAction::Retry
                        }
                    })
            }
        };
        let port = builder.create().map_err(|e| PortError::Port {
            service: sv.name.clone(),
            port: "publisher",
            reason: e.to_string(),
        })?;
        let notifier = sv
            .event
            .notifier_builder()
            .create()
            .map_err(|e| PortError::Port {
                service: sv.name.clone(),
                port: "notifier",
                reason: e.to_string(),
            })?;
        Ok(Publisher {
            port,
            notifier,
            services: sv,
            seq: Cell::new(0),
        })
    }

    /// A subscriber on `topic` (creates the services if they do not exist yet).
    pub fn subscriber<T: Message>(&self, topic: &str) -> Result<Subscriber<T>, PortError> {
        let sv = self.services::<T>(topic)?;
        let port = sv
            .pubsub
            .subscriber_builder()
            .buffer_size(sv.settings.subscriber_buffer)
            .create()
            .map_err(|e| PortError::Port {
                service: sv.name.clone(),
                port: "subscriber",
                reason: e.to_string(),
            })?;
        let listener = sv
            .event
            .listener_builder()
            .create()
            .map_err(|e| PortError::Port {
                service: sv.name.clone(),
                port: "listener",
                reason: e.to_string(),
            })?;
        Ok(Subscriber {
            port,
            listener,
            services: sv,
            last_seq: Cell::new(None),
            gaps: Cell::new(0),
        })
    }
}

/// The two services of one topic.
struct Services<T: Message> {
    pubsub: publish_subscribe::PortFactory<ipc::Service, T, ()>,
    event: event::PortFactory<ipc::Service>,
    settings: TopicSettings,
    name: String,
}

/// Sends `T` on one topic, zero-copy.
pub struct Publisher<T: Message> {
    port: iceoryx2::port::publisher::Publisher<ipc::Service, T, ()>,
    notifier: Notifier<ipc::Service>,
    services: Services<T>,
    seq: Cell<u64>,
}

impl<T: Message> fmt::Debug for Publisher<T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Publisher")
            .field("service", &self.services.name)
            .field("seq", &self.seq.get())
            .finish_non_exhaustive()
    }
}

impl<T: Message> Publisher<T> {
    /// A zero-filled sample in shared memory for the caller to fill in place, then
    /// [`Loan::send`]. Dropping the loan without sending returns the memory.
    pub fn loan(&self) -> Result<Loan<'_, T>, PortError> {
        Ok(Loan {
            sample: shm_types::init_zeroed(self.loan_uninit()?),
            publisher: self,
        })
    }

    fn loan_uninit(&self) -> Result<SampleMutUninit<ipc::Service, MaybeUninit<T>, ()>, PortError> {
        self.port.loan_uninit().map_err(|e| PortError::Loan {
            service: self.services.name.clone(),
            reason: e.to_string(),
        })
    }

    /// Full service name.
    pub fn service_name(&self) -> &str {
        &self.services.name
    }

    /// The settings of this topic.
    pub fn settings(&self) -> &TopicSettings {
        &self.services.settings
    }

    /// Sequence number of the last sample sent (0 before the first).
    pub fn last_seq(&self) -> u64 {
        self.seq.get()
    }

    /// Subscribers currently connected to the topic (any process).
    pub fn subscriber_count(&self) -> usize {
        self.services
            .pubsub
            .dynamic_config()
            .number_of_subscribers()
    }
}

impl<T: Message + AnyBitPattern> Publisher<T> {
    /// Like [`Publisher::loan`] but **not** zero-filled: the sample holds whatever its slot of
    /// this publisher's shared memory last held, i.e. an earlier sample of this topic (possibly
    /// a partly written one that was dropped unsent) or zeros. For producers that overwrite every
    /// field they publish: it saves the fill (600 KB for a `DepthFrame`). Whatever the producer
    /// leaves unwritten is stale, so write every field a consumer reads — e.g. all
    /// `width × height` pixels; entries beyond the used part of an array may stay stale only if
    /// consumers never read them.
    pub fn loan_reused(&self) -> Result<Loan<'_, T>, PortError> {
        Ok(Loan {
            sample: shm_types::init_reused(self.loan_uninit()?),
            publisher: self,
        })
    }
}

/// A loaned sample being filled by the producer (zero-filled, or stale with
/// [`Publisher::loan_reused`]). `DerefMut<Target = T>`.
pub struct Loan<'p, T: Message> {
    sample: SampleMut<ipc::Service, T, ()>,
    publisher: &'p Publisher<T>,
}

impl<T: Message> fmt::Debug for Loan<'_, T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Loan")
            .field("service", &self.publisher.services.name)
            .finish_non_exhaustive()
    }
}

impl<T: Message> Deref for Loan<'_, T> {
    type Target = T;
    fn deref(&self) -> &T {
        self.sample.payload()
    }
}

impl<T: Message> DerefMut for Loan<'_, T> {
    fn deref_mut(&mut self) -> &mut T {
        self.sample.payload_mut()
    }
}

/// What [`Loan::send`] did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Sent {
    /// Sequence number written into the header.
    pub seq: u64,
    /// Subscribers the sample was delivered to.
    pub subscribers: usize,
}

impl<T: Message> Loan<'_, T> {
    /// Stamp the header (next sequence number, `stamp`), deliver the sample to every
    /// subscriber and signal the paired event. Overwrites whatever the caller put in the header.
    pub fn send(mut self, stamp: Stamp) -> Result<Sent, PortError> {
        let p = self.publisher;
        let seq = p.seq.get() + 1;
        *self.sample.payload_mut().header_mut() = Header {
            seq,
            stamp_ns: stamp.source_ns,
            sim_time_ns: stamp.sim_ns,
        };
        let subscribers = self.sample.send().map_err(|e| PortError::Send {
            service: p.services.name.clone(),
            reason: e.to_string(),
        })?;
        p.seq.set(seq);
        p.notifier.notify().map_err(|e| PortError::Notify {
            service: p.services.name.clone(),
            reason: e.to_string(),
        })?;
        Ok(Sent { seq, subscribers })
    }
}

/// Receives `T` on one topic, zero-copy.
pub struct Subscriber<T: Message> {
    port: iceoryx2::port::subscriber::Subscriber<ipc::Service, T, ()>,
    listener: Listener<ipc::Service>,
    services: Services<T>,
    last_seq: Cell<Option<u64>>,
    gaps: Cell<u64>,
}

impl<T: Message> fmt::Debug for Subscriber<T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Subscriber")
            .field("service", &self.services.name)
            .field("gaps", &self.gaps.get())
            .finish_non_exhaustive()
    }
}

/// A sample borrowed from shared memory (`Deref<Target = T>`); dropping it returns it.
pub struct Received<T: Message> {
    sample: Sample<ipc::Service, T, ()>,
}

impl<T: Message> fmt::Debug for Received<T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Received")
            .field("header", self.header())
            .finish_non_exhaustive()
    }
}

impl<T: Message> Deref for Received<T> {
    type Target = T;
    fn deref(&self) -> &T {
        self.sample.payload()
    }
}

impl<T: Message> Received<T> {
    /// The message header.
    pub fn header(&self) -> &Header {
        self.sample.payload().header()
    }
}

impl<T: Message> Subscriber<T> {
    /// The oldest unread sample, if any (never blocks).
    pub fn receive(&self) -> Result<Option<Received<T>>, PortError> {
        let sample = self.port.receive().map_err(|e| PortError::Receive {
            service: self.services.name.clone(),
            reason: e.to_string(),
        })?;
        Ok(sample.map(|sample| {
            let r = Received { sample };
            self.track(r.header().seq);
            r
        }))
    }

    /// Drain the buffer and return only the newest sample, if any (never blocks).
    pub fn latest(&self) -> Result<Option<Received<T>>, PortError> {
        let mut newest = None;
        while let Some(s) = self.receive()? {
            newest = Some(s); // the previous one is dropped (returned) here
        }
        Ok(newest)
    }

    /// The oldest unread sample, blocking on the paired event for up to `timeout`.
    /// `Ok(None)` on timeout.
    pub fn wait(&self, timeout: Duration) -> Result<Option<Received<T>>, PortError> {
        let deadline = Instant::now() + timeout;
        loop {
            if let Some(s) = self.receive()? {
                return Ok(Some(s));
            }
            let now = Instant::now();
            if now >= deadline {
                return Ok(None);
            }
            self.listener
                .timed_wait(|_| {}, deadline - now)
                .map_err(|e| PortError::Wait {
                    service: self.services.name.clone(),
                    reason: format!("{e:?}"),
                })?;
        }
    }

    /// Like [`Subscriber::wait`] but drains the buffer and returns the newest sample.
    pub fn wait_latest(&self, timeout: Duration) -> Result<Option<Received<T>>, PortError> {
        match self.wait(timeout)? {
            None => Ok(None),
            Some(first) => Ok(Some(self.latest()?.unwrap_or(first))),
        }
    }

    /// `true` if an unread sample is buffered.
    pub fn has_samples(&self) -> Result<bool, PortError> {
        self.port.has_samples().map_err(|e| PortError::Receive {
            service: self.services.name.clone(),
            reason: format!("{e:?}"),
        })
    }

    /// Sequence numbers skipped between consecutive received samples (samples lost to
    /// overwrite or discard; samples drained by [`Subscriber::latest`] were received, so they
    /// are not gaps). Meaningful with a single publisher; a sequence restart is not counted.
    pub fn gaps(&self) -> u64 {
        self.gaps.get()
    }

    /// Sequence number of the last sample received, if any.
    pub fn last_seq(&self) -> Option<u64> {
        self.last_seq.get()
    }

    /// Full service name.
    pub fn service_name(&self) -> &str {
        &self.services.name
    }

    /// Connect to every publisher of the topic now (map their data segments) instead of
    /// lazily on the next receive; returns the publisher count. A real-time consumer calls this
    /// before its first cycle so that cycle does not pay for mapping (and, under `mlockall`,
    /// faulting in) a publisher's shared memory.
    pub fn connect(&self) -> Result<usize, PortError> {
        use iceoryx2::port::update_connections::UpdateConnections;
        self.port
            .update_connections()
            .map_err(|e| PortError::Receive {
                service: self.services.name.clone(),
                reason: format!("connecting to publishers: {e:?}"),
            })?;
        Ok(self.publisher_count())
    }

    /// Publishers currently connected to the topic (any process).
    pub fn publisher_count(&self) -> usize {
        self.services.pubsub.dynamic_config().number_of_publishers()
    }

    fn track(&self, seq: u64) {
        if let Some(last) = self.last_seq.get()
            && seq > last + 1
        {
            self.gaps.set(self.gaps.get() + (seq - last - 1));
        }
        self.last_seq.set(Some(seq));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use shm_types::{DepthFrame, NeckGoal};

    fn unique_ns(tag: &str) -> String {
        format!(
            "t{}-{}-{tag}",
            std::process::id(),
            crate::os::monotonic_ns() % 1_000_000_007
        )
    }

    #[test]
    fn header_is_stamped_and_wait_times_out_and_latest_keeps_newest() {
        let cfg = PortsConfig {
            subscriber_buffer: 4,
            ..PortsConfig::default()
        };
        let ctx = PortContext::with_namespace(&cfg, "unit", &unique_ns("basic")).unwrap();
        let sub = ctx.subscriber::<NeckGoal>("neck").unwrap();
        let publ = ctx.publisher::<NeckGoal>("neck").unwrap();
        assert_eq!(publ.subscriber_count(), 1);
        assert_eq!(sub.publisher_count(), 1);
        assert_eq!(sub.connect().unwrap(), 1);
        assert!(sub.wait(Duration::from_millis(5)).unwrap().is_none());
        for k in 1..=3u64 {
            let mut g = publ.loan().unwrap();
            assert_eq!(*g.header(), Header::default(), "loan is zero-filled");
            g.yaw = k as f32;
            g.header_mut().seq = 999; // overwritten by send
            let sent = g
                .send(Stamp {
                    source_ns: 10 * k,
                    sim_ns: 20 * k,
                })
                .unwrap();
            assert_eq!(
                sent,
                Sent {
                    seq: k,
                    subscribers: 1
                }
            );
        }
        let first = sub.wait(Duration::from_secs(5)).unwrap().unwrap();
        assert_eq!(
            *first.header(),
            Header {
                seq: 1,
                stamp_ns: 10,
                sim_time_ns: 20
            }
        );
        drop(first);
        let newest = sub.latest().unwrap().unwrap();
        assert_eq!(newest.header().seq, 3);
        assert_eq!(newest.yaw, 3.0);
        assert_eq!(
            sub.gaps(),
            0,
            "latest() received seq 2 and dropped it: no gap"
        );
        assert!(sub.receive().unwrap().is_none());
    }

    /// Frame `k` as the test writes it: `width = k`, the first `k` pixels `= k`, `sim_ns = k`.
    fn is_frame_k(f: &DepthFrame, k: u64) -> bool {
        f.width as u64 == k
            && f.height == u32::from(k > 0)
            && f.header.sim_time_ns == k
            && f.pixels().iter().all(|&p| u64::from(p) == k)
    }

    #[test]
    fn loan_reused_hands_out_a_previous_sample_or_zeros_and_sends() {
        let cfg = PortsConfig {
            subscriber_buffer: 1,
            subscriber_max_borrowed: 1,
            publisher_max_loaned: 1,
            max_subscribers: 1,
            ..PortsConfig::default()
        };
        let ctx = PortContext::with_namespace(&cfg, "unit", &unique_ns("reuse")).unwrap();
        let sub = ctx.subscriber::<DepthFrame>("depth").unwrap();
        let publ = ctx.publisher::<DepthFrame>("depth").unwrap();
        // More rounds than the data segment has slots, so some slot is handed out again.
        let rounds = 64u64;
        let mut stale = 0;
        for k in 1..=rounds {
            let mut f = publ.loan_reused().unwrap();
            let before = f.header.seq;
            assert!(
                before < k && is_frame_k(&f, before),
                "round {k}: not zeros and not an earlier frame (seq {before}, width {})",
                f.width
            );
            stale += u64::from(before > 0);
            f.width = k as u32;
            f.height = 1;
            f.pixels_mut().fill(k as u16);
            let sent = f
                .send(Stamp {
                    source_ns: 0,
                    sim_ns: k,
                })
                .unwrap();
            assert_eq!(sent.seq, k);
            let got = sub.receive().unwrap().unwrap();
            assert!(is_frame_k(&got, k), "round {k}: received a different frame");
        }
        assert!(stale > 0, "no slot was reused in {rounds} rounds");
        // The zero-filling loan still clears a slot that held a frame.
        let f = publ.loan().unwrap();
        assert!(is_frame_k(&f, 0) && f.header.seq == 0 && f.depth_mm.iter().all(|&p| p == 0));
    }

    #[test]
    fn overwrite_keeps_the_newest_when_the_buffer_is_full() {
        let cfg = PortsConfig::default(); // buffer 2, overwrite
        let ctx = PortContext::with_namespace(&cfg, "unit", &unique_ns("ovw")).unwrap();
        let sub = ctx.subscriber::<NeckGoal>("neck").unwrap();
        let publ = ctx.publisher::<NeckGoal>("neck").unwrap();
        publ.loan().unwrap().send(Stamp::default()).unwrap();
        assert_eq!(sub.receive().unwrap().unwrap().header().seq, 1);
        for _ in 0..5 {
            publ.loan().unwrap().send(Stamp::default()).unwrap();
        }
        let seqs: Vec<u64> = std::iter::from_fn(|| sub.receive().unwrap())
            .map(|s| s.header().seq)
            .collect();
        assert_eq!(seqs, vec![5, 6]);
        assert_eq!(sub.gaps(), 3, "seqs 2..=4 were overwritten");
    }

    #[test]
    fn block_times_out_with_a_send_error_when_the_subscriber_never_reads() {
        let mut cfg = PortsConfig::default();
        cfg.topics.insert(
            "neck".into(),
            TopicOverride {
                overflow: Some(Overflow::Block),
                subscriber_buffer: Some(1),
                block_timeout_ms: Some(20),
                ..TopicOverride::default()
            },
        );
        let ctx = PortContext::with_namespace(&cfg, "unit", &unique_ns("blk")).unwrap();
        let sub = ctx.subscriber::<NeckGoal>("neck").unwrap();
        let publ = ctx.publisher::<NeckGoal>("neck").unwrap();
        assert_eq!(publ.settings().overflow, Overflow::Block);
        // The subscriber attaches its end of the connection on its first receive.
        assert!(sub.receive().unwrap().is_none());
        publ.loan().unwrap().send(Stamp::default()).unwrap();
        let e = publ.loan().unwrap().send(Stamp::default()).unwrap_err();
        assert!(matches!(e, PortError::Send { .. }), "{e}");
        assert!(e.to_string().contains("/neck"), "{e}");
        assert_eq!(sub.receive().unwrap().unwrap().header().seq, 1);
    }

    #[test]
    fn mismatched_overflow_between_processes_is_a_service_error() {
        let ns = unique_ns("mis");
        let ctx = PortContext::with_namespace(&PortsConfig::default(), "unit", &ns).unwrap();
        let _sub = ctx.subscriber::<NeckGoal>("neck").unwrap();
        let other = PortsConfig {
            overflow: Overflow::Block,
            ..PortsConfig::default()
        };
        let ctx2 = PortContext::with_namespace(&other, "unit2", &ns).unwrap();
        let e = ctx2.publisher::<NeckGoal>("neck").unwrap_err();
        assert!(matches!(e, PortError::Service { .. }), "{e}");
        let e = PortContext::with_namespace(&other, "unit", "bad/ns").unwrap_err();
        assert!(matches!(e, PortError::Name { .. }), "{e}");
    }
}
