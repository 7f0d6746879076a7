//! `vpsom`: the vpsom-rt command line.

use clap::{Parser, Subcommand};
use std::path::PathBuf;
use std::process::ExitCode;

/// Active sparse object mapping with VP-SOM view planning on a zero-copy real-time runtime.
#[derive(Debug, Parser)]
#[command(name = "vpsom", version, about, long_about = None)]
struct Cli {
    /// Configuration file (default: ./config/default.toml if present, else the built-in copy).
    #[arg(long, global = true)]
    config: Option<PathBuf>,
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Print what the runtime can get on this machine (shared memory, scheduling, clocks, CPUs).
    Doctor,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Some(Command::Doctor) | None => doctor(cli.config),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

fn doctor(config: Option<PathBuf>) -> anyhow::Result<()> {
    let (_cfg, from) = nodes::config::Config::load_or_default(config.as_deref())?;
    println!("config: {}", from.display());
    print!("{}", runtime::doctor::Report::gather());
    println!();
    Ok(())
}
