//! Every command reads and decodes each photo once (issue 17): the reduced search image,
//! the full-resolution pixels and the report's thumbnail all come from one decode. Each
//! test runs a whole command in this process and reads the photo counters
//! (`fslcal::photo::counter`) before and after it.

mod common;

use calib_targets::scene::{render, Water};
use calib_targets::write_scene;
use common::{fish_set, laser_set, no_board_spec, FishSet, SceneSet};
use fslcal::photo::counter::{counts, PhotoCounts};
use std::path::{Path, PathBuf};
use std::sync::{Mutex, OnceLock};

/// The counters are the process's: one command at a time.
static ONE_AT_A_TIME: Mutex<()> = Mutex::new(());

/// Six board photos with the dot (clear water, one glint each) and one without a board.
fn board_set() -> &'static (SceneSet, PathBuf) {
    static SET: OnceLock<(SceneSet, PathBuf)> = OnceLock::new();
    SET.get_or_init(|| {
        let set = laser_set("decode-once", 6, 31, Water::Clear, 1);
        write_scene(&set.dir, "no_board", &render(&no_board_spec(7))).unwrap();
        let no_board = set.dir.join("no_board.jpg");
        (set, no_board)
    })
}

fn fish() -> &'static FishSet {
    static SET: OnceLock<FishSet> = OnceLock::new();
    SET.get_or_init(|| fish_set("decode-once-fish", 3, 5))
}

/// Runs `fslcal ARGS...` in this process; its photo counts, and whether it succeeded.
fn counted(args: &[String]) -> (PhotoCounts, bool) {
    let before = counts();
    let ok = fslcal::cli::run_from(std::iter::once("fslcal".to_string()).chain(args.iter().cloned()))
        .map(|code| code == std::process::ExitCode::SUCCESS)
        .unwrap_or(false);
    (counts() - before, ok)
}

fn strings(v: &[&dyn AsRef<std::ffi::OsStr>]) -> Vec<String> {
    v.iter().map(|s| s.as_ref().to_string_lossy().into_owned()).collect()
}

fn paths(p: &[PathBuf]) -> Vec<String> {
    p.iter().map(|p| p.display().to_string()).collect()
}

fn scratch(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("decode-once-out").join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Thumbnails a report at `dir` shows.
fn thumbnails(dir: &Path) -> usize {
    std::fs::read_dir(dir.join("thumbs")).map_or(0, |d| d.count())
}

const BOARD: &str = "checkerboard:14x10@42.17mm";

/// Prints the counts (for the closing note) and holds them to one read and one
/// full-resolution decode per photo, nothing decoded at reduced size besides, and at most
/// one header read per photo (the EXIF a command reports).
fn once_each(what: &str, photos: usize, c: &PhotoCounts) {
    println!(
        "{what}: {photos} photos: file reads {}, header reads {}, full decodes {}, reduced decodes {}",
        c.file_reads, c.header_reads, c.full_decodes, c.reduced_decodes
    );
    let want =
        PhotoCounts { file_reads: photos, header_reads: c.header_reads, full_decodes: photos, reduced_decodes: 0 };
    assert_eq!(*c, want, "{what}");
    assert!(c.header_reads <= photos, "{what}: {} header reads", c.header_reads);
}

#[test]
fn laser_and_its_report_decode_each_photo_once() {
    let (set, no_board) = board_set();
    let _one = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    let out = scratch("laser");
    let mut photos = set.photos.clone();
    photos.push(no_board.clone());
    let mut args = strings(&[&"laser", &"--json", &"--camera", &set.camera_file, &"--target", &BOARD]);
    args.extend(paths(&photos));
    let (plain, ok) = counted(&args);
    assert!(ok, "the laser run fits");
    once_each("laser", photos.len(), &plain);
    args.extend(strings(&[&"--report", &out.join("report")]));
    let (report, ok) = counted(&args);
    assert!(ok && out.join("report/index.html").is_file());
    assert_eq!(thumbnails(&out.join("report")), photos.len());
    once_each("laser --report", photos.len(), &report);
}

#[test]
fn camera_and_its_report_decode_each_photo_once() {
    let (set, no_board) = board_set();
    let _one = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    let out = scratch("camera");
    let mut photos = set.photos.clone();
    photos.push(no_board.clone());
    let mut args = strings(&[&"camera", &"--json", &"--board", &"14x10@42.17mm", &"--report", &out.join("report")]);
    args.extend(paths(&photos));
    let (c, ok) = counted(&args);
    assert!(ok && thumbnails(&out.join("report")) == photos.len());
    once_each("camera --report", photos.len(), &c);
}

#[test]
fn validate_and_check_decode_each_photo_once() {
    let (set, no_board) = board_set();
    let _one = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    let out = scratch("validate");
    let cal = out.join("cal.json");
    let mut args = strings(&[&"laser", &"--out", &cal, &"--camera", &set.camera_file, &"--target", &BOARD]);
    args.extend(paths(&set.photos));
    assert!(counted(&args).1, "the calibration for validate and check");
    let mut photos = set.photos.clone();
    photos.push(no_board.clone());
    let mut validate =
        strings(&[&"validate", &"--json", &"--cal", &cal, &"--target", &BOARD, &"--report", &out.join("v")]);
    validate.extend(paths(&photos));
    let (c, _) = counted(&validate);
    assert_eq!(thumbnails(&out.join("v")), photos.len());
    once_each("validate --report", photos.len(), &c);
    let mut check = strings(&[&"check", &"--json", &"--cal", &cal, &"--report", &out.join("c")]);
    check.extend(paths(&photos));
    let (c, _) = counted(&check);
    assert_eq!(thumbnails(&out.join("c")), photos.len());
    once_each("check --report", photos.len(), &c);
}

#[test]
fn measure_decodes_each_photo_once_or_not_at_all() {
    let set = fish();
    let _one = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    let masks = set.dir.join("masks");
    let mut searched = strings(&[&"measure", &"--json", &"--cal", &set.cal, &"--masks", &masks]);
    searched.extend(paths(&set.photos));
    let (c, ok) = counted(&searched);
    assert!(ok);
    once_each("measure --masks (dot searched)", set.photos.len(), &c);
    let mut given = strings(&[&"measure", &"--json", &"--cal", &set.cal, &"--masks", &masks, &"--dots", &set.dots]);
    given.extend(paths(&set.photos));
    let (c, ok) = counted(&given);
    assert!(ok);
    println!("measure --masks --dots: {} photos: {c:?}", set.photos.len());
    // With the dots given, only the photos' headers are read (their size and body).
    assert_eq!((c.file_reads, c.full_decodes, c.reduced_decodes), (0, 0, 0));
    assert!(c.header_reads <= set.photos.len());
}

#[test]
fn develop_decodes_each_raw_once() {
    let (set, _) = board_set();
    let _one = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    let out = scratch("develop");
    let image = image::open(&set.photos[0]).unwrap().to_rgb8();
    let raw = out.join("P0000001.ORF");
    std::fs::write(&raw, calib_targets::orf::tg6_orf(&image, &calib_targets::orf::OrfMeta::default())).unwrap();
    let (c, ok) = counted(&strings(&[&"develop", &"--json", &"--out", &out.join("png"), &raw]));
    assert!(ok);
    once_each("develop", 1, &c);
}
