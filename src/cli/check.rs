//! `fslcal check`: has the laser moved since it was calibrated?

use super::body_check::BodyCheckArgs;
use super::progress;
use crate::calibration;
use crate::calibration::drift::{check, CheckOutcome, DriftCheck, FLAG_SIGMAS};
use crate::documents::{self, check::CheckDocument};
use crate::photo::identity::ExpectedCamera;
use crate::report::{self, check::CheckReport};
use anyhow::{bail, Context};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

/// Check for a moved laser: every photo with a laser dot (fish photos too, no target
/// needed) is compared with the calibrated laser line's image.
///
/// A dot further from the line than the calibration's uncertainty and the dot's
/// localisation explain flags the photo; half the photos or more flagged means the mount
/// has moved. A laser turned within the plane of camera and beam cannot show here (its dot
/// slides along the line): `fslcal validate` at several distances catches that.
#[derive(clap::Args, Debug)]
pub struct CheckArgs {
    /// The calibration: the JSON `fslcal laser --out` writes, or a signed .fslcal.
    #[arg(long, value_name = "CAL")]
    cal: PathBuf,

    #[command(flatten)]
    body: BodyCheckArgs,

    /// Print one JSON object instead of the summary.
    #[arg(long)]
    json: bool,

    /// Write an HTML report into this folder (created if missing): each photo's offset
    /// against its flag threshold, and a thumbnail with the dot and the calibrated line.
    /// Written also when drift is found.
    #[arg(long, value_name = "DIR")]
    report: Option<PathBuf>,

    /// Photos with the laser dot in them.
    #[arg(required = true, value_name = "PHOTOS")]
    photos: Vec<PathBuf>,
}

pub fn run(args: CheckArgs) -> anyhow::Result<ExitCode> {
    let cal = calibration::load(&args.cal)?;
    for p in &args.photos {
        if !p.is_file() {
            bail!("{}: no such photo", p.display());
        }
    }
    args.body.check(&ExpectedCamera::from(&cal), &args.photos)?;
    let bar = progress::bar(args.photos.len(), "photos", args.json);
    let result = check(&cal, &args.photos, &|| bar.inc(1));
    bar.finish_and_clear();
    let r = result.context("drift check")?;
    if args.json {
        println!("{}", documents::to_text(&CheckDocument::from(&r))?);
    } else {
        print!("{}", summary(&r));
    }
    if let Some(dir) = &args.report {
        let index = report::check::write(dir, &CheckReport::of(&r, &cal))
            .with_context(|| format!("{}: cannot write the report", dir.display()))?;
        if !args.json {
            eprintln!("report: {}", index.display());
        }
    }
    if r.drifted {
        bail!(
            "the laser has moved since {} was made (implied direction change {:.2} deg): recalibrate with `fslcal laser`",
            args.cal.display(),
            r.implied_direction_change_deg.unwrap_or(f64::NAN)
        );
    }
    Ok(ExitCode::SUCCESS)
}

fn name_of(file: &str) -> String {
    Path::new(file).file_name().map_or_else(|| file.to_string(), |n| n.to_string_lossy().into_owned())
}

fn summary(r: &DriftCheck) -> String {
    let width = r.photos.iter().map(|p| name_of(&p.file).len()).max().unwrap_or(4).max(4);
    let mut s = format!("fslcal check: {} photos\n\n", r.photos.len());
    s += &format!(
        "  {:width$}  {:>19}  {:>7}  {:>9}  {:>8}  {:>5}  {}\n",
        "file", "dot px", "dist m", "offset px", "sigma px", "conf", "status"
    );
    for p in &r.photos {
        let dot = p.dot_px.map_or("-".into(), |d| format!("({:.1}, {:.1})", d[0], d[1]));
        let f = |x: Option<f64>, d: usize| x.map_or("-".to_string(), |x| format!("{x:.d$}"));
        let status = match p.outcome() {
            CheckOutcome::Skipped(why) => format!("skipped: {why}"),
            CheckOutcome::Flagged => "FLAG".to_string(),
            CheckOutcome::Within => "ok".to_string(),
        };
        s += &format!(
            "  {:width$}  {dot:>19}  {:>7}  {:>9}  {:>8}  {:>5}  {status}\n",
            name_of(&p.file),
            f(p.distance_m, 3),
            f(p.offset_px, 2),
            f(p.explained_sigma_px, 2),
            f(p.confidence, 2)
        );
    }
    let flagged = r.photos.iter().filter(|p| p.flag).count();
    s += &format!(
        "\njudged from {} sure dots of {} photos; flagged (offset over {FLAG_SIGMAS} sigma): {flagged} of {}\n",
        r.sure_dots,
        r.photos.len(),
        r.sure_dots
    );
    if let Some(d) = r.implied_direction_change_deg {
        s += &format!("implied change of the laser's direction: {d:.3} deg (median of the sure dots)\n");
    }
    s += if r.drifted { "\nverdict: DRIFTED\n" } else { "\nverdict: no drift seen\n" };
    s
}
