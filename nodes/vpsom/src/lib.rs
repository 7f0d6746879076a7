//! The `vpsom` application: hosting of the pure node logic. Unlike the logic crates (`geom`,
//! `sim`, `mapper`, `planner`, `eval`, re-exported here), this crate owns processes, threads,
//! clocks, files and iceoryx2 ports (through `runtime`), and assembles the configuration
//! ([`config`]) from each logic crate's section.
//!
//! Ground truth stays in `sim` and `eval`: `mapper` and `planner` do not depend on them (Cargo
//! enforces it; `tests/layering.rs` checks what Cargo cannot).
//!
//! | module | what |
//! |---|---|
//! | [`config`] | the whole configuration: one typed struct per `config/default.toml` section |
//! | [`deploy`] | `vpsom run`: one process per node over iceoryx2 on the real clock, launched and watched |
//! | [`gridpng`] | a run's final exploration grid and its frontiers as `explore.png` |
//! | [`lockstep`] | one process, one thread, simulated clock: deterministic sessions (bench, tests) |
//! | [`bench`](mod@bench) | scenes × planners × seeds on the lockstep host, report and figures |
//! | [`recording`] | what a trace holds: the recorder's converter, topics and messages of our messages |
//! | [`replay`] | `vpsom replay`: the mapper and planner re-run on a trace's recorded inputs |
//! | [`step`] | one step loop: the mapper and planner stepped on a simulated clock (lockstep, replay) |
//! | [`sensing`] | `vpsom sensing`: a scripted tour of each scene, sensing scored against the ground truth |
//! | [`topics`] | topic names of a live run |
//!
//! [`error_report`] is how the binaries print an error.

pub mod bench;
pub mod config;
pub mod deploy;
pub mod gridpng;
pub mod lockstep;
pub mod orbit;
pub mod recording;
pub mod replay;
pub mod sensing;
pub mod step;
pub mod topics;
pub mod variants;

pub use eval;
pub use geom;
pub use mapper;
pub use planner;
pub use sim;

/// An error and its causes on one line, as `{:#}` prints them, but without repeating a cause
/// that its parent's message already contains (our error types name their cause in their own
/// message, e.g. `"FILE: cannot read scene file: No such file or directory"`, and also return it
/// as their `source`).
pub fn error_report(e: &anyhow::Error) -> String {
    let mut out = String::new();
    for cause in e.chain() {
        let text = cause.to_string();
        if out.contains(&text) {
            continue;
        }
        if !out.is_empty() {
            out.push_str(": ");
        }
        out.push_str(&text);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::error_report;
    use anyhow::Context;

    /// Regression: `vpsom bench --scene nope` printed "No such file or directory (os error 2)"
    /// twice, once from the scene error's message and once as its source.
    #[test]
    fn a_cause_already_in_the_message_is_not_repeated() {
        let e = crate::sim::Scene::builtin_or_load("no-such-scene.toml")
            .context("scene \"no-such-scene.toml\"")
            .unwrap_err();
        let report = error_report(&e);
        assert_eq!(
            report.matches("No such file or directory").count(),
            1,
            "{report}"
        );
        assert!(
            report.starts_with(
                "scene \"no-such-scene.toml\": no-such-scene.toml: cannot read scene file"
            ),
            "{report}"
        );
        // A cause that is not in its parent's message is kept, as `{:#}` keeps it.
        let e = anyhow::anyhow!("disk full").context("writing map.json");
        assert_eq!(error_report(&e), "writing map.json: disk full");
    }
}
