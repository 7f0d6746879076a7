//! The `vpsom` application: hosting of the pure node logic. Unlike the logic modules, this layer
//! owns processes, threads, clocks and iceoryx2 ports (through `runtime`).
//!
//! | module | what |
//! |---|---|
//! | [`deploy`] | `vpsom run`: one process per node over iceoryx2 on the real clock, launched and watched |
//! | [`gridpng`] | a run's final exploration grid and its frontiers as `explore.png` |
//! | [`lockstep`] | one process, one thread, simulated clock: deterministic sessions (bench, tests) |
//! | [`bench`](mod@bench) | scenes × planners × seeds on the lockstep host, report and figures |
//! | [`sensing`] | `vpsom sensing`: a scripted tour of each scene, sensing scored against the ground truth |
//! | [`topics`] | topic names of a live run |

pub mod bench;
pub mod deploy;
pub mod gridpng;
pub mod lockstep;
pub mod sensing;
pub mod topics;
