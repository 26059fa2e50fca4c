//! The SHA-256 of each archive `calibrate` and `diagnose` have loaded, remembered in the FMU
//! cache by the file's identity, so that a run of an unchanged archive whose unpacked copy is
//! in the cache neither reads nor hashes it again (hashing 13 MB of bundled documentation takes
//! longer than a cheap model's whole calibration budget for start-up).
//!
//! The identity is the canonical path, device, inode, size, and the modification and
//! status-change times in nanoseconds: writing to the file changes its status-change time,
//! which no user can set back. A miss, or an unpacked copy that is gone, loads the archive as
//! [`Fmu::load`] does (hashing it, unpacking it if need be) and remembers its SHA-256. Each
//! record is a file `<cache>/.sha256-by-file/<SHA-256 of the identity>` holding the archive's
//! SHA-256; a record that cannot be written is only a lost shortcut.

use std::os::unix::fs::MetadataExt;
use std::path::Path;

use fmucal_shared::fmu::archive::{default_cache_dir, sha256_hex};
use fmucal_shared::fmu::{Fmu, FmuError};

/// The folder of the records, in the FMU cache.
const RECORDS: &str = ".sha256-by-file";

/// The key of `path`'s identity, or `None` if it cannot be read.
fn identity(path: &Path) -> Option<String> {
    let meta = std::fs::metadata(path).ok()?;
    let canonical = std::fs::canonicalize(path).ok()?;
    let text = format!(
        "{}\0{} {} {} {}.{} {}.{}",
        canonical.display(),
        meta.dev(),
        meta.ino(),
        meta.len(),
        meta.mtime(),
        meta.mtime_nsec(),
        meta.ctime(),
        meta.ctime_nsec()
    );
    Some(sha256_hex(text.as_bytes()))
}

fn is_sha256(s: &str) -> bool {
    s.len() == 64 && s.bytes().all(|b| b.is_ascii_hexdigit())
}

/// Loads the archive at `path` as [`Fmu::load`] does, from its unpacked copy in the FMU cache
/// without reading the archive if it is unchanged since a load recorded it.
///
/// # Errors
/// As [`Fmu::load`].
pub fn load(path: &Path) -> Result<Fmu, FmuError> {
    let cache = default_cache_dir();
    let key = identity(path);
    if let Some(key) = &key
        && let Ok(text) = std::fs::read_to_string(cache.join(RECORDS).join(key))
        && is_sha256(text.trim())
    {
        let sha = text.trim();
        let dir = cache.join(sha);
        if dir.join("modelDescription.xml").is_file() {
            tracing::debug!(fmu = %path.display(), dir = %dir.display(), "unchanged archive: reusing its unpacked copy");
            return Fmu::open_unpacked(&dir, sha.to_owned());
        }
    }
    let fmu = Fmu::load(path)?;
    if let Some(key) = key {
        let records = cache.join(RECORDS);
        let tmp = records.join(format!(".{key}.{}", std::process::id()));
        let written = std::fs::create_dir_all(&records)
            .and_then(|()| std::fs::write(&tmp, &fmu.sha256))
            .and_then(|()| std::fs::rename(&tmp, records.join(&key)));
        if let Err(e) = written {
            let _ = std::fs::remove_file(&tmp);
            tracing::debug!("cannot record the SHA-256 of {}: {e}", path.display());
        }
    }
    Ok(fmu)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_write_to_the_archive_changes_its_identity() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.fmu");
        std::fs::write(&path, b"one").unwrap();
        let first = identity(&path).unwrap();
        assert_eq!(identity(&path).unwrap(), first);
        // Same size, written again: the status-change time (and the content) moved on.
        std::thread::sleep(std::time::Duration::from_millis(10));
        std::fs::write(&path, b"two").unwrap();
        assert_ne!(identity(&path).unwrap(), first);
        // Another file with the same bytes is another file.
        let other = dir.path().join("b.fmu");
        std::fs::write(&other, b"two").unwrap();
        assert_ne!(identity(&other).unwrap(), identity(&path).unwrap());
        assert!(identity(&dir.path().join("missing.fmu")).is_none());
    }
}
