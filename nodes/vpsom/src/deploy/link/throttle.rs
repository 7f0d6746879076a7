//! Rate limits for the large topics (`[link.max_hz]`): a limited topic `T` is not bridged
//! itself; the host that publishes it copies its newest sample at most `max_hz` times a second
//! onto `link/T`, which is bridged, and the other host copies what arrives on `link/T` back onto
//! `T`. Both copies keep the publisher's header (sequence number, stamps), so a consumer sees the
//! frames that crossed as the producer numbered them. Either copy validates the sample first
//! (it is received through a [`Subscriber`]). A slow link then carries at most
//! `max_hz × size` bytes a second of that topic, and the robot's publisher never waits for it.

use super::LinkError;
use runtime::ports::{PortContext, Publisher, ReceiveError, SendError, Subscriber};
use shm_types::{DepthFrame, Message, ObjectMap};
use std::time::{Duration, Instant};

/// Name of the bridged relay topic of a limited topic.
pub fn relay_topic(topic: &str) -> String {
    format!("link/{topic}")
}

/// A message that can be copied into a loaned sample of its type, header included.
pub trait Copyable: Message {
    /// Copy `self` (every field a consumer reads) into `dst`.
    fn copy_into(&self, dst: &mut Self);
}

impl Copyable for DepthFrame {
    fn copy_into(&self, dst: &mut Self) {
        dst.header = self.header;
        dst.width = self.width;
        dst.height = self.height;
        dst.intrinsics = self.intrinsics;
        dst.camera_pose = self.camera_pose;
        dst.reserved = self.reserved;
        dst.pixels_mut().copy_from_slice(self.pixels());
    }
}

impl Copyable for ObjectMap {
    fn copy_into(&self, dst: &mut Self) {
        dst.copy_from(self);
    }
}

/// One direction of one limited topic.
trait Relay {
    /// Copy what is due; returns the samples copied.
    fn poll(&mut self, now: Instant) -> Result<u64, RelayError>;
    /// When the next copy may be due (outbound), if it waits for time.
    fn next_due(&self) -> Option<Instant>;
}

/// Why a relay failed.
#[derive(Debug, thiserror::Error)]
pub enum RelayError {
    /// Receiving the sample to copy failed.
    #[error(transparent)]
    Receive(#[from] ReceiveError),
    /// Loaning the copy failed.
    #[error(transparent)]
    Loan(#[from] runtime::ports::LoanError),
    /// Sending the copy failed.
    #[error(transparent)]
    Send(#[from] SendError),
}

/// Here → `link/T`: the newest sample of `T`, at most every `period`.
struct Outbound<T: Copyable> {
    from: Subscriber<T>,
    to: Publisher<T>,
    period: Duration,
    next: Instant,
}

impl<T: Copyable> Relay for Outbound<T> {
    fn poll(&mut self, now: Instant) -> Result<u64, RelayError> {
        if now < self.next {
            return Ok(0);
        }
        let Some(s) = self.from.latest()? else {
            return Ok(0);
        };
        let mut loan = self.to.loan()?;
        s.copy_into(&mut loan);
        loan.send_relayed()?;
        self.next = now + self.period;
        Ok(1)
    }

    fn next_due(&self) -> Option<Instant> {
        Some(self.next)
    }
}

/// `link/T` → `T` here: every sample that crossed.
struct Inbound<T: Copyable> {
    from: Subscriber<T>,
    to: Publisher<T>,
}

impl<T: Copyable> Relay for Inbound<T> {
    fn poll(&mut self, _now: Instant) -> Result<u64, RelayError> {
        let mut n = 0;
        while let Some(s) = self.from.receive()? {
            let mut loan = self.to.loan()?;
            s.copy_into(&mut loan);
            loan.send_relayed()?;
            n += 1;
        }
        Ok(n)
    }

    fn next_due(&self) -> Option<Instant> {
        None
    }
}

/// The relays of a tunnel's limited topics.
pub struct Throttle {
    /// (topic, relay, samples it copied).
    relays: Vec<(String, Box<dyn Relay>, u64)>,
    copied: u64,
}

impl std::fmt::Debug for Throttle {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Throttle")
            .field(
                "relays",
                &self.relays.iter().map(|r| &r.0).collect::<Vec<_>>(),
            )
            .field("copied", &self.copied)
            .finish()
    }
}

fn relay<T: Copyable>(
    ctx: &PortContext,
    topic: &str,
    outbound: bool,
    max_hz: f64,
) -> Result<Box<dyn Relay>, LinkError> {
    let link = relay_topic(topic);
    Ok(if outbound {
        Box::new(Outbound {
            from: ctx.subscriber::<T>(topic)?,
            to: ctx.publisher::<T>(&link)?,
            period: Duration::from_secs_f64(1.0 / max_hz),
            next: Instant::now(),
        })
    } else {
        Box::new(Inbound {
            from: ctx.subscriber::<T>(&link)?,
            to: ctx.publisher::<T>(topic)?,
        })
    })
}

impl Throttle {
    /// A relay per `(topic, max_hz)` in `limited`, outbound where the topic is in `local`.
    pub fn new(
        ctx: &PortContext,
        limited: &[(&'static str, f64)],
        local: &[&'static str],
    ) -> Result<Self, LinkError> {
        let mut relays = Vec::new();
        for &(topic, hz) in limited {
            let out = local.contains(&topic);
            let r = match topic {
                crate::topics::DEPTH => relay::<DepthFrame>(ctx, topic, out, hz)?,
                crate::topics::MAP => relay::<ObjectMap>(ctx, topic, out, hz)?,
                other => unreachable!("{other} is not a limitable topic"),
            };
            relays.push((topic.to_string(), r, 0));
        }
        Ok(Self { relays, copied: 0 })
    }

    /// Copy what is due on every relay.
    pub fn poll(&mut self, now: Instant) -> Result<u64, RelayError> {
        let mut n = 0;
        for (_, r, copied) in &mut self.relays {
            let k = r.poll(now)?;
            *copied += k;
            n += k;
        }
        self.copied += n;
        Ok(n)
    }

    /// The earliest time an outbound relay may copy again.
    pub fn next_due(&self) -> Option<Instant> {
        self.relays
            .iter()
            .filter_map(|(_, r, _)| r.next_due())
            .min()
    }

    /// Samples copied so far (both directions).
    pub fn copied(&self) -> u64 {
        self.copied
    }

    /// Samples the relay of `topic` copied so far (outbound: onto `link/<topic>`, i.e. the
    /// samples that crossed; inbound: back onto `topic` here, i.e. the samples received).
    pub fn copied_of(&self, topic: &str) -> u64 {
        self.relays
            .iter()
            .filter(|(t, _, _)| t == topic)
            .map(|(_, _, n)| n)
            .sum()
    }
}
