//! Hand-labelled laser dots from a file, told apart by content: a `file,x,y` CSV, or a Label
//! Studio export as the lab makes it (a keypoint labelled "Green Laser" per photo). Each dot
//! keeps the frame it was clicked in and is matched to the photos of a run.
//!
//! A Label Studio task's photo is the last component of its `data.img`, matched to the
//! photos by file stem (`P2100001.JPG` labels `P2100001.ORF`; Label Studio's upload names
//! `HASH-P2100001.JPG` too). Cancelled annotations and tasks without a result are skipped,
//! and of several annotations of one photo the newest counts; each is said.

use super::frame::Frame;
use super::label_studio::{self, LabelStudioError, Task};
use fslcal_core::Vec2;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// What kind of file it was.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DotsFormat {
    Csv,
    LabelStudio,
}

impl DotsFormat {
    pub fn name(self) -> &'static str {
        match self {
            DotsFormat::Csv => "csv",
            DotsFormat::LabelStudio => "label-studio",
        }
    }
}

/// One labelled dot.
#[derive(Clone, Debug, PartialEq)]
pub struct DotLabel {
    /// The photo as the file names it: a path or file name (CSV), the image's file name
    /// (Label Studio).
    pub photo: String,
    pub pixel: Vec2,
    /// The image it was clicked on, when the file says (Label Studio's `original_width` x
    /// `original_height`); a CSV's dots are in the frame the command is told.
    pub frame: Option<Frame>,
}

/// Why a Label Studio task gave no dot.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum SkippedTask {
    NoImage,
    /// No annotation, or only cancelled ones.
    NoAnnotation,
    /// The current annotation has no result (nothing was clicked).
    NoResult,
    /// Keypoints, none with the dot's label.
    NoDotLabel {
        labels: Vec<String>,
    },
    /// More than one keypoint with the dot's label: which is the dot is not known.
    SeveralDots(usize),
}

impl std::fmt::Display for SkippedTask {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            SkippedTask::NoImage => write!(f, "no `data.img` naming the photo"),
            SkippedTask::NoAnnotation => write!(f, "no annotation that is not cancelled"),
            SkippedTask::NoResult => write!(f, "its annotation has no result"),
            SkippedTask::NoDotLabel { labels } => {
                write!(f, "no keypoint with the dot's label (it has {})", labels.join(", "))
            }
            SkippedTask::SeveralDots(n) => {
                write!(f, "{n} keypoints with the dot's label; which is the dot is not known")
            }
        }
    }
}

/// A dots file, read completely.
#[derive(Clone, Debug, PartialEq)]
pub struct DotsFile {
    pub format: DotsFormat,
    pub dots: Vec<DotLabel>,
    /// Label Studio: the tasks in the export (CSV: the dot rows).
    pub entries: usize,
    /// Label Studio tasks that gave no dot, with why (`task 138992 (P2100001.JPG)`).
    pub skipped: Vec<(String, SkippedTask)>,
    /// Photos with several annotations (or tasks) of which the newest was used.
    pub newest_of_several: Vec<String>,
    /// Keypoint labels seen, with how many (the dot's and the others).
    pub labels: BTreeMap<String, usize>,
}

#[derive(Debug, thiserror::Error)]
pub enum DotsFileError {
    #[error("{path}: cannot read the dots file: {source}")]
    Io { path: String, source: std::io::Error },
    #[error("{path}: {why}")]
    Csv { path: String, why: String },
    #[error("{path}: not a Label Studio export fslcal reads ({source}); --dots takes a `file,x,y` CSV or the lab's Label Studio JSON export")]
    LabelStudio { path: String, source: LabelStudioError },
    #[error("{path}: {why}")]
    Empty { path: String, why: String },
}

/// Reads a dots file; a Label Studio export's dots are its keypoints labelled `dot_label`.
pub fn read(path: &Path, dot_label: &str) -> Result<DotsFile, DotsFileError> {
    let name = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|source| DotsFileError::Io { path: name.clone(), source })?;
    let text = String::from_utf8(bytes).map_err(|_| DotsFileError::Csv {
        path: name.clone(),
        why: "not text: expected a `file,x,y` CSV or a Label Studio JSON export".into(),
    })?;
    if label_studio::looks_like_json(&text) {
        let tasks =
            label_studio::parse(&text).map_err(|source| DotsFileError::LabelStudio { path: name.clone(), source })?;
        let file = from_tasks(&tasks, dot_label);
        if file.dots.is_empty() {
            let seen: Vec<String> = file.labels.iter().map(|(l, n)| format!("{n} `{l}`")).collect();
            let why = format!(
                "a Label Studio export of {} task(s) with no keypoint labelled `{dot_label}` to use (keypoints: {}); give the label with --dot-label",
                file.entries,
                if seen.is_empty() { "none".into() } else { seen.join(", ") }
            );
            return Err(DotsFileError::Empty { path: name, why });
        }
        return Ok(file);
    }
    let dots = parse_csv(&text).map_err(|why| DotsFileError::Csv { path: name.clone(), why })?;
    if dots.is_empty() {
        return Err(DotsFileError::Empty {
            path: name,
            why: "no dots in it: expected `file,x,y` rows (x, y in pixels), or a Label Studio JSON export".into(),
        });
    }
    let dots: Vec<DotLabel> = dots.into_iter().map(|(photo, pixel)| DotLabel { photo, pixel, frame: None }).collect();
    Ok(DotsFile {
        format: DotsFormat::Csv,
        entries: dots.len(),
        dots,
        skipped: Vec::new(),
        newest_of_several: Vec::new(),
        labels: BTreeMap::new(),
    })
}

/// `file,x,y` rows: the photo as written (a path or a file name) and its dot in pixels. A
/// first row naming its columns and `#` comments are allowed; anything else that is not a
/// row is refused with its line, and so are two rows giving one photo different dots
/// (repeated identical rows count once).
pub fn parse_csv(text: &str) -> Result<Vec<(String, Vec2)>, String> {
    let mut dots = Vec::new();
    let mut first_line: std::collections::HashMap<String, (usize, Vec2)> = std::collections::HashMap::new();
    let mut first = true;
    for (n, line) in text.trim_start_matches('\u{feff}').lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let cells: Vec<&str> = line.split(',').map(str::trim).collect();
        let number = |c: &str| c.parse::<f64>().ok().filter(|v| v.is_finite());
        match cells.as_slice() {
            [file, x, y] if !file.is_empty() => match (number(x), number(y)) {
                (Some(x), Some(y)) => {
                    let px = Vec2::new(x, y);
                    // Which of two different rows is right is the labeller's call, not the last row's.
                    match first_line.get(*file) {
                        Some(&(line_no, earlier)) if earlier != px => {
                            return Err(format!(
                                "line {}: a second, different dot for {file} (line {line_no} gives another); keep one row per photo",
                                n + 1
                            ));
                        }
                        Some(_) => {}
                        None => {
                            first_line.insert(file.to_string(), (n + 1, px));
                            dots.push((file.to_string(), px));
                        }
                    }
                }
                // A header names its columns: no number in them.
                (None, None) if first => {}
                _ => return Err(format!("line {}: expected `file,x,y` with x and y in pixels, got `{line}`", n + 1)),
            },
            _ => return Err(format!("line {}: expected `file,x,y` with x and y in pixels, got `{line}`", n + 1)),
        }
        first = false;
    }
    Ok(dots)
}

/// The dots of a Label Studio export: per photo, the newest live annotation's one keypoint
/// labelled `dot_label`.
fn from_tasks(tasks: &[Task], dot_label: &str) -> DotsFile {
    let mut out = DotsFile {
        format: DotsFormat::LabelStudio,
        dots: Vec::new(),
        entries: tasks.len(),
        skipped: Vec::new(),
        newest_of_several: Vec::new(),
        labels: BTreeMap::new(),
    };
    // Per photo name: the dot, its annotation's time, and how many labellings it had.
    let mut by_photo: BTreeMap<String, (DotLabel, Option<jiff::Timestamp>, usize)> = BTreeMap::new();
    for task in tasks {
        for k in task.current().into_iter().flat_map(|a| &a.keypoints) {
            for l in &k.labels {
                *out.labels.entry(l.clone()).or_default() += 1;
            }
        }
        match task_dot(task, dot_label) {
            Err(why) => out.skipped.push((task.describe(), why)),
            Ok((dot, time)) => {
                let live = task.live().count();
                let entry = by_photo.entry(dot.photo.clone()).or_insert((dot.clone(), time, 0));
                if time > entry.1 {
                    (entry.0, entry.1) = (dot, time);
                }
                entry.2 += live;
            }
        }
    }
    for (name, (dot, _, labellings)) in by_photo {
        if labellings > 1 {
            out.newest_of_several.push(name);
        }
        out.dots.push(dot);
    }
    out
}

fn task_dot(task: &Task, dot_label: &str) -> Result<(DotLabel, Option<jiff::Timestamp>), SkippedTask> {
    let photo = task.image_name().ok_or(SkippedTask::NoImage)?;
    let a = task.current().ok_or(SkippedTask::NoAnnotation)?;
    if a.keypoints.is_empty() && a.choices.is_empty() {
        return Err(SkippedTask::NoResult);
    }
    let dots: Vec<_> = a.keypoints.iter().filter(|k| k.has_label(dot_label)).collect();
    match dots.as_slice() {
        [k] => Ok((DotLabel { photo: photo.to_string(), pixel: k.pixel(), frame: Some(k.frame) }, a.time)),
        [] => Err(SkippedTask::NoDotLabel { labels: a.keypoints.iter().flat_map(|k| k.labels.clone()).collect() }),
        many => Err(SkippedTask::SeveralDots(many.len())),
    }
}

/// Whether a label naming `label_photo` is for `photo`. A path names it by path or by file
/// name; a Label Studio image by file stem (`P2100001.JPG` names `P2100001.ORF`, as does its
/// upload name `HASH-P2100001.JPG`).
pub fn names_photo(format: DotsFormat, label_photo: &str, photo: &Path) -> bool {
    let stem = |p: &Path| p.file_stem().map(|s| s.to_string_lossy().into_owned());
    match format {
        DotsFormat::Csv => {
            Path::new(label_photo) == photo
                || Path::new(label_photo).file_name().is_some_and(|n| Some(n) == photo.file_name())
        }
        DotsFormat::LabelStudio => {
            let (Some(have), Some(want)) = (stem(Path::new(label_photo)), stem(photo)) else { return false };
            have == want || have.strip_suffix(want.as_str()).is_some_and(|p| p.ends_with('-'))
        }
    }
}

/// A dots file's dots matched to a run's photos.
pub type Matched<'a> = (Vec<(PathBuf, &'a DotLabel)>, Vec<&'a str>);

/// The dots matched to `photos`: each photo's dot, and the labels that named no photo.
/// A label naming two photos is refused: which one it was clicked on is not known.
pub fn match_photos<'a>(file: &'a DotsFile, photos: &[PathBuf]) -> Result<Matched<'a>, String> {
    let mut matched = Vec::new();
    let mut unmatched = Vec::new();
    for dot in &file.dots {
        let hits: Vec<&PathBuf> = photos.iter().filter(|p| names_photo(file.format, &dot.photo, p)).collect();
        match hits.as_slice() {
            [] => unmatched.push(dot.photo.as_str()),
            [p] => matched.push(((*p).clone(), dot)),
            [a, b, ..] => {
                return Err(format!(
                    "the dot for `{}` names both {} and {}; give photos with distinct names",
                    dot.photo,
                    a.display(),
                    b.display()
                ))
            }
        }
    }
    Ok((matched, unmatched))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p
    }

    #[test]
    fn csv_rows_headers_and_what_is_not_a_csv() {
        let dir = tempfile::tempdir().unwrap();
        let ok = write(dir.path(), "d.csv", "file,x,y\n# hand\na/P1.jpg, 10.5 ,20\nP2.jpg,1,2\n");
        let f = read(&ok, "Green Laser").unwrap();
        assert_eq!(f.format, DotsFormat::Csv);
        assert_eq!(f.dots[0], DotLabel { photo: "a/P1.jpg".into(), pixel: Vec2::new(10.5, 20.0), frame: None });
        // A JSON export that is not Label Studio's, a one-line non-CSV, an empty file and a
        // binary file are each refused with the reason, not read as zero dots.
        for (name, text, why) in [
            ("other.json", r#"{"camera": {}}"#, "not a Label Studio export fslcal reads"),
            ("one.txt", "hello there", "line 1: expected `file,x,y`"),
            ("empty.csv", "file,x,y\n", "no dots in it"),
            ("bad.csv", "file,x,y\nP1.jpg,10\n", "line 2"),
        ] {
            let e = read(&write(dir.path(), name, text), "Green Laser").unwrap_err().to_string();
            assert!(e.contains(name) && e.contains(why), "{name}: {e}");
        }
        std::fs::write(dir.path().join("bin"), [0xff, 0xfe, 0x00, 0x9c]).unwrap();
        assert!(read(&dir.path().join("bin"), "x").unwrap_err().to_string().contains("not text"));
    }

    #[test]
    fn label_studio_newest_wins_skips_are_said_and_stems_match() {
        let kp = |x: f64, label: &str| {
            format!(
                r#"{{"value": {{"x": {x}, "y": 50, "keypointlabels": ["{label}"]}}, "original_width": 4040, "original_height": 3016}}"#
            )
        };
        let text = format!(
            r#"[
            {{"id": 1, "data": {{"img": "https://nas/x/P1.JPG"}}, "annotations": [
                {{"updated_at": "2025-02-12T01:00:00Z", "result": [{}]}},
                {{"updated_at": "2025-02-12T02:00:00Z", "result": [{}]}}]}},
            {{"id": 2, "data": {{"img": "https://nas/x/P2.JPG"}}, "annotations": [{{"was_cancelled": true, "result": []}}]}},
            {{"id": 3, "data": {{"img": "https://nas/x/P3.JPG"}}, "annotations": [{{"result": []}}]}},
            {{"id": 4, "data": {{"img": "https://nas/x/P4.JPG"}}, "annotations": [{{"result": [{}]}}]}},
            {{"id": 5, "data": {{"img": "https://nas/x/P5.JPG"}}, "annotations": [{{"result": [{}, {}]}}]}}
        ]"#,
            kp(10.0, "Green Laser"),
            kp(20.0, "Green Laser"),
            kp(30.0, "Red Laser"),
            kp(40.0, "Green Laser"),
            kp(41.0, "Green Laser"),
        );
        let dir = tempfile::tempdir().unwrap();
        let f = read(&write(dir.path(), "export.json", &text), "Green Laser").unwrap();
        assert_eq!(f.entries, 5);
        assert_eq!(f.dots.len(), 1);
        assert_eq!(f.dots[0].pixel.x, 0.2 * 4040.0 - 0.5, "the newer annotation's dot");
        assert_eq!(f.dots[0].frame, Some(Frame::of_size(4040, 3016)));
        assert_eq!(f.newest_of_several, vec!["P1.JPG".to_string()]);
        let why: Vec<&SkippedTask> = f.skipped.iter().map(|(_, w)| w).collect();
        assert_eq!(
            why,
            [
                &SkippedTask::NoAnnotation,
                &SkippedTask::NoResult,
                &SkippedTask::NoDotLabel { labels: vec!["Red Laser".into()] },
                &SkippedTask::SeveralDots(2)
            ]
        );
        let red = read(&write(dir.path(), "export.json", &text), "Red Laser").unwrap();
        assert_eq!(red.dots[0].photo, "P4.JPG");
        let e = read(&write(dir.path(), "export.json", &text), "Blue Laser").unwrap_err().to_string();
        assert!(e.contains("no keypoint labelled `Blue Laser`") && e.contains("3 `Green Laser`, 1 `Red Laser`"), "{e}");

        let photos = [PathBuf::from("dive/P1.ORF"), PathBuf::from("dive/P10.ORF")];
        let (m, unmatched) = match_photos(&f, &photos).unwrap();
        assert_eq!((m.len(), m[0].0.as_path(), unmatched.len()), (1, Path::new("dive/P1.ORF"), 0));
        assert!(names_photo(DotsFormat::LabelStudio, "3fa9c1-P1.JPG", Path::new("P1.ORF")));
        assert!(!names_photo(DotsFormat::LabelStudio, "XP1.JPG", Path::new("P1.ORF")));
        assert!(!names_photo(DotsFormat::Csv, "P1.JPG", Path::new("P1.ORF")));
        let twice = [PathBuf::from("a/P1.ORF"), PathBuf::from("b/P1.JPG")];
        assert!(match_photos(&f, &twice).unwrap_err().contains("names both"));
    }
}
