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
//! [`AnyBitPattern`](shm_types::AnyBitPattern) messages whose producer overwrites everything it
//! publishes, [`Publisher::loan_reused`] hands it out as it is (an earlier sample's bytes, no
//! fill); the caller fills it through `DerefMut` and calls [`Loan::send`], which stamps the
//! [`Header`](shm_types::Header) (per-publisher sequence number starting at 1, caller's time
//! stamps). A subscriber reads the same memory through a borrowed [`Received`] sample
//! (`Deref<Target = T>`).
//!
//! iceoryx2 configuration: the iceoryx2 `Config` is built **in code** from its built-in defaults
//! and handed to the node explicitly, so iceoryx2 never reads `config/iceoryx2.toml` (nor the
//! user's or system's copy): a stray file cannot change behaviour silently. Every service
//! setting that matters (history, buffers, port counts, overflow) comes from `[ports]`.
//!
//! Ports are not `Send` (iceoryx2's `ipc::Service` is single-threaded): create the context and
//! its ports on the thread that uses them (the periodic executor's `make_body` closure runs on
//!
//! # Files
//! | file | content |
//! |---|---|
//! | `mod.rs` | [`PortContext`] (node, naming, a topic's two services), [`list_services`] |
//! | [`access`] | per-user iceoryx2 root directory and prefix: who may open a run's services |
//! | `config.rs` | [`PortsConfig`] (`[ports]`), [`TopicOverride`], [`TopicSettings`], [`Overflow`] |
//! | `publisher.rs` | [`Publisher`], [`Loan`], [`Stamp`], [`Sent`] |
//! | `subscriber.rs` | [`Subscriber`], [`Received`] |
//! | `slice.rs` | [`SlicePublisher`], [`SliceLoan`], [`SliceSubscriber`], [`ReceivedSlice`]: a topic of variable-length byte samples (the link's relays) |
//! | `error.rs` | one error type per operation, each keeping iceoryx2's error as its source |

pub mod access;
mod config;
mod error;
mod publisher;
mod slice;
mod subscriber;

pub use config::{
    Overflow, PortsConfig, TopicOverride, TopicSettings, check_domain, domain_prefix,
};
use config::{check_namespace, check_topic};
pub use error::{
    ConnectError, ContextError, ListError, LoanError, PublisherError, ReceiveError, SendError,
    ServiceError, SubscriberError, WaitError,
};
pub use publisher::{Loan, Publisher, Sent, Stamp};
pub use slice::{ReceivedSlice, SliceLoan, SlicePublisher, SliceSubscriber};
pub use subscriber::{Received, Subscriber};

use iceoryx2::node::Node;
use iceoryx2::prelude::{IceoryxSend, NodeBuilder, NodeName, ServiceName, ZeroCopySend, ipc};
use iceoryx2::service::port_factory::{event, publish_subscribe};
use shm_types::Message;
use std::fmt;

/// First element of every service name.
pub const SERVICE_ROOT: &str = "vpsom";

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

/// The process's iceoryx2 domain (`[ports] domain`), set once by [`set_domain`].
static DOMAIN: std::sync::OnceLock<String> = std::sync::OnceLock::new();

/// Puts every iceoryx2 node this process creates from now on into `domain` (`[ports] domain`;
/// "" = iceoryx2's default). Call it once, before the first node, with the loaded
/// configuration's value; a second call with another domain is an error (a process lives in
/// one domain).
pub fn set_domain(domain: &str) -> Result<(), ContextError> {
    check_domain(domain).map_err(|reason| ContextError::Domain {
        domain: domain.into(),
        reason,
    })?;
    let set = DOMAIN.get_or_init(|| domain.to_string());
    if set != domain {
        return Err(ContextError::Domain {
            domain: domain.into(),
            reason: "this process already lives in another iceoryx2 domain",
        });
    }
    Ok(())
}

/// The iceoryx2 configuration used by every node we create: iceoryx2's built-in defaults, never
/// a file (see the module docs): the calling user's own root directory (made `0700`) and
/// prefix ([`access`]), or, in a named domain ([`set_domain`]), that domain's prefix for this user.
pub fn iceoryx2_config() -> iceoryx2::config::Config {
    let uid = crate::os::euid();
    access::ensure_private_root(uid);
    let mut c = access::config_for_user(uid);
    if let Some(prefix) = DOMAIN.get().and_then(|d| domain_prefix(d, uid)) {
        // A checked domain gives a valid file name.
        use iceoryx2::prelude::SemanticString as _;
        if let Ok(p) = iceoryx2::prelude::FileName::new(prefix.as_bytes()) {
            c.global.prefix = p;
        }
    }
    c
}

/// Names of the existing services (any process) under `vpsom/<namespace>/`, sorted; each topic
/// appears twice (publish-subscribe and event). Used to check that a run cleaned up.
pub fn list_services(namespace: &str) -> Result<Vec<String>, ListError> {
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
    .map_err(|source| ListError {
        prefix: prefix.clone(),
        source,
    })?;
    names.sort();
    Ok(names)
}

impl PortContext {
    /// A node named `node_name` using `config.namespace`.
    pub fn new(config: &PortsConfig, node_name: &str) -> Result<Self, ContextError> {
        Self::with_namespace(config, node_name, &config.namespace)
    }

    /// A node named `node_name` whose services live under `vpsom/<namespace>/`.
    pub fn with_namespace(
        config: &PortsConfig,
        node_name: &str,
        namespace: &str,
    ) -> Result<Self, ContextError> {
        check_namespace(namespace).map_err(|reason| ContextError::Namespace {
            namespace: namespace.into(),
            reason,
        })?;
        let name = NodeName::new(node_name).map_err(|source| ContextError::NodeName {
            node: node_name.into(),
            source,
        })?;
        let node = NodeBuilder::new()
            .name(&name)
            .config(&iceoryx2_config())
            .create::<ipc::Service>()
            .map_err(|source| ContextError::Node {
                node: node_name.into(),
                source,
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

    /// `topic`'s settings, full service name and iceoryx2 service name (checked).
    fn naming(&self, topic: &str) -> Result<(TopicSettings, String, ServiceName), ServiceError> {
        check_topic(topic).map_err(|reason| ServiceError::Topic {
            topic: topic.into(),
            reason,
        })?;
        let full = self.service_name(topic);
        let name = ServiceName::new(&full).map_err(|source| ServiceError::ServiceName {
            service: full.clone(),
            source,
        })?;
        Ok((self.config.topic(topic), full, name))
    }

    /// The event service paired with the publish-subscribe service `name`.
    fn event_service(
        &self,
        name: &ServiceName,
        full: &str,
        s: &TopicSettings,
    ) -> Result<event::PortFactory<ipc::Service>, ServiceError> {
        self.node
            .service_builder(name)
            .event()
            .max_notifiers(s.max_publishers)
            .max_listeners(s.max_subscribers)
            .max_nodes(s.max_nodes)
            .open_or_create()
            .map_err(|source| ServiceError::Event {
                service: full.into(),
                source,
            })
    }

    fn services<T: Message>(&self, topic: &str) -> Result<Services<T>, ServiceError> {
        let (s, full, name) = self.naming(topic)?;
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
            .map_err(|source| ServiceError::PublishSubscribe {
                service: full.clone(),
                source,
            })?;
        let event = self.event_service(&name, &full, &s)?;
        Ok(Services {
            pubsub,
            event,
            settings: s,
            name: full,
        })
    }

    /// A publisher on `topic` (creates the services if they do not exist yet).
    pub fn publisher<T: Message>(&self, topic: &str) -> Result<Publisher<T>, PublisherError> {
        Publisher::new(self.services::<T>(topic)?)
    }

    /// A subscriber on `topic` (creates the services if they do not exist yet).
    pub fn subscriber<T: Message>(&self, topic: &str) -> Result<Subscriber<T>, SubscriberError> {
        Subscriber::new(self.services::<T>(topic)?)
    }
}

/// The two services of one topic: a typed message `T`, or (`Services<[u8], Header>`, see
/// [`slice`]) the bytes of one with the header beside them.
struct Services<T: ?Sized + fmt::Debug + IceoryxSend, H: fmt::Debug + ZeroCopySend = ()> {
    pubsub: publish_subscribe::PortFactory<ipc::Service, T, H>,
    event: event::PortFactory<ipc::Service>,
    settings: TopicSettings,
    name: String,
}

#[cfg(test)]
mod tests {
    use super::*;
    use shm_types::{DepthFrame, Header, NeckGoal};
    use std::time::Duration;

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
            // Valid intrinsics and pose: the subscriber drops invalid frames on receipt.
            f.intrinsics.fx = 1.0;
            f.intrinsics.fy = 1.0;
            f.intrinsics.max_range = 5.0;
            f.camera_pose.rotation = [0.0, 0.0, 0.0, 1.0];
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
        assert_eq!(sub.received(), 3, "seqs 1, 5 and 6 were received");
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
        assert!(matches!(e, SendError::Deliver { .. }), "{e}");
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
        assert!(
            matches!(
                e,
                PublisherError::Service(ServiceError::PublishSubscribe { .. })
            ),
            "{e}"
        );
        let e = PortContext::with_namespace(&other, "unit", "bad/ns").unwrap_err();
        assert!(matches!(e, ContextError::Namespace { .. }), "{e}");
    }
}
