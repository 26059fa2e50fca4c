//! Resolves a [`SimSpec`] against a model description before any FMU call: defaults from
//! `DefaultExperiment`, the output grid, typed and range-checked parameter values, input and
//! output variables. Every bad request is rejected here with a message naming the culprit.

use std::time::Instant;

use super::inputs::Side;
use super::spec::{OutputTimes, PortTerm, SimError, SimSpec, Solver, StateTerm};
use crate::effects::{self, PortEffect};
use crate::fmu::schema::{Causality, ScalarVariable, VarType, Variability};
use crate::fmu::{FmuError, Instance, Interface, ModelDescription};
use crate::quote::quote_user_text;
use crate::series::TimeSeries;

/// A typed value to set on the FMU.
#[derive(Debug, Clone, PartialEq)]
pub enum Setting {
    Real(u32, f64),
    Integer(u32, i32),
    Boolean(u32, bool),
    String(u32, String),
    /// FMI 3.0 only.
    Binary(u32, Vec<u8>),
}

/// A variable read back or written, with its value reference and base type.
#[derive(Debug, Clone)]
pub struct VarRef {
    pub name: String,
    pub vr: u32,
    pub var_type: VarType,
    /// An FMI 1.0 negated alias: read and written as minus the value behind `vr`.
    pub negated: bool,
}

impl VarRef {
    /// The value of the variable from the value behind its value reference, or back.
    fn sign(&self, v: f64) -> f64 {
        match (self.negated, self.var_type) {
            (false, _) => v,
            (true, VarType::Boolean) => f64::from(u8::from(v == 0.0)),
            (true, _) => -v,
        }
    }
}

/// An input column bound to an FMU input.
#[derive(Debug, Clone)]
pub struct InputBinding {
    pub var: VarRef,
    pub column: usize,
    /// Held (discrete or non-Real) rather than interpolated.
    pub hold: bool,
}

/// A port term resolved against the model: the effect, the port and signal value references,
/// and what the port holds without the effect.
#[derive(Clone)]
pub struct PlannedTerm {
    pub effect: &'static dyn PortEffect,
    pub parameters: Vec<f64>,
    pub signal_vr: u32,
    pub port_vr: u32,
    /// The input column mapped to the port, else the port's start value.
    pub base: PortBase,
}

/// A term's kinks, none where it vanishes.
fn active_kinks(effect: &dyn PortEffect, parameters: &[f64]) -> Vec<f64> {
    if effect.vanishes(parameters) { vec![] } else { effect.kinks(parameters) }
}

impl PlannedTerm {
    fn kinks(&self) -> Vec<f64> {
        active_kinks(self.effect, &self.parameters)
    }
}

impl std::fmt::Debug for PlannedTerm {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}({:?}) of vr {} into vr {}", self.effect.name(), self.parameters, self.signal_vr, self.port_vr)
    }
}

/// A state term resolved against the model: the effect, the state whose derivative it changes
/// and the state it reads, by position in the state vector, and the value references of the
/// signal (to read it from the FMU) and of the derivative (outputs that share it get the term
/// too).
#[derive(Clone)]
pub struct PlannedStateTerm {
    pub effect: &'static dyn PortEffect,
    pub parameters: Vec<f64>,
    pub state: usize,
    pub signal: usize,
    pub signal_vr: u32,
    pub derivative_vr: u32,
}

impl PlannedStateTerm {
    fn kinks(&self) -> Vec<f64> {
        active_kinks(self.effect, &self.parameters)
    }
}

impl std::fmt::Debug for PlannedStateTerm {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{}({:?}) of state {} into der(state {})",
            self.effect.name(),
            self.parameters,
            self.signal,
            self.state
        )
    }
}

/// What an injection port holds before effects are added.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PortBase {
    Column(usize),
    Value(f64),
}

/// The resolved request.
#[derive(Debug, Clone)]
pub struct Plan {
    pub interface: Interface,
    pub start: f64,
    pub stop: f64,
    pub grid: Vec<f64>,
    pub tolerance: f64,
    pub solver: Solver,
    pub max_step: Option<f64>,
    pub max_steps: u64,
    pub deadline: Option<Instant>,
    pub settings: Vec<Setting>,
    pub inputs: Option<TimeSeries>,
    pub input_bindings: Vec<InputBinding>,
    pub outputs: Vec<VarRef>,
    /// Value references of the Real outputs and their positions in `outputs`.
    pub real_output_vrs: Vec<u32>,
    pub real_output_slots: Vec<usize>,
    pub port_terms: Vec<PlannedTerm>,
    pub state_terms: Vec<PlannedStateTerm>,
    /// Per Real output slot, the state terms whose derivative it is.
    pub output_state_terms: Vec<(usize, Vec<usize>)>,
}

fn invalid(msg: impl Into<String>) -> SimError {
    SimError::Invalid(msg.into())
}

/// The additive kind named `kind` (a port or state term, not a series effect) given exactly
/// its parameters; `to` says where it was to be added.
fn additive_kind(kind: &str, parameters: &[f64], to: &str) -> Result<&'static dyn PortEffect, SimError> {
    let effect = match effects::find(kind).map_err(|e| invalid(e.to_string()))? {
        effects::Found::Port(e) => e,
        effects::Found::Series(_) => {
            return Err(invalid(format!("{kind} changes a measured series, it is not added to {to}")));
        }
    };
    if parameters.len() != effect.parameters().len() {
        return Err(invalid(format!(
            "{kind} takes {} parameters ({}), got {}",
            effect.parameters().len(),
            effect.parameters().join(", "),
            parameters.len()
        )));
    }
    Ok(effect)
}

/// Resolves a port term: a known port effect, a continuous Real input as port whose unit (if
/// it says) is of the effect's domain, a readable Real signal that does not depend directly on
/// the port (an algebraic loop).
fn plan_term(
    md: &ModelDescription,
    t: &PortTerm,
    starts: &[(String, String)],
    inputs: Option<&TimeSeries>,
    bindings: &[InputBinding],
) -> Result<PlannedTerm, SimError> {
    let effect = additive_kind(&t.kind, &t.parameters, "a port")?;
    if effect.domain() == effects::Domain::Generic {
        return Err(invalid(format!("{} acts on a state's derivative, not on a port: name a state instead", t.kind)));
    }
    let port = term_variable(md, &t.port, "port")?;
    if port.causality != Causality::Input
        || port.var_type != VarType::Real
        || port.variability != Variability::Continuous
    {
        return Err(invalid(format!("port {} is not a continuous Real input of the model", quote_user_text(&t.port))));
    }
    if let Some((unit, domain)) = crate::structure::port_domain(md, port)
        && domain != effect.domain()
    {
        return Err(invalid(format!(
            "port {:?} is in {unit} ({domain}); {} is a {} effect",
            t.port,
            t.kind,
            effect.domain()
        )));
    }
    let signal = term_variable(md, &t.signal, "signal")?;
    if signal.var_type != VarType::Real {
        return Err(invalid(format!("signal {} is not a Real variable", quote_user_text(&t.signal))));
    }
    let port_index = md.variables.iter().position(|v| v.name == port.name).map(|i| i + 1);
    let feeds_through = md.model_structure.outputs.iter().any(|u| {
        md.variables.get(u.index - 1).is_some_and(|v| v.name == signal.name)
            && u.dependencies.as_ref().is_some_and(|d| port_index.is_some_and(|p| d.contains(&p)))
    });
    if feeds_through {
        return Err(invalid(format!(
            "signal {:?} depends directly on port {:?}: adding the effect would make an algebraic loop",
            t.signal, t.port
        )));
    }
    let base = match bindings.iter().find(|b| b.var.vr == port.value_reference) {
        Some(b) if b.var.negated => {
            return Err(invalid(format!(
                "port {:?} is fed by input column {:?}, a negated alias: map the column to {:?} instead",
                t.port, b.var.name, port.name
            )));
        }
        Some(b) if inputs.is_some() => PortBase::Column(b.column),
        _ => {
            let set = starts
                .iter()
                .rev()
                .find(|(n, _)| *n == port.name || *n == t.port)
                .and_then(|(_, v)| v.parse::<f64>().ok());
            let start = match &port.start {
                Some(crate::fmu::schema::Value::Real(v)) => *v,
                _ => 0.0,
            };
            PortBase::Value(set.unwrap_or(start))
        }
    };
    Ok(PlannedTerm {
        effect,
        parameters: t.parameters.clone(),
        signal_vr: signal.value_reference,
        port_vr: port.value_reference,
        base,
    })
}

/// The position in the state vector of the continuous state `name` (or of the state an alias
/// of that name stands for).
fn state_index(md: &ModelDescription, name: &str, what: &str) -> Result<usize, SimError> {
    let v = term_variable(md, name, what)?;
    md.states().iter().position(|(s, _)| s.value_reference == v.value_reference && s.var_type == v.var_type).ok_or_else(
        || {
            let states: Vec<&str> = md.states().iter().map(|(s, _)| s.name.as_str()).collect();
            invalid(format!(
                "{what} {} is not a continuous state of the model (its states: {})",
                quote_user_text(name),
                if states.is_empty() { "none".to_owned() } else { quote_user_text(&states.join(", ")) }
            ))
        },
    )
}

/// Resolves a state term: a known additive kind, a continuous state and a signal that is one.
fn plan_state_term(md: &ModelDescription, t: &StateTerm) -> Result<PlannedStateTerm, SimError> {
    let effect = additive_kind(&t.kind, &t.parameters, "a state")?;
    let state = state_index(md, &t.state, "state")?;
    let signal = state_index(md, &t.signal, "signal")?;
    let states = md.states();
    if let Some((v, _)) = states.iter().find(|(v, _)| v.value_reference == states[state].1.value_reference) {
        return Err(invalid(format!(
            "the derivative of state {} is the state {:?}: add the term to der({:?}) instead",
            quote_user_text(&t.state),
            v.name,
            v.name
        )));
    }
    Ok(PlannedStateTerm {
        effect,
        parameters: t.parameters.clone(),
        state,
        signal,
        signal_vr: states[signal].0.value_reference,
        derivative_vr: states[state].1.value_reference,
    })
}

fn var_ref(v: &ScalarVariable) -> VarRef {
    VarRef { name: v.name.clone(), vr: v.value_reference, var_type: v.var_type, negated: v.negated }
}

/// A port or signal of a port term: an alias stands for its base, a negated one is refused.
fn term_variable<'a>(md: &'a ModelDescription, name: &str, what: &str) -> Result<&'a ScalarVariable, SimError> {
    let v = md
        .variable(name)
        .ok_or_else(|| invalid(format!("{what} {} is not a variable of the model", quote_user_text(name))))?;
    if v.negated {
        return Err(invalid(format!(
            "{what} {name:?} is a negated alias of {:?}: name {0:?} instead",
            v.alias_of.as_deref().unwrap_or("its base")
        )));
    }
    Ok(md.base_of(v))
}

impl Plan {
    /// Resolves `spec` for an FMU offering `interfaces`.
    ///
    /// # Errors
    /// [`SimError::Invalid`] naming the bad field, variable or value.
    pub fn new(md: &ModelDescription, interfaces: &[Interface], spec: &SimSpec) -> Result<Plan, SimError> {
        let interface = match spec.interface {
            Some(i) if interfaces.contains(&i) => i,
            Some(i) => return Err(invalid(format!("the FMU does not offer {i}"))),
            None => *interfaces.first().ok_or_else(|| invalid("the FMU offers no interface"))?,
        };
        let de = md.default_experiment.clone().unwrap_or_default();
        let start = spec.start_time.or(de.start_time).unwrap_or(0.0);
        let stop = spec.stop_time.or(de.stop_time).unwrap_or(start + 1.0);
        if !start.is_finite() || !stop.is_finite() || stop <= start {
            return Err(invalid(format!("stop time {stop} must be a finite number after start time {start}")));
        }
        let tolerance = spec.tolerance.or(de.tolerance).unwrap_or(1e-6);
        if !(tolerance > 0.0 && tolerance < 1.0) {
            return Err(invalid(format!("tolerance {tolerance} must be in (0, 1)")));
        }
        if let Some(h) = spec.max_step
            && !(h > 0.0 && h.is_finite())
        {
            return Err(invalid(format!("max step {h} must be a positive number")));
        }
        let output_times = spec.output_times.clone().unwrap_or_else(|| {
            OutputTimes::Interval(de.step_size.filter(|h| *h > 0.0).unwrap_or((stop - start) / 500.0))
        });
        let grid = build_grid(start, stop, &output_times)?;

        let settings =
            spec.parameters.iter().map(|(name, text)| setting(md, name, text)).collect::<Result<Vec<_>, _>>()?;

        let (inputs, input_bindings) = match &spec.inputs {
            None => (None, vec![]),
            Some(table) => {
                table.validate_inputs()?;
                let bindings = table
                    .columns
                    .iter()
                    .enumerate()
                    .map(|(column, (name, _))| {
                        let v = md.variable(name).ok_or_else(|| {
                            invalid(format!("input column {} is not a variable of the model", quote_user_text(name)))
                        })?;
                        if v.causality != Causality::Input && md.base_of(v).causality != Causality::Input {
                            return Err(invalid(format!(
                                "input column {name:?} is not an input of the model (causality {:?})",
                                v.causality
                            )));
                        }
                        if matches!(v.var_type, VarType::String | VarType::Binary | VarType::Clock) {
                            return Err(invalid(format!("{:?} input {name:?} is not supported", v.var_type)));
                        }
                        Ok(InputBinding {
                            var: var_ref(v),
                            column,
                            hold: v.var_type != VarType::Real || v.variability == Variability::Discrete,
                        })
                    })
                    .collect::<Result<Vec<_>, _>>()?;
                (Some(table.clone()), bindings)
            }
        };

        let outputs = if spec.outputs.is_empty() {
            let outs: Vec<VarRef> = md.outputs().into_iter().filter(|v| recordable(v)).map(var_ref).collect();
            if outs.is_empty() { md.states().into_iter().map(|(s, _)| var_ref(s)).collect() } else { outs }
        } else {
            let mut outs = vec![];
            for name in &spec.outputs {
                // An FMI 3.0 array's own name stands for its elements, in order.
                let vars = match md.variable(name) {
                    Some(v) => vec![v],
                    None => md
                        .array_elements(name)
                        .ok_or_else(|| invalid(format!("unknown output variable {}", quote_user_text(name))))?,
                };
                for v in vars {
                    if !recordable(v) {
                        return Err(invalid(format!("{:?} variable {:?} cannot be recorded", v.var_type, v.name)));
                    }
                    outs.push(var_ref(v));
                }
            }
            outs
        };

        let port_terms = spec
            .port_terms
            .iter()
            .map(|t| plan_term(md, t, &spec.parameters, spec.inputs.as_ref(), &input_bindings))
            .collect::<Result<Vec<_>, _>>()?;
        if !spec.state_terms.is_empty() && interface != Interface::ModelExchange {
            let only = if interfaces.contains(&Interface::ModelExchange) {
                ""
            } else {
                " (the FMU offers Co-Simulation only)"
            };
            return Err(invalid(format!(
                "state effects need Model Exchange, where fmucal integrates the states{only}; use a port effect instead"
            )));
        }
        let state_terms = spec.state_terms.iter().map(|t| plan_state_term(md, t)).collect::<Result<Vec<_>, _>>()?;
        let real: Vec<(usize, u32)> =
            outputs.iter().enumerate().filter(|(_, o)| o.var_type == VarType::Real).map(|(i, o)| (i, o.vr)).collect();
        let output_state_terms = real
            .iter()
            .enumerate()
            .filter_map(|(k, (_, vr))| {
                let terms: Vec<usize> = state_terms
                    .iter()
                    .enumerate()
                    // Added to the value behind the reference, before a negated alias's sign.
                    .filter(|(_, t)| t.derivative_vr == *vr)
                    .map(|(i, _)| i)
                    .collect();
                (!terms.is_empty()).then_some((k, terms))
            })
            .collect();
        Ok(Plan {
            real_output_vrs: real.iter().map(|r| r.1).collect(),
            real_output_slots: real.iter().map(|r| r.0).collect(),
            interface,
            start,
            stop,
            grid,
            tolerance,
            solver: spec.solver,
            // FMPy's default for Model Exchange: without it a step can span a whole input
            // excursion. Co-Simulation steps only where asked.
            max_step: spec.max_step.or((interface == Interface::ModelExchange).then_some((stop - start) / 50.0)),
            max_steps: spec.max_steps.unwrap_or(10_000_000),
            deadline: spec.timeout.map(|d| Instant::now() + d),
            settings,
            inputs,
            input_bindings,
            outputs,
            port_terms,
            state_terms,
            output_state_terms,
        })
    }

    /// Adds the state terms to the derivatives `dx` of the states `x`.
    pub fn add_state_terms(&self, x: &[f64], dx: &mut [f64]) {
        for t in &self.state_terms {
            if !t.effect.vanishes(&t.parameters) {
                dx[t.state] += t.effect.term(&t.parameters, x[t.signal]);
            }
        }
    }

    /// Adds the port terms to their ports at time `t`: reads each signal (the states must be
    /// set), and sets each port to its base value (input column from `side`, or start value)
    /// plus the sum of its terms.
    ///
    /// # Errors
    /// [`FmuError::Call`] if the FMU rejects a call.
    pub fn apply_port_terms(&self, inst: &mut Instance, t: f64, side: Side) -> Result<(), FmuError> {
        let mut ports: Vec<(u32, f64)> = vec![];
        for term in &self.port_terms {
            let add = if term.effect.vanishes(&term.parameters) {
                0.0
            } else {
                let mut s = [0.0];
                inst.call("fmi2GetReal", |c| c.get_real(&[term.signal_vr], &mut s))?;
                term.effect.term(&term.parameters, s[0])
            };
            match ports.iter_mut().find(|(vr, _)| *vr == term.port_vr) {
                Some((_, v)) => *v += add,
                None => {
                    let base = match (term.base, &self.inputs) {
                        (PortBase::Column(col), Some(table)) => table.value_on(side, col, t, false),
                        (PortBase::Column(_), None) => 0.0,
                        (PortBase::Value(v), _) => v,
                    };
                    ports.push((term.port_vr, base + add));
                }
            }
        }
        for (vr, v) in ports {
            inst.call("fmi2SetReal", |c| c.set_real(&[vr], &[v]))?;
        }
        Ok(())
    }

    /// Event indicators of the port and state terms: one per kink of each term
    /// ([`PortEffect::kinks`]) that does not vanish ([`PortEffect::vanishes`]), port terms first.
    pub fn term_indicator_count(&self) -> usize {
        self.port_terms.iter().map(|t| t.kinks().len()).sum::<usize>()
            + self.state_terms.iter().map(|t| t.kinks().len()).sum::<usize>()
    }

    /// The port and state terms' event indicators, signal − kink, into `z` (of
    /// [`Plan::term_indicator_count`] values); the states must be set.
    ///
    /// # Errors
    /// [`FmuError::Call`] if the FMU rejects a call.
    pub fn term_indicators(&self, inst: &mut Instance, z: &mut [f64]) -> Result<(), FmuError> {
        // Port terms first, then state terms: (signal's value reference, kinks).
        let terms = self.port_terms.iter().map(|t| (t.signal_vr, t.kinks()));
        let terms = terms.chain(self.state_terms.iter().map(|t| (t.signal_vr, t.kinks())));
        let mut k = 0;
        for (vr, kinks) in terms.filter(|(_, kinks)| !kinks.is_empty()) {
            let mut s = [0.0];
            inst.call("fmi2GetReal", |c| c.get_real(&[vr], &mut s))?;
            for kink in kinks {
                z[k] = s[0] - kink;
                k += 1;
            }
        }
        Ok(())
    }

    /// Sets parameters and start values (before `fmi2EnterInitializationMode`).
    ///
    /// # Errors
    /// [`FmuError::Call`] if the FMU rejects a value.
    pub fn apply_settings(&self, inst: &mut Instance) -> Result<(), FmuError> {
        for s in &self.settings {
            match s {
                Setting::Real(vr, v) => inst.call("fmi2SetReal", |c| c.set_real(&[*vr], &[*v]))?,
                Setting::Integer(vr, v) => inst.call("fmi2SetInteger", |c| c.set_integer(&[*vr], &[*v]))?,
                Setting::Boolean(vr, v) => inst.call("fmi2SetBoolean", |c| c.set_boolean(&[*vr], &[*v as i32]))?,
                Setting::String(vr, v) => inst.call("fmi2SetString", |c| c.set_string(&[*vr], &[v.as_str()]))?,
                Setting::Binary(vr, v) => inst.call("fmi3SetBinary", |c| c.set_binary(&[*vr], &[v.as_slice()]))?,
            };
        }
        Ok(())
    }

    /// Sets all inputs to their values at time `t` (after any jump at `t`).
    ///
    /// # Errors
    /// [`FmuError::Call`] if the FMU rejects a value.
    pub fn set_inputs(&self, inst: &mut Instance, t: f64) -> Result<(), FmuError> {
        self.set_inputs_from(inst, t, Side::Right, false)
    }

    /// Sets the inputs from `side` of `t`; with `continuous_only`, held inputs are skipped (in
    /// Model Exchange they may change only at events).
    ///
    /// # Errors
    /// [`FmuError::Call`] if the FMU rejects a value.
    pub fn set_inputs_from(
        &self,
        inst: &mut Instance,
        t: f64,
        side: Side,
        continuous_only: bool,
    ) -> Result<(), FmuError> {
        let Some(table) = &self.inputs else { return Ok(()) };
        for b in &self.input_bindings {
            if continuous_only && b.hold {
                continue;
            }
            let v = b.var.sign(table.value_on(side, b.column, t, b.hold));
            let vr = b.var.vr;
            match b.var.var_type {
                VarType::Real => inst.call("fmi2SetReal", |c| c.set_real(&[vr], &[v]))?,
                VarType::Boolean => inst.call("fmi2SetBoolean", |c| c.set_boolean(&[vr], &[(v != 0.0) as i32]))?,
                _ => inst.call("fmi2SetInteger", |c| c.set_integer(&[vr], &[v.round() as i32]))?,
            };
        }
        Ok(())
    }

    /// Table columns of held inputs (their sample times are events in Model Exchange).
    pub fn held_columns(&self) -> Vec<usize> {
        self.input_bindings.iter().filter(|b| b.hold).map(|b| b.column).collect()
    }

    /// Reads the recorded variables into `row`: all Real ones in one `fmi2GetReal` call (an FMU
    /// may compute its outputs on every call), the others one by one.
    ///
    /// # Errors
    /// [`FmuError::Call`] if a get function fails.
    pub fn read_outputs(&self, inst: &mut Instance, row: &mut [f64]) -> Result<(), FmuError> {
        if !self.real_output_vrs.is_empty() {
            let mut values = vec![0.0; self.real_output_vrs.len()];
            inst.call("fmi2GetReal", |c| c.get_real(&self.real_output_vrs, &mut values))?;
            // An output that is a state's derivative carries that state's terms too.
            for (k, terms) in &self.output_state_terms {
                for &i in terms {
                    let t = &self.state_terms[i];
                    if t.effect.vanishes(&t.parameters) {
                        continue;
                    }
                    let mut s = [0.0];
                    inst.call("fmi2GetReal", |c| c.get_real(&[t.signal_vr], &mut s))?;
                    values[*k] += t.effect.term(&t.parameters, s[0]);
                }
            }
            for (slot, v) in self.real_output_slots.iter().zip(values) {
                row[*slot] = self.outputs[*slot].sign(v);
            }
        }
        for (out, slot) in self.outputs.iter().zip(row.iter_mut()) {
            let vr = out.vr;
            *slot = out.sign(match out.var_type {
                VarType::Real => continue,
                VarType::Boolean => {
                    let mut v = [0];
                    inst.call("fmi2GetBoolean", |c| c.get_boolean(&[vr], &mut v))?;
                    v[0] as f64
                }
                _ => {
                    let mut v = [0];
                    inst.call("fmi2GetInteger", |c| c.get_integer(&[vr], &mut v))?;
                    v[0] as f64
                }
            });
        }
        Ok(())
    }

    /// Fails if the step budget or the wall-clock deadline is exhausted.
    ///
    /// # Errors
    /// [`SimError::Budget`].
    pub fn check_budget(&self, steps: u64, t: f64) -> Result<(), SimError> {
        if steps > self.max_steps {
            return Err(SimError::Budget { time: t, what: format!("more than {} steps", self.max_steps) });
        }
        if let Some(d) = self.deadline
            && Instant::now() > d
        {
            return Err(SimError::Budget { time: t, what: "wall-clock timeout".into() });
        }
        Ok(())
    }
}

fn build_grid(start: f64, stop: f64, times: &OutputTimes) -> Result<Vec<f64>, SimError> {
    match times {
        OutputTimes::Interval(dt) => {
            if !(*dt > 0.0 && dt.is_finite()) {
                return Err(invalid(format!("output interval {dt} must be a positive number")));
            }
            let n = ((stop - start) / dt + 1e-9).floor();
            if n > 1e8 {
                return Err(invalid(format!("output interval {dt} gives more than 1e8 output times")));
            }
            let n = n as usize;
            // start + n·dt may land a round-off past the stop time (7 · 0.1 = 0.7000000000000001):
            // the last time is then the stop time itself, which every driver reaches.
            let mut grid: Vec<f64> = (0..=n).map(|i| (start + i as f64 * dt).min(stop)).collect();
            if stop - grid[n] > 1e-9 * dt {
                grid.push(stop);
            } else {
                grid[n] = stop;
            }
            Ok(grid)
        }
        OutputTimes::Times(list) => {
            if list.is_empty() {
                return Err(invalid("the list of output times is empty"));
            }
            let tol = 1e-12 * (stop - start).abs().max(1.0);
            for (i, t) in list.iter().enumerate() {
                if !t.is_finite() || *t < start - tol || *t > stop + tol {
                    return Err(invalid(format!("output time {t} (entry {}) is outside [{start}, {stop}]", i + 1)));
                }
                if i > 0 && *t <= list[i - 1] {
                    return Err(invalid(format!(
                        "output times must increase: entry {} ({t}) follows {}",
                        i + 1,
                        list[i - 1]
                    )));
                }
            }
            // Times within round-off outside [start, stop] are the start or the stop time.
            let clamped: Vec<f64> = list.iter().map(|t| t.clamp(start, stop)).collect();
            if let Some(i) = clamped.windows(2).position(|w| w[1] <= w[0]) {
                return Err(invalid(format!("output times {} and {} are the same instant", list[i], list[i + 1])));
            }
            Ok(clamped)
        }
    }
}

/// Whether a variable's values fit a numeric result table (not a String, Binary or Clock).
fn recordable(v: &ScalarVariable) -> bool {
    !matches!(v.var_type, VarType::String | VarType::Binary | VarType::Clock)
}

/// Parses `text` for variable `name` and checks that it may be set and lies within min/max.
pub fn setting(md: &ModelDescription, name: &str, text: &str) -> Result<Setting, SimError> {
    let v = md.variable(name).ok_or_else(|| invalid(format!("unknown variable {}", quote_user_text(name))))?;
    // An alias may be set where its base may (tools often write an alias of a parameter as a
    // calculated local).
    if !v.settable_before_init() && !md.base_of(v).settable_before_init() {
        return Err(invalid(format!(
            "variable {name:?} may not be set (causality {:?}, variability {:?}, initial {:?})",
            v.causality,
            v.variability,
            v.effective_initial()
        )));
    }
    // A String's value is the text as given, spaces included.
    let given = text;
    let text = text.trim();
    let base = md.base_of(v);
    // The value within the variable's own limits, and, through an alias, the value its base
    // gets within the base's.
    let range = |x: f64| -> Result<(), SimError> {
        let stored = if v.negated { -x } else { x };
        let mut checks = vec![(v, x, String::new())];
        if !std::ptr::eq(base, v) {
            checks.push((base, stored, format!(" (as {} = {stored})", base.name)));
        }
        for (var, value, what) in checks {
            if let Some(min) = var.min
                && value < min
            {
                return Err(invalid(format!("{name} = {text}{what} is below its minimum {min}")));
            }
            if let Some(max) = var.max
                && value > max
            {
                return Err(invalid(format!("{name} = {text}{what} is above its maximum {max}")));
            }
        }
        Ok(())
    };
    let negate = |x: i32| -> Result<i32, SimError> {
        if !v.negated {
            return Ok(x);
        }
        x.checked_neg().ok_or_else(|| invalid(format!("{name} = {x}: its negated base value does not fit an Integer")))
    };
    match v.var_type {
        VarType::Real => {
            let x: f64 =
                text.parse().map_err(|_| invalid(format!("{name} = {} is not a number", quote_user_text(text))))?;
            if !x.is_finite() {
                return Err(invalid(format!("{name} = {text} is not a finite number")));
            }
            range(x)?;
            Ok(Setting::Real(v.value_reference, if v.negated { -x } else { x }))
        }
        VarType::Integer => {
            let x: i32 =
                text.parse().map_err(|_| invalid(format!("{name} = {} is not an integer", quote_user_text(text))))?;
            range(x as f64)?;
            Ok(Setting::Integer(v.value_reference, negate(x)?))
        }
        VarType::Enumeration => {
            let items = v
                .declared_type
                .as_ref()
                .and_then(|t| md.type_definitions.iter().find(|st| &st.name == t))
                .map(|st| st.items.clone())
                .unwrap_or_default();
            let x = match text.parse::<i32>() {
                Ok(x) => x,
                Err(_) => items.iter().find(|i| i.name == text).map(|i| i.value as i32).ok_or_else(|| {
                    let names: Vec<_> = items.iter().map(|i| i.name.as_str()).collect();
                    invalid(format!("{name} = {} is not one of {}", quote_user_text(text), names.join(", ")))
                })?,
            };
            if !items.is_empty() && !items.iter().any(|i| i.value == x as i64) {
                return Err(invalid(format!("{name} = {x} is not a value of its enumeration")));
            }
            range(x as f64)?;
            Ok(Setting::Integer(v.value_reference, negate(x)?))
        }
        VarType::Boolean => match text {
            "true" | "1" => Ok(Setting::Boolean(v.value_reference, !v.negated)),
            "false" | "0" => Ok(Setting::Boolean(v.value_reference, v.negated)),
            _ => Err(invalid(format!("{name} = {} is not a boolean (true/false)", quote_user_text(text)))),
        },
        VarType::String if v.negated => Err(invalid(format!("{name} is a negated alias of a String"))),
        VarType::String if given.contains('\0') => {
            Err(invalid(format!("{name}: a String value cannot hold a NUL character")))
        }
        VarType::String => Ok(Setting::String(v.value_reference, given.to_owned())),
        VarType::Binary => match crate::fmu::schema::parse_hex(text) {
            Some(bytes) => Ok(Setting::Binary(v.value_reference, bytes)),
            None => Err(invalid(format!("{name} = {text:?} is not hex digits (a Binary value, as 0a1b… or 0x0a1b…)"))),
        },
        VarType::Clock => Err(invalid(format!("setting Clock variable {name:?} is not supported"))),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const BOTH: &str = r#"<?xml version="1.0"?>
<fmiModelDescription fmiVersion="2.0" modelName="M" guid="{g}">
  <ModelExchange modelIdentifier="M"/>
  <CoSimulation modelIdentifier="M"/>
  <ModelVariables>
    <ScalarVariable name="x" valueReference="0" causality="output" initial="exact"><Real start="1"/></ScalarVariable>
    <ScalarVariable name="der(x)" valueReference="1"><Real derivative="1"/></ScalarVariable>
  </ModelVariables>
  <ModelStructure><Outputs><Unknown index="1"/></Outputs><Derivatives><Unknown index="2"/></Derivatives></ModelStructure>
</fmiModelDescription>"#;

    #[test]
    fn the_last_output_time_is_the_stop_time_not_a_round_off_past_it() {
        for (stop, dt) in [(0.7, 0.1), (0.3, 0.1), (2.3, 0.1), (1.0, 0.1)] {
            let grid = build_grid(0.0, stop, &OutputTimes::Interval(dt)).unwrap();
            assert_eq!(*grid.last().unwrap(), stop, "stop {stop}, dt {dt}: {grid:?}");
            assert_eq!(grid.len(), (stop / dt).round() as usize + 1);
        }
        let listed = build_grid(0.0, 1.0, &OutputTimes::Times(vec![0.5, 1.0 + 1e-13])).unwrap();
        assert_eq!(listed, [0.5, 1.0]);
    }

    #[test]
    fn model_exchange_default_max_step_is_a_fiftieth_of_the_span_as_in_fmpy() {
        let md = ModelDescription::parse(BOTH).unwrap();
        let both = [Interface::ModelExchange, Interface::CoSimulation];
        let spec = |i, max_step| SimSpec { interface: Some(i), stop_time: Some(10.0), max_step, ..Default::default() };
        assert_eq!(Plan::new(&md, &both, &spec(both[0], None)).unwrap().max_step, Some(0.2));
        assert_eq!(Plan::new(&md, &both, &spec(both[0], Some(0.5))).unwrap().max_step, Some(0.5));
        assert_eq!(Plan::new(&md, &both, &spec(both[1], None)).unwrap().max_step, None);
    }
}
