//! Hosting for vpsom-rt nodes: typed iceoryx2 ports, the periodic executor with its deadline
//! monitor, the low-priority worker pool, clocks, the MCAP recorder, and configuration loading.
//! Nothing here knows about view planning; node logic lives in the logic crates under `nodes/` (`sim`, `mapper`, `planner`, `eval`), hosted by the app crate `vpsom`.

pub mod clock;
pub mod config;
pub mod doctor;
pub mod executor;
pub mod launcher;
mod os;
pub mod pool;
pub mod ports;
pub mod recorder;
mod waker;
