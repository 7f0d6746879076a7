//! Inspect an MCAP trace written by the recorder.
//!
//! ```text
//! cargo run -p runtime --example trace -- info FILE
//! cargo run -p runtime --example trace -- export FILE --topic /runtime/deadline --csv
//! ```
//! (`vpsom trace info|export` offers the same.)

use runtime::recorder::inspect::{export_csv, info};
use std::path::Path;
use std::process::ExitCode;

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let usage = "usage: trace info FILE | trace export FILE --topic T --csv";
    let result = match args
        .iter()
        .map(String::as_str)
        .collect::<Vec<_>>()
        .as_slice()
    {
        ["info", file] => info(Path::new(file)).map(|i| println!("{i}")),
        ["export", file, rest @ ..] => {
            let topic = rest
                .iter()
                .position(|a| *a == "--topic")
                .and_then(|i| rest.get(i + 1));
            match (topic, rest.contains(&"--csv")) {
                (Some(t), true) => {
                    let stdout = std::io::stdout();
                    let mut lock = stdout.lock();
                    export_csv(Path::new(file), t, &mut lock).map(|_| ())
                }
                _ => {
                    eprintln!("{usage}");
                    return ExitCode::from(2);
                }
            }
        }
        _ => {
            eprintln!("{usage}");
            return ExitCode::from(2);
        }
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
