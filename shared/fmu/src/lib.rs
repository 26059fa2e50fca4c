//! The FMI 2.0 C functions of an FMU written by `fmucal export` (see
//! [`fmucal_shared::export`] for what the archive holds). This file is the crate's FFI layer and
//! holds all of its `unsafe`: it turns the importer's pointers into slices and strings, calls
//! [`wrapper::Corrected`], and turns its results into FMI status codes. No panic crosses into
//! the importing tool: every entry point catches it and answers `fmi2Fatal`. Failures go to the
//! importer's logger, one line each.
//!
//! The FMU does not support getting and setting its state, nor directional derivatives (its
//! description says so); those calls answer `fmi2Error`.

mod wrapper;

use std::ffi::{CStr, CString, c_char, c_int, c_uint, c_void};
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::PathBuf;

use fmucal_fmi::Interface;
use fmucal_fmi::ffi::EventInfo;
use wrapper::Corrected;

type Status = c_int;
const OK: Status = 0;
const ERROR: Status = 3;
const FATAL: Status = 4;

type Logger = unsafe extern "C" fn(*mut c_void, *const c_char, c_int, *const c_char, *const c_char, ...);

/// `fmi2CallbackFunctions`.
#[repr(C)]
pub struct CallbackFunctions {
    logger: Option<Logger>,
    allocate_memory: Option<unsafe extern "C" fn(usize, usize) -> *mut c_void>,
    free_memory: Option<unsafe extern "C" fn(*mut c_void)>,
    step_finished: Option<unsafe extern "C" fn(*mut c_void, c_int)>,
    component_environment: *mut c_void,
}

/// What an `fmi2Component` points to.
struct Component {
    model: Corrected,
    name: CString,
    logger: Option<Logger>,
    environment: *mut c_void,
    logging: bool,
    /// Strings handed out by `fmi2GetString`, alive until the next call.
    strings: Vec<CString>,
}

impl Component {
    fn log(&self, status: Status, message: &str) {
        log_to(self.logger, self.environment, &self.name, status, message);
    }
}

fn log_to(logger: Option<Logger>, env: *mut c_void, name: &CStr, status: Status, message: &str) {
    let Some(logger) = logger else { return };
    let text = CString::new(message.replace('\0', " ")).unwrap_or_default();
    let category = if status >= ERROR { c"logStatusError" } else { c"logAll" };
    // SAFETY: the importer gave this logger for this purpose; the format "%s" takes the one
    // NUL-terminated string passed, so no text of ours is read as a format.
    unsafe { logger(env, name.as_ptr(), status, category.as_ptr(), c"%s".as_ptr(), text.as_ptr()) };
}

/// Runs `f` on the component, catching panics and logging failures.
fn with(c: *mut c_void, function: &str, f: impl FnOnce(&mut Component) -> Result<Status, String>) -> Status {
    if c.is_null() {
        return ERROR;
    }
    // SAFETY: a non-null component is one `fmi2Instantiate` returned and `fmi2FreeInstance`
    // has not freed; the importer calls one function of an instance at a time.
    let comp = unsafe { &mut *(c as *mut Component) };
    match catch_unwind(AssertUnwindSafe(|| f(comp))) {
        Ok(Ok(status)) => status,
        Ok(Err(message)) => {
            comp.log(ERROR, &format!("{function}: {message}"));
            ERROR
        }
        Err(_) => {
            comp.log(FATAL, &format!("{function}: internal error (a panic in the fmucal runtime)"));
            FATAL
        }
    }
}

/// A slice from an importer's pointer and length (empty for a null pointer or no elements).
///
/// # Safety
/// `p` must point to `n` valid elements when it is not null.
unsafe fn slice<'a, T>(p: *const T, n: usize) -> &'a [T] {
    if p.is_null() || n == 0 { &[] } else { unsafe { std::slice::from_raw_parts(p, n) } }
}

/// # Safety
/// As [`slice`], for writing.
unsafe fn slice_mut<'a, T>(p: *mut T, n: usize) -> &'a mut [T] {
    if p.is_null() || n == 0 { &mut [] } else { unsafe { std::slice::from_raw_parts_mut(p, n) } }
}

/// The local folder a `file:` URI names (`file:///a/b`, `file:/a/b`, `file://localhost/a/b`),
/// with percent escapes decoded.
fn uri_path(uri: &str) -> Option<PathBuf> {
    let rest = uri.strip_prefix("file:")?;
    let rest = if let Some(r) = rest.strip_prefix("//") {
        let slash = r.find('/')?;
        let host = &r[..slash];
        if !(host.is_empty() || host == "localhost") {
            return None;
        }
        &r[slash..]
    } else {
        rest
    };
    let bytes = rest.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%'
            && i + 2 < bytes.len()
            && let Ok(v) = u8::from_str_radix(std::str::from_utf8(&bytes[i + 1..i + 3]).ok()?, 16)
        {
            out.push(v);
            i += 3;
        } else {
            out.push(bytes[i]);
            i += 1;
        }
    }
    Some(PathBuf::from(String::from_utf8(out).ok()?))
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2GetTypesPlatform() -> *const c_char {
    c"default".as_ptr()
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2GetVersion() -> *const c_char {
    c"2.0".as_ptr()
}

/// # Safety
/// FMI 2.0's contract: valid strings and callbacks from the importer.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2Instantiate(
    instance_name: *const c_char,
    fmu_type: c_int,
    guid: *const c_char,
    resource_location: *const c_char,
    functions: *const CallbackFunctions,
    _visible: c_int,
    logging_on: c_int,
) -> *mut c_void {
    let (logger, env) = if functions.is_null() {
        (None, std::ptr::null_mut())
    } else {
        // SAFETY: a non-null pointer to the importer's callback struct.
        let f = unsafe { &*functions };
        (f.logger, f.component_environment)
    };
    let text = |p: *const c_char| {
        // SAFETY: the importer passes NUL-terminated strings or null.
        if p.is_null() { None } else { Some(unsafe { CStr::from_ptr(p) }.to_string_lossy().into_owned()) }
    };
    let name =
        CString::new(text(instance_name).unwrap_or_else(|| "instance".into()).replace('\0', "")).unwrap_or_default();
    let result = catch_unwind(AssertUnwindSafe(|| -> Result<Corrected, String> {
        let interface = match fmu_type {
            0 => Interface::ModelExchange,
            1 => Interface::CoSimulation,
            other => return Err(format!("fmuType {other} is neither Model Exchange (0) nor Co-Simulation (1)")),
        };
        let uri = text(resource_location).ok_or("no fmuResourceLocation was given")?;
        let resources = uri_path(&uri).ok_or_else(|| format!("fmuResourceLocation {uri:?} is not a local file URI"))?;
        Corrected::new(&resources, interface, &name.to_string_lossy(), text(guid).as_deref())
    }));
    match result {
        Ok(Ok(model)) => Box::into_raw(Box::new(Component {
            model,
            name,
            logger,
            environment: env,
            logging: logging_on != 0,
            strings: vec![],
        })) as *mut c_void,
        Ok(Err(message)) => {
            log_to(logger, env, &name, ERROR, &format!("fmi2Instantiate: {message}"));
            std::ptr::null_mut()
        }
        Err(_) => {
            log_to(logger, env, &name, FATAL, "fmi2Instantiate: internal error (a panic in the fmucal runtime)");
            std::ptr::null_mut()
        }
    }
}

/// # Safety
/// `c` is null or an instance not yet freed.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2FreeInstance(c: *mut c_void) {
    if c.is_null() {
        return;
    }
    // SAFETY: `c` came from `Box::into_raw` in `fmi2Instantiate` and is freed once.
    let comp = unsafe { Box::from_raw(c as *mut Component) };
    // Dropping frees the original's instance; a panic there stays here.
    let _ = catch_unwind(AssertUnwindSafe(move || drop(comp)));
}

/// # Safety
/// FMI 2.0's contract.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2SetDebugLogging(
    c: *mut c_void,
    on: c_int,
    _n: usize,
    _categories: *const *const c_char,
) -> Status {
    with(c, "fmi2SetDebugLogging", |comp| {
        comp.logging = on != 0;
        Ok(OK)
    })
}

/// # Safety
/// FMI 2.0's contract.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2SetupExperiment(
    c: *mut c_void,
    tolerance_defined: c_int,
    tolerance: f64,
    start: f64,
    stop_defined: c_int,
    stop: f64,
) -> Status {
    with(c, "fmi2SetupExperiment", |comp| {
        let tol = (tolerance_defined != 0).then_some(tolerance);
        comp.model.setup_experiment(tol, start, (stop_defined != 0).then_some(stop)).map(|_| OK)
    })
}

macro_rules! simple {
    ($name:ident, $method:ident) => {
        /// # Safety
        /// FMI 2.0's contract.
        #[unsafe(no_mangle)]
        pub unsafe extern "C" fn $name(c: *mut c_void) -> Status {
            with(c, stringify!($name), |comp| comp.model.$method().map(|_| OK))
        }
    };
}

simple!(fmi2EnterInitializationMode, enter_initialization_mode);
simple!(fmi2ExitInitializationMode, exit_initialization_mode);
simple!(fmi2Terminate, terminate);
simple!(fmi2Reset, reset);
simple!(fmi2EnterEventMode, enter_event_mode);
simple!(fmi2EnterContinuousTimeMode, enter_continuous_time_mode);

/// `$name(c, vr, n, value)`: `$body` on the component, the `n` value references `$vrs` and
/// the `n` values `$values` at `value`, which `$slice` borrows (`slice_mut` for a getter,
/// which writes them, `slice` for a setter); given a `$method` instead, the model's method.
macro_rules! accessor {
    ($name:ident, $value:ty, $slice:ident, $method:ident) => {
        accessor!($name, $value, $slice, |comp, vrs, values| comp.model.$method(vrs, values).map(|_| OK));
    };
    ($(#[$doc:meta])* $name:ident, $value:ty, $slice:ident, |$comp:ident, $vrs:ident, $values:ident| $body:expr) => {
        /// # Safety
        /// FMI 2.0's contract: `vr` and `value` hold `n` elements.
        $(#[$doc])*
        #[unsafe(no_mangle)]
        pub unsafe extern "C" fn $name(c: *mut c_void, vr: *const c_uint, n: usize, value: $value) -> Status {
            // SAFETY: as the function's contract says.
            let ($vrs, $values) = unsafe { (slice(vr, n), $slice(value, n)) };
            with(c, stringify!($name), |$comp| $body)
        }
    };
}

accessor!(fmi2GetReal, *mut f64, slice_mut, get_real);
accessor!(fmi2GetInteger, *mut c_int, slice_mut, get_integer);
accessor!(fmi2GetBoolean, *mut c_int, slice_mut, get_boolean);
accessor!(fmi2SetReal, *const f64, slice, set_real);
accessor!(fmi2SetInteger, *const c_int, slice, set_integer);
accessor!(fmi2SetBoolean, *const c_int, slice, set_boolean);

accessor!(fmi2GetString, *mut *const c_char, slice_mut, |comp, vrs, out| {
    comp.strings =
        vrs.iter().map(|&v| CString::new(comp.model.get_string(v).replace('\0', "")).unwrap_or_default()).collect();
    for (slot, s) in out.iter_mut().zip(&comp.strings) {
        *slot = s.as_ptr();
    }
    Ok(OK)
});

accessor!(
    /// Each value is a NUL-terminated string.
    fmi2SetString,
    *const *const c_char,
    slice,
    |comp, vrs, ptrs| {
        let texts: Vec<String> = ptrs
            .iter()
            // SAFETY: each element is a NUL-terminated string or null.
            .map(|&p| {
                if p.is_null() { String::new() } else { unsafe { CStr::from_ptr(p) }.to_string_lossy().into_owned() }
            })
            .collect();
        let refs: Vec<&str> = texts.iter().map(String::as_str).collect();
        comp.model.set_string(vrs, &refs).map(|_| OK)
    }
);

macro_rules! unsupported {
    ($name:ident, $($arg:ident: $ty:ty),*) => {
        /// Not supported (the description says so): answers `fmi2Error`.
        ///
        /// # Safety
        /// FMI 2.0's contract.
        #[unsafe(no_mangle)]
        pub unsafe extern "C" fn $name(c: *mut c_void, $($arg: $ty),*) -> Status {
            $(let _ = $arg;)*
            with(c, stringify!($name), |_| Err("not supported by this FMU".into()))
        }
    };
}

unsupported!(fmi2GetFMUstate, state: *mut *mut c_void);
unsupported!(fmi2SetFMUstate, state: *mut c_void);
unsupported!(fmi2FreeFMUstate, state: *mut *mut c_void);
unsupported!(fmi2SerializedFMUstateSize, state: *mut c_void, size: *mut usize);
unsupported!(fmi2SerializeFMUstate, state: *mut c_void, bytes: *mut c_char, size: usize);
unsupported!(fmi2DeSerializeFMUstate, bytes: *const c_char, size: usize, state: *mut *mut c_void);
unsupported!(fmi2GetDirectionalDerivative, u: *const c_uint, nu: usize, k: *const c_uint, nk: usize, dk: *const f64, du: *mut f64);
unsupported!(fmi2SetRealInputDerivatives, vr: *const c_uint, n: usize, order: *const c_int, value: *const f64);
unsupported!(fmi2GetRealOutputDerivatives, vr: *const c_uint, n: usize, order: *const c_int, value: *mut f64);
unsupported!(fmi2CancelStep,);

/// # Safety
/// FMI 2.0's contract.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2NewDiscreteStates(c: *mut c_void, info: *mut EventInfo) -> Status {
    with(c, "fmi2NewDiscreteStates", |comp| {
        let mut i = EventInfo::default();
        comp.model.new_discrete_states(&mut i)?;
        if !info.is_null() {
            // SAFETY: the importer's event info struct, of this layout.
            unsafe { *info = i };
        }
        Ok(OK)
    })
}

/// # Safety
/// FMI 2.0's contract.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2CompletedIntegratorStep(
    c: *mut c_void,
    _no_set_prior: c_int,
    enter_event_mode: *mut c_int,
    terminate: *mut c_int,
) -> Status {
    with(c, "fmi2CompletedIntegratorStep", |comp| {
        let (event, stop) = comp.model.completed_integrator_step()?;
        // SAFETY: the importer's out-arguments, or null.
        unsafe {
            if !enter_event_mode.is_null() {
                *enter_event_mode = c_int::from(event);
            }
            if !terminate.is_null() {
                *terminate = c_int::from(stop);
            }
        }
        Ok(OK)
    })
}

/// # Safety
/// FMI 2.0's contract.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2SetTime(c: *mut c_void, t: f64) -> Status {
    with(c, "fmi2SetTime", |comp| comp.model.set_time(t).map(|_| OK))
}

/// # Safety
/// FMI 2.0's contract: `x` holds `n` values.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2SetContinuousStates(c: *mut c_void, x: *const f64, n: usize) -> Status {
    // SAFETY: as the function's contract says.
    let x = unsafe { slice(x, n) };
    with(c, "fmi2SetContinuousStates", |comp| comp.model.set_continuous_states(x).map(|_| OK))
}

macro_rules! vector_out {
    ($name:ident, $method:ident) => {
        /// # Safety
        /// FMI 2.0's contract: the buffer holds `n` values.
        #[unsafe(no_mangle)]
        pub unsafe extern "C" fn $name(c: *mut c_void, out: *mut f64, n: usize) -> Status {
            // SAFETY: as the function's contract says.
            let out = unsafe { slice_mut(out, n) };
            with(c, stringify!($name), |comp| comp.model.$method(out).map(|_| OK))
        }
    };
}

vector_out!(fmi2GetDerivatives, get_derivatives);
vector_out!(fmi2GetEventIndicators, get_event_indicators);
vector_out!(fmi2GetContinuousStates, get_continuous_states);
vector_out!(fmi2GetNominalsOfContinuousStates, get_nominals);

/// # Safety
/// FMI 2.0's contract.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2DoStep(c: *mut c_void, t: f64, h: f64, _no_set_prior: c_int) -> Status {
    with(c, "fmi2DoStep", |comp| Ok(if comp.model.do_step(t, h)? { 2 } else { OK }))
}

/// # Safety
/// FMI 2.0's contract.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2GetStatus(c: *mut c_void, _kind: c_int, value: *mut Status) -> Status {
    with(c, "fmi2GetStatus", |_| {
        if !value.is_null() {
            // SAFETY: the importer's out-argument.
            unsafe { *value = OK };
        }
        Ok(OK)
    })
}

/// # Safety
/// FMI 2.0's contract.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2GetRealStatus(c: *mut c_void, kind: c_int, value: *mut f64) -> Status {
    with(c, "fmi2GetRealStatus", |comp| {
        // fmi2LastSuccessfulTime (2) is the only Real status.
        if kind != 2 {
            return Err(format!("status kind {kind} has no Real value"));
        }
        if !value.is_null() {
            // SAFETY: the importer's out-argument.
            unsafe { *value = comp.model.time() };
        }
        Ok(OK)
    })
}

/// # Safety
/// FMI 2.0's contract.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2GetIntegerStatus(c: *mut c_void, kind: c_int, _value: *mut c_int) -> Status {
    with(c, "fmi2GetIntegerStatus", |_| Err(format!("status kind {kind} has no Integer value")))
}

/// # Safety
/// FMI 2.0's contract.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2GetBooleanStatus(c: *mut c_void, kind: c_int, value: *mut c_int) -> Status {
    with(c, "fmi2GetBooleanStatus", |comp| {
        // fmi2Terminated (3): the model asked to stop in its last step.
        if kind != 3 {
            return Err(format!("status kind {kind} has no Boolean value"));
        }
        let terminated = comp.model.terminated();
        if !value.is_null() {
            // SAFETY: the importer's out-argument.
            unsafe { *value = c_int::from(terminated) };
        }
        Ok(OK)
    })
}

/// # Safety
/// FMI 2.0's contract.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2GetStringStatus(c: *mut c_void, kind: c_int, _value: *mut *const c_char) -> Status {
    with(c, "fmi2GetStringStatus", |_| Err(format!("status kind {kind} has no String value")))
}

#[cfg(test)]
mod tests {
    use super::uri_path;
    use std::path::PathBuf;

    #[test]
    fn resource_uris_of_every_common_shape_name_the_folder() {
        assert_eq!(uri_path("file:///tmp/a%20b/resources"), Some(PathBuf::from("/tmp/a b/resources")));
        assert_eq!(uri_path("file:/tmp/x/resources/"), Some(PathBuf::from("/tmp/x/resources/")));
        assert_eq!(uri_path("file://localhost/tmp/x"), Some(PathBuf::from("/tmp/x")));
        assert_eq!(uri_path("file://server/share"), None);
        assert_eq!(uri_path("http://x/y"), None);
    }
}
