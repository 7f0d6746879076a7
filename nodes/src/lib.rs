//! The robot's logic as pure structs, plus the `vpsom` application.
//!
//! Logic modules (`sim`, `mapper`, `planner`, `eval`, `geom`) take inputs and a time and return
//! outputs: they never touch iceoryx2, threads or the OS clock. `runtime` hosts them.
//! Ground truth stays in `sim` and `eval`: `mapper` and `planner` must not use `sim`'s world types
//! (a test in `tests/layering.rs` guards this).

pub mod app;
pub mod config;
pub mod eval;
pub mod geom;
pub mod mapper;
pub mod planner;
pub mod sim;
