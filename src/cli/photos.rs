//! The photos a command is given, checked before any work: each must be a file (a folder
//! is said to be one), and each is used once. The same photo given twice (the same path, a
//! symlink, a hard link or a copy: the same contents) would count its dot twice and shrink
//! every sigma, so it is used once and said so on stderr.

use anyhow::bail;
use sha2::{Digest, Sha256};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// Duplicates listed one by one on stderr; beyond this they are counted.
const LISTED_DUPLICATES: usize = 5;

/// `photos` as they exist, each content once (the first of each kept, in order).
pub fn prepare(photos: &[PathBuf]) -> anyhow::Result<Vec<PathBuf>> {
    for p in photos {
        check_is_photo_file(p)?;
        crate::photo::names::remember(p);
    }
    let (unique, duplicates) = dedupe(photos)?;
    for (dup, first) in duplicates.iter().take(LISTED_DUPLICATES) {
        eprintln!(
            "fslcal: note: {} is the same photo as {} (same contents); used once",
            dup.display(),
            first.display()
        );
    }
    if duplicates.len() > LISTED_DUPLICATES {
        eprintln!(
            "fslcal: note: {} more photos repeat earlier ones; {} distinct photos used of {} given",
            duplicates.len() - LISTED_DUPLICATES,
            unique.len(),
            photos.len()
        );
    }
    Ok(unique)
}

/// Refuses what is not a photo file, saying what it is.
pub fn check_is_photo_file(p: &Path) -> anyhow::Result<()> {
    match std::fs::metadata(p) {
        Ok(m) if m.is_dir() => bail!(
            "{}: a folder, not a photo; give the photos in it (e.g. {}/*.jpg)",
            p.display(),
            p.display().to_string().trim_end_matches('/')
        ),
        Ok(m) if !m.is_file() => bail!("{}: not a regular file (a device or a pipe), not a photo", p.display()),
        Ok(_) => Ok(()),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => bail!("{}: no such photo", p.display()),
        Err(e) => bail!("{}: cannot read the photo: {e}", p.display()),
    }
}

/// Bytes hashed at each end of a file for a first comparison: raws of one camera all have
/// one size, and hashing whole raws of a season would cost seconds; their headers differ.
const QUICK_BYTES: u64 = 64 * 1024;

/// A dropped photo and the earlier one whose content it repeats.
type Repeat = (PathBuf, PathBuf);

/// The photos with each content once, and each dropped duplicate with the photo it repeats.
/// Files are compared by size, then by a hash of their two ends, and hashed whole only when
/// those agree.
fn dedupe(photos: &[PathBuf]) -> anyhow::Result<(Vec<PathBuf>, Vec<Repeat>)> {
    let sizes: Vec<u64> = photos.iter().map(|p| Ok(std::fs::metadata(p)?.len())).collect::<anyhow::Result<_>>()?;
    let quick: Vec<Option<(u64, [u8; 32])>> = photos
        .iter()
        .zip(&sizes)
        .map(|(p, &size)| match sizes.iter().filter(|&&s| s == size).count() {
            1 => Ok(None),
            _ => Ok(Some((size, hash_ends(p, size)?))),
        })
        .collect::<anyhow::Result<_>>()?;
    let mut seen: HashMap<(u64, [u8; 32]), PathBuf> = HashMap::new();
    let (mut unique, mut duplicates) = (Vec::new(), Vec::new());
    for (p, q) in photos.iter().zip(&quick) {
        let shared = q.is_some_and(|q| quick.iter().filter(|o| **o == Some(q)).count() > 1);
        if !shared {
            unique.push(p.clone());
            continue;
        }
        let bytes = read(p)?;
        let key = (bytes.len() as u64, Sha256::digest(&bytes).into());
        match seen.get(&key) {
            Some(first) => duplicates.push((p.clone(), first.clone())),
            None => {
                seen.insert(key, p.clone());
                unique.push(p.clone());
            }
        }
    }
    Ok((unique, duplicates))
}

fn read(p: &Path) -> anyhow::Result<Vec<u8>> {
    std::fs::read(p).map_err(|e| anyhow::anyhow!("{}: cannot read the photo: {e}", p.display()))
}

/// SHA-256 of a file's first and last [`QUICK_BYTES`].
fn hash_ends(p: &Path, size: u64) -> anyhow::Result<[u8; 32]> {
    use std::io::{Read, Seek, SeekFrom};
    let io = |e: std::io::Error| anyhow::anyhow!("{}: cannot read the photo: {e}", p.display());
    let mut f = std::fs::File::open(p).map_err(io)?;
    let mut hasher = Sha256::new();
    let mut buf = Vec::new();
    (&mut f).take(QUICK_BYTES).read_to_end(&mut buf).map_err(io)?;
    if size > QUICK_BYTES {
        f.seek(SeekFrom::Start(size.saturating_sub(QUICK_BYTES).max(QUICK_BYTES))).map_err(io)?;
        f.take(QUICK_BYTES).read_to_end(&mut buf).map_err(io)?;
    }
    hasher.update(&buf);
    Ok(hasher.finalize().into())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_same_photo_by_copy_link_or_path_is_used_once() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let a = d.join("a.jpg");
        let b = d.join("b.jpg");
        let same_size = d.join("c.jpg");
        std::fs::write(&a, b"photo a").unwrap();
        std::fs::write(&b, b"photo b, longer").unwrap();
        std::fs::write(&same_size, b"photo c").unwrap();
        std::fs::copy(&a, d.join("copy.jpg")).unwrap();
        #[cfg(unix)]
        std::os::unix::fs::symlink(&b, d.join("link.jpg")).unwrap();
        #[cfg(not(unix))]
        std::fs::copy(&b, d.join("link.jpg")).unwrap();
        let given = [a.clone(), d.join("copy.jpg"), b.clone(), a.clone(), d.join("link.jpg"), same_size.clone()];
        let (unique, dups) = dedupe(&given).unwrap();
        assert_eq!(unique, vec![a.clone(), b.clone(), same_size]);
        assert_eq!(dups, vec![(d.join("copy.jpg"), a.clone()), (a.clone(), a), (d.join("link.jpg"), b)]);
    }

    #[test]
    fn a_folder_or_a_missing_file_is_named_for_what_it_is() {
        let dir = tempfile::tempdir().unwrap();
        let e = check_is_photo_file(dir.path()).unwrap_err().to_string();
        assert!(e.contains("a folder, not a photo; give the photos in it"), "{e}");
        let e = check_is_photo_file(&dir.path().join("nope.jpg")).unwrap_err().to_string();
        assert!(e.ends_with("nope.jpg: no such photo"), "{e}");
    }
}
