//! Opens `.fmu` archives as untrusted input and unpacks them once into a cache directory keyed
//! by the archive's SHA-256. Entries with absolute paths, `..` components or symlinks are
//! rejected; the entry count and the total uncompressed size are capped, both as declared in
//! the central directory and as actually decompressed (a lying header cannot exceed the cap).
#![forbid(unsafe_code)]

use std::fs;
use std::io::{Read, Write};
use std::path::{Component, Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use sha2::{Digest, Sha256};

/// Limits applied while unpacking an archive.
#[derive(Debug, Clone)]
pub struct ArchiveLimits {
    /// Largest total uncompressed size. Default: 2 GiB.
    pub max_total_bytes: u64,
    /// Largest number of entries. Default: 20,000.
    pub max_entries: usize,
    /// Largest archive file read into memory for hashing. Default: 1 GiB.
    pub max_archive_bytes: u64,
}

impl Default for ArchiveLimits {
    fn default() -> Self {
        Self { max_total_bytes: 2 << 30, max_entries: 20_000, max_archive_bytes: 1 << 30 }
    }
}

/// An environment variable holding a value that is not a setting.
#[derive(Debug, thiserror::Error)]
#[error("{var}: {message}")]
pub struct EnvError {
    /// The variable's name.
    pub var: &'static str,
    pub message: String,
}

impl ArchiveLimits {
    /// The defaults, overridden by `FMUCAL_MAX_UNPACK_BYTES` and `FMUCAL_MAX_UNPACK_ENTRIES`;
    /// a value that is not a positive whole number is ignored with a warning (the `fmucal`
    /// binary refuses it at start, with [`Self::try_from_env`]).
    pub fn from_env() -> Self {
        Self::try_from_env().unwrap_or_else(|e| {
            tracing::warn!("{e}; the default limits apply");
            Self::default()
        })
    }

    /// The defaults, overridden by `FMUCAL_MAX_UNPACK_BYTES` and `FMUCAL_MAX_UNPACK_ENTRIES`.
    ///
    /// # Errors
    /// [`EnvError`] naming the variable, when it is set to anything but a positive whole
    /// number.
    pub fn try_from_env() -> Result<Self, EnvError> {
        let mut limits = Self::default();
        let read = |var: &'static str| -> Result<Option<u64>, EnvError> {
            let Some(v) = std::env::var_os(var) else { return Ok(None) };
            let text = v.to_string_lossy();
            match text.trim().parse::<u64>() {
                Ok(n) if n > 0 => Ok(Some(n)),
                _ => {
                    let shown: String = text.chars().take(64).flat_map(char::escape_debug).collect();
                    Err(EnvError { var, message: format!("\"{shown}\" is not a positive whole number") })
                }
            }
        };
        if let Some(n) = read("FMUCAL_MAX_UNPACK_BYTES")? {
            limits.max_total_bytes = n;
        }
        if let Some(n) = read("FMUCAL_MAX_UNPACK_ENTRIES")? {
            limits.max_entries = usize::try_from(n).unwrap_or(usize::MAX);
        }
        Ok(limits)
    }
}

/// Why an archive could not be unpacked.
#[derive(Debug, thiserror::Error)]
pub enum ArchiveError {
    #[error("cannot read {path}: {source}")]
    Io { path: PathBuf, source: std::io::Error },
    #[error("{path} is not a valid zip archive: {message}")]
    Corrupt { path: PathBuf, message: String },
    #[error("unsafe entry {entry:?} in {path}: {reason}")]
    UnsafeEntry { path: PathBuf, entry: String, reason: &'static str },
    #[error("{path} exceeds the unpacking limit: {what}")]
    TooLarge { path: PathBuf, what: String },
    #[error("{path} has no modelDescription.xml at its top level")]
    NoModelDescription { path: PathBuf },
    /// A directory, a device, a FIFO or a socket given where an archive file is read.
    #[error("{path} is {kind}, not a regular file")]
    NotAFile { path: PathBuf, kind: &'static str },
}

/// What a path that is not a regular file is, for an error (`a directory`, `a FIFO`, ...);
/// `None` for a regular file. Symbolic links are followed by the `metadata` given.
pub fn non_regular_kind(meta: &fs::Metadata) -> Option<&'static str> {
    let t = meta.file_type();
    if t.is_file() {
        return None;
    }
    if t.is_dir() {
        return Some("a directory");
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        for (is, kind) in [
            (t.is_fifo(), "a FIFO"),
            (t.is_char_device(), "a character device"),
            (t.is_block_device(), "a block device"),
            (t.is_socket(), "a socket"),
        ] {
            if is {
                return Some(kind);
            }
        }
    }
    Some("a special file")
}

/// An archive unpacked into the cache.
#[derive(Debug, Clone)]
pub struct Unpacked {
    /// Hex SHA-256 of the archive bytes.
    pub sha256: String,
    /// Directory holding the unpacked files.
    pub dir: PathBuf,
}

/// The cache root: `$FMUCAL_CACHE_DIR`, else `$XDG_CACHE_HOME/fmucal/fmus`, else
/// `$HOME/.cache/fmucal/fmus`, else a folder in the system temp directory.
pub fn default_cache_dir() -> PathBuf {
    if let Some(dir) = std::env::var_os("FMUCAL_CACHE_DIR") {
        return PathBuf::from(dir);
    }
    if let Some(dir) = std::env::var_os("XDG_CACHE_HOME") {
        return PathBuf::from(dir).join("fmucal").join("fmus");
    }
    if let Some(home) = std::env::var_os("HOME") {
        return PathBuf::from(home).join(".cache").join("fmucal").join("fmus");
    }
    std::env::temp_dir().join("fmucal-fmus")
}

/// Hex SHA-256 of some bytes.
pub fn sha256_hex(bytes: &[u8]) -> String {
    Sha256::digest(bytes).iter().map(|b| format!("{b:02x}")).collect()
}

/// Unpacks `path` into `cache_dir/<sha256>` unless that directory already exists.
///
/// # Errors
/// [`ArchiveError`] for unreadable or corrupt archives, unsafe entries, and archives over the limits.
pub fn unpack(path: &Path, cache_dir: &Path, limits: &ArchiveLimits) -> Result<Unpacked, ArchiveError> {
    let io = |source| ArchiveError::Io { path: path.to_owned(), source };
    let meta = fs::metadata(path).map_err(io)?;
    if let Some(kind) = non_regular_kind(&meta) {
        return Err(ArchiveError::NotAFile { path: path.to_owned(), kind });
    }
    let len = meta.len();
    if len > limits.max_archive_bytes {
        return Err(ArchiveError::TooLarge {
            path: path.to_owned(),
            what: format!("archive is {len} bytes, limit {}", limits.max_archive_bytes),
        });
    }
    // Read from the file, never held whole in memory (an upload may be a gigabyte).
    let mut file = fs::File::open(path).map_err(io)?;
    let mut hasher = Sha256::new();
    std::io::copy(&mut std::io::Read::take(&mut file, limits.max_archive_bytes), &mut hasher).map_err(io)?;
    let sha256: String = hasher.finalize().iter().map(|b| format!("{b:02x}")).collect();
    std::io::Seek::rewind(&mut file).map_err(io)?;
    let dir = cache_dir.join(&sha256);
    if dir.join("modelDescription.xml").is_file() {
        tracing::debug!(fmu = %path.display(), dir = %dir.display(), "reusing unpacked FMU");
        return Ok(Unpacked { sha256, dir });
    }
    fs::create_dir_all(cache_dir).map_err(|source| ArchiveError::Io { path: cache_dir.to_owned(), source })?;
    let staging = staging_dir(cache_dir, &sha256);
    let result = extract(path, file, &staging, limits);
    if let Err(e) = result {
        let _ = fs::remove_dir_all(&staging);
        return Err(e);
    }
    if !staging.join("modelDescription.xml").is_file() {
        let _ = fs::remove_dir_all(&staging);
        return Err(ArchiveError::NoModelDescription { path: path.to_owned() });
    }
    // Another process may have won the race; either copy is identical.
    if fs::rename(&staging, &dir).is_err() {
        let _ = fs::remove_dir_all(&staging);
        if !dir.join("modelDescription.xml").is_file() {
            return Err(ArchiveError::Io {
                path: dir.clone(),
                source: std::io::Error::other("could not move the unpacked FMU into the cache"),
            });
        }
    }
    tracing::debug!(fmu = %path.display(), dir = %dir.display(), "unpacked FMU");
    Ok(Unpacked { sha256, dir })
}

fn staging_dir(cache_dir: &Path, sha256: &str) -> PathBuf {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    cache_dir.join(format!(".{sha256}.partial-{}-{n}", std::process::id()))
}

/// Checks an entry name and turns it into a relative path below the target directory.
fn safe_relative_path(name: &str) -> Result<PathBuf, &'static str> {
    if name.contains('\0') {
        return Err("NUL byte in name");
    }
    let normalized = name.replace('\\', "/");
    if normalized.starts_with('/') || normalized.as_bytes().get(1) == Some(&b':') {
        return Err("absolute path");
    }
    let mut out = PathBuf::new();
    for comp in Path::new(&normalized).components() {
        match comp {
            Component::Normal(c) => out.push(c),
            Component::CurDir => {}
            Component::ParentDir => return Err("path climbs out of the archive with '..'"),
            Component::RootDir | Component::Prefix(_) => return Err("absolute path"),
        }
    }
    Ok(out)
}

fn extract(path: &Path, file: fs::File, target: &Path, limits: &ArchiveLimits) -> Result<(), ArchiveError> {
    let corrupt = |e: zip::result::ZipError| ArchiveError::Corrupt { path: path.to_owned(), message: e.to_string() };
    let mut zip = zip::ZipArchive::new(std::io::BufReader::new(file)).map_err(corrupt)?;
    if zip.len() > limits.max_entries {
        return Err(ArchiveError::TooLarge {
            path: path.to_owned(),
            what: format!("{} entries, limit {}", zip.len(), limits.max_entries),
        });
    }
    // First pass: names, kinds and declared sizes, before anything is written.
    let mut declared: u64 = 0;
    for i in 0..zip.len() {
        let entry = zip.by_index_raw(i).map_err(corrupt)?;
        let name = entry.name().map_err(corrupt)?.into_owned();
        safe_relative_path(&name).map_err(|reason| ArchiveError::UnsafeEntry {
            path: path.to_owned(),
            entry: name.clone(),
            reason,
        })?;
        if entry.is_symlink() {
            return Err(ArchiveError::UnsafeEntry { path: path.to_owned(), entry: name, reason: "symbolic link" });
        }
        declared = declared.saturating_add(entry.size());
        if declared > limits.max_total_bytes {
            return Err(ArchiveError::TooLarge {
                path: path.to_owned(),
                what: format!("declared uncompressed size over {} bytes", limits.max_total_bytes),
            });
        }
    }
    let io = |p: &Path| {
        let p = p.to_owned();
        move |source| ArchiveError::Io { path: p, source }
    };
    fs::create_dir_all(target).map_err(io(target))?;
    let mut written: u64 = 0;
    for i in 0..zip.len() {
        let mut entry = zip.by_index(i).map_err(corrupt)?;
        let name = entry.name().map_err(corrupt)?.into_owned();
        let rel = safe_relative_path(&name).map_err(|reason| ArchiveError::UnsafeEntry {
            path: path.to_owned(),
            entry: name.clone(),
            reason,
        })?;
        let out = target.join(&rel);
        if entry.is_dir() {
            fs::create_dir_all(&out).map_err(io(&out))?;
            continue;
        }
        if let Some(parent) = out.parent() {
            fs::create_dir_all(parent).map_err(io(parent))?;
        }
        let mut file = fs::File::create(&out).map_err(io(&out))?;
        let budget = limits.max_total_bytes - written;
        let mut limited = (&mut entry).take(budget + 1);
        let mut buf = [0u8; 64 * 1024];
        loop {
            let n = limited.read(&mut buf).map_err(|e| ArchiveError::Corrupt {
                path: path.to_owned(),
                message: format!("entry {}: {e}", rel.display()),
            })?;
            if n == 0 {
                break;
            }
            written += n as u64;
            if written > limits.max_total_bytes {
                return Err(ArchiveError::TooLarge {
                    path: path.to_owned(),
                    what: format!("decompressed size over {} bytes", limits.max_total_bytes),
                });
            }
            file.write_all(&buf[..n]).map_err(io(&out))?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn entry_names_that_escape_are_rejected() {
        for bad in ["../evil.so", "a/../../b", "/etc/passwd", "C:/x", "..\\x"] {
            assert!(safe_relative_path(bad).is_err(), "{bad} accepted");
        }
        assert_eq!(safe_relative_path("binaries/linux64/M.so").unwrap(), PathBuf::from("binaries/linux64/M.so"));
        assert_eq!(safe_relative_path("./resources/a.txt").unwrap(), PathBuf::from("resources/a.txt"));
    }
}
