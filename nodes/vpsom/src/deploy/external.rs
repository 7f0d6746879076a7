//! Which nodes a run hosts (`vpsom run --nodes`), which of their inputs must then come from
//! outside (a robot's drivers, or any process that meets the topic contract of
//! [`shm_types::contract`]), and the launcher's watch over those inputs: publisher counts,
//! samples seen, a report every [`REPORT_EVERY`] of the topics that have no publisher yet.

use crate::topics;
use runtime::ports::{PortContext, ReceiveError, Subscriber, SubscriberError};
use shm_types::{
    DepthFrame, Detections, Message, NavGoal, NeckGoal, ObjectMap, OccupancyGrid, RobotState,
};
use std::time::{Duration, Instant};

/// The node roles, in launch order (the recorder first, so it misses nothing).
pub const ROLES: [&str; 4] = ["recorder", "sim", "mapper", "planner"];

/// While an external input has no publisher, the launcher says so this often: often enough
/// to see a driver come up, rarely enough to leave the status line readable.
pub const REPORT_EVERY: Duration = Duration::from_secs(3);

/// Topics a role reads that another role (or a driver) must publish. The recorder reads
/// every topic but needs none.
fn inputs(role: &str) -> &'static [&'static str] {
    match role {
        "sim" => &[topics::NAV_GOAL, topics::NECK_GOAL],
        "mapper" => &[topics::DEPTH, topics::DETECTIONS, topics::STATE],
        "planner" => &[
            topics::MAP,
            topics::STATE,
            topics::NAV_GRID,
            topics::MAP_GRID,
        ],
        _ => &[],
    }
}

/// Topics a role publishes.
pub(super) fn outputs(role: &str) -> &'static [&'static str] {
    match role {
        "sim" => &[
            topics::DEPTH,
            topics::DETECTIONS,
            topics::STATE,
            topics::TRUTH,
            topics::VISIBILITY,
            topics::NAV_GRID,
        ],
        "mapper" => &[topics::MAP, topics::MAP_GRID],
        "planner" => &[
            topics::NAV_GOAL,
            topics::NECK_GOAL,
            topics::DECISION,
            topics::DEADLINE,
        ],
        _ => &[],
    }
}

/// Parse `--nodes` (a comma list, as clap splits it): the roles in launch order, each once.
/// Empty means every role.
pub fn parse_nodes(list: &[String]) -> Result<Vec<&'static str>, String> {
    if list.is_empty() {
        return Ok(ROLES.to_vec());
    }
    for name in list {
        if !ROLES.contains(&name.trim()) {
            return Err(format!(
                "--nodes: unknown node {name:?} (nodes: {})",
                ROLES.join(", ")
            ));
        }
    }
    Ok(ROLES
        .into_iter()
        .filter(|r| list.iter().any(|n| n.trim() == *r))
        .collect())
}

/// Inputs of the hosted `roles` that none of them publishes, in first-use order.
pub fn external_inputs(roles: &[&str]) -> Vec<&'static str> {
    let mut out: Vec<&'static str> = Vec::new();
    for role in roles {
        for topic in inputs(role) {
            let ours = roles.iter().any(|r| outputs(r).contains(topic));
            if !ours && !out.contains(topic) {
                out.push(topic);
            }
        }
    }
    out
}

/// A subscriber seen through what the launcher needs of it.
trait Watched {
    fn publishers(&self) -> usize;
    /// Receive everything buffered: `(samples, newest header.sim_time_ns)`.
    fn drain(&self) -> Result<(u64, Option<u64>), ReceiveError>;
    /// Samples dropped on receipt because they failed validation.
    fn invalid(&self) -> u64;
}

impl<T: Message> Watched for Subscriber<T> {
    fn publishers(&self) -> usize {
        self.publisher_count()
    }

    fn drain(&self) -> Result<(u64, Option<u64>), ReceiveError> {
        let (mut n, mut t) = (0, None);
        while let Some(s) = self.receive()? {
            n += 1;
            t = Some(s.header().sim_time_ns);
        }
        Ok((n, t))
    }

    fn invalid(&self) -> u64 {
        Subscriber::invalid(self)
    }
}

fn watch(ctx: &PortContext, topic: &str) -> Result<Box<dyn Watched>, SubscriberError> {
    Ok(match topic {
        topics::DEPTH => Box::new(ctx.subscriber::<DepthFrame>(topic)?),
        topics::DETECTIONS => Box::new(ctx.subscriber::<Detections>(topic)?),
        topics::STATE => Box::new(ctx.subscriber::<RobotState>(topic)?),
        topics::MAP => Box::new(ctx.subscriber::<ObjectMap>(topic)?),
        topics::NAV_GRID | topics::MAP_GRID => Box::new(ctx.subscriber::<OccupancyGrid>(topic)?),
        topics::NAV_GOAL => Box::new(ctx.subscriber::<NavGoal>(topic)?),
        topics::NECK_GOAL => Box::new(ctx.subscriber::<NeckGoal>(topic)?),
        other => unreachable!("no external input is named {other}"),
    })
}

/// The launcher's watch over the inputs that must come from outside the run.
pub struct ExternalInputs {
    watched: Vec<(&'static str, Box<dyn Watched>, u64)>,
    namespace: String,
    last_report: Option<Instant>,
    all_present: bool,
    /// `sim_time_ns` of the first and the newest `robot/state` sample from outside.
    state_ns: Option<(u64, u64)>,
}

impl std::fmt::Debug for ExternalInputs {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ExternalInputs")
            .field("topics", &self.topics())
            .finish_non_exhaustive()
    }
}

impl ExternalInputs {
    /// Subscribe to every topic in `topics` (to count its publishers and samples).
    pub fn new(ctx: &PortContext, topics: &[&'static str]) -> Result<Self, SubscriberError> {
        Ok(Self {
            watched: topics
                .iter()
                .map(|t| Ok((*t, watch(ctx, t)?, 0)))
                .collect::<Result<_, SubscriberError>>()?,
            namespace: ctx.namespace().to_string(),
            last_report: None,
            all_present: false,
            state_ns: None,
        })
    }

    /// Robot time since the first external `robot/state` sample, ns (the run's clock when the
    /// sim does not run; a driver's time base may start anywhere, so only its progress counts).
    pub fn robot_elapsed_ns(&self) -> Option<u64> {
        self.state_ns
            .map(|(first, last)| last.saturating_sub(first))
    }

    /// The watched topics.
    pub fn topics(&self) -> Vec<&'static str> {
        self.watched.iter().map(|w| w.0).collect()
    }

    /// The watched topics that have no publisher now.
    pub fn missing(&self) -> Vec<&'static str> {
        self.watched
            .iter()
            .filter(|w| w.1.publishers() == 0)
            .map(|w| w.0)
            .collect()
    }

    /// Per topic: `(topic, valid samples seen, invalid samples dropped)` so far.
    pub fn samples(&self) -> Vec<(&'static str, u64, u64)> {
        self.watched
            .iter()
            .map(|w| (w.0, w.2, w.1.invalid()))
            .collect()
    }

    /// Drain every watched topic; then, if a topic has no publisher, say which (at most every
    /// [`REPORT_EVERY`]); once every topic has one, say so once. Returns the line to print.
    pub fn poll(&mut self, now: Instant) -> Result<Option<String>, ReceiveError> {
        for (topic, sub, seen) in &mut self.watched {
            let (n, t) = sub.drain()?;
            *seen += n;
            if let (true, Some(t)) = (*topic == topics::STATE, t) {
                let first = self.state_ns.map_or(t, |s| s.0);
                self.state_ns = Some((first, t));
            }
        }
        if self.watched.is_empty() {
            return Ok(None);
        }
        let missing = self.missing();
        if missing.is_empty() {
            if self.all_present {
                return Ok(None);
            }
            self.all_present = true;
            let counts: Vec<String> = self
                .watched
                .iter()
                .map(|w| format!("{} ({})", w.0, w.1.publishers()))
                .collect();
            return Ok(Some(format!(
                "external inputs: every topic has a publisher: {}",
                counts.join(", ")
            )));
        }
        self.all_present = false;
        if self
            .last_report
            .is_some_and(|t| now.duration_since(t) < REPORT_EVERY)
        {
            return Ok(None);
        }
        self.last_report = Some(now);
        let services: Vec<String> = missing
            .iter()
            .map(|t| shm_types::contract::service_name(&self.namespace, t))
            .collect();
        Ok(Some(format!(
            "waiting for external publishers: no publisher yet on {} (services {})",
            missing.join(", "),
            services.join(", ")
        )))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn without_the_sim_the_mapper_needs_the_sensor_topics_from_outside() {
        let roles = parse_nodes(&["mapper".into(), "planner".into(), "recorder".into()]).unwrap();
        assert_eq!(roles, ["recorder", "mapper", "planner"]);
        assert_eq!(
            external_inputs(&roles),
            [
                topics::DEPTH,
                topics::DETECTIONS,
                topics::STATE,
                topics::NAV_GRID
            ]
        );
        assert_eq!(external_inputs(&ROLES), Vec::<&str>::new());
        assert_eq!(parse_nodes(&[]).unwrap(), ROLES);
        assert!(parse_nodes(&["mapper".into(), "slam".into()]).is_err());
    }

    /// The topic names the nodes use are the contract's, and so are the service names.
    #[test]
    fn topics_are_the_contracts() {
        let all = [
            topics::DEPTH,
            topics::DETECTIONS,
            topics::STATE,
            topics::TRUTH,
            topics::VISIBILITY,
            topics::NAV_GRID,
            topics::MAP,
            topics::MAP_RESUME,
            topics::MAP_GRID,
            topics::NAV_GOAL,
            topics::NECK_GOAL,
            topics::DECISION,
            topics::DEADLINE,
            topics::HEALTH,
        ];
        let contract: Vec<&str> = shm_types::contract::topics()
            .iter()
            .map(|t| t.topic)
            .collect();
        assert_eq!(contract, all);
        assert_eq!(
            runtime::ports::SERVICE_ROOT,
            shm_types::contract::SERVICE_ROOT
        );
    }
}
