//! Calibration jobs (paper section 6):
//! - the job specification ([`spec`], TOML for the CLI and the same fields over gRPC), with
//!   several experiments in one job ([`experiments`]), the optimizer settings with one options
//!   type per algorithm ([`options`]) and the enums a job names ([`choices`]);
//! - measurement data ([`data`]: CSV or MATLAB v5) and the quadratic error objective
//!   ([`objective`], the paper's `quad_err`);
//! - the job checked against its model and data ([`prepared`]), and the caps on its size
//!   ([`limits`]);
//! - one evaluation of a parameter point on one experiment, on a warm FMU instance
//!   ([`evaluator`]), and a pool of threads keeping such instances warm ([`pool`]);
//! - the optimizer built from the spec ([`optimizer`]), one job's run and its bookkeeping
//!   ([`run`]), the one ask/evaluate/tell loop ([`executor`]) and in-process calibration
//!   ([`local`]);
//! - standard errors and correlations at the optimum ([`identifiability`]), the result
//!   ([`result`]) and what its report compares: measured against start and optimized outputs,
//!   RMS errors per window and per output with its fit % ([`report`]);
//! - the integration-tolerance guard: the integrator's error small against the noise
//!   ([`tolerance`]).

pub mod choices;
pub mod data;
pub mod evaluator;
pub mod executor;
pub mod experiments;
pub mod identifiability;
pub mod limits;
pub mod local;
pub mod objective;
pub mod optimizer;
pub mod options;
pub mod pool;
pub mod prepared;
pub mod report;
pub mod result;
pub mod run;
pub mod spec;
pub mod tolerance;
pub mod warnings;

use crate::fmu::FmuError;
use crate::optim::OptimError;
use crate::sim::SimError;

pub use choices::{Algorithm, JobKind, JobStatus};
pub use data::MeasurementTable;
pub use evaluator::{Evaluation, Evaluator};
pub use objective::Objective;
pub use prepared::{PreparedExperiment, PreparedJob};
pub use report::FitTable;
pub use result::{CalibrationResult, ErrorReport, EvaluatedPoint, ExperimentErrors, HistoryPoint, ParameterRange};
pub use run::JobRun;
pub use spec::JobSpec;

/// Why a job cannot be prepared or run.
#[derive(Debug, thiserror::Error)]
pub enum JobError {
    /// The job is inconsistent with itself, its data or its model; `field` names the culprit
    /// (e.g. `parameters[1].lower`, `outputs[0].column`, `data.time`).
    #[error("{field}: {message}")]
    Invalid { field: String, message: String },
    #[error("cannot read {path}: {message}")]
    Read { path: String, message: String },
    #[error(transparent)]
    Fmu(#[from] FmuError),
    #[error(transparent)]
    Sim(#[from] SimError),
    #[error(transparent)]
    Optim(#[from] OptimError),
    /// The run cannot give a result: its start point failed, or no evaluation succeeded.
    #[error("{0}")]
    Failed(String),
}

impl JobError {
    pub fn invalid(field: impl Into<String>, message: impl Into<String>) -> Self {
        JobError::Invalid { field: field.into(), message: message.into() }
    }
}
