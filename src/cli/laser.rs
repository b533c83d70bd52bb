//! `fslcal laser`: the command a diver runs before a dive.

use super::body_check::BodyCheckArgs;
use super::lab_files::{self, LAB_FRAME};
use super::outputs::{self, Input, Output};
use super::parse;
use super::pixels::parse_pixel;
use super::progress;
use super::signing::PriorUnit;
use super::signing::{self, SigningArgs};
use crate::atomic_file::write_atomically;
use crate::documents::laser::{
    DotsFileJson, DotsFrameJson, LabEquivalentJson, LaserColourJson, LaserDocument, LaserLineJson, SkippedTaskJson,
    ToneRetryJson, COVARIANCE_PARAMETERS,
};
use crate::documents::refused::RefusedDocument;
use crate::documents::{self, CameraJson, SCHEMA_VERSION};
use crate::dot::candidates::DotDetectorParams;
use crate::laser::fit::{Gates, Method};
use crate::laser::gates::GateResult;
use crate::laser::lab_equivalent::{lab_equivalent, LabEquivalent};
use crate::laser::pipeline::{
    calibrate, HandDots, LaserCalibration, LaserError, LaserJob, PhotoReport, PhotoStatus, ToneRetry,
};
use crate::laser::target::{Target, TargetArg};
use crate::photo::dot_labels::{self, DotsFile, DotsFormat};
use crate::photo::frame::{Frame, FramePlace, ImageGeometry};
use crate::photo::identity::{photos_exif, ExpectedCamera, PhotosExif};
use crate::photo::thumbnails::Keeping;
use crate::report::{
    self,
    laser::{LaserOutcome, LaserReport},
};
use crate::units::keys;
use crate::utc_time;
use anyhow::{bail, Context};
use fslcal_core::unit_file::{CameraIdentity, FitMethod, FitQuality, Provenance, UnitFile};
use fslcal_core::CameraModel;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

/// Fit the laser line from photos of a checkerboard with the laser dot on it.
///
/// Take 8-20 photos with the dot on the board at distances spread over 0.5-5 m, board tilted
/// a little differently in each. Photos without a board or a dot are skipped with a reason.
#[derive(clap::Args, Debug)]
pub struct LaserArgs {
    /// Camera intrinsics: OpenCV FileStorage YAML, as OpenCV's calibration sample or
    /// `fslcal camera --out` writes it, a previous .fslcal of the same unit, or the lab's
    /// lens calibration (a `.pkg`, or its API's `CameraIntrinsics` JSON) made in
    /// --camera-frame.
    #[arg(long, value_name = "CAMERA")]
    camera: PathBuf,

    /// The frame a lab lens given as --camera was made in, pixels: the lab's are made on the
    /// TG-6's whole sensor readout, 4040x3016; it is moved into the 4000x3000 picture fslcal
    /// develops (docs/conventions.md).
    #[arg(long, value_name = "WxH", default_value = LAB_FRAME, value_parser = lab_files::parse_frame)]
    camera_frame: Frame,

    /// The target in the photos: `checkerboard:COLSxROWS@SQUAREmm` with inner corners, e.g.
    /// `checkerboard:14x10@42.17mm`, or `slate:PATH.toml`, a taped dive slate defined by its
    /// scan (docs/slate.md). Measure the square with calipers over many squares: the
    /// FishSense board's nominal 41.3 mm is really 42.17 mm, a silent 2% scale error.
    #[arg(long, value_name = "TARGET")]
    target: TargetArg,

    /// Fitting method. `reprojection` weighs each dot by what its pixel tells and drops
    /// outlier photos; the thesis's `gauss-newton` and `average` use every dot as given.
    #[arg(long, value_enum, default_value_t = Method::Reprojection)]
    method: Method,

    /// A dot given by hand for one photo, overriding detection (repeatable).
    #[arg(long = "dot", value_name = "PHOTO=X,Y")]
    dot: Vec<String>,

    /// Hand-labelled dots: a CSV with `file,x,y` rows (a header row is allowed; `file` a
    /// path or a file name), or the lab's Label Studio JSON export (keypoints in percent of
    /// the image they were clicked on; each task's photo matched by file stem, so
    /// `P2100001.JPG` labels `P2100001.ORF`; the newest annotation of a photo counts). Told
    /// apart by content; labelled photos skip detection.
    #[arg(long = "dots", value_name = "FILE")]
    dots: Option<PathBuf>,

    /// The Label Studio keypoint label of the laser dot in --dots.
    #[arg(long, value_name = "LABEL", default_value = "Green Laser")]
    dot_label: String,

    /// The frame a --dots CSV's pixels were measured in, pixels (default: the camera's).
    /// A Label Studio export says its own (`original_width` x `original_height`).
    #[arg(long, value_name = "WxH", value_parser = lab_files::parse_frame, requires = "dots")]
    dots_frame: Option<Frame>,

    /// What the --dots images showed: `as-shot` photos, or photos `undistorted` with the
    /// camera's lens (the lab's `fsl preprocess --lens-calibration` JPGs), whose dots are
    /// distorted back. Default: `undistorted` for a Label Studio export made on the lab's
    /// 4040x3016 JPGs, `as-shot` otherwise.
    #[arg(long, value_enum, value_name = "IMAGE", requires = "dots")]
    dots_image: Option<ImageGeometry>,

    /// Plausible camera-to-laser baseline for the rig, millimetres.
    #[arg(long, value_name = "MIN,MAX", default_value = "78,145", value_parser = parse::range_mm)]
    baseline_range_mm: (f64, f64),

    /// A used dot must lie within this many pixels of the fitted line's image. The gate the
    /// fit applies is eight times the used dots' median distance from it, at least 2 px (in a
    /// 4000 px wide photo), and at most this.
    #[arg(long, value_name = "PX", default_value = "4", value_parser = parse::positive_px, allow_negative_numbers = true)]
    max_dot_offset_px: f64,

    #[command(flatten)]
    body: BodyCheckArgs,

    /// Print one JSON object instead of the summary.
    #[arg(long)]
    json: bool,

    /// Write the result here, only when every gate passes: a signed unit file when the name
    /// ends in `.fslcal` (needs --unit and --key), JSON otherwise.
    #[arg(long, value_name = "FILE")]
    out: Option<PathBuf>,

    /// Write an HTML report into this folder (created if missing): `index.html` with the
    /// plots and a thumbnail of every photo, opened offline in any browser. Written also
    /// when a gate fails or the fit is refused, since that is when it is needed.
    #[arg(long, value_name = "DIR")]
    report: Option<PathBuf>,

    #[command(flatten)]
    signing: SigningArgs,

    /// Calibration photos (JPEG, PNG or Olympus ORF raw).
    #[arg(required = true, value_name = "PHOTOS")]
    photos: Vec<PathBuf>,
}

/// The camera as given, in the frame fslcal develops the photos in.
struct CameraInput {
    camera: CameraModel,
    prior: Option<PriorUnit>,
    expected: ExpectedCamera,
    /// A lab lens: where it came from and how it was moved, for the summary.
    lab_note: Option<String>,
}

/// Reads `--camera`: the lab's lens (moved from --camera-frame into the developed picture)
/// or what `signing::read_camera` reads.
fn read_camera(args: &LaserArgs) -> anyhow::Result<CameraInput> {
    // Enough to tell a lab lens (a gzip magic, or a small JSON body) from the others, which
    // `signing::read_camera` reads itself.
    let mut bytes = Vec::new();
    std::fs::File::open(&args.camera)
        .and_then(|f| std::io::Read::read_to_end(&mut std::io::Read::take(f, 1 << 20), &mut bytes))
        .with_context(|| format!("{}: cannot read the camera file", args.camera.display()))?;
    if !lab_files::is_lab_lens(&bytes) {
        let (camera, prior, expected) = signing::read_camera(&args.camera, &args.signing)?;
        return Ok(CameraInput { camera, prior, expected, lab_note: None });
    }
    // The lens's date does not enter a fit: a date without a zone is no reason to refuse.
    let lens = lab_files::read_lens(&args.camera, args.camera_frame, Some(&jiff::tz::TimeZone::UTC))?;
    let from = args.camera_frame;
    let map = from.map_to(&from.developed()).with_context(|| args.camera.display().to_string())?;
    let lab_note = format!(
        "{} from {}, made in {}: principal point {} into {}",
        args.camera.display(),
        lens.format.describe(),
        from.describe(),
        map.describe(),
        map.to.describe()
    );
    Ok(CameraInput {
        camera: map.camera(&lens.camera),
        prior: None,
        expected: ExpectedCamera::default(),
        lab_note: Some(lab_note),
    })
}

/// The hand-given dots by photo, each in the camera's pixels, and what the --dots file gave.
fn hand_dots(args: &LaserArgs, camera: &CameraModel) -> anyhow::Result<(HandDots, Option<DotsFileJson>)> {
    let mut dots = HandDots::default();
    let report = match &args.dots {
        Some(path) => Some(file_dots(args, path, camera, &mut dots)?),
        None => None,
    };
    let mut given = std::collections::HashSet::new();
    for d in &args.dot {
        let (photo, xy) = d.split_once('=').unwrap_or((d, ""));
        let px = parse_pixel(xy).with_context(|| format!("--dot {d}: expected PHOTO=X,Y with X and Y in pixels"))?;
        check_dot_photo(d, Path::new(photo), &args.photos)?;
        if !given.insert(photo) {
            bail!("--dot {d}: a second --dot for {photo}; give each photo's dot once");
        }
        dots.insert(Path::new(photo), px);
    }
    Ok((dots, report))
}

/// What the lab's Label Studio export of its `fsl preprocess` JPGs is: clicked on the whole
/// readout, undistorted.
fn default_image(file: &DotsFile) -> ImageGeometry {
    let on_lab_jpgs = file.format == DotsFormat::LabelStudio
        && file.dots.iter().all(|d| d.frame.is_some_and(|f| matches!(f.place, FramePlace::Readout(_))));
    if on_lab_jpgs {
        ImageGeometry::Undistorted
    } else {
        ImageGeometry::AsShot
    }
}

/// Reads the --dots file, matches its dots to the photos and puts each in the camera's
/// pixels: moved from the frame it was clicked in, distorted back when clicked on an
/// undistorted image.
fn file_dots(args: &LaserArgs, path: &Path, camera: &CameraModel, out: &mut HandDots) -> anyhow::Result<DotsFileJson> {
    let file = dot_labels::read(path, &args.dot_label)?;
    let (matched, unmatched) =
        dot_labels::match_photos(&file, &args.photos).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    let to = Frame::of_camera(camera);
    let image = args.dots_image.unwrap_or_else(|| default_image(&file));
    let mut frames: BTreeMap<String, DotsFrameJson> = BTreeMap::new();
    for (photo, dot) in &matched {
        let from = dot.frame.or(args.dots_frame).unwrap_or(to);
        let map = from.map_to(&to).with_context(|| format!("{}: the dot for {}", path.display(), dot.photo))?;
        let px = image.as_shot(camera, map.pixel(dot.pixel)).with_context(|| {
            format!("{}: the dot for {} lies where the lens model cannot distort it back", path.display(), dot.photo)
        })?;
        out.insert(photo, px);
        let f = frames.entry(from.to_string()).or_insert(DotsFrameJson {
            size: from.to_string(),
            dots: 0,
            shift_px: [map.shift_px.x, map.shift_px.y],
        });
        f.dots += 1;
    }
    Ok(DotsFileJson {
        file: path.display().to_string(),
        format: file.format.name().into(),
        entries: file.entries,
        dots: file.dots.len(),
        matched: matched.len(),
        unmatched: unmatched.iter().map(|s| s.to_string()).collect(),
        label: (file.format == DotsFormat::LabelStudio).then(|| args.dot_label.clone()),
        frames: frames.into_values().collect(),
        image: image.name().into(),
        newest_of_several: file.newest_of_several.clone(),
        skipped: file
            .skipped
            .iter()
            .map(|(task, why)| SkippedTaskJson { task: task.clone(), why: why.to_string() })
            .collect(),
    })
}

/// Refuses, before any work, an output that is one of the run's inputs or another output.
fn check_outputs(args: &LaserArgs) -> anyhow::Result<()> {
    let mut inputs = vec![Input::new("--camera", &args.camera)];
    inputs.extend(args.dots.as_deref().map(|p| Input::new("--dots", p)));
    inputs.extend(args.signing.key.as_deref().map(|p| Input::new("--key", p)));
    if let TargetArg::Slate(p) = &args.target {
        inputs.push(Input::new("--target", p));
    }
    inputs.extend(args.photos.iter().map(|p| Input::new("photo", p)));
    let mut outs = Vec::new();
    outs.extend(args.out.as_deref().map(|p| Output::result("--out", p)));
    outs.extend(args.report.as_deref().map(|p| Output::report("--report", p)));
    Ok(outputs::check(&inputs, &outs, args.signing.force)?)
}

/// Refuses a `--dot` for a photo that is not in the run (as given, or by file name, the
/// way the dot is looked up): a typo must not leave the photo to detection silently.
fn check_dot_photo(option: &str, photo: &Path, photos: &[PathBuf]) -> anyhow::Result<()> {
    let name = photo.file_name();
    if photos.iter().any(|p| p == photo || (name.is_some() && p.file_name() == name)) {
        return Ok(());
    }
    bail!("--dot {option}: {} is not one of this run's photos; name it as given on the command line", photo.display())
}

pub fn run(args: LaserArgs) -> anyhow::Result<ExitCode> {
    check_outputs(&args)?;
    let args = LaserArgs { photos: super::photos::prepare(&args.photos)?, ..args };
    let CameraInput { camera, prior, expected, lab_note } = read_camera(&args)?;
    let signed_out = args.out.as_deref().filter(|o| signing::is_unit_file_path(o));
    if let Some(out) = signed_out {
        // Refuse before the long fit, not after it.
        let mut check = args.signing.clone();
        check.unit = check.unit.or_else(|| prior.as_ref().map(|p| p.unit.clone()));
        check.unit_and_key(out)?;
        keys::read_secret(check.key.as_deref().unwrap_or(out))?;
    }
    let (hand_dots, dots_file) = hand_dots(&args, &camera)?;
    let job = job(&args, camera, &expected, hand_dots)?;
    // The report's thumbnails come from each photo's one decode, kept while the run lasts.
    let _thumbnails = args.report.is_some().then(|| Keeping::start(report::THUMBNAIL_WIDTH_PX));
    let cal = fit(&args, &job)?;
    // Read once: the JSON reports it and a signed file records the body and depth from it.
    let identity = photos_exif(&args.photos);
    let lab = lab_equivalent(&job.camera, &cal.fit);
    let mut document = document(&args, &job, &cal, &identity);
    document.lab_equivalent = lab.as_ref().map(lab_equivalent_json);
    document.dots_file = dots_file;
    if args.json {
        println!("{}", documents::to_text(&document)?);
    } else {
        print!("{}", summary(&args, &job, &cal));
        print!("{}", lab_inputs_summary(lab_note.as_deref(), document.dots_file.as_ref()));
        if let Some(l) = &lab {
            print!("{}", lab_equivalent_summary(l));
        }
    }
    write_report(&args, &job, LaserOutcome::Fitted(&cal))?;
    if !cal.accepted() {
        let failed: Vec<String> = cal.gates.iter().filter(|g| !g.pass).map(GateResult::failure_text).collect();
        let note = if args.out.is_some() { "; nothing written" } else { "" };
        bail!("laser calibration rejected: {}{note}", failed.join(", "));
    }
    match (signed_out, &args.out) {
        (Some(out), _) => write_signed(&args, out, &job, &cal, prior.as_ref(), &identity)?,
        (None, Some(out)) => {
            let mut text = documents::to_text(&document)?;
            text.push('\n');
            outputs::say_if_replacing(out);
            write_atomically(out, text.as_bytes())
                .with_context(|| format!("{}: cannot write the result", out.display()))?;
            if !args.json {
                println!("wrote {}", out.display());
            }
        }
        (None, None) => {}
    }
    Ok(ExitCode::SUCCESS)
}

/// The run's settings from the options, once the photos are there and from the right body.
fn job(
    args: &LaserArgs,
    camera: CameraModel,
    expected: &ExpectedCamera,
    hand_dots: HandDots,
) -> anyhow::Result<LaserJob> {
    args.body.check(expected, &args.photos)?;
    Ok(LaserJob {
        camera,
        target: args.target.load()?,
        method: args.method,
        gates: Gates {
            baseline_range_m: args.baseline_range_mm,
            max_dot_offset_px: args.max_dot_offset_px,
            ..Gates::default()
        },
        detector: DotDetectorParams::default(),
        hand_dots,
    })
}

/// Runs the chain with a progress bar; a refused fit still gets its photo table and report.
fn fit(args: &LaserArgs, job: &LaserJob) -> anyhow::Result<LaserCalibration> {
    let bar = progress::bar(args.photos.len(), "photos", args.json);
    let result = calibrate(job, &args.photos, &|| bar.inc(1));
    bar.finish_and_clear();
    match result {
        Ok(c) => Ok(c),
        Err(LaserError::Fit { source, photos }) => {
            if args.json {
                let error = format!("cannot fit the laser: {source}");
                println!("{}", documents::to_text(&RefusedDocument::new(error, photos.clone()))?);
            } else {
                eprint!("{}", photo_table(&photos));
            }
            write_report(args, job, LaserOutcome::Refused { reason: &source, photos: &photos })?;
            bail!("cannot fit the laser: {source}");
        }
        Err(e) => Err(e.into()),
    }
}

/// Signs the accepted calibration into `out`, with the camera body and the water depth the
/// photos say when the options do not.
fn write_signed(
    args: &LaserArgs,
    out: &Path,
    job: &LaserJob,
    cal: &LaserCalibration,
    prior: Option<&PriorUnit>,
    (exif, serial, _): &PhotosExif,
) -> anyhow::Result<()> {
    let mut signing_args = args.signing.clone();
    // The body the photos agree on is the body calibrated: record it so photos from
    // another body are refused later.
    signing_args.camera_serial = signing_args.camera_serial.or_else(|| serial.clone());
    // Where the calibration was made, from the TG-6's depth gauge when the options do
    // not say: the median photo's, as divers drift a metre or two while shooting.
    if signing_args.water_depth_m.is_none() {
        let mut depths: Vec<f64> = exif.iter().flatten().filter_map(|e| e.water_depth_m).collect();
        depths.sort_by(f64::total_cmp);
        signing_args.water_depth_m = depths.get(depths.len() / 2).map(|&d| d as f32);
    }
    let target = target_label(&job.target);
    outputs::say_if_replacing(out);
    let size = signing::sign_unit_file(out, &signing_args, prior, unit_contents(&target, &job.camera, cal))?;
    if !args.json {
        println!("wrote {} (signed, {size} bytes)", out.display());
    }
    Ok(())
}

fn write_report(args: &LaserArgs, job: &LaserJob, outcome: LaserOutcome) -> anyhow::Result<()> {
    let Some(dir) = &args.report else { return Ok(()) };
    let report = LaserReport { job, camera_file: &args.camera, outcome };
    outputs::say_if_replacing(dir);
    let index = report::laser::write(dir, &report)?;
    if !args.json {
        // On stderr: a refused fit's summary went there too, and stdout may be piped.
        eprintln!("report: {}", index.display());
    }
    Ok(())
}

/// The laser result document (`--json`, `--out FILE.json`).
fn document(args: &LaserArgs, job: &LaserJob, cal: &LaserCalibration, identity: &PhotosExif) -> LaserDocument {
    let f = &cal.fit;
    let (exif, serial, focal) = identity;
    LaserDocument {
        schema_version: SCHEMA_VERSION,
        camera_file: Some(args.camera.display().to_string()),
        camera: CameraJson::from(&job.camera),
        target: Some(job.target.to_string()),
        method: Some(f.method),
        laser: LaserLineJson {
            origin_m: f.laser.origin_m,
            direction: f.laser.direction,
            baseline_m: Some(f.laser.baseline_m()),
            angle_to_optical_axis_deg: Some(f.laser.angle_to_optical_axis().to_degrees()),
            covariance: f.covariance,
            covariance_parameters: COVARIANCE_PARAMETERS.map(String::from).to_vec(),
        },
        residual_rms_px: Some(f.residual_rms_px),
        residual_worst_px: Some(f.residual_worst_px),
        residual_rms_mm: Some(f.residual_rms_mm),
        residual_worst_mm: Some(f.residual_worst_mm),
        span_m: Some(f.span_m),
        depth_range_m: Some(f.depth_range_m),
        predicted_distance_sigma_m: f.distance_sigma_m.iter().map(|(z, s)| (format!("{z}"), *s)).collect(),
        outliers: Some(cal.outliers.into()),
        gates: cal.gates.clone(),
        accepted: Some(cal.accepted()),
        photos: cal.photos.clone(),
        camera_serial: serial.clone(),
        focal_length_mm: *focal,
        photo_exif: exif.clone(),
        laser_colour: cal.laser_colour.map(|c| LaserColourJson {
            rgb: c.rgb,
            spread_rad: c.spread_rad,
            dots: c.to_unit().dots,
            tone_gamma: c.tone.gamma(),
            tone_retry: cal.tone_retry.map(|r| match r {
                ToneRetry::LinearRefused => ToneRetryJson::LinearRefused,
                ToneRetry::LinearScattered { spread_rad } => ToneRetryJson::LinearScattered { spread_rad },
            }),
        }),
        unit: None,
        dots_file: None,
        lab_equivalent: None,
    }
}

fn lab_equivalent_json(l: &LabEquivalent) -> LabEquivalentJson {
    LabEquivalentJson {
        method: "average".into(),
        dots: l.dots,
        left_out_by_fslcal: l.left_out_by_fslcal,
        origin_m: l.laser.origin_m,
        direction: l.laser.direction,
        baseline_m: l.laser.baseline_m(),
        angle_deg: l.angle_deg,
        origin_difference_mm: l.origin_difference_mm,
        distance_difference_m: l.distance_difference_m.iter().map(|(z, d)| (format!("{z}"), *d)).collect(),
    }
}

/// Where a lab lens and a --dots file's dots came from and how they were placed.
fn lab_inputs_summary(camera: Option<&str>, dots: Option<&DotsFileJson>) -> String {
    let mut s = String::new();
    if let Some(c) = camera {
        s += &format!("\ncamera: {c}\n");
    }
    let Some(d) = dots else { return s };
    let what = match &d.label {
        Some(label) => format!("a Label Studio export: {} tasks, {} dots labelled \"{label}\"", d.entries, d.dots),
        None => format!("a CSV of {} dots", d.dots),
    };
    s += &format!("\ndots: {}, {what}; {} used for photos given", d.file, d.matched);
    if !d.unmatched.is_empty() {
        s += &format!(", {} name no photo given", d.unmatched.len());
    }
    s += "\n";
    for f in &d.frames {
        let shift = if f.shift_px == [0.0, 0.0] {
            "in the camera's pixels".to_string()
        } else {
            format!("moved by ({:+}, {:+}) px into the camera's pixels", f.shift_px[0], f.shift_px[1])
        };
        s += &format!("  {} dots clicked on {} images ({}), {shift}\n", f.dots, f.size, d.image);
    }
    if d.image == ImageGeometry::Undistorted.name() {
        s += "  clicked on undistorted images: distorted back with the camera's lens\n";
    }
    if !d.newest_of_several.is_empty() {
        s += &format!("  several annotations of {}: the newest used\n", d.newest_of_several.join(", "));
    }
    for t in &d.skipped {
        s += &format!("  skipped {}: {}\n", t.task, t.why);
    }
    s
}

/// The lab's `fsl calibrate-laser` result on the same dots, beside fslcal's.
fn lab_equivalent_summary(l: &LabEquivalent) -> String {
    let o = l.laser.origin_m;
    let d = l.laser.direction;
    let mut s = format!(
        "\nthe lab's fsl calibrate-laser on these dots (averaging fit on all {} dots{}):\n",
        l.dots,
        match l.left_out_by_fslcal {
            0 => String::new(),
            n => format!(", {n} of which fslcal left out"),
        }
    );
    s += &format!(
        "  laser origin ({:.2}, {:.2}, 0) mm, baseline {:.1} mm; direction ({:.5}, {:.5}, {:.5})\n",
        o[0] * 1e3,
        o[1] * 1e3,
        l.laser.baseline_m() * 1e3,
        d[0],
        d[1],
        d[2]
    );
    s += &format!(
        "  from fslcal's: {:.3} deg apart, origins {:.2} mm apart; a dot fslcal puts at",
        l.angle_deg, l.origin_difference_mm
    );
    let diffs: Vec<String> = l
        .distance_difference_m
        .iter()
        .map(|(z, d)| match d {
            Some(d) => format!(" {z:.0} m it puts {:+.1} mm ({:+.2}%)", d * 1e3, 100.0 * d / z),
            None => format!(" {z:.0} m it cannot place"),
        })
        .collect();
    s += &diffs.join(",");
    s += "\n";
    s
}

/// What the signed unit file records of this fit; the unit and camera identity are filled
/// in by `signing::sign_unit_file`.
/// The target as the unit file records it: a slate by its definition's file name only, since
/// a full path says nothing on another machine and would eat the file's 512 bytes.
fn target_label(target: &Target) -> String {
    match target {
        Target::Slate(m) => format!(
            "slate:{}",
            m.slate
                .definition
                .file_name()
                .map_or_else(|| m.slate.definition.display().to_string(), |n| n.to_string_lossy().into_owned())
        ),
        other => other.to_string(),
    }
}

fn unit_contents<'a>(target: &'a str, camera: &CameraModel, cal: &LaserCalibration) -> UnitFile<'a> {
    let f = &cal.fit;
    let narrow = |n: usize| u16::try_from(n).unwrap_or(u16::MAX);
    UnitFile {
        unit: "",
        camera_identity: CameraIdentity { make: "", model: "", serial: None },
        camera: *camera,
        laser: f.laser,
        // The file keeps the upper triangle; average away the fit's rounding asymmetry.
        laser_covariance: std::array::from_fn(|r| {
            std::array::from_fn(|c| 0.5 * (f.covariance[r][c] + f.covariance[c][r]))
        }),
        made_utc_s: utc_time::now_s(),
        water_depth_m: None,
        depth_range_m: Some([f.depth_range_m.0 as f32, f.depth_range_m.1 as f32]),
        fit: Some(FitQuality {
            photos_used: narrow(f.used),
            photos_total: narrow(cal.photos.len()),
            outliers: narrow(cal.outliers.0),
            residual_rms_px: f.residual_rms_px as f32,
            residual_worst_px: f.residual_worst_px as f32,
            residual_rms_mm: f.residual_rms_mm as f32,
            residual_worst_mm: f.residual_worst_mm as f32,
            span_m: f.span_m as f32,
        }),
        method: match f.method {
            Method::Reprojection => FitMethod::Reprojection,
            Method::GaussNewton => FitMethod::GaussNewton,
            Method::Average => FitMethod::Average,
        },
        target: Some(target),
        provenance: Provenance::Fitted,
        laser_colour: cal.laser_colour.map(|c| c.to_unit()),
    }
}

fn name_of(file: &str) -> String {
    Path::new(file).file_name().map_or_else(|| file.to_string(), |n| n.to_string_lossy().into_owned())
}

fn photo_table(photos: &[PhotoReport]) -> String {
    let mut s = String::new();
    let width = photos.iter().map(|p| name_of(&p.file).len()).max().unwrap_or(4).max(4);
    s += &format!("  {:width$}  {:>7}  {:>19}  {:>8}  {}\n", "file", "dist m", "dot px", "resid px", "status");
    for p in photos {
        let dist = p.distance_m.map_or("-".into(), |d| format!("{d:.3}"));
        let dot = p.dot_px.map_or("-".into(), |d| format!("({:.1}, {:.1})", d[0], d[1]));
        let resid = p.residual_px.map_or("-".into(), |r| format!("{r:.2}"));
        s += &format!("  {:width$}  {dist:>7}  {dot:>19}  {resid:>8}  {}\n", name_of(&p.file), p.status_text());
    }
    s
}

/// For each photo whose dot was not used or that had rivals: its candidates and what the
/// consensus over photos made of them.
fn candidate_lines(photos: &[PhotoReport]) -> String {
    let mut s = String::new();
    for p in photos.iter().filter(|p| p.status != PhotoStatus::Used || p.candidates.len() > 1) {
        if p.candidates.is_empty() {
            continue;
        }
        s += &format!("  {} candidates:", name_of(&p.file));
        for c in &p.candidates {
            let off = c.line_offset_px.map_or("-".into(), |o| format!("{o:.1}"));
            s += &format!(
                " ({:.1}, {:.1}) colour {:.0} sigma, {:.0} deg, r {:.1} px, {off} px off the line: {:?};",
                c.px[0], c.px[1], c.colour_score, c.colour_angle_deg, c.radius_px, c.role
            );
        }
        s += "\n";
    }
    s
}

fn summary(args: &LaserArgs, job: &LaserJob, cal: &LaserCalibration) -> String {
    let f = &cal.fit;
    let l = &f.laser;
    let used = cal.photos.iter().filter(|p| p.status == PhotoStatus::Used).count();
    let mut s = format!(
        "fslcal laser: {} photos, target {}, camera {}, method {}\n\n",
        cal.photos.len(),
        job.target,
        args.camera.display(),
        clap::ValueEnum::to_possible_value(&f.method).map_or_else(String::new, |v| v.get_name().to_string()),
    );
    s += &format!("photos: {used} used, {} skipped\n", cal.photos.len() - used);
    s += &photo_table(&cal.photos);
    s += &candidate_lines(&cal.photos);
    if let Some(c) = &cal.laser_colour {
        s += &format!(
            "laser colour: RGB ({:.3}, {:.3}, {:.3}), spread {:.1} deg, from {} dots{}\n",
            c.rgb[0],
            c.rgb[1],
            c.rgb[2],
            c.spread_rad.to_degrees(),
            c.to_unit().dots,
            match (c.tone.table(), cal.tone_retry) {
                (None, _) => String::new(),
                (Some(_), retry) => format!(
                    "; photos read through a camera tone curve of gamma {:.1}{}",
                    c.tone.gamma(),
                    match retry {
                        Some(ToneRetry::LinearRefused) => " (read as linear, the fit was refused)".to_string(),
                        Some(ToneRetry::LinearScattered { spread_rad }) =>
                            format!(" (read as linear, the dots' colours spread {:.1} deg)", spread_rad.to_degrees()),
                        None => " (the curve the run was given)".to_string(),
                    }
                ),
            }
        );
    }
    let worst = f
        .photos
        .iter()
        .zip(&cal.photos)
        .filter_map(|(p, r)| p.as_ref().filter(|p| p.outlier.is_none()).map(|p| (p.residual_px, name_of(&r.file))))
        .max_by(|a, b| a.0.total_cmp(&b.0));
    s += &format!(
        "\nresiduals: RMS {:.2} px ({:.2} mm on the board), worst {:.2} px ({:.2} mm){}; outliers {} of {}\n",
        f.residual_rms_px,
        f.residual_rms_mm,
        f.residual_worst_px,
        f.residual_worst_mm,
        worst.map_or(String::new(), |(_, n)| format!(" in {n}")),
        cal.outliers.0,
        cal.outliers.1,
    );
    s += &format!(
        "dots: {:.2}-{:.2} m deep, spanning {:.2} m along the laser\n",
        f.depth_range_m.0, f.depth_range_m.1, f.span_m
    );
    s += &format!("laser origin    {}; baseline {:.1} mm\n", f.origin_text(), l.baseline_m() * 1e3);
    s += &format!("laser direction {}\n", f.direction_text());
    s += "predicted 1-sigma distance error from this calibration:";
    for (z, sig) in &f.distance_sigma_m {
        s += &format!("  at {z:.0} m: {:.1} mm ({:.2}%)", sig * 1e3, 100.0 * sig / z);
    }
    s += "\n\ngates:\n";
    for g in &cal.gates {
        s += &format!(
            "  {}  {:28} {:>12}   limit {}\n",
            if g.pass { "pass" } else { "FAIL" },
            g.name,
            g.figure,
            g.limit
        );
    }
    s += if cal.accepted() { "\nverdict: ACCEPTED\n" } else { "\nverdict: REJECTED\n" };
    s
}
