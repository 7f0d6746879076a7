//! The receiving side: [`Subscriber`] (one per topic and consumer, with its received,
//! sequence-gap and invalid-sample counts) and the [`Received`] sample it lends out of shared memory.
//!
//! Every sample is validated on receipt ([`shm_types::Validate`], allocation-free while the
//! sample is valid): one that fails is returned to its publisher unread, counted, and logged at
//! most once per [`INVALID_LOG_EVERY`] per subscriber. A consumer never sees it.

use super::Services;
use super::error::{ConnectError, ReceiveError, SubscriberError, WaitError};
use iceoryx2::port::listener::Listener;
use iceoryx2::prelude::{PortFactory as _, ipc};
use iceoryx2::sample::Sample;
use shm_types::{Header, Message};
use std::cell::Cell;
use std::fmt;
use std::ops::Deref;
use std::time::{Duration, Instant};

/// Least interval between two log lines about invalid samples on one subscriber.
pub const INVALID_LOG_EVERY: Duration = Duration::from_secs(1);

/// Receives `T` on one topic, zero-copy.
pub struct Subscriber<T: Message> {
    port: iceoryx2::port::subscriber::Subscriber<ipc::Service, T, ()>,
    listener: Listener<ipc::Service>,
    services: Services<T>,
    last_seq: Cell<Option<u64>>,
    gaps: Cell<u64>,
    received: Cell<u64>,
    invalid: Cell<u64>,
    last_invalid_log: Cell<Option<Instant>>,
}

impl<T: Message> fmt::Debug for Subscriber<T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Subscriber")
            .field("service", &self.services.name)
            .field("gaps", &self.gaps.get())
            .field("invalid", &self.invalid.get())
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
    /// The subscriber and listener on the topic's services `sv` (see
    /// [`PortContext::subscriber`](super::PortContext::subscriber)).
    pub(super) fn new(sv: Services<T>) -> Result<Self, SubscriberError> {
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
            listener,
            services: sv,
            last_seq: Cell::new(None),
            gaps: Cell::new(0),
            received: Cell::new(0),
            invalid: Cell::new(0),
            last_invalid_log: Cell::new(None),
        })
    }

    /// The oldest unread valid sample, if any (never blocks). Invalid samples before it are
    /// dropped and counted ([`Subscriber::invalid`]).
    pub fn receive(&self) -> Result<Option<Received<T>>, ReceiveError> {
        loop {
            let sample = self.port.receive().map_err(|source| ReceiveError {
                service: self.services.name.clone(),
                source,
            })?;
            let Some(sample) = sample else {
                return Ok(None);
            };
            let r = Received { sample };
            self.track(r.header().seq);
            match r.validate() {
                Ok(()) => {
                    self.received.set(self.received.get() + 1);
                    return Ok(Some(r));
                }
                Err(e) => self.reject(r.header().seq, &e),
            }
        }
    }

    /// Counts an invalid sample and logs it, rate-limited.
    fn reject(&self, seq: u64, e: &shm_types::ValidationError) {
        self.invalid.set(self.invalid.get() + 1);
        let now = Instant::now();
        if self
            .last_invalid_log
            .get()
            .is_none_or(|t| now.duration_since(t) >= INVALID_LOG_EVERY)
        {
            self.last_invalid_log.set(Some(now));
            eprintln!(
                "{}: dropped invalid sample seq {seq}: {e} ({} invalid so far)",
                self.services.name,
                self.invalid.get()
            );
        }
    }

    /// Valid samples received (handed to the consumer, including those [`Subscriber::latest`]
    /// drained).
    pub fn received(&self) -> u64 {
        self.received.get()
    }

    /// Samples dropped on receipt because they failed validation.
    pub fn invalid(&self) -> u64 {
        self.invalid.get()
    }

    /// Drain the buffer and return only the newest sample, if any (never blocks).
    ///
    /// While draining it borrows two samples at once (the newest so far and the next), on top of
    /// any the caller still holds: `subscriber_max_borrowed` must cover both.
    pub fn latest(&self) -> Result<Option<Received<T>>, ReceiveError> {
        let mut newest = None;
        while let Some(s) = self.receive()? {
            newest = Some(s); // the previous one is dropped (returned) here
        }
        Ok(newest)
    }

    /// The oldest unread sample, blocking on the paired event for up to `timeout`.
    /// `Ok(None)` on timeout.
    pub fn wait(&self, timeout: Duration) -> Result<Option<Received<T>>, WaitError> {
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
                .map_err(|source| WaitError::Wait {
                    service: self.services.name.clone(),
                    source,
                })?;
        }
    }

    /// Like [`Subscriber::wait`] but drains the buffer and returns the newest sample.
    pub fn wait_latest(&self, timeout: Duration) -> Result<Option<Received<T>>, WaitError> {
        match self.wait(timeout)? {
            None => Ok(None),
            Some(first) => Ok(Some(self.latest()?.unwrap_or(first))),
        }
    }

    /// `true` if an unread sample is buffered.
    pub fn has_samples(&self) -> Result<bool, ConnectError> {
        self.port.has_samples().map_err(|source| ConnectError {
            service: self.services.name.clone(),
            source,
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
    pub fn connect(&self) -> Result<usize, ConnectError> {
        use iceoryx2::port::update_connections::UpdateConnections;
        self.port
            .update_connections()
            .map_err(|source| ConnectError {
                service: self.services.name.clone(),
                source,
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
