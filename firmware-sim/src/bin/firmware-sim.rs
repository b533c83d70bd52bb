//! `firmware-sim run SCRIPT --out DIR`: runs the companion firmware on a scripted dive and
//! writes the display after every step as a PNG (no SDL: the simulator crate's output-image
//! path only).

use anyhow::{bail, Context};
use clap::{Parser, Subcommand};
use embedded_graphics::pixelcolor::BinaryColor;
use embedded_graphics::prelude::*;
use embedded_graphics_simulator::{BinaryColorTheme, OutputSettingsBuilder, SimulatorDisplay};
use firmware_sim::script::{self, Command};
use firmware_sim::{screens, Config, Event, Firmware, Screen, TrustedKey};
use fslcal_core::unit_file;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

/// The FishSense Lite camera companion's firmware, run on a desktop.
#[derive(Parser, Debug)]
#[command(name = "firmware-sim", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Cmd,
}

#[derive(Subcommand, Debug)]
enum Cmd {
    Run(RunArgs),
}

/// Runs a dive script (clock, load, press, dot, validate; see docs/firmware-example/) and
/// writes every screen as DIR/NN-COMMAND.png.
#[derive(clap::Args, Debug)]
struct RunArgs {
    /// The dive script.
    script: PathBuf,
    /// Folder for the PNGs (created if missing).
    #[arg(long)]
    out: PathBuf,
    /// The unit this firmware is built for; files for other units are refused.
    #[arg(long, default_value = "FSL-03")]
    unit: String,
    /// Output pixels per display pixel.
    #[arg(long, default_value_t = 3)]
    scale: u32,
    /// Print one JSON object with every step instead of the table.
    #[arg(long)]
    json: bool,
}

/// The simulator trusts the format's worked-example key (`fslcal_core::unit_file::
/// EXAMPLE_SECRET_KEY`, public knowledge): a real build embeds the lab's public key instead.
pub const SIM_SIGNER_NAME: &str = "example-key";

fn main() -> ExitCode {
    let Cli { command: Cmd::Run(args) } = Cli::parse();
    match run(&args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("firmware-sim: error: {err:#}");
            ExitCode::FAILURE
        }
    }
}

/// One step of the dive, with everything read from disk before anything is written.
struct Step<'a> {
    line_no: usize,
    command: Command<'a>,
    file: Option<Vec<u8>>,
}

fn parse_script<'a>(path: &Path, text: &'a str) -> anyhow::Result<Vec<Step<'a>>> {
    let base = path.parent().unwrap_or(Path::new("."));
    let mut steps = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let command = match script::parse_line(line) {
            Ok(Some(c)) => c,
            Ok(None) => continue,
            Err(e) => bail!("{}:{}: {e}", path.display(), i + 1),
        };
        let file = match command {
            Command::Load { path: p } => {
                let full = base.join(p);
                Some(
                    std::fs::read(&full)
                        .with_context(|| format!("{}:{}: cannot read {}", path.display(), i + 1, full.display()))?,
                )
            }
            _ => None,
        };
        steps.push(Step { line_no: i + 1, command, file });
    }
    if steps.is_empty() {
        bail!("{}: no commands; see docs/firmware-example/dive.txt for the format", path.display());
    }
    Ok(steps)
}

fn run(args: &RunArgs) -> anyhow::Result<()> {
    let text = std::fs::read_to_string(&args.script)
        .with_context(|| format!("cannot read the script {}", args.script.display()))?;
    let steps = parse_script(&args.script, &text)?;
    if !(1..=16).contains(&args.scale) {
        bail!("--scale {} is out of range; use 1 to 16", args.scale);
    }
    std::fs::create_dir_all(&args.out).with_context(|| format!("cannot create {}", args.out.display()))?;

    let trusted: &'static [TrustedKey] = Box::leak(Box::new([TrustedKey {
        name: SIM_SIGNER_NAME,
        public_key: unit_file::public_key(&unit_file::EXAMPLE_SECRET_KEY),
    }]));
    let unit: &'static str = Box::leak(args.unit.clone().into_boxed_str());
    let mut fw = Box::new(Firmware::new(Config { unit, trusted_keys: trusted }));
    let settings = OutputSettingsBuilder::new().scale(args.scale).theme(BinaryColorTheme::OledBlue).build();
    let mut display = SimulatorDisplay::<BinaryColor>::new(Size::new(screens::WIDTH, screens::HEIGHT));

    let mut report = Vec::new();
    for (n, step) in steps.iter().enumerate() {
        let event = match step.command {
            Command::Clock { unix_s } => Event::SetClock { unix_s },
            Command::Load { .. } => Event::LoadFile(step.file.as_deref().unwrap_or(&[])),
            Command::Press(b) => Event::Press(b),
            Command::Dot { u_px, v_px } => Event::Dot { u_px, v_px },
            Command::Validate { measured_mm, true_mm } => Event::Validation { measured_mm, true_mm },
        };
        fw.handle(event);
        screens::draw(&fw, &mut display).unwrap_or_else(|e: core::convert::Infallible| match e {});
        let name = format!("{:02}-{}.png", n + 1, step.command.label());
        let png = encode_png(&display, &settings)?;
        let target = args.out.join(&name);
        write_atomically(&target, &png).with_context(|| format!("cannot write {}", target.display()))?;
        report.push((step.line_no, name, fw.screen(), summary(&fw)));
    }

    if args.json {
        let steps: Vec<_> = report
            .iter()
            .map(|(line, png, screen, what)| {
                serde_json::json!({ "line": line, "png": png, "screen": format!("{screen:?}"), "summary": what })
            })
            .collect();
        println!(
            "{}",
            serde_json::json!({ "script": args.script.display().to_string(), "out": args.out.display().to_string(), "steps": steps })
        );
    } else {
        for (line, png, screen, what) in &report {
            println!("line {line:>3}  {png:<20} {:<14} {what}", format!("{screen:?}"));
        }
        println!("{} screens written to {}", report.len(), args.out.display());
    }
    Ok(())
}

/// The screen's headline, for the table: what a reviewer would read off the PNG.
fn summary(fw: &Firmware) -> String {
    use firmware_sim::Calibration;
    match (fw.screen(), fw.calibration()) {
        (Screen::Invalid, Calibration::Invalid(why)) => {
            let [a, b, c] = screens::rejection_lines(fw.config().unit, why);
            format!("{} / {} / {}", a.as_str(), b.as_str(), c.as_str())
        }
        (Screen::Live, Calibration::Valid(cal)) => {
            let (big, lines) = screens::live_lines(fw, cal);
            format!("{} {}", big.as_str(), lines[0].as_str())
        }
        (Screen::Validation, _) => {
            let (verdict, big, _) = screens::validation_lines(fw);
            format!("{} {}", verdict.as_str(), big.as_str())
        }
        (Screen::DriftWarning, _) => screens::drift_lines(fw)[0].as_str().to_string(),
        (Screen::SelfCheck, Calibration::Valid(cal)) => {
            let l = screens::self_check_lines(fw, cal);
            format!("{} / {}", l[0].as_str(), l[1].as_str())
        }
        _ => String::new(),
    }
}

fn encode_png(
    display: &SimulatorDisplay<BinaryColor>,
    settings: &embedded_graphics_simulator::OutputSettings,
) -> anyhow::Result<Vec<u8>> {
    use image::ImageEncoder;
    let img = display.to_rgb_output_image(settings);
    let buf = img.as_image_buffer();
    let mut png = Vec::new();
    use image::codecs::png::{CompressionType, FilterType, PngEncoder};
    PngEncoder::new_with_quality(&mut png, CompressionType::Best, FilterType::Adaptive)
        .write_image(buf.as_raw(), buf.width(), buf.height(), image::ExtendedColorType::Rgb8)
        .context("PNG encoding failed")?;
    Ok(png)
}

/// Temporary file beside the target, fsync, rename: a killed run leaves whole PNGs only.
fn write_atomically(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let dir = path.parent().unwrap_or(Path::new("."));
    let mut tmp = tempfile::NamedTempFile::new_in(dir)?;
    tmp.write_all(bytes)?;
    tmp.as_file().sync_all()?;
    tmp.persist(path).map_err(|e| e.error)?;
    Ok(())
}
