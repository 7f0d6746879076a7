//! The sending side: [`Publisher`] (one per topic and producer), the [`Loan`] it hands out to be
//! filled in place, the [`Stamp`] written into the header on [`Loan::send`], and what a send
//! did ([`Sent`]).

use super::error::{ConnectError, LoanError, PublisherError, SendError};
use super::{Overflow, Services, TopicSettings};
use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::{BackpressureAction, BackpressureInfo};
use iceoryx2::prelude::{BackpressureStrategy, PortFactory as _, ipc};
use iceoryx2::sample_mut::SampleMut;
use iceoryx2::sample_mut_uninit::SampleMutUninit;
use shm_types::{AnyBitPattern, Header, Message};
use std::cell::Cell;
use std::fmt;
use std::mem::MaybeUninit;
use std::ops::{Deref, DerefMut};
use std::time::Duration;

/// The producer's time stamps written into a message [`Header`] on send.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Stamp {
    /// Producer's monotonic clock when the data was produced, ns (`Header::stamp_ns`).
    pub source_ns: u64,
    /// Simulation (or robot) time the data refers to, ns (`Header::sim_time_ns`).
    pub sim_ns: u64,
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
    /// The publisher and notifier on the topic's services `sv` (see
    /// [`PortContext::publisher`](super::PortContext::publisher)).
    pub(super) fn new(sv: Services<T>) -> Result<Self, PublisherError> {
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
            seq: Cell::new(0),
        })
    }

    /// A zero-filled sample in shared memory for the caller to fill in place, then
    /// [`Loan::send`]. Dropping the loan without sending returns the memory.
    pub fn loan(&self) -> Result<Loan<'_, T>, LoanError> {
        Ok(Loan {
            sample: shm_types::init_zeroed(self.loan_uninit()?),
            publisher: self,
        })
    }

    fn loan_uninit(&self) -> Result<SampleMutUninit<ipc::Service, MaybeUninit<T>, ()>, LoanError> {
        self.port.loan_uninit().map_err(|source| LoanError {
            service: self.services.name.clone(),
            source,
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

    /// Connect to subscribers that appeared since the last send, and hand them the topic's
    /// history (`history_size`): iceoryx2 delivers history only from the publisher's side, so a
    /// publisher that sends rarely calls this regularly for late joiners to get it.
    pub fn update_connections(&self) -> Result<(), ConnectError> {
        use iceoryx2::port::update_connections::UpdateConnections;
        self.port
            .update_connections()
            .map_err(|source| ConnectError {
                service: self.services.name.clone(),
                source,
            })
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
    pub fn loan_reused(&self) -> Result<Loan<'_, T>, LoanError> {
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
    pub fn send(mut self, stamp: Stamp) -> Result<Sent, SendError> {
        let p = self.publisher;
        let seq = p.seq.get() + 1;
        *self.sample.payload_mut().header_mut() = Header {
            seq,
            stamp_ns: stamp.source_ns,
            sim_time_ns: stamp.sim_ns,
        };
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

    /// Like [`Loan::send`] but keeps the header the caller wrote: for a relay that forwards
    /// another publisher's sample (the link's rate limit), so consumers see the producer's
    /// sequence number and stamps.
    pub fn send_relayed(self) -> Result<Sent, SendError> {
        let p = self.publisher;
        let seq = self.sample.payload().header().seq;
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
