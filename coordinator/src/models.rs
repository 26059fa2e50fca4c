//! Uploaded models, stored under `<data-dir>/models/<sha256>.fmu`. An upload is checked by
//! unpacking it and parsing its model description; the coordinator never loads FMU binaries.

use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::Arc;

use fmucal_shared::fmu::{self, Described, LoadOptions, archive};

use crate::error::CoordinatorError;

pub struct ModelStore {
    dir: PathBuf,
    opts: LoadOptions,
    described: HashMap<String, Described>,
}

impl ModelStore {
    pub fn open(data_dir: &std::path::Path) -> Result<Self, CoordinatorError> {
        let dir = data_dir.join("models");
        std::fs::create_dir_all(&dir)?;
        let opts = LoadOptions { cache_dir: data_dir.join("unpacked"), ..Default::default() };
        Ok(ModelStore { dir, opts, described: HashMap::new() })
    }

    fn path(&self, id: &str) -> PathBuf {
        self.dir.join(format!("{id}.fmu"))
    }

    /// Stores the bytes (a no-op if already stored) and returns (id, model name).
    pub fn put(&mut self, bytes: &[u8]) -> Result<(String, String), CoordinatorError> {
        let id = archive::sha256_hex(bytes);
        if !self.path(&id).is_file() {
            let tmp = self.dir.join(format!(".{id}.upload"));
            std::fs::write(&tmp, bytes)?;
            match fmu::describe(&tmp, &self.opts) {
                Ok(_) => std::fs::rename(&tmp, self.path(&id))?,
                Err(e) => {
                    let _ = std::fs::remove_file(&tmp);
                    return Err(CoordinatorError::InvalidArgument(format!(
                        "the uploaded bytes are not a usable FMU: {e}"
                    )));
                }
            }
        }
        let name = self.describe(&id)?.description.model_name.clone();
        Ok((id, name))
    }

    /// The description of a stored model.
    pub fn describe(&mut self, id: &str) -> Result<Described, CoordinatorError> {
        if let Some(d) = self.described.get(id) {
            return Ok(d.clone());
        }
        let path = self.path(id);
        if !is_model_id(id) || !path.is_file() {
            return Err(CoordinatorError::InvalidArgument(format!("spec.model_id: unknown model id {id:?}")));
        }
        let d = fmu::describe(&path, &self.opts).map_err(|e| CoordinatorError::InvalidArgument(e.to_string()))?;
        self.described.insert(id.to_owned(), d.clone());
        Ok(d)
    }

    /// The archive of a stored model, checked as [`ModelStore::describe`] checks it.
    ///
    /// # Errors
    /// INVALID_ARGUMENT for an unknown id or an archive that is not a usable FMU.
    pub fn archive(&mut self, id: &str) -> Result<PathBuf, CoordinatorError> {
        self.describe(id)?;
        Ok(self.path(id))
    }

    /// The bytes of a stored model.
    pub fn bytes(&self, id: &str) -> Result<Arc<Vec<u8>>, CoordinatorError> {
        if !is_model_id(id) {
            return Err(CoordinatorError::NotFound(format!("model {id:?}")));
        }
        std::fs::read(self.path(id)).map(Arc::new).map_err(|_| CoordinatorError::NotFound(format!("model {id:?}")))
    }
}

fn is_model_id(id: &str) -> bool {
    id.len() == 64 && id.bytes().all(|b| b.is_ascii_hexdigit())
}
