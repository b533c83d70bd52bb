//! `fslcal`: one error path to an exit code; everything else lives in the library's `cli`.

use std::process::ExitCode;

fn main() -> ExitCode {
    match fslcal::cli::run() {
        Ok(code) => code,
        Err(err) => {
            // `{:#}` joins anyhow's context chain into the one line a diver reads.
            eprintln!("fslcal: error: {err:#}");
            ExitCode::FAILURE
        }
    }
}
