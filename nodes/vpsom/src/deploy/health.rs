//! Liveness and input accounting of a run: every node host's [`Heartbeat`] (a `NodeHealth` on
//! the `health` topic at `[run] health_hz`, published from the thread that steps the node, so a
//! node that hangs without dying falls silent), and the launcher's [`HealthWatch`] (feeds the
//! heartbeats to the [`Launcher`]'s hang detection and keeps each node's input counts for the
//! run summary).

use super::host::{HostError, NodeHost};
use crate::topics;
use runtime::clock::{Clock, MonotonicClock};
use runtime::launcher::Launcher;
use runtime::ports::{PortContext, Publisher, ReceiveError, Stamp, Subscriber, SubscriberError};
use shm_types::{Message, NodeHealth};
use std::collections::BTreeMap;
use std::time::Duration;

/// Append subscriber `s` on `topic` to a health report: received, invalid, overflow (samples
/// lost before they were read).
pub fn report_input<T: Message>(h: &mut NodeHealth, topic: &str, s: &Subscriber<T>) {
    h.push_input(topic, s.received(), s.invalid(), s.gaps());
}

/// A node's heartbeat publisher, ticked after every step.
pub(super) struct Heartbeat {
    publisher: Publisher<NodeHealth>,
    clock: MonotonicClock,
    period_ns: u64,
    next_ns: u64,
    steps: u64,
    pid: u32,
}

impl Heartbeat {
    /// The heartbeat of `host`, if it has one (on the stepping thread: ports are not `Send`).
    pub fn of<H: NodeHost>(host: &H) -> Result<Option<Self>, HostError> {
        let Some((ctx, period)) = host.heartbeat() else {
            return Ok(None);
        };
        Ok(Some(Self::new(ctx, period)?))
    }

    fn new(ctx: &PortContext, period: Duration) -> Result<Self, HostError> {
        Ok(Self {
            publisher: ctx.publisher(topics::HEALTH)?,
            clock: MonotonicClock::new(),
            period_ns: period.as_nanos().try_into().unwrap_or(u64::MAX),
            next_ns: 0,
            steps: 0,
            pid: std::process::id(),
        })
    }

    /// One step done: publish `host`'s health if a period has passed since the last one (the
    /// first step always does). No allocation: the report is written into the loaned sample.
    pub fn tick<H: NodeHost>(&mut self, name: &str, host: &H) -> Result<(), HostError> {
        self.steps += 1;
        let now = self.clock.now_ns();
        if now < self.next_ns {
            return Ok(());
        }
        self.next_ns = now + self.period_ns;
        let mut h = self.publisher.loan()?;
        h.set_node_name(name);
        h.pid = self.pid;
        h.steps = self.steps;
        h.clear_inputs();
        host.inputs(&mut h);
        h.send(Stamp {
            source_ns: now,
            sim_ns: 0,
        })?;
        Ok(())
    }
}

/// One input of one node, summed over the node's incarnations (a restarted node counts from 0).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct InputAccount {
    /// Node (role).
    pub node: String,
    /// Input topic.
    pub topic: String,
    /// Valid samples received.
    pub received: u64,
    /// Samples dropped on receipt (failed validation).
    pub invalid: u64,
    /// Samples lost before they were read (overflow).
    pub overflow: u64,
}

/// The launcher's side of the `health` topic.
pub(super) struct HealthWatch {
    sub: Subscriber<NodeHealth>,
    /// The newest report of each node incarnation: (node, pid) → report.
    newest: BTreeMap<(String, u32), NodeHealth>,
}

impl HealthWatch {
    pub fn new(ctx: &PortContext) -> Result<Self, SubscriberError> {
        Ok(Self {
            sub: ctx.subscriber(topics::HEALTH)?,
            newest: BTreeMap::new(),
        })
    }

    /// Read every heartbeat that arrived, telling `launcher` of each.
    pub fn poll(&mut self, launcher: &mut Launcher) -> Result<(), ReceiveError> {
        while let Some(h) = self.sub.receive()? {
            launcher.heartbeat(h.node_name(), h.pid);
            self.newest.insert((h.node_name().to_string(), h.pid), *h);
        }
        Ok(())
    }

    /// Whether every one of `roles` has sent a heartbeat: its ports are open, so a driver that
    /// starts publishing now loses nothing to a subscriber that is not there yet.
    pub fn all_up(&self, roles: &[&str]) -> bool {
        roles
            .iter()
            .all(|r| self.newest.keys().any(|(node, _)| node == r))
    }

    /// Every node's inputs, each summed over the node's incarnations, by node then topic.
    pub fn accounts(&self) -> Vec<InputAccount> {
        let mut sum: BTreeMap<(String, String), InputAccount> = BTreeMap::new();
        for ((node, _pid), h) in &self.newest {
            for i in h.inputs() {
                let a = sum
                    .entry((node.clone(), i.topic_name().to_string()))
                    .or_insert_with(|| InputAccount {
                        node: node.clone(),
                        topic: i.topic_name().to_string(),
                        ..InputAccount::default()
                    });
                a.received += i.received;
                a.invalid += i.invalid;
                a.overflow += i.overflow;
            }
        }
        sum.into_values().collect()
    }

    /// Heartbeats received and dropped as invalid (the topic has one publisher per node, so
    /// its sequence gaps mean nothing and are not reported).
    pub fn heartbeats(&self) -> (u64, u64) {
        (self.sub.received(), self.sub.invalid())
    }
}
