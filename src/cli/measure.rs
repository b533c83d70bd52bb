//! `fslcal measure`: fish lengths from end points, the laser dot and a unit's calibration,
//! with their 1-sigma, and a dive's length distribution.

use super::outputs::{self, Input, Output};
use super::pixels::{pixel_arg, read_dots_csv};
use super::progress;
use crate::atomic_file::write_atomically;
use crate::calibration::{self, Calibration};
use crate::documents::lengths::{
    px, DistributionJson, FishEndsDocument, FishEndsJson, FishLengthDocument, FishRowJson, LengthsDocument, SummaryJson,
};
use crate::documents::{self, SCHEMA_VERSION};
use crate::fish::labels::{read_labels, FishLabel};
use crate::fish::measure::{
    camera_body_mismatch, distribution, ends_at_edge, measure, Distribution, DotMissing, EndsMissing, Length,
    MeasureParams, Withheld,
};
use crate::fish::{fish_ends, FishEnds, HeadCall, Mask};
use crate::photo::frame::Frame;
use anyhow::{bail, Context};
use fslcal_core::Vec2;
use rayon::prelude::*;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

/// Measure fish: length, distance and 1-sigma from the fish's end points, the laser dot and
/// the unit's calibration; or, with `--labels`/`--masks`, a whole dive with its length
/// distribution.
///
/// One fish: `--cal CAL PHOTO --head X,Y --tail X,Y [--dot X,Y]` (or `--mask MASK` for the
/// ends). A dive: `--cal CAL (--labels FILE | --masks DIR) PHOTOS...`. End points from a
/// mask alone: `--mask MASK` without `--cal`. A fish whose number would be wrong is listed
/// with the reason instead: no dot, dot off the laser line, distance outside the calibrated
/// range, fish cut by the frame edge, photo from another camera.
#[derive(clap::Args, Debug)]
pub struct MeasureArgs {
    /// The unit's calibration: the JSON `fslcal laser --out` writes, or a signed `.fslcal`.
    #[arg(long, value_name = "CAL")]
    cal: Option<PathBuf>,

    /// The snout, pixels (docs/conventions.md: centre of the top-left pixel is 0,0).
    #[arg(long, value_name = "X,Y", value_parser = pixel_arg, allow_hyphen_values = true)]
    head: Option<Vec2>,

    /// The fork of the tail, pixels.
    #[arg(long, value_name = "X,Y", value_parser = pixel_arg, allow_hyphen_values = true)]
    tail: Option<Vec2>,

    /// The laser dot, pixels, when it is not to be searched for.
    #[arg(long, value_name = "X,Y", value_parser = pixel_arg, allow_hyphen_values = true)]
    dot: Option<Vec2>,

    /// One fish's mask (fish pixels non-zero): its snout and fork are found in it.
    #[arg(long, value_name = "MASK", conflicts_with_all = ["head", "tail", "labels", "masks"])]
    mask: Option<PathBuf>,

    /// Hand labels for a dive: a CSV `photo,head_x,head_y,tail_x,tail_y[,dot_x,dot_y][,species]`
    /// (a header row may name the columns in any order) or Label Studio's JSON export with
    /// keypoints labelled head/snout, tail/fork and optionally dot, species as a choice.
    #[arg(long, value_name = "FILE", conflicts_with_all = ["head", "tail", "masks"])]
    labels: Option<PathBuf>,

    /// Measure photos from another camera body than the calibration's (EXIF serial); without
    /// it their fish are withheld.
    #[arg(long)]
    allow_other_body: bool,

    /// A folder of fish masks, one per photo: `NAME.png`, `NAME_mask.png` or
    /// `NAME.mask.png` for photo `NAME.jpg`.
    #[arg(long, value_name = "DIR", conflicts_with_all = ["head", "tail"])]
    masks: Option<PathBuf>,

    /// Hand-labelled dots, a CSV of `file,x,y` rows, for photos whose labels carry none.
    #[arg(long, value_name = "CSV")]
    dots: Option<PathBuf>,

    /// 1-sigma of a dot's centre in pixels, for the length's 1-sigma and the off-line check.
    #[arg(long, value_name = "PX", default_value = "1", value_parser = super::parse::positive_px, allow_negative_numbers = true)]
    dot_sigma_px: f64,

    /// Write one row per fish here (CSV).
    #[arg(long, value_name = "FILE")]
    out: Option<PathBuf>,

    /// Write the length distribution here (CSV: species, statistic, from_m, to_m, value).
    #[arg(long, value_name = "FILE")]
    summary_out: Option<PathBuf>,

    /// Print one JSON object instead of the summary.
    #[arg(long)]
    json: bool,

    /// Photos (JPEG, PNG or Olympus ORF raw).
    #[arg(value_name = "PHOTOS")]
    photos: Vec<PathBuf>,
}

/// Refuses, before any work, an output that is one of the run's inputs or the other output.
fn check_outputs(args: &MeasureArgs) -> anyhow::Result<()> {
    let mut inputs = Vec::new();
    for (what, path) in
        [("--cal", &args.cal), ("--labels", &args.labels), ("--dots", &args.dots), ("--mask", &args.mask)]
    {
        inputs.extend(path.as_deref().map(|p| Input::new(what, p)));
    }
    // The masks a folder holds are inputs too (a file merely in the folder may be replaced).
    let masks: Vec<PathBuf> = args
        .masks
        .as_deref()
        .and_then(|d| std::fs::read_dir(d).ok())
        .map(|entries| entries.filter_map(|e| e.ok().map(|e| e.path())).collect())
        .unwrap_or_default();
    inputs.extend(masks.iter().map(|p| Input::new("mask", p)));
    inputs.extend(args.photos.iter().map(|p| Input::new("photo", p)));
    let mut outs = Vec::new();
    outs.extend(args.out.as_deref().map(|p| Output::file("--out", p)));
    outs.extend(args.summary_out.as_deref().map(|p| Output::file("--summary-out", p)));
    Ok(outputs::check(&inputs, &outs, false)?)
}

pub fn run(args: MeasureArgs) -> anyhow::Result<ExitCode> {
    check_outputs(&args)?;
    if let (Some(head), Some(tail)) = (args.head, args.tail) {
        // Before any work: a zero-length fish would be measured as 0.0 mm ± 0.0.
        if (head - tail).norm() < 1.0 {
            let show = super::parse::show_number;
            bail!(
                "--head {},{} and --tail {},{} are the same point: give the snout and the fork of the tail",
                show(head.x),
                show(head.y),
                show(tail.x),
                show(tail.y)
            );
        }
    }
    let args = MeasureArgs { photos: super::photos::prepare(&args.photos)?, ..args };
    if args.labels.is_some() || args.masks.is_some() {
        return batch(&args);
    }
    match (&args.mask, &args.cal) {
        (Some(mask), None) => return mask_only(&args, mask),
        (None, None) => bail!("give --cal CAL to measure (or --mask MASK alone for end points in pixels)"),
        _ => {}
    }
    single(&args)
}

fn load_cal(args: &MeasureArgs) -> anyhow::Result<Calibration> {
    let path = args.cal.as_ref().context("--labels and --masks need --cal CAL")?;
    Ok(calibration::load(path)?)
}

fn load_ends(mask: &Path) -> anyhow::Result<(Mask, FishEnds)> {
    let m = Mask::load(mask)?;
    let ends = fish_ends(&m).with_context(|| mask.display().to_string())?;
    Ok((m, ends))
}

fn head_call_text(call: HeadCall) -> &'static str {
    match call {
        HeadCall::ForkNotch => "head told by the fork notch at the other end",
        HeadCall::NarrowPeduncle => "head told by the caudal peduncle and fin at the other end",
        HeadCall::Labelled => "head as labelled",
        HeadCall::Unknown => {
            "the mask does not tell head from tail (head and tail may be swapped; the length is the same)"
        }
    }
}

/// `--mask M` without a calibration: end points and pixel length only.
fn mask_only(args: &MeasureArgs, mask: &Path) -> anyhow::Result<ExitCode> {
    let (_, ends) = load_ends(mask)?;
    if args.json {
        let document = FishEndsDocument { schema_version: SCHEMA_VERSION, ends: FishEndsJson::from(&ends) };
        println!("{}", documents::to_text(&document)?);
    } else {
        println!(
            "{}: head ({:.1}, {:.1}) px, tail ({:.1}, {:.1}) px ({}), length {:.1} px{}\n  {}{}",
            mask.display(),
            ends.head_px.x,
            ends.head_px.y,
            ends.tail_px.x,
            ends.tail_px.y,
            match ends.tail_point {
                crate::fish::TailPoint::Fork { .. } => "fork",
                crate::fish::TailPoint::Tip => "tail tip, no fork found",
            },
            ends.length_px,
            if ends.bent { " along the bent body" } else { "" },
            head_call_text(ends.head_call),
            if ends.cut_by_edge { "\n  warning: the fish touches the frame edge and may be cut" } else { "" },
        );
    }
    Ok(ExitCode::SUCCESS)
}

/// The laser dot of a fish photo, searched for along the calibrated laser's image (no
/// target to narrow it down).
#[cfg(feature = "vision")]
fn search_dot(cal: &Calibration, photo: &Path) -> Result<Vec2, Withheld> {
    use crate::dot::on_line::find_dot_on_laser_line;
    let no_dot = |why: DotMissing| Withheld::NoDot { why: why.into() };
    let decoded = crate::vision::EncodedPhoto::read(photo)
        .and_then(|p| p.decode())
        .map_err(|e| no_dot(DotMissing::Unreadable { message: e.to_string() }))?;
    let search = cal.line_search();
    find_dot_on_laser_line(&decoded.colour(&search.detector.colour.tone), &cal.camera, &cal.laser, &search)
        .map(|d| d.pixel)
        .map_err(|e| no_dot(DotMissing::NotFound(e)))
}

#[cfg(not(feature = "vision"))]
fn search_dot(_cal: &Calibration, _photo: &Path) -> Result<Vec2, Withheld> {
    Err(Withheld::NoDot { why: DotMissing::NoVision.into() })
}

/// A photo's size in pixels: a JPEG's or PNG's from its header, a raw's from its active area.
fn photo_size(photo: &Path) -> anyhow::Result<(u32, u32)> {
    crate::photo::counter::count(crate::photo::counter::Event::HeaderRead);
    match image::image_dimensions(photo) {
        Ok(size) => Ok(size),
        #[cfg(feature = "vision")]
        Err(_) => Ok(crate::vision::EncodedPhoto::read(photo).and_then(|p| p.dimensions())?),
        #[cfg(not(feature = "vision"))]
        Err(e) => Err(e.into()),
    }
}

/// One fish in one photo.
fn single(args: &MeasureArgs) -> anyhow::Result<ExitCode> {
    let cal = load_cal(args)?;
    let [photo] = args.photos.as_slice() else {
        bail!("one fish: give exactly one PHOTO (for many, use --labels or --masks)");
    };
    let size = photo_size(photo).map_err(|why| anyhow::anyhow!("{}: cannot read the photo: {why}", photo.display()))?;
    let fish = single_fish(args, photo, size)?;
    let (dot, length) = measure_single(args, &cal, photo, size, &fish)?;
    if args.json {
        let document = FishLengthDocument {
            schema_version: SCHEMA_VERSION,
            photo: photo.display().to_string(),
            head_px: px(fish.head_px),
            tail_px: px(fish.tail_px),
            dot_px: Some(px(dot)),
            length: length.clone(),
            ends: fish.ends.as_ref().map(FishEndsJson::from),
        };
        println!("{}", documents::to_text(&document)?);
    } else {
        println!(
            "{}: length {:.1} mm ± {} (1-sigma), distance {:.3} m ± {} (calibration {}, dot {:.1} mm); dot {:.2} px from the laser line",
            photo.display(),
            length.length_m * 1e3,
            mm(length.length_sigma_m),
            length.distance_m,
            mm(length.distance_sigma_m),
            mm(length.distance_sigma_calibration_m),
            length.distance_sigma_dot_m * 1e3,
            length.dot_offset_px,
        );
        if length.distance_sigma_calibration_m.is_none() {
            println!("  {UNKNOWN_COVARIANCE}");
        }
        if let Some(e) = &fish.ends {
            println!("  {}", head_call_text(e.head_call));
        }
    }
    Ok(ExitCode::SUCCESS)
}

/// A 1-sigma in millimetres, or "unknown" when the calibration's covariance is.
fn mm(sigma_m: Option<f64>) -> String {
    sigma_m.map_or_else(|| "unknown".into(), |s| format!("{:.1} mm", s * 1e3))
}

/// Said once with lengths whose 1-sigma is unknown.
const UNKNOWN_COVARIANCE: &str = "the calibration's covariance is unknown (an imported calibration records none): the 1-sigma cannot be given, and the dot's part alone would understate it";

/// The one fish's end points: from `--mask` or from `--head` and `--tail`.
struct OneFish {
    head_px: Vec2,
    tail_px: Vec2,
    /// Length along the spine over the straight length (1 without a mask).
    length_over_chord: f64,
    ends: Option<FishEnds>,
}

fn single_fish(args: &MeasureArgs, photo: &Path, size: (u32, u32)) -> anyhow::Result<OneFish> {
    match (&args.mask, args.head, args.tail) {
        (Some(mask), _, _) => {
            let (m, ends) = load_ends(mask)?;
            if (m.width as u32, m.height as u32) != size {
                bail!(
                    "{}: the mask is {}x{} but the photo {} is {}x{}",
                    mask.display(),
                    m.width,
                    m.height,
                    photo.display(),
                    size.0,
                    size.1
                );
            }
            let length_over_chord = ends.length_px / ends.chord_px.max(1e-9);
            Ok(OneFish { head_px: ends.head_px, tail_px: ends.tail_px, length_over_chord, ends: Some(ends) })
        }
        (None, Some(head_px), Some(tail_px)) => Ok(OneFish { head_px, tail_px, length_over_chord: 1.0, ends: None }),
        _ => bail!("give --head X,Y and --tail X,Y (or --mask MASK) for the fish"),
    }
}

/// The one fish's dot and length, or an error naming every reason to withhold it.
fn measure_single(
    args: &MeasureArgs,
    cal: &Calibration,
    photo: &Path,
    size: (u32, u32),
    fish: &OneFish,
) -> anyhow::Result<(Vec2, Length)> {
    let mut flags = Vec::new();
    flags.extend(camera_body_mismatch(cal, photo, size, args.allow_other_body));
    let cut =
        fish.ends.as_ref().map_or_else(|| ends_at_edge(size, [fish.head_px, fish.tail_px], 2.0), |e| e.cut_by_edge);
    if cut {
        flags.push(Withheld::CutByEdge);
    }
    let params = MeasureParams {
        dot_sigma_px: args.dot_sigma_px,
        allow_other_body: args.allow_other_body,
        ..MeasureParams::default()
    };
    let dot = args.dot.map_or_else(|| search_dot(cal, photo), Ok);
    let result =
        dot.and_then(|d| Ok((d, measure(cal, fish.head_px, fish.tail_px, fish.length_over_chord, d, &params)?)));
    match result {
        Ok(measured) if flags.is_empty() => return Ok(measured),
        Ok(_) => {}
        Err(w) => flags.push(w),
    }
    bail!(
        "{}: length withheld: {}",
        photo.display(),
        flags.iter().map(Withheld::describe).collect::<Vec<_>>().join("; ")
    )
}

/// One fish of a dive, measured or withheld.
struct FishRow {
    photo: PathBuf,
    fish: usize,
    species: Option<String>,
    head_px: Option<Vec2>,
    tail_px: Option<Vec2>,
    dot_px: Option<Vec2>,
    head_call: Option<HeadCall>,
    result: Result<Length, Vec<Withheld>>,
}

/// Where a dive's end points come from.
enum Ends<'a> {
    Labels(&'a [FishLabel]),
    Masks(&'a Path),
}

/// The mask for `photo` in `dir`: `NAME.png`, `NAME_mask.png` or `NAME.mask.png`.
fn mask_for(dir: &Path, photo: &Path) -> Option<PathBuf> {
    let stem = photo.file_stem()?.to_string_lossy().into_owned();
    [format!("{stem}.png"), format!("{stem}_mask.png"), format!("{stem}.mask.png")]
        .into_iter()
        .map(|n| dir.join(n))
        .find(|p| p.is_file() && p.canonicalize().ok() != photo.canonicalize().ok())
}

/// A fish's end points as labelled or found in its mask.
struct EndPoints {
    head_px: Vec2,
    tail_px: Vec2,
    /// Length along the spine over the straight length (1 for labels).
    length_over_chord: f64,
    cut_by_edge: bool,
    head_call: HeadCall,
}

/// One fish to measure in a photo: its species, its end points or why they are missing,
/// and a dot given with its labels.
struct FishInPhoto {
    species: Option<String>,
    ends: Result<EndPoints, Withheld>,
    label_dot: Option<Vec2>,
}

fn measure_photo(
    cal: &Calibration,
    photo: &Path,
    source: &Ends,
    dots: &[(String, Vec2)],
    params: &MeasureParams,
) -> Vec<FishRow> {
    let size = photo_size(photo);
    let body = match &size {
        Ok(s) => camera_body_mismatch(cal, photo, *s, params.allow_other_body),
        Err(e) => Some(Withheld::NoEnds { why: EndsMissing::PhotoUnreadable { message: e.to_string() }.into() }),
    };
    let fish = fish_in_photo(photo, source, size.ok());
    let hand_dot = hand_dot(photo, dots);
    // One search per photo, however many fish it has.
    let searched = std::cell::OnceCell::new();
    fish.into_iter()
        .enumerate()
        .map(|(i, f)| {
            let dot = match f.label_dot.or(hand_dot) {
                Some(d) => Ok(d),
                None => searched.get_or_init(|| search_dot(cal, photo)).clone(),
            };
            let row = FishRow {
                photo: photo.to_path_buf(),
                fish: i + 1,
                species: f.species.clone(),
                head_px: None,
                tail_px: None,
                dot_px: dot.clone().ok(),
                head_call: None,
                result: Err(vec![]),
            };
            measure_fish(cal, row, f.ends, dot, body.as_ref(), params)
        })
        .collect()
}

/// The fish `row` with its end points and dot measured, or withheld with every reason.
fn measure_fish(
    cal: &Calibration,
    mut row: FishRow,
    ends: Result<EndPoints, Withheld>,
    dot: Result<Vec2, Withheld>,
    body: Option<&Withheld>,
    params: &MeasureParams,
) -> FishRow {
    let mut flags: Vec<Withheld> = body.into_iter().cloned().collect();
    let mut length = None;
    match ends {
        Err(w) => flags.push(w),
        Ok(e) => {
            (row.head_px, row.tail_px, row.head_call) = (Some(e.head_px), Some(e.tail_px), Some(e.head_call));
            if e.cut_by_edge {
                flags.push(Withheld::CutByEdge);
            }
            match dot.and_then(|d| measure(cal, e.head_px, e.tail_px, e.length_over_chord, d, params)) {
                Err(w) => flags.push(w),
                Ok(l) => length = Some(l),
            }
        }
    }
    row.result = match length {
        Some(l) if flags.is_empty() => Ok(l),
        _ => Err(flags),
    };
    row
}

/// The fish in `photo`: every label that names it, or its mask's one fish.
fn fish_in_photo(photo: &Path, source: &Ends, size: Option<(u32, u32)>) -> Vec<FishInPhoto> {
    match source {
        Ends::Labels(labels) => {
            labels.iter().filter(|l| l.names_photo(photo)).map(|l| labelled_fish(l, size)).collect()
        }
        Ends::Masks(dir) => vec![FishInPhoto { species: None, ends: mask_ends(dir, photo, size), label_dot: None }],
    }
}

/// A labelled fish in the photo's pixels: moved from the frame it was clicked in
/// (docs/conventions.md), withheld when that frame cannot be placed on the photo.
fn labelled_fish(l: &FishLabel, size: Option<(u32, u32)>) -> FishInPhoto {
    let shift = match (l.frame, size) {
        (Some(from), Some((w, h))) => from.map_to(&Frame::of_size(w, h)).map(|m| m.shift_px),
        _ => Ok(Vec2::zeros()),
    };
    let at = |p: Vec2| p + *shift.as_ref().unwrap_or(&Vec2::zeros());
    let (head_px, tail_px) = (at(l.head_px), at(l.tail_px));
    let ends = match &shift {
        Err(e) => Err(Withheld::NoEnds { why: EndsMissing::LabelFrame { message: e.to_string() }.into() }),
        Ok(_) => Ok(EndPoints {
            head_px,
            tail_px,
            length_over_chord: 1.0,
            cut_by_edge: size.is_some_and(|s| ends_at_edge(s, [head_px, tail_px], 2.0)),
            head_call: HeadCall::Labelled,
        }),
    };
    FishInPhoto { species: l.species.clone(), ends, label_dot: l.dot_px.map(at) }
}

/// The end points of the fish in `photo`'s mask in `dir`.
fn mask_ends(dir: &Path, photo: &Path, size: Option<(u32, u32)>) -> Result<EndPoints, Withheld> {
    let no_ends = |why: EndsMissing| Withheld::NoEnds { why: why.into() };
    let path = mask_for(dir, photo).ok_or_else(|| no_ends(EndsMissing::NoMask { dir: dir.to_path_buf() }))?;
    let mask = Mask::load(&path).map_err(|e| no_ends(EndsMissing::Mask { message: e.to_string() }))?;
    // A mask of another grid of the same sensor (the lab's 4040x3016 readout) is moved by
    // the crop; any other size cannot be placed.
    let mask_frame = Frame::of_size(mask.width as u32, mask.height as u32);
    let shift = match size {
        Some((w, h)) => {
            mask_frame
                .map_to(&Frame::of_size(w, h))
                .map_err(|_| no_ends(EndsMissing::MaskSize { mask: path }))?
                .shift_px
        }
        None => Vec2::zeros(),
    };
    let e = fish_ends(&mask).map_err(|e| no_ends(EndsMissing::Mask { message: e.to_string() }))?;
    Ok(EndPoints {
        head_px: e.head_px + shift,
        tail_px: e.tail_px + shift,
        length_over_chord: e.length_px / e.chord_px.max(1e-9),
        cut_by_edge: e.cut_by_edge,
        head_call: e.head_call,
    })
}

/// A dot given by hand for `photo` (by its path or its file name) in `--dots`.
fn hand_dot(photo: &Path, dots: &[(String, Vec2)]) -> Option<Vec2> {
    let name = photo.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    dots.iter()
        .find(|(f, _)| Path::new(f) == photo || Path::new(f).file_name().is_some_and(|n| n.to_string_lossy() == name))
        .map(|d| d.1)
}

fn batch(args: &MeasureArgs) -> anyhow::Result<ExitCode> {
    let cal = load_cal(args)?;
    if args.photos.is_empty() {
        bail!("give the dive's PHOTOS after the options");
    }
    let labels = match &args.labels {
        Some(path) => read_labels(path)?,
        None => Vec::new(),
    };
    let source = match &args.masks {
        Some(dir) if dir.is_file() => bail!(
            "{}: a file, not a folder of masks; give the folder the masks are in (--mask FILE is for one fish)",
            dir.display()
        ),
        Some(dir) if !dir.is_dir() => bail!("{}: no such folder of masks", dir.display()),
        Some(dir) => Ends::Masks(dir),
        None => Ends::Labels(&labels),
    };
    let dots = match &args.dots {
        Some(csv) => read_dots_csv(csv)?,
        None => Vec::new(),
    };
    let params = MeasureParams {
        dot_sigma_px: args.dot_sigma_px,
        allow_other_body: args.allow_other_body,
        ..MeasureParams::default()
    };
    let bar = progress::bar(args.photos.len(), "photos", args.json);
    let per_photo: Vec<Vec<FishRow>> = args
        .photos
        .par_iter()
        .map(|p| {
            let rows = measure_photo(&cal, p, &source, &dots, &params);
            bar.inc(1);
            rows
        })
        .collect();
    bar.finish_and_clear();
    let unlabelled: Vec<&PathBuf> =
        args.photos.iter().zip(&per_photo).filter(|(_, r)| r.is_empty()).map(|(p, _)| p).collect();
    let rows: Vec<FishRow> = per_photo.into_iter().flatten().collect();
    if rows.is_empty() {
        bail!(
            "none of the {} photos has a labelled fish: do the label file's photo names match the photos' file names?",
            args.photos.len()
        );
    }
    let summary = Summary::of(&rows);
    if let Some(out) = &args.out {
        outputs::say_if_replacing(out);
        write_atomically(out, rows_csv(&rows).as_bytes())
            .with_context(|| format!("{}: cannot write the lengths", out.display()))?;
    }
    if let Some(out) = &args.summary_out {
        outputs::say_if_replacing(out);
        write_atomically(out, summary.csv().as_bytes())
            .with_context(|| format!("{}: cannot write the summary", out.display()))?;
    }
    if args.json {
        let document = LengthsDocument {
            schema_version: SCHEMA_VERSION,
            calibration: cal.source.display().to_string(),
            fish: rows.iter().map(row_document).collect(),
            photos_without_fish: unlabelled.iter().map(|p| p.display().to_string()).collect(),
            measured: summary.measured,
            total: rows.len(),
            withheld: summary.withheld.iter().map(|(k, n)| (k.to_string(), *n)).collect(),
            summary: summary.document(),
        };
        println!("{}", documents::to_text(&document)?);
    } else {
        print!("{}", table(&rows));
        if rows.iter().any(|r| r.result.as_ref().is_ok_and(|l| l.distance_sigma_calibration_m.is_none())) {
            println!("{UNKNOWN_COVARIANCE}");
        }
        if !unlabelled.is_empty() {
            println!("{} photo(s) without a labelled fish", unlabelled.len());
        }
        print!("{}", summary.text(rows.len()));
        for (what, out) in [("lengths", &args.out), ("summary", &args.summary_out)] {
            if let Some(out) = out {
                println!("wrote {what} to {}", out.display());
            }
        }
    }
    Ok(ExitCode::SUCCESS)
}

fn row_document(r: &FishRow) -> FishRowJson {
    let length = r.result.as_ref().ok();
    FishRowJson {
        photo: r.photo.display().to_string(),
        fish: r.fish,
        species: r.species.clone(),
        head_px: r.head_px.map(px),
        tail_px: r.tail_px.map(px),
        dot_px: r.dot_px.map(px),
        head_call: r.head_call,
        length_m: length.map(|l| l.length_m),
        distance_m: length.map(|l| l.distance_m),
        length_sigma_m: length.and_then(|l| l.length_sigma_m),
        distance_sigma_m: length.and_then(|l| l.distance_sigma_m),
        dot_offset_px: length.map(|l| l.dot_offset_px),
        flags: r.result.as_ref().err().cloned().unwrap_or_default(),
    }
}

fn name_of(p: &Path) -> String {
    p.file_name().map_or_else(|| p.display().to_string(), |n| n.to_string_lossy().into_owned())
}

fn table(rows: &[FishRow]) -> String {
    let width = rows.iter().map(|r| name_of(&r.photo).len()).max().unwrap_or(5).max(5);
    let mut s = format!(
        "  {:width$}  {:>4}  {:12}  {:>20}  {:>15}  {}\n",
        "photo", "fish", "species", "length mm (1-sigma)", "distance m", "status"
    );
    for r in rows {
        let (length, distance, status) = match &r.result {
            Ok(l) => (
                match l.length_sigma_m {
                    Some(s) => format!("{:.1} ± {:.1}", l.length_m * 1e3, s * 1e3),
                    None => format!("{:.1} ± unknown", l.length_m * 1e3),
                },
                match l.distance_sigma_m {
                    Some(s) => format!("{:.3} ± {s:.3}", l.distance_m),
                    None => format!("{:.3} ± unknown", l.distance_m),
                },
                "measured".to_string(),
            ),
            Err(flags) => (
                "-".into(),
                "-".into(),
                format!("withheld: {}", flags.iter().map(Withheld::describe).collect::<Vec<_>>().join("; ")),
            ),
        };
        let species = r.species.as_deref().unwrap_or("-");
        s += &format!(
            "  {:width$}  {:>4}  {species:12}  {length:>20}  {distance:>15}  {status}\n",
            name_of(&r.photo),
            r.fish
        );
    }
    s
}

fn rows_csv(rows: &[FishRow]) -> String {
    let mut s = String::from("photo,fish,species,head_x,head_y,tail_x,tail_y,dot_x,dot_y,length_m,length_sigma_m,distance_m,distance_sigma_m,flags\n");
    let xy = |p: Option<Vec2>| p.map_or(",".to_string(), |p| format!("{:.2},{:.2}", p.x, p.y));
    for r in rows {
        let (numbers, flags) = match &r.result {
            Ok(l) => (
                {
                    // An unknown 1-sigma is an empty field, never 0.
                    let or_empty = |s: Option<f64>, d: usize| s.map_or(String::new(), |s| format!("{s:.d$}"));
                    format!(
                        "{:.5},{},{:.4},{}",
                        l.length_m,
                        or_empty(l.length_sigma_m, 5),
                        l.distance_m,
                        or_empty(l.distance_sigma_m, 5)
                    )
                },
                String::new(),
            ),
            Err(f) => (",,,".to_string(), f.iter().map(Withheld::flag_name).collect::<Vec<_>>().join(";")),
        };
        s += &format!(
            "{},{},{},{},{},{},{},{}\n",
            r.photo.display(),
            r.fish,
            r.species.as_deref().unwrap_or(""),
            xy(r.head_px),
            xy(r.tail_px),
            xy(r.dot_px),
            numbers,
            flags
        );
    }
    s
}

/// The dive's length distribution, overall and per species.
struct Summary {
    measured: usize,
    /// Withheld fish by flag name.
    withheld: BTreeMap<&'static str, usize>,
    all: Option<Distribution>,
    species: BTreeMap<String, Distribution>,
}

impl Summary {
    fn of(rows: &[FishRow]) -> Summary {
        let mut withheld = BTreeMap::new();
        let mut by_species: BTreeMap<String, Vec<f64>> = BTreeMap::new();
        let mut all = Vec::new();
        for r in rows {
            match &r.result {
                Ok(l) => {
                    all.push(l.length_m);
                    if let Some(sp) = &r.species {
                        by_species.entry(sp.clone()).or_default().push(l.length_m);
                    }
                }
                Err(flags) => {
                    for f in flags {
                        *withheld.entry(f.flag_name()).or_insert(0) += 1;
                    }
                }
            }
        }
        Summary {
            measured: all.len(),
            withheld,
            all: distribution(&all),
            species: by_species.into_iter().filter_map(|(k, v)| distribution(&v).map(|d| (k, d))).collect(),
        }
    }

    fn groups(&self) -> Vec<(&str, &Distribution)> {
        self.all.iter().map(|d| ("all", d)).chain(self.species.iter().map(|(k, d)| (k.as_str(), d))).collect()
    }

    fn document(&self) -> SummaryJson {
        SummaryJson {
            all: self.all.as_ref().map(DistributionJson::from),
            species: self.species.iter().map(|(k, d)| (k.clone(), DistributionJson::from(d))).collect(),
        }
    }

    fn csv(&self) -> String {
        let mut s = String::from("species,statistic,from_m,to_m,value\n");
        for (group, d) in self.groups() {
            s += &format!("{group},n,,,{}\n{group},mean_m,,,{:.5}\n", d.n, d.mean_m);
            for (p, v) in &d.percentiles_m {
                s += &format!("{group},p{p}_m,,,{v:.5}\n");
            }
            for (a, b, n) in &d.histogram {
                s += &format!("{group},count,{a:.4},{b:.4},{n}\n");
            }
        }
        s
    }

    fn text(&self, total: usize) -> String {
        let mut s = format!("\nmeasured {} of {} fish", self.measured, total);
        if !self.withheld.is_empty() {
            let w: Vec<String> = self.withheld.iter().map(|(k, n)| format!("{k} {n}")).collect();
            s += &format!("; withheld: {}", w.join(", "));
        }
        s += "\n";
        for (group, d) in self.groups() {
            let pct: Vec<String> = d.percentiles_m.iter().map(|(p, v)| format!("p{p} {:.1}", v * 1e3)).collect();
            s += &format!("\n{group}: n {}, mean {:.1} mm; {} mm\n", d.n, d.mean_m * 1e3, pct.join(", "));
            let most = d.histogram.iter().map(|h| h.2).max().unwrap_or(1).max(1);
            for (a, b, n) in &d.histogram {
                s += &format!(
                    "  {:7.1}-{:<7.1} mm {:>5}  {}\n",
                    a * 1e3,
                    b * 1e3,
                    n,
                    "#".repeat((40 * n).div_ceil(most))
                );
            }
        }
        s
    }
}
