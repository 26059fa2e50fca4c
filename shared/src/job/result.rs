//! The result of a calibration, as written to `result.json`. `serde_json` writes a NaN or
//! infinite number as `null`; the numbers of this module read such a `null` back as NaN.
//!
//! The model at the job's start values is called "start" (`rms_start`); files written before
//! that name say `rms_nominal`, which is read as `rms_start` and still written beside it for
//! one release, so scripts reading the old name keep working.

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

/// `result.json`. Its `Default` is an empty result, for filling in the fields a caller has.
#[serde_with::skip_serializing_none]
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
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
    pub errors: Option<ErrorReport>,
    /// Standard errors and correlations at the optimum, when computed.
    pub identifiability: Option<super::identifiability::Identifiability>,
    /// For a job with `[[experiments]]`: each experiment's RMS errors, when the CLI computed them.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub experiments: Vec<ExperimentErrors>,
    /// The FMI version of the model (`fmiVersion` of its description), when the CLI wrote it.
    pub fmi_version: Option<String>,
    /// The checks after the fit that failed ([`super::warnings`]), one sentence each; the CLI
    /// prints each as `warning: ...`, and `--strict` makes any of them exit code 3.
    #[serde(default)]
    pub warnings: Vec<String>,
    /// The integration-tolerance guard's checks, and its refit if it made one, when the CLI
    /// ran it ([`super::tolerance`]).
    pub tolerance_guard: Option<super::tolerance::Guard>,
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

    /// This run followed by `next`, a run of the same job that started where this one ended
    /// (the tolerance guard's refit): `next`'s optimum and termination, the counts and wall
    /// times of both, and `next`'s history after this one's.
    #[must_use]
    pub fn followed_by(self, next: CalibrationResult) -> CalibrationResult {
        let (evaluations, rounds) = (self.evaluations, self.rounds);
        let mut history = self.history;
        history.extend(next.history.into_iter().map(|h| HistoryPoint {
            round: h.round + rounds,
            evaluations: h.evaluations + evaluations,
            ..h
        }));
        CalibrationResult {
            iterations: self.iterations + next.iterations,
            evaluations: evaluations + next.evaluations,
            rounds: rounds + next.rounds,
            failed_evaluations: self.failed_evaluations + next.failed_evaluations,
            elapsed_s: self.elapsed_s + next.elapsed_s,
            history,
            ..next
        }
    }
}

/// RMS errors of the start and the optimized model on the calibration window and, if the job
/// has one, the validation window; "scaled" divides by the start model's RMS on that window.
/// The window errors weigh and pool every output as the objective does; `outputs` has each
/// output's own errors, in its unit.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ErrorReport {
    pub calibration: WindowError,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub validation: Option<WindowError>,
    /// Each output's errors, in the order of the job's outputs (empty in files written before
    /// they were reported).
    #[serde(default)]
    pub outputs: Vec<OutputErrors>,
}

impl ErrorReport {
    /// The end of the calibration window, when a validation window follows it.
    pub fn validation_split(&self) -> Option<f64> {
        self.validation.as_ref().map(|_| self.calibration.stop_time)
    }
}

/// RMS errors on one time window (computed by [`super::report::error_report`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(from = "WindowErrorFile", into = "WindowErrorFile")]
pub struct WindowError {
    pub start_time: f64,
    pub stop_time: f64,
    /// The model at the job's start values; NaN where its simulation failed.
    pub rms_start: f64,
    pub rms_optimized: f64,
    /// rms_optimized / rms_start (1.0 before calibration).
    pub scaled_rms: f64,
}

/// [`WindowError`] as `result.json` holds it: `rms_start`, or `rms_nominal` in older files,
/// and `rms_nominal` written as a copy of `rms_start` for one release.
#[derive(Serialize, Deserialize)]
struct WindowErrorFile {
    #[serde(deserialize_with = "null_as_nan")]
    start_time: f64,
    #[serde(deserialize_with = "null_as_nan")]
    stop_time: f64,
    #[serde(default)]
    rms_start: Option<f64>,
    /// The old name of `rms_start`.
    #[serde(default)]
    rms_nominal: Option<f64>,
    #[serde(deserialize_with = "null_as_nan")]
    rms_optimized: f64,
    #[serde(deserialize_with = "null_as_nan")]
    scaled_rms: f64,
}

impl From<WindowErrorFile> for WindowError {
    fn from(f: WindowErrorFile) -> Self {
        WindowError {
            start_time: f.start_time,
            stop_time: f.stop_time,
            rms_start: f.rms_start.or(f.rms_nominal).unwrap_or(f64::NAN),
            rms_optimized: f.rms_optimized,
            scaled_rms: f.scaled_rms,
        }
    }
}

impl From<WindowError> for WindowErrorFile {
    fn from(w: WindowError) -> Self {
        WindowErrorFile {
            start_time: w.start_time,
            stop_time: w.stop_time,
            rms_start: Some(w.rms_start),
            rms_nominal: Some(w.rms_start),
            rms_optimized: w.rms_optimized,
            scaled_rms: w.scaled_rms,
        }
    }
}

/// One output's errors against its measurements, in the output's own unit, unweighted.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct OutputErrors {
    /// The model variable.
    pub variable: String,
    /// The unit of its values in the model description (its own `unit`, else its declared
    /// type's), which is also the unit of the measurements compared with it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub unit: Option<String>,
    pub calibration: OutputWindowErrors,
    /// On the validation window, when the job has one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub validation: Option<OutputWindowErrors>,
}

/// One output's agreement with its measurements on one window, for the start and the optimized
/// model (computed by [`super::report::Agreement::of`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct OutputWindowErrors {
    /// RMS error of the start model, in the output's unit.
    #[serde(deserialize_with = "null_as_nan")]
    pub rms_start: f64,
    /// RMS error of the optimized model, in the output's unit.
    #[serde(deserialize_with = "null_as_nan")]
    pub rms_optimized: f64,
    /// The start model's normalised fit in percent, 100·(1 − ‖y − ŷ‖/‖y − ȳ‖): 100 fits
    /// exactly, 0 is no better than the measurements' mean, and it is negative when worse.
    #[serde(deserialize_with = "null_as_nan")]
    pub fit_percent_start: f64,
    /// The optimized model's normalised fit in percent.
    #[serde(deserialize_with = "null_as_nan")]
    pub fit_percent_optimized: f64,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn non_finite_numbers_survive_json() {
        let w =
            WindowError { start_time: 0.0, stop_time: 2.0, rms_start: 0.0, rms_optimized: 0.0, scaled_rms: f64::NAN };
        let report = ErrorReport {
            calibration: w.clone(),
            validation: Some(WindowError { start_time: 2.0, ..w }),
            outputs: vec![],
        };
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
            tolerance_guard: None,
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
        assert_eq!(errors.calibration.rms_start, 0.0);
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
        let w = WindowError { start_time: 0.0, stop_time: 2.0, rms_start: 1.0, rms_optimized: 0.5, scaled_rms: 0.5 };
        assert_eq!(ErrorReport { calibration: w, validation: None, outputs: vec![] }.validation_split(), None);
    }

    #[test]
    fn old_files_say_rms_nominal_and_new_files_say_both_names() {
        // A result.json of the release before: `rms_nominal`, no per-output errors.
        let old =
            r#"{"calibration":{"start_time":0,"stop_time":2,"rms_nominal":0.5,"rms_optimized":0.25,"scaled_rms":0.5}}"#;
        let report: ErrorReport = serde_json::from_str(old).unwrap();
        assert_eq!(report.calibration.rms_start, 0.5);
        assert!(report.outputs.is_empty());
        let json = serde_json::to_value(&report).unwrap();
        assert_eq!(
            (json["calibration"]["rms_start"].as_f64(), json["calibration"]["rms_nominal"].as_f64()),
            (Some(0.5), Some(0.5))
        );
        assert_eq!(serde_json::from_value::<ErrorReport>(json).unwrap(), report);
    }

    #[test]
    fn per_output_errors_survive_json_with_nan_as_null() {
        let w = WindowError { start_time: 0.0, stop_time: 2.0, rms_start: 1.0, rms_optimized: 0.5, scaled_rms: 0.5 };
        let o = OutputWindowErrors {
            rms_start: 2.0,
            rms_optimized: 0.1,
            fit_percent_start: -3.0,
            fit_percent_optimized: f64::NAN,
        };
        let report = ErrorReport {
            calibration: w,
            validation: None,
            outputs: vec![OutputErrors {
                variable: "h".into(),
                unit: Some("m".into()),
                calibration: o,
                validation: Some(o),
            }],
        };
        let json = serde_json::to_string(&report).unwrap();
        assert!(json.contains(r#""unit":"m""#) && json.contains(r#""fit_percent_optimized":null"#), "{json}");
        let back: ErrorReport = serde_json::from_str(&json).unwrap();
        assert_eq!(back.outputs[0].calibration.fit_percent_start, -3.0);
        assert!(back.outputs[0].validation.unwrap().fit_percent_optimized.is_nan());
    }
}
