//! The corrected model behind the C functions: the original FMU's instance, with the job's
//! effects applied where `fmucal simulate` applies them ([`fmucal_shared::sim`]), so the
//! exported FMU and fmucal's simulation of the original with its effects are one computation.
//!
//! - Effect parameters (`effects[K].NAME`) live here; setting one changes the term at once.
//! - A port term's port keeps the value the importer set as its base; the original sees base +
//!   term, recomputed from the signal whenever the model is evaluated after initialisation.
//! - A state term is added to the derivative `fmi2GetDerivatives` returns and to every output
//!   that is that derivative.
//! - A kinked term (the dead zone) adds event indicators after the original's.
//! - A sensor effect's `effects[K].output` is the effect applied to the original output; an
//!   actuator effect transforms the input before the original sees it.
//! - Co-Simulation over a Model Exchange original integrates it with
//!   [`fmucal_shared::sim::Stepper`]; over a Co-Simulation original, port terms are applied at
//!   each communication point, as `fmucal simulate` does.
#![deny(unsafe_code)]

use std::collections::HashMap;
use std::path::Path;

use fmucal_fmi::ffi::{EventInfo, Status};
use fmucal_fmi::{Fmu, Instance, Interface};
use fmucal_shared::effects::{self, Found, SeriesEffect};
use fmucal_shared::export::{CONFIG_FORMAT, CONFIG_PATH, ORIGINAL_DIR, RuntimeConfig, Target};
use fmucal_shared::sim::inputs::Side;
use fmucal_shared::sim::plan::{Plan, PortBase};
use fmucal_shared::sim::{PortTerm, SimSpec, StateTerm, Stepper};

/// The state of the FMI 2.0 state machine the importer drives.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Mode {
    Instantiated,
    Initialization,
    /// Model Exchange Event Mode, or Co-Simulation Step Mode.
    Event,
    Continuous,
    Terminated,
}

/// Where an effect parameter's value is used.
#[derive(Debug, Clone, Copy)]
enum Use {
    Port(usize),
    State(usize),
    /// A state effect with a reaction: its own term and the reaction's, which shares every
    /// parameter but the strength; the effect's last parameter is the reaction's strength.
    Reacting(usize, usize),
    Series(usize),
}

#[derive(Clone)]
struct SeriesTerm {
    kind: &'static dyn SeriesEffect,
    parameters: Vec<f64>,
    /// The original variable: the sensor's output or the actuator's input.
    vr: u32,
    /// A sensor's corrected output; `None` for an actuator.
    output_vr: Option<u32>,
}

/// One instance of the corrected model.
pub struct Corrected {
    config: RuntimeConfig,
    fmu: Fmu,
    inst: Instance,
    /// The interface the importer instantiated.
    interface: Interface,
    /// Co-Simulation over a Model Exchange original.
    integrate: bool,
    plan: Plan,
    /// The plan and the series terms as instantiated, which `fmi2Reset` restores.
    initial: (Plan, Vec<SeriesTerm>),
    stepper: Option<Stepper>,
    mode: Mode,
    params: HashMap<u32, (Use, usize)>,
    series: Vec<SeriesTerm>,
    /// Indicators of kinked terms: (port term?, term index, how many).
    kinked: Vec<(bool, usize, usize)>,
    nx: usize,
    fmu_nz: usize,
    /// Actuated inputs as the importer set them.
    raw_inputs: HashMap<u32, f64>,
    strings: HashMap<u32, String>,
    start_time: f64,
    stop_time: Option<f64>,
    tolerance: Option<f64>,
}

/// A failure, as the importer's logger hears it.
pub type Failure = String;

fn fail(e: impl std::fmt::Display) -> Failure {
    e.to_string()
}

impl Corrected {
    /// Loads the original from `resources` (the exported FMU's unpacked `resources/` folder) and
    /// instantiates it for `interface`; `guid`, if given, must be this FMU's.
    ///
    /// # Errors
    /// A line saying what is missing or broken.
    pub fn new(resources: &Path, interface: Interface, name: &str, guid: Option<&str>) -> Result<Corrected, Failure> {
        let path = resources.join(CONFIG_PATH.trim_start_matches("resources/"));
        let text = std::fs::read_to_string(&path).map_err(|e| format!("cannot read {}: {e}", path.display()))?;
        let config: RuntimeConfig = serde_json::from_str(&text).map_err(|e| format!("{}: {e}", path.display()))?;
        if config.format != CONFIG_FORMAT {
            return Err(format!("{} is format {}, this runtime reads {CONFIG_FORMAT}", path.display(), config.format));
        }
        // The importer's GUID must be this FMU's (its description sits beside resources/).
        if let (Some(guid), Ok(xml)) = (guid, std::fs::read_to_string(resources.join("../modelDescription.xml")))
            && let Ok(md) = fmucal_fmi::ModelDescription::parse(&xml)
            && md.guid != guid
        {
            return Err(format!("fmuGUID {guid:?} is not this FMU's ({:?})", md.guid));
        }
        let fmu = Fmu::open_unpacked(&resources.join(ORIGINAL_DIR.trim_start_matches("resources/")), String::new())
            .map_err(fail)?;
        let offers = fmu.interfaces();
        let (inner, integrate) = match interface {
            Interface::ModelExchange => (Interface::ModelExchange, false),
            Interface::CoSimulation if offers.contains(&Interface::ModelExchange) => (Interface::ModelExchange, true),
            Interface::CoSimulation => (Interface::CoSimulation, false),
        };
        if !offers.contains(&inner) {
            return Err(format!("the original FMU does not offer {inner}"));
        }
        let inst = Instance::new(&fmu, inner, name).map_err(fail)?;
        let md = fmu.description.clone();

        let mut spec = SimSpec {
            interface: Some(inner),
            parameters: config.settings.clone(),
            solver: config.solver.parse().map_err(|e: String| e)?,
            tolerance: config.tolerance,
            ..SimSpec::default()
        };
        let mut params = HashMap::new();
        let mut series = vec![];
        for e in &config.effects {
            let values: Vec<f64> = e.parameters.iter().map(|p| p.start).collect();
            let place = match &e.target {
                Target::Port { port, signal } => {
                    spec.port_terms.push(PortTerm {
                        kind: e.kind.clone(),
                        port: port.clone(),
                        signal: signal.clone(),
                        parameters: values,
                    });
                    Use::Port(spec.port_terms.len() - 1)
                }
                Target::State { state, signal, reaction } => {
                    let terms = StateTerm::of_effect(&e.kind, state, signal, reaction.as_deref(), &values);
                    let first = spec.state_terms.len();
                    let reacting = terms.len() == 2;
                    spec.state_terms.extend(terms);
                    if reacting { Use::Reacting(first, first + 1) } else { Use::State(first) }
                }

                Target::Sensor { output: name } | Target::Actuator { input: name } => {
                    let Ok(Found::Series(kind)) = effects::find(&e.kind) else {
                        return Err(format!("effects[{}]: {} is not a sensor or actuator effect", e.index, e.kind));
                    };
                    let v = md.variable(name).ok_or_else(|| format!("effects[{}]: no variable {name:?}", e.index))?;
                    series.push(SeriesTerm {
                        kind,
                        parameters: values,
                        vr: md.base_of(v).value_reference,
                        output_vr: e.output_value_reference,
                    });
                    Use::Series(series.len() - 1)
                }
            };
            for (j, p) in e.parameters.iter().enumerate() {
                params.insert(p.value_reference, (place, j));
            }
        }
        let plan = Plan::new(&md, &[inner], &spec).map_err(fail)?;
        let count = |e: &'static dyn effects::PortEffect, p: &[f64]| e.kinks(p).len();
        let mut kinked = vec![];
        for (i, t) in plan.port_terms.iter().enumerate() {
            kinked.push((true, i, count(t.effect, &t.parameters)));
        }
        for (i, t) in plan.state_terms.iter().enumerate() {
            kinked.push((false, i, count(t.effect, &t.parameters)));
        }
        kinked.retain(|k| k.2 > 0);
        let de = md.default_experiment.clone().unwrap_or_default();
        let mut c = Corrected {
            nx: md.states().len(),
            fmu_nz: md.number_of_event_indicators,
            config,
            fmu,
            inst,
            interface,
            integrate,
            initial: (plan.clone(), series.clone()),
            plan,
            stepper: None,
            mode: Mode::Instantiated,
            params,
            series,
            kinked,
            raw_inputs: HashMap::new(),
            strings: HashMap::new(),
            start_time: de.start_time.unwrap_or(0.0),
            stop_time: None,
            tolerance: None,
        };
        c.plan.apply_settings(&mut c.inst).map_err(fail)?;
        c.actuate_starts()?;
        Ok(c)
    }

    fn live(&self) -> bool {
        matches!(self.mode, Mode::Event | Mode::Continuous)
    }

    /// The port terms on the original, from the signals at its current time and states.
    fn apply_ports(&mut self) -> Result<(), Failure> {
        if self.live() && !self.plan.port_terms.is_empty() {
            let t = self.inst.time();
            self.plan.apply_port_terms(&mut self.inst, t, Side::Right).map_err(fail)?;
        }
        Ok(())
    }

    fn states(&mut self) -> Result<Vec<f64>, Failure> {
        let mut x = vec![0.0; self.nx];
        if self.nx > 0 {
            self.inst.call("fmi2GetContinuousStates", |c| c.get_continuous_states(&mut x)).map_err(fail)?;
        }
        Ok(x)
    }

    fn original_real(&mut self, vrs: &[u32]) -> Result<Vec<f64>, Failure> {
        let mut out = vec![0.0; vrs.len()];
        if !vrs.is_empty() {
            self.inst.call("fmi2GetReal", |c| c.get_real(vrs, &mut out)).map_err(fail)?;
        }
        Ok(out)
    }

    pub fn setup_experiment(&mut self, tolerance: Option<f64>, start: f64, stop: Option<f64>) -> Result<(), Failure> {
        self.start_time = start;
        self.stop_time = stop;
        self.tolerance = tolerance;
        let tol = if self.integrate { None } else { tolerance };
        self.inst.set_error_time(start);
        self.inst.call("fmi2SetupExperiment", |c| c.setup_experiment(tol, start, stop)).map_err(fail)?;
        Ok(())
    }

    pub fn enter_initialization_mode(&mut self) -> Result<(), Failure> {
        self.inst.call("fmi2EnterInitializationMode", |c| c.enter_initialization_mode()).map_err(fail)?;
        self.mode = Mode::Initialization;
        Ok(())
    }

    pub fn exit_initialization_mode(&mut self) -> Result<(), Failure> {
        self.inst.call("fmi2ExitInitializationMode", |c| c.exit_initialization_mode()).map_err(fail)?;
        self.mode = Mode::Event;
        if self.integrate {
            self.plan.start = self.start_time;
            self.plan.stop = self.stop_time.unwrap_or(f64::INFINITY).max(self.start_time);
            self.plan.grid.clear();
            // The importer's tolerance wins; the plan holds the job's (else the default
            // experiment's, else 1e-6).
            if let Some(tol) = self.tolerance.filter(|t| *t > 0.0 && *t < 1.0) {
                self.plan.tolerance = tol;
            }
            if let Some(stop) = self.stop_time.filter(|s| *s > self.start_time) {
                self.plan.max_step = Some((stop - self.start_time) / 50.0);
            }
            let stepper = Stepper::start(&mut self.inst, &self.plan).map_err(fail)?;
            self.stepper = Some(stepper);
            self.mode = Mode::Continuous;
        }
        Ok(())
    }

    pub fn terminate(&mut self) -> Result<(), Failure> {
        self.mode = Mode::Terminated;
        self.inst.call("fmi2Terminate", |c| c.terminate()).map(|_| ()).map_err(fail)
    }

    /// Back to the state after instantiation, with the exported defaults.
    pub fn reset(&mut self) -> Result<(), Failure> {
        self.inst.call("fmi2Reset", |c| c.reset()).map_err(fail)?;
        // The effect parameters and port bases as exported, and the plan's times.
        (self.plan, self.series) = self.initial.clone();
        self.raw_inputs.clear();
        self.strings.clear();
        self.stepper = None;
        self.mode = Mode::Instantiated;
        self.plan.apply_settings(&mut self.inst).map_err(fail)?;
        self.actuate_starts()
    }

    /// Each actuated input at its start value (the exported default, else the description's),
    /// transformed, so that the original sees the effect even if the importer never sets it.
    fn actuate_starts(&mut self) -> Result<(), Failure> {
        let md = self.fmu.description.clone();
        let mut vrs = vec![];
        for s in self.series.iter().filter(|s| s.output_vr.is_none()) {
            if !vrs.contains(&s.vr) {
                vrs.push(s.vr);
            }
        }
        for vr in vrs {
            let var = md
                .variables
                .iter()
                .find(|v| v.value_reference == vr && v.var_type == fmucal_fmi::schema::VarType::Real);
            let set =
                self.config.settings.iter().rev().find_map(|(n, text)| {
                    md.variable(n).filter(|v| v.value_reference == vr).and(text.parse::<f64>().ok())
                });
            let start = var.and_then(|v| match &v.start {
                Some(fmucal_fmi::schema::Value::Real(x)) => Some(*x),
                _ => None,
            });
            let raw = set.or(start).unwrap_or(0.0);
            self.raw_inputs.insert(vr, raw);
            let u = self.actuated(vr, raw);
            self.inst.call("fmi2SetReal", |c| c.set_real(&[vr], &[u])).map_err(fail)?;
        }
        Ok(())
    }

    fn set_parameter(&mut self, place: Use, j: usize, v: f64) {
        match place {
            Use::Port(i) => self.plan.port_terms[i].parameters[j] = v,
            Use::State(i) => self.plan.state_terms[i].parameters[j] = v,
            Use::Reacting(own, reaction) => {
                let n = self.plan.state_terms[own].parameters.len();
                if j == n {
                    self.plan.state_terms[reaction].parameters[0] = v;
                } else {
                    self.plan.state_terms[own].parameters[j] = v;
                    if j > 0 {
                        self.plan.state_terms[reaction].parameters[j] = v;
                    }
                }
            }
            Use::Series(i) => self.series[i].parameters[j] = v,
        }
    }

    fn parameter(&self, place: Use, j: usize) -> f64 {
        match place {
            Use::Port(i) => self.plan.port_terms[i].parameters[j],
            Use::State(i) => self.plan.state_terms[i].parameters[j],
            Use::Reacting(own, reaction) => match self.plan.state_terms[own].parameters.get(j) {
                Some(v) => *v,
                None => self.plan.state_terms[reaction].parameters[0],
            },
            Use::Series(i) => self.series[i].parameters[j],
        }
    }

    /// An actuated input as the original sees it.
    fn actuated(&self, vr: u32, raw: f64) -> f64 {
        let mut u = raw;
        for s in self.series.iter().filter(|s| s.output_vr.is_none() && s.vr == vr) {
            u = s.kind.apply(&s.parameters, &[0.0], &[u])[0];
        }
        u
    }

    pub fn get_real(&mut self, vrs: &[u32], out: &mut [f64]) -> Result<(), Failure> {
        self.apply_ports()?;
        // What the original answers: every reference that is not the wrapper's own, and the
        // outputs behind the sensor effects.
        let mut ask: Vec<u32> = vec![];
        for vr in vrs {
            if self.params.contains_key(vr) || self.raw_inputs.contains_key(vr) {
                continue;
            }
            let vr = self.series.iter().find(|s| s.output_vr == Some(*vr)).map_or(*vr, |s| s.vr);
            if !ask.contains(&vr) {
                ask.push(vr);
            }
        }
        let values = self.original_real(&ask)?;
        let mut value_of: HashMap<u32, f64> = ask.iter().copied().zip(values).collect();
        // A state term is part of its derivative, wherever that is read.
        if self.mode != Mode::Instantiated && !self.plan.state_terms.is_empty() {
            let wanted: Vec<usize> = (0..self.plan.state_terms.len())
                .filter(|&i| value_of.contains_key(&self.plan.state_terms[i].derivative_vr))
                .collect();
            if !wanted.is_empty() {
                let x = self.states()?;
                for i in wanted {
                    let t = &self.plan.state_terms[i];
                    if !t.effect.vanishes(&t.parameters)
                        && let Some(v) = value_of.get_mut(&t.derivative_vr)
                    {
                        *v += t.effect.term(&t.parameters, x[t.signal]);
                    }
                }
            }
        }
        let t = self.inst.time();
        for (vr, slot) in vrs.iter().zip(out.iter_mut()) {
            *slot = if let Some(&(place, j)) = self.params.get(vr) {
                self.parameter(place, j)
            } else if let Some(raw) = self.raw_inputs.get(vr) {
                *raw
            } else if let Some(PortBase::Value(base)) =
                self.plan.port_terms.iter().find(|t| t.port_vr == *vr).map(|t| t.base)
            {
                // The port reads back what was set, not base + term.
                base
            } else if let Some(s) = self.series.iter().find(|s| s.output_vr == Some(*vr)) {
                let y = value_of.get(&s.vr).copied().unwrap_or(f64::NAN);
                s.kind.apply(&s.parameters, &[t], &[y])[0]
            } else {
                value_of.get(vr).copied().unwrap_or(f64::NAN)
            };
        }
        Ok(())
    }

    pub fn set_real(&mut self, vrs: &[u32], values: &[f64]) -> Result<(), Failure> {
        let mut pass_vrs = vec![];
        let mut pass_values = vec![];
        let mut ports_changed = false;
        let mut inputs_changed = vec![];
        for (&vr, &v) in vrs.iter().zip(values) {
            if let Some(&(place, j)) = self.params.get(&vr) {
                self.set_parameter(place, j, v);
                ports_changed = true;
                if let Use::Series(i) = place
                    && self.series[i].output_vr.is_none()
                {
                    inputs_changed.push(self.series[i].vr);
                }
            } else if self.plan.port_terms.iter().any(|t| t.port_vr == vr) {
                for t in self.plan.port_terms.iter_mut().filter(|t| t.port_vr == vr) {
                    t.base = PortBase::Value(v);
                }
                ports_changed = true;
                // Until the terms apply (after initialisation) the port holds its base.
                if !self.live() {
                    pass_vrs.push(vr);
                    pass_values.push(v);
                }
            } else if self.series.iter().any(|s| s.output_vr.is_none() && s.vr == vr) {
                self.raw_inputs.insert(vr, v);
                pass_vrs.push(vr);
                pass_values.push(self.actuated(vr, v));
            } else {
                pass_vrs.push(vr);
                pass_values.push(v);
            }
        }
        for vr in inputs_changed {
            if let Some(&raw) = self.raw_inputs.get(&vr) {
                pass_vrs.push(vr);
                pass_values.push(self.actuated(vr, raw));
            }
        }
        if !pass_vrs.is_empty() {
            self.inst.call("fmi2SetReal", |c| c.set_real(&pass_vrs, &pass_values)).map_err(fail)?;
        }
        if ports_changed {
            self.apply_ports()?;
        }
        Ok(())
    }

    pub fn get_integer(&mut self, vrs: &[u32], out: &mut [i32]) -> Result<(), Failure> {
        self.apply_ports()?;
        self.inst.call("fmi2GetInteger", |c| c.get_integer(vrs, out)).map(|_| ()).map_err(fail)
    }

    pub fn set_integer(&mut self, vrs: &[u32], values: &[i32]) -> Result<(), Failure> {
        self.inst.call("fmi2SetInteger", |c| c.set_integer(vrs, values)).map(|_| ()).map_err(fail)
    }

    pub fn get_boolean(&mut self, vrs: &[u32], out: &mut [i32]) -> Result<(), Failure> {
        self.apply_ports()?;
        self.inst.call("fmi2GetBoolean", |c| c.get_boolean(vrs, out)).map(|_| ()).map_err(fail)
    }

    pub fn set_boolean(&mut self, vrs: &[u32], values: &[i32]) -> Result<(), Failure> {
        self.inst.call("fmi2SetBoolean", |c| c.set_boolean(vrs, values)).map(|_| ()).map_err(fail)
    }

    /// String variables read back what was set, else their start value (the import layer
    /// has no way to read a String from the original).
    pub fn get_string(&self, vr: u32) -> String {
        if let Some(s) = self.strings.get(&vr) {
            return s.clone();
        }
        self.fmu
            .description
            .variables
            .iter()
            .find(|v| v.value_reference == vr && v.var_type == fmucal_fmi::schema::VarType::String)
            .and_then(|v| match &v.start {
                Some(fmucal_fmi::schema::Value::String(s)) => Some(s.clone()),
                _ => None,
            })
            .unwrap_or_default()
    }

    pub fn set_string(&mut self, vrs: &[u32], values: &[&str]) -> Result<(), Failure> {
        self.inst.call("fmi2SetString", |c| c.set_string(vrs, values)).map_err(fail)?;
        for (vr, v) in vrs.iter().zip(values) {
            self.strings.insert(*vr, (*v).to_owned());
        }
        Ok(())
    }

    // Model Exchange.

    pub fn enter_event_mode(&mut self) -> Result<(), Failure> {
        self.inst.call("fmi2EnterEventMode", |c| c.enter_event_mode()).map_err(fail)?;
        self.mode = Mode::Event;
        self.apply_ports()
    }

    pub fn new_discrete_states(&mut self, info: &mut EventInfo) -> Result<(), Failure> {
        self.inst.call("fmi2NewDiscreteStates", |c| c.new_discrete_states(info)).map(|_| ()).map_err(fail)
    }

    pub fn enter_continuous_time_mode(&mut self) -> Result<(), Failure> {
        self.inst.call("fmi2EnterContinuousTimeMode", |c| c.enter_continuous_time_mode()).map_err(fail)?;
        self.mode = Mode::Continuous;
        Ok(())
    }

    pub fn completed_integrator_step(&mut self) -> Result<(bool, bool), Failure> {
        self.apply_ports()?;
        let mut out = (Status::Ok, false, false);
        self.inst
            .call("fmi2CompletedIntegratorStep", |c| {
                out = c.completed_integrator_step();
                out.0
            })
            .map_err(fail)?;
        Ok((out.1, out.2))
    }

    pub fn set_time(&mut self, t: f64) -> Result<(), Failure> {
        self.inst.set_error_time(t);
        self.inst.call("fmi2SetTime", |c| c.set_time(t)).map(|_| ()).map_err(fail)
    }

    pub fn set_continuous_states(&mut self, x: &[f64]) -> Result<(), Failure> {
        self.inst.call("fmi2SetContinuousStates", |c| c.set_continuous_states(x)).map(|_| ()).map_err(fail)
    }

    pub fn get_derivatives(&mut self, dx: &mut [f64]) -> Result<(), Failure> {
        self.apply_ports()?;
        self.inst.call("fmi2GetDerivatives", |c| c.get_derivatives(dx)).map_err(fail)?;
        if !self.plan.state_terms.is_empty() {
            let x = self.states()?;
            self.plan.add_state_terms(&x, dx);
        }
        Ok(())
    }

    pub fn number_of_event_indicators(&self) -> usize {
        self.fmu_nz + self.kinked.iter().map(|k| k.2).sum::<usize>()
    }

    pub fn get_event_indicators(&mut self, z: &mut [f64]) -> Result<(), Failure> {
        if z.len() != self.number_of_event_indicators() {
            return Err(format!(
                "fmi2GetEventIndicators: asked for {} indicators, the model has {}",
                z.len(),
                self.number_of_event_indicators()
            ));
        }
        self.apply_ports()?;
        let (own, terms) = z.split_at_mut(self.fmu_nz);
        if !own.is_empty() {
            self.inst.call("fmi2GetEventIndicators", |c| c.get_event_indicators(own)).map_err(fail)?;
        }
        let mut k = 0;
        for &(port, i, n) in &self.kinked {
            let (vr, kinks) = if port {
                let t = &self.plan.port_terms[i];
                (t.signal_vr, t.effect.kinks(&t.parameters))
            } else {
                let t = &self.plan.state_terms[i];
                (t.signal_vr, t.effect.kinks(&t.parameters))
            };
            let mut s = [0.0];
            self.inst.call("fmi2GetReal", |c| c.get_real(&[vr], &mut s)).map_err(fail)?;
            for j in 0..n {
                terms[k] = s[0] - kinks.get(j).copied().unwrap_or(f64::INFINITY);
                k += 1;
            }
        }
        Ok(())
    }

    pub fn get_continuous_states(&mut self, x: &mut [f64]) -> Result<(), Failure> {
        self.inst.call("fmi2GetContinuousStates", |c| c.get_continuous_states(x)).map(|_| ()).map_err(fail)
    }

    pub fn get_nominals(&mut self, x: &mut [f64]) -> Result<(), Failure> {
        self.inst
            .call("fmi2GetNominalsOfContinuousStates", |c| c.get_nominals_of_continuous_states(x))
            .map(|_| ())
            .map_err(fail)
    }

    // Co-Simulation.

    /// One communication step. Returns whether the model asked to terminate.
    pub fn do_step(&mut self, t: f64, h: f64) -> Result<bool, Failure> {
        if self.interface != Interface::CoSimulation {
            return Err("fmi2DoStep on a Model Exchange instance".into());
        }
        if !(h >= 0.0) || !h.is_finite() {
            return Err(format!("fmi2DoStep: step size {h} is not a non-negative number"));
        }
        if !t.is_finite() {
            return Err(format!("fmi2DoStep: the communication point {t} is not a number"));
        }
        if !self.live() {
            return Err("fmi2DoStep before fmi2ExitInitializationMode (or after fmi2Terminate)".into());
        }
        if self.integrate && self.stepper.is_none() {
            return Err("fmi2DoStep: the model has not been initialised".into());
        }
        if let Some(stepper) = &mut self.stepper {
            if (stepper.time() - t).abs() > 1e-9 * t.abs().max(1.0) {
                return Err(format!(
                    "fmi2DoStep: the step starts at {t}, but the model stands at {} (this FMU cannot go back)",
                    stepper.time()
                ));
            }
            stepper.advance(&mut self.inst, &self.plan, t + h).map_err(fail)?;
            return Ok(stepper.terminated());
        }
        self.apply_ports_at(t)?;
        self.inst.set_error_time(t);
        let status = self.inst.call("fmi2DoStep", |c| c.do_step(t, h)).map_err(fail)?;
        if status != Status::Discard {
            self.inst.set_error_time(t + h);
        }
        Ok(status == Status::Discard)
    }

    fn apply_ports_at(&mut self, t: f64) -> Result<(), Failure> {
        if !self.plan.port_terms.is_empty() {
            self.plan.apply_port_terms(&mut self.inst, t, Side::Right).map_err(fail)?;
        }
        Ok(())
    }

    /// Whether the model asked to end the simulation in its last step (`fmi2Terminated`).
    pub fn terminated(&mut self) -> bool {
        match &self.stepper {
            Some(s) => s.terminated(),
            None => self.inst.component().ok().and_then(|c| c.terminated()).unwrap_or(false),
        }
    }

    /// The time the model stands at.
    pub fn time(&self) -> f64 {
        self.stepper.as_ref().map_or_else(|| self.inst.time(), Stepper::time)
    }
}
