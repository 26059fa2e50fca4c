//! FMI 3.0: the libloading symbol table (unprefixed `fmi3*` names), the logger callback (not
//! variadic in 3.0, so no C shim), and [`Instance`], the wrapper of one `fmi3Instance` whose
//! methods are the only calls into FMI 3.0 FMU code. It maps fmucal's calls ([`FmiCalls`]) to
//! the typed 3.0 API: a Real variable is read with `fmi3GetFloat64` or `fmi3GetFloat32`, an
//! Integer with the getter of its width (`fmi3GetInt64` for enumerations), and an element of an
//! array by reading or writing the whole array.

use std::collections::HashMap;
use std::ffi::{CString, c_char, c_int, c_void};
use std::path::{Path, PathBuf};
use std::sync::Arc;

use super::{EventInfo, FfiError, FmiCalls, FmuType, Status, lossy};
use crate::log::InstanceLog;
use crate::schema::{Fmi3Storage, Fmi3Type, ModelDescription, Value};

type Inst = *mut c_void;
type LogMessage = extern "C" fn(*mut c_void, c_int, *const c_char, *const c_char);

type InstantiateMe =
    unsafe extern "C" fn(*const c_char, *const c_char, *const c_char, bool, bool, *mut c_void, LogMessage) -> Inst;
type InstantiateCs = unsafe extern "C" fn(
    *const c_char,
    *const c_char,
    *const c_char,
    bool,
    bool,
    bool,
    bool,
    *const u32,
    usize,
    *mut c_void,
    LogMessage,
    *const c_void,
) -> Inst;
type Free = unsafe extern "C" fn(Inst);
type Str = unsafe extern "C" fn() -> *const c_char;
type Call = unsafe extern "C" fn(Inst) -> c_int;
type SetDebugLogging = unsafe extern "C" fn(Inst, bool, usize, *const *const c_char) -> c_int;
type EnterInit = unsafe extern "C" fn(Inst, bool, f64, f64, bool, f64) -> c_int;
type Get<T> = unsafe extern "C" fn(Inst, *const u32, usize, *mut T, usize) -> c_int;
type Set<T> = unsafe extern "C" fn(Inst, *const u32, usize, *const T, usize) -> c_int;
// Out-arguments of type fmi3Boolean are read as bytes: a byte other than 0 or 1 written by the
// FMU must not become an invalid Rust bool.
type UpdateDiscreteStates = unsafe extern "C" fn(Inst, *mut u8, *mut u8, *mut u8, *mut u8, *mut u8, *mut f64) -> c_int;
type CompletedIntegratorStep = unsafe extern "C" fn(Inst, bool, *mut u8, *mut u8) -> c_int;
type SetString = unsafe extern "C" fn(Inst, *const u32, usize, *const *const c_char, usize) -> c_int;
type SetBinary = unsafe extern "C" fn(Inst, *const u32, usize, *const usize, *const *const u8, usize) -> c_int;
type SetTime = unsafe extern "C" fn(Inst, f64) -> c_int;
type SetArray = unsafe extern "C" fn(Inst, *const f64, usize) -> c_int;
type GetArray = unsafe extern "C" fn(Inst, *mut f64, usize) -> c_int;
type DoStep = unsafe extern "C" fn(Inst, f64, f64, bool, *mut u8, *mut u8, *mut u8, *mut f64) -> c_int;

#[derive(Clone, Copy)]
enum Need {
    Always,
    ModelExchange,
    CoSimulation,
    /// Resolved if exported; a call without it fails with a message naming it.
    Optional,
}

macro_rules! fmi3_api {
    ($( $field:ident : $sym:literal => $ty:ty, $need:ident ),* $(,)?) => {
        /// Resolved FMI 3.0 entry points of one binary. Model Exchange and Co-Simulation entry
        /// points are `Some` when that interface was requested at load time.
        #[allow(dead_code)] // every symbol is resolved to check the binary, not all are called
        pub struct Api {
            $( $field: Option<$ty>, )*
            path: PathBuf,
            _lib: libloading::Library,
        }

        impl Api {
            fn resolve(lib: libloading::Library, path: &Path, me: bool, cs: bool) -> Result<Self, FfiError> {
                $( let $field: Option<$ty> = lookup(&lib, path, $sym, Need::$need, me, cs)?; )*
                Ok(Api { $( $field, )* path: path.to_owned(), _lib: lib })
            }
        }
    };
}

fmi3_api! {
    get_version: "fmi3GetVersion" => Str, Always,
    set_debug_logging: "fmi3SetDebugLogging" => SetDebugLogging, Always,
    instantiate_me: "fmi3InstantiateModelExchange" => InstantiateMe, ModelExchange,
    instantiate_cs: "fmi3InstantiateCoSimulation" => InstantiateCs, CoSimulation,
    free_instance: "fmi3FreeInstance" => Free, Always,
    enter_initialization_mode: "fmi3EnterInitializationMode" => EnterInit, Always,
    exit_initialization_mode: "fmi3ExitInitializationMode" => Call, Always,
    enter_event_mode: "fmi3EnterEventMode" => Call, ModelExchange,
    terminate: "fmi3Terminate" => Call, Always,
    reset: "fmi3Reset" => Call, Always,
    get_float64: "fmi3GetFloat64" => Get<f64>, Always,
    set_float64: "fmi3SetFloat64" => Set<f64>, Always,
    get_float32: "fmi3GetFloat32" => Get<f32>, Optional,
    set_float32: "fmi3SetFloat32" => Set<f32>, Optional,
    get_int8: "fmi3GetInt8" => Get<i8>, Optional,
    set_int8: "fmi3SetInt8" => Set<i8>, Optional,
    get_uint8: "fmi3GetUInt8" => Get<u8>, Optional,
    set_uint8: "fmi3SetUInt8" => Set<u8>, Optional,
    get_int16: "fmi3GetInt16" => Get<i16>, Optional,
    set_int16: "fmi3SetInt16" => Set<i16>, Optional,
    get_uint16: "fmi3GetUInt16" => Get<u16>, Optional,
    set_uint16: "fmi3SetUInt16" => Set<u16>, Optional,
    get_int32: "fmi3GetInt32" => Get<i32>, Optional,
    set_int32: "fmi3SetInt32" => Set<i32>, Optional,
    get_uint32: "fmi3GetUInt32" => Get<u32>, Optional,
    set_uint32: "fmi3SetUInt32" => Set<u32>, Optional,
    get_int64: "fmi3GetInt64" => Get<i64>, Optional,
    set_int64: "fmi3SetInt64" => Set<i64>, Optional,
    get_uint64: "fmi3GetUInt64" => Get<u64>, Optional,
    set_uint64: "fmi3SetUInt64" => Set<u64>, Optional,
    get_boolean: "fmi3GetBoolean" => Get<u8>, Optional,
    set_boolean: "fmi3SetBoolean" => Set<u8>, Optional,
    set_string: "fmi3SetString" => SetString, Optional,
    set_binary: "fmi3SetBinary" => SetBinary, Optional,
    update_discrete_states: "fmi3UpdateDiscreteStates" => UpdateDiscreteStates, ModelExchange,
    enter_continuous_time_mode: "fmi3EnterContinuousTimeMode" => Call, ModelExchange,
    completed_integrator_step: "fmi3CompletedIntegratorStep" => CompletedIntegratorStep, ModelExchange,
    set_time: "fmi3SetTime" => SetTime, ModelExchange,
    set_continuous_states: "fmi3SetContinuousStates" => SetArray, ModelExchange,
    get_derivatives: "fmi3GetContinuousStateDerivatives" => GetArray, ModelExchange,
    get_event_indicators: "fmi3GetEventIndicators" => GetArray, ModelExchange,
    get_continuous_states: "fmi3GetContinuousStates" => GetArray, ModelExchange,
    get_nominals_of_continuous_states: "fmi3GetNominalsOfContinuousStates" => GetArray, ModelExchange,
    do_step: "fmi3DoStep" => DoStep, CoSimulation,
}

fn lookup<T: Copy>(
    lib: &libloading::Library,
    path: &Path,
    symbol: &str,
    need: Need,
    me: bool,
    cs: bool,
) -> Result<Option<T>, FfiError> {
    let required = match need {
        Need::Always => true,
        Need::ModelExchange if !me => return Ok(None),
        Need::CoSimulation if !cs => return Ok(None),
        Need::ModelExchange | Need::CoSimulation => true,
        Need::Optional => false,
    };
    // SAFETY: T is the fn-pointer type the FMI 3.0 standard gives this symbol.
    match unsafe { lib.get::<T>(symbol.as_bytes()) } {
        Ok(sym) => Ok(Some(*sym)),
        Err(_) if required => Err(FfiError::MissingSymbol { path: path.to_owned(), symbol: symbol.to_owned() }),
        Err(_) => Ok(None),
    }
}

impl Api {
    /// Loads the shared library at `path` and resolves the entry points of the requested
    /// interfaces (FMI 3.0 functions are never prefixed with the model identifier).
    ///
    /// # Errors
    /// [`FfiError::Load`] if the library cannot be opened, [`FfiError::MissingSymbol`] naming the
    /// first required function that is not exported.
    pub fn load(path: &Path, me: bool, cs: bool) -> Result<Arc<Api>, FfiError> {
        // SAFETY: loading a library runs its initialisers. The caller has chosen to trust this
        // FMU's binary; the archive layer has already rejected path tricks.
        let lib = unsafe { libloading::Library::new(path) }
            .map_err(|e| FfiError::Load { path: path.to_owned(), message: e.to_string() })?;
        Ok(Arc::new(Api::resolve(lib, path, me, cs)?))
    }

    /// `fmi3GetVersion()`, e.g. "3.0".
    pub fn version(&self) -> String {
        // SAFETY: resolved at load; returns a static string.
        self.get_version.map(|f| lossy(unsafe { f() })).unwrap_or_default()
    }

    /// Path of the loaded binary.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

extern "C" fn log_message(env: *mut c_void, status: c_int, category: *const c_char, message: *const c_char) {
    let (category, message) = (lossy(category), lossy(message));
    let status = Status::from_raw(status);
    if env.is_null() {
        crate::log::emit(status, "", &category, &message);
        return;
    }
    // SAFETY: env is the InstanceLog owned by the Instance calling into the FMU; it lives until
    // after fmi3FreeInstance returns.
    let log = unsafe { &*(env as *const InstanceLog) };
    log.receive(status, "", &category, &message);
}

/// One live `fmi3Instance`, freed on drop. Neither `Send` nor `Sync`: it stays on the thread
/// that created it.
pub struct Instance {
    api: Arc<Api>,
    raw: Inst,
    log: Box<InstanceLog>,
    /// How to reach each variable that is not a scalar Float64 (whose fmucal value reference is
    /// its own): its type, and for an array element the array.
    storage: HashMap<u32, Fmi3Storage>,
    /// The values fmucal holds for each array it may write an element of (by the array's value
    /// reference): the description's start values, then what was set. Writing an element sends
    /// the whole array from here, so the FMU is never read before initialisation, where FMI 3.0
    /// allows no getter. `None` for an element without a start value: such an array is read
    /// first.
    arrays: HashMap<u32, Vec<Option<f64>>>,
    array_starts: HashMap<u32, Vec<Option<f64>>>,
    /// The experiment of `setup_experiment`, passed on by `enter_initialization_mode`.
    experiment: (Option<f64>, f64, Option<f64>),
    /// What the last `fmi3DoStep` said.
    terminated: bool,
    last_successful_time: Option<f64>,
}

impl Instance {
    /// `fmi3InstantiateModelExchange` or `fmi3InstantiateCoSimulation` (without event mode or
    /// early return). Returns the FMU's messages if it returned NULL.
    pub fn instantiate(
        api: Arc<Api>,
        description: &ModelDescription,
        instance_name: &str,
        kind: FmuType,
        resources: &Path,
        logging_on: bool,
    ) -> Result<Self, Vec<String>> {
        let to_c = |s: &str| CString::new(s.replace('\0', "")).expect("NUL bytes removed");
        // FMI 3.0 passes the resources folder as a path ending in a separator.
        let mut resource_path = resources.to_string_lossy().into_owned();
        if !resource_path.ends_with(std::path::MAIN_SEPARATOR) {
            resource_path.push(std::path::MAIN_SEPARATOR);
        }
        let (name, token, resource_path) = (to_c(instance_name), to_c(&description.guid), to_c(&resource_path));
        let log = Box::new(InstanceLog::default());
        let env = &*log as *const InstanceLog as *mut c_void;
        // SAFETY: all strings are NUL-terminated and outlive the call; the log is boxed so its
        // address stays valid for the instance's lifetime; no intermediate variables are asked
        // for and the intermediate-update callback is NULL (early return is not allowed).
        let raw = unsafe {
            match kind {
                FmuType::ModelExchange => match api.instantiate_me {
                    Some(f) => {
                        f(name.as_ptr(), token.as_ptr(), resource_path.as_ptr(), false, logging_on, env, log_message)
                    }
                    None => return Err(vec!["fmi3InstantiateModelExchange not resolved".into()]),
                },
                FmuType::CoSimulation => match api.instantiate_cs {
                    Some(f) => f(
                        name.as_ptr(),
                        token.as_ptr(),
                        resource_path.as_ptr(),
                        false,
                        logging_on,
                        false,
                        false,
                        std::ptr::null(),
                        0,
                        env,
                        log_message,
                        std::ptr::null(),
                    ),
                    None => return Err(vec!["fmi3InstantiateCoSimulation not resolved".into()]),
                },
            }
        };
        if raw.is_null() {
            return Err(log.drain());
        }
        let storage = description
            .variables
            .iter()
            .filter_map(|v| v.fmi3.clone().map(|s| (v.value_reference, s)))
            .filter(|(vr, s)| !(s.ty == Fmi3Type::Float64 && s.element.is_none() && s.value_reference == *vr))
            .collect();
        let mut array_starts: HashMap<u32, Vec<Option<f64>>> = HashMap::new();
        for v in &description.variables {
            let Some(Fmi3Storage { value_reference, element: Some(k), .. }) = &v.fmi3 else { continue };
            let n = v.fmi3.as_ref().map_or(0, Fmi3Storage::len);
            let values = array_starts.entry(*value_reference).or_insert_with(|| vec![None; n]);
            if let Some(slot) = values.get_mut(*k) {
                *slot = match &v.start {
                    Some(Value::Real(x)) => Some(*x),
                    Some(Value::Integer(i)) => Some(*i as f64),
                    Some(Value::Boolean(b)) => Some(f64::from(u8::from(*b))),
                    _ => None,
                };
            }
        }
        Ok(Instance {
            api,
            raw,
            log,
            storage,
            arrays: array_starts.clone(),
            array_starts,
            experiment: (None, 0.0, None),
            terminated: false,
            last_successful_time: None,
        })
    }

    /// Logs why a call cannot be made and returns `Error`, as an FMU would.
    fn refuse(&self, message: String) -> Status {
        self.log.receive(Status::Error, "", "fmucal", &message);
        Status::Error
    }

    /// Reads every value of the variable `s` (all elements of an array) as f64.
    fn read(&mut self, s: &Fmi3Storage) -> Result<Vec<f64>, Status> {
        let n = s.len();
        macro_rules! typed {
            ($get:ident, $t:ty) => {{
                let Some(f) = self.api.$get else {
                    return Err(self.refuse(format!("the FMU does not export {}", stringify!($get))));
                };
                let mut buf: Vec<$t> = vec![Default::default(); n];
                // SAFETY: one value reference whose variable holds n values, into a buffer of n.
                let st = Status::from_raw(unsafe { f(self.raw, &s.value_reference, 1, buf.as_mut_ptr(), n) });
                if st > Status::Warning {
                    return Err(st);
                }
                buf.into_iter().map(|v| v as f64).collect()
            }};
        }
        Ok(match s.ty {
            Fmi3Type::Float64 => typed!(get_float64, f64),
            Fmi3Type::Float32 => typed!(get_float32, f32),
            Fmi3Type::Int8 => typed!(get_int8, i8),
            Fmi3Type::UInt8 => typed!(get_uint8, u8),
            Fmi3Type::Int16 => typed!(get_int16, i16),
            Fmi3Type::UInt16 => typed!(get_uint16, u16),
            Fmi3Type::Int32 => typed!(get_int32, i32),
            Fmi3Type::UInt32 => typed!(get_uint32, u32),
            Fmi3Type::Int64 | Fmi3Type::Enumeration => typed!(get_int64, i64),
            Fmi3Type::UInt64 => typed!(get_uint64, u64),
            Fmi3Type::Boolean => {
                let Some(f) = self.api.get_boolean else {
                    return Err(self.refuse("the FMU does not export fmi3GetBoolean".into()));
                };
                let mut buf = vec![0u8; n];
                // SAFETY: as above (fmi3Boolean is one byte).
                let st = Status::from_raw(unsafe { f(self.raw, &s.value_reference, 1, buf.as_mut_ptr(), n) });
                if st > Status::Warning {
                    return Err(st);
                }
                buf.into_iter().map(|b| f64::from(u8::from(b != 0))).collect()
            }
            other => return Err(self.refuse(format!("fmucal cannot read {other:?} variables"))),
        })
    }

    /// Writes every value of the variable `s`, converted from f64 to its type.
    fn write(&mut self, s: &Fmi3Storage, values: &[f64]) -> Status {
        let n = values.len();
        macro_rules! typed {
            ($set:ident, $t:ty) => {{
                let Some(f) = self.api.$set else {
                    return self.refuse(format!("the FMU does not export {}", stringify!($set)));
                };
                let buf: Vec<$t> = values.iter().map(|v| *v as $t).collect();
                // SAFETY: one value reference whose variable holds n values, from a buffer of n.
                Status::from_raw(unsafe { f(self.raw, &s.value_reference, 1, buf.as_ptr(), n) })
            }};
        }
        match s.ty {
            Fmi3Type::Float64 => typed!(set_float64, f64),
            Fmi3Type::Float32 => typed!(set_float32, f32),
            Fmi3Type::Int8 => typed!(set_int8, i8),
            Fmi3Type::UInt8 => typed!(set_uint8, u8),
            Fmi3Type::Int16 => typed!(set_int16, i16),
            Fmi3Type::UInt16 => typed!(set_uint16, u16),
            Fmi3Type::Int32 => typed!(set_int32, i32),
            Fmi3Type::UInt32 => typed!(set_uint32, u32),
            Fmi3Type::Int64 | Fmi3Type::Enumeration => typed!(set_int64, i64),
            Fmi3Type::UInt64 => typed!(set_uint64, u64),
            Fmi3Type::Boolean => {
                let Some(f) = self.api.set_boolean else {
                    return self.refuse("the FMU does not export fmi3SetBoolean".into());
                };
                let buf: Vec<u8> = values.iter().map(|v| u8::from(*v != 0.0)).collect();
                // SAFETY: as above.
                Status::from_raw(unsafe { f(self.raw, &s.value_reference, 1, buf.as_ptr(), n) })
            }
            other => self.refuse(format!("fmucal cannot set {other:?} variables")),
        }
    }

    /// The FMU's value references of fmucal's `vrs` of type `ty`, which must be scalars.
    fn scalar_references(&self, vrs: &[u32], ty: Fmi3Type) -> Result<Vec<u32>, Status> {
        vrs.iter()
            .map(|vr| {
                let s = self.storage_of(*vr, ty);
                if s.element.is_some() {
                    return Err(self.refuse(format!("setting an element of a {ty:?} array is not supported")));
                }
                Ok(s.value_reference)
            })
            .collect()
    }

    /// The storage of fmucal's value reference `vr`: a scalar Float64 unless listed.
    fn storage_of(&self, vr: u32, default: Fmi3Type) -> Fmi3Storage {
        self.storage.get(&vr).cloned().unwrap_or(Fmi3Storage {
            ty: default,
            value_reference: vr,
            element: None,
            dimensions: vec![],
        })
    }

    /// Reads the values of fmucal's value references `vrs` as f64, each by its storage.
    fn get_values(&mut self, vrs: &[u32], default: Fmi3Type, out: &mut [f64]) -> Status {
        assert_eq!(vrs.len(), out.len());
        if default == Fmi3Type::Float64 && vrs.iter().all(|vr| !self.storage.contains_key(vr)) {
            let Some(f) = self.api.get_float64 else { return Status::Error };
            // SAFETY: scalar Float64 variables: one value each, into a buffer of vrs.len().
            return Status::from_raw(unsafe { f(self.raw, vrs.as_ptr(), vrs.len(), out.as_mut_ptr(), out.len()) });
        }
        // Each variable (each array, for its elements) is read once per call.
        let mut read: HashMap<u32, Vec<f64>> = HashMap::new();
        for (vr, slot) in vrs.iter().zip(out.iter_mut()) {
            let s = self.storage_of(*vr, default);
            if !read.contains_key(&s.value_reference) {
                match self.read(&s) {
                    Ok(values) => read.insert(s.value_reference, values),
                    Err(st) => return st,
                };
            }
            match read[&s.value_reference].get(s.element.unwrap_or(0)) {
                Some(v) => *slot = *v,
                None => return self.refuse(format!("variable {vr} is past the end of its array")),
            }
        }
        Status::Ok
    }

    /// Writes `values` to fmucal's value references `vrs`; an array element is written by
    /// sending its whole array from the values held for it (read from the FMU only where an
    /// element has no start value).
    fn set_values(&mut self, vrs: &[u32], default: Fmi3Type, values: &[f64]) -> Status {
        assert_eq!(vrs.len(), values.len());
        if default == Fmi3Type::Float64 && vrs.iter().all(|vr| !self.storage.contains_key(vr)) {
            let Some(f) = self.api.set_float64 else { return Status::Error };
            // SAFETY: scalar Float64 variables: one value each, from a buffer of vrs.len().
            return Status::from_raw(unsafe { f(self.raw, vrs.as_ptr(), vrs.len(), values.as_ptr(), values.len()) });
        }
        let mut worst = Status::Ok;
        for (vr, value) in vrs.iter().zip(values) {
            let s = self.storage_of(*vr, default);
            let st = match s.element {
                None => self.write(&s, &[*value]),
                Some(k) => {
                    let held = self.arrays.get(&s.value_reference).and_then(|a| {
                        let mut all = a.clone();
                        *all.get_mut(k)? = Some(*value);
                        all.into_iter().collect::<Option<Vec<f64>>>()
                    });
                    let all = match held {
                        Some(all) => Ok(all),
                        None => self.read(&s).map(|mut all| {
                            if let Some(slot) = all.get_mut(k) {
                                *slot = *value;
                            }
                            all
                        }),
                    };
                    match all {
                        Ok(all) if all.len() == s.len() => {
                            let st = self.write(&s, &all);
                            if st <= Status::Warning {
                                self.arrays.insert(s.value_reference, all.into_iter().map(Some).collect());
                            }
                            st
                        }
                        Ok(all) => self.refuse(format!(
                            "array {} holds {} values, not the {} of its description",
                            s.value_reference,
                            all.len(),
                            s.len()
                        )),
                        Err(st) => st,
                    }
                }
            };
            if st > Status::Warning {
                return st;
            }
            worst = worst.max(st);
        }
        worst
    }
}

macro_rules! call {
    ($self:ident, $f:ident $(, $arg:expr)*) => {{
        match $self.api.$f {
            // SAFETY: the pointer was resolved from this FMU's binary with the standard's
            // signature; `raw` is a live instance; slices passed carry their true lengths.
            Some(f) => Status::from_raw(unsafe { f($self.raw $(, $arg)*) }),
            None => Status::Error,
        }
    }};
}

impl FmiCalls for Instance {
    fn take_log(&self) -> Vec<String> {
        self.log.drain()
    }

    fn set_debug_logging(&mut self, on: bool) -> Status {
        call!(self, set_debug_logging, on, 0, std::ptr::null())
    }

    fn setup_experiment(&mut self, tolerance: Option<f64>, start: f64, stop: Option<f64>) -> Status {
        self.experiment = (tolerance, start, stop);
        Status::Ok
    }

    fn enter_initialization_mode(&mut self) -> Status {
        let (tolerance, start, stop) = self.experiment;
        self.terminated = false;
        self.last_successful_time = None;
        call!(
            self,
            enter_initialization_mode,
            tolerance.is_some(),
            tolerance.unwrap_or(0.0),
            start,
            stop.is_some(),
            stop.unwrap_or(0.0)
        )
    }
    fn exit_initialization_mode(&mut self) -> Status {
        call!(self, exit_initialization_mode)
    }
    fn terminate(&mut self) -> Status {
        call!(self, terminate)
    }
    fn reset(&mut self) -> Status {
        self.arrays = self.array_starts.clone();
        call!(self, reset)
    }

    fn get_real(&mut self, vrs: &[u32], out: &mut [f64]) -> Status {
        self.get_values(vrs, Fmi3Type::Float64, out)
    }
    fn set_real(&mut self, vrs: &[u32], values: &[f64]) -> Status {
        self.set_values(vrs, Fmi3Type::Float64, values)
    }
    fn get_integer(&mut self, vrs: &[u32], out: &mut [i32]) -> Status {
        let mut values = vec![0.0; vrs.len()];
        let st = self.get_values(vrs, Fmi3Type::Int32, &mut values);
        for (o, v) in out.iter_mut().zip(values) {
            *o = v as i32;
        }
        st
    }
    fn set_integer(&mut self, vrs: &[u32], values: &[i32]) -> Status {
        let values: Vec<f64> = values.iter().map(|v| f64::from(*v)).collect();
        self.set_values(vrs, Fmi3Type::Int32, &values)
    }
    fn get_boolean(&mut self, vrs: &[u32], out: &mut [i32]) -> Status {
        let mut values = vec![0.0; vrs.len()];
        let st = self.get_values(vrs, Fmi3Type::Boolean, &mut values);
        for (o, v) in out.iter_mut().zip(values) {
            *o = i32::from(v != 0.0);
        }
        st
    }
    fn set_boolean(&mut self, vrs: &[u32], values: &[i32]) -> Status {
        let values: Vec<f64> = values.iter().map(|v| f64::from(i32::from(*v != 0))).collect();
        self.set_values(vrs, Fmi3Type::Boolean, &values)
    }

    fn enter_event_mode(&mut self) -> Status {
        call!(self, enter_event_mode)
    }
    fn new_discrete_states(&mut self, info: &mut EventInfo) -> Status {
        let (mut needed, mut terminate, mut nominals, mut values, mut time_defined, mut time) =
            (0u8, 0u8, 0u8, 0u8, 0u8, 0.0);
        let st = call!(
            self,
            update_discrete_states,
            &mut needed,
            &mut terminate,
            &mut nominals,
            &mut values,
            &mut time_defined,
            &mut time
        );
        let flag = |b: u8| c_int::from(b != 0);
        *info = EventInfo {
            new_discrete_states_needed: flag(needed),
            terminate_simulation: flag(terminate),
            nominals_of_continuous_states_changed: flag(nominals),
            values_of_continuous_states_changed: flag(values),
            next_event_time_defined: flag(time_defined),
            next_event_time: time,
        };
        st
    }
    fn enter_continuous_time_mode(&mut self) -> Status {
        call!(self, enter_continuous_time_mode)
    }
    fn completed_integrator_step(&mut self) -> (Status, bool, bool) {
        let (mut enter, mut terminate) = (0u8, 0u8);
        let st = call!(self, completed_integrator_step, true, &mut enter, &mut terminate);
        (st, enter != 0, terminate != 0)
    }
    state_vector_calls!(get_nominals_of_continuous_states);

    fn do_step(&mut self, t: f64, h: f64) -> Status {
        let (mut event, mut terminate, mut early, mut last) = (0u8, 0u8, 0u8, t);
        let st = call!(self, do_step, t, h, true, &mut event, &mut terminate, &mut early, &mut last);
        let (terminate, early) = (terminate != 0, early != 0);
        self.terminated = terminate;
        // Without early return the FMU reached the end of the step (FMI 3.0 section 4.2.1).
        let last = if terminate && !early && last <= t { t + h } else { last };
        self.last_successful_time = (terminate || early).then_some(last);
        if early && !terminate && st <= Status::Warning {
            // Early return was not allowed at instantiation: an FMU that does it anyway did not
            // reach the end of the step.
            return self.refuse(format!("fmi3DoStep returned early at t={last} though early return was not allowed"));
        }
        // FMI 3.0 asks to end the simulation through `terminateSimulation` with fmi3OK, where
        // FMI 2.0 returns fmi2Discard and reports fmi2Terminated: the drivers read the 2.0 shape.
        if terminate && st <= Status::Warning {
            return Status::Discard;
        }
        st
    }
    fn terminated(&mut self) -> Option<bool> {
        Some(self.terminated)
    }
    fn set_string(&mut self, vrs: &[u32], values: &[&str]) -> Status {
        assert_eq!(vrs.len(), values.len());
        let refs = match self.scalar_references(vrs, Fmi3Type::String) {
            Ok(refs) => refs,
            Err(st) => return st,
        };
        if self.api.set_string.is_none() {
            return self.refuse("the FMU does not export fmi3SetString".into());
        }
        // The C strings and the array of their pointers live until the call returns.
        let (_owned, pointers) = super::c_strings(values);
        call!(self, set_string, refs.as_ptr(), refs.len(), pointers.as_ptr(), pointers.len())
    }
    fn set_binary(&mut self, vrs: &[u32], values: &[&[u8]]) -> Status {
        assert_eq!(vrs.len(), values.len());
        let refs = match self.scalar_references(vrs, Fmi3Type::Binary) {
            Ok(refs) => refs,
            Err(st) => return st,
        };
        if self.api.set_binary.is_none() {
            return self.refuse("the FMU does not export fmi3SetBinary".into());
        }
        // The sizes, the pointers and the bytes they point to live until the call returns.
        let sizes: Vec<usize> = values.iter().map(|v| v.len()).collect();
        let pointers: Vec<*const u8> = values.iter().map(|v| v.as_ptr()).collect();
        call!(self, set_binary, refs.as_ptr(), refs.len(), sizes.as_ptr(), pointers.as_ptr(), pointers.len())
    }
    fn last_successful_time(&mut self) -> Option<f64> {
        self.last_successful_time
    }
}

impl Drop for Instance {
    fn drop(&mut self) {
        if let Some(f) = self.api.free_instance {
            // SAFETY: raw came from fmi3Instantiate* of this binary and is freed exactly once.
            unsafe { f(self.raw) };
        }
        self.log.summarize();
    }
}
