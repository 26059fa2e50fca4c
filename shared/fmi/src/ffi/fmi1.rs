//! FMI 1.0: the libloading symbol tables of Model Exchange 1.0 and Co-Simulation 1.0 (every
//! function prefixed with the model identifier, `Furuta_fmiGetReal`), and [`Component`], the
//! wrapper of one `fmiComponent` whose methods are the only calls into FMI 1.0 FMU code. It
//! maps fmucal's calls ([`FmiCalls`], named after FMI 2.0) to 1.0: initialisation is
//! `fmiInitialize` (which also iterates the first event) or `fmiInitializeSlave`, an event
//! update is `fmiEventUpdate`, Booleans are `char`, and a Model Exchange instance has no reset
//! (so [`crate::instance`] instantiates it again). The 1.0 logger is variadic as in 2.0
//! and goes through the same C shim, but passes the component rather than an environment
//! pointer: while fmucal calls into an instance, that instance's log is the thread's current
//! one ([`CURRENT_LOG`]).

use std::cell::Cell;
use std::ffi::{CString, c_char, c_int, c_uint, c_void};
use std::path::{Path, PathBuf};
use std::sync::Arc;

use super::fmi2::{fmucal_calloc, fmucal_free, fmucal_logger_fmi1, install_log_sink};
use super::{EventInfo, FfiError, FmiCalls, FmuType, Status, lossy};
use crate::log::InstanceLog;

thread_local! {
    /// The log of the FMI 1.0 instance this thread is calling into (null between calls).
    pub(super) static CURRENT_LOG: Cell<*const InstanceLog> = const { Cell::new(std::ptr::null()) };
}

/// Makes `log` the thread's current log while it lives.
struct LogScope(*const InstanceLog);

impl LogScope {
    fn enter(log: &InstanceLog) -> Self {
        LogScope(CURRENT_LOG.with(|c| c.replace(log as *const InstanceLog)))
    }
}

impl Drop for LogScope {
    fn drop(&mut self) {
        CURRENT_LOG.with(|c| c.set(self.0));
    }
}

/// `fmiCallbackFunctions` of Model Exchange 1.0.
#[repr(C)]
struct MeCallbacks {
    logger: *const c_void,
    allocate_memory: unsafe extern "C" fn(usize, usize) -> *mut c_void,
    free_memory: unsafe extern "C" fn(*mut c_void),
}

/// `fmiCallbackFunctions` of Co-Simulation 1.0.
#[repr(C)]
struct CsCallbacks {
    logger: *const c_void,
    allocate_memory: unsafe extern "C" fn(usize, usize) -> *mut c_void,
    free_memory: unsafe extern "C" fn(*mut c_void),
    step_finished: *const c_void,
}

/// `fmiEventInfo` of FMI 1.0.
#[repr(C)]
#[derive(Default)]
struct EventInfo1 {
    iteration_converged: c_char,
    state_value_references_changed: c_char,
    state_values_changed: c_char,
    terminate_simulation: c_char,
    upcoming_time_event: c_char,
    next_event_time: f64,
}

impl EventInfo1 {
    fn to_event_info(&self) -> EventInfo {
        EventInfo {
            new_discrete_states_needed: c_int::from(self.iteration_converged == 0),
            terminate_simulation: c_int::from(self.terminate_simulation != 0),
            nominals_of_continuous_states_changed: c_int::from(self.state_value_references_changed != 0),
            values_of_continuous_states_changed: c_int::from(self.state_values_changed != 0),
            next_event_time_defined: c_int::from(self.upcoming_time_event != 0),
            next_event_time: self.next_event_time,
        }
    }
}

type Comp = *mut c_void;
type InstantiateModel = unsafe extern "C" fn(*const c_char, *const c_char, MeCallbacks, c_char) -> Comp;
type InstantiateSlave = unsafe extern "C" fn(
    *const c_char,
    *const c_char,
    *const c_char,
    *const c_char,
    f64,
    c_char,
    c_char,
    CsCallbacks,
    c_char,
) -> Comp;
type Free = unsafe extern "C" fn(Comp);
type Str = unsafe extern "C" fn() -> *const c_char;
type Call = unsafe extern "C" fn(Comp) -> c_int;
type SetDebugLogging = unsafe extern "C" fn(Comp, c_char) -> c_int;
type Initialize = unsafe extern "C" fn(Comp, c_char, f64, *mut EventInfo1) -> c_int;
type EventUpdate = unsafe extern "C" fn(Comp, c_char, *mut EventInfo1) -> c_int;
type InitializeSlave = unsafe extern "C" fn(Comp, f64, c_char, f64) -> c_int;
type GetReal = unsafe extern "C" fn(Comp, *const c_uint, usize, *mut f64) -> c_int;
type SetReal = unsafe extern "C" fn(Comp, *const c_uint, usize, *const f64) -> c_int;
type GetInt = unsafe extern "C" fn(Comp, *const c_uint, usize, *mut c_int) -> c_int;
type SetInt = unsafe extern "C" fn(Comp, *const c_uint, usize, *const c_int) -> c_int;
type GetBool = unsafe extern "C" fn(Comp, *const c_uint, usize, *mut c_char) -> c_int;
type SetBool = unsafe extern "C" fn(Comp, *const c_uint, usize, *const c_char) -> c_int;
type SetString = unsafe extern "C" fn(Comp, *const c_uint, usize, *const *const c_char) -> c_int;
type CompletedIntegratorStep = unsafe extern "C" fn(Comp, *mut c_char) -> c_int;
type SetTime = unsafe extern "C" fn(Comp, f64) -> c_int;
type SetArray = unsafe extern "C" fn(Comp, *const f64, usize) -> c_int;
type GetArray = unsafe extern "C" fn(Comp, *mut f64, usize) -> c_int;
type DoStep = unsafe extern "C" fn(Comp, f64, f64, c_char) -> c_int;
type GetRealStatus = unsafe extern "C" fn(Comp, c_int, *mut f64) -> c_int;

#[derive(Clone, Copy, PartialEq, Eq)]
enum Need {
    /// Both function sets have it.
    Both,
    ModelExchange,
    CoSimulation,
    Optional,
}

macro_rules! fmi1_api {
    ($( $field:ident : $sym:literal => $ty:ty, $need:ident ),* $(,)?) => {
        /// Resolved FMI 1.0 entry points of one binary, for Model Exchange or Co-Simulation
        /// (an FMI 1.0 FMU offers one of them).
        #[allow(dead_code)] // every symbol is resolved to check the binary, not all are called
        pub struct Api {
            $( $field: Option<$ty>, )*
            co_simulation: bool,
            path: PathBuf,
            _lib: libloading::Library,
        }

        impl Api {
            fn resolve(lib: libloading::Library, path: &Path, prefix: &str, cs: bool) -> Result<Self, FfiError> {
                $( let $field: Option<$ty> = lookup(&lib, path, prefix, $sym, Need::$need, cs)?; )*
                Ok(Api { $( $field, )* co_simulation: cs, path: path.to_owned(), _lib: lib })
            }
        }
    };
}

fmi1_api! {
    get_version: "fmiGetVersion" => Str, Both,
    set_debug_logging: "fmiSetDebugLogging" => SetDebugLogging, Both,
    get_real: "fmiGetReal" => GetReal, Both,
    set_real: "fmiSetReal" => SetReal, Both,
    get_integer: "fmiGetInteger" => GetInt, Both,
    set_integer: "fmiSetInteger" => SetInt, Both,
    get_boolean: "fmiGetBoolean" => GetBool, Both,
    set_boolean: "fmiSetBoolean" => SetBool, Both,
    set_string: "fmiSetString" => SetString, Optional,
    instantiate_model: "fmiInstantiateModel" => InstantiateModel, ModelExchange,
    free_model_instance: "fmiFreeModelInstance" => Free, ModelExchange,
    initialize: "fmiInitialize" => Initialize, ModelExchange,
    event_update: "fmiEventUpdate" => EventUpdate, ModelExchange,
    completed_integrator_step: "fmiCompletedIntegratorStep" => CompletedIntegratorStep, ModelExchange,
    set_time: "fmiSetTime" => SetTime, ModelExchange,
    set_continuous_states: "fmiSetContinuousStates" => SetArray, ModelExchange,
    get_derivatives: "fmiGetDerivatives" => GetArray, ModelExchange,
    get_event_indicators: "fmiGetEventIndicators" => GetArray, ModelExchange,
    get_continuous_states: "fmiGetContinuousStates" => GetArray, ModelExchange,
    get_nominal_continuous_states: "fmiGetNominalContinuousStates" => GetArray, ModelExchange,
    terminate: "fmiTerminate" => Call, ModelExchange,
    instantiate_slave: "fmiInstantiateSlave" => InstantiateSlave, CoSimulation,
    free_slave_instance: "fmiFreeSlaveInstance" => Free, CoSimulation,
    initialize_slave: "fmiInitializeSlave" => InitializeSlave, CoSimulation,
    terminate_slave: "fmiTerminateSlave" => Call, CoSimulation,
    reset_slave: "fmiResetSlave" => Call, CoSimulation,
    do_step: "fmiDoStep" => DoStep, CoSimulation,
    get_real_status: "fmiGetRealStatus" => GetRealStatus, Optional,
}

fn lookup<T: Copy>(
    lib: &libloading::Library,
    path: &Path,
    prefix: &str,
    symbol: &str,
    need: Need,
    cs: bool,
) -> Result<Option<T>, FfiError> {
    if need == Need::ModelExchange && cs || need == Need::CoSimulation && !cs {
        return Ok(None);
    }
    let prefixed = format!("{prefix}_{symbol}");
    // SAFETY: T is the fn-pointer type the FMI 1.0 standard gives this symbol.
    if let Ok(sym) = unsafe { lib.get::<T>(prefixed.as_bytes()) } {
        return Ok(Some(*sym));
    }
    if need == Need::Optional {
        return Ok(None);
    }
    // SAFETY: only checks whether the name exists; the symbol is not used.
    let unprefixed = unsafe { lib.get::<*const c_void>(symbol.as_bytes()) }.is_ok();
    Err(if unprefixed {
        FfiError::Unprefixed { path: path.to_owned(), symbol: symbol.to_owned(), expected: prefixed }
    } else {
        FfiError::MissingSymbol { path: path.to_owned(), symbol: prefixed }
    })
}

impl Api {
    /// Loads the shared library at `path` and resolves the Model Exchange (`cs` false) or
    /// Co-Simulation entry points, each named `<model_identifier>_fmiX`.
    ///
    /// # Errors
    /// [`FfiError::Load`] if the library cannot be opened, [`FfiError::Unprefixed`] if it exports
    /// a function without the model identifier's prefix, [`FfiError::MissingSymbol`] naming the
    /// first required function that is not exported.
    pub fn load(path: &Path, model_identifier: &str, cs: bool) -> Result<Arc<Api>, FfiError> {
        install_log_sink();
        // SAFETY: loading a library runs its initialisers. The caller has chosen to trust this
        // FMU's binary; the archive layer has already rejected path tricks.
        let lib = unsafe { libloading::Library::new(path) }
            .map_err(|e| FfiError::Load { path: path.to_owned(), message: e.to_string() })?;
        Ok(Arc::new(Api::resolve(lib, path, model_identifier, cs)?))
    }

    /// `fmiGetVersion()`, "1.0".
    pub fn version(&self) -> String {
        // SAFETY: resolved at load; returns a static string.
        self.get_version.map(|f| lossy(unsafe { f() })).unwrap_or_default()
    }

    /// Path of the loaded binary.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

/// One live FMI 1.0 `fmiComponent`, freed on drop. Neither `Send` nor `Sync`: it stays on the
/// thread that created it.
pub struct Component {
    api: Arc<Api>,
    raw: Comp,
    log: Box<InstanceLog>,
    /// The experiment of `setup_experiment`, used at initialisation.
    experiment: (Option<f64>, f64, Option<f64>),
    /// What `fmiInitialize` reported, handed out by the first event update after it.
    initial_event: Option<EventInfo>,
}

impl Component {
    /// `fmiInstantiateModel` or `fmiInstantiateSlave` (`fmu_dir` is the unpacked FMU, whose
    /// URI is the slave's `fmuLocation`). Returns the FMU's messages if it returned NULL.
    pub fn instantiate(
        api: Arc<Api>,
        instance_name: &str,
        kind: FmuType,
        guid: &str,
        fmu_dir: &Path,
        logging_on: bool,
    ) -> Result<Self, Vec<String>> {
        let to_c = |s: &str| CString::new(s.replace('\0', "")).expect("NUL bytes removed");
        let (name, guid) = (to_c(instance_name), to_c(guid));
        let log = Box::new(InstanceLog::default());
        let raw = {
            let _scope = LogScope::enter(&log);
            match (kind, api.co_simulation) {
                (FmuType::ModelExchange, false) => {
                    let f = api.instantiate_model.ok_or_else(|| vec!["fmiInstantiateModel not resolved".to_owned()])?;
                    let callbacks = MeCallbacks {
                        logger: fmucal_logger_fmi1 as *const c_void,
                        allocate_memory: fmucal_calloc,
                        free_memory: fmucal_free,
                    };
                    // SAFETY: the strings are NUL-terminated and outlive the call; the callbacks
                    // are passed by value, as FMI 1.0 Model Exchange declares.
                    unsafe { f(name.as_ptr(), guid.as_ptr(), callbacks, c_char::from(logging_on)) }
                }
                (FmuType::CoSimulation, true) => {
                    let f = api.instantiate_slave.ok_or_else(|| vec!["fmiInstantiateSlave not resolved".to_owned()])?;
                    let location = to_c(&super::file_uri(fmu_dir));
                    let mime = to_c("application/x-fmu-sharedlibrary");
                    let callbacks = CsCallbacks {
                        logger: fmucal_logger_fmi1 as *const c_void,
                        allocate_memory: fmucal_calloc,
                        free_memory: fmucal_free,
                        step_finished: std::ptr::null(),
                    };
                    // SAFETY: as above; no timeout, not visible, not interactive.
                    unsafe {
                        f(
                            name.as_ptr(),
                            guid.as_ptr(),
                            location.as_ptr(),
                            mime.as_ptr(),
                            0.0,
                            0,
                            0,
                            callbacks,
                            c_char::from(logging_on),
                        )
                    }
                }
                _ => return Err(vec![format!("this FMI 1.0 binary does not offer {kind:?}")]),
            }
        };
        if raw.is_null() {
            return Err(log.drain());
        }
        Ok(Component { api, raw, log, experiment: (None, 0.0, None), initial_event: None })
    }

    /// Logs why a call cannot be made and returns `Error`, as an FMU would.
    fn refuse(&self, message: &str) -> Status {
        self.log.receive(Status::Error, "", "fmucal", message);
        Status::Error
    }
}

macro_rules! call {
    ($self:ident, $f:ident $(, $arg:expr)*) => {{
        match $self.api.$f {
            Some(f) => {
                let _scope = LogScope::enter(&$self.log);
                // SAFETY: the pointer was resolved from this FMU's binary with the standard's
                // signature; `raw` is a live component; slices passed carry their true lengths.
                Status::from_raw(unsafe { f($self.raw $(, $arg)*) })
            }
            None => $self.refuse(concat!("the FMI 1.0 ", stringify!($f), " function is not available for this interface")),
        }
    }};
}

impl FmiCalls for Component {
    fn take_log(&self) -> Vec<String> {
        self.log.drain()
    }
    fn set_debug_logging(&mut self, on: bool) -> Status {
        call!(self, set_debug_logging, c_char::from(on))
    }
    fn setup_experiment(&mut self, tolerance: Option<f64>, start: f64, stop: Option<f64>) -> Status {
        self.experiment = (tolerance, start, stop);
        Status::Ok
    }
    fn enter_initialization_mode(&mut self) -> Status {
        // FMI 1.0 has no initialisation mode: start values are set before fmiInitialize.
        if self.api.co_simulation { Status::Ok } else { call!(self, set_time, self.experiment.1) }
    }
    fn exit_initialization_mode(&mut self) -> Status {
        let (tolerance, start, stop) = self.experiment;
        if self.api.co_simulation {
            return call!(self, initialize_slave, start, c_char::from(stop.is_some()), stop.unwrap_or(0.0));
        }
        let mut info = EventInfo1::default();
        let st = call!(
            self,
            initialize,
            c_char::from(tolerance.is_some()),
            tolerance.unwrap_or(0.0),
            &mut info as *mut EventInfo1
        );
        self.initial_event = Some(info.to_event_info());
        st
    }
    fn terminate(&mut self) -> Status {
        if self.api.co_simulation { call!(self, terminate_slave) } else { call!(self, terminate) }
    }
    fn reset(&mut self) -> Status {
        if self.api.co_simulation {
            call!(self, reset_slave)
        } else {
            // Model Exchange 1.0 has no reset: the caller instantiates again.
            Status::Error
        }
    }

    real_and_integer_calls!();
    fn get_boolean(&mut self, vrs: &[u32], out: &mut [i32]) -> Status {
        assert_eq!(vrs.len(), out.len());
        let mut buf = vec![0 as c_char; vrs.len()];
        let st = call!(self, get_boolean, vrs.as_ptr(), vrs.len(), buf.as_mut_ptr());
        for (o, b) in out.iter_mut().zip(buf) {
            *o = i32::from(b != 0);
        }
        st
    }
    fn set_boolean(&mut self, vrs: &[u32], values: &[i32]) -> Status {
        assert_eq!(vrs.len(), values.len());
        let buf: Vec<c_char> = values.iter().map(|v| c_char::from(*v != 0)).collect();
        call!(self, set_boolean, vrs.as_ptr(), vrs.len(), buf.as_ptr())
    }
    fn set_string(&mut self, vrs: &[u32], values: &[&str]) -> Status {
        assert_eq!(vrs.len(), values.len());
        let (_owned, pointers) = super::c_strings(values);
        call!(self, set_string, vrs.as_ptr(), vrs.len(), pointers.as_ptr())
    }
    fn set_binary(&mut self, _vrs: &[u32], _values: &[&[u8]]) -> Status {
        self.refuse("FMI 1.0 has no Binary variables")
    }

    fn enter_event_mode(&mut self) -> Status {
        Status::Ok
    }
    fn new_discrete_states(&mut self, info: &mut EventInfo) -> Status {
        // fmiInitialize has already iterated the initial event.
        if let Some(initial) = self.initial_event.take() {
            *info = initial;
            return Status::Ok;
        }
        let mut raw = EventInfo1::default();
        let st = call!(self, event_update, 0, &mut raw as *mut EventInfo1);
        *info = raw.to_event_info();
        st
    }
    fn enter_continuous_time_mode(&mut self) -> Status {
        Status::Ok
    }
    fn completed_integrator_step(&mut self) -> (Status, bool, bool) {
        let mut call_event_update: c_char = 0;
        let st = call!(self, completed_integrator_step, &mut call_event_update);
        (st, call_event_update != 0, false)
    }
    state_vector_calls!(get_nominal_continuous_states);
    fn do_step(&mut self, t: f64, h: f64) -> Status {
        call!(self, do_step, t, h, 1)
    }
    fn terminated(&mut self) -> Option<bool> {
        // FMI 1.0 has no fmiTerminated status kind.
        None
    }
    fn last_successful_time(&mut self) -> Option<f64> {
        self.api.get_real_status?;
        let mut v = 0.0;
        // fmiLastSuccessfulTime is status kind 2.
        (call!(self, get_real_status, 2, &mut v) == Status::Ok).then_some(v)
    }
}

impl Drop for Component {
    fn drop(&mut self) {
        let free = if self.api.co_simulation { self.api.free_slave_instance } else { self.api.free_model_instance };
        if let Some(f) = free {
            let _scope = LogScope::enter(&self.log);
            // SAFETY: raw came from this binary's instantiate function and is freed exactly once.
            unsafe { f(self.raw) };
        }
        self.log.summarize();
    }
}
