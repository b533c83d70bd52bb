//! `fslcal`: one error path to an exit code; everything else lives in the library's `cli`.

use std::process::ExitCode;

fn main() -> ExitCode {
    match fslcal::cli::run() {
        Ok(code) => code,
        Err(err) => {
            // The context chain joined into the one line a diver reads, each cause once.
            eprintln!("fslcal: error: {}", fslcal::cli::error_line(&err));
            ExitCode::FAILURE
        }
    }
}
