//! `cargo bench --bench speed`: every speed figure of issue 17 in one run, each read against
//! the floor, a bare JPEG decode of the same photos.
//!
//! Prints, on the 16-photo laser bench set (4000x3000 JPEGs, 0.6-4.5 m, clear water):
//! - the decode floor: OpenCV's `imdecode` of the 16 photos, one thread in turn and all
//!   threads at once;
//! - `fslcal laser` beside `benches/laser_opencv.py` (plain single-threaded OpenCV-Python,
//!   true dots given), paired round by round, as a ratio (target at most 0.5);
//! - `fslcal laser --report`: what the report adds (target at most 10%) and peak memory;
//! - photos per second for `check` (target within 0.6x of the one-thread decode),
//!   `validate`, `measure --masks` (target at least 15 photos/s) and `develop`;
//! - the slowest single photo on one thread, the 16, a photo without a board, and small
//!   low-contrast boards in green and brown water (target under 2 s each);
//! - with `--bench`, peak memory of `fslcal laser --report` over 300 photos.
//!
//! Every command runs as a user runs it (a child process, from the files on disk); wall
//! time, CPU time (user + sys) and peak resident memory are printed, since the machine may
//! be shared: read the CPU figures when the load is high. With `FSLCAL_BENCH_BASELINE` set
//! to another `fslcal` binary (e.g. one built from an older commit), every command line is
//! run with both, round by round, and printed side by side.
//!
//! The OpenCV-Python line needs Python 3 with OpenCV and NumPy:
//!   python3 -m venv ~/.venv-fslcal-bench
//!   ~/.venv-fslcal-bench/bin/pip install opencv-python-headless numpy
//!   FSLCAL_BENCH_PYTHON=~/.venv-fslcal-bench/bin/python cargo bench --bench speed
//! Without it that line is skipped with a note. Asserts nothing about time.

#[path = "../tests/common/mod.rs"]
mod common;

use calib_targets::orf::{tg6_orf, OrfMeta};
use calib_targets::scene::{laser_scene_set, render, SceneTruth, Water};
use calib_targets::Checkerboard;
use common::tinted::{board_13x9, small_board_set, SmallBoard, Tint};
use common::SceneSet;
use opencv::core::Vector;
use opencv::prelude::*;
use rayon::prelude::*;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// One run of a command: wall seconds, CPU seconds (user + sys), peak resident MB.
#[derive(Clone, Copy, Debug)]
struct Run {
    wall_s: f64,
    cpu_s: f64,
    peak_mb: f64,
}

/// Medians over rounds (peak: the largest).
fn summarise(runs: &[Run]) -> Run {
    let med = |f: fn(&Run) -> f64| {
        let mut v: Vec<f64> = runs.iter().map(f).collect();
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    Run {
        wall_s: med(|r| r.wall_s),
        cpu_s: med(|r| r.cpu_s),
        peak_mb: runs.iter().map(|r| r.peak_mb).fold(0.0, f64::max),
    }
}

fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .map_or("?".into(), |s| s.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
}

/// CPU seconds of this process's waited-for children (`cutime + cstime`).
fn children_cpu_s() -> f64 {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let after = stat.rsplit_once(')').map_or("", |(_, r)| r);
    let f: Vec<f64> = after.split_whitespace().filter_map(|v| v.parse().ok()).collect();
    // Fields after the name: state (not a number, skipped), ppid, ... cutime is field 16.
    match (f.get(12), f.get(13)) {
        (Some(u), Some(s)) => (u + s) / 100.0,
        _ => f64::NAN,
    }
}

fn vm_hwm_mb(pid: u32) -> Option<f64> {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).ok()?;
    let kb: f64 =
        status.lines().find_map(|l| l.strip_prefix("VmHWM:"))?.trim().trim_end_matches("kB").trim().parse().ok()?;
    Some(kb / 1024.0)
}

/// Runs `program args`, returning its figures and its standard output; panics on failure
/// unless `may_fail`.
fn run(program: &Path, args: &[String], env: &[(&str, &str)], may_fail: bool) -> (Run, Vec<u8>) {
    let cpu0 = children_cpu_s();
    let t = Instant::now();
    let mut child = Command::new(program)
        .args(args)
        .envs(env.iter().copied())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap_or_else(|e| panic!("{}: {e}", program.display()));
    let pid = child.id();
    let mut out = Vec::new();
    let mut err = Vec::new();
    let mut stdout = child.stdout.take().unwrap();
    let mut stderr = child.stderr.take().unwrap();
    let reader = std::thread::spawn(move || {
        let mut e = Vec::new();
        let _ = stderr.read_to_end(&mut e);
        e
    });
    let peak = std::thread::spawn(move || {
        let mut peak = 0.0f64;
        while let Some(mb) = vm_hwm_mb(pid) {
            peak = peak.max(mb);
            std::thread::sleep(Duration::from_millis(3));
        }
        peak
    });
    let _ = stdout.read_to_end(&mut out);
    err.extend(reader.join().unwrap());
    let status = child.wait().unwrap();
    let wall_s = t.elapsed().as_secs_f64();
    let cpu_s = children_cpu_s() - cpu0;
    let peak_mb = peak.join().unwrap();
    assert!(
        may_fail || status.success(),
        "{} {}: {}",
        program.display(),
        args.join(" "),
        String::from_utf8_lossy(&err)
    );
    (Run { wall_s, cpu_s, peak_mb }, out)
}

/// The binaries compared: this build, and a baseline when `FSLCAL_BENCH_BASELINE` names one.
struct Binaries {
    after: PathBuf,
    before: Option<PathBuf>,
}

impl Binaries {
    fn from_env() -> Binaries {
        let before = std::env::var_os("FSLCAL_BENCH_BASELINE").map(PathBuf::from);
        if let Some(b) = &before {
            assert!(b.is_file(), "FSLCAL_BENCH_BASELINE={}: no such binary", b.display());
        }
        Binaries { after: PathBuf::from(env!("CARGO_BIN_EXE_fslcal")), before }
    }

    /// Runs `args` `rounds` times with each binary, alternating, and summarises each.
    fn time(&self, args: &[String], rounds: usize) -> (Option<Run>, Run) {
        let (mut before, mut after) = (Vec::new(), Vec::new());
        for _ in 0..rounds {
            if let Some(b) = &self.before {
                before.push(run(b, args, &[], false).0);
            }
            after.push(run(&self.after, args, &[], false).0);
        }
        ((!before.is_empty()).then(|| summarise(&before)), summarise(&after))
    }
}

fn fmt(r: &Run) -> String {
    format!("{:.2} s wall, {:.2} s CPU, peak {:.0} MB", r.wall_s, r.cpu_s, r.peak_mb)
}

/// "before X | after Y" or just "Y".
fn pair(before: &Option<Run>, after: &Run, show: impl Fn(&Run) -> String) -> String {
    match before {
        Some(b) => format!("before {} | after {}", show(b), show(after)),
        None => show(after),
    }
}

fn strings<S: AsRef<std::ffi::OsStr>>(v: impl IntoIterator<Item = S>) -> Vec<String> {
    v.into_iter().map(|s| s.as_ref().to_string_lossy().into_owned()).collect()
}

/// Renders `specs` into `name`, or reuses a previous bench run's photos of the same specs.
fn cached_set(name: &str, specs: &[calib_targets::scene::SceneSpec]) -> SceneSet {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(name);
    let key = format!("{specs:?}");
    let marker = dir.join("specs.txt");
    if std::fs::read_to_string(&marker).ok().as_deref() == Some(key.as_str()) {
        let photos: Vec<PathBuf> = (0..specs.len()).map(|i| dir.join(format!("photo_{i:02}.jpg"))).collect();
        let truths: Option<Vec<SceneTruth>> = (0..specs.len())
            .map(|i| {
                let text = std::fs::read_to_string(dir.join(format!("photo_{i:02}.truth.json"))).ok()?;
                serde_json::from_str(&text).ok()
            })
            .collect();
        if let Some(truths) = truths {
            return SceneSet { camera_file: dir.join("camera.yml"), dir, photos, truths };
        }
    }
    let set = common::render_set(name, specs);
    std::fs::write(&marker, key).unwrap();
    set
}

fn write_dots(set: &SceneSet) -> PathBuf {
    let mut csv = String::from("file,x,y\n");
    for (p, t) in set.photos.iter().zip(&set.truths) {
        if let Some(d) = &t.dot {
            csv += &format!("{},{},{}\n", p.file_name().unwrap().to_string_lossy(), d.pixel[0], d.pixel[1]);
        }
    }
    let path = set.dir.join("dots.csv");
    std::fs::write(&path, csv).unwrap();
    path
}

/// Seconds to read and decode every photo with OpenCV (colour, full size): on one thread
/// in turn, and on all threads at once.
fn decode_floor(photos: &[PathBuf]) -> (f64, f64) {
    let _ = opencv::core::set_num_threads(1);
    let decode = |p: &PathBuf| {
        let bytes = Vector::<u8>::from_slice(&std::fs::read(p).unwrap());
        let m = opencv::imgcodecs::imdecode(&bytes, opencv::imgcodecs::IMREAD_COLOR).unwrap();
        assert!(m.cols() > 0);
    };
    photos.iter().for_each(decode); // warm the page cache
    let best = |f: &dyn Fn()| {
        (0..3)
            .map(|_| {
                let t = Instant::now();
                f();
                t.elapsed().as_secs_f64()
            })
            .fold(f64::INFINITY, f64::min)
    };
    let serial = best(&|| photos.iter().for_each(decode));
    let parallel = best(&|| photos.par_iter().for_each(decode));
    (serial, parallel)
}

/// The Python interpreter with OpenCV and NumPy, or why there is none.
fn python() -> Result<PathBuf, String> {
    let py = std::env::var_os("FSLCAL_BENCH_PYTHON").map_or_else(|| PathBuf::from("python3"), PathBuf::from);
    match Command::new(&py).args(["-c", "import cv2, numpy"]).output() {
        Ok(o) if o.status.success() => Ok(py),
        _ => Err(format!(
            "{} cannot import cv2 and numpy; to include this line: python3 -m venv ~/.venv-fslcal-bench && ~/.venv-fslcal-bench/bin/pip install opencv-python-headless numpy, then run with FSLCAL_BENCH_PYTHON=~/.venv-fslcal-bench/bin/python",
            py.display()
        )),
    }
}

struct Bench {
    bins: Binaries,
    rounds: usize,
    full: bool,
    set: SceneSet,
    board: Checkerboard,
    dots: PathBuf,
    out: PathBuf,
}

impl Bench {
    fn laser_args(&self, photos: &[PathBuf], extra: &[String]) -> Vec<String> {
        let mut args = strings(["laser", "--json", "--camera"]);
        args.push(self.set.camera_file.display().to_string());
        args.push("--target".into());
        args.push(self.board.to_string());
        args.extend(extra.iter().cloned());
        args.extend(strings(photos));
        args
    }

    /// `fslcal laser` beside the OpenCV-Python script, round by round.
    fn laser_vs_python(&self, floor_serial_s: f64) -> Run {
        let args = self.laser_args(&self.set.photos, &[]);
        let py = python();
        let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("benches/laser_opencv.py");
        let mut py_args = strings(["--camera".as_ref(), self.set.camera_file.as_os_str()]);
        py_args.extend(strings([
            "--board".to_string(),
            format!("{}x{}@{}", self.board.inner_cols, self.board.inner_rows, self.board.square_m * 1e3),
        ]));
        py_args.extend(strings(["--dots".as_ref(), self.dots.as_os_str()]));
        py_args.extend(strings(&self.set.photos));
        let (mut before, mut after, mut script_runs) = (Vec::new(), Vec::new(), Vec::new());
        let mut script_note = String::new();
        for _ in 0..self.rounds {
            if let Some(b) = &self.bins.before {
                before.push(run(b, &args, &[], false).0);
            }
            after.push(run(&self.bins.after, &args, &[], false).0);
            if let Ok(py) = &py {
                let mut a = vec![script.display().to_string()];
                a.extend(py_args.iter().cloned());
                let (r, out) = run(py, &a, &[("OMP_NUM_THREADS", "1")], false);
                let v: serde_json::Value = serde_json::from_slice(&out).unwrap_or_default();
                script_note = format!(
                    "OpenCV {} , {} of {} photos used, {:.2} s of it decoding",
                    v["opencv"].as_str().unwrap_or("?"),
                    v["used"],
                    v["photos"],
                    v["decode_seconds"].as_f64().unwrap_or(f64::NAN)
                );
                script_runs.push(r);
            }
        }
        let before = (!before.is_empty()).then(|| summarise(&before));
        let after = summarise(&after);
        let n = self.set.photos.len();
        println!("laser, {n} photos: {}", pair(&before, &after, fmt));
        match py {
            Ok(_) => {
                let s = summarise(&script_runs);
                println!("  OpenCV-Python script (1 thread, true dots given): {} ({script_note})", fmt(&s));
                let ratio = |r: &Run| format!("{:.2}x wall, {:.2}x CPU", r.wall_s / s.wall_s, r.cpu_s / s.cpu_s);
                println!("  fslcal / script: {}  (target at most 0.5x wall)", pair(&before, &after, ratio));
            }
            Err(why) => println!("  OpenCV-Python script: skipped: {why}"),
        }
        let floor = |r: &Run| format!("{:.2}x", r.wall_s / floor_serial_s);
        println!("  laser / one-thread decode floor: {}", pair(&before, &after, floor));
        after
    }

    /// `laser --report` against `laser` alone, and the report's peak memory.
    fn report_overhead(&self, plain: &Run) {
        let dir = self.out.join("report");
        let args = self.laser_args(&self.set.photos, &strings(["--report".as_ref(), dir.as_os_str()]));
        let (before, after) = self.bins.time(&args, self.rounds);
        let plain_args = self.laser_args(&self.set.photos, &[]);
        // The plain run again, paired with the report runs, for an honest ratio.
        let (plain_before, plain_after) = self.bins.time(&plain_args, self.rounds);
        let _ = plain;
        let over = |r: &Run, p: &Run| {
            format!("{:+.0}% wall, {:+.0}% CPU", 100.0 * (r.wall_s / p.wall_s - 1.0), 100.0 * (r.cpu_s / p.cpu_s - 1.0))
        };
        println!("laser --report, {} photos: {}", self.set.photos.len(), pair(&before, &after, fmt));
        let b = before.zip(plain_before).map(|(r, p)| over(&r, &p));
        let a = over(&after, &plain_after);
        match b {
            Some(b) => println!("  the report adds: before {b} | after {a}  (target at most +10%)"),
            None => println!("  the report adds: {a}  (target at most +10%)"),
        }
    }

    /// A calibration of the set (the laser's JSON) for check and validate.
    fn calibration(&self) -> PathBuf {
        let cal = self.out.join("cal.json");
        let mut args = self.laser_args(&self.set.photos, &strings(["--out".as_ref(), cal.as_os_str()]));
        args.retain(|a| a != "--json");
        run(&self.bins.after, &args, &[], false);
        cal
    }

    fn per_second(&self, what: &str, args: &[String], count: usize, floor_serial_s: Option<f64>, target: &str) {
        let (before, after) = self.bins.time(args, self.rounds);
        let rate = |r: &Run| {
            let mut s = format!("{:.1} photos/s ({})", count as f64 / r.wall_s, fmt(r));
            if let Some(f) = floor_serial_s {
                s += &format!(", {:.2}x the one-thread decode", r.wall_s / f);
            }
            s
        };
        println!("{what}, {count} photos: {}  {target}", pair(&before, &after, rate));
    }

    /// The slowest photo on one thread, each photo alone through `fslcal laser` (which
    /// then refuses to fit one photo: the time is the photo's).
    fn slowest_photo(&self, label: &str, camera: &Path, board: &Checkerboard, photos: &[PathBuf]) {
        let env = [("RAYON_NUM_THREADS", "1")];
        let time_one = |bin: &Path, p: &PathBuf| {
            let mut args = strings(["laser", "--json", "--camera"]);
            args.push(camera.display().to_string());
            args.push("--target".into());
            args.push(board.to_string());
            args.push(p.display().to_string());
            run(bin, &args, &env, true).0
        };
        let worst = |bin: &Path| {
            photos
                .iter()
                .map(|p| (time_one(bin, p), p.file_name().unwrap().to_string_lossy().into_owned()))
                .max_by(|a, b| a.0.cpu_s.total_cmp(&b.0.cpu_s))
                .unwrap()
        };
        let show = |(r, name): &(Run, String)| format!("{name} {:.2} s wall, {:.2} s CPU", r.wall_s, r.cpu_s);
        let after = worst(&self.bins.after);
        match &self.bins.before {
            Some(b) => println!("  slowest {label}: before {} | after {}", show(&worst(b)), show(&after)),
            None => println!("  slowest {label}: {}", show(&after)),
        }
    }
}

fn main() {
    // `cargo test --benches` runs this too; keep that quick.
    let full = std::env::args().any(|a| a == "--bench");
    let rounds = if full { 3 } else { 1 };
    let threads = rayon::current_num_threads();
    println!("speed bench: {threads} threads, load average at start {}", load_average());
    eprintln!("rendering scenes (not timed; reused by later runs)...");
    let set = cached_set("bench-speed-laser", &laser_scene_set(16, 11, Water::Clear, 0));
    let out = set.dir.join("out");
    let _ = std::fs::remove_dir_all(&out);
    std::fs::create_dir_all(&out).unwrap();
    let dots = write_dots(&set);
    let bench = Bench { bins: Binaries::from_env(), rounds, full, board: Checkerboard::fishsense(), dots, out, set };

    let (serial, parallel) = decode_floor(&bench.set.photos);
    let n = bench.set.photos.len();
    println!(
        "decode floor, {n} photos 4000x3000 (OpenCV imdecode, colour): one thread {serial:.2} s ({:.0} ms/photo, {:.1} photos/s), {threads} threads {parallel:.2} s ({:.1} photos/s)",
        1e3 * serial / n as f64,
        n as f64 / serial,
        n as f64 / parallel
    );
    let plain = bench.laser_vs_python(serial);
    bench.report_overhead(&plain);
    let cal = bench.calibration();
    let mut check = strings(["check", "--json", "--cal"]);
    check.push(cal.display().to_string());
    check.extend(strings(&bench.set.photos));
    bench.per_second("check", &check, n, Some(serial), "(target within 0.6x of the one-thread decode)");
    let mut validate = strings(["validate", "--json", "--cal"]);
    validate.push(cal.display().to_string());
    validate.extend(["--target".into(), bench.board.to_string()]);
    validate.extend(strings(&bench.set.photos));
    bench.per_second("validate", &validate, n, Some(serial), "");
    measure(&bench);
    develop(&bench);
    slowest(&bench);
    if bench.full {
        memory_300(&bench);
    }
    println!("load average at end {}", load_average());
}

/// `measure --masks` over a dive of rendered fish (each photo copied several times, each copy
/// distinct, its mask linked).
fn measure(bench: &Bench) {
    let copies = if bench.full { 25 } else { 2 };
    let set = common::fish_set("bench-speed-measure", 4, 5);
    let dive = set.dir.join("dive");
    let _ = std::fs::remove_dir_all(&dive);
    std::fs::create_dir_all(dive.join("masks")).unwrap();
    let mut photos = Vec::new();
    let mut dots = String::from("file,x,y\n");
    for c in 0..copies {
        for (i, (p, t)) in set.photos.iter().zip(&set.truths).enumerate() {
            let name = format!("dive_{c:03}_{i}");
            let photo = dive.join(format!("{name}.jpg"));
            common::distinct_copy(p, &photo, c);
            common::link(
                &set.dir.join("masks").join(p.file_stem().unwrap()).with_extension("png"),
                &dive.join("masks").join(format!("{name}.png")),
            );
            let d = t.dot.as_ref().unwrap().pixel;
            dots += &format!("{name}.jpg,{},{}\n", d[0], d[1]);
            photos.push(photo);
        }
    }
    std::fs::write(dive.join("dots.csv"), dots).unwrap();
    let mut args = strings(["measure", "--json", "--cal"]);
    args.push(set.cal.display().to_string());
    args.extend(strings(["--masks".as_ref(), dive.join("masks").as_os_str()]));
    let mut with_dots = args.clone();
    with_dots.extend(strings(["--dots".as_ref(), dive.join("dots.csv").as_os_str()]));
    with_dots.extend(strings(&photos));
    bench.per_second("measure --masks --dots", &with_dots, photos.len(), None, "(target at least 15 photos/s)");
    args.extend(strings(&photos));
    bench.per_second("measure --masks (dot searched)", &args, photos.len(), None, "(target at least 15 photos/s)");
}

/// `fslcal develop` on TG-6 raws.
fn develop(bench: &Bench) {
    let count = if bench.full { 8 } else { 2 };
    let dir = bench.out.join("raws");
    std::fs::create_dir_all(&dir).unwrap();
    let orf = tg6_orf(&render(&laser_scene_set(1, 7, Water::Clear, 1)[0]).image, &OrfMeta::default());
    let raws: Vec<PathBuf> = (0..count)
        .map(|i| {
            let p = dir.join(format!("P{i:07}.ORF"));
            std::fs::write(&p, &orf).unwrap();
            p
        })
        .collect();
    let mut args = strings(["develop", "--json", "--out"]);
    args.push(bench.out.join("png").display().to_string());
    args.extend(strings(&raws));
    bench.per_second("develop (TG-6 ORF to PNG)", &args, count, None, "");
    for r in raws {
        let _ = std::fs::remove_file(r);
    }
}

/// The slowest photo on one thread: the bench set, a photo without a board, and small,
/// low-contrast boards in green and brown water.
fn slowest(bench: &Bench) {
    println!("one photo on one thread (target under 2 s each):");
    bench.slowest_photo("of the 16", &bench.set.camera_file, &bench.board, &bench.set.photos);
    let board = board_13x9();
    let scenes: Vec<SmallBoard> =
        [(Tint::Green, 3.0, 0.35), (Tint::Green, 4.0, 0.3), (Tint::Brown, 3.0, 0.35), (Tint::Brown, 4.0, 0.3)]
            .iter()
            .enumerate()
            .map(|(i, &(tint, depth_m, transmission))| SmallBoard {
                board: Some(board),
                depth_m,
                yaw_rad: 0.3,
                at: (0.35 - 0.2 * i as f64, -0.2 + 0.1 * i as f64),
                tint,
                transmission,
                seed: 40 + i as u64,
            })
            .chain([Tint::Green, Tint::Brown].iter().enumerate().map(|(i, &tint)| SmallBoard {
                board: None,
                depth_m: 3.0,
                yaw_rad: 0.0,
                at: (0.0, 0.0),
                tint,
                transmission: 0.35,
                seed: 50 + i as u64,
            }))
            .collect();
    let small = small_board_set("bench-speed-small-boards", &scenes);
    bench.slowest_photo(
        "small 13x9 boards and no board, green and brown water",
        &small.camera_file,
        &board,
        &small.photos,
    );
}

/// Peak memory of `fslcal laser --report` over 300 photos (distinct copies of the 16).
fn memory_300(bench: &Bench) {
    let dir = bench.out.join("300");
    std::fs::create_dir_all(&dir).unwrap();
    let photos: Vec<PathBuf> = (0..300)
        .map(|i| {
            let p = dir.join(format!("p{i:03}.jpg"));
            common::distinct_copy(&bench.set.photos[i % bench.set.photos.len()], &p, i);
            p
        })
        .collect();
    let report = bench.out.join("report-300");
    let args = bench.laser_args(&photos, &strings(["--report".as_ref(), report.as_os_str()]));
    let (before, after) = bench.bins.time(&args, 1);
    println!("laser --report, 300 photos: {}  (target: peak no higher than 330 MB)", pair(&before, &after, fmt));
}
