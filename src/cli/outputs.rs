//! What a command may write: every output (`--out`, `--summary-out`, `--report`, a folder's
//! files) is checked against the command's inputs and the other outputs before any work,
//! so that no run ever turns a photo, a camera file or a label file into its own result.
//!
//! One output is the same file as an input when both name the same file on disk: the same
//! device and inode (a symlink, a hard link, `./x` and `x` alike), or, where there are no
//! inodes, the same canonical path. A signed unit file already at an output is replaced
//! only with `--force`; any other file that is replaced is said so on stderr when written.

use crate::report::replaceable_report_folder;
use fslcal_core::unit_file;
use std::path::{Path, PathBuf};

/// What an output is, which decides what may be there already.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OutputKind {
    /// A file that may be replaced (said on stderr).
    File,
    /// A signed unit file (`.fslcal`): an existing one is replaced only with `--force`.
    Signed,
    /// A report folder, replaced whole: only an earlier report or an empty folder.
    ReportFolder,
}

/// One output of a run: the option that names it, its path, its kind.
#[derive(Clone, Copy, Debug)]
pub struct Output<'a> {
    pub option: &'static str,
    pub path: &'a Path,
    pub kind: OutputKind,
}

impl<'a> Output<'a> {
    pub fn file(option: &'static str, path: &'a Path) -> Self {
        Output { option, path, kind: OutputKind::File }
    }

    /// A file that is a signed unit file when its name ends in `.fslcal`.
    // Only the photo commands (behind `vision`) write results and reports.
    #[cfg_attr(not(feature = "vision"), allow(dead_code))]
    pub fn result(option: &'static str, path: &'a Path) -> Self {
        let kind = if path.extension().is_some_and(|e| e == "fslcal") { OutputKind::Signed } else { OutputKind::File };
        Output { option, path, kind }
    }

    #[cfg_attr(not(feature = "vision"), allow(dead_code))]
    pub fn report(option: &'static str, path: &'a Path) -> Self {
        Output { option, path, kind: OutputKind::ReportFolder }
    }
}

/// One input of a run: what it is (`--camera`, `photo`) and its path.
#[derive(Clone, Copy, Debug)]
pub struct Input<'a> {
    pub what: &'static str,
    pub path: &'a Path,
}

impl<'a> Input<'a> {
    pub fn new(what: &'static str, path: &'a Path) -> Self {
        Input { what, path }
    }
}

/// Why an output is refused.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    #[error(
        "{path}: {option} would overwrite an input of this run ({what} {input}); nothing written: choose another name"
    )]
    IsAnInput { option: &'static str, path: String, what: &'static str, input: String },
    #[error("{path}: {option} would replace a folder holding an input of this run ({what} {input}); nothing written: choose another folder")]
    HoldsAnInput { option: &'static str, path: String, what: &'static str, input: String },
    #[error("{path}: {first} and {second} name the same file; give them different names")]
    SameOutput { first: &'static str, second: &'static str, path: String },
    #[error("{path}: a signed unit file is already there; give --force to replace it (or another name)")]
    SignedExists { path: String },
    #[error("{path}: {option} is {why}; give a new folder")]
    NotAReportFolder { option: &'static str, path: String, why: crate::report::ForeignFolder },
    #[error("{path}: {option} names a folder; give a file name")]
    IsAFolder { option: &'static str, path: String },
}

/// A file's identity on disk (following symlinks), when it exists.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct FileId {
    #[cfg(unix)]
    dev_ino: (u64, u64),
}

fn file_id(path: &Path) -> Option<FileId> {
    let m = std::fs::metadata(path).ok()?;
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        Some(FileId { dev_ino: (m.dev(), m.ino()) })
    }
    #[cfg(not(unix))]
    {
        let _ = m;
        None
    }
}

/// The path with its folder resolved (symlinks followed), and the file itself resolved when
/// it exists: two spellings of one place compare equal.
fn resolved(path: &Path) -> PathBuf {
    if let Ok(p) = path.canonicalize() {
        return p;
    }
    let parent = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    match (parent.canonicalize(), path.file_name()) {
        (Ok(dir), Some(name)) => dir.join(name),
        _ => path.to_path_buf(),
    }
}

/// Where a path leads: its identity on disk when it exists, and its resolved path.
struct Place {
    id: Option<FileId>,
    path: PathBuf,
}

impl Place {
    fn of(path: &Path) -> Place {
        Place { id: file_id(path), path: resolved(path) }
    }

    fn is(&self, other: &Place) -> bool {
        match (self.id, other.id) {
            (Some(a), Some(b)) => a == b,
            _ => self.path == other.path,
        }
    }
}

/// Checks `outputs` against `inputs` and each other before a run starts. `force` allows an
/// existing signed unit file to be replaced.
pub fn check(inputs: &[Input], outputs: &[Output], force: bool) -> Result<(), OutputError> {
    remove_leftovers(outputs);
    let input_places: Vec<Place> = inputs.iter().map(|i| Place::of(i.path)).collect();
    let output_places: Vec<Place> = outputs.iter().map(|o| Place::of(o.path)).collect();
    for (i, out) in outputs.iter().enumerate() {
        let path = out.path.display().to_string();
        if let Some(j) = output_places[..i].iter().position(|o| o.is(&output_places[i])) {
            return Err(OutputError::SameOutput { first: outputs[j].option, second: out.option, path });
        }
        let input = |k: usize| (inputs[k].what, inputs[k].path.display().to_string());
        match out.kind {
            OutputKind::ReportFolder => {
                replaceable_report_folder(out.path).map_err(|why| OutputError::NotAReportFolder {
                    option: out.option,
                    path: path.clone(),
                    why,
                })?;
                let dir = &output_places[i].path;
                if let Some(k) = input_places.iter().position(|p| p.path.starts_with(dir)) {
                    let (what, input) = input(k);
                    return Err(OutputError::HoldsAnInput { option: out.option, path, what, input });
                }
            }
            OutputKind::File | OutputKind::Signed => {
                if out.path.is_dir() {
                    return Err(OutputError::IsAFolder { option: out.option, path });
                }
                if let Some(k) = input_places.iter().position(|p| p.is(&output_places[i])) {
                    let (what, input) = input(k);
                    return Err(OutputError::IsAnInput { option: out.option, path, what, input });
                }
                let signed = out.kind == OutputKind::Signed || holds_a_signed_file(out.path);
                if !force && signed && out.path.exists() {
                    return Err(OutputError::SignedExists { path });
                }
            }
        }
    }
    check_report_contents(outputs, &output_places)
}

/// Removes what killed writers of these outputs left: the next run does it, even one that
/// is itself stopped before it writes.
fn remove_leftovers(outputs: &[Output]) {
    for out in outputs {
        if let (Some(parent), Some(name)) = (out.path.parent(), out.path.file_name()) {
            let parent = if parent.as_os_str().is_empty() { Path::new(".") } else { parent };
            crate::atomic_file::remove_dead_temporaries(parent, name);
        }
    }
}

/// A file written inside a report folder would be swapped away with the folder.
fn check_report_contents(outputs: &[Output], places: &[Place]) -> Result<(), OutputError> {
    for (folder, dir) in outputs.iter().zip(places).filter(|(o, _)| o.kind == OutputKind::ReportFolder) {
        for (file, place) in outputs.iter().zip(places).filter(|(o, _)| o.kind != OutputKind::ReportFolder) {
            if place.path.starts_with(&dir.path) {
                return Err(OutputError::SameOutput {
                    first: folder.option,
                    second: file.option,
                    path: file.path.display().to_string(),
                });
            }
        }
    }
    Ok(())
}

/// Whether a signed unit file is at `path` now, whatever its name.
fn holds_a_signed_file(path: &Path) -> bool {
    let mut magic = [0u8; unit_file::MAGIC.len()];
    std::fs::File::open(path).and_then(|mut f| std::io::Read::read_exact(&mut f, &mut magic)).is_ok()
        && magic == unit_file::MAGIC
}

/// Says on stderr that `path` is about to be replaced, when something is there. Called
/// right before an output is written, so a run that ends without writing says nothing.
pub fn say_if_replacing(path: &Path) {
    let there = match std::fs::read_dir(path) {
        Ok(mut entries) => entries.next().is_some(),
        Err(_) => path.exists(),
    };
    if there {
        eprintln!("fslcal: note: replacing {}", path.display());
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::fs;

    fn err(inputs: &[Input], outputs: &[Output], force: bool) -> String {
        check(inputs, outputs, force).unwrap_err().to_string()
    }

    #[cfg(unix)]
    #[test]
    fn an_output_that_is_an_input_is_refused_however_it_is_spelled() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let photo = d.join("photo_00.jpg");
        fs::write(&photo, b"jpeg").unwrap();
        std::os::unix::fs::symlink(&photo, d.join("link.jpg")).unwrap();
        fs::hard_link(&photo, d.join("hard.jpg")).unwrap();
        fs::create_dir(d.join("sub")).unwrap();
        let inputs = [Input::new("photo", &photo)];
        for spelled in [photo.clone(), d.join("sub/../photo_00.jpg"), d.join("link.jpg"), d.join("hard.jpg")] {
            let e = err(&inputs, &[Output::result("--out", &spelled)], false);
            assert!(e.contains("--out would overwrite an input of this run (photo "), "{e}");
            assert_eq!(fs::read(&photo).unwrap(), b"jpeg");
        }
        let fresh = d.join("fit.json");
        assert!(check(&inputs, &[Output::result("--out", &fresh)], false).is_ok());
    }

    #[test]
    fn two_outputs_naming_one_file_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let a = dir.path().join("lengths.csv");
        let same = dir.path().join(".").join("lengths.csv");
        let e = err(&[], &[Output::file("--out", &a), Output::file("--summary-out", &same)], false);
        assert!(e.contains("--out and --summary-out name the same file"), "{e}");
        let report = dir.path().join("r");
        let inside = report.join("fit.json");
        let e = err(&[], &[Output::report("--report", &report), Output::file("--out", &inside)], false);
        assert!(e.contains("--report and --out name the same file"), "{e}");
    }

    #[test]
    fn a_signed_file_is_replaced_only_with_force() {
        let dir = tempfile::tempdir().unwrap();
        let cal = dir.path().join("FSL-03.fslcal");
        assert!(check(&[], &[Output::result("--out", &cal)], false).is_ok(), "nothing there yet");
        fs::write(&cal, unit_file::MAGIC).unwrap();
        let e = err(&[], &[Output::result("--out", &cal)], false);
        assert!(e.contains("a signed unit file is already there; give --force"), "{e}");
        assert!(check(&[], &[Output::result("--out", &cal)], true).is_ok());
        // Whatever its name: a signed file is told by its magic.
        let renamed = dir.path().join("cal.json");
        fs::write(&renamed, unit_file::MAGIC).unwrap();
        assert!(err(&[], &[Output::result("--out", &renamed)], false).contains("--force"));
        let json = dir.path().join("fit.json");
        fs::write(&json, b"{}").unwrap();
        assert!(check(&[], &[Output::result("--out", &json)], false).is_ok(), "other files are replaced");
    }

    #[test]
    fn a_report_folder_holding_inputs_or_other_files_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let photos = dir.path().join("photos");
        fs::create_dir(&photos).unwrap();
        let photo = photos.join("a.jpg");
        fs::write(&photo, b"jpeg").unwrap();
        let e = err(&[Input::new("photo", &photo)], &[Output::report("--report", &photos)], false);
        assert!(e.contains("--report is a folder that is not an fslcal report"), "{e}");
        let e = err(&[Input::new("photo", &photo)], &[Output::report("--report", dir.path())], false);
        assert!(e.contains("not an fslcal report"), "{e}");
        let e = err(&[], &[Output::file("--out", &photos)], false);
        assert!(e.contains("--out names a folder"), "{e}");
    }
}
