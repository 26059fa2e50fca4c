//! Simulating an FMU from a [`SimSpec`]: Model Exchange with a diffsol integrator ([`me`]) or
//! Co-Simulation with `fmi2DoStep` ([`cs`]), returning the requested variables at exactly the
//! requested times. A [`Simulator`] keeps one instance warm and reuses it with `fmi2Reset`.

mod cs;
pub mod csv_io;
pub mod inputs;
#[cfg(feature = "integrators")]
mod me;
pub mod plan;
pub mod spec;

pub use inputs::InputTable;
#[cfg(feature = "integrators")]
pub use me::Stepper;
pub use spec::{OutputTimes, PortTerm, SimError, SimResult, SimSpec, SimStats, Solver, StateTerm};

use crate::fmu::{Fmu, FmuError, Instance, Interface};
use plan::Plan;

/// One FMU instance reused across simulations: reset between runs, re-instantiated after a
/// failed run.
pub struct Simulator {
    instance: Instance,
    used: bool,
    broken: bool,
}

impl Simulator {
    /// Instantiates `fmu` for `interface` (default: Model Exchange if offered, else Co-Simulation).
    ///
    /// # Errors
    /// [`SimError::Fmu`] if the FMU lacks the interface or cannot be instantiated.
    pub fn new(fmu: &Fmu, interface: Option<Interface>) -> Result<Self, SimError> {
        let interface = match interface {
            Some(i) => i,
            None => *fmu.interfaces().first().ok_or(FmuError::NoInterface(Interface::ModelExchange))?,
        };
        let instance = Instance::new(fmu, interface, &fmu.description.model_name)?;
        Ok(Simulator { instance, used: false, broken: false })
    }

    /// The interface this simulator's instance was created for.
    pub fn interface(&self) -> Interface {
        self.instance.interface()
    }

    /// Runs one simulation. `spec.interface`, if given, must match [`Simulator::interface`].
    ///
    /// # Errors
    /// [`SimError::Invalid`] for a bad request (checked before the FMU is touched), otherwise
    /// the FMU, integrator or budget failure with the time it happened.
    pub fn run(&mut self, spec: &SimSpec) -> Result<SimResult, SimError> {
        let plan = Plan::new(self.instance.description(), &[self.instance.interface()], spec)?;
        if self.broken {
            self.instance.reinstantiate()?;
            self.broken = false;
        } else if self.used {
            self.instance.reset()?;
        }
        self.used = true;
        let result = match plan.interface {
            Interface::ModelExchange => model_exchange(&mut self.instance, &plan),
            Interface::CoSimulation => cs::run(&mut self.instance, &plan),
        };
        match &result {
            Ok(_) => {
                let _ = self.instance.call("fmi2Terminate", |c| c.terminate());
            }
            Err(_) => self.broken = true,
        }
        result
    }
}

/// Simulates `fmu` once with a fresh instance.
///
/// The `decay` example is dx/dt = −k·x with x(0) = 1: at k = 2, x(1) = e⁻².
///
/// ```
/// use fmucal_shared::fmu::Fmu;
/// use fmucal_shared::sim::{SimSpec, simulate};
///
/// let fmu = Fmu::load(&fmucal_models::example("decay").unwrap()).unwrap();
/// let spec = SimSpec {
///     stop_time: Some(1.0),
///     tolerance: Some(1e-8),
///     parameters: vec![("k".into(), "2".into())],
///     outputs: vec!["x".into()],
///     ..SimSpec::default()
/// };
/// let result = simulate(&fmu, &spec).unwrap();
/// let x = result.column("x").unwrap();
/// assert!((x.last().unwrap() - (-2.0f64).exp()).abs() < 1e-6);
/// ```
///
/// # Errors
/// See [`Simulator::run`].
pub fn simulate(fmu: &Fmu, spec: &SimSpec) -> Result<SimResult, SimError> {
    let interface = match spec.interface {
        Some(i) => Some(i),
        None => fmu.interfaces().first().copied(),
    };
    // Check the request before instantiating, so bad input never runs model code.
    Plan::new(&fmu.description, &fmu.interfaces(), spec)?;
    Simulator::new(fmu, interface)?.run(spec)
}

/// Times closer than this to `t` are the same instant: data files, output grids and integrator
/// times differ by round-off (1e-12 relative, at least 1e-12). One rule for inputs and drivers.
pub(crate) fn time_eps(t: f64) -> f64 {
    1e-12 * t.abs().max(1.0)
}

/// Runs a Model Exchange simulation with diffsol's integrators.
#[cfg(feature = "integrators")]
fn model_exchange(inst: &mut Instance, plan: &Plan) -> Result<SimResult, SimError> {
    me::run(inst, plan)
}

/// A build without the integrators (the coordinator never simulates) refuses Model Exchange.
#[cfg(not(feature = "integrators"))]
fn model_exchange(_inst: &mut Instance, _plan: &Plan) -> Result<SimResult, SimError> {
    Err(SimError::Invalid("this build has no Model Exchange integrators (the feature `integrators` is off)".into()))
}

/// Whether `a` and `b` are the same instant up to round-off ([`time_eps`]); looser than diffsol's
/// own test unless its step is far longer than the time (the ME driver's `set_stop` catches that).
#[cfg_attr(not(feature = "integrators"), allow(dead_code))] // only the Model Exchange driver uses it
pub(crate) fn same_instant(a: f64, b: f64) -> bool {
    (a - b).abs() <= time_eps(a.abs().max(b.abs()))
}

/// Common start of both drivers: experiment setup, parameters, inputs at the start time, and
/// initialisation mode. The tolerance goes to Co-Simulation FMUs only, as FMPy does. FMI 2.0
/// lets a Model Exchange FMU use it for its internal solvers (algebraic loops), but exported ME
/// FMUs warn about it at every run, and those solvers keep their own defaults without it: the
/// trade-off FMPy makes.
fn initialize(inst: &mut Instance, plan: &Plan) -> Result<(), SimError> {
    inst.set_error_time(plan.start);
    let tolerance = (plan.interface == Interface::CoSimulation).then_some(plan.tolerance);
    inst.call("fmi2SetupExperiment", |c| c.setup_experiment(tolerance, plan.start, Some(plan.stop)))?;
    plan.apply_settings(inst)?;
    plan.set_inputs(inst, plan.start)?;
    inst.call("fmi2EnterInitializationMode", |c| c.enter_initialization_mode())?;
    inst.call("fmi2ExitInitializationMode", |c| c.exit_initialization_mode())?;
    Ok(())
}

/// Collects output rows.
struct Recorder {
    time: Vec<f64>,
    columns: Vec<Vec<f64>>,
    row: Vec<f64>,
    names: Vec<String>,
    event_times: Vec<f64>,
}

impl Recorder {
    fn new(plan: &Plan) -> Self {
        let n = plan.outputs.len();
        Recorder {
            time: Vec::with_capacity(plan.grid.len()),
            columns: (0..n).map(|_| Vec::with_capacity(plan.grid.len())).collect(),
            row: vec![0.0; n],
            names: plan.outputs.iter().map(|o| o.name.clone()).collect(),
            event_times: vec![],
        }
    }

    /// Reads the outputs from the instance (whose time and states must be set to `t`).
    fn record(&mut self, inst: &mut Instance, plan: &Plan, t: f64) -> Result<(), FmuError> {
        plan.read_outputs(inst, &mut self.row)?;
        self.time.push(t);
        for (col, v) in self.columns.iter_mut().zip(&self.row) {
            col.push(*v);
        }
        Ok(())
    }

    fn finish(self, steps: u64, rhs_evaluations: u64, terminated_early: bool) -> SimResult {
        let events = self.event_times.len() as u64;
        SimResult {
            names: self.names,
            time: self.time,
            columns: self.columns,
            event_times: self.event_times,
            terminated_early,
            stats: SimStats { steps, rhs_evaluations, events },
        }
    }
}
