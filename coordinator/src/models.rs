//! Uploaded models, stored under `<data-dir>/models/<sha256>.fmu`. An upload is streamed to a
//! temporary file, checked by unpacking it (into `<data-dir>/unpacked/<sha256>`) and parsing
//! its model description, and moved into place only when accepted: a rejected upload leaves
//! nothing behind. The store's total size (archives and unpacked files) is capped; opening the
//! store removes what an interrupted upload left. The coordinator never loads FMU binaries.
//!
//! A local run's own model ([`LocalModel`]: an archive its process has already unpacked and
//! checked) is registered through [`ModelStore::register_local`], a Rust call of the process
//! that runs the coordinator: it is described from its unpacked folder and neither copied nor
//! unpacked again. No request names a path: a client names a model only by the id it got back
//! from an upload, or that a registration gave it.

use std::collections::HashMap;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

use fmucal_shared::fmu::{self, Described, LoadOptions};
use sha2::{Digest, Sha256};

use crate::error::CoordinatorError;

/// Default cap on the model store's total size: 20 GiB.
pub const DEFAULT_MAX_STORE_BYTES: u64 = 20 << 30;

/// A model a local run has unpacked and checked already: its archive, the folder it was
/// unpacked into and the archive's SHA-256 (hex), which is its id.
#[derive(Debug, Clone)]
pub struct LocalModel {
    pub archive: PathBuf,
    pub dir: PathBuf,
    pub sha256: String,
}

pub struct ModelStore {
    dir: PathBuf,
    opts: LoadOptions,
    described: HashMap<String, Described>,
    /// Archives of the models registered with [`ModelStore::register_local`], by id.
    local: HashMap<String, PathBuf>,
    /// Cap on archives plus unpacked files, in bytes.
    max_bytes: u64,
    /// What they take now.
    used: u64,
}

/// A temporary upload file, removed when dropped unless it was moved into the store.
pub struct UploadFile {
    path: PathBuf,
}

impl UploadFile {
    pub fn path(&self) -> &Path {
        &self.path
    }
}

impl Drop for UploadFile {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.path);
    }
}

impl ModelStore {
    /// Opens (creating) the store under `data_dir`, capped at `max_bytes`, and removes what
    /// interrupted uploads left: temporary files, half-unpacked folders, and unpacked folders
    /// of models that were never accepted.
    ///
    /// # Errors
    /// I/O errors creating or reading the folders.
    pub fn open(data_dir: &Path, max_bytes: u64) -> Result<Self, CoordinatorError> {
        let dir = data_dir.join("models");
        std::fs::create_dir_all(&dir)?;
        let opts = LoadOptions { cache_dir: data_dir.join("unpacked"), ..Default::default() };
        std::fs::create_dir_all(&opts.cache_dir)?;
        let mut store = ModelStore { dir, opts, described: HashMap::new(), local: HashMap::new(), max_bytes, used: 0 };
        store.remove_leftovers()?;
        store.used = tree_size(&store.dir) + tree_size(&store.opts.cache_dir);
        tracing::debug!(used = store.used, max = max_bytes, "model store opened");
        Ok(store)
    }

    fn remove_leftovers(&self) -> Result<(), CoordinatorError> {
        for entry in std::fs::read_dir(&self.dir)?.flatten() {
            if entry.file_name().to_string_lossy().starts_with('.') {
                tracing::info!(path = %entry.path().display(), "removing an interrupted upload");
                let _ = std::fs::remove_file(entry.path());
            }
        }
        for entry in std::fs::read_dir(&self.opts.cache_dir)?.flatten() {
            let name = entry.file_name().to_string_lossy().into_owned();
            let orphan = name.starts_with('.') || (is_model_id(&name) && !self.path(&name).is_file());
            if orphan {
                tracing::info!(path = %entry.path().display(), "removing an unpacked model that was never accepted");
                let _ = std::fs::remove_dir_all(entry.path());
            }
        }
        Ok(())
    }

    fn path(&self, id: &str) -> PathBuf {
        self.dir.join(format!("{id}.fmu"))
    }

    /// Registers a model the calling process has unpacked and checked already (a local run's),
    /// under its SHA-256: described from its folder, with nothing copied into the store or
    /// unpacked again, and not counted against the store's cap. Returns (id, model name).
    ///
    /// # Errors
    /// INVALID_ARGUMENT if the SHA-256 is not 64 hex digits or the folder holds no usable
    /// model description.
    pub fn register_local(&mut self, model: &LocalModel) -> Result<(String, String), CoordinatorError> {
        if !is_model_id(&model.sha256) {
            return Err(CoordinatorError::InvalidArgument(format!(
                "sha256: {} is not 64 hex digits",
                crate::error::quote(&model.sha256)
            )));
        }
        let d = fmu::describe_unpacked(&model.dir, model.sha256.clone())
            .map_err(|e| CoordinatorError::InvalidArgument(format!("{}: {e}", model.dir.display())))?;
        let name = d.description.model_name.clone();
        self.described.insert(model.sha256.clone(), d);
        self.local.insert(model.sha256.clone(), model.archive.clone());
        Ok((model.sha256.clone(), name))
    }

    /// The archive of a model by id: a registered local model's own file, else the store's.
    fn archive_path(&self, id: &str) -> PathBuf {
        self.local.get(id).cloned().unwrap_or_else(|| self.path(id))
    }

    /// Bytes the store may still take.
    fn room(&self) -> u64 {
        self.max_bytes.saturating_sub(self.used)
    }

    /// Where uploads are streamed to ([`upload_file`]).
    pub fn models_dir(&self) -> PathBuf {
        self.dir.clone()
    }

    /// Stores the bytes (a no-op if already stored) and returns (id, model name).
    ///
    /// # Errors
    /// As [`ModelStore::put_file`].
    pub fn put(&mut self, bytes: &[u8]) -> Result<(String, String), CoordinatorError> {
        let file = upload_file(&self.dir);
        std::fs::write(file.path(), bytes)?;
        self.put_file(file)
    }

    /// Checks an uploaded file and moves it into the store (a no-op if already stored);
    /// returns (id, model name). A rejected file, and what was unpacked from it, is removed.
    ///
    /// # Errors
    /// INVALID_ARGUMENT if the file is not a usable FMU; RESOURCE_EXHAUSTED if it would take
    /// the store past its cap.
    pub fn put_file(&mut self, file: UploadFile) -> Result<(String, String), CoordinatorError> {
        let id = file_sha256(file.path())?;
        if !self.path(&id).is_file() {
            let size = std::fs::metadata(file.path())?.len();
            self.check_room(size)?;
            let unpacked = self.opts.cache_dir.join(&id);
            let checked = fmu::describe(file.path(), &self.opts);
            let unpacked_size = tree_size(&unpacked);
            let refusal = match checked {
                Err(e) => Some(CoordinatorError::InvalidArgument(format!(
                    "the uploaded bytes are not a usable FMU: {}",
                    self.hide_paths(&e.to_string(), file.path())
                ))),
                Ok(_) => self.check_room(size + unpacked_size).err(),
            };
            if let Some(e) = refusal {
                let _ = std::fs::remove_dir_all(&unpacked);
                return Err(e);
            }
            std::fs::rename(file.path(), self.path(&id))?;
            self.used += size + unpacked_size;
        }
        let name = self.describe(&id)?.description.model_name.clone();
        Ok((id, name))
    }

    /// `message` without the coordinator's paths, which a client has no business knowing: the
    /// archive `archive` becomes "the model", a file unpacked from it its path inside the
    /// model, and any other path in the store "the model store".
    fn hide_paths(&self, message: &str, archive: &Path) -> String {
        let mut out = message.replace(&*archive.to_string_lossy(), "the model");
        // An unpacked file: `<unpacked>/<id or .partial folder>/<path in the model>`.
        let unpacked = format!("{}/", self.opts.cache_dir.to_string_lossy());
        while let Some(at) = out.find(&unpacked) {
            let rest = &out[at + unpacked.len()..];
            let skip = rest.find('/').map_or(rest.len(), |slash| slash + 1);
            out = format!("{}{}", &out[..at], &out[at + unpacked.len() + skip..]);
        }
        let data_dir = self.dir.parent().unwrap_or(&self.dir).to_string_lossy().into_owned();
        if data_dir.len() > 1 {
            out = out.replace(&data_dir, "the model store");
        }
        out
    }

    fn check_room(&self, bytes: u64) -> Result<(), CoordinatorError> {
        if bytes > self.room() {
            return Err(CoordinatorError::ResourceExhausted(format!(
                "the model store is full: {} of its {} bytes are used and this model needs {bytes} \
                 (raise the coordinator's --max-store-bytes)",
                self.used, self.max_bytes
            )));
        }
        Ok(())
    }

    /// The description of a stored model.
    pub fn describe(&mut self, id: &str) -> Result<Described, CoordinatorError> {
        if let Some(d) = self.described.get(id) {
            return Ok(d.clone());
        }
        let path = self.path(id);
        if !is_model_id(id) || !path.is_file() {
            return Err(CoordinatorError::InvalidArgument(format!(
                "spec.model_id: unknown model id {}",
                crate::error::quote(id)
            )));
        }
        let d = fmu::describe(&path, &self.opts)
            .map_err(|e| CoordinatorError::InvalidArgument(self.hide_paths(&e.to_string(), &path)))?;
        self.described.insert(id.to_owned(), d.clone());
        Ok(d)
    }

    /// The archive of a stored model, checked as [`ModelStore::describe`] checks it.
    ///
    /// # Errors
    /// INVALID_ARGUMENT for an unknown id or an archive that is not a usable FMU.
    pub fn archive(&mut self, id: &str) -> Result<PathBuf, CoordinatorError> {
        self.describe(id)?;
        Ok(self.archive_path(id))
    }

    /// The bytes of a stored model.
    pub fn bytes(&self, id: &str) -> Result<Arc<Vec<u8>>, CoordinatorError> {
        if !is_model_id(id) {
            return Err(CoordinatorError::NotFound(format!("model {}", crate::error::quote(id))));
        }
        std::fs::read(self.archive_path(id))
            .map(Arc::new)
            .map_err(|_| CoordinatorError::NotFound(format!("model {}", crate::error::quote(id))))
    }
}

/// A new temporary file to stream an upload into, in the store's `models` folder `dir` (so
/// accepting it is a rename); callable without the store's lock, which the check of an earlier
/// upload may hold.
pub fn upload_file(dir: &Path) -> UploadFile {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    UploadFile { path: dir.join(format!(".upload-{}-{n}", std::process::id())) }
}

fn is_model_id(id: &str) -> bool {
    id.len() == 64 && id.bytes().all(|b| b.is_ascii_hexdigit())
}

/// The SHA-256 of a file, read in blocks.
fn file_sha256(path: &Path) -> Result<String, CoordinatorError> {
    let mut file = std::fs::File::open(path)?;
    let mut hasher = Sha256::new();
    let mut block = vec![0u8; 1 << 16];
    loop {
        let n = file.read(&mut block)?;
        if n == 0 {
            break;
        }
        hasher.update(&block[..n]);
    }
    Ok(hasher.finalize().iter().map(|b| format!("{b:02x}")).collect())
}

/// Bytes of the regular files under `path` (0 if it does not exist); symbolic links are not
/// followed.
fn tree_size(path: &Path) -> u64 {
    let Ok(meta) = std::fs::symlink_metadata(path) else { return 0 };
    if !meta.is_dir() {
        return meta.len();
    }
    std::fs::read_dir(path).map_or(0, |entries| entries.flatten().map(|e| tree_size(&e.path())).sum())
}

#[cfg(test)]
mod tests {
    use std::io::Write;

    use super::*;

    /// A zip of `entries`, stored uncompressed unless `deflate`.
    fn zip(entries: &[(&str, Vec<u8>)], deflate: bool) -> Vec<u8> {
        let mut out = std::io::Cursor::new(vec![]);
        let mut w = zip::ZipWriter::new(&mut out);
        let method = if deflate { zip::CompressionMethod::Deflated } else { zip::CompressionMethod::Stored };
        for (name, bytes) in entries {
            w.start_file(*name, zip::write::SimpleFileOptions::default().compression_method(method)).unwrap();
            w.write_all(bytes).unwrap();
        }
        w.finish().unwrap();
        out.into_inner()
    }

    fn names(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> =
            std::fs::read_dir(dir).unwrap().flatten().map(|e| e.file_name().to_string_lossy().into_owned()).collect();
        v.sort();
        v
    }

    #[test]
    fn a_rejected_upload_leaves_nothing_behind() {
        let dir = tempfile::tempdir().unwrap();
        let mut store = ModelStore::open(dir.path(), DEFAULT_MAX_STORE_BYTES).unwrap();
        // 20 MB of zeros that deflate to a few kB, next to a broken model description.
        let bomb =
            zip(&[("modelDescription.xml", b"<fmiModelDescription".to_vec()), ("big.bin", vec![0; 20 << 20])], true);
        assert!(bomb.len() < 1 << 20);
        let e = store.put(&bomb).unwrap_err().to_string();
        assert!(e.contains("not a usable FMU"), "{e}");
        assert!(names(&dir.path().join("unpacked")).is_empty(), "{:?}", names(&dir.path().join("unpacked")));
        assert!(names(&dir.path().join("models")).is_empty());
        assert_eq!(store.used, 0);
    }

    #[test]
    fn an_upload_error_names_no_path_of_the_coordinator() {
        let dir = tempfile::tempdir().unwrap();
        let mut store = ModelStore::open(dir.path(), DEFAULT_MAX_STORE_BYTES).unwrap();
        store.opts.limits.max_total_bytes = 1000;
        let big =
            zip(&[("modelDescription.xml", b"<fmiModelDescription/>".to_vec()), ("big.bin", vec![0; 5000])], true);
        let broken = zip(&[("modelDescription.xml", b"<fmiModelDescription".to_vec())], false);
        for (bytes, what) in
            [(big, "exceeds the unpacking limit"), (broken, "modelDescription.xml"), (b"garbage".to_vec(), "zip")]
        {
            let e = store.put(&bytes).unwrap_err().to_string();
            assert!(e.contains(what), "{e}");
            let root = dir.path().to_string_lossy();
            assert!(!e.contains(&*root) && !e.contains(".upload-") && !e.contains(".partial"), "{e}");
        }
    }

    #[test]
    fn opening_the_store_removes_interrupted_uploads_and_unaccepted_unpacked_models() {
        let dir = tempfile::tempdir().unwrap();
        let (models, unpacked) = (dir.path().join("models"), dir.path().join("unpacked"));
        for d in [&models, &unpacked] {
            std::fs::create_dir_all(d).unwrap();
        }
        let kept = "a".repeat(64);
        std::fs::write(models.join(format!("{kept}.fmu")), b"zip").unwrap();
        std::fs::create_dir_all(unpacked.join(&kept)).unwrap();
        std::fs::write(unpacked.join(&kept).join("modelDescription.xml"), b"<x/>").unwrap();
        std::fs::write(models.join(".upload-7-0"), vec![1; 1000]).unwrap();
        std::fs::create_dir_all(unpacked.join(format!(".{kept}.partial-7-0"))).unwrap();
        std::fs::create_dir_all(unpacked.join("b".repeat(64)).join("binaries")).unwrap();
        let store = ModelStore::open(dir.path(), DEFAULT_MAX_STORE_BYTES).unwrap();
        assert_eq!(names(&models), vec![format!("{kept}.fmu")]);
        assert_eq!(names(&unpacked), vec![kept]);
        assert_eq!(store.used, 3 + 4);
    }

    #[test]
    fn the_store_refuses_a_model_past_its_cap() {
        let dir = tempfile::tempdir().unwrap();
        let bytes = std::fs::read(fmucal_models::example("decay").unwrap()).unwrap();
        let mut store = ModelStore::open(dir.path(), bytes.len() as u64 + 10).unwrap();
        let e = store.put(&bytes).unwrap_err();
        assert!(matches!(e, CoordinatorError::ResourceExhausted(_)), "{e}");
        assert!(e.to_string().contains("the model store is full"), "{e}");
        assert!(names(&dir.path().join("unpacked")).is_empty() && names(&dir.path().join("models")).is_empty());
        let mut store = ModelStore::open(dir.path(), DEFAULT_MAX_STORE_BYTES).unwrap();
        let (id, name) = store.put(&bytes).unwrap();
        assert_eq!(name, "Decay");
        assert!(store.used > bytes.len() as u64, "the unpacked files count too");
        assert_eq!(store.put(&bytes).unwrap().0, id, "a second upload is a no-op");
    }
}
