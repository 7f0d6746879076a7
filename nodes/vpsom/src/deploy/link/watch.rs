//! What crossed the link, per topic: the tunnel's own typed subscriber on every topic of the
//! run, counting the samples that came from the other host and the sequence numbers missing
//! between them (lost across the link, or while it was down).
//!
//! These subscribers also create the run's services before anything else on the host does
//! (the launcher starts the tunnel first), with the run's `[ports]` settings except that each
//! subscriber may borrow a little more (see [`tunnel_ports`]) and each topic's services buffer
//! [`service_depths`] samples per subscriber: [`STALL_S`](super::STALL_S) of the topic's rate,
//! a small topic at least [`LinkConfig::buffer`](crate::config::LinkConfig). The tunnel's own
//! subscribers (the bridge's, and these) take that depth, so the bursts in which samples come
//! over a network do not overwrite them; the nodes' subscribers keep the depth they ask for (a
//! service admits any depth up to its own), the recorder asks for that depth too.

use super::TopicCount;
use crate::topics;
use runtime::ports::{PortContext, ReceiveError, Subscriber, SubscriberError};
use shm_types::{
    DeadlineEvent, DepthFrame, Detections, FrameVisibility, Message, NavGoal, NeckGoal, NodeHealth,
    ObjectMap, OccupancyGrid, PlannerDecision, RobotState,
};
use std::collections::BTreeMap;
use std::time::{Duration, Instant};

/// Every topic of a run (the tunnel's allow-list is built from it).
pub const RUN_TOPICS: [&str; 12] = [
    topics::DEPTH,
    topics::DETECTIONS,
    topics::STATE,
    topics::TRUTH,
    topics::VISIBILITY,
    topics::NAV_GRID,
    topics::MAP,
    topics::MAP_GRID,
    topics::NAV_GOAL,
    topics::NECK_GOAL,
    topics::DECISION,
    topics::DEADLINE,
];

/// Topics whose message is at most this big get the tunnel's deeper buffer.
pub const SMALL: usize = 16 * 1024;

/// Whether `topic`'s message is small ([`SMALL`]).
pub fn is_small(topic: &str) -> bool {
    message_size(topic) <= SMALL
}

/// The size of a run topic's message, bytes.
fn message_size(topic: &str) -> usize {
    use std::mem::size_of;
    match topic {
        topics::DEPTH => size_of::<DepthFrame>(),
        topics::DETECTIONS => size_of::<Detections>(),
        topics::STATE | topics::TRUTH => size_of::<RobotState>(),
        topics::VISIBILITY => size_of::<FrameVisibility>(),
        topics::NAV_GRID | topics::MAP_GRID => size_of::<OccupancyGrid>(),
        topics::MAP => size_of::<ObjectMap>(),
        topics::NAV_GOAL => size_of::<NavGoal>(),
        topics::NECK_GOAL => size_of::<NeckGoal>(),
        topics::DECISION => size_of::<PlannerDecision>(),
        topics::DEADLINE => size_of::<DeadlineEvent>(),
        other => unreachable!("{other} is not a run topic"),
    }
}

/// Extra samples a subscriber may hold borrowed on a service the tunnel created.
const EXTRA_BORROWS: usize = 2;

/// The subscriber depth the tunnel creates each run topic's services with (see the module
/// docs): [`burst_depth`](super::burst_depth) of the topic's wall rate at `time_scale`,
/// at least `[ports]`' depth and, for a small topic, at least `[link] buffer`. A node here may
/// then subscribe that deep (the station's recorder does: `deploy::recorder::recorder_ports`).
pub fn service_depths(cfg: &crate::config::Config, time_scale: f64) -> Vec<(&'static str, usize)> {
    RUN_TOPICS
        .iter()
        .map(|&topic| {
            let configured = cfg.ports.topic(topic).subscriber_buffer;
            let large = message_size(topic) > SMALL;
            let base = if large {
                configured
            } else {
                configured.max(cfg.link.buffer)
            };
            let hz = super::wall_hz(topic, cfg, time_scale);
            (topic, super::burst_depth(hz, base, large))
        })
        .collect()
}

/// The `[ports]` settings the tunnel creates the run's services with: each run topic's
/// subscribers as deep as `depths` says ([`service_depths`]; see the module docs), and every
/// subscriber may hold [`EXTRA_BORROWS`] more samples borrowed than `[ports]` says. Samples from
/// the other host come in bursts, so a consumer that keeps the newest sample while draining to
/// the next (`Subscriber::latest`) holds three at once where one host rarely gives it two
/// (regression: the planner on the station died with `ExceedsMaxBorrows` on `map`).
pub fn tunnel_ports(
    ports: &runtime::ports::PortsConfig,
    depths: &[(&'static str, usize)],
) -> runtime::ports::PortsConfig {
    let mut p = ports.clone();
    for topic in RUN_TOPICS {
        let s = ports.topic(topic);
        let o = p.topics.entry(topic.to_string()).or_default();
        o.subscriber_max_borrowed = Some(s.subscriber_max_borrowed + EXTRA_BORROWS);
        if let Some(&(_, depth)) = depths.iter().find(|(t, _)| *t == topic) {
            o.subscriber_buffer = Some(depth);
        }
    }
    p
}

/// Least interval between two log lines about lost samples on one topic.
const LOSS_LOG_EVERY: Duration = Duration::from_secs(1);

/// A typed subscriber seen as sequence numbers.
trait Seqs {
    /// Receive everything buffered, calling `f` with each sample's `header.seq`.
    fn drain(&self, f: &mut dyn FnMut(u64)) -> Result<(), ReceiveError>;
    /// Samples dropped on receipt because they failed validation.
    fn invalid(&self) -> u64;
}

impl<T: Message> Seqs for Subscriber<T> {
    fn drain(&self, f: &mut dyn FnMut(u64)) -> Result<(), ReceiveError> {
        while let Some(s) = self.receive()? {
            f(s.header().seq);
        }
        Ok(())
    }

    fn invalid(&self) -> u64 {
        Subscriber::invalid(self)
    }
}

fn subscribe(ctx: &PortContext, topic: &str) -> Result<Box<dyn Seqs>, SubscriberError> {
    Ok(match topic {
        topics::DEPTH => Box::new(ctx.subscriber::<DepthFrame>(topic)?),
        topics::DETECTIONS => Box::new(ctx.subscriber::<Detections>(topic)?),
        topics::STATE | topics::TRUTH => Box::new(ctx.subscriber::<RobotState>(topic)?),
        topics::VISIBILITY => Box::new(ctx.subscriber::<FrameVisibility>(topic)?),
        topics::NAV_GRID | topics::MAP_GRID => Box::new(ctx.subscriber::<OccupancyGrid>(topic)?),
        topics::MAP => Box::new(ctx.subscriber::<ObjectMap>(topic)?),
        topics::NAV_GOAL => Box::new(ctx.subscriber::<NavGoal>(topic)?),
        topics::NECK_GOAL => Box::new(ctx.subscriber::<NeckGoal>(topic)?),
        topics::DECISION => Box::new(ctx.subscriber::<PlannerDecision>(topic)?),
        topics::DEADLINE => Box::new(ctx.subscriber::<DeadlineEvent>(topic)?),
        other => unreachable!("{other} is not a run topic"),
    })
}

/// One topic's account.
struct Watched {
    topic: &'static str,
    sub: Box<dyn Seqs>,
    /// Published on the other host (inbound); else here (outbound).
    remote: bool,
    /// Rate-limited (`[link.max_hz]`): crosses through a relay, so its sequence gaps across the
    /// link are by design, not losses.
    limited: bool,
    /// Its wall rate, Hz ([`super::wall_hz`] at the run's time scale), for the report.
    hz: Option<f64>,
    last_seq: Option<u64>,
    /// Sequence numbers of earlier publisher incarnations (a restarted node counts from 1).
    seq_base: u64,
    samples: u64,
    /// Sequence numbers missing in what this subscriber received (before the first and between
    /// two): inbound, lost in the tunnel; outbound, dropped before the tunnel took them.
    missing: u64,
    /// Of `missing`, those between two received samples (a local subscriber sees them as gaps
    /// too).
    interior: u64,
    last_loss_log: Option<Instant>,
}

impl Watched {
    /// Account for a received sequence number; returns the sequence numbers it skipped.
    fn observe(&mut self, seq: u64) -> u64 {
        self.samples += 1;
        let skipped = match self.last_seq {
            // A restarted publisher counts from 1 again.
            Some(l) if seq <= l => {
                self.seq_base += l;
                seq.saturating_sub(1)
            }
            Some(l) => {
                self.interior += seq - l - 1;
                seq - l - 1
            }
            None => seq.saturating_sub(1),
        };
        self.missing += skipped;
        self.last_seq = Some(seq);
        skipped
    }

    /// Sequence numbers the publisher used so far (as far as seen here).
    fn published(&self) -> u64 {
        self.seq_base + self.last_seq.unwrap_or(0)
    }
}

/// The newest input account each local node reported on `health` (see `deploy::health`).
#[derive(Default)]
struct NodeInputs {
    /// (node, pid) → [(topic, overflow)].
    newest: BTreeMap<(String, u32), Vec<(String, u64)>>,
}

impl NodeInputs {
    fn take(&mut self, h: &NodeHealth) {
        let inputs = h
            .inputs()
            .iter()
            .map(|i| (i.topic_name().to_string(), i.overflow))
            .collect();
        self.newest
            .insert((h.node_name().to_string(), h.pid), inputs);
    }

    /// Per node (summed over its incarnations): samples of `topic` it lost to overflow.
    fn overflow(&self, topic: &str) -> BTreeMap<String, u64> {
        let mut by_node = BTreeMap::new();
        for ((node, _), inputs) in &self.newest {
            for (t, n) in inputs {
                if t == topic {
                    *by_node.entry(node.clone()).or_insert(0) += n;
                }
            }
        }
        by_node
    }
}

/// The per-topic account of a tunnel (see the module docs).
pub struct Watch {
    topics: Vec<Watched>,
    health: Subscriber<NodeHealth>,
    nodes: NodeInputs,
}

impl std::fmt::Debug for Watch {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Watch")
            .field("topics", &self.topics.len())
            .finish_non_exhaustive()
    }
}

impl Watch {
    /// Subscribe to every run topic (and to the nodes' heartbeats, for their overflow
    /// counts); `local` are the topics published on this host, `limited` the rate-limited ones,
    /// `hz` each topic's wall rate.
    pub fn new(
        ctx: &PortContext,
        local: &[&'static str],
        limited: &[&'static str],
        hz: impl Fn(&str) -> Option<f64>,
    ) -> Result<Self, SubscriberError> {
        let topics = RUN_TOPICS
            .iter()
            .map(|&topic| {
                Ok(Watched {
                    topic,
                    sub: subscribe(ctx, topic)?,
                    remote: !local.contains(&topic),
                    limited: limited.contains(&topic),
                    hz: hz(topic),
                    last_seq: None,
                    seq_base: 0,
                    samples: 0,
                    missing: 0,
                    interior: 0,
                    last_loss_log: None,
                })
            })
            .collect::<Result<_, SubscriberError>>()?;
        Ok(Self {
            topics,
            health: ctx.subscriber(topics::HEALTH)?,
            nodes: NodeInputs::default(),
        })
    }

    /// Drain every subscriber; returns the inbound samples received. Logs sequence numbers lost
    /// across the link at most once per [`LOSS_LOG_EVERY`] per topic.
    pub fn poll(&mut self, now: Instant) -> Result<u64, ReceiveError> {
        let mut inbound = 0;
        for w in &mut self.topics {
            let (mut lost_now, mut jump) = (0u64, None);
            let before = w.samples;
            let mut seqs = Vec::new();
            w.sub.drain(&mut |seq| seqs.push(seq))?;
            for seq in seqs {
                let last = w.last_seq.unwrap_or(0);
                let skipped = w.observe(seq);
                if skipped > 0 && w.remote && !w.limited {
                    lost_now += skipped;
                    jump = Some((last, seq));
                }
            }
            if w.remote {
                inbound += w.samples - before;
            }
            if lost_now > 0
                && w.last_loss_log
                    .is_none_or(|t| now.duration_since(t) >= LOSS_LOG_EVERY)
            {
                w.last_loss_log = Some(now);
                let (a, b) = jump.unwrap_or_default();
                eprintln!(
                    "\nlink: {}: {lost_now} sample(s) lost across the link (seq {a} -> {b}; {} so far)",
                    w.topic, w.missing
                );
            }
        }
        while let Some(h) = self.health.receive()? {
            self.nodes.take(&h);
        }
        Ok(inbound)
    }

    /// Per-topic counts (topics that saw nothing are left out); `relayed(topic)`: the samples
    /// the rate-limit relay of `topic` copied.
    pub fn counts(&self, relayed: impl Fn(&str) -> u64) -> Vec<TopicCount> {
        self.topics
            .iter()
            .filter(|w| w.samples > 0 || w.sub.invalid() > 0)
            .map(|w| {
                let mut dropped: Vec<(String, u64)> = self
                    .nodes
                    .overflow(w.topic)
                    .into_iter()
                    .map(|(node, gaps)| {
                        // A node's sequence gaps include what never reached this host.
                        let n = if w.remote && !w.limited {
                            gaps.saturating_sub(w.interior)
                        } else {
                            gaps
                        };
                        (node, n)
                    })
                    .collect();
                // A rate-limited topic's nodes here see the limit's gaps: not losses.
                if w.remote && w.limited {
                    dropped.clear();
                }
                let (published, crossed, received, lost) = match (w.remote, w.limited) {
                    (false, false) => (w.published(), w.samples, 0, 0),
                    (false, true) => (w.published(), relayed(w.topic), 0, 0),
                    (true, false) => (0, 0, w.samples, w.missing),
                    (true, true) => (0, 0, relayed(w.topic), 0),
                };
                TopicCount {
                    topic: w.topic,
                    inbound: w.remote,
                    limited: w.limited,
                    hz: w.hz,
                    published,
                    crossed,
                    received,
                    lost,
                    dropped,
                    invalid: w.sub.invalid(),
                }
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    struct NoSamples;

    impl Seqs for NoSamples {
        fn drain(&self, _f: &mut dyn FnMut(u64)) -> Result<(), ReceiveError> {
            Ok(())
        }

        fn invalid(&self) -> u64 {
            0
        }
    }

    #[test]
    fn every_sequence_number_is_received_or_missing_across_a_publisher_restart() {
        let mut w = Watched {
            topic: topics::STATE,
            sub: Box::new(NoSamples),
            remote: true,
            limited: false,
            hz: None,
            last_seq: None,
            seq_base: 0,
            samples: 0,
            missing: 0,
            interior: 0,
            last_loss_log: None,
        };
        // 1, 2 before the first arrival; 5 between; a restart after 7; 3, 4 of the second run.
        let skipped: Vec<u64> = [3, 4, 6, 7, 1, 2, 5].map(|s| w.observe(s)).to_vec();
        assert_eq!(skipped, [2, 0, 1, 0, 0, 0, 2]);
        assert_eq!(w.published(), 7 + 5);
        assert_eq!((w.samples, w.missing, w.interior), (7, 5, 3));
        assert_eq!(w.samples + w.missing, w.published());
    }

    /// The tunnel's services hold a second of each topic at the run's own time scale
    /// (`--time-scale`), not `[run] time_scale` (regression: a station at `--time-scale 4`
    /// buffered half a second of robot/state).
    #[test]
    fn service_depths_hold_a_second_at_the_runs_time_scale() {
        let mut cfg = crate::config::Config::builtin();
        cfg.rates.state_hz = 50.0;
        cfg.run.time_scale = 1.0;
        let depth = |scale| {
            service_depths(&cfg, scale)
                .into_iter()
                .find(|(t, _)| *t == topics::STATE)
                .unwrap()
                .1
        };
        assert_eq!(depth(4.0), 200);
        assert_eq!(depth(5.0), 250);
        assert!(depth(1.0) < 200);
    }
}
