//! The HTML reports in a real browser (Debian's chromium, headless): `fslcal laser --report`
//! on rendered photos and `fslcal camera --report` on OpenCV's sample photos, then each page
//! loaded with no failed requests and no console messages, every image decoded
//! (naturalWidth > 0), nothing fetched from outside the report's folder, and a screenshot
//! taken.
//!
//! chromium is installed by `.ci/setup`; without it this test fails (it does not skip), so
//! CI cannot pass with the report untested. `FSLCAL_CHROMIUM` names another binary.

mod common;

use calib_targets::scene::{laser_scene_set, Water};
use common::{no_board_spec, render_set, SceneSet};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

/// Put at the top of a copy of the page's `<head>`: records load failures (capture phase
/// sees every element's failed load), console errors and warnings, and on `load` writes
/// the images' state and every fetched resource into the DOM for `--dump-dom`.
const CHECK_SCRIPT: &str = r#"<script>
(function () {
  var errors = [];
  window.addEventListener('error', function (e) {
    var t = e.target;
    if (t && t !== window && (t.src || t.href)) { errors.push('failed to load ' + (t.src || t.href)); }
    else { errors.push('script error: ' + e.message); }
  }, true);
  ['error', 'warn'].forEach(function (k) {
    console[k] = function () { errors.push('console.' + k + ': ' + Array.prototype.join.call(arguments, ' ')); };
  });
  window.addEventListener('load', function () {
    var images = Array.prototype.map.call(document.images, function (i) {
      return { src: i.currentSrc || i.src, complete: i.complete, naturalWidth: i.naturalWidth, naturalHeight: i.naturalHeight };
    });
    var resources = performance.getEntriesByType('resource').map(function (r) { return r.name; });
    var out = document.createElement('pre');
    out.id = 'fslcal-check';
    out.textContent = JSON.stringify({ errors: errors, images: images, resources: resources, page: location.href });
    document.body.appendChild(out);
  });
})();
</script>"#;

fn chromium() -> PathBuf {
    if let Some(p) = std::env::var_os("FSLCAL_CHROMIUM") {
        return PathBuf::from(p);
    }
    for name in ["chromium", "chromium-browser", "google-chrome"] {
        if let Some(p) = std::env::split_paths(&std::env::var_os("PATH").unwrap_or_default())
            .map(|d| d.join(name))
            .find(|p| p.is_file())
        {
            return p;
        }
    }
    panic!("chromium not found: the report's browser test needs it; run `bash .ci/setup` (apt package `chromium`) or set FSLCAL_CHROMIUM");
}

/// Runs headless chromium on `page` with `extra` arguments; returns (stdout, stderr).
fn run_chromium(page: &Path, profile: &Path, extra: &[String]) -> (String, String) {
    let url = format!("file://{}", page.canonicalize().expect("page exists").display());
    let out = Command::new("timeout")
        .arg("120")
        .arg(chromium())
        .args([
            "--headless",
            // CI runs as root in a container, where chromium's sandbox cannot start.
            "--no-sandbox",
            "--disable-gpu",
            "--hide-scrollbars",
            "--no-first-run",
            "--enable-logging=stderr",
            "--v=0",
            // Any attempt at the network fails, and shows up as a failed load.
            "--host-resolver-rules=MAP * ~NOTFOUND",
            "--virtual-time-budget=10000",
        ])
        .arg(format!("--user-data-dir={}", profile.display()))
        .args(extra)
        .arg(&url)
        .output()
        .expect("run chromium");
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success(), "chromium failed ({}) on {url}:\n{stderr}", out.status);
    (String::from_utf8_lossy(&out.stdout).into_owned(), stderr)
}

/// What the page check found: problems, one line each, and the number of images.
struct PageCheck {
    problems: Vec<String>,
    images: usize,
}

/// Loads a copy of `dir/index.html` with [`CHECK_SCRIPT`] in it and reads the verdict back
/// from the dumped DOM and chromium's console log.
fn check_page(dir: &Path, profile: &Path) -> PageCheck {
    let html = std::fs::read_to_string(dir.join("index.html")).expect("index.html");
    let checked = html.replacen("<head>", &format!("<head>\n{CHECK_SCRIPT}"), 1);
    assert_ne!(checked, html, "the report has a <head>");
    let page = dir.join("check-page.html");
    std::fs::write(&page, checked).unwrap();
    let (dom, stderr) = run_chromium(&page, profile, &["--dump-dom".to_string()]);
    std::fs::remove_file(&page).unwrap();

    let start = dom.find("<pre id=\"fslcal-check\">").expect("the check ran (its result is in the DOM)") + 23;
    let end = start + dom[start..].find("</pre>").unwrap();
    let json = dom[start..end].replace("&quot;", "\"").replace("&lt;", "<").replace("&gt;", ">").replace("&amp;", "&");
    let v: serde_json::Value = serde_json::from_str(&json).expect("check result is JSON");

    let mut problems: Vec<String> =
        v["errors"].as_array().unwrap().iter().map(|e| e.as_str().unwrap().to_string()).collect();
    // Messages the browser itself logs to the console (CSP, parse and load errors) reach
    // stderr as CONSOLE lines; the report has no scripts, so any such line is a problem.
    problems.extend(stderr.lines().filter(|l| l.contains(":CONSOLE")).map(|l| format!("console: {l}")));
    let images = v["images"].as_array().unwrap();
    for img in images {
        if !(img["complete"].as_bool() == Some(true) && img["naturalWidth"].as_u64().unwrap_or(0) > 0) {
            problems.push(format!("image not shown: {img}"));
        }
    }
    let dir_url = format!("file://{}/", dir.canonicalize().unwrap().display());
    for r in v["resources"].as_array().unwrap() {
        let r = r.as_str().unwrap();
        if !r.starts_with(&dir_url) {
            problems.push(format!("fetched from outside the report: {r}"));
        }
    }
    PageCheck { problems, images: images.len() }
}

/// Rendered once per test binary, shared by the tests.
fn scenes() -> &'static SceneSet {
    static SET: OnceLock<SceneSet> = OnceLock::new();
    SET.get_or_init(|| {
        let mut specs = laser_scene_set(5, 41, Water::Clear, 1);
        specs.push(no_board_spec(42));
        render_set("report-browser", &specs)
    })
}

fn fslcal(args: &[String]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_fslcal")).args(args).output().expect("run fslcal")
}

fn photo_args(set: &SceneSet) -> Vec<String> {
    set.photos.iter().map(|p| p.display().to_string()).collect()
}

/// `fslcal laser` on the shared scenes with one more option (`--out` or `--report`).
fn laser_args(set: &SceneSet, option: &str, path: &Path) -> Vec<String> {
    let mut args: Vec<String> = vec!["laser".into(), "--camera".into(), set.camera_file.display().to_string()];
    args.extend(["--target".into(), "checkerboard:14x10@42.17mm".into(), option.into(), path.display().to_string()]);
    args.extend(photo_args(set));
    args
}

#[test]
fn validate_and_check_reports_load_in_chromium() {
    let set = scenes();
    let dir = tempfile::tempdir().unwrap();
    let cal = dir.path().join("laser.json");
    let o = fslcal(&laser_args(set, "--out", &cal));
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let profile = tempfile::tempdir().unwrap();

    let report = dir.path().join("validate-report");
    let mut args: Vec<String> = vec!["validate".into(), "--cal".into(), cal.display().to_string()];
    args.extend([
        "--target".into(),
        "checkerboard:14x10@42.17mm".into(),
        "--report".into(),
        report.display().to_string(),
    ]);
    args.extend(photo_args(set));
    let o = fslcal(&args);
    let html = std::fs::read_to_string(report.join("index.html")).expect("validate report");
    // Pass or fail, the page says which and lists all six photos.
    let verdict = if o.status.success() { "PASS: " } else { "FAIL: " };
    assert!(html.contains(verdict), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(html.contains("length `first row of inner corners` (548.2 mm)"));
    assert!(html.contains("skipped: no 14x10 checkerboard found"));
    assert_eq!(html.matches("<img src=\"thumbs/").count(), 6);
    assert_loads_cleanly(&report, profile.path(), 8);

    let report = dir.path().join("check-report");
    let mut args: Vec<String> = vec!["check".into(), "--cal".into(), cal.display().to_string()];
    args.extend(["--report".into(), report.display().to_string()]);
    args.extend(photo_args(set));
    let o = fslcal(&args);
    let html = std::fs::read_to_string(report.join("index.html")).expect("check report");
    let verdict = if o.status.success() { "No drift: " } else { "DRIFTED: " };
    assert!(html.contains(verdict), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(html.contains("flag above (px)"));
    assert_eq!(html.matches("<img src=\"thumbs/").count(), 6);
    assert_loads_cleanly(&report, profile.path(), 7);
}

#[test]
fn laser_report_loads_in_chromium_with_every_image_and_no_errors() {
    let set = scenes();
    let report = set.path().join("report");
    let o = fslcal(&laser_args(set, "--report", &report));
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));

    // The page's own claims: the skipped photo's reason, five plots, six thumbnails.
    let html = std::fs::read_to_string(report.join("index.html")).unwrap();
    assert!(html.contains("ACCEPTED"));
    assert!(html.contains("skipped: no 14x10 checkerboard found"), "reason beside the skipped photo");
    assert_eq!(html.matches("<img src=\"plots/").count(), 5);
    assert_eq!(html.matches("<img src=\"thumbs/").count(), 6);

    let profile = tempfile::tempdir().unwrap();
    assert_loads_cleanly(&report, profile.path(), 11);

    // The check can fail: the same page with a plot and a thumbnail removed.
    let broken = set.path().join("report-broken");
    let _ = std::fs::remove_dir_all(&broken);
    copy_dir(&report, &broken);
    std::fs::remove_file(broken.join("plots/residuals.svg")).unwrap();
    let thumb = std::fs::read_dir(broken.join("thumbs")).unwrap().next().unwrap().unwrap().path();
    std::fs::remove_file(&thumb).unwrap();
    // ... and a picture from the network, and a script complaining on the console.
    let page = std::fs::read_to_string(broken.join("index.html")).unwrap().replacen(
        "</body>",
        "<img src=\"https://example.invalid/pixel.png\" alt=\"\"><script>console.error('broken on purpose')</script></body>",
        1,
    );
    std::fs::write(broken.join("index.html"), page).unwrap();
    let bad = check_page(&broken, profile.path());
    let count = |prefix: &str| bad.problems.iter().filter(|p| p.starts_with(prefix)).count();
    assert_eq!(
        (
            count("image not shown"),
            count("failed to load"),
            count("failed to load https://example.invalid"),
            count("fetched from outside the report"),
            count("console.error: broken on purpose"),
        ),
        (3, 3, 1, 1, 1),
        "{:#?}",
        bad.problems
    );

    // The screenshot a person would see, kept beside the rendered photos.
    let shot = set.path().join("report-screenshot.png");
    let _ = std::fs::remove_file(&shot);
    run_chromium(
        &report.join("index.html"),
        profile.path(),
        &[format!("--screenshot={}", shot.display()), "--window-size=1200,2400".to_string()],
    );
    let img = image::open(&shot).expect("a screenshot was written").to_rgb8();
    assert_eq!(img.dimensions(), (1200, 2400));
    // A rendered page, not a blank one: the accepted banner's green and the plots' blue.
    let has = |c: [u8; 3]| img.pixels().any(|p| p.0 == c);
    assert!(has([0xe3, 0xf4, 0xe3]), "verdict banner drawn");
    assert!(has([31, 119, 180]), "plot markers drawn");
    eprintln!("screenshot: {}", shot.display());
}

/// The page loads with nothing failed or logged, and all `images` images are shown.
fn assert_loads_cleanly(report: &Path, profile: &Path, images: usize) {
    let html = std::fs::read_to_string(report.join("index.html")).unwrap();
    for banned in ["<script", "<link", "@import", "url(", "http://", "https://"] {
        assert!(!html.contains(banned), "the page must load nothing else: found `{banned}`");
    }
    let check = check_page(report, profile);
    assert!(check.problems.is_empty(), "the report does not load cleanly:\n{}", check.problems.join("\n"));
    assert_eq!(check.images, images, "every plot and thumbnail reached the browser");
}

#[test]
fn camera_report_of_opencvs_sample_photos_loads_in_chromium() {
    let photos: Vec<PathBuf> = (1..=14)
        .filter(|i| *i != 10)
        .map(|i| Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("tests/data/opencv-samples/left{i:02}.jpg")))
        .collect();
    let dir = tempfile::tempdir().unwrap();
    let report = dir.path().join("camera-report");
    let o = Command::new(env!("CARGO_BIN_EXE_fslcal"))
        .args(["camera", "--board", "9x6@25mm", "--report"])
        .arg(&report)
        .args(&photos)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let html = std::fs::read_to_string(report.join("index.html")).unwrap();
    // The figures of this set (see tests/camera_real.rs): fx near 533 px, 13 photos used,
    // and the frame's corners never reached by the board.
    assert!(html.contains("13 photos (13 used, 0 rejected, 0 without the board)"), "{html}");
    assert!(html.contains("<td>fx, fy</td><td>533."), "fx in the key figures");
    assert!(html.contains("verdict warning") && html.contains("top-left"), "uncovered frame corners are a warning");
    assert_eq!(html.matches("<img src=\"plots/").count(), 3);
    assert_eq!(html.matches("<img src=\"thumbs/").count(), 13);
    let profile = tempfile::tempdir().unwrap();
    assert_loads_cleanly(&report, profile.path(), 16);
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        let dest = to.join(e.file_name());
        if e.file_type().unwrap().is_dir() {
            copy_dir(&e.path(), &dest);
        } else {
            std::fs::copy(e.path(), dest).unwrap();
        }
    }
}
