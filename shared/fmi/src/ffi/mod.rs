//! The C boundary of every FMI version fmucal imports: [`fmi1`] (FMI 1.0 Model Exchange and
//! Co-Simulation, prefixed function names), [`fmi2`] (FMI 2.0, with the C shim for the variadic
//! logger of 1.0 and 2.0) and [`fmi3`] (FMI 3.0). Each loads a binary's entry points and wraps a
//! live instance in a type that implements [`FmiCalls`], the one set of calls the simulator
//! and [`crate::instance`] use whatever the version. All of the project's `unsafe` lives
//! in this module. Status codes are returned raw here and mapped to `Result` by
//! [`crate::instance`].

/// The calls on time and the continuous-state vector, which every version makes alike: one
/// function each, given the instance and a buffer with its length. Expands inside an
/// `impl FmiCalls`, with that module's `call!` and the name of its nominals function.
macro_rules! state_vector_calls {
    ($nominals:ident) => {
        fn set_time(&mut self, t: f64) -> Status {
            call!(self, set_time, t)
        }
        fn set_continuous_states(&mut self, x: &[f64]) -> Status {
            call!(self, set_continuous_states, x.as_ptr(), x.len())
        }
        fn get_derivatives(&mut self, dx: &mut [f64]) -> Status {
            call!(self, get_derivatives, dx.as_mut_ptr(), dx.len())
        }
        fn get_event_indicators(&mut self, z: &mut [f64]) -> Status {
            call!(self, get_event_indicators, z.as_mut_ptr(), z.len())
        }
        fn get_continuous_states(&mut self, x: &mut [f64]) -> Status {
            call!(self, get_continuous_states, x.as_mut_ptr(), x.len())
        }
        fn get_nominals_of_continuous_states(&mut self, x: &mut [f64]) -> Status {
            call!(self, $nominals, x.as_mut_ptr(), x.len())
        }
    };
}

/// `get_real`, `set_real`, `get_integer`, `set_integer` of FMI 1.0 and 2.0, which pass the
/// value references and a buffer of `f64` or `int` straight through.
macro_rules! real_and_integer_calls {
    () => {
        fn get_real(&mut self, vrs: &[u32], out: &mut [f64]) -> Status {
            assert_eq!(vrs.len(), out.len());
            call!(self, get_real, vrs.as_ptr(), vrs.len(), out.as_mut_ptr())
        }
        fn set_real(&mut self, vrs: &[u32], values: &[f64]) -> Status {
            assert_eq!(vrs.len(), values.len());
            call!(self, set_real, vrs.as_ptr(), vrs.len(), values.as_ptr())
        }
        fn get_integer(&mut self, vrs: &[u32], out: &mut [i32]) -> Status {
            assert_eq!(vrs.len(), out.len());
            call!(self, get_integer, vrs.as_ptr(), vrs.len(), out.as_mut_ptr())
        }
        fn set_integer(&mut self, vrs: &[u32], values: &[i32]) -> Status {
            assert_eq!(vrs.len(), values.len());
            call!(self, set_integer, vrs.as_ptr(), vrs.len(), values.as_ptr())
        }
    };
}

pub mod fmi1;
pub mod fmi2;
pub mod fmi3;

use std::ffi::{CStr, c_char, c_int};
use std::path::{Path, PathBuf};
use std::sync::Arc;

use super::schema::ModelDescription;

/// An FMI status code (`fmi2Status`, `fmi3Status`: the same numbers; 3.0 has no Pending).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Status {
    Ok,
    Warning,
    Discard,
    Error,
    Fatal,
    Pending,
}

impl Status {
    pub(crate) fn from_raw(v: c_int) -> Self {
        match v {
            0 => Status::Ok,
            1 => Status::Warning,
            2 => Status::Discard,
            3 => Status::Error,
            5 => Status::Pending,
            _ => Status::Fatal,
        }
    }
}

/// Which interface an instance is created for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FmuType {
    ModelExchange = 0,
    CoSimulation = 1,
}

/// What an event update reports (`fmi2EventInfo`; the out-arguments of
/// `fmi3UpdateDiscreteStates`).
#[repr(C)]
#[derive(Debug, Clone, Copy, Default)]
pub struct EventInfo {
    pub new_discrete_states_needed: c_int,
    pub terminate_simulation: c_int,
    pub nominals_of_continuous_states_changed: c_int,
    pub values_of_continuous_states_changed: c_int,
    pub next_event_time_defined: c_int,
    pub next_event_time: f64,
}

/// Why a binary could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum FfiError {
    #[error("cannot load FMU binary {path}: {message}")]
    Load { path: PathBuf, message: String },
    #[error("FMU binary {path} does not export {symbol}")]
    MissingSymbol { path: PathBuf, symbol: String },
    #[error(
        "FMU binary {path} exports {symbol} without the model identifier prefix: FMI 1.0 requires {expected} (export the functions as <modelIdentifier>_fmiX)"
    )]
    Unprefixed { path: PathBuf, symbol: String, expected: String },
}

/// Texts as C strings (NUL bytes removed) and the array of their pointers, which lives as long
/// as the first.
pub(crate) fn c_strings(values: &[&str]) -> (Vec<std::ffi::CString>, Vec<*const c_char>) {
    let owned: Vec<std::ffi::CString> =
        values.iter().map(|v| std::ffi::CString::new(v.replace('\0', "")).unwrap_or_default()).collect();
    let pointers = owned.iter().map(|c| c.as_ptr()).collect();
    (owned, pointers)
}

pub(crate) fn lossy(p: *const c_char) -> String {
    if p.is_null() {
        return String::new();
    }
    // SAFETY: FMUs and the shim pass NUL-terminated strings that live for the duration of the call.
    unsafe { CStr::from_ptr(p) }.to_string_lossy().into_owned()
}

/// The calls fmucal makes on a live FMU instance, whatever its FMI version. Names follow FMI
/// 2.0; an FMI 3.0 instance maps each to its counterpart (`get_real` to `fmi3GetFloat64` or
/// `fmi3GetFloat32` by the variable's type, `new_discrete_states` to
/// `fmi3UpdateDiscreteStates`, the experiment of `setup_experiment` to the arguments of
/// `fmi3EnterInitializationMode`, ...). Value references are fmucal's: an element of an FMI 3.0
/// array has its own (see [`crate::schema::Fmi3Storage`]).
pub trait FmiCalls {
    /// Messages the FMU logged at warning level or worse since the last call.
    fn take_log(&self) -> Vec<String>;
    fn set_debug_logging(&mut self, on: bool) -> Status;
    fn setup_experiment(&mut self, tolerance: Option<f64>, start: f64, stop: Option<f64>) -> Status;
    fn enter_initialization_mode(&mut self) -> Status;
    fn exit_initialization_mode(&mut self) -> Status;
    fn terminate(&mut self) -> Status;
    fn reset(&mut self) -> Status;
    fn get_real(&mut self, vrs: &[u32], out: &mut [f64]) -> Status;
    fn set_real(&mut self, vrs: &[u32], values: &[f64]) -> Status;
    fn get_integer(&mut self, vrs: &[u32], out: &mut [i32]) -> Status;
    fn set_integer(&mut self, vrs: &[u32], values: &[i32]) -> Status;
    fn get_boolean(&mut self, vrs: &[u32], out: &mut [i32]) -> Status;
    fn set_boolean(&mut self, vrs: &[u32], values: &[i32]) -> Status;
    /// Sets String variables (NUL bytes are removed; the FMU copies the text in the call).
    fn set_string(&mut self, vrs: &[u32], values: &[&str]) -> Status;
    /// Sets Binary variables, which only FMI 3.0 has.
    fn set_binary(&mut self, vrs: &[u32], values: &[&[u8]]) -> Status;
    fn enter_event_mode(&mut self) -> Status;
    fn new_discrete_states(&mut self, info: &mut EventInfo) -> Status;
    fn enter_continuous_time_mode(&mut self) -> Status;
    /// Returns (status, enterEventMode, terminateSimulation).
    fn completed_integrator_step(&mut self) -> (Status, bool, bool);
    fn set_time(&mut self, t: f64) -> Status;
    fn set_continuous_states(&mut self, x: &[f64]) -> Status;
    fn get_derivatives(&mut self, dx: &mut [f64]) -> Status;
    fn get_event_indicators(&mut self, z: &mut [f64]) -> Status;
    fn get_continuous_states(&mut self, x: &mut [f64]) -> Status;
    fn get_nominals_of_continuous_states(&mut self, x: &mut [f64]) -> Status;
    fn do_step(&mut self, t: f64, h: f64) -> Status;
    /// Whether the FMU ended the simulation in its last step, if it can tell.
    fn terminated(&mut self) -> Option<bool>;
    /// The time a step that did not complete reached, if the FMU can tell.
    fn last_successful_time(&mut self) -> Option<f64>;
}

/// A live instance of any FMI version; freed when dropped.
pub type Component = Box<dyn FmiCalls>;

/// The resolved entry points of one binary, by FMI version (cheap to clone).
#[derive(Clone)]
pub enum Api {
    Fmi1(Arc<fmi1::Api>),
    Fmi2(Arc<fmi2::Api>),
    Fmi3(Arc<fmi3::Api>),
}

impl Api {
    /// Loads the binary at `path` for the FMI version of `description` and resolves the entry
    /// points of the requested interfaces.
    ///
    /// # Errors
    /// [`FfiError::Load`] if the library cannot be opened, [`FfiError::MissingSymbol`] naming the
    /// first required function that is not exported.
    pub fn load(
        path: &Path,
        description: &ModelDescription,
        model_identifier: &str,
        me: bool,
        cs: bool,
    ) -> Result<Api, FfiError> {
        if description.fmi_version.starts_with("3.") {
            Ok(Api::Fmi3(fmi3::Api::load(path, me, cs)?))
        } else if description.fmi_version.starts_with("1.") {
            Ok(Api::Fmi1(fmi1::Api::load(path, model_identifier, cs && !me)?))
        } else {
            Ok(Api::Fmi2(fmi2::Api::load(path, model_identifier, me, cs)?))
        }
    }

    /// `fmiXGetVersion()`, e.g. "2.0" or "3.0".
    pub fn version(&self) -> String {
        match self {
            Api::Fmi1(api) => api.version(),
            Api::Fmi2(api) => api.version(),
            Api::Fmi3(api) => api.version(),
        }
    }

    /// Whether an instance for `interface` can be reset (FMI 1.0 Model Exchange has no reset).
    pub fn can_reset(&self, interface: super::Interface) -> bool {
        !matches!((self, interface), (Api::Fmi1(_), super::Interface::ModelExchange))
    }

    /// The name of the function that instantiates `interface` in this version.
    pub fn instantiate_function(&self, interface: super::Interface) -> &'static str {
        match (self, interface) {
            (Api::Fmi1(_), super::Interface::ModelExchange) => "fmiInstantiateModel",
            (Api::Fmi1(_), super::Interface::CoSimulation) => "fmiInstantiateSlave",
            (Api::Fmi2(_), _) => "fmi2Instantiate",
            (Api::Fmi3(_), super::Interface::ModelExchange) => "fmi3InstantiateModelExchange",
            (Api::Fmi3(_), super::Interface::CoSimulation) => "fmi3InstantiateCoSimulation",
        }
    }

    /// The name in this version of the FMI 2.0 function `fmi2_name` (what error messages say).
    pub fn function_name(&self, fmi2_name: &'static str) -> &'static str {
        match self {
            Api::Fmi2(_) => fmi2_name,
            Api::Fmi1(_) => fmi1_name(fmi2_name),
            Api::Fmi3(_) => fmi3_name(fmi2_name),
        }
    }

    /// Path of the loaded binary.
    pub fn path(&self) -> &Path {
        match self {
            Api::Fmi1(api) => api.path(),
            Api::Fmi2(api) => api.path(),
            Api::Fmi3(api) => api.path(),
        }
    }
}

/// The FMI 1.0 function that does what the FMI 2.0 function `fmi2_name` does.
fn fmi1_name(fmi2_name: &'static str) -> &'static str {
    match fmi2_name {
        "fmi2SetupExperiment" | "fmi2EnterInitializationMode" | "fmi2SetTime" => "fmiSetTime",
        "fmi2ExitInitializationMode" => "fmiInitialize",
        "fmi2Terminate" => "fmiTerminate",
        "fmi2GetReal" => "fmiGetReal",
        "fmi2SetReal" => "fmiSetReal",
        "fmi2GetInteger" => "fmiGetInteger",
        "fmi2SetInteger" => "fmiSetInteger",
        "fmi2GetBoolean" => "fmiGetBoolean",
        "fmi2SetBoolean" => "fmiSetBoolean",
        "fmi2SetString" => "fmiSetString",
        "fmi2EnterEventMode" | "fmi2NewDiscreteStates" | "fmi2EnterContinuousTimeMode" => "fmiEventUpdate",
        "fmi2CompletedIntegratorStep" => "fmiCompletedIntegratorStep",
        "fmi2SetContinuousStates" => "fmiSetContinuousStates",
        "fmi2GetDerivatives" => "fmiGetDerivatives",
        "fmi2GetEventIndicators" => "fmiGetEventIndicators",
        "fmi2GetContinuousStates" => "fmiGetContinuousStates",
        "fmi2GetNominalsOfContinuousStates" => "fmiGetNominalContinuousStates",
        "fmi2DoStep" => "fmiDoStep",
        other => other,
    }
}

/// The FMI 3.0 function that does what the FMI 2.0 function `fmi2_name` does.
fn fmi3_name(fmi2_name: &'static str) -> &'static str {
    match fmi2_name {
        "fmi2SetupExperiment" | "fmi2EnterInitializationMode" => "fmi3EnterInitializationMode",
        "fmi2ExitInitializationMode" => "fmi3ExitInitializationMode",
        "fmi2Terminate" => "fmi3Terminate",
        "fmi2GetReal" => "fmi3GetFloat64",
        "fmi2SetReal" => "fmi3SetFloat64",
        "fmi2GetInteger" => "fmi3GetInt32",
        "fmi2SetInteger" => "fmi3SetInt32",
        "fmi2GetBoolean" => "fmi3GetBoolean",
        "fmi2SetBoolean" => "fmi3SetBoolean",
        "fmi2SetString" => "fmi3SetString",
        "fmi2EnterEventMode" => "fmi3EnterEventMode",
        "fmi2NewDiscreteStates" => "fmi3UpdateDiscreteStates",
        "fmi2EnterContinuousTimeMode" => "fmi3EnterContinuousTimeMode",
        "fmi2CompletedIntegratorStep" => "fmi3CompletedIntegratorStep",
        "fmi2SetTime" => "fmi3SetTime",
        "fmi2SetContinuousStates" => "fmi3SetContinuousStates",
        "fmi2GetDerivatives" => "fmi3GetContinuousStateDerivatives",
        "fmi2GetEventIndicators" => "fmi3GetEventIndicators",
        "fmi2GetContinuousStates" => "fmi3GetContinuousStates",
        "fmi2GetNominalsOfContinuousStates" => "fmi3GetNominalsOfContinuousStates",
        "fmi2DoStep" => "fmi3DoStep",
        other => other,
    }
}

impl Api {
    /// Creates an instance. `resources` is the unpacked `resources/` folder (passed as a
    /// `file://` URI to FMI 2.0, as a path with a trailing separator to FMI 3.0). Returns the
    /// FMU's messages if it would not instantiate.
    pub fn instantiate(
        &self,
        description: &ModelDescription,
        instance_name: &str,
        kind: FmuType,
        resources: &Path,
        logging_on: bool,
    ) -> Result<Component, Vec<String>> {
        match self {
            Api::Fmi1(api) => {
                let fmu_dir = resources.parent().unwrap_or(resources);
                fmi1::Component::instantiate(api.clone(), instance_name, kind, &description.guid, fmu_dir, logging_on)
                    .map(|c| Box::new(c) as Component)
            }
            Api::Fmi2(api) => {
                let uri = file_uri(resources);
                fmi2::Component::instantiate(api.clone(), instance_name, kind, &description.guid, &uri, logging_on)
                    .map(|c| Box::new(c) as Component)
            }
            Api::Fmi3(api) => {
                fmi3::Instance::instantiate(api.clone(), description, instance_name, kind, resources, logging_on)
                    .map(|c| Box::new(c) as Component)
            }
        }
    }
}

/// `file://` URI of a folder, percent-encoded, as `fmi2Instantiate` expects.
pub fn file_uri(dir: &Path) -> String {
    let mut uri = String::from("file://");
    for b in dir.to_string_lossy().bytes() {
        match b {
            b'A'..=b'Z' | b'a'..=b'z' | b'0'..=b'9' | b'/' | b'-' | b'_' | b'.' | b'~' => uri.push(b as char),
            _ => uri.push_str(&format!("%{b:02X}")),
        }
    }
    uri
}
