//! The result of a calibration, as written to `result.json`. `serde_json` writes a NaN or
//! infinite number as `null`; the numbers of this module read such a `null` back as NaN.

use std::collections::BTreeMap;

use serde::{Deserialize, Deserializer, Serialize};

/// Reads a number, or `null` (a non-finite number as `serde_json` writes it) as NaN.
fn null_as_nan<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::NAN))
}

/// Best value after each completed round.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HistoryPoint {
    /// The round (batch) completed, counted from 1.
    pub round: u64,
    pub evaluations: u64,
    /// Infinite until a point succeeded (written as "inf": JSON has no such number).
    #[serde(with = "crate::optim::serde_float")]
    pub best_f: f64,
    /// Wall time of the round's batch.
    #[serde(deserialize_with = "null_as_nan")]
    pub batch_wall_s: f64,
    /// The best point after the round (user units, in the order of the job's calibrated
    /// parameters; empty before a point succeeded, and in files written before it was kept).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub best_x: Vec<f64>,
}

/// A calibrated parameter's name and bounds (user units).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ParameterRange {
    pub name: String,
    pub lower: f64,
    pub upper: f64,
}

/// One point of a job that evaluates given points.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EvaluatedPoint {
    /// The point, in parameter order.
    pub x: Vec<f64>,
    /// The objective value, or `None` if the simulation failed.
    #[serde(with = "crate::optim::serde_float::option")]
    pub value: Option<f64>,
    /// Weighted residuals (empty if the simulation failed).
    #[serde(with = "crate::optim::serde_float::vec")]
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
    #[serde(deserialize_with = "null_as_nan")]
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
    /// For a job with `[[experiments]]`: each experiment's RMS errors, when the CLI computed them.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub experiments: Vec<ExperimentErrors>,
    /// The FMI version of the model (`fmiVersion` of its description), when the CLI wrote it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fmi_version: Option<String>,
    /// The checks after the fit that failed ([`super::warnings`]), one sentence each; the CLI
    /// prints each as `warning: ...`, and `--strict` makes any of them exit code 3.
    #[serde(default)]
    pub warnings: Vec<String>,
    /// The calibrated parameters in the order of each history point's `best_x`, with their
    /// bounds, when the CLI wrote them (the convergence plot's parameter paths).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub parameters: Vec<ParameterRange>,
    /// Each output's unit from the model description (output → unit), when the CLI wrote it
    /// (the fit plot's axis labels).
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub units: BTreeMap<String, String>,
}

/// One experiment's RMS errors in `result.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ExperimentErrors {
    pub name: String,
    /// `fit` or `validation`.
    pub role: String,
    pub errors: ErrorReport,
}

impl CalibrationResult {
    /// The optimum as a vector in the order of `names` (NaN for a name it lacks).
    pub fn x_opt_in(&self, names: &[String]) -> Vec<f64> {
        names.iter().map(|n| self.x_opt.get(n).copied().unwrap_or(f64::NAN)).collect()
    }
}

/// RMS errors of the nominal and the optimized model on the calibration window and, if the job
/// has one, the validation window; "scaled" divides by the nominal model's RMS on that window.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ErrorReport {
    pub calibration: WindowError,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub validation: Option<WindowError>,
}

impl ErrorReport {
    /// The end of the calibration window, when a validation window follows it.
    pub fn validation_split(&self) -> Option<f64> {
        self.validation.as_ref().map(|_| self.calibration.stop_time)
    }
}

/// RMS errors on one time window (computed by [`super::report::error_report`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct WindowError {
    #[serde(deserialize_with = "null_as_nan")]
    pub start_time: f64,
    #[serde(deserialize_with = "null_as_nan")]
    pub stop_time: f64,
    /// NaN where the model's simulation failed.
    #[serde(deserialize_with = "null_as_nan")]
    pub rms_nominal: f64,
    #[serde(deserialize_with = "null_as_nan")]
    pub rms_optimized: f64,
    /// rms_optimized / rms_nominal (1.0 before calibration).
    #[serde(deserialize_with = "null_as_nan")]
    pub scaled_rms: f64,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn non_finite_numbers_survive_json() {
        let w =
            WindowError { start_time: 0.0, stop_time: 2.0, rms_nominal: 0.0, rms_optimized: 0.0, scaled_rms: f64::NAN };
        let report = ErrorReport { calibration: w.clone(), validation: Some(WindowError { start_time: 2.0, ..w }) };
        let result = CalibrationResult {
            x_opt: BTreeMap::from([("k".to_owned(), 1.5)]),
            f_opt: f64::INFINITY,
            iterations: 0,
            evaluations: 4,
            rounds: 1,
            failed_evaluations: 4,
            termination: "max_evals".into(),
            elapsed_s: 0.25,
            history: vec![HistoryPoint {
                round: 1,
                evaluations: 4,
                best_f: f64::INFINITY,
                batch_wall_s: 0.25,
                best_x: vec![],
            }],
            evaluated: vec![],
            errors: Some(report),
            identifiability: None,
            experiments: vec![],
            fmi_version: None,
            warnings: vec![],
            parameters: vec![],
            units: Default::default(),
        };
        let json = serde_json::to_string(&result).unwrap();
        // The optimum and the best value so far keep their infinity (a job with no successful
        // point must load back from the coordinator's store); report figures read null as NaN.
        assert!(json.contains(r#""f_opt":"inf""#) && json.contains(r#""scaled_rms":null"#), "{json}");
        let back: CalibrationResult = serde_json::from_str(&json).unwrap();
        assert!(back.f_opt == f64::INFINITY && back.history[0].best_f == f64::INFINITY);
        assert_eq!(back.history[0].batch_wall_s, 0.25);
        let errors = back.errors.as_ref().unwrap();
        assert!(errors.calibration.scaled_rms.is_nan());
        assert_eq!(errors.calibration.rms_nominal, 0.0);
        assert_eq!(errors.validation_split(), Some(2.0));
        assert_eq!(back.x_opt_in(&["k".into(), "c".into()])[0], 1.5);
        assert!(back.x_opt_in(&["c".into()])[0].is_nan());
    }

    #[test]
    fn a_result_written_before_the_plot_fields_still_reads() {
        let json = r#"{"x_opt":{"k":1.5},"f_opt":0.5,"iterations":1,"evaluations":4,"rounds":1,
            "failed_evaluations":0,"termination":"f_tol reached","elapsed_s":0.25,
            "history":[{"round":1,"evaluations":4,"best_f":0.5,"batch_wall_s":0.25}]}"#;
        let r: CalibrationResult = serde_json::from_str(json).unwrap();
        assert!(r.history[0].best_x.is_empty() && r.parameters.is_empty() && r.units.is_empty());
        // And the new fields survive a round trip.
        let r = CalibrationResult {
            parameters: vec![ParameterRange { name: "k".into(), lower: 0.0, upper: 2.0 }],
            units: BTreeMap::from([("y".to_owned(), "rad".to_owned())]),
            history: vec![HistoryPoint { best_x: vec![1.5], ..r.history[0].clone() }],
            ..r
        };
        let back: CalibrationResult = serde_json::from_str(&serde_json::to_string(&r).unwrap()).unwrap();
        assert_eq!(back, r);
    }

    #[test]
    fn no_validation_window_no_split() {
        let w = WindowError { start_time: 0.0, stop_time: 2.0, rms_nominal: 1.0, rms_optimized: 0.5, scaled_rms: 0.5 };
        assert_eq!(ErrorReport { calibration: w, validation: None }.validation_split(), None);
    }
}
