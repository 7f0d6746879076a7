//! One error type per port operation. Each names the node or service it is about and keeps
//! iceoryx2's own error as its [`source`](std::error::Error::source) (printed by `{:#}` of an
//! `anyhow::Error`, or by walking the chain), never flattened into a string. All are
//! `Send + Sync + 'static`, so `?` into `anyhow` works.

use iceoryx2::node::NodeCreationFailure;
use iceoryx2::port::listener::ListenerCreateError;
use iceoryx2::port::notifier::{NotifierCreateError, NotifierNotifyError};
use iceoryx2::port::publisher::PublisherCreateError;
use iceoryx2::port::subscriber::SubscriberCreateError;
use iceoryx2::port::update_connections::ConnectionFailure;
use iceoryx2::prelude::SemanticStringError;
use iceoryx2::service::ServiceListError;
use iceoryx2::service::builder::event::EventOpenOrCreateError;
use iceoryx2::service::builder::publish_subscribe::PublishSubscribeOpenOrCreateError;
use iceoryx2::service::service_name::ServiceNameError;

/// Why [`PortContext::new`](super::PortContext::new) (or `with_namespace`) failed.
#[derive(Debug, thiserror::Error)]
pub enum ContextError {
    /// The namespace is not usable as one segment of a service name.
    #[error("invalid namespace {namespace:?}: {reason}")]
    Namespace {
        /// The namespace.
        namespace: String,
        /// Which names are allowed.
        reason: &'static str,
    },
    /// iceoryx2 refused the node name.
    #[error("invalid iceoryx2 node name {node:?}")]
    NodeName {
        /// The node name.
        node: String,
        /// iceoryx2's reason.
        #[source]
        source: SemanticStringError,
    },
    /// The iceoryx2 node could not be created (e.g. no shared memory, no permission).
    #[error("cannot create iceoryx2 node {node:?}")]
    Node {
        /// The node name.
        node: String,
        /// iceoryx2's reason.
        #[source]
        source: NodeCreationFailure,
    },
    /// The iceoryx2 domain (`[ports] domain`) is not a valid name, or the process already
    /// lives in another one.
    #[error("iceoryx2 domain {domain:?}: {reason}")]
    Domain {
        /// The domain.
        domain: String,
        /// What is wrong.
        reason: &'static str,
    },
}

/// Why the two services of a topic (publish-subscribe and event) could not be opened or
/// created; part of [`PublisherError`] and [`SubscriberError`].
#[derive(Debug, thiserror::Error)]
pub enum ServiceError {
    /// The topic is not a usable name.
    #[error("invalid topic {topic:?}: {reason}")]
    Topic {
        /// The topic.
        topic: String,
        /// Which names are allowed.
        reason: &'static str,
    },
    /// iceoryx2 refused the full service name (e.g. too long).
    #[error("invalid service name {service:?}")]
    ServiceName {
        /// Full service name.
        service: String,
        /// iceoryx2's reason.
        #[source]
        source: ServiceNameError,
    },
    /// The publish-subscribe service could not be opened or created (e.g. it exists with
    /// another payload type or incompatible settings).
    #[error("service {service}: cannot open or create the publish-subscribe service")]
    PublishSubscribe {
        /// Full service name.
        service: String,
        /// iceoryx2's reason.
        #[source]
        source: PublishSubscribeOpenOrCreateError,
    },
    /// The paired event service could not be opened or created.
    #[error("service {service}: cannot open or create the event service")]
    Event {
        /// Full service name.
        service: String,
        /// iceoryx2's reason.
        #[source]
        source: EventOpenOrCreateError,
    },
}

/// Why [`PortContext::publisher`](super::PortContext::publisher) failed.
#[derive(Debug, thiserror::Error)]
pub enum PublisherError {
    /// The topic's services could not be opened or created.
    #[error(transparent)]
    Service(#[from] ServiceError),
    /// The publisher port could not be created (e.g. more publishers than `max_publishers`).
    #[error("service {service}: cannot create the publisher")]
    Publisher {
        /// Full service name.
        service: String,
        /// iceoryx2's reason.
        #[source]
        source: PublisherCreateError,
    },
    /// The notifier of the paired event could not be created.
    #[error("service {service}: cannot create the notifier")]
    Notifier {
        /// Full service name.
        service: String,
        /// iceoryx2's reason.
        #[source]
        source: NotifierCreateError,
    },
}

/// Why [`PortContext::subscriber`](super::PortContext::subscriber) failed.
#[derive(Debug, thiserror::Error)]
pub enum SubscriberError {
    /// The topic's services could not be opened or created.
    #[error(transparent)]
    Service(#[from] ServiceError),
    /// The subscriber port could not be created (e.g. more subscribers than
    /// `max_subscribers`).
    #[error("service {service}: cannot create the subscriber")]
    Subscriber {
        /// Full service name.
        service: String,
        /// iceoryx2's reason.
        #[source]
        source: SubscriberCreateError,
    },
    /// The listener of the paired event could not be created.
    #[error("service {service}: cannot create the listener")]
    Listener {
        /// Full service name.
        service: String,
        /// iceoryx2's reason.
        #[source]
        source: ListenerCreateError,
    },
}

/// Why [`Publisher::loan`](super::Publisher::loan) (or `loan_reused`) failed: no sample is free
/// (all loaned, or still held by subscribers).
#[derive(Debug, thiserror::Error)]
#[error("service {service}: cannot loan a sample")]
pub struct LoanError {
    /// Full service name.
    pub service: String,
    /// iceoryx2's reason.
    #[source]
    pub source: iceoryx2::port::LoanError,
}

/// Why [`Loan::send`](super::Loan::send) failed.
#[derive(Debug, thiserror::Error)]
pub enum SendError {
    /// The sample was not delivered (with [`Overflow::Block`](super::Overflow::Block): a
    /// subscriber stayed full past the timeout). The sequence number was not used.
    #[error("service {service}: send failed")]
    Deliver {
        /// Full service name.
        service: String,
        /// iceoryx2's reason.
        #[source]
        source: iceoryx2::port::SendError,
    },
    /// The sample was sent (its sequence number is used) but the paired event could not be
    /// signalled, so a waiting subscriber may not wake up.
    #[error("service {service}: sample {seq} sent, but notify failed")]
    Notify {
        /// Full service name.
        service: String,
        /// Sequence number of the sample that was sent.
        seq: u64,
        /// iceoryx2's reason.
        #[source]
        source: NotifierNotifyError,
    },
}

/// Why [`Subscriber::receive`](super::Subscriber::receive) (or `latest`) failed (e.g. too
/// many borrowed samples, or a corrupted connection).
#[derive(Debug, thiserror::Error)]
#[error("service {service}: receive failed")]
pub struct ReceiveError {
    /// Full service name.
    pub service: String,
    /// iceoryx2's reason.
    #[source]
    pub source: iceoryx2::port::ReceiveError,
}

/// Why [`Subscriber::wait`](super::Subscriber::wait) (or `wait_latest`) failed.
#[derive(Debug, thiserror::Error)]
pub enum WaitError {
    /// Receiving failed.
    #[error(transparent)]
    Receive(#[from] ReceiveError),
    /// Waiting on the paired event failed (e.g. interrupted by a termination signal).
    #[error("service {service}: wait failed")]
    Wait {
        /// Full service name.
        service: String,
        /// iceoryx2's reason.
        #[source]
        source: iceoryx2::port::listener::ListenerWaitError,
    },
}

/// Why [`Subscriber::connect`](super::Subscriber::connect) or
/// [`Subscriber::has_samples`](super::Subscriber::has_samples) failed: a publisher's data
/// segment could not be mapped or its connection set up.
#[derive(Debug, thiserror::Error)]
#[error("service {service}: cannot connect to the publishers")]
pub struct ConnectError {
    /// Full service name.
    pub service: String,
    /// iceoryx2's reason.
    #[source]
    pub source: ConnectionFailure,
}

/// Why [`list_services`](super::list_services) failed.
#[derive(Debug, thiserror::Error)]
#[error("cannot list the services under {prefix}")]
pub struct ListError {
    /// The service-name prefix listed, `vpsom/<namespace>/`.
    pub prefix: String,
    /// iceoryx2's reason.
    #[source]
    pub source: ServiceListError,
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `?` into `anyhow` (the app crate) needs this.
    fn is_send_sync_static<E: std::error::Error + Send + Sync + 'static>() {}

    #[test]
    fn every_error_is_send_sync_static() {
        is_send_sync_static::<ContextError>();
        is_send_sync_static::<ServiceError>();
        is_send_sync_static::<PublisherError>();
        is_send_sync_static::<SubscriberError>();
        is_send_sync_static::<LoanError>();
        is_send_sync_static::<SendError>();
        is_send_sync_static::<ReceiveError>();
        is_send_sync_static::<WaitError>();
        is_send_sync_static::<ConnectError>();
        is_send_sync_static::<ListError>();
    }
}
