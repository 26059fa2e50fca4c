//! A job checked against its model and data once ([`PreparedJob`]), holding what every
//! evaluation needs: per experiment ([`PreparedExperiment`]), the simulation template, the
//! averaged targets of its objective, which values of a point it sets, and the effects.
//!
//! A point holds every calibrated value of the job ([`JobSpec::calibrated`]); an experiment
//! picks the model parameters it uses out of it, so one point is evaluated on each fitted
//! experiment and the job's objective is the sum over them.

use super::choices::ExperimentRole;
use super::data::MeasurementTable;
use super::experiments::{ExperimentView, Slot, position_for, prefixed};
use super::objective::{Objective, Target};
use super::spec::{EffectSpec, JobSpec};
use super::{JobError, JobKind, limits};
use crate::effects;
use crate::effects::Domain;
use crate::effects::guess::SignalRole;
use crate::fmu::schema::{Causality, ScalarVariable, VarType};
use crate::fmu::{Interface, ModelDescription};
use crate::quote::quote_user_text;
use crate::sim::plan::Plan;
use crate::sim::{InputTable, OutputTimes, PortTerm, SimResult, SimSpec, StateTerm};
use crate::structure::{Quantity, Role, Structure};

/// A job checked against its model and data.
#[derive(Debug, Clone)]
pub struct PreparedJob {
    pub spec: JobSpec,
    pub interface: Interface,
    /// Every calibrated name, in point order ([`JobSpec::calibrated`]).
    pub parameter_names: Vec<String>,
    /// Every experiment, in the job's order (one for a job without `[[experiments]]`).
    pub experiments: Vec<PreparedExperiment>,
    /// The fitted experiments' indices: a point is evaluated on these, in this order.
    pub fitted: Vec<usize>,
}

/// One experiment of a prepared job.
#[derive(Debug, Clone)]
pub struct PreparedExperiment {
    /// Empty for a job without `[[experiments]]`.
    pub name: String,
    pub role: ExperimentRole,
    /// This experiment as a single-experiment job (see [`ExperimentView`]).
    pub spec: JobSpec,
    pub objective: Objective,
    /// The simulation of one evaluation, without the calibrated values.
    pub template: SimSpec,
    /// The model parameters a point sets: name and index in the point.
    pub parameters: Vec<(String, usize)>,
    pub effects: Vec<PreparedEffect>,
}

impl PreparedJob {
    /// Checks `spec` against the model description and the data — `data[k]` is the table of
    /// experiment `k` of [`JobSpec::experiment_views`] — and builds each experiment's objective.
    ///
    /// # Errors
    /// [`JobError::Invalid`] naming the field (inside `experiments[K].` for an experiment's):
    /// unknown or unsettable parameters, bounds outside a variable's min/max, unknown output
    /// variables, missing or malformed data columns, inputs that are not model inputs, a data
    /// table count that does not match the experiments, and anything the simulation itself
    /// would reject.
    pub fn new(
        spec: &JobSpec,
        md: &ModelDescription,
        interfaces: &[Interface],
        data: &[MeasurementTable],
    ) -> Result<Self, JobError> {
        spec.validate()?;
        let views = spec.experiment_views();
        if data.len() != views.len() {
            return Err(JobError::invalid(
                "data",
                format!("{} data tables for {} experiments", data.len(), views.len()),
            ));
        }
        let interface = match spec.model.interface {
            Some(i) => i,
            None => *interfaces.first().ok_or_else(|| JobError::invalid("model", "the FMU offers no interface"))?,
        };
        let calibrated = spec.calibrated();
        let mut effects = vec![];
        let structure = spec.effects.iter().any(|e| e.state.is_some()).then(|| Structure::read(md, &[]));
        for (k, e) in spec.effects.iter().enumerate() {
            let offset = calibrated.iter().position(|c| matches!(c.slot, Slot::Effect { effect, .. } if effect == k));
            let count = e.ordered_parameters(k)?.len();
            let (state_signal, reaction) = match (&e.state, &structure) {
                (Some(state), Some(structure)) => {
                    let (signal, reaction) = state_signal(k, e, state, structure, interface, interfaces)?;
                    (Some(signal), reaction)
                }
                _ => (None, None),
            };
            effects.push(PreparedEffect {
                spec: e.clone(),
                offset: offset.unwrap_or(calibrated.len()),
                count,
                state_signal,
                reaction,
            });
        }
        let names: Vec<String> = calibrated.iter().map(|c| c.name.clone()).collect();
        let x0: Vec<f64> = calibrated.iter().map(|c| c.bounds.start).collect();
        let mut experiments = vec![];
        for (k, (view, table)) in views.iter().zip(data).enumerate() {
            let parameters = spec
                .parameters
                .iter()
                .enumerate()
                .filter_map(|(index, p)| Some((p.name.clone(), position_for(&calibrated, index, k)?)))
                .collect();
            let context = Context { md, interfaces, interface, parameters, effects: effects.clone() };
            experiments.push(
                PreparedExperiment::new(view, table, &context, &x0).map_err(|e| prefixed(&view.field_prefix, e))?,
            );
        }
        let fitted = spec.fitted_experiments();
        if let JobKind::EvaluatePoints(points) = &spec.kind {
            let per_point = fitted.iter().map(|&k| experiments[k].objective.residual_count()).sum();
            limits::check_kept_residuals(points.len(), per_point)?;
        }
        Ok(PreparedJob { spec: spec.clone(), interface, parameter_names: names, experiments, fitted })
    }

    /// The same job, asked to evaluate `points` instead of calibrating.
    pub fn evaluating_points(&self, points: Vec<Vec<f64>>) -> PreparedJob {
        PreparedJob { spec: self.spec.evaluating_points(points), ..self.clone() }
    }

    /// The same job with experiment `k` replaced by `experiment`.
    pub fn with_experiment(&self, k: usize, experiment: PreparedExperiment) -> PreparedJob {
        let mut job = self.clone();
        if let Some(e) = job.experiments.get_mut(k) {
            *e = experiment;
        }
        job
    }

    /// The only experiment of a job without `[[experiments]]` (the first of one with them):
    /// for the analyses that take a single experiment.
    pub fn single(&self) -> &PreparedExperiment {
        &self.experiments[0]
    }
}

/// The state a state effect reads, checked against the model's structure: its `signal` if it
/// names one, else the state itself, or for a spring the position whose derivative the state
/// is. The kind must fit the state's quantity: mechanical kinds a velocity, thermal kinds a
/// temperature (generic kinds any state). With it, the effect's reaction state by its own name
/// (not an alias): a velocity other than the effect's state.
fn state_signal(
    k: usize,
    e: &EffectSpec,
    state: &str,
    structure: &Structure,
    interface: Interface,
    interfaces: &[Interface],
) -> Result<(String, Option<String>), JobError> {
    let field = |f: &str| format!("effects[{k}].{f}");
    if interface != Interface::ModelExchange {
        let why = if interfaces.contains(&Interface::ModelExchange) {
            "the job uses Co-Simulation, where the FMU integrates its own states: set [model] interface = \"me\""
        } else {
            "the FMU offers Co-Simulation only, where it integrates its own states: no state effects (use a port effect)"
        };
        return Err(JobError::invalid(field("state"), why));
    }
    let Some(s) = structure.state(state) else {
        let names: Vec<&str> = structure.states.iter().map(|s| s.name.as_str()).collect();
        return Err(JobError::invalid(
            field("state"),
            format!(
                "{} is not a continuous state of the model (its states: {})",
                quote_user_text(state),
                if names.is_empty() { "none".to_owned() } else { quote_user_text(&names.join(", ")) }
            ),
        ));
    };
    let Ok(effects::Found::Port(kind)) = effects::find(&e.kind) else {
        return Err(JobError::invalid(field("kind"), format!("{} is not added to a state", e.kind)));
    };
    let fits = match kind.domain() {
        Domain::Mechanical => s.role == Role::Velocity,
        Domain::Thermal => s.role == Role::Temperature,
        _ => true,
    };
    if !fits {
        let wants = if kind.domain() == Domain::Thermal { "a temperature" } else { "a velocity" };
        return Err(JobError::invalid(
            field("kind"),
            format!("{} acts on {wants}; state {} is {}", e.kind, quote_user_text(state), describe_state(s)),
        ));
    }
    let reaction = match &e.reaction {
        None => None,
        Some(reaction) => match structure.state(reaction) {
            Some(r) if r.name == s.name => {
                return Err(JobError::invalid(
                    field("reaction"),
                    format!(
                        "{} is the effect's own state {}: a reaction acts on another one",
                        quote_user_text(reaction),
                        quote_user_text(&s.name)
                    ),
                ));
            }
            Some(r) if r.role == Role::Velocity => Some(r.name.clone()),
            Some(r) => {
                return Err(JobError::invalid(
                    field("reaction"),
                    format!(
                        "a reaction acts on a velocity; state {} is {}",
                        quote_user_text(reaction),
                        describe_state(r)
                    ),
                ));
            }
            None => {
                return Err(JobError::invalid(
                    field("reaction"),
                    format!("{} is not a continuous state of the model", quote_user_text(reaction)),
                ));
            }
        },
    };
    if let Some(signal) = &e.signal {
        if structure.state(signal).is_none() {
            return Err(JobError::invalid(
                field("signal"),
                format!(
                    "{} is not a continuous state of the model: a state effect reads a state",
                    quote_user_text(signal)
                ),
            ));
        }
        return Ok((signal.clone(), reaction));
    }
    if kind.signal_role() == SignalRole::Position {
        let position = s.position.clone().ok_or_else(|| {
            JobError::invalid(
                field("signal"),
                format!(
                    "{} reads a position, and no state of the model has {} as its derivative: name the position as signal",
                    e.kind,
                    quote_user_text(state)
                ),
            )
        })?;
        return Ok((position, reaction));
    }
    Ok((s.name.clone(), reaction))
}

/// A state's quantity and role in words: "a rotational position (rad)".
pub fn describe_state(s: &crate::structure::State) -> String {
    let quantity = match s.quantity {
        Quantity::Translational => "translational ",
        Quantity::Rotational => "rotational ",
        Quantity::Thermal => "thermal ",
        Quantity::Other => "",
    };
    let role = match s.role {
        Role::Position => "position",
        Role::Velocity => "velocity",
        Role::Temperature => "temperature",
        Role::Other => "state",
    };
    match &s.unit {
        Some(u) => format!("a {quantity}{role} ({u})"),
        None => format!("a {quantity}{role}"),
    }
}

/// The model's variable `name`, which the job names at `field`; else the error at `field`.
fn variable<'m>(md: &'m ModelDescription, field: &str, name: &str) -> Result<&'m ScalarVariable, JobError> {
    md.variable(name).ok_or_else(|| JobError::invalid(field, md.unknown_variable(name)))
}

/// What every experiment of a job shares while it is prepared.
struct Context<'a> {
    md: &'a ModelDescription,
    interfaces: &'a [Interface],
    interface: Interface,
    parameters: Vec<(String, usize)>,
    effects: Vec<PreparedEffect>,
}

impl PreparedExperiment {
    /// Checks experiment `view` against the model and its data and builds its objective.
    fn new(view: &ExperimentView, data: &MeasurementTable, cx: &Context, x0: &[f64]) -> Result<Self, JobError> {
        let spec = &view.spec;
        let md = cx.md;
        let mut used: Vec<&str> = spec.outputs.iter().map(|o| o.column.as_str()).collect();
        used.extend(spec.inputs.iter().map(|i| i.column.as_str()));
        super::data::check_columns(spec, "", data.columns.iter().map(|(n, _)| n.as_str()))?;
        data.validate_measurements(&used)?;

        for (k, p) in spec.parameters.iter().enumerate() {
            let field = format!("parameters[{k}].name");
            let v = variable(md, &field, &p.name)?;
            if v.var_type != VarType::Real {
                return Err(JobError::invalid(
                    &field,
                    format!("{} is {:?}; only Real parameters can be calibrated", p.name, v.var_type),
                ));
            }
            if !v.settable_before_init() && !md.base_of(v).settable_before_init() {
                return Err(JobError::invalid(
                    &field,
                    format!("{} may not be set (causality {:?})", p.name, v.causality),
                ));
            }
            if let Some(min) = v.min
                && p.lower < min
            {
                return Err(JobError::invalid(
                    format!("parameters[{k}].lower"),
                    format!("{} is below {}'s minimum {min}", p.lower, p.name),
                ));
            }
            if let Some(max) = v.max
                && p.upper > max
            {
                return Err(JobError::invalid(
                    format!("parameters[{k}].upper"),
                    format!("{} is above {}'s maximum {max}", p.upper, p.name),
                ));
            }
        }
        for (k, o) in spec.outputs.iter().enumerate() {
            let field = format!("outputs[{k}].variable");
            let v = variable(md, &field, &o.variable)?;
            if matches!(v.var_type, VarType::String | VarType::Binary | VarType::Clock) {
                return Err(JobError::invalid(field, format!("{} is a {:?}", o.variable, v.var_type)));
            }
        }
        for (k, i) in spec.inputs.iter().enumerate() {
            let field = format!("inputs[{k}].variable");
            let v = variable(md, &field, &i.variable)?;
            if v.causality != Causality::Input && md.base_of(v).causality != Causality::Input {
                return Err(JobError::invalid(field, format!("{} is not an input of the model", i.variable)));
            }
        }
        let (objective, inputs) = objective_of(spec, data)?;
        let solver = spec.simulation.solver.unwrap_or_default();
        let mut outputs: Vec<String> = vec![];
        for o in &spec.outputs {
            if !outputs.contains(&o.variable) {
                outputs.push(o.variable.clone());
            }
        }
        for name in spec.simulation.set.keys() {
            if spec.parameters.iter().any(|p| &p.name == name) {
                return Err(JobError::invalid(
                    "simulation.set",
                    format!("{} is also a calibrated parameter", quote_user_text(name)),
                ));
            }
        }
        let template = SimSpec {
            interface: Some(cx.interface),
            start_time: Some(spec_start(spec, data)),
            stop_time: Some(spec_stop(spec, data)),
            output_times: Some(OutputTimes::Times(objective.times.clone())),
            parameters: spec.simulation.set.iter().map(|(k, v)| (k.clone(), v.to_string())).collect(),
            inputs,
            outputs,
            tolerance: spec.simulation.tolerance,
            solver,
            ..Default::default()
        };
        let experiment = PreparedExperiment {
            name: view.name.clone(),
            role: view.role,
            spec: spec.clone(),
            objective,
            template,
            parameters: cx
                .parameters
                .iter()
                .filter(|(name, _)| spec.parameters.iter().any(|p| &p.name == name))
                .cloned()
                .collect(),
            effects: cx.effects.clone(),
        };
        // Everything the simulation would reject, rejected now, with the start values set:
        // first each port effect on its own (to name it), then the whole experiment.
        let check = experiment.sim_spec(x0);
        for (k, effect) in experiment.effects.iter().enumerate() {
            let one = match (effect.port_term(x0), effect.state_terms(x0)) {
                (Some(term), _) => Some(SimSpec { port_terms: vec![term], state_terms: vec![], ..check.clone() }),
                (_, terms) if !terms.is_empty() => {
                    Some(SimSpec { port_terms: vec![], state_terms: terms, ..check.clone() })
                }
                _ => None,
            };
            if let Some(one) = one {
                Plan::new(md, cx.interfaces, &one).map_err(|e| {
                    let why = match e {
                        crate::sim::SimError::Invalid(why) => why,
                        other => other.to_string(),
                    };
                    JobError::invalid(format!("effects[{k}]"), why)
                })?;
            }
        }
        Plan::new(md, cx.interfaces, &check).map_err(|e| JobError::invalid("simulation", e.to_string()))?;
        Ok(experiment)
    }

    /// This experiment with its simulation settings replaced by `spec`'s (a later stop time,
    /// fewer fixed values), checked again against the model and `data`; the values a point
    /// sets stay the same.
    ///
    /// # Errors
    /// As [`PreparedJob::new`].
    pub fn with_spec(
        &self,
        spec: JobSpec,
        md: &ModelDescription,
        interfaces: &[Interface],
        data: &MeasurementTable,
        x0: &[f64],
    ) -> Result<PreparedExperiment, JobError> {
        let interface = self.template.interface.unwrap_or(Interface::ModelExchange);
        let view = ExperimentView { name: self.name.clone(), role: self.role, field_prefix: String::new(), spec };
        let cx =
            Context { md, interfaces, interface, parameters: self.parameters.clone(), effects: self.effects.clone() };
        PreparedExperiment::new(&view, data, &cx, x0)
    }

    /// The simulation request of one evaluation at the point `x` (every calibrated value of the
    /// job, in order): this experiment's model parameters, the port effects, and the actuator
    /// effects applied to their inputs.
    pub fn sim_spec(&self, x: &[f64]) -> SimSpec {
        let mut s = self.template.clone();
        // `{}` prints the shortest text that parses back to the same f64.
        s.parameters
            .extend(self.parameters.iter().filter_map(|(name, i)| Some((name.clone(), format!("{}", x.get(*i)?)))));
        for e in &self.effects {
            let p = e.values(x);
            if let Some(term) = e.port_term(x) {
                s.port_terms.push(term);
            } else if e.spec.state.is_some() {
                s.state_terms.extend(e.state_terms(x));
            } else if let (Some(input), Some(table), Ok(effects::Found::Series(kind))) =
                (&e.spec.input, s.inputs.as_mut(), effects::find(&e.spec.kind))
                && p.len() == e.count
                && let Some((_, column)) = table.columns.iter_mut().find(|(name, _)| name == input)
            {
                *column = kind.apply(p, &table.time, column);
            }
        }
        s
    }

    /// Applies the sensor effects at `x` to the simulated outputs they name.
    pub fn apply_sensor_effects(&self, x: &[f64], sim: &mut SimResult) {
        for e in &self.effects {
            let (Some(output), Ok(effects::Found::Series(kind))) = (&e.spec.output, effects::find(&e.spec.kind)) else {
                continue;
            };
            if let Some(i) = sim.names.iter().position(|n| n == output)
                && e.values(x).len() == e.count
            {
                sim.columns[i] = kind.apply(e.values(x), &sim.time, &sim.columns[i]);
            }
        }
    }
}

fn spec_start(spec: &JobSpec, data: &MeasurementTable) -> f64 {
    spec.simulation.start_time.unwrap_or(data.time[0])
}

fn spec_stop(spec: &JobSpec, data: &MeasurementTable) -> f64 {
    spec.simulation.stop_time.unwrap_or_else(|| data.time.last().copied().unwrap_or(f64::NAN))
}

/// The objective of one experiment — its measurement times inside [start, stop] (rows with
/// one time stamp averaged per column) and the targets — and its input table.
fn objective_of(spec: &JobSpec, data: &MeasurementTable) -> Result<(Objective, Option<InputTable>), JobError> {
    let start = spec_start(spec, data);
    let stop = spec_stop(spec, data);
    if !(stop > start) {
        return Err(JobError::invalid("simulation.stop_time", format!("{stop} is not after the start time {start}")));
    }
    spec.simulation.check_validation_stop(stop)?;
    if let (Some(v), Some(&end)) = (spec.simulation.validation_stop_time, data.time.last())
        && v > end + 1e-12 * end.abs().max(1.0)
    {
        return Err(JobError::invalid(
            "simulation.validation_stop_time",
            format!("{v} is past the end of the data ({end}): the validation window must lie inside the data"),
        ));
    }
    let tol = 1e-12 * stop.abs().max(start.abs()).max(1.0);
    let mut times: Vec<f64> = vec![];
    let mut groups: Vec<(usize, usize)> = vec![];
    let mut i = 0;
    while i < data.time.len() {
        let mut j = i + 1;
        while j < data.time.len() && data.time[j] == data.time[i] {
            j += 1;
        }
        let t = data.time[i];
        if t >= start - tol && t <= stop + tol {
            times.push(t.clamp(start, stop));
            groups.push((i, j));
        }
        i = j;
    }
    if times.is_empty() {
        return Err(JobError::invalid(
            "data.time",
            format!("no measurement inside the simulated span [{start}, {stop}]"),
        ));
    }
    let left_out = data.time.len() - groups.iter().map(|(a, b)| b - a).sum::<usize>();
    if left_out > 0 {
        tracing::info!(
            left_out,
            start,
            stop,
            "measurement rows outside the simulated span are left out of the objective"
        );
    }
    let targets: Vec<Target> = spec
        .outputs
        .iter()
        .map(|o| {
            let col = data.column(&o.column).expect("validated");
            let values = groups
                .iter()
                .map(|&(a, b)| {
                    let vals: Vec<f64> = col[a..b].iter().copied().filter(|v| !v.is_nan()).collect();
                    if vals.is_empty() { f64::NAN } else { vals.iter().sum::<f64>() / vals.len() as f64 }
                })
                .collect();
            Target { variable: o.variable.clone(), weight: o.weight, values }
        })
        .collect();
    if targets.iter().all(|t| t.values.iter().all(|v| v.is_nan())) {
        return Err(JobError::invalid("data", "every measurement of the outputs is missing"));
    }
    let inputs = (!spec.inputs.is_empty()).then(|| InputTable {
        time: data.time.clone(),
        columns: spec
            .inputs
            .iter()
            .map(|i| (i.variable.clone(), data.column(&i.column).expect("validated").to_vec()))
            .collect(),
    });
    if let Some(t) = &inputs {
        t.validate_inputs().map_err(|e| JobError::invalid("inputs", e.to_string()))?;
    }
    Ok((Objective { times, targets }, inputs))
}

/// An effect of the job and where its parameters sit in a point.
#[derive(Debug, Clone)]
pub struct PreparedEffect {
    pub spec: EffectSpec,
    pub offset: usize,
    pub count: usize,
    /// A state effect's signal, resolved against the model's structure.
    pub state_signal: Option<String>,
    /// A state effect's reaction state, by the state's own name (not an alias).
    pub reaction: Option<String>,
}

impl PreparedEffect {
    /// Its parameter values in the point `x` (none if `x` is too short, which a point from the
    /// job's optimizer never is; the effect is then left out rather than indexed past the end).
    fn values<'a>(&self, x: &'a [f64]) -> &'a [f64] {
        x.get(self.offset..self.offset + self.count).unwrap_or_default()
    }

    /// The port term at `x`, for an effect on a port.
    fn port_term(&self, x: &[f64]) -> Option<PortTerm> {
        let (port, signal) = (self.spec.port.as_ref()?, self.spec.signal.as_ref()?);
        Some(PortTerm {
            kind: self.spec.kind.clone(),
            port: port.clone(),
            signal: signal.clone(),
            parameters: self.values(x).to_vec(),
        })
    }

    /// The state terms at `x`, for an effect on a state ([`StateTerm::of_effect`]).
    fn state_terms(&self, x: &[f64]) -> Vec<StateTerm> {
        let (Some(state), Some(signal)) = (&self.spec.state, &self.state_signal) else { return vec![] };
        StateTerm::of_effect(&self.spec.kind, state, signal, self.reaction.as_deref(), self.values(x))
    }
}
