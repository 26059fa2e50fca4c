//! The FMI runtime, a leaf crate (it knows no simulation, job or optimizer): loading FMI 1.0,
//! 2.0 and 3.0 FMUs. [`archive`] unpacks the zip safely, [`schema`] reads
//! `modelDescription.xml` of any version into one [`ModelDescription`], [`ffi`] loads the
//! platform binary and holds every `unsafe` call behind one instance trait ([`ffi::FmiCalls`]),
//! [`log`] takes what an instance logs, [`instance`] wraps one live FMU instance with `Drop`
//! and `reset()`, and [`quote`] bounds and escapes the user text an error quotes (every crate
//! above uses it).

#![deny(unsafe_code)]

pub mod archive;
// Every `unsafe` block of the libraries is in this module.
#[allow(unsafe_code)]
pub mod ffi;
pub mod instance;
pub mod log;
pub mod quote;
pub mod schema;

use std::path::{Path, PathBuf};
use std::sync::Arc;

pub use archive::{ArchiveError, ArchiveLimits};
pub use ffi::{FfiError, Status};
pub use instance::Instance;
pub use schema::{ModelDescription, SchemaError};

/// FMI interface of an instance.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub enum Interface {
    ModelExchange,
    CoSimulation,
}

impl std::fmt::Display for Interface {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Interface::ModelExchange => "Model Exchange",
            Interface::CoSimulation => "Co-Simulation",
        })
    }
}

/// Everything that can go wrong while loading or driving an FMU.
#[derive(Debug, thiserror::Error)]
pub enum FmuError {
    #[error(transparent)]
    Archive(#[from] ArchiveError),
    #[error(transparent)]
    Schema(#[from] SchemaError),
    #[error(transparent)]
    Ffi(#[from] FfiError),
    #[error("cannot read {path}: {message}")]
    Read { path: PathBuf, message: String },
    #[error("FMU has no {platform} binary {expected} (platforms present: {present})")]
    NoPlatformBinary { platform: &'static str, expected: String, present: String },
    #[error("FMU does not offer {0}")]
    NoInterface(Interface),
    #[error("FMU {model} needs its execution tool (needsExecutionTool=true), which fmucal cannot provide")]
    NeedsExecutionTool { model: String },
    #[error("FMU {model} can be instantiated only once per process and an instance is already live")]
    OnlyOncePerProcess { model: String },
    #[error("{function} of {model} failed{}", fmt_messages(.messages))]
    Instantiate { function: &'static str, model: String, messages: Vec<String> },
    #[error("{function} returned {status:?} at t={time}{}", fmt_messages(.messages))]
    Call { function: &'static str, status: Status, time: f64, messages: Vec<String> },
}

fn fmt_messages(m: &[String]) -> String {
    if m.is_empty() { String::new() } else { format!(": {}", m.join("; ")) }
}

/// The platform folder name of this build under `binaries/`.
pub const PLATFORM: &str = if cfg!(all(target_os = "linux", target_pointer_width = "64")) {
    "linux64"
} else if cfg!(target_os = "linux") {
    "linux32"
} else if cfg!(target_os = "macos") {
    "darwin64"
} else if cfg!(target_pointer_width = "64") {
    "win64"
} else {
    "win32"
};

const LIB_EXT: &str = if cfg!(target_os = "macos") {
    "dylib"
} else if cfg!(windows) {
    "dll"
} else {
    "so"
};

/// Options for [`Fmu::load_with`].
#[derive(Debug, Clone)]
pub struct LoadOptions {
    /// Where archives are unpacked. Default: [`archive::default_cache_dir`].
    pub cache_dir: PathBuf,
    /// Unpacking limits. Default: [`ArchiveLimits::from_env`].
    pub limits: ArchiveLimits,
}

impl Default for LoadOptions {
    fn default() -> Self {
        Self { cache_dir: archive::default_cache_dir(), limits: ArchiveLimits::from_env() }
    }
}

/// A loaded FMU: its description, unpacked files and resolved binaries.
pub struct Fmu {
    pub description: Arc<ModelDescription>,
    /// SHA-256 of the archive, hex.
    pub sha256: String,
    /// Directory the archive was unpacked into.
    pub dir: PathBuf,
    me: Option<ffi::Api>,
    cs: Option<ffi::Api>,
}

impl std::fmt::Debug for Fmu {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Fmu").field("model", &self.description.model_name).field("dir", &self.dir).finish()
    }
}

impl Fmu {
    /// Loads an `.fmu` with default options.
    ///
    /// # Errors
    /// See [`Fmu::load_with`].
    pub fn load(path: &Path) -> Result<Self, FmuError> {
        Self::load_with(path, &LoadOptions::default())
    }

    /// Unpacks (or reuses the cached copy of) the archive, parses its model description and
    /// loads the binaries of every interface it declares.
    ///
    /// # Errors
    /// [`FmuError::Archive`] for unsafe or corrupt archives, [`FmuError::Schema`] for bad or
    /// unsupported descriptions, [`FmuError::NoPlatformBinary`] when no binary for this platform
    /// exists, [`FmuError::Ffi`] when the binary cannot be loaded or misses a function.
    pub fn load_with(path: &Path, opts: &LoadOptions) -> Result<Self, FmuError> {
        let unpacked = archive::unpack(path, &opts.cache_dir, &opts.limits)?;
        Self::open_unpacked(&unpacked.dir, unpacked.sha256)
    }

    /// Opens an FMU already unpacked into `dir` (as an importing tool unpacks the FMU that
    /// `fmucal export` writes, with the original inside): parses its model description and
    /// loads the binaries of every interface it declares. `sha256` identifies it in logs.
    ///
    /// # Errors
    /// As [`Fmu::load_with`], but for the archive.
    pub fn open_unpacked(dir: &Path, sha256: String) -> Result<Self, FmuError> {
        let unpacked = archive::Unpacked { dir: dir.to_path_buf(), sha256 };
        let md_path = unpacked.dir.join("modelDescription.xml");
        let xml =
            std::fs::read(&md_path).map_err(|e| FmuError::Read { path: md_path.clone(), message: e.to_string() })?;
        let xml = String::from_utf8(xml)
            .map_err(|_| FmuError::Read { path: md_path.clone(), message: "not UTF-8".into() })?;
        let description = Arc::new(ModelDescription::parse(&xml)?);
        for info in [&description.model_exchange, &description.co_simulation].into_iter().flatten() {
            if info.needs_execution_tool {
                return Err(FmuError::NeedsExecutionTool { model: description.model_name.clone() });
            }
        }
        let me_id = description.model_exchange.as_ref().map(|i| i.model_identifier.clone());
        let cs_id = description.co_simulation.as_ref().map(|i| i.model_identifier.clone());
        let load = |id: &str, me: bool, cs: bool| -> Result<ffi::Api, FmuError> {
            let bin = binary_path(&unpacked.dir, &description, id)?;
            Ok(ffi::Api::load(&bin, &description, id, me, cs)?)
        };
        let (me, cs) = match (&me_id, &cs_id) {
            (Some(a), Some(b)) if a == b => {
                let api = load(a, true, true)?;
                (Some(api.clone()), Some(api))
            }
            _ => (
                me_id.as_deref().map(|id| load(id, true, false)).transpose()?,
                cs_id.as_deref().map(|id| load(id, false, true)).transpose()?,
            ),
        };
        Ok(Fmu { description, sha256: unpacked.sha256, dir: unpacked.dir, me, cs })
    }

    /// Whether the description says `interface` can be instantiated only once per process
    /// (`canBeInstantiatedOnlyOncePerProcess`): its evaluations then share one thread.
    pub fn once_per_process(&self, interface: Interface) -> bool {
        let info = match interface {
            Interface::ModelExchange => self.description.model_exchange.as_ref(),
            Interface::CoSimulation => self.description.co_simulation.as_ref(),
        };
        info.is_some_and(|i| i.can_be_instantiated_only_once_per_process)
    }

    /// Interfaces this FMU offers, Model Exchange first.
    pub fn interfaces(&self) -> Vec<Interface> {
        let mut v = vec![];
        if self.me.is_some() {
            v.push(Interface::ModelExchange);
        }
        if self.cs.is_some() {
            v.push(Interface::CoSimulation);
        }
        v
    }

    pub(crate) fn api(&self, interface: Interface) -> Result<ffi::Api, FmuError> {
        match interface {
            Interface::ModelExchange => self.me.clone(),
            Interface::CoSimulation => self.cs.clone(),
        }
        .ok_or(FmuError::NoInterface(interface))
    }

    /// The unpacked `resources/` folder.
    pub fn resources_dir(&self) -> PathBuf {
        self.dir.join("resources")
    }

    /// `file://` URI of the unpacked `resources/` folder, as `fmi2Instantiate` expects.
    pub fn resource_uri(&self) -> String {
        ffi::file_uri(&self.resources_dir())
    }
}

/// An FMU's description, read without loading its binary (for processes that must not run
/// model code, such as the coordinator).
#[derive(Debug, Clone)]
pub struct Described {
    pub description: Arc<ModelDescription>,
    pub sha256: String,
    /// Interfaces declared in the description, Model Exchange first.
    pub interfaces: Vec<Interface>,
    /// Platform folders under `binaries/` that hold at least one file, sorted.
    pub platforms: Vec<String>,
    /// The binaries this build would load (`binaries/<PLATFORM>/<modelIdentifier>.<ext>`, one
    /// per declared model identifier) that the archive lacks.
    pub missing_binaries: Vec<String>,
}

/// Unpacks (or reuses) `path` and parses its model description; no native code is loaded.
///
/// # Errors
/// As [`Fmu::load_with`], except binary errors.
pub fn describe(path: &Path, opts: &LoadOptions) -> Result<Described, FmuError> {
    let unpacked = archive::unpack(path, &opts.cache_dir, &opts.limits)?;
    describe_unpacked(&unpacked.dir, unpacked.sha256)
}

/// [`describe`] of an archive already unpacked into `dir` (by [`archive::unpack`], whose
/// SHA-256 `sha256` was): nothing is unpacked again and no native code is loaded.
///
/// # Errors
/// As [`describe`], except archive errors.
pub fn describe_unpacked(dir: &Path, sha256: String) -> Result<Described, FmuError> {
    let unpacked = archive::Unpacked { dir: dir.to_path_buf(), sha256 };
    let md_path = unpacked.dir.join("modelDescription.xml");
    let xml = std::fs::read(&md_path).map_err(|e| FmuError::Read { path: md_path.clone(), message: e.to_string() })?;
    let xml =
        String::from_utf8(xml).map_err(|_| FmuError::Read { path: md_path.clone(), message: "not UTF-8".into() })?;
    let description = Arc::new(ModelDescription::parse(&xml)?);
    let mut interfaces = vec![];
    if description.model_exchange.is_some() {
        interfaces.push(Interface::ModelExchange);
    }
    if description.co_simulation.is_some() {
        interfaces.push(Interface::CoSimulation);
    }
    let platforms = platforms(&unpacked.dir);
    let mut missing_binaries: Vec<String> = [&description.model_exchange, &description.co_simulation]
        .into_iter()
        .flatten()
        .map(|info| binary_in_archive(&description, &info.model_identifier))
        .filter(|rel| !unpacked.dir.join(rel).is_file())
        .collect();
    missing_binaries.dedup();
    Ok(Described { description, sha256: unpacked.sha256, interfaces, platforms, missing_binaries })
}

/// Platform folders under `dir/binaries` that hold at least one regular file (an empty
/// `binaries/linux64/` counts as absent), sorted.
fn platforms(dir: &Path) -> Vec<String> {
    let has_file = |p: &Path| {
        std::fs::read_dir(p)
            .map(|rd| rd.filter_map(|e| e.ok()).any(|e| e.file_type().is_ok_and(|t| t.is_file())))
            .unwrap_or(false)
    };
    let mut found: Vec<String> = std::fs::read_dir(dir.join("binaries"))
        .map(|rd| {
            rd.filter_map(|e| e.ok())
                .filter(|e| e.file_type().is_ok_and(|t| t.is_dir()) && has_file(&e.path()))
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .collect()
        })
        .unwrap_or_default();
    found.sort();
    found
}

/// The platform folder under `binaries/` of this build for an FMU of `description`'s version:
/// FMI 2.0's `linux64`, or FMI 3.0's platform tuple (`x86_64-linux`).
pub fn platform_folder(description: &ModelDescription) -> &'static str {
    if description.fmi_version.starts_with("3.") { PLATFORM_TUPLE } else { PLATFORM }
}

/// The FMI 3.0 platform tuple of this build.
pub const PLATFORM_TUPLE: &str = if cfg!(all(target_arch = "x86_64", target_os = "linux")) {
    "x86_64-linux"
} else if cfg!(all(target_arch = "aarch64", target_os = "linux")) {
    "aarch64-linux"
} else if cfg!(all(target_arch = "x86", target_os = "linux")) {
    "x86-linux"
} else if cfg!(all(target_arch = "x86_64", target_os = "macos")) {
    "x86_64-darwin"
} else if cfg!(all(target_arch = "aarch64", target_os = "macos")) {
    "aarch64-darwin"
} else if cfg!(all(target_arch = "x86_64", windows)) {
    "x86_64-windows"
} else {
    "x86-windows"
};

/// Where the binary this build loads for `identifier` sits inside an FMU archive.
fn binary_in_archive(description: &ModelDescription, identifier: &str) -> String {
    format!("binaries/{}/{identifier}.{LIB_EXT}", platform_folder(description))
}

fn binary_path(dir: &Path, description: &ModelDescription, identifier: &str) -> Result<PathBuf, FmuError> {
    let expected = binary_in_archive(description, identifier);
    let path = dir.join(&expected);
    if path.is_file() {
        return Ok(path);
    }
    let present = platforms(dir);
    let present = if present.is_empty() { "none".to_owned() } else { present.join(", ") };
    Err(FmuError::NoPlatformBinary { platform: platform_folder(description), expected, present })
}
