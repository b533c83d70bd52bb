//! `cargo bench --bench dot_generalisation [-- OPTIONS]`: how often today's fslcal finds the
//! right laser dot on randomised scenes it was never tuned on (issue 14).
//!
//! Renders sets with `calib_targets::variety` (docs/scene-variety.md) into a temporary
//! folder, runs the release `fslcal` on them as a user would, and tabulates per scene kind
//! and water type: the right dot (within 2 px of the truth), a wrong dot, a missed dot, and
//! "no dot" answered on photos without one (laser off, dot hidden or off the frame).
//!
//! - calibration and slate sets: `fslcal laser --json`, each photo's `dot_px` and `status`
//!   (a wrong dot is either used in the fit or caught as an outlier);
//! - target-less sets (fish, reef): `fslcal check --json --cal CAL` and `fslcal measure
//!   --labels --json` (its `dot_px` per fish). CAL is what `fslcal laser` made of the
//!   unit's companion calibration photos (10 of the board,
//!   `VarietySet::companion_calibration`), as a diver's would be: its fit and the laser
//!   colour it learned; `--true-cal` uses the unit's true calibration instead.
//!
//! Options: `--first-seed S` (default 1000000, the first held-out seed; `--tuning` for 0),
//! `--sets N` or `--sets calibration=N,slate=N,targetless=N` (default 2, 1, 2), `--size WxH`
//! (default 4000x3000; at smaller sizes the board finder loses far boards), `--photos N` per
//! set (default: as the seed draws), `--keep DIR` (render there and keep the photos; sets
//! already there, complete and the same, are reused rather than rendered again), `--csv
//! FILE` (one row per photo and answer). Photos `fslcal laser` takes over a minute on alone
//! (OpenCV's chessboard search can take many minutes on a faint or glaring board) are
//! reported as stalled and left out of their set's run.
//! `cargo test --benches` runs a small smoke run instead.

use calib_targets::variety::{Kind, NoDot, PhotoTruth, SeedSplit, VarietySet, HELD_OUT_FIRST_SEED};
use serde_json::Value;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

/// A dot within this many pixels of the truth is the right one.
const RIGHT_PX: f64 = 2.0;

struct Options {
    first_seed: u64,
    sets: BTreeMap<Kind, usize>,
    width_px: u32,
    photos: Option<usize>,
    keep: Option<PathBuf>,
    csv: Option<PathBuf>,
    /// Target-less sets are checked with the unit's true calibration (the green prior)
    /// instead of one made from its companion calibration photos.
    true_cal: bool,
}

fn parse_options() -> Result<Options, String> {
    let args: Vec<String> = std::env::args().skip(1).filter(|a| a != "--bench").collect();
    let full = std::env::args().any(|a| a == "--bench");
    let mut o = Options {
        first_seed: HELD_OUT_FIRST_SEED,
        sets: [(Kind::Calibration, 2), (Kind::Slate, 1), (Kind::Targetless, 2)].into(),
        width_px: 4000,
        photos: None,
        keep: None,
        csv: None,
        true_cal: false,
    };
    if !full {
        // `cargo test --benches`: one small target-less set, enough to run every step.
        o.sets = [(Kind::Targetless, 1)].into();
        o.width_px = 1000;
        o.photos = Some(4);
    }
    let mut it = args.into_iter();
    while let Some(flag) = it.next() {
        if flag == "--tuning" {
            o.first_seed = 0;
            continue;
        }
        if flag == "--true-cal" {
            o.true_cal = true;
            continue;
        }
        let value = it.next().ok_or_else(|| format!("{flag} needs a value"))?;
        let number = |v: &str| v.parse::<u64>().map_err(|_| format!("{flag}: `{v}` is not a whole number"));
        match flag.as_str() {
            "--first-seed" => o.first_seed = number(&value)?,
            "--sets" => o.sets = parse_sets(&value)?,
            "--size" => {
                let (w, h) = value.split_once('x').ok_or("--size: expected WxH, e.g. 4000x3000")?;
                o.width_px = number(w)? as u32;
                if number(h)? as u32 != o.width_px / 4 * 3 {
                    return Err("--size: photos are 4:3, e.g. 4000x3000 or 2000x1500".into());
                }
            }
            "--photos" => o.photos = Some(number(&value)? as usize),
            "--keep" => o.keep = Some(PathBuf::from(value)),
            "--csv" => o.csv = Some(PathBuf::from(value)),
            _ => return Err(format!("unknown option {flag}")),
        }
    }
    Ok(o)
}

/// `N` for every kind, or `kind=N,...` for some.
fn parse_sets(v: &str) -> Result<BTreeMap<Kind, usize>, String> {
    if let Ok(n) = v.parse::<usize>() {
        return Ok(Kind::ALL.into_iter().map(|k| (k, n)).collect());
    }
    v.split(',')
        .map(|part| {
            let (k, n) = part.split_once('=').ok_or_else(|| format!("--sets: `{part}` is not KIND=N"))?;
            Ok((k.parse::<Kind>()?, n.parse::<usize>().map_err(|_| format!("--sets: `{n}` is not a number"))?))
        })
        .collect()
}

/// What fslcal answered for one photo.
#[derive(Clone, Debug, Default)]
struct Answer {
    dot_px: Option<[f64; 2]>,
    /// `laser`: "used" or "skipped"; `check`: "ok", "flag" or "none".
    status: String,
    reason: Option<String>,
    /// `check`: every candidate it reported, with the scores that judged it.
    candidates: Vec<Scored>,
}

/// One reported candidate's scores (`check --json`'s `candidates`).
#[derive(Clone, Debug, Default)]
struct Scored {
    pixel: [f64; 2],
    /// Sigmas off the laser's colour (`colour_off_sigmas`); `None` under the prior.
    off_colour_sigmas: Option<f64>,
    /// Why it was refused; `None` when it stayed a plausible dot.
    refused: Option<String>,
}

fn scored_from(c: &Value) -> Option<Scored> {
    let p = c["pixel"].as_array()?;
    Some(Scored {
        pixel: [p[0].as_f64()?, p[1].as_f64()?],
        off_colour_sigmas: c["colour_off_sigmas"].as_f64(),
        refused: c["refused"].as_str().map(String::from),
    })
}

/// One photo's truth and answers.
struct Row {
    truth: PhotoTruth,
    file: PathBuf,
    /// `laser` for sets with a target, `check` without.
    answer: Answer,
    /// `measure` (sets without a target).
    measure: Option<Answer>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
enum Verdict {
    Right,
    /// The right dot found but left out of the fit as an outlier.
    RightDropped,
    WrongUsed,
    /// A wrong dot left out of the fit as an outlier (calibration only).
    WrongCaught,
    Missed,
    NoneCorrect,
    /// A dot reported (and used) on a photo without one.
    Phantom,
    /// A dot found on a photo without one, left out of the fit as an outlier.
    PhantomCaught,
    /// fslcal took over a minute on the photo alone and it was left out of the set.
    Stalled,
}

/// The truth's category: a visible dot, a faint one, or none (why).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
enum Truth {
    Visible,
    Faint,
    None(NoDot),
}

fn truth_of(t: &PhotoTruth) -> Truth {
    match (&t.dot, t.visible_dot(), t.no_dot) {
        (Some(_), Some(_), _) => Truth::Visible,
        (Some(_), None, _) => Truth::Faint,
        (None, _, why) => Truth::None(why.unwrap_or(NoDot::NoSurface)),
    }
}

fn verdict(t: &PhotoTruth, a: &Answer, in_fit: bool) -> Verdict {
    let used = !in_fit || a.status == "used";
    if a.status == "stalled" {
        return Verdict::Stalled;
    }
    match (&t.dot, a.dot_px) {
        (None, None) => Verdict::NoneCorrect,
        (Some(_), None) => Verdict::Missed,
        (None, Some(_)) if !used => Verdict::PhantomCaught,
        (None, Some(_)) => Verdict::Phantom,
        (Some(d), Some(p)) => {
            let right = (d.pixel[0] - p[0]).hypot(d.pixel[1] - p[1]) <= RIGHT_PX;
            match (right, used) {
                (true, true) => Verdict::Right,
                (true, false) => Verdict::RightDropped,
                (false, true) => Verdict::WrongUsed,
                (false, false) => Verdict::WrongCaught,
            }
        }
    }
}

fn fslcal() -> Command {
    Command::new(env!("CARGO_BIN_EXE_fslcal"))
}

fn photo_args(photos: &[PathBuf]) -> Vec<String> {
    photos.iter().map(|p| p.display().to_string()).collect()
}

/// Runs `cmd`, killing it after `timeout_s`: `None` when it had to be killed.
fn output_within(mut cmd: Command, timeout_s: f64) -> Option<std::process::Output> {
    use std::process::Stdio;
    let mut child = cmd.stdout(Stdio::piped()).stderr(Stdio::piped()).spawn().expect("start fslcal");
    // Drain the pipes while waiting, or a chatty child blocks on a full pipe.
    let (mut out, mut err) = (child.stdout.take().unwrap(), child.stderr.take().unwrap());
    let reader = std::thread::spawn(move || {
        let mut b = Vec::new();
        std::io::Read::read_to_end(&mut out, &mut b).ok();
        b
    });
    let err_reader = std::thread::spawn(move || {
        let mut b = Vec::new();
        std::io::Read::read_to_end(&mut err, &mut b).ok();
        b
    });
    let start = Instant::now();
    loop {
        if let Some(status) = child.try_wait().expect("wait for fslcal") {
            let (stdout, stderr) = (reader.join().unwrap(), err_reader.join().unwrap());
            return Some(std::process::Output { status, stdout, stderr });
        }
        if start.elapsed().as_secs_f64() > timeout_s {
            let _ = child.kill();
            let _ = child.wait();
            return None;
        }
        std::thread::sleep(std::time::Duration::from_millis(200));
    }
}

/// A photo on which one `fslcal laser` run on it alone takes longer than this is reported
/// as a stall and left out of the set's run.
const STALL_S: f64 = 60.0;

/// `fslcal laser --json` on the set, as a user runs it. Each photo is first tried alone
/// (two at a time) to find the ones fslcal stalls on (OpenCV's chessboard search on a faint
/// or glaring board can take many minutes); those are reported and left out of the run.
/// When the fit is refused (no JSON), each photo's reason is the one its own try gave.
fn run_laser(dir: &Path, target: &str, photos: &[PathBuf]) -> (Vec<Answer>, String) {
    let camera = dir.join("camera.yml").display().to_string();
    let laser = |ps: &[PathBuf], json: bool, t: f64| {
        let mut c = fslcal();
        c.args(["laser", "--camera", &camera, "--target", target]).args(photo_args(ps));
        if json {
            c.arg("--json");
        }
        output_within(c, t)
    };
    let alone: Vec<Option<std::process::Output>> = photos
        .chunks(2)
        .flat_map(|pair| {
            std::thread::scope(|s| {
                let tries: Vec<_> =
                    pair.iter().map(|p| s.spawn(|| laser(std::slice::from_ref(p), false, STALL_S))).collect();
                tries.into_iter().map(|h| h.join().unwrap()).collect::<Vec<_>>()
            })
        })
        .collect();
    let kept: Vec<usize> = (0..photos.len()).filter(|&i| alone[i].is_some()).collect();
    let rest: Vec<PathBuf> = kept.iter().map(|&i| photos[i].clone()).collect();
    let out = laser(&rest, true, f64::INFINITY).expect("no time limit");
    let (fitted, mut outcome) = match serde_json::from_slice::<Value>(&out.stdout) {
        Ok(v) => {
            let accepted = v["accepted"].as_bool() == Some(true);
            let answers: Vec<Answer> =
                v["photos"].as_array().expect("laser --json lists the photos").iter().map(answer_from_laser).collect();
            (Some(answers), if accepted { "accepted" } else { "rejected by a gate" }.to_string())
        }
        Err(_) => (None, format!("refused: {}", String::from_utf8_lossy(&out.stderr).lines().last().unwrap_or(""))),
    };
    let mut fitted = fitted.map(|a| a.into_iter());
    let answers = photos
        .iter()
        .zip(&alone)
        .map(|(p, tried)| match (tried, fitted.as_mut()) {
            (None, _) => Answer {
                dot_px: None,
                status: "stalled".into(),
                reason: Some(format!("fslcal laser stalled (over {STALL_S:.0} s on this photo alone)")),
                candidates: Vec::new(),
            },
            (Some(_), Some(f)) => f.next().expect("one answer per photo"),
            (Some(t), None) => Answer {
                dot_px: None,
                status: "skipped".into(),
                reason: table_reason(&t.stderr, p),
                candidates: Vec::new(),
            },
        })
        .collect();
    let n = alone.iter().filter(|t| t.is_none()).count();
    if n > 0 {
        outcome += &format!("; {n} photo(s) stalled and left out");
    }
    (answers, outcome)
}

/// A photo's reason in the table `fslcal laser` prints to stderr when it refuses a fit.
fn table_reason(stderr: &[u8], photo: &Path) -> Option<String> {
    let name = photo.file_name()?.to_string_lossy().into_owned();
    let table = String::from_utf8_lossy(stderr);
    let line = table.lines().find(|l| l.trim_start().starts_with(&name))?;
    line.split_once("skipped: ").map(|(_, r)| r.trim().to_string())
}

fn answer_from_laser(p: &Value) -> Answer {
    Answer {
        dot_px: p["dot_px"].as_array().map(|a| [a[0].as_f64().unwrap(), a[1].as_f64().unwrap()]),
        status: p["status"].as_str().unwrap_or("").into(),
        reason: p["reason"].as_str().map(String::from),
        candidates: Vec::new(),
    }
}

/// Photos of a target-less set's companion calibration (`VarietySet::companion_calibration`).
const COMPANION_PHOTOS: usize = 10;

/// The unit's calibration as a diver would have it: `fslcal laser --out` on the set's
/// companion calibration photos (in `DIR/calibration`), with the laser colour it learned.
/// Falls back to the unit's true calibration (`cal.json`, the green prior) when the fit is
/// refused, and says so in the outcome.
fn calibrate_unit(set: &VarietySet, dir: &Path) -> (PathBuf, String) {
    let companion = set.companion_calibration(COMPANION_PHOTOS).expect("a valid photo count");
    let cdir = dir.join("calibration");
    let photos = match rendered_before(&cdir, &companion) {
        Some(photos) => photos,
        None => companion.write(&cdir, &mut |_| {}).expect("render the companion calibration"),
    };
    let fitted = cdir.join("fitted.json");
    let _ = std::fs::remove_file(&fitted);
    let camera = cdir.join("camera.yml").display().to_string();
    let out = fslcal()
        .args(["laser", "--camera", &camera, "--target", "checkerboard:14x10@42.17mm", "--json", "--out"])
        .arg(&fitted)
        .args(photo_args(&photos))
        .output()
        .expect("run laser");
    let v: Value = serde_json::from_slice(&out.stdout).unwrap_or(Value::Null);
    let used = v["photos"].as_array().map_or(0, |p| p.iter().filter(|p| p["status"] == "used").count());
    if fitted.is_file() {
        let colour = v["laser_colour"]["dots"]
            .as_u64()
            .map_or("no laser colour".to_string(), |n| format!("colour from {n} dots"));
        (fitted, format!("check with its own calibration ({used} of {} photos, {colour})", photos.len()))
    } else {
        let why = String::from_utf8_lossy(&out.stderr).lines().last().unwrap_or("").to_string();
        (dir.join("cal.json"), format!("companion calibration refused ({why}): check with the true one"))
    }
}

/// `fslcal check --json --cal CAL`: every photo's dot, or none when no photo has one.
fn run_check(cal: &Path, photos: &[PathBuf]) -> Vec<Answer> {
    let cal = cal.display().to_string();
    let out = fslcal().args(["check", "--json", "--cal", &cal]).args(photo_args(photos)).output().expect("run check");
    let Ok(v) = serde_json::from_slice::<Value>(&out.stdout) else {
        let why = String::from_utf8_lossy(&out.stderr).trim().to_string();
        return photos
            .iter()
            .map(|_| Answer { dot_px: None, status: "none".into(), reason: Some(why.clone()), candidates: Vec::new() })
            .collect();
    };
    v["photos"]
        .as_array()
        .expect("check --json lists the photos")
        .iter()
        .map(|p| {
            let dot_px = p["dot_px"].as_array().map(|a| [a[0].as_f64().unwrap(), a[1].as_f64().unwrap()]);
            let status = match (dot_px, p["flag"].as_bool()) {
                (None, _) => "none",
                (Some(_), Some(true)) => "flag",
                _ => "ok",
            };
            let candidates =
                p["candidates"].as_array().map_or_else(Vec::new, |cs| cs.iter().filter_map(scored_from).collect());
            Answer { dot_px, status: status.into(), reason: p["reason"].as_str().map(String::from), candidates }
        })
        .collect()
}

/// `fslcal measure --labels --json`: one labelled fish per photo (the truth's first fish in
/// the frame, or a stand-in across the middle), its `dot_px`.
fn run_measure(dir: &Path, cal: &Path, photos: &[PathBuf], truths: &[PhotoTruth]) -> Vec<Answer> {
    let mut csv = String::from("photo,head_x,head_y,tail_x,tail_y\n");
    for (p, t) in photos.iter().zip(truths) {
        let [w, h] = t.image_size.map(|v| v as f64);
        let (a, b) = t
            .fish
            .iter()
            .find(|f| f.in_frame)
            .map_or(([0.4 * w, 0.5 * h], [0.6 * w, 0.5 * h]), |f| (f.snout_px, f.fork_px));
        csv += &format!("{},{},{},{},{}\n", p.file_name().unwrap().to_string_lossy(), a[0], a[1], b[0], b[1]);
    }
    let labels = dir.join("labels.csv");
    std::fs::write(&labels, csv).expect("write labels");
    let cal = cal.display().to_string();
    let labels = labels.display().to_string();
    let out = fslcal()
        .args(["measure", "--json", "--cal", &cal, "--labels", &labels])
        .args(photo_args(photos))
        .output()
        .expect("run measure");
    let v: Value = serde_json::from_slice(&out.stdout)
        .unwrap_or_else(|_| panic!("measure printed no JSON: {}", String::from_utf8_lossy(&out.stderr)));
    let rows = v["fish"].as_array().expect("measure --json lists the fish");
    photos
        .iter()
        .map(|p| {
            let r = rows.iter().find(|r| r["photo"].as_str() == Some(&p.display().to_string()));
            let dot_px =
                r.and_then(|r| r["dot_px"].as_array()).map(|a| [a[0].as_f64().unwrap(), a[1].as_f64().unwrap()]);
            Answer {
                dot_px,
                status: if dot_px.is_some() { "dot" } else { "none" }.into(),
                reason: None,
                candidates: Vec::new(),
            }
        })
        .collect()
}

fn read_truths(photos: &[PathBuf]) -> Vec<PhotoTruth> {
    photos
        .iter()
        .map(|p| {
            let t = p.with_extension("truth.json");
            serde_json::from_slice(&std::fs::read(&t).expect("truth written")).expect("truth parses")
        })
        .collect()
}

/// The set's photos when `--keep DIR` already holds it, complete and the same.
fn rendered_before(dir: &Path, set: &VarietySet) -> Option<Vec<PathBuf>> {
    let written: Value = serde_json::from_slice(&std::fs::read(dir.join("set.json")).ok()?).ok()?;
    let photos: Vec<PathBuf> = (0..set.len()).map(|i| dir.join(format!("photo_{i:02}.jpg"))).collect();
    let complete = photos.iter().all(|p| p.is_file() && p.with_extension("truth.json").is_file());
    (written == set.summary() && complete).then_some(photos)
}

/// Renders one set (or reuses it from `--keep DIR`) and runs fslcal on it.
fn evaluate_set(kind: Kind, seed: u64, o: &Options, root: &Path, timing: &mut [f64; 2]) -> (Vec<Row>, String) {
    let dir = root.join(format!("{}-{seed}-{}", kind.name(), o.width_px));
    let set = VarietySet::plan(kind, seed, o.photos, o.width_px).expect("valid options");
    let t = Instant::now();
    let photos = match rendered_before(&dir, &set) {
        Some(photos) => photos,
        None => set.write(&dir, &mut |_| {}).expect("render the set"),
    };
    timing[0] += t.elapsed().as_secs_f64();
    let truths = read_truths(&photos);
    let t = Instant::now();
    let (answers, measures, outcome) = match kind {
        Kind::Calibration => {
            let (a, v) = run_laser(&dir, "checkerboard:14x10@42.17mm", &photos);
            (a, None, v)
        }
        Kind::Slate => {
            let target = format!("slate:{}", dir.join("slate.toml").display());
            let (a, v) = run_laser(&dir, &target, &photos);
            (a, None, v)
        }
        Kind::Targetless => {
            let (cal, outcome) =
                if o.true_cal { (dir.join("cal.json"), String::new()) } else { calibrate_unit(&set, &dir) };
            (run_check(&cal, &photos), Some(run_measure(&dir, &cal, &photos, &truths)), outcome)
        }
    };
    timing[1] += t.elapsed().as_secs_f64();
    let mut measures = measures.map(|m| m.into_iter());
    let rows = photos
        .into_iter()
        .zip(truths)
        .zip(answers)
        .map(|((file, truth), answer)| Row { truth, file, answer, measure: measures.as_mut().and_then(|m| m.next()) })
        .collect();
    (rows, outcome)
}

/// Counts for one row of a table.
#[derive(Default)]
struct Tally {
    photos: usize,
    visible: BTreeMap<Verdict, usize>,
    faint: BTreeMap<Verdict, usize>,
    none: BTreeMap<Verdict, usize>,
    laser_off: (usize, usize),
}

impl Tally {
    fn add(&mut self, t: &PhotoTruth, a: &Answer, in_fit: bool) {
        self.photos += 1;
        let v = verdict(t, a, in_fit);
        let bucket = match truth_of(t) {
            Truth::Visible => &mut self.visible,
            Truth::Faint => &mut self.faint,
            Truth::None(_) => &mut self.none,
        };
        *bucket.entry(v).or_default() += 1;
        if t.no_dot == Some(NoDot::LaserOff) {
            self.laser_off.0 += 1;
            self.laser_off.1 += matches!(v, Verdict::NoneCorrect | Verdict::PhantomCaught) as usize;
        }
    }
}

fn pct(n: usize, of: usize) -> String {
    if of == 0 {
        "-".into()
    } else {
        format!("{n} ({:.0}%)", 100.0 * n as f64 / of as f64)
    }
}

/// One table: per kind and water, what fslcal answered. `answer` gives a row's answer and
/// whether it comes from a fit (where a dot can be left out as an outlier).
fn print_table(title: &str, rows: &[Row], answer: &dyn Fn(&Row) -> Option<(Answer, bool)>) {
    let mut groups: BTreeMap<(String, String), Tally> = BTreeMap::new();
    for r in rows {
        let Some((a, in_fit)) = answer(r) else { continue };
        let kind = r.truth.kind.name().to_string();
        for water in [r.truth.water.kind.name().to_string(), "all".to_string()] {
            groups.entry((kind.clone(), water)).or_default().add(&r.truth, &a, in_fit);
        }
    }
    println!("\n{title}");
    println!("| kind | water | photos | dot visible | right | wrong used | wrong caught | missed or dropped | stalled | faint dots found | no dot | answered none | wrong dot used | laser off: none |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    for ((kind, water), t) in &groups {
        let g = |m: &BTreeMap<Verdict, usize>, v: Verdict| m.get(&v).copied().unwrap_or(0);
        let n = t.visible.values().sum::<usize>();
        let missed = g(&t.visible, Verdict::Missed) + g(&t.visible, Verdict::RightDropped);
        let faint_n = t.faint.values().sum::<usize>();
        let faint_found = g(&t.faint, Verdict::Right) + g(&t.faint, Verdict::RightDropped);
        let none_n = t.none.values().sum::<usize>();
        println!(
            "| {kind} | {water} | {} | {n} | {} | {} | {} | {} | {} | {faint_found} of {faint_n} | {none_n} | {} | {} | {} |",
            t.photos,
            pct(g(&t.visible, Verdict::Right), n),
            pct(g(&t.visible, Verdict::WrongUsed), n),
            pct(g(&t.visible, Verdict::WrongCaught), n),
            pct(missed, n),
            [&t.visible, &t.faint, &t.none].iter().map(|m| g(m, Verdict::Stalled)).sum::<usize>(),
            pct(g(&t.none, Verdict::NoneCorrect) + g(&t.none, Verdict::PhantomCaught), none_n),
            pct(g(&t.none, Verdict::Phantom), none_n),
            pct(t.laser_off.1, t.laser_off.0),
        );
    }
}

/// What lies at image point `p` by the truth: the laser's dot (within [`RIGHT_PX`], or
/// inside the dot off its centre), the nearest impostor within its radius + 3 px, or the
/// scene (texture, edge, corner).
fn what_is(t: &PhotoTruth, p: [f64; 2]) -> String {
    if let Some(d) = &t.dot {
        let off = (d.pixel[0] - p[0]).hypot(d.pixel[1] - p[1]);
        if off <= RIGHT_PX {
            return "laser dot".into();
        }
        if off <= d.radius_px.max(RIGHT_PX) {
            return "laser dot, off its centre".into();
        }
    }
    t.impostors
        .iter()
        .map(|i| ((i.pixel[0] - p[0]).hypot(i.pixel[1] - p[1]), i))
        .filter(|(d, i)| *d <= i.radius_px + 3.0)
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .map_or_else(|| "scene (texture, edge, corner)".to_string(), |(_, i)| format!("{:?}", i.kind))
}

/// What the wrong dots were ([`what_is`]), laser and check answers.
fn print_wrong_dots(rows: &[Row]) {
    let mut by: BTreeMap<(String, String), usize> = BTreeMap::new();
    for r in rows {
        let Some(p) = r.answer.dot_px else { continue };
        if matches!(verdict(&r.truth, &r.answer, false), Verdict::Right) {
            continue;
        }
        *by.entry((r.truth.kind.name().into(), what_is(&r.truth, p))).or_default() += 1;
    }
    println!("\nwrong dots by what they were (nearest impostor), laser and check answers");
    println!("| kind | taken for the dot | photos |");
    println!("|---|---|---|");
    for ((kind, what), n) in by {
        println!("| {kind} | {what} | {n} |");
    }
}

/// Upper edges of the off-colour histogram's bins, sigmas; the gate is at 3.
const OFF_COLOUR_BINS: [f64; 7] = [1.0, 2.0, 3.0, 5.0, 10.0, 30.0, f64::INFINITY];

/// How the colour model's score separates the laser's dots from each impostor kind: every
/// candidate `check` reported, by what the truth says it is, as a histogram of its sigmas
/// off the laser's learned colour, and what became of it (refused and why, or plausible).
fn print_score_histograms(rows: &[Row]) {
    #[derive(Default)]
    struct Bins {
        off: [usize; OFF_COLOUR_BINS.len()],
        prior: usize,
        outcome: BTreeMap<String, usize>,
    }
    let mut by: BTreeMap<String, Bins> = BTreeMap::new();
    for r in rows {
        for c in &r.answer.candidates {
            let b = by.entry(what_is(&r.truth, c.pixel)).or_default();
            match c.off_colour_sigmas {
                Some(z) => b.off[OFF_COLOUR_BINS.iter().position(|&e| z < e).unwrap_or(OFF_COLOUR_BINS.len() - 1)] += 1,
                None => b.prior += 1,
            }
            *b.outcome.entry(c.refused.clone().unwrap_or_else(|| "plausible".into())).or_default() += 1;
        }
    }
    if by.is_empty() {
        return;
    }
    println!("\ncheck's candidates by what they are: sigmas off the learned laser colour (gate 3), and their outcome");
    println!("| what | candidates | <1 | 1-2 | 2-3 | 3-5 | 5-10 | 10-30 | >=30 | prior colour | outcome |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|");
    for (what, b) in &by {
        let n = b.off.iter().sum::<usize>() + b.prior;
        let bins: Vec<String> = b.off.iter().map(|k| k.to_string()).collect();
        let outcome: Vec<String> = b.outcome.iter().map(|(k, v)| format!("{k} {v}")).collect();
        println!("| {what} | {n} | {} | {} | {} |", bins.join(" | "), b.prior, outcome.join(", "));
    }
}

/// Why a photo with a visible dot got none: fslcal's reason, in a few words.
fn miss_category(a: &Answer) -> String {
    let r = a.reason.as_deref().unwrap_or("");
    let known = [
        ("checkerboard found", "no board found"),
        ("no slate found", "no slate found"),
        ("no laser dot found on the target", "no dot found on the target"),
        ("the fit was refused", "candidates found, fit refused"),
        ("no usable dot", "candidates off the fitted line"),
        ("stalled", "fslcal stalled on the photo"),
        ("no laser dot on the calibrated laser's image", "no dot on the calibrated line"),
        ("like it refused for", "ambiguous: beside look-alikes refused"),
        ("none clearly the dot", "ambiguous: several dot-like blobs"),
        ("not clearly the dot", "ambiguous: one blob, not clearly the dot"),
    ];
    known.iter().find(|(k, _)| r.contains(k)).map_or_else(|| format!("other: {r}"), |(_, v)| v.to_string())
}

fn print_missed(rows: &[Row]) {
    let mut by: BTreeMap<(String, String), usize> = BTreeMap::new();
    for r in rows {
        if truth_of(&r.truth) == Truth::Visible && r.answer.dot_px.is_none() {
            *by.entry((r.truth.kind.name().into(), miss_category(&r.answer))).or_default() += 1;
        }
    }
    println!("\nwhy visible dots were missed (laser and check answers)");
    println!("| kind | reason | photos |");
    println!("|---|---|---|");
    for ((kind, why), n) in by {
        println!("| {kind} | {why} | {n} |");
    }
}

fn write_csv(path: &Path, rows: &[Row]) {
    let mut s = String::from("file,kind,water,truth,truth_x,truth_y,peak_levels,answer_x,answer_y,status,reason,verdict,measure_x,measure_y\n");
    let xy = |p: Option<[f64; 2]>| p.map_or(",".to_string(), |p| format!("{:.2},{:.2}", p[0], p[1]));
    for r in rows {
        let t = &r.truth;
        let in_fit = t.kind != Kind::Targetless;
        s += &format!(
            "{},{},{},{:?},{},{:.1},{},{},\"{}\",{:?},{}\n",
            r.file.display(),
            t.kind.name(),
            t.water.kind.name(),
            truth_of(t),
            xy(t.dot.as_ref().map(|d| d.pixel)),
            t.dot.as_ref().map_or(0.0, |d| d.peak_levels),
            xy(r.answer.dot_px),
            r.answer.status,
            r.answer.reason.clone().unwrap_or_default().replace('"', "'"),
            verdict(t, &r.answer, in_fit),
            xy(r.measure.as_ref().and_then(|m| m.dot_px)),
        );
    }
    std::fs::write(path, s).expect("write the CSV");
}

fn main() {
    let o = match parse_options() {
        Ok(o) => o,
        Err(e) => {
            eprintln!("dot_generalisation: {e}");
            std::process::exit(2);
        }
    };
    let temp = tempfile::tempdir().expect("temp dir");
    let root = o.keep.clone().unwrap_or_else(|| temp.path().to_path_buf());
    let split = SeedSplit::of(o.first_seed);
    println!(
        "dot generalisation: {:?} seeds from {}, photos {}x{}, fslcal {}",
        split,
        o.first_seed,
        o.width_px,
        o.width_px / 4 * 3,
        env!("CARGO_BIN_EXE_fslcal")
    );
    let mut rows = Vec::new();
    let mut timing = [0.0; 2];
    for (&kind, &sets) in &o.sets {
        for k in 0..sets {
            let seed = o.first_seed + k as u64;
            let (r, outcome) = evaluate_set(kind, seed, &o, &root, &mut timing);
            let right = r.iter().filter(|r| verdict(&r.truth, &r.answer, kind != Kind::Targetless) == Verdict::Right);
            eprintln!("{} seed {seed}: {} photos, {} right {outcome}", kind.name(), r.len(), right.count());
            if !outcome.is_empty() {
                println!("{} set {seed}: fit {outcome}", kind.name());
            }
            rows.extend(r);
        }
    }
    print_table("fslcal laser (sets with a target) and fslcal check (without)", &rows, &|r| {
        Some((r.answer.clone(), r.truth.kind != Kind::Targetless))
    });
    let measured: Vec<&Row> = rows.iter().filter(|r| r.measure.is_some()).collect();
    if !measured.is_empty() {
        let agree = measured.iter().filter(|r| r.measure.as_ref().unwrap().dot_px == r.answer.dot_px).count();
        print_table("fslcal measure (sets without a target)", &rows, &|r| r.measure.clone().map(|m| (m, false)));
        println!("measure and check report the same dot (or none) on {agree} of {} photos", measured.len());
    }
    print_missed(&rows);
    print_wrong_dots(&rows);
    print_score_histograms(&rows);
    println!(
        "\n{} photos; rendering {:.0} s, fslcal {:.0} s ({:.2} s per photo)",
        rows.len(),
        timing[0],
        timing[1],
        timing[1] / rows.len().max(1) as f64
    );
    if let Some(csv) = &o.csv {
        write_csv(csv, &rows);
        println!("per-photo rows: {}", csv.display());
    }
}
