//! Writing output files so that a crash, a full disk or Ctrl-C never leaves a half-written
//! calibration behind: write a temporary file beside the target, fsync it, rename it over
//! the target (atomic on POSIX), then fsync the directory so the rename itself is durable.
//!
//! The temporary file is `tempfile`'s: created with `O_EXCL` under a random name (two
//! threads or processes writing the same output never share one), deleted when a write
//! fails, and renamed with `NamedTempFile::persist`. Its name keeps the writer's process
//! id, `.NAME.PID.RANDOM.tmp`, so that temporaries left by a killed writer can be told from
//! a live one's and cleaned up. `tempfile` also makes the temporary folders a whole report
//! can be written into and swapped in. What it does not do, and this module adds, is the two
//! fsyncs.

use std::fs::File;
use std::io::{self, Write};
use std::path::{Path, PathBuf};

/// Replaces `path` with `bytes` atomically.
pub fn write_atomically(path: &Path, bytes: &[u8]) -> io::Result<()> {
    write_atomically_with_mode(path, bytes, 0o666, Persist::Replace)
}

/// [`write_atomically`] for secrets: the file is owner-only (0600) from its creation, so the
/// secret is never readable by others, not even while being written.
pub fn write_atomically_private(path: &Path, bytes: &[u8]) -> io::Result<()> {
    write_atomically_with_mode(path, bytes, 0o600, Persist::Replace)
}

/// Writes `bytes` to `path` only if nothing is there: the file appears whole or not at all,
/// and of two writers racing for one name exactly one wins (the other gets
/// [`io::ErrorKind::AlreadyExists`]). What a registry files must never replace what another
/// process filed a moment before.
pub fn write_new_atomically(path: &Path, bytes: &[u8]) -> io::Result<()> {
    write_atomically_with_mode(path, bytes, 0o666, Persist::NoClobber)
}

/// Whether the rename may replace what is at the target.
#[derive(Clone, Copy, PartialEq)]
enum Persist {
    Replace,
    NoClobber,
}

/// The folder `path` is in (`.` for a bare name) and its file name.
fn split(path: &Path) -> io::Result<(&Path, &std::ffi::OsStr)> {
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let name =
        path.file_name().ok_or_else(|| io::Error::new(io::ErrorKind::InvalidInput, "the output path names no file"))?;
    Ok((dir, name))
}

/// The prefix of the temporaries written for `name` by this process.
fn temporary_prefix(name: &std::ffi::OsStr) -> String {
    format!(".{}.{}.", name.to_string_lossy(), std::process::id())
}

fn write_atomically_with_mode(path: &Path, bytes: &[u8], mode: u32, persist: Persist) -> io::Result<()> {
    let (dir, name) = split(path)?;
    remove_dead_temporaries(dir, name);
    let prefix = temporary_prefix(name);
    let mut builder = tempfile::Builder::new();
    builder.prefix(&prefix).suffix(".tmp");
    set_mode(&mut builder, mode);
    // On any error below the temporary is dropped, which deletes it.
    let mut tmp = builder.tempfile_in(dir)?;
    tmp.write_all(bytes)?;
    tmp.as_file().sync_all()?;
    match persist {
        Persist::Replace => tmp.persist(path).map(drop).map_err(|e| e.error)?,
        Persist::NoClobber => tmp.persist_noclobber(path).map(drop).map_err(|e| e.error)?,
    }
    sync_dir(dir);
    Ok(())
}

/// fsyncs a folder so that a rename in it is durable. Some filesystems refuse fsync on a
/// directory; the data itself is already safe then.
fn sync_dir(dir: &Path) {
    if let Ok(d) = File::open(dir) {
        let _ = d.sync_all();
    }
}

/// Replaces the folder `dir` with one `fill` writes, in one step: `fill` writes into a
/// fresh temporary folder beside `dir` (`.NAME.PID.RANDOM.tmp`), which is then swapped in
/// with a single rename (Linux's `RENAME_EXCHANGE`), so that a reader or a crash sees the
/// whole old folder or the whole new one, never a mix, and nothing of an earlier run stays.
/// The old folder is deleted afterwards. Where the filesystem cannot exchange, the old
/// folder is moved aside first: a crash in between leaves `dir` missing, with the old
/// folder whole beside it as `.NAME.PID.RANDOM.old`.
pub fn replace_dir_atomically<T>(dir: &Path, fill: impl FnOnce(&Path) -> io::Result<T>) -> io::Result<T> {
    let (parent, name) = split(dir)?;
    std::fs::create_dir_all(parent)?;
    remove_dead_temporaries(parent, name);
    let prefix = temporary_prefix(name);
    let mut builder = tempfile::Builder::new();
    builder.prefix(&prefix).suffix(".tmp");
    // Narrowed by the umask as any new folder (tempfile's default is owner-only).
    set_mode(&mut builder, 0o777);
    // Dropped on any error, which deletes what was written; after the swap it holds the
    // old folder, which dropping deletes.
    let tmp = builder.tempdir_in(parent)?;
    let out = fill(tmp.path())?;
    sync_tree(tmp.path())?;
    swap_in(tmp.path(), dir, parent, name)?;
    sync_dir(parent);
    Ok(out)
}

/// Moves the folder `new` to `dir`; whatever was at `dir` ends up at `new`.
fn swap_in(new: &Path, dir: &Path, parent: &Path, name: &std::ffi::OsStr) -> io::Result<()> {
    match std::fs::symlink_metadata(dir) {
        Err(e) if e.kind() == io::ErrorKind::NotFound => return std::fs::rename(new, dir),
        Err(e) => return Err(e),
        Ok(m) if !m.is_dir() => {
            return Err(io::Error::new(io::ErrorKind::AlreadyExists, "a file, not a folder, is in the way"))
        }
        Ok(_) => {}
    }
    if exchange(new, dir)? {
        return Ok(());
    }
    let aside = tempfile::Builder::new().prefix(&temporary_prefix(name)).suffix(".old").tempdir_in(parent)?;
    // `rename` replaces the empty folder `aside` made; keep its name, not the guard.
    let aside = aside.keep();
    std::fs::rename(dir, &aside)?;
    std::fs::rename(new, dir)?;
    std::fs::rename(&aside, new)
}

/// Exchanges two paths atomically; `Ok(false)` when the filesystem cannot.
#[cfg(target_os = "linux")]
fn exchange(a: &Path, b: &Path) -> io::Result<bool> {
    use rustix::fs::{renameat_with, RenameFlags, CWD};
    match renameat_with(CWD, a, CWD, b, RenameFlags::EXCHANGE) {
        Ok(()) => Ok(true),
        Err(e)
            if e == rustix::io::Errno::INVAL || e == rustix::io::Errno::NOSYS || e == rustix::io::Errno::OPNOTSUPP =>
        {
            Ok(false)
        }
        Err(e) => Err(e.into()),
    }
}

#[cfg(not(target_os = "linux"))]
fn exchange(_a: &Path, _b: &Path) -> io::Result<bool> {
    Ok(false)
}

/// fsyncs every file and folder under `root` (a report is a few dozen files).
fn sync_tree(root: &Path) -> io::Result<()> {
    for entry in std::fs::read_dir(root)? {
        let entry = entry?;
        let path = entry.path();
        if entry.file_type()?.is_dir() {
            sync_tree(&path)?;
        } else {
            File::open(&path)?.sync_all()?;
        }
    }
    sync_dir(root);
    Ok(())
}

/// Deletes the temporaries (files or folders, `.NAME.PID.RANDOM.tmp` or `.old`) that
/// writers of `name` in `dir` left when they were killed: those whose process is gone. A
/// live writer's are left alone. Best effort: what cannot be read or removed stays.
pub fn remove_dead_temporaries(dir: &Path, name: &std::ffi::OsStr) {
    for path in dead_temporaries(dir, name) {
        let _ = if path.is_dir() { std::fs::remove_dir_all(&path) } else { std::fs::remove_file(&path) };
    }
}

/// The temporaries of `name` in `dir` whose writer is no longer running.
pub fn dead_temporaries(dir: &Path, name: &std::ffi::OsStr) -> Vec<PathBuf> {
    let Ok(entries) = std::fs::read_dir(dir) else { return Vec::new() };
    let prefix = format!(".{}.", name.to_string_lossy());
    entries
        .filter_map(|e| e.ok())
        .filter(|e| {
            let file = e.file_name();
            let Some(rest) = file.to_str().and_then(|f| f.strip_prefix(prefix.as_str())) else { return false };
            temporary_pid(rest).is_some_and(|pid| pid != std::process::id() && !process_alive(pid))
        })
        .map(|e| e.path())
        .collect()
}

/// The writer's process id in `PID.RANDOM.tmp` (or `.old`), the part of a temporary's name
/// after `.NAME.`; `None` for anything else.
fn temporary_pid(rest: &str) -> Option<u32> {
    let rest = rest.strip_suffix(".tmp").or_else(|| rest.strip_suffix(".old"))?;
    let (pid, random) = rest.split_once('.')?;
    let ok = !random.is_empty() && random.chars().all(|c| c.is_ascii_alphanumeric());
    ok.then(|| pid.parse().ok()).flatten()
}

/// Whether process `pid` exists (another user's process counts: it cannot be signalled but
/// is there).
#[cfg(unix)]
fn process_alive(pid: u32) -> bool {
    let Some(pid) = i32::try_from(pid).ok().and_then(rustix::process::Pid::from_raw) else { return false };
    !matches!(rustix::process::test_kill_process(pid), Err(e) if e == rustix::io::Errno::SRCH)
}

#[cfg(not(unix))]
fn process_alive(_pid: u32) -> bool {
    // Without a way to ask, every writer is presumed alive: nothing is deleted.
    true
}

/// The mode is given at creation (and narrowed by the umask, as for any new file), never
/// changed afterwards: a secret is never readable by others, even empty.
#[cfg(unix)]
fn set_mode(builder: &mut tempfile::Builder, mode: u32) {
    use std::os::unix::fs::PermissionsExt;
    builder.permissions(std::fs::Permissions::from_mode(mode));
}

#[cfg(not(unix))]
fn set_mode(_builder: &mut tempfile::Builder, _mode: u32) {}

#[cfg(test)]
mod tests {
    use super::*;
    use std::fs;

    fn names(dir: &Path) -> Vec<std::ffi::OsString> {
        fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name()).collect()
    }

    #[test]
    fn replaces_the_file_and_leaves_no_temporary() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("out.json");
        fs::write(&p, b"old").unwrap();
        write_atomically(&p, b"new contents").unwrap();
        assert_eq!(fs::read(&p).unwrap(), b"new contents");
        let names = names(dir.path());
        assert_eq!(names.len(), 1, "left behind: {names:?}");
    }

    #[cfg(unix)]
    #[test]
    fn private_files_are_owner_only() {
        use std::os::unix::fs::PermissionsExt;
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("key");
        write_atomically_private(&p, b"secret").unwrap();
        assert_eq!(fs::metadata(&p).unwrap().permissions().mode() & 0o777, 0o600);
        // Ordinary outputs are readable by others as any new file is (umask permitting).
        let q = dir.path().join("out.json");
        write_atomically(&q, b"{}").unwrap();
        assert_eq!(fs::metadata(&q).unwrap().permissions().mode() & 0o600, 0o600);
    }

    #[test]
    fn a_failed_write_leaves_the_old_file() {
        let dir = tempfile::tempdir().unwrap();
        let missing = dir.path().join("no-such-dir").join("out.json");
        assert!(write_atomically(&missing, b"x").is_err());
        // The rename fails (a folder is in the way): what was there stays, and the
        // temporary is gone.
        let in_the_way = dir.path().join("out.json");
        fs::create_dir(&in_the_way).unwrap();
        fs::write(in_the_way.join("old"), b"old").unwrap();
        assert!(write_atomically(&in_the_way, b"new").is_err());
        assert_eq!(fs::read(in_the_way.join("old")).unwrap(), b"old");
        assert_eq!(names(dir.path()), vec![std::ffi::OsString::from("out.json")]);
    }

    /// A process id that is surely not running: a child that has exited and been reaped.
    #[cfg(unix)]
    fn dead_pid() -> u32 {
        let mut child = std::process::Command::new("true").spawn().unwrap();
        let pid = child.id();
        child.wait().unwrap();
        pid
    }

    #[cfg(unix)]
    #[test]
    fn temporaries_of_killed_writers_are_removed_by_the_next_write() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("out.json");
        let dead = dead_pid();
        let live = std::os::unix::process::parent_id();
        let leftovers = [
            format!(".out.json.{dead}.a1B2c3.tmp"),
            format!(".report.{dead}.Zz9yY8.tmp"),
            format!(".out.json.{live}.q1w2e3.tmp"),
            format!(".out.json.{dead}.not-mine"),
        ];
        for n in &leftovers {
            fs::write(dir.path().join(n), b"partial").unwrap();
        }
        write_atomically(&p, b"new").unwrap();
        let mut left: Vec<String> = names(dir.path()).into_iter().map(|n| n.into_string().unwrap()).collect();
        left.sort();
        // The dead writer's temporary of this output is gone; another output's, a live
        // writer's and a file that only looks alike stay.
        let mut want = vec!["out.json".to_string(), leftovers[1].clone(), leftovers[2].clone(), leftovers[3].clone()];
        want.sort();
        assert_eq!(left, want);
    }

    #[test]
    fn a_new_file_never_replaces_one_already_there() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("entry");
        write_new_atomically(&p, b"first").unwrap();
        let e = write_new_atomically(&p, b"second").unwrap_err();
        assert_eq!(e.kind(), io::ErrorKind::AlreadyExists);
        assert_eq!(fs::read(&p).unwrap(), b"first");
        assert_eq!(names(dir.path()).len(), 1);
    }

    fn tree(dir: &Path) -> Vec<(String, Vec<u8>)> {
        let mut out = Vec::new();
        for e in fs::read_dir(dir).unwrap() {
            let e = e.unwrap();
            let name = e.file_name().into_string().unwrap();
            if e.file_type().unwrap().is_dir() {
                out.extend(tree(&e.path()).into_iter().map(|(n, b)| (format!("{name}/{n}"), b)));
            } else {
                out.push((name, fs::read(e.path()).unwrap()));
            }
        }
        out.sort();
        out
    }

    #[test]
    fn a_folder_is_replaced_whole_and_nothing_of_the_old_one_stays() {
        let dir = tempfile::tempdir().unwrap();
        let report = dir.path().join("report");
        fs::create_dir_all(report.join("thumbs")).unwrap();
        fs::write(report.join("index.html"), b"old").unwrap();
        fs::write(report.join("thumbs/stale.jpg"), b"old thumb").unwrap();
        let n = replace_dir_atomically(&report, |tmp| {
            fs::create_dir(tmp.join("plots"))?;
            fs::write(tmp.join("plots/a.svg"), b"<svg/>")?;
            fs::write(tmp.join("index.html"), b"new")?;
            Ok(2)
        })
        .unwrap();
        assert_eq!(n, 2);
        assert_eq!(
            tree(&report),
            vec![("index.html".into(), b"new".to_vec()), ("plots/a.svg".into(), b"<svg/>".to_vec())]
        );
        assert_eq!(names(dir.path()), vec![std::ffi::OsString::from("report")], "no temporary or old folder left");
        // A folder that did not exist is created the same way.
        let fresh = dir.path().join("fresh");
        replace_dir_atomically(&fresh, |tmp| fs::write(tmp.join("index.html"), b"x")).unwrap();
        assert_eq!(tree(&fresh), vec![("index.html".into(), b"x".to_vec())]);
    }

    #[test]
    fn a_failed_fill_leaves_the_old_folder_and_no_temporary() {
        let dir = tempfile::tempdir().unwrap();
        let report = dir.path().join("report");
        fs::create_dir(&report).unwrap();
        fs::write(report.join("index.html"), b"old").unwrap();
        let e = replace_dir_atomically(&report, |tmp| {
            fs::write(tmp.join("index.html"), b"half")?;
            Err::<(), _>(io::Error::other("disk full"))
        })
        .unwrap_err();
        assert_eq!(e.to_string(), "disk full");
        assert_eq!(tree(&report), vec![("index.html".into(), b"old".to_vec())]);
        assert_eq!(names(dir.path()), vec![std::ffi::OsString::from("report")]);
    }

    #[test]
    fn temporary_names_are_told_from_others() {
        assert_eq!(temporary_pid("1234.aB3dE9.tmp"), Some(1234));
        assert_eq!(temporary_pid("1234.aB3dE9.old"), Some(1234));
        for other in ["1234.tmp", "x.aB3dE9.tmp", "1234.a.b.tmp", "1234.aB3dE9.json", "5.123.xyz.tmp"] {
            assert_eq!(temporary_pid(other), None, "{other}");
        }
    }
}
