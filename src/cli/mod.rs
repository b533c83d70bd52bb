//! The command line: one file per subcommand, each with its clap `Args` (whose doc comments
//! are the help text) and a `run()`.

#[cfg(feature = "vision")]
mod camera;
#[cfg(feature = "vision")]
mod laser;
mod progress;

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
    #[cfg(feature = "vision")]
    Camera(camera::CameraArgs),
    #[cfg(feature = "vision")]
    Laser(laser::LaserArgs),
}

/// Parses the command line and runs the subcommand.
pub fn run() -> anyhow::Result<ExitCode> {
    let cli = Cli::parse();
    match cli.command {
        #[cfg(feature = "vision")]
        Command::Camera(args) => camera::run(args),
        #[cfg(feature = "vision")]
        Command::Laser(args) => laser::run(args),
    }
}
