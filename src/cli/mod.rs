//! The command line: one file per subcommand, each with its clap `Args` (whose doc comments
//! are the help text) and a `run()`.

mod develop;
#[cfg(feature = "vision")]
mod laser;
mod progress;

pub use develop::develop_one;

use clap::{Parser, Subcommand};
use std::process::ExitCode;

/// Field calibration for FishSense Lite: fit the camera's laser from checkerboard photos and
/// say how far the result can be trusted.
#[derive(Parser, Debug)]
#[command(name = "fslcal", version, about, long_about = None)]
pub struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    Develop(develop::DevelopArgs),
    #[cfg(feature = "vision")]
    Laser(laser::LaserArgs),
}

/// Parses the command line and runs the subcommand.
pub fn run() -> anyhow::Result<ExitCode> {
    let cli = Cli::parse();
    match cli.command {
        Command::Develop(args) => develop::run(args),
        #[cfg(feature = "vision")]
        Command::Laser(args) => laser::run(args),
    }
}
