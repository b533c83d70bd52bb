//! The command line: one file per subcommand, each with its clap `Args` (whose doc comments
//! are the help text) and a `run()`.

mod body_check;
#[cfg(feature = "vision")]
mod camera;
#[cfg(feature = "vision")]
mod check;
mod develop;
mod export;
mod import;
mod inspect;
mod keygen;
mod lab_files;
#[cfg(feature = "vision")]
mod laser;
mod measure;
mod outputs;
mod parse;
mod photos;
mod pixels;
mod progress;
mod signing;
mod units;
#[cfg(feature = "vision")]
mod validate;
mod verify;

pub use develop::develop_one;
pub use parse::show_number;

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
    Camera(camera::CameraArgs),
    #[cfg(feature = "vision")]
    Laser(laser::LaserArgs),
    Keygen(keygen::KeygenArgs),
    Inspect(inspect::InspectArgs),
    Verify(verify::VerifyArgs),
    Units(units::UnitsArgs),
    Import(import::ImportArgs),
    Export(export::ExportArgs),
    #[cfg(feature = "vision")]
    Validate(validate::ValidateArgs),
    #[cfg(feature = "vision")]
    Check(check::CheckArgs),
    Measure(measure::MeasureArgs),
}

/// The one line an error is printed as: its message and each cause of its chain, each said
/// once. A cause whose words the line already holds (an error that names its cause and
/// also reports it as its source) is not repeated: "No such file or directory (os error
/// 2): No such file or directory (os error 2)" reads as a fault of the tool.
pub fn error_line(err: &anyhow::Error) -> String {
    let mut line = String::new();
    for cause in err.chain() {
        let text = cause.to_string();
        if text.is_empty() || line.contains(&text) {
            continue;
        }
        if !line.is_empty() {
            line.push_str(": ");
        }
        line.push_str(&text);
    }
    line
}

/// Parses the command line and runs the subcommand.
pub fn run() -> anyhow::Result<ExitCode> {
    set_up_process();
    run_parsed(Cli::parse())
}

/// What the process sets before any thread starts; the crate's one `unsafe` block.
///
/// - glibc gives each thread that allocates its own heap arena, and memory freed there goes
///   back to the system only from the top of the heap; with every photo's maps, crops and
///   thumbnails freed in whichever worker made them, the arenas held a 300-photo `laser
///   --report` at 305-340 MB peak over three runs, against 298-301 MB with two arenas
///   (issue 17's limit is 330). The cost is the workers' contention on the shared arena:
///   `laser` on 16 photos takes the same time, `measure --masks` on 100 photos 3.1-3.3 s
///   instead of 2.9 s (system time 0.1 -> 0.5 s), still twice the 15 photos/s it must reach.
///   (glibc reads its environment variable for this before `main`, too early to set it from
///   here.)
/// - A reader that closes the pipe early (`fslcal check --json ... | head`) ends the
///   process quietly, as it ends any Unix filter: Rust ignores SIGPIPE, and every `println!`
///   after the reader left panicked with a backtrace instead.
#[allow(unsafe_code)]
fn set_up_process() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: both are called before any thread starts; mallopt only sets an allocator
    // parameter, and signal restores one signal's default disposition (no handler of ours).
    unsafe {
        libc::mallopt(libc::M_ARENA_MAX, 2);
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
}

/// Runs the command line `args` (the program's name first) in this process, as `main` runs
/// the process's own: tests count what a whole command does (e.g. photo decodes) this way.
pub fn run_from(args: impl IntoIterator<Item = impl Into<std::ffi::OsString> + Clone>) -> anyhow::Result<ExitCode> {
    run_parsed(Cli::try_parse_from(args)?)
}

fn run_parsed(cli: Cli) -> anyhow::Result<ExitCode> {
    match cli.command {
        Command::Develop(args) => develop::run(args),
        #[cfg(feature = "vision")]
        Command::Camera(args) => camera::run(args),
        #[cfg(feature = "vision")]
        Command::Laser(args) => laser::run(args),
        Command::Keygen(args) => keygen::run(args),
        Command::Inspect(args) => inspect::run(args),
        Command::Verify(args) => verify::run(args),
        Command::Units(args) => units::run(args),
        Command::Import(args) => import::run(args),
        Command::Export(args) => export::run(args),
        #[cfg(feature = "vision")]
        Command::Validate(args) => validate::run(args),
        #[cfg(feature = "vision")]
        Command::Check(args) => check::run(args),
        Command::Measure(args) => measure::run(args),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, thiserror::Error)]
    #[error("{path}: cannot read: {source}")]
    struct Twice {
        path: String,
        source: std::io::Error,
    }

    #[test]
    fn each_cause_is_said_once() {
        let io = || std::io::Error::new(std::io::ErrorKind::NotFound, "No such file or directory (os error 2)");
        let err = anyhow::Error::new(Twice { path: "x.orf".into(), source: io() });
        assert_eq!(
            format!("{err:#}"),
            "x.orf: cannot read: No such file or directory (os error 2): No such file or directory (os error 2)"
        );
        assert_eq!(error_line(&err), "x.orf: cannot read: No such file or directory (os error 2)");
        let wrapped = anyhow::Error::new(io()).context("camera.yml: cannot read");
        assert_eq!(error_line(&wrapped), "camera.yml: cannot read: No such file or directory (os error 2)");
    }
}
