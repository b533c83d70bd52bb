//! `fslcal keygen`: the signing key a coordinator (or a dive lead) signs unit files with.

use crate::units::keys;
use fslcal_core::unit_file::KeyId;
use serde_json::json;
use std::path::PathBuf;
use std::process::ExitCode;

/// Make a signing key pair: KEY (secret, readable by you only) and KEY.pub (share it).
///
/// Keep KEY off shared drives; give KEY.pub to whoever verifies your calibrations
/// (`fslcal verify --trust`, the registry's `trusted/` folder). An existing key is never
/// replaced.
#[derive(clap::Args, Debug)]
pub struct KeygenArgs {
    /// Where to write the secret key; the public key goes to the same path plus `.pub`.
    #[arg(long, value_name = "KEY")]
    out: PathBuf,

    /// A note stored in KEY.pub, e.g. who holds the key.
    #[arg(long, default_value = "")]
    comment: String,

    /// Print one JSON object instead of the summary.
    #[arg(long)]
    json: bool,
}

pub fn run(args: KeygenArgs) -> anyhow::Result<ExitCode> {
    let public = keys::generate(&args.out, &args.comment)?;
    let pub_path = keys::public_path(&args.out);
    if args.json {
        let report = json!({
            "secret_key_file": args.out.display().to_string(),
            "public_key_file": pub_path.display().to_string(),
            "public_key": keys::hex(&public),
            "key_id": KeyId::of(&public).to_string(),
        });
        println!("{report}");
    } else {
        println!("secret key {} (mode 0600: keep it private)", args.out.display());
        println!(
            "public key {} (key id {}): give it to those who verify your files",
            pub_path.display(),
            KeyId::of(&public)
        );
    }
    Ok(ExitCode::SUCCESS)
}
