//! A safe FMU instance of any FMI version: owns one [`ffi::Component`], frees it on drop, maps
//! FMI status codes to `Result`, enforces `canBeInstantiatedOnlyOncePerProcess`, and is reused
//! across simulations with [`Instance::reset`] (falling back to a fresh instantiation if the
//! reset fails).
//! An instance is not `Send`: it stays on the thread that created it.
#![deny(unsafe_code)]

use std::collections::HashSet;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};

use super::ffi::{self, Component, FmuType, Status};
use super::{Fmu, FmuError, Interface, ModelDescription};

static ONCE_PER_PROCESS: Mutex<Option<HashSet<PathBuf>>> = Mutex::new(None);

/// Holds the process-wide claim of a `canBeInstantiatedOnlyOncePerProcess` binary.
struct OnceGuard(PathBuf);

impl OnceGuard {
    fn claim(binary: PathBuf, model: &str) -> Result<Self, FmuError> {
        let mut live = ONCE_PER_PROCESS.lock().unwrap_or_else(|p| p.into_inner());
        if !live.get_or_insert_with(HashSet::new).insert(binary.clone()) {
            return Err(FmuError::OnlyOncePerProcess { model: model.to_owned() });
        }
        Ok(OnceGuard(binary))
    }
}

impl Drop for OnceGuard {
    fn drop(&mut self) {
        let mut live = ONCE_PER_PROCESS.lock().unwrap_or_else(|p| p.into_inner());
        if let Some(set) = live.as_mut() {
            set.remove(&self.0);
        }
    }
}

/// One live instance of an FMU for one interface.
pub struct Instance {
    // Dropped first: the component must be freed before the once-per-process claim is released.
    // `None` only after a failed re-instantiation.
    component: Option<Component>,
    _once: Option<OnceGuard>,
    api: ffi::Api,
    description: Arc<ModelDescription>,
    interface: Interface,
    name: String,
    resources: PathBuf,
    time: f64,
}

impl Instance {
    /// Instantiates `fmu` for `interface`.
    ///
    /// # Errors
    /// [`FmuError::NoInterface`], [`FmuError::OnlyOncePerProcess`], or [`FmuError::Instantiate`]
    /// with the messages the FMU logged.
    pub fn new(fmu: &Fmu, interface: Interface, name: &str) -> Result<Self, FmuError> {
        let api = fmu.api(interface)?;
        let md = fmu.description.clone();
        let info = match interface {
            Interface::ModelExchange => md.model_exchange.as_ref(),
            Interface::CoSimulation => md.co_simulation.as_ref(),
        }
        .ok_or(FmuError::NoInterface(interface))?;
        let once = if info.can_be_instantiated_only_once_per_process {
            Some(OnceGuard::claim(api.path().to_owned(), &md.model_name)?)
        } else {
            None
        };
        let mut inst = Instance {
            component: None,
            _once: once,
            api,
            description: md,
            interface,
            name: name.to_owned(),
            resources: fmu.resources_dir(),
            time: 0.0,
        };
        inst.component = Some(inst.instantiate()?);
        Ok(inst)
    }

    pub fn description(&self) -> &ModelDescription {
        &self.description
    }

    pub fn interface(&self) -> Interface {
        self.interface
    }

    /// Last time set on the instance, used in error messages.
    pub fn time(&self) -> f64 {
        self.time
    }

    /// Records the current simulation time for error messages.
    pub fn set_error_time(&mut self, t: f64) {
        self.time = t;
    }

    /// Returns the instance to the state after instantiation: `fmi2Reset` (`fmi3Reset`,
    /// `fmiResetSlave`), or, if that fails or the version has none (FMI 1.0 Model Exchange),
    /// frees it and instantiates again.
    ///
    /// # Errors
    /// [`FmuError::Instantiate`] if re-instantiation also fails.
    pub fn reset(&mut self) -> Result<(), FmuError> {
        if !self.api.can_reset(self.interface) {
            return self.reinstantiate();
        }
        if let Some(c) = self.component.as_mut() {
            let status = c.reset();
            if status <= Status::Warning {
                c.take_log();
                self.time = 0.0;
                return Ok(());
            }
            tracing::warn!(model = %self.description.model_name, ?status, "reset failed; instantiating again");
        }
        self.reinstantiate()
    }

    /// Frees the component and creates a fresh one (used after a failed simulation).
    ///
    /// # Errors
    /// [`FmuError::Instantiate`] with the FMU's messages.
    pub fn reinstantiate(&mut self) -> Result<(), FmuError> {
        // Free first: an FMU may allow only one live instance.
        self.component = None;
        self.component = Some(self.instantiate()?);
        self.time = 0.0;
        Ok(())
    }

    /// Calls `f` on the component and maps the status: `Ok`/`Warning`/`Discard` are returned,
    /// `function` is the FMI 2.0 name of what `f` calls (errors name this version's function);
    /// `Error`/`Fatal`/`Pending` become [`FmuError::Call`] with the FMU's logged messages.
    ///
    /// # Errors
    /// As above, and [`FmuError::Instantiate`] if the instance was lost.
    pub fn call(
        &mut self,
        function: &'static str,
        f: impl FnOnce(&mut Component) -> Status,
    ) -> Result<Status, FmuError> {
        let time = self.time;
        let c = self.component.as_mut().ok_or_else(|| lost(&self.api, self.interface, &self.description))?;
        let status = f(c);
        match status {
            Status::Ok | Status::Warning | Status::Discard => Ok(status),
            _ => {
                Err(FmuError::Call { function: self.api.function_name(function), status, time, messages: c.take_log() })
            }
        }
    }

    /// Direct access to the component for queries whose status the caller handles.
    ///
    /// # Errors
    /// [`FmuError::Instantiate`] if a failed re-instantiation left no component.
    pub fn component(&mut self) -> Result<&mut Component, FmuError> {
        self.component.as_mut().ok_or_else(|| lost(&self.api, self.interface, &self.description))
    }

    fn instantiate(&self) -> Result<Component, FmuError> {
        let kind = match self.interface {
            Interface::ModelExchange => FmuType::ModelExchange,
            Interface::CoSimulation => FmuType::CoSimulation,
        };
        self.api.instantiate(&self.description, &self.name, kind, &self.resources, false).map_err(|messages| {
            FmuError::Instantiate {
                function: self.api.instantiate_function(self.interface),
                model: self.description.model_name.clone(),
                messages,
            }
        })
    }
}

/// The error of a call on an instance that a failed re-instantiation left without a component.
fn lost(api: &ffi::Api, interface: Interface, description: &ModelDescription) -> FmuError {
    FmuError::Instantiate {
        function: api.instantiate_function(interface),
        model: description.model_name.clone(),
        messages: vec!["the instance was lost after a failed re-instantiation".into()],
    }
}
