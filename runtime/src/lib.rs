//! Hosting for vpsom-rt nodes: typed iceoryx2 ports, the periodic executor with its deadline
//! monitor, the low-priority worker pool, clocks, the MCAP recorder, and configuration loading.
//! Nothing here knows about view planning; node logic lives in the `nodes` crate.

pub mod config;
pub mod executor;
pub mod ports;
