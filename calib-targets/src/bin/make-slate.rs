//! `make-slate DIR [SEED]`: writes a synthetic taped dive slate (`DIR/scan.png`, 300x220 mm
//! at 2 px/mm) and its definition (`DIR/slate.toml`, docs/slate.md). The example slate in
//! `calib-targets/slates/example/` was made with seed 1.

use calib_targets::slate::{slate_toml, taped_slate_scan};
use std::path::PathBuf;
use std::process::ExitCode;

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(dir) = args.first().map(PathBuf::from) else {
        eprintln!("usage: make-slate DIR [SEED]");
        return ExitCode::FAILURE;
    };
    let seed = match args.get(1).map(|s| s.parse::<u64>()) {
        None => 1,
        Some(Ok(s)) => s,
        Some(Err(_)) => {
            eprintln!("make-slate: SEED must be a whole number");
            return ExitCode::FAILURE;
        }
    };
    let (w, h) = (300.0, 220.0);
    let lengths = [("diagonal", [20.0, 20.0], [280.0, 200.0]), ("across", [20.0, 110.0], [280.0, 110.0])];
    let result = std::fs::create_dir_all(&dir)
        .and_then(|_| taped_slate_scan(seed, w, h, 2.0).save(dir.join("scan.png")).map_err(std::io::Error::other))
        .and_then(|_| std::fs::write(dir.join("slate.toml"), slate_toml("scan.png", w, h, &lengths)));
    match result {
        Ok(()) => {
            println!("wrote {}/scan.png and slate.toml", dir.display());
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("make-slate: {}: {e}", dir.display());
            ExitCode::FAILURE
        }
    }
}
