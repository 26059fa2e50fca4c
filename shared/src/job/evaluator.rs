//! One evaluation of the objective at a parameter point on one experiment, on a warm FMU
//! instance that is reset between points and re-instantiated after a failure (see
//! [`crate::sim::Simulator`]); one instance serves every experiment of a job. A failed
//! simulation is an [`Evaluation`] with no value and the error text, never a panic. A point's
//! evaluations on the fitted experiments add up to its evaluation ([`Evaluation::combine`]).

use std::sync::Arc;
use std::time::{Duration, Instant};

use serde::{Deserialize, Serialize};

use super::JobError;
use super::objective::Objective;
use super::prepared::PreparedJob;
use crate::fmu::Fmu;
use crate::sim::{SimError, SimResult, Simulator};

/// The result of evaluating one point.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Evaluation {
    /// The objective value, or `None` if the simulation failed (an infinite value is kept
    /// apart from a failure in JSON, so a resumed job is told the same).
    #[serde(with = "crate::optim::serde_float::option")]
    pub value: Option<f64>,
    /// Weighted residuals, when asked for and the simulation succeeded.
    #[serde(default, with = "optional_floats")]
    pub residuals: Option<Vec<f64>>,
    /// Why the simulation failed.
    pub error: Option<String>,
    /// Wall time of the simulation.
    pub wall: Duration,
}

/// Serde for optional residual vectors whose values may be non-finite.
mod optional_floats {
    use serde::{Deserialize, Deserializer, Serializer};

    #[derive(serde::Serialize, serde::Deserialize)]
    struct Floats(#[serde(with = "crate::optim::serde_float::vec")] Vec<f64>);

    pub fn serialize<S: Serializer>(v: &Option<Vec<f64>>, s: S) -> Result<S::Ok, S::Error> {
        match v {
            Some(v) => s.serialize_some(&Floats(v.clone())),
            None => s.serialize_none(),
        }
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Option<Vec<f64>>, D::Error> {
        Ok(Option::<Floats>::deserialize(d)?.map(|f| f.0))
    }
}

impl Evaluation {
    /// A failed evaluation that never ran a simulation.
    pub fn failed(error: impl Into<String>) -> Self {
        Evaluation { value: None, residuals: None, error: Some(error.into()), wall: Duration::ZERO }
    }

    /// One point's evaluation from its evaluations on the fitted experiments, in order: the
    /// values add up, the residual vectors are concatenated and the wall times add up. It fails
    /// if any part failed (the first failure's error, naming the experiment in `names`).
    pub fn combine(parts: Vec<Evaluation>, names: &[&str]) -> Evaluation {
        if parts.len() == 1 {
            return parts.into_iter().next().expect("one part");
        }
        let wall = parts.iter().map(|p| p.wall).sum();
        if let Some((k, failed)) = parts.iter().enumerate().find(|(_, p)| p.value.is_none()) {
            let why = failed.error.clone().unwrap_or_default();
            let error = match names.get(k) {
                Some(name) if !name.is_empty() => format!("experiment {name}: {why}"),
                _ => why,
            };
            return Evaluation { value: None, residuals: None, error: Some(error), wall };
        }
        let residuals =
            parts.iter().map(|p| p.residuals.as_deref()).collect::<Option<Vec<&[f64]>>>().map(|r| r.concat());
        Evaluation { value: Some(parts.iter().filter_map(|p| p.value).sum()), residuals, error: None, wall }
    }
}

/// Evaluates points of one job on one warm instance. Not `Send`: keep it on its thread.
pub struct Evaluator {
    simulator: Simulator,
    job: Arc<PreparedJob>,
}

impl Evaluator {
    /// Instantiates the FMU for the job's interface.
    ///
    /// # Errors
    /// [`JobError::Sim`] if the FMU cannot be instantiated.
    pub fn new(fmu: &Fmu, job: Arc<PreparedJob>) -> Result<Self, JobError> {
        Ok(Evaluator { simulator: Simulator::new(fmu, Some(job.interface))?, job })
    }

    /// Simulates experiment `experiment` at `x` on its measurement grid, sensor effects applied.
    ///
    /// # Errors
    /// The simulation's error; [`SimError::Invalid`] for an experiment the job does not have.
    pub fn simulate(&mut self, x: &[f64], experiment: usize) -> Result<SimResult, SimError> {
        let e = self
            .job
            .experiments
            .get(experiment)
            .ok_or_else(|| SimError::Invalid(format!("the job has no experiment {experiment}")))?;
        let mut sim = self.simulator.run(&e.sim_spec(x))?;
        e.apply_sensor_effects(x, &mut sim);
        Ok(sim)
    }

    /// Evaluates the objective of experiment `experiment` at `x`.
    pub fn evaluate(&mut self, x: &[f64], experiment: usize, want_residuals: bool) -> Evaluation {
        let start = Instant::now();
        let outcome = self.simulate(x, experiment);
        let wall = start.elapsed();
        match outcome {
            // `simulate` succeeds only for an experiment the job has.
            Ok(sim) => match self.job.experiments[experiment].objective.residuals(&sim) {
                Some(r) => Evaluation {
                    value: Some(Objective::value(&r)),
                    residuals: want_residuals.then_some(r),
                    error: None,
                    wall,
                },
                None => Evaluation {
                    value: None,
                    residuals: None,
                    error: Some(if sim.terminated_early {
                        let end = sim.time.last().copied().unwrap_or(f64::NAN);
                        format!("the FMU terminated the simulation at t={end}, before the stop time")
                    } else {
                        "non-finite simulation output".into()
                    }),
                    wall,
                },
            },
            Err(e) => Evaluation { value: None, residuals: None, error: Some(e.to_string()), wall },
        }
    }
}
