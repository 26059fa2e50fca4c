//! The objective of the paper's equation (1), over several outputs with weights:
//! f(x) = Σ_j w_j Σ_i (y_sim,j(t_i, x) − y_meas,j(t_i))², with y_sim taken at exactly the
//! measurement times. Missing measurements (NaN or empty cells) are skipped; rows with the same
//! time stamp (before and after an event) are averaged per column, as the 2012 `quad_err` did.
//! Measurements outside the simulated span [start, stop] are left out, so one data file can
//! serve a calibration window and a validation window.
//!
//! [`PreparedJob`] checks a job against its model and data once, and holds what every
//! evaluation needs: the simulation template and the averaged targets.

use serde::{Deserialize, Serialize};

use super::JobError;
use super::data::MeasurementTable;
use super::spec::{EffectSpec, JobSpec};
use crate::diagnose::effects;
use crate::fmu::schema::{Causality, VarType};
use crate::fmu::{Interface, ModelDescription};
use crate::sim::plan::Plan;
use crate::sim::{InputTable, OutputTimes, PortTerm, SimResult, SimSpec};

/// One output's targets at the unique measurement times (NaN = missing).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Target {
    pub variable: String,
    pub weight: f64,
    pub values: Vec<f64>,
}

/// The measurement side of the objective.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Objective {
    /// Unique measurement times inside the simulated span, increasing.
    pub times: Vec<f64>,
    pub targets: Vec<Target>,
}

impl Objective {
    /// Weighted residuals √w_j (y_sim − y_meas), output by output, skipping missing values.
    /// `None` if the simulation lacks an output, ended before the stop time (its last row may
    /// then be off the measurement times) or produced a non-finite value.
    pub fn residuals(&self, sim: &SimResult) -> Option<Vec<f64>> {
        if sim.terminated_early {
            return None;
        }
        let mut r = Vec::with_capacity(self.times.len() * self.targets.len());
        for t in &self.targets {
            let y = sim.column(&t.variable)?;
            if y.len() != t.values.len() {
                return None;
            }
            let s = t.weight.sqrt();
            for (ys, ym) in y.iter().zip(&t.values) {
                if ym.is_nan() {
                    continue;
                }
                let d = s * (ys - ym);
                if !d.is_finite() {
                    return None;
                }
                r.push(d);
            }
        }
        Some(r)
    }

    /// Σ r².
    pub fn value(residuals: &[f64]) -> f64 {
        residuals.iter().map(|r| r * r).sum()
    }
}

/// A job checked against its model and data.
#[derive(Debug, Clone)]
pub struct PreparedJob {
    pub spec: JobSpec,
    pub objective: Objective,
    /// The simulation of one evaluation, without the parameters.
    pub template: SimSpec,
    pub interface: Interface,
    /// Every calibrated name: the model's parameters, then the effects' (`effects[K].NAME`).
    pub parameter_names: Vec<String>,
    /// How many of `parameter_names` are the model's.
    pub fmu_parameters: usize,
    pub effects: Vec<PreparedEffect>,
}

impl PreparedJob {
    /// Checks `spec` against the model description and the data and builds the objective.
    ///
    /// # Errors
    /// [`JobError::Invalid`] naming the field: unknown or unsettable parameters, bounds outside
    /// a variable's min/max, unknown output variables, missing or malformed data columns,
    /// inputs that are not model inputs, and anything the simulation itself would reject.
    pub fn new(
        spec: &JobSpec,
        md: &ModelDescription,
        interfaces: &[Interface],
        data: &MeasurementTable,
    ) -> Result<Self, JobError> {
        spec.validate()?;
        let mut used: Vec<&str> = spec.outputs.iter().map(|o| o.column.as_str()).collect();
        used.extend(spec.inputs.iter().map(|i| i.column.as_str()));
        data.validate_measurements(&used)?;

        for (k, p) in spec.parameters.iter().enumerate() {
            let field = format!("parameters[{k}].name");
            let v = md
                .variable(&p.name)
                .ok_or_else(|| JobError::invalid(&field, format!("unknown variable {:?}", p.name)))?;
            if v.var_type != VarType::Real {
                return Err(JobError::invalid(
                    &field,
                    format!("{} is {:?}; only Real parameters can be calibrated", p.name, v.var_type),
                ));
            }
            if !v.settable_before_init() {
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
            let v = md.variable(&o.variable).ok_or_else(|| {
                JobError::invalid(format!("outputs[{k}].variable"), format!("unknown variable {:?}", o.variable))
            })?;
            if v.var_type == VarType::String {
                return Err(JobError::invalid(format!("outputs[{k}].variable"), format!("{} is a String", o.variable)));
            }
        }
        for (k, i) in spec.inputs.iter().enumerate() {
            let v = md.variable(&i.variable).ok_or_else(|| {
                JobError::invalid(format!("inputs[{k}].variable"), format!("unknown variable {:?}", i.variable))
            })?;
            if v.causality != Causality::Input {
                return Err(JobError::invalid(
                    format!("inputs[{k}].variable"),
                    format!("{} is not an input of the model", i.variable),
                ));
            }
        }

        let start = spec.simulation.start_time.unwrap_or(data.time[0]);
        let stop = spec.simulation.stop_time.unwrap_or(*data.time.last().expect("validated: rows present"));
        if !(stop > start) {
            return Err(JobError::invalid(
                "simulation.stop_time",
                format!("{stop} is not after the start time {start}"),
            ));
        }
        // Group rows by time stamp inside [start, stop] and average each output column.
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
        let interface = match spec.model.interface {
            Some(i) => i,
            None => *interfaces.first().ok_or_else(|| JobError::invalid("model", "the FMU offers no interface"))?,
        };
        let solver = spec.simulation.solver.unwrap_or_default();
        let mut outputs: Vec<String> = vec![];
        for o in &spec.outputs {
            if !outputs.contains(&o.variable) {
                outputs.push(o.variable.clone());
            }
        }
        for name in spec.simulation.set.keys() {
            if spec.parameters.iter().any(|p| &p.name == name) {
                return Err(JobError::invalid(format!("simulation.set.{name}"), "is also a calibrated parameter"));
            }
        }
        let template = SimSpec {
            interface: Some(interface),
            start_time: Some(start),
            stop_time: Some(stop),
            output_times: Some(OutputTimes::Times(times.clone())),
            parameters: spec.simulation.set.iter().map(|(k, v)| (k.clone(), v.to_string())).collect(),
            inputs,
            outputs,
            tolerance: spec.simulation.tolerance,
            solver,
            ..Default::default()
        };
        let (names, x0, _, _) = spec.parameter_vectors();
        let mut offset = spec.parameters.len();
        let mut effects = vec![];
        for (k, e) in spec.effects.iter().enumerate() {
            let count = e.ordered_parameters(k)?.len();
            effects.push(PreparedEffect { spec: e.clone(), offset, count });
            offset += count;
        }
        let job = PreparedJob {
            spec: spec.clone(),
            objective: Objective { times, targets },
            template,
            interface,
            parameter_names: names,
            fmu_parameters: spec.parameters.len(),
            effects,
        };
        // Everything the simulation would reject, rejected now, with the start values set:
        // first each port effect on its own (to name it), then the whole job.
        let check = job.sim_spec(&x0);
        for (k, effect) in job.effects.iter().enumerate() {
            if let Some(term) = effect.port_term(&x0) {
                let one = SimSpec { port_terms: vec![term], ..check.clone() };
                Plan::new(md, interfaces, &one).map_err(|e| {
                    let why = match e {
                        crate::sim::SimError::Invalid(why) => why,
                        other => other.to_string(),
                    };
                    JobError::invalid(format!("effects[{k}]"), why)
                })?;
            }
        }
        Plan::new(md, interfaces, &check).map_err(|e| JobError::invalid("simulation", e.to_string()))?;
        Ok(job)
    }

    /// The same job, asked to evaluate `points` instead of calibrating.
    pub fn evaluating_points(&self, points: Vec<Vec<f64>>) -> PreparedJob {
        PreparedJob { spec: self.spec.evaluating_points(points), ..self.clone() }
    }

    /// The simulation request of one evaluation at `x` (user units, in parameter order): the
    /// model's parameters, the port effects, and the actuator effects applied to their inputs.
    pub fn sim_spec(&self, x: &[f64]) -> SimSpec {
        let mut s = self.template.clone();
        let n = self.fmu_parameters.min(x.len());
        // `{}` prints the shortest text that parses back to the same f64.
        s.parameters.extend(self.parameter_names.iter().zip(&x[..n]).map(|(n, v)| (n.clone(), format!("{v}"))));
        for e in &self.effects {
            let p = e.values(x);
            if let Some(term) = e.port_term(x) {
                s.port_terms.push(term);
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

/// An effect of the job and where its parameters sit in a point.
#[derive(Debug, Clone)]
pub struct PreparedEffect {
    pub spec: EffectSpec,
    pub offset: usize,
    pub count: usize,
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
}
