//! `fslcal validate`: the slate-length check of a calibration.

use super::body_check::BodyCheckArgs;
use super::outputs::{self, Input, Output};
use super::progress;
use crate::calibration;
use crate::calibration::validate::{
    validate, LengthRule, Validation, ValidationError, ValidationJob, ValidationOutcome,
};
use crate::documents::refused::RefusedDocument;
use crate::documents::validation::{CalibrationUsed, ValidationDocument};
use crate::documents::{self};
use crate::laser::target::TargetArg;
use crate::photo::identity::ExpectedCamera;
use crate::photo::thumbnails::Keeping;
use crate::report::{self, validate::ValidationReport};
use crate::units::registry::sha256_hex;
use crate::utc_time;
use anyhow::bail;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

/// Check a calibration by measuring a known length on a target the way a fish is measured.
///
/// The scale comes from the laser dot and the calibration only; the target gives the two
/// end points (and, by default, the plane's orientation). With photos at several distances
/// a trend of the error with distance fails the check: that is a wrong laser direction.
#[derive(clap::Args, Debug)]
pub struct ValidateArgs {
    /// The calibration: the JSON `fslcal laser --out` writes, or a signed .fslcal.
    #[arg(long, value_name = "CAL")]
    cal: PathBuf,

    /// The target: `slate:PATH.toml` (docs/slate.md) or `checkerboard:COLSxROWS@SQUAREmm`
    /// (whose known length is the first row's outermost inner corners).
    #[arg(long, value_name = "TARGET")]
    target: TargetArg,

    /// The slate's known length to measure, by name (default: its first).
    #[arg(long, value_name = "NAME")]
    length: Option<String>,

    /// Pass when every photo's length error is within this many percent.
    #[arg(long, value_name = "PCT", default_value = "3", value_parser = super::parse::percentage, allow_negative_numbers = true)]
    tolerance: f64,

    /// Where the end points lie: on the plane through the dot with the target's detected
    /// orientation (default), or both at the dot's depth as for a fish (the thesis's rule).
    #[arg(long, value_enum, default_value_t = LengthRule::TiltedPlane)]
    rule: LengthRule,

    #[command(flatten)]
    body: BodyCheckArgs,

    /// Print one JSON object instead of the summary.
    #[arg(long)]
    json: bool,

    /// Write an HTML report into this folder (created if missing): each photo's length
    /// error against distance with the tolerance band, and a thumbnail of every photo.
    /// Written also when the check fails.
    #[arg(long, value_name = "DIR")]
    report: Option<PathBuf>,

    /// Photos of the target with the laser dot on it, ideally at several distances.
    #[arg(required = true, value_name = "PHOTOS")]
    photos: Vec<PathBuf>,
}

pub fn run(args: ValidateArgs) -> anyhow::Result<ExitCode> {
    let mut inputs = vec![Input::new("--cal", &args.cal)];
    if let TargetArg::Slate(p) = &args.target {
        inputs.push(Input::new("--target", p));
    }
    inputs.extend(args.photos.iter().map(|p| Input::new("photo", p)));
    let outs: Vec<Output> = args.report.as_deref().map(|p| Output::report("--report", p)).into_iter().collect();
    outputs::check(&inputs, &outs, false)?;
    let bytes = std::fs::read(&args.cal)
        .map_err(|cause| calibration::CalibrationError::Io { path: args.cal.display().to_string(), cause })?;
    let cal = calibration::from_bytes(&bytes, &args.cal)?;
    let validated_utc_s = utc_time::now_s();
    let args = ValidateArgs { photos: super::photos::prepare(&args.photos)?, ..args };
    args.body.check(&ExpectedCamera::from(&cal), &args.photos)?;
    let target = args.target.load()?;
    let job =
        ValidationJob { cal, target, length_name: args.length.clone(), rule: args.rule, tolerance_pct: args.tolerance };
    // The report's thumbnails come from each photo's one decode, kept while the run lasts.
    let _thumbnails = args.report.is_some().then(|| Keeping::start(report::THUMBNAIL_WIDTH_PX));
    let bar = progress::bar(args.photos.len(), "photos", args.json);
    let result = validate(&job, &args.photos, &|| bar.inc(1));
    bar.finish_and_clear();
    // Nothing measured is still a run that read photos: each says why, then the error.
    let (v, refused) = match result {
        Ok(v) => (v, None),
        Err(ValidationError::NothingMeasured(v)) => {
            let message = ValidationError::NothingMeasured(v.clone()).to_string();
            (*v, Some(message))
        }
        Err(e) => return Err(anyhow::Error::new(e).context("validation")),
    };
    if let (Some(error), true) = (&refused, args.json) {
        println!("{}", documents::to_text(&RefusedDocument::new(error, v.photos.clone()))?);
    } else if args.json {
        let used = CalibrationUsed {
            unit: job.cal.unit.clone(),
            file: args.cal.display().to_string(),
            sha256: sha256_hex(&bytes),
            validated_utc_s,
        };
        println!("{}", documents::to_text(&ValidationDocument::new(&v, used))?);
    } else {
        print!("{}", summary(&v));
    }
    if let Some(dir) = &args.report {
        let page = ValidationReport::of(&v, &args.cal, job.target.to_string());
        outputs::say_if_replacing(dir);
        let index = report::validate::write(dir, &page)?;
        if !args.json {
            eprintln!("report: {}", index.display());
        }
    }
    if let Some(error) = refused {
        bail!("validation: {error}");
    }
    if !v.pass {
        bail!("calibration failed validation: {}", failure(&v));
    }
    Ok(ExitCode::SUCCESS)
}

fn failure(v: &Validation) -> String {
    let failed = v.photos.iter().filter(|p| p.pass == Some(false)).count();
    let measured = v.photos.iter().filter(|p| p.pass.is_some()).count();
    let mut why = Vec::new();
    if failed > 0 {
        why.push(format!("{failed} of {measured} photos outside ±{}%", v.tolerance_pct));
    }
    if v.trend_fails {
        if let Some((b, s)) = v.slope_pct_per_m {
            why.push(format!("the error changes with distance by {b:+.2} ±{s:.2} %/m (a wrong laser direction): recalibrate the laser"));
        }
    }
    why.join("; ")
}

fn name_of(file: &str) -> String {
    Path::new(file).file_name().map_or_else(|| file.to_string(), |n| n.to_string_lossy().into_owned())
}

fn summary(v: &Validation) -> String {
    let rule = v.rule.as_str();
    let mut s = format!(
        "fslcal validate: length `{}` ({:.1} mm), rule {rule}, tolerance ±{}%\n\n",
        v.length_name, v.true_mm, v.tolerance_pct
    );
    let width = v.photos.iter().map(|p| name_of(&p.file).len()).max().unwrap_or(4).max(4);
    s += &format!(
        "  {:width$}  {:>7}  {:>11}  {:>8}  {:>8}  {}\n",
        "file", "dist m", "measured mm", "error %", "inliers", "status"
    );
    for p in &v.photos {
        let f = |x: Option<f64>, d: usize| x.map_or("-".to_string(), |x| format!("{x:.d$}"));
        let status = match p.outcome() {
            ValidationOutcome::Pass => "pass".to_string(),
            ValidationOutcome::Fail => "FAIL".to_string(),
            ValidationOutcome::Skipped(why) => format!("skipped: {why}"),
            ValidationOutcome::Unknown => "skipped".to_string(),
        };
        let inl = p.target_inliers.map_or("-".to_string(), |n| n.to_string());
        s += &format!(
            "  {:width$}  {:>7}  {:>11}  {:>8}  {inl:>8}  {status}\n",
            name_of(&p.file),
            f(p.distance_m, 3),
            f(p.measured_mm, 1),
            f(p.error_pct, 2)
        );
    }
    let errs: Vec<f64> = v.photos.iter().filter_map(|p| p.error_pct).collect();
    if !errs.is_empty() {
        let rms = (errs.iter().map(|e| e * e).sum::<f64>() / errs.len() as f64).sqrt();
        let worst = errs.iter().fold(0.0f64, |a, e| a.max(e.abs()));
        let outside = errs.iter().filter(|e| e.abs() > v.tolerance_pct).count();
        s += &format!(
            "\nlength error: RMS {rms:.2}%, worst {worst:.2}%; outside tolerance {outside} of {}\n",
            errs.len()
        );
    }
    match v.slope_pct_per_m {
        Some((b, sd)) => {
            s += &format!(
                "error against distance: {b:+.2} ±{sd:.2} %/m{}\n",
                if v.trend_fails { "  TREND: the laser's direction is wrong" } else { "" }
            )
        }
        None => s += "error against distance: not judged (needs 3 photos spread over 0.5 m or more)\n",
    }
    s += match (errs.len(), v.pass) {
        (0, _) => "\nverdict: NOT JUDGED (no photo could be measured; reasons above)\n",
        (_, true) => "\nverdict: PASS\n",
        (_, false) => "\nverdict: FAIL\n",
    };
    s
}
