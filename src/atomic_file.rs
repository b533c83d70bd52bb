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
use std::path::Path;

/// Replaces `path` with `bytes` atomically.
pub fn write_atomically(path: &Path, bytes: &[u8]) -> io::Result<()> {
    write_atomically_with_mode(path, bytes, 0o666)
}

/// [`write_atomically`] for secrets: the file is owner-only (0600) from its creation, so the
/// secret is never readable by others, not even while being written.
pub fn write_atomically_private(path: &Path, bytes: &[u8]) -> io::Result<()> {
    write_atomically_with_mode(path, bytes, 0o600)
}

/// The prefix of the temporaries written for `name` by this process.
fn temporary_prefix(name: &std::ffi::OsStr) -> String {
    format!(".{}.{}.", name.to_string_lossy(), std::process::id())
}

fn write_atomically_with_mode(path: &Path, bytes: &[u8], mode: u32) -> io::Result<()> {
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let name =
        path.file_name().ok_or_else(|| io::Error::new(io::ErrorKind::InvalidInput, "the output path names no file"))?;
    let prefix = temporary_prefix(name);
    let mut builder = tempfile::Builder::new();
    builder.prefix(&prefix).suffix(".tmp");
    set_mode(&mut builder, mode);
    // On any error below the temporary is dropped, which deletes it.
    let mut tmp = builder.tempfile_in(dir)?;
    tmp.write_all(bytes)?;
    tmp.as_file().sync_all()?;
    tmp.persist(path).map_err(|e| e.error)?;
    if let Ok(d) = File::open(dir) {
        // Some filesystems refuse fsync on a directory; the data itself is already safe.
        let _ = d.sync_all();
    }
    Ok(())
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
}
