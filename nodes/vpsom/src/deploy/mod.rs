//! The deployment host: `vpsom run` launches the sim, mapper, planner and recorder (or the
//! subset `--nodes` names) as separate processes (`vpsom node <role>`) that talk through iceoryx2 shared memory on the real clock at
//! fixed rates, watches them (exit status, iceoryx2 dead nodes, restarts), and scores the session
//! from what it hears on the topics.
//!
//! # Files
//! | file | content |
//! |---|---|
//! | [`host`] | the node-hosting abstraction: [`NodeHost`](host::NodeHost) (start → step → health → finish) and [`drive`](host::drive), the one loop around every node (stop flag, thread and pace, timing, errors); [`HostError`] |
//! | `health` | [`Heartbeat`](health) of every node (`NodeHealth` on `health`), the launcher's watch of them, [`InputAccount`] |
//! | `sim` | [`sim_node`]: the simulator, periodic executor thread at `rates.state_hz` |
//! | `mapper` | [`mapper_node`]: the mapper, main thread, woken by depth frames |
//! | `planner` | [`planner_node`]: the LBV on the deadline-monitored executor, GBV rounds and the GBV load on the worker pool |
//! | `recorder` | [`recorder_node`]: every topic to `trace.mcap`, polled; [`recorder_setup`] |
//! | `launch` | [`run`]: launch, watch and score a run; [`RunArgs`], [`RunOutcome`], [`run_config`] |
//! | [`link`] | `--link`: this run's topics bridged to another host through iceoryx2's link tunnel over zenoh ([`link::Link`]) |
//! | `external` | `--nodes`: [`parse_nodes`], [`external_inputs`] (what must come from a robot's drivers), [`ExternalInputs`] (publisher watch and report) |
//!
//! Time: the sim advances `time_scale` simulated seconds per wall second; every rate in the
//! configuration is in simulated time, so wall periods are divided by `time_scale`. Message
//! headers carry both the producer's monotonic clock (`stamp_ns`, for latency) and the simulated
//! time (`sim_time_ns`).

mod external;
mod health;
pub mod host;
mod launch;
pub mod link;
mod mapper;
mod planner;
mod recorder;
mod sim;

pub use external::{ExternalInputs, REPORT_EVERY, ROLES, external_inputs, parse_nodes};
pub use health::{InputAccount, report_input};
pub use host::HostError;
pub use launch::{RunArgs, RunOutcome, run, run_config};
pub use mapper::mapper_node;
pub use planner::planner_node;
pub use recorder::{recorder_node, recorder_setup};
pub use sim::sim_node;
