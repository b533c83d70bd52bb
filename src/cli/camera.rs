//! `fslcal camera`: the intrinsics a diver calibrates once per unit, under water.

use super::outputs::{self, Input, Output};
use super::progress;
use crate::atomic_file::write_atomically;
use crate::camera::calibrate::{calibrate, CameraCalibration, CameraJob, CameraPhotoStatus};
use crate::camera::opencv_yaml::{self, CameraFileExtras};
use crate::camera::residuals::FRAME_CORNER_SHARE;
use crate::documents::{self, camera::CameraDocument, XOfN};
use crate::photo::identity::photos_exif;
use crate::photo::thumbnails::Keeping;
use crate::report::{self, camera::CameraReport};
use anyhow::Context;
use calib_targets::Checkerboard;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

/// Calibrate the camera's intrinsics from photos of a checkerboard.
///
/// Take 10-20 photos under water, the whole board in the frame, at different distances and
/// tilts, and put the board into every part of the frame, corners included: distortion is
/// only known where corners were seen. Photos without the board are listed and skipped.
#[derive(clap::Args, Debug)]
pub struct CameraArgs {
    /// The board: `COLSxROWS@SQUAREmm` with inner corners (where four squares meet), e.g.
    /// `14x10@42.17mm`. The square size only scales the poses, not the intrinsics.
    #[arg(long, value_name = "COLSxROWS@SQUAREmm", value_parser = parse_board)]
    board: Checkerboard,

    /// Print one JSON object instead of the summary.
    #[arg(long)]
    json: bool,

    /// Write the camera here as OpenCV FileStorage YAML (what `fslcal laser --camera` and
    /// OpenCV read).
    #[arg(long, value_name = "CAMERA")]
    out: Option<PathBuf>,

    /// Write an HTML report into this folder (created if missing): `index.html` with the
    /// residual vectors, per-photo RMS, the frame's coverage and a thumbnail of every photo,
    /// opened offline in any browser.
    #[arg(long, value_name = "DIR")]
    report: Option<PathBuf>,

    /// Calibration photos (JPEG, PNG or Olympus ORF raw), all from the same camera mode.
    #[arg(required = true, value_name = "PHOTOS")]
    photos: Vec<PathBuf>,
}

fn parse_board(s: &str) -> Result<Checkerboard, String> {
    crate::laser::target::parse_checkerboard(s)
}

pub fn run(args: CameraArgs) -> anyhow::Result<ExitCode> {
    let inputs: Vec<Input> = args.photos.iter().map(|p| Input::new("photo", p)).collect();
    let mut outs = Vec::new();
    outs.extend(args.out.as_deref().map(|p| Output::file("--out", p)));
    outs.extend(args.report.as_deref().map(|p| Output::report("--report", p)));
    outputs::check(&inputs, &outs, false)?;
    let args = CameraArgs { photos: super::photos::prepare(&args.photos)?, ..args };
    let job = CameraJob::new(args.board);
    // The report's thumbnails come from each photo's one decode, kept while the run lasts.
    let _thumbnails = args.report.is_some().then(|| Keeping::start(report::THUMBNAIL_WIDTH_PX));
    let bar = progress::bar(args.photos.len(), "photos", args.json);
    let result = calibrate(&job, &args.photos, &|| bar.inc(1));
    bar.finish_and_clear();
    let cal = result.context("cannot calibrate the camera")?;
    if args.json {
        println!("{}", documents::to_text(&CameraDocument::new(args.board.to_string(), &cal))?);
    } else {
        print!("{}", summary(&args, &cal));
    }
    if let Some(dir) = &args.report {
        outputs::say_if_replacing(dir);
        let index = report::camera::write(dir, &CameraReport { board: &args.board, calibration: &cal })?;
        if !args.json {
            eprintln!("report: {}", index.display());
        }
    }
    if let Some(out) = &args.out {
        // The body and zoom the photos agree on go into the file, so that `fslcal laser`
        // refuses another body's photos and warns when the zoom was used.
        let (_, camera_serial, focal_length_mm) = photos_exif(&args.photos);
        let extras = CameraFileExtras { avg_reprojection_error: Some(cal.rms_px), camera_serial, focal_length_mm };
        let yaml = opencv_yaml::to_yaml(&cal.camera, &extras);
        outputs::say_if_replacing(out);
        write_atomically(out, yaml.as_bytes())
            .with_context(|| format!("{}: cannot write the camera file", out.display()))?;
        if !args.json {
            println!("wrote {}", out.display());
        }
    }
    Ok(ExitCode::SUCCESS)
}

fn name_of(file: &str) -> String {
    Path::new(file).file_name().map_or_else(|| file.to_string(), |n| n.to_string_lossy().into_owned())
}

fn summary(args: &CameraArgs, cal: &CameraCalibration) -> String {
    let c = &cal.camera;
    let s = &cal.sigma;
    let d = c.distortion;
    let mut out = format!(
        "fslcal camera: {} photos, board {}, {}x{} px\n\n",
        cal.photos.len(),
        args.board,
        c.width_px,
        c.height_px
    );
    let width = cal.photos.iter().map(|p| name_of(&p.file).len()).max().unwrap_or(4).max(4);
    out += &format!("  {:width$}  {:>7}  {:>7}  {:>8}  {}\n", "file", "corners", "rms px", "worst px", "status");
    for p in &cal.photos {
        let corners = match (p.corners_used, p.corners_found) {
            (Some(u), Some(f)) => format!("{u}/{f}"),
            _ => "-".into(),
        };
        let rms = p.rms_px.map_or("-".into(), |r| format!("{r:.3}"));
        let worst = p.worst_px.map_or("-".into(), |r| format!("{r:.2}"));
        let status = p.status.explained();
        out += &format!("  {:width$}  {corners:>7}  {rms:>7}  {worst:>8}  {status}\n", name_of(&p.file));
    }
    let no_board = cal.photos.iter().filter(|p| p.status == CameraPhotoStatus::NoBoard).count();
    out += &format!(
        "\nphotos: {} used, {} rejected, {no_board} without the board; outlier photos {}\n",
        cal.used_photos(),
        cal.photo_outliers.0,
        XOfN::from(cal.photo_outliers)
    );
    out += &format!(
        "residuals: RMS {:.3} px per point over {} corners, worst {:.2} px in {}; outlier corners {} (beyond {} robust sigmas of their photo's corners)\n",
        cal.rms_px,
        cal.points,
        cal.worst_px,
        name_of(&cal.photos[cal.worst_photo].file),
        XOfN::from(cal.corner_outliers),
        cal.k_corner
    );
    out += &format!("fx {:9.2} ± {:.2} px   fy {:9.2} ± {:.2} px\n", c.fx_px, s[0], c.fy_px, s[1]);
    out += &format!("cx {:9.2} ± {:.2} px   cy {:9.2} ± {:.2} px\n", c.cx_px, s[2], c.cy_px, s[3]);
    out += &format!(
        "k1 {:+.5} ± {:.5}   k2 {:+.5} ± {:.5}   k3 {:+.5} ± {:.5}   p1 {:+.6} ± {:.6}   p2 {:+.6} ± {:.6}\n",
        d.k1, s[4], d.k2, s[5], d.k3, s[8], d.p1, s[6], d.p2, s[7]
    );
    out += &format!(
        "  (± is 1-sigma from the fit's covariance with the noise estimated per coordinate; OpenCV 4.6's own figures are {:.2}x larger)\n",
        if s[0] > 0.0 { cal.opencv_std_dev[0] / s[0] } else { f64::NAN }
    );
    out += &format!("coverage: the boards span {:.0}% of the image", 100.0 * cal.coverage.share);
    if cal.coverage.uncovered_frame_corners.is_empty() {
        out += "; every corner of the frame has board corners\n";
    } else {
        out += &format!(
            "\nwarning: no board corner within {:.0}% of the frame's {} corner(s): the distortion there is extrapolated; add photos with the board in those corners\n",
            100.0 * FRAME_CORNER_SHARE,
            cal.coverage.uncovered_frame_corners.join(", ")
        );
    }
    out
}
