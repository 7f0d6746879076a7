//! Byte-slice ports: a topic whose samples are variable-length byte slices (iceoryx2 slice
//! payloads, `[u8]`), each with a message [`Header`] beside it as the iceoryx2 user header.
//! For a message whose used part is much smaller than its type's capacity (a `Detections`
//! without masks, a 320×240 `DepthFrame`): the producer encodes the used bytes into a loan
//! of exactly that length, so whatever moves the sample on (the link's tunnel) moves only
//! those. The encoding is the caller's; these ports only move bytes.
//!
//! Consistent with the typed ports: the service is `vpsom/<namespace>/<topic>` with the topic's
//! `[ports]` settings and a paired event service; [`SliceLoan::send`] stamps the header (per
//! publisher sequence number from 1) and [`SliceLoan::send_relayed`] keeps the caller's; a
//! [`SliceSubscriber`] counts received samples and sequence gaps from the header as a
//! [`Subscriber`](super::Subscriber) does. It cannot validate bytes it does not understand:
//! the consumer decodes them and hands a sample that fails to [`SliceSubscriber::reject`],
//! which counts it as invalid and logs it (rate-limited), as a typed subscriber does on receipt.
//!
//! The header is a user header, not the front of the slice, so that sequence accounting never
//! depends on the payload's encoding, and the payload stays exactly the encoded bytes. The
//! service's payload type is `[u8]` (alignment 1): a decoder reads it unaligned.
//!
//! The longest slice is the publisher's (`max_len`, iceoryx2's `initial_max_slice_len`, with
//! the static allocation strategy: its data segment is sized for it once); a loan asks for the
//! length it needs, and only that length is a sample's payload.

use super::error::{ConnectError, LoanError, PublisherError, ReceiveError, SendError};
use super::error::{ServiceError, SubscriberError};
use super::{Overflow, Sent};
use super::{PortContext, Services, Stamp, TopicSettings};
use iceoryx2::port::listener::Listener;
use iceoryx2::port::notifier::Notifier;
use iceoryx2::prelude::{AllocationStrategy, BackpressureStrategy, PortFactory as _, ipc};
use iceoryx2::sample::Sample;
use iceoryx2::sample_mut::SampleMut;
use shm_types::Header;
use std::cell::Cell;
use std::fmt;
use std::ops::{Deref, DerefMut};
use std::time::Instant;

type SliceServices = Services<[u8], Header>;

impl PortContext {
    fn slice_services(&self, topic: &str) -> Result<SliceServices, ServiceError> {
        let (s, full, name) = self.naming(topic)?;
        let pubsub = self
            .node
            .service_builder(&name)
            .publish_subscribe::<[u8]>()
            .user_header::<Header>()
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

    /// A publisher of byte slices of at most `max_len` bytes on `topic` (creates the services if
    /// they do not exist yet). `[ports]` `overflow = "block"` is treated as `discard` here (a
    /// slice topic is a relay's, which never waits).
    pub fn slice_publisher(
        &self,
        topic: &str,
        max_len: usize,
    ) -> Result<SlicePublisher, PublisherError> {
        SlicePublisher::new(self.slice_services(topic)?, max_len)
    }

    /// A subscriber of byte slices on `topic` (creates the services if they do not exist yet).
    pub fn slice_subscriber(&self, topic: &str) -> Result<SliceSubscriber, SubscriberError> {
        SliceSubscriber::new(self.slice_services(topic)?)
    }
}

/// Sends byte slices with a [`Header`] on one topic, zero-copy (see the module docs).
pub struct SlicePublisher {
    port: iceoryx2::port::publisher::Publisher<ipc::Service, [u8], Header>,
    notifier: Notifier<ipc::Service>,
    services: SliceServices,
    max_len: usize,
    seq: Cell<u64>,
}

impl fmt::Debug for SlicePublisher {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("SlicePublisher")
            .field("service", &self.services.name)
            .field("max_len", &self.max_len)
            .field("seq", &self.seq.get())
            .finish_non_exhaustive()
    }
}

impl SlicePublisher {
    fn new(sv: SliceServices, max_len: usize) -> Result<Self, PublisherError> {
        let s = sv.settings;
        let mut builder = sv
            .pubsub
            .publisher_builder()
            .max_loaned_samples(s.publisher_max_loaned)
            .initial_max_slice_len(max_len)
            .allocation_strategy(AllocationStrategy::Static);
        if s.overflow != Overflow::Overwrite {
            builder = builder.backpressure_strategy(BackpressureStrategy::DiscardData);
        }
        let port = builder
            .create()
            .map_err(|source| PublisherError::Publisher {
                service: sv.name.clone(),
                source,
            })?;
        let notifier =
            sv.event
                .notifier_builder()
                .create()
                .map_err(|source| PublisherError::Notifier {
                    service: sv.name.clone(),
                    source,
                })?;
        Ok(Self {
            port,
            notifier,
            services: sv,
            max_len,
            seq: Cell::new(0),
        })
    }

    /// `len` zero-filled bytes in shared memory (at most [`Self::max_len`]) for the caller to
    /// fill, then [`SliceLoan::send`]. Dropping the loan without sending returns the memory.
    pub fn loan(&self, len: usize) -> Result<SliceLoan<'_>, LoanError> {
        let sample = self.port.loan_slice(len).map_err(|source| LoanError {
            service: self.services.name.clone(),
            source,
        })?;
        Ok(SliceLoan {
            sample,
            publisher: self,
        })
    }

    /// The longest slice a loan may ask for, bytes.
    pub fn max_len(&self) -> usize {
        self.max_len
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

/// A loaned byte slice being filled (`DerefMut<Target = [u8]>`), with its header.
pub struct SliceLoan<'p> {
    sample: SampleMut<ipc::Service, [u8], Header>,
    publisher: &'p SlicePublisher,
}

impl fmt::Debug for SliceLoan<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("SliceLoan")
            .field("service", &self.publisher.services.name)
            .field("len", &self.sample.payload().len())
            .finish_non_exhaustive()
    }
}

impl Deref for SliceLoan<'_> {
    type Target = [u8];
    fn deref(&self) -> &[u8] {
        self.sample.payload()
    }
}

impl DerefMut for SliceLoan<'_> {
    fn deref_mut(&mut self) -> &mut [u8] {
        self.sample.payload_mut()
    }
}

impl SliceLoan<'_> {
    /// The header sent with the bytes.
    pub fn header_mut(&mut self) -> &mut Header {
        self.sample.user_header_mut()
    }

    /// Stamp the header (next sequence number, `stamp`), deliver the sample and signal the
    /// paired event. Overwrites whatever the caller put in the header.
    pub fn send(mut self, stamp: Stamp) -> Result<Sent, SendError> {
        let seq = self.publisher.seq.get() + 1;
        *self.sample.user_header_mut() = Header {
            seq,
            stamp_ns: stamp.source_ns,
            sim_time_ns: stamp.sim_ns,
        };
        self.deliver(seq)
    }

    /// Like [`SliceLoan::send`] but keeps the header the caller wrote ([`Self::header_mut`]):
    /// for a relay that forwards another publisher's sample.
    pub fn send_relayed(self) -> Result<Sent, SendError> {
        let seq = self.sample.user_header().seq;
        self.deliver(seq)
    }

    fn deliver(self, seq: u64) -> Result<Sent, SendError> {
        let p = self.publisher;
        let subscribers = self.sample.send().map_err(|source| SendError::Deliver {
            service: p.services.name.clone(),
            source,
        })?;
        p.seq.set(seq);
        p.notifier.notify().map_err(|source| SendError::Notify {
            service: p.services.name.clone(),
            seq,
            source,
        })?;
        Ok(Sent { seq, subscribers })
    }
}

/// Receives byte slices with a [`Header`] on one topic, zero-copy, counting what it received,
/// the sequence gaps, and the samples its consumer rejected ([`Self::reject`]).
pub struct SliceSubscriber {
    port: iceoryx2::port::subscriber::Subscriber<ipc::Service, [u8], Header>,
    // Kept for the paired event service's lifetime (a typed subscriber waits on it; the relay
    // polls).
    _listener: Listener<ipc::Service>,
    services: SliceServices,
    last_seq: Cell<Option<u64>>,
    gaps: Cell<u64>,
    received: Cell<u64>,
    invalid: Cell<u64>,
    last_invalid_log: Cell<Option<Instant>>,
}

impl fmt::Debug for SliceSubscriber {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("SliceSubscriber")
            .field("service", &self.services.name)
            .field("gaps", &self.gaps.get())
            .field("invalid", &self.invalid.get())
            .finish_non_exhaustive()
    }
}

/// A byte slice borrowed from shared memory (`Deref<Target = [u8]>`), with its header;
/// dropping it returns it.
pub struct ReceivedSlice {
    sample: Sample<ipc::Service, [u8], Header>,
}

impl fmt::Debug for ReceivedSlice {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("ReceivedSlice")
            .field("header", self.header())
            .field("len", &self.len())
            .finish_non_exhaustive()
    }
}

impl Deref for ReceivedSlice {
    type Target = [u8];
    fn deref(&self) -> &[u8] {
        self.sample.payload()
    }
}

impl ReceivedSlice {
    /// The header sent with the bytes.
    pub fn header(&self) -> &Header {
        self.sample.user_header()
    }
}

impl SliceSubscriber {
    fn new(sv: SliceServices) -> Result<Self, SubscriberError> {
        let port = sv
            .pubsub
            .subscriber_builder()
            .buffer_size(sv.settings.subscriber_buffer)
            .create()
            .map_err(|source| SubscriberError::Subscriber {
                service: sv.name.clone(),
                source,
            })?;
        let listener =
            sv.event
                .listener_builder()
                .create()
                .map_err(|source| SubscriberError::Listener {
                    service: sv.name.clone(),
                    source,
                })?;
        Ok(Self {
            port,
            _listener: listener,
            services: sv,
            last_seq: Cell::new(None),
            gaps: Cell::new(0),
            received: Cell::new(0),
            invalid: Cell::new(0),
            last_invalid_log: Cell::new(None),
        })
    }

    /// The oldest unread sample, if any (never blocks). Counted as received until the consumer
    /// [`rejects`](Self::reject) it.
    pub fn receive(&self) -> Result<Option<ReceivedSlice>, ReceiveError> {
        let sample = self.port.receive().map_err(|source| ReceiveError {
            service: self.services.name.clone(),
            source,
        })?;
        let Some(sample) = sample else {
            return Ok(None);
        };
        let r = ReceivedSlice { sample };
        self.track(r.header().seq);
        self.received.set(self.received.get() + 1);
        Ok(Some(r))
    }

    /// Drain the buffer and return only the newest sample, if any (never blocks). Borrows two
    /// samples at once while draining, as [`Subscriber::latest`](super::Subscriber::latest).
    pub fn latest(&self) -> Result<Option<ReceivedSlice>, ReceiveError> {
        let mut newest = None;
        while let Some(s) = self.receive()? {
            newest = Some(s);
        }
        Ok(newest)
    }

    /// The consumer could not use `sample` (its bytes do not decode, or decode to an invalid
    /// message): count it as invalid instead of received, log `why` (at most once per
    /// [`INVALID_LOG_EVERY`](super::subscriber::INVALID_LOG_EVERY)) and return it.
    pub fn reject(&self, sample: ReceivedSlice, why: &dyn fmt::Display) {
        let seq = sample.header().seq;
        drop(sample);
        self.received.set(self.received.get().saturating_sub(1));
        self.invalid.set(self.invalid.get() + 1);
        let now = Instant::now();
        if self
            .last_invalid_log
            .get()
            .is_none_or(|t| now.duration_since(t) >= super::subscriber::INVALID_LOG_EVERY)
        {
            self.last_invalid_log.set(Some(now));
            eprintln!(
                "{}: dropped invalid sample seq {seq}: {why} ({} invalid so far)",
                self.services.name,
                self.invalid.get()
            );
        }
    }

    /// Samples received and not rejected.
    pub fn received(&self) -> u64 {
        self.received.get()
    }

    /// Samples the consumer rejected ([`Self::reject`]).
    pub fn invalid(&self) -> u64 {
        self.invalid.get()
    }

    /// Sequence numbers skipped between consecutive received samples (see
    /// [`Subscriber::gaps`](super::Subscriber::gaps)).
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

    /// Connect to every publisher of the topic now; returns the publisher count.
    pub fn connect(&self) -> Result<usize, ConnectError> {
        use iceoryx2::port::update_connections::UpdateConnections;
        self.port
            .update_connections()
            .map_err(|source| ConnectError {
                service: self.services.name.clone(),
                source,
            })?;
        Ok(self.services.pubsub.dynamic_config().number_of_publishers())
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
    use super::super::PortsConfig;
    use super::*;

    fn unique_ns(tag: &str) -> String {
        format!(
            "t{}-{}-{tag}",
            std::process::id(),
            crate::os::monotonic_ns() % 1_000_000_007
        )
    }

    #[test]
    fn slices_cross_at_their_length_with_their_header_and_gaps_are_counted() {
        let cfg = PortsConfig {
            subscriber_buffer: 2,
            ..PortsConfig::default()
        };
        let ctx = PortContext::with_namespace(&cfg, "unit", &unique_ns("slice")).unwrap();
        let sub = ctx.slice_subscriber("link/depth").unwrap();
        let publ = ctx.slice_publisher("link/depth", 1000).unwrap();
        assert_eq!(publ.max_len(), 1000);
        assert_eq!(publ.subscriber_count(), 1);
        assert_eq!(sub.connect().unwrap(), 1);
        let mut l = publ.loan(3).unwrap();
        assert_eq!(&*l, &[0, 0, 0], "a loan is zero-filled");
        l.copy_from_slice(&[1, 2, 3]);
        let sent = l
            .send(Stamp {
                source_ns: 7,
                sim_ns: 8,
            })
            .unwrap();
        assert_eq!(sent.seq, 1);
        let r = sub.receive().unwrap().unwrap();
        assert_eq!(&*r, &[1, 2, 3]);
        assert_eq!(
            *r.header(),
            Header {
                seq: 1,
                stamp_ns: 7,
                sim_time_ns: 8
            }
        );
        drop(r);
        // A relayed header is kept; seq 2..=4 never published here are gaps.
        let mut l = publ.loan(1000).unwrap();
        l[999] = 9;
        l.header_mut().seq = 5;
        assert_eq!(l.send_relayed().unwrap().seq, 5);
        let r = sub.latest().unwrap().unwrap();
        assert_eq!((r.len(), r[999], r.header().seq), (1000, 9, 5));
        assert_eq!(sub.gaps(), 3);
        sub.reject(r, &"test");
        assert_eq!((sub.received(), sub.invalid()), (1, 1));
        // Longer than the publisher's maximum: refused, not truncated.
        assert!(publ.loan(1001).is_err());
    }
}
