//! The result of a calibration, as written to `result.json`.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

/// Best value after each completed round.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HistoryPoint {
    pub round: u64,
    pub evaluations: u64,
    pub best_f: f64,
    /// Wall time of the round's batch.
    pub batch_wall_s: f64,
}

/// `result.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CalibrationResult {
    /// Parameter name → optimal value.
    pub x_opt: BTreeMap<String, f64>,
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
}
