//! The result of a calibration, as written to `result.json`.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

/// Best value after each completed round.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HistoryPoint {
    pub round: u64,
    pub evaluations: u64,
    /// Infinite until a point succeeded (written as "inf": JSON has no such number).
    #[serde(with = "crate::optim::serde_float")]
    pub best_f: f64,
    /// Wall time of the round's batch.
    pub batch_wall_s: f64,
}

/// One point of a job that evaluates given points.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EvaluatedPoint {
    /// The point, in parameter order.
    pub x: Vec<f64>,
    /// The objective value, or `None` if the simulation failed.
    pub value: Option<f64>,
    /// Weighted residuals (empty if the simulation failed).
    pub residuals: Vec<f64>,
    /// Why the simulation failed.
    pub message: String,
}

impl EvaluatedPoint {
    /// The record of `evaluation` at `x`.
    pub fn new(x: &[f64], evaluation: &super::Evaluation) -> Self {
        EvaluatedPoint {
            x: x.to_vec(),
            value: evaluation.value,
            residuals: evaluation.residuals.clone().unwrap_or_default(),
            message: evaluation.error.clone().unwrap_or_default(),
        }
    }
}

/// `result.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CalibrationResult {
    /// Parameter name → optimal value.
    pub x_opt: BTreeMap<String, f64>,
    /// Infinite if no point succeeded (written as "inf").
    #[serde(with = "crate::optim::serde_float")]
    pub f_opt: f64,
    pub iterations: u64,
    pub evaluations: u64,
    pub rounds: u64,
    /// Evaluations whose simulation failed.
    pub failed_evaluations: u64,
    /// Which stopping rule ended the run.
    pub termination: String,
    pub elapsed_s: f64,
    pub history: Vec<HistoryPoint>,
    /// For a job that evaluates given points: each point with its value and residuals.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub evaluated: Vec<EvaluatedPoint>,
    /// Root-mean-square errors, when the CLI computed them.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub errors: Option<ErrorReport>,
    /// Standard errors and correlations at the optimum, when computed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub identifiability: Option<super::identifiability::Identifiability>,
}

/// RMS errors of the nominal and the optimized model on the calibration window and, if the job
/// has one, the validation window; "scaled" divides by the nominal model's RMS on that window.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ErrorReport {
    pub calibration: WindowError,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub validation: Option<WindowError>,
}

/// RMS errors on one time window.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct WindowError {
    pub start_time: f64,
    pub stop_time: f64,
    pub rms_nominal: f64,
    pub rms_optimized: f64,
    /// rms_optimized / rms_nominal (1.0 before calibration).
    pub scaled_rms: f64,
}
