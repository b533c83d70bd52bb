//! `fslcal check`: has the laser moved since it was calibrated?

use super::body_check::BodyCheckArgs;
use super::outputs::{self, Input, Output};
use super::progress;
use crate::calibration;
use crate::calibration::drift::{check, CheckError, CheckOutcome, DriftCheck, FLAG_SIGMAS};
use crate::documents::{self, check::CheckDocument, refused::RefusedDocument};
use crate::photo::identity::ExpectedCamera;
use crate::photo::thumbnails::Keeping;
use crate::report::{self, check::CheckReport};
use anyhow::bail;
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
    let mut inputs = vec![Input::new("--cal", &args.cal)];
    inputs.extend(args.photos.iter().map(|p| Input::new("photo", p)));
    let outs: Vec<Output> = args.report.as_deref().map(|p| Output::report("--report", p)).into_iter().collect();
    outputs::check(&inputs, &outs, false)?;
    let cal = calibration::load(&args.cal)?;
    let args = CheckArgs { photos: super::photos::prepare(&args.photos)?, ..args };
    args.body.check(&ExpectedCamera::from(&cal), &args.photos)?;
    // The report's thumbnails come from each photo's one decode, kept while the run lasts.
    let _thumbnails = args.report.is_some().then(|| Keeping::start(report::THUMBNAIL_WIDTH_PX));
    let bar = progress::bar(args.photos.len(), "photos", args.json);
    let result = check(&cal, &args.photos, &|| bar.inc(1));
    bar.finish_and_clear();
    // No judgeable dot is still a run that read photos: each says why, then the error.
    let (r, refused) = match result {
        Ok(r) => (r, None),
        Err(e @ CheckError::NoDots { .. }) => {
            let message = e.to_string();
            let CheckError::NoDots { photos } = e else { unreachable!() };
            (DriftCheck { photos, drifted: false, sure_dots: 0, implied_direction_change_deg: None }, Some(message))
        }
        Err(e) => return Err(anyhow::Error::new(e).context("drift check")),
    };
    match (&refused, args.json) {
        (Some(error), true) => println!("{}", documents::to_text(&RefusedDocument::new(error, r.photos.clone()))?),
        (None, true) => println!("{}", documents::to_text(&CheckDocument::from(&r))?),
        (_, false) => print!("{}", summary(&r, fslcal_core::covariance_known(&cal.laser_covariance))),
    }
    if let Some(dir) = &args.report {
        outputs::say_if_replacing(dir);
        let index = report::check::write(dir, &CheckReport::of(&r, &cal))?;
        if !args.json {
            eprintln!("report: {}", index.display());
        }
    }
    if let Some(error) = refused {
        bail!("drift check: {error}");
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

fn summary(r: &DriftCheck, covariance_known: bool) -> String {
    let width = r.photos.iter().map(|p| name_of(&p.file).len()).max().unwrap_or(4).max(4);
    let mut s = format!("fslcal check: {} photos\n\n", r.photos.len());
    if !covariance_known {
        s += "the calibration's covariance is unknown (an imported calibration records none): the flag threshold counts the dot's localisation only\n\n";
    }
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
    s += match (r.sure_dots, r.drifted) {
        (0, _) => "\nverdict: NOT JUDGED (no photo with a dot the check is sure of; reasons above)\n",
        (_, true) => "\nverdict: DRIFTED\n",
        (_, false) => "\nverdict: no drift seen\n",
    };
    s
}
