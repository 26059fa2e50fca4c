//! FMI 2.0: the libloading symbol table, the C logger shim (the 2.0 logger is variadic), and
//! [`Component`], the wrapper of one `fmi2Component` whose methods are the only calls into
//! FMI 2.0 FMU code.

use std::ffi::{CString, c_char, c_int, c_uint, c_void};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Once};

use super::{EventInfo, FfiError, FmiCalls, FmuType, Status, lossy};
use crate::log::InstanceLog;

#[repr(C)]
struct CallbackFunctions {
    logger: *const c_void,
    allocate_memory: unsafe extern "C" fn(usize, usize) -> *mut c_void,
    free_memory: unsafe extern "C" fn(*mut c_void),
    step_finished: *const c_void,
    component_environment: *mut c_void,
}

type LogSink = extern "C" fn(*mut c_void, *const c_char, c_int, *const c_char, *const c_char);

unsafe extern "C" {
    fn fmucal_set_log_sink(sink: LogSink);
    fn fmucal_logger(
        env: *mut c_void,
        instance: *const c_char,
        status: c_int,
        category: *const c_char,
        fmt: *const c_char,
        ...
    );
    /// The FMI 1.0 logger: passes no environment to the sink.
    pub(super) fn fmucal_logger_fmi1(
        component: *mut c_void,
        instance: *const c_char,
        status: c_int,
        category: *const c_char,
        fmt: *const c_char,
        ...
    );
    pub(super) fn fmucal_calloc(n: usize, size: usize) -> *mut c_void;
    pub(super) fn fmucal_free(p: *mut c_void);
}

extern "C" fn log_sink(
    env: *mut c_void,
    instance: *const c_char,
    status: c_int,
    category: *const c_char,
    message: *const c_char,
) {
    let (instance, category, message) = (lossy(instance), lossy(category), lossy(message));
    let status = Status::from_raw(status);
    if env.is_null() {
        // An FMI 1.0 instance fmucal is calling into on this thread, if any.
        let current = super::fmi1::CURRENT_LOG.with(|c| c.get());
        if !current.is_null() {
            // SAFETY: set by fmi1's LogScope to the log of the instance being called, which
            // outlives the call.
            unsafe { &*current }.receive(status, &instance, &category, &message);
            return;
        }
        // The FMU did not pass back our environment: no per-instance log to count repeats in.
        crate::log::emit(status, &instance, &category, &message);
        return;
    }
    // SAFETY: env is the InstanceLog owned by the Component that is calling into the FMU; it
    // lives until after fmi2FreeInstance returns.
    let log = unsafe { &*(env as *const InstanceLog) };
    log.receive(status, &instance, &category, &message);
}

pub(super) fn install_log_sink() {
    static ONCE: Once = Once::new();
    // SAFETY: stores a function pointer in the shim; no other state is touched.
    ONCE.call_once(|| unsafe { fmucal_set_log_sink(log_sink) });
}

macro_rules! fmi_api {
    ($( $field:ident : $sym:literal => $ty:ty ),* $(,)?) => {
        /// Resolved FMI 2.0 entry points of one binary. Model Exchange and Co-Simulation entry
        /// points are `Some` when that interface was requested at load time.
        #[allow(dead_code)] // every symbol is resolved to check the binary, not all are called
        pub struct Api {
            $( $field: Option<$ty>, )*
            path: PathBuf,
            _lib: libloading::Library,
        }

        impl Api {
            fn resolve(lib: libloading::Library, path: &Path, prefix: &str, me: bool, cs: bool) -> Result<Self, FfiError> {
                $( let $field: Option<$ty> = Self::lookup(&lib, path, prefix, $sym, me, cs)?; )*
                Ok(Api { $( $field, )* path: path.to_owned(), _lib: lib })
            }
        }
    };
}

type Fmi2Instantiate = unsafe extern "C" fn(
    *const c_char,
    c_int,
    *const c_char,
    *const c_char,
    *const CallbackFunctions,
    c_int,
    c_int,
) -> *mut c_void;
type Fmi2Component = unsafe extern "C" fn(*mut c_void) -> c_int;
type Fmi2Free = unsafe extern "C" fn(*mut c_void);
type Fmi2Str = unsafe extern "C" fn() -> *const c_char;
type Fmi2SetDebugLogging = unsafe extern "C" fn(*mut c_void, c_int, usize, *const *const c_char) -> c_int;
type Fmi2SetupExperiment = unsafe extern "C" fn(*mut c_void, c_int, f64, f64, c_int, f64) -> c_int;
type Fmi2GetReal = unsafe extern "C" fn(*mut c_void, *const c_uint, usize, *mut f64) -> c_int;
type Fmi2SetReal = unsafe extern "C" fn(*mut c_void, *const c_uint, usize, *const f64) -> c_int;
type Fmi2GetInt = unsafe extern "C" fn(*mut c_void, *const c_uint, usize, *mut c_int) -> c_int;
type Fmi2SetInt = unsafe extern "C" fn(*mut c_void, *const c_uint, usize, *const c_int) -> c_int;
type Fmi2GetStr = unsafe extern "C" fn(*mut c_void, *const c_uint, usize, *mut *const c_char) -> c_int;
type Fmi2SetStr = unsafe extern "C" fn(*mut c_void, *const c_uint, usize, *const *const c_char) -> c_int;
type Fmi2NewDiscreteStates = unsafe extern "C" fn(*mut c_void, *mut EventInfo) -> c_int;
type Fmi2CompletedIntegratorStep = unsafe extern "C" fn(*mut c_void, c_int, *mut c_int, *mut c_int) -> c_int;
type Fmi2SetTime = unsafe extern "C" fn(*mut c_void, f64) -> c_int;
type Fmi2SetStates = unsafe extern "C" fn(*mut c_void, *const f64, usize) -> c_int;
type Fmi2GetArray = unsafe extern "C" fn(*mut c_void, *mut f64, usize) -> c_int;
type Fmi2DoStep = unsafe extern "C" fn(*mut c_void, f64, f64, c_int) -> c_int;
type Fmi2GetRealStatus = unsafe extern "C" fn(*mut c_void, c_int, *mut f64) -> c_int;
type Fmi2GetBooleanStatus = unsafe extern "C" fn(*mut c_void, c_int, *mut c_int) -> c_int;

#[derive(Clone, Copy)]
enum Need {
    Always,
    ModelExchange,
    CoSimulation,
    Optional,
}

fn need(symbol: &str) -> Need {
    match symbol {
        "fmi2EnterEventMode"
        | "fmi2NewDiscreteStates"
        | "fmi2EnterContinuousTimeMode"
        | "fmi2CompletedIntegratorStep"
        | "fmi2SetTime"
        | "fmi2SetContinuousStates"
        | "fmi2GetDerivatives"
        | "fmi2GetEventIndicators"
        | "fmi2GetContinuousStates"
        | "fmi2GetNominalsOfContinuousStates" => Need::ModelExchange,
        "fmi2DoStep" => Need::CoSimulation,
        "fmi2GetRealStatus" | "fmi2GetBooleanStatus" => Need::Optional,
        _ => Need::Always,
    }
}

fmi_api! {
    get_types_platform: "fmi2GetTypesPlatform" => Fmi2Str,
    get_version: "fmi2GetVersion" => Fmi2Str,
    set_debug_logging: "fmi2SetDebugLogging" => Fmi2SetDebugLogging,
    instantiate: "fmi2Instantiate" => Fmi2Instantiate,
    free_instance: "fmi2FreeInstance" => Fmi2Free,
    setup_experiment: "fmi2SetupExperiment" => Fmi2SetupExperiment,
    enter_initialization_mode: "fmi2EnterInitializationMode" => Fmi2Component,
    exit_initialization_mode: "fmi2ExitInitializationMode" => Fmi2Component,
    terminate: "fmi2Terminate" => Fmi2Component,
    reset: "fmi2Reset" => Fmi2Component,
    get_real: "fmi2GetReal" => Fmi2GetReal,
    get_integer: "fmi2GetInteger" => Fmi2GetInt,
    get_boolean: "fmi2GetBoolean" => Fmi2GetInt,
    get_string: "fmi2GetString" => Fmi2GetStr,
    set_real: "fmi2SetReal" => Fmi2SetReal,
    set_integer: "fmi2SetInteger" => Fmi2SetInt,
    set_boolean: "fmi2SetBoolean" => Fmi2SetInt,
    set_string: "fmi2SetString" => Fmi2SetStr,
    enter_event_mode: "fmi2EnterEventMode" => Fmi2Component,
    new_discrete_states: "fmi2NewDiscreteStates" => Fmi2NewDiscreteStates,
    enter_continuous_time_mode: "fmi2EnterContinuousTimeMode" => Fmi2Component,
    completed_integrator_step: "fmi2CompletedIntegratorStep" => Fmi2CompletedIntegratorStep,
    set_time: "fmi2SetTime" => Fmi2SetTime,
    set_continuous_states: "fmi2SetContinuousStates" => Fmi2SetStates,
    get_derivatives: "fmi2GetDerivatives" => Fmi2GetArray,
    get_event_indicators: "fmi2GetEventIndicators" => Fmi2GetArray,
    get_continuous_states: "fmi2GetContinuousStates" => Fmi2GetArray,
    get_nominals_of_continuous_states: "fmi2GetNominalsOfContinuousStates" => Fmi2GetArray,
    do_step: "fmi2DoStep" => Fmi2DoStep,
    get_real_status: "fmi2GetRealStatus" => Fmi2GetRealStatus,
    get_boolean_status: "fmi2GetBooleanStatus" => Fmi2GetBooleanStatus,
}

impl Api {
    /// Loads the shared library at `path` and resolves the entry points of the requested
    /// interfaces. Symbols are looked up as `fmi2X`, then as `<modelIdentifier>_fmi2X`.
    ///
    /// # Errors
    /// [`FfiError::Load`] if the library cannot be opened, [`FfiError::MissingSymbol`] naming the
    /// first required function that is not exported.
    pub fn load(path: &Path, model_identifier: &str, me: bool, cs: bool) -> Result<Arc<Api>, FfiError> {
        install_log_sink();
        // SAFETY: loading a library runs its initialisers. The caller has chosen to trust this
        // FMU's binary; the archive layer has already rejected path tricks.
        let lib = unsafe { libloading::Library::new(path) }
            .map_err(|e| FfiError::Load { path: path.to_owned(), message: e.to_string() })?;
        Ok(Arc::new(Api::resolve(lib, path, model_identifier, me, cs)?))
    }

    fn lookup<T: Copy>(
        lib: &libloading::Library,
        path: &Path,
        prefix: &str,
        symbol: &str,
        me: bool,
        cs: bool,
    ) -> Result<Option<T>, FfiError> {
        let required = match need(symbol) {
            Need::Always => true,
            Need::ModelExchange => me,
            Need::CoSimulation => cs,
            Need::Optional => false,
        };
        if matches!(need(symbol), Need::ModelExchange) && !me || matches!(need(symbol), Need::CoSimulation) && !cs {
            return Ok(None);
        }
        for name in [symbol.to_owned(), format!("{prefix}_{symbol}")] {
            // SAFETY: T is the fn-pointer type the FMI 2.0 standard gives this symbol.
            if let Ok(sym) = unsafe { lib.get::<T>(name.as_bytes()) } {
                return Ok(Some(*sym));
            }
        }
        if required {
            Err(FfiError::MissingSymbol { path: path.to_owned(), symbol: symbol.to_owned() })
        } else {
            Ok(None)
        }
    }

    /// `fmi2GetVersion()`, e.g. "2.0".
    pub fn version(&self) -> String {
        // SAFETY: resolved at load; returns a static string.
        self.get_version.map(|f| lossy(unsafe { f() })).unwrap_or_default()
    }

    /// `fmi2GetTypesPlatform()`, "default" for standard builds.
    pub fn types_platform(&self) -> String {
        // SAFETY: as above.
        self.get_types_platform.map(|f| lossy(unsafe { f() })).unwrap_or_default()
    }

    /// Path of the loaded binary.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

/// One live `fmi2Component`. Calls go straight to the FMU; the component is freed on drop.
/// It is neither `Send` nor `Sync`: it stays on the thread that created it.
pub struct Component {
    api: Arc<Api>,
    raw: *mut c_void,
    log: Box<InstanceLog>,
    // Keeps the callback struct alive: FMUs may keep its address.
    _callbacks: Box<CallbackFunctions>,
}

fn status(v: c_int) -> Status {
    Status::from_raw(v)
}

macro_rules! call {
    ($self:ident, $f:ident $(, $arg:expr)*) => {{
        match $self.api.$f {
            // SAFETY: the pointer was resolved from this FMU's binary with the standard's
            // signature; `raw` is a live component; slices passed carry their true lengths.
            Some(f) => status(unsafe { f($self.raw $(, $arg)*) }),
            None => Status::Error,
        }
    }};
}

impl Component {
    /// `fmi2Instantiate`. Returns `None` if the FMU returned NULL; the log says why.
    pub fn instantiate(
        api: Arc<Api>,
        instance_name: &str,
        kind: FmuType,
        guid: &str,
        resource_uri: &str,
        logging_on: bool,
    ) -> Result<Self, Vec<String>> {
        let to_c = |s: &str| CString::new(s.replace('\0', "")).expect("NUL bytes removed");
        let (name, guid, uri) = (to_c(instance_name), to_c(guid), to_c(resource_uri));
        let log = Box::new(InstanceLog::default());
        let callbacks = Box::new(CallbackFunctions {
            logger: fmucal_logger as *const c_void,
            allocate_memory: fmucal_calloc,
            free_memory: fmucal_free,
            step_finished: std::ptr::null(),
            component_environment: &*log as *const InstanceLog as *mut c_void,
        });
        let Some(f) = api.instantiate else {
            return Err(vec!["fmi2Instantiate not resolved".into()]);
        };
        // SAFETY: all strings are NUL-terminated and outlive the call; callbacks and log are
        // boxed so their addresses stay valid for the component's lifetime.
        let raw = unsafe {
            f(name.as_ptr(), kind as c_int, guid.as_ptr(), uri.as_ptr(), &*callbacks, 0, logging_on as c_int)
        };
        if raw.is_null() {
            return Err(log.drain());
        }
        Ok(Component { api, raw, log, _callbacks: callbacks })
    }
}

impl FmiCalls for Component {
    fn take_log(&self) -> Vec<String> {
        self.log.drain()
    }

    fn set_debug_logging(&mut self, on: bool) -> Status {
        call!(self, set_debug_logging, on as c_int, 0, std::ptr::null())
    }

    fn setup_experiment(&mut self, tolerance: Option<f64>, start: f64, stop: Option<f64>) -> Status {
        call!(
            self,
            setup_experiment,
            tolerance.is_some() as c_int,
            tolerance.unwrap_or(0.0),
            start,
            stop.is_some() as c_int,
            stop.unwrap_or(0.0)
        )
    }

    fn enter_initialization_mode(&mut self) -> Status {
        call!(self, enter_initialization_mode)
    }
    fn exit_initialization_mode(&mut self) -> Status {
        call!(self, exit_initialization_mode)
    }
    fn terminate(&mut self) -> Status {
        call!(self, terminate)
    }
    fn reset(&mut self) -> Status {
        call!(self, reset)
    }

    real_and_integer_calls!();
    fn get_boolean(&mut self, vrs: &[u32], out: &mut [i32]) -> Status {
        assert_eq!(vrs.len(), out.len());
        call!(self, get_boolean, vrs.as_ptr(), vrs.len(), out.as_mut_ptr())
    }
    fn set_boolean(&mut self, vrs: &[u32], values: &[i32]) -> Status {
        assert_eq!(vrs.len(), values.len());
        call!(self, set_boolean, vrs.as_ptr(), vrs.len(), values.as_ptr())
    }
    fn set_string(&mut self, vrs: &[u32], values: &[&str]) -> Status {
        assert_eq!(vrs.len(), values.len());
        let (_owned, pointers) = super::c_strings(values);
        call!(self, set_string, vrs.as_ptr(), vrs.len(), pointers.as_ptr())
    }
    fn set_binary(&mut self, _vrs: &[u32], _values: &[&[u8]]) -> Status {
        self.log.receive(Status::Error, "", "fmucal", "FMI 2.0 has no Binary variables");
        Status::Error
    }

    fn enter_event_mode(&mut self) -> Status {
        call!(self, enter_event_mode)
    }
    fn new_discrete_states(&mut self, info: &mut EventInfo) -> Status {
        call!(self, new_discrete_states, info as *mut EventInfo)
    }
    fn enter_continuous_time_mode(&mut self) -> Status {
        call!(self, enter_continuous_time_mode)
    }
    /// Returns (status, enterEventMode, terminateSimulation).
    fn completed_integrator_step(&mut self) -> (Status, bool, bool) {
        let (mut enter, mut term): (c_int, c_int) = (0, 0);
        let s = call!(self, completed_integrator_step, 1, &mut enter, &mut term);
        (s, enter != 0, term != 0)
    }
    state_vector_calls!(get_nominals_of_continuous_states);

    fn do_step(&mut self, t: f64, h: f64) -> Status {
        call!(self, do_step, t, h, 1)
    }
    /// `fmi2GetBooleanStatus(fmi2Terminated)`, if the FMU exports it.
    fn terminated(&mut self) -> Option<bool> {
        self.api.get_boolean_status?;
        let mut v: c_int = 0;
        (call!(self, get_boolean_status, 3, &mut v) == Status::Ok).then_some(v != 0)
    }
    /// `fmi2GetRealStatus(fmi2LastSuccessfulTime)`, if the FMU exports it.
    fn last_successful_time(&mut self) -> Option<f64> {
        self.api.get_real_status?;
        let mut v = 0.0;
        (call!(self, get_real_status, 2, &mut v) == Status::Ok).then_some(v)
    }
}

impl Drop for Component {
    fn drop(&mut self) {
        if let Some(f) = self.api.free_instance {
            // SAFETY: raw came from fmi2Instantiate of this binary and is freed exactly once.
            unsafe { f(self.raw) };
        }
        self.log.summarize();
    }
}
