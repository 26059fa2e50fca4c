//! What a calibration report compares: the measured outputs and those of the model at the
//! job's start values ("start"; the `nominal` columns of [`FitColumns`]) and of the optimized
//! model at the measurement times ([`FitTable`], the CLI's `fit.csv`), and the two models'
//! errors per time window ([`ErrorReport`], in `result.json`): the objective's weighted RMS
//! over all outputs, and each output's RMS error in its own unit with its normalised fit
//! ([`Agreement`], the fit percentage of MATLAB System Identification Toolbox's `compare`).
//! [`compare`] simulates both models and labels each output with its unit from the model
//! description; [`FitTable::new`], [`error_report`] and [`Agreement::of`] are pure.

use std::sync::Arc;

use super::JobError;
use super::data::MeasurementTable;
use super::evaluator::Evaluator;
use super::objective::Objective;
use super::prepared::PreparedJob;
use super::result::{ErrorReport, OutputErrors, OutputWindowErrors, WindowError};
use crate::fmu::{Fmu, ModelDescription};
use crate::residuals::{Misfit, OutputMisfit};
use crate::sim::SimResult;

/// One output's columns of a [`FitTable`], each with one entry per time.
#[derive(Debug, Clone, PartialEq)]
pub struct FitColumns {
    pub variable: String,
    /// The variable's unit in the model description (its own or its declared type's), in
    /// which all three columns are; `None` where the description gives none.
    pub unit: Option<String>,
    /// NaN where the measurement is missing.
    pub measured: Vec<f64>,
    /// The model at the job's start values; `None` where it has no value (its simulation
    /// failed or ended early).
    pub nominal: Vec<Option<f64>>,
    /// `None` where the optimized model has no value.
    pub optimized: Vec<Option<f64>>,
}

/// Measured, nominal and optimized values of each output at the measurement times.
#[derive(Debug, Clone, PartialEq)]
pub struct FitTable {
    pub time: Vec<f64>,
    /// In the order of the objective's targets.
    pub outputs: Vec<FitColumns>,
}

impl FitTable {
    /// How far the optimized model is from its noise ([`Misfit`]), per output: residuals up to
    /// `calibration_stop` against those after it (the validation window, if the table has one).
    pub fn misfit(&self, calibration_stop: f64) -> Misfit {
        let rows = self.time.partition_point(|t| *t <= calibration_stop);
        let outputs = self
            .outputs
            .iter()
            .map(|o| {
                let r: Vec<f64> =
                    o.measured.iter().zip(&o.optimized).map(|(m, s)| s.map_or(f64::NAN, |s| s - m)).collect();
                let cut = rows.min(r.len());
                let finite = o.measured.iter().copied().filter(|m| m.is_finite());
                let (lo, hi) = finite.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), m| (a.min(m), b.max(m)));
                let range = if hi >= lo { hi - lo } else { 0.0 };
                OutputMisfit::new(&o.variable, &r[..cut], &r[cut..], range)
            })
            .collect();
        Misfit { outputs }
    }

    /// The table of `objective`'s targets against two simulations on its time grid (`None`: the
    /// simulation failed).
    pub fn new(objective: &Objective, nominal: Option<&SimResult>, optimized: Option<&SimResult>) -> Self {
        let n = objective.times.len();
        let at = |sim: Option<&SimResult>, variable: &str| {
            let column = sim.and_then(|s| s.column(variable));
            (0..n).map(|i| column.and_then(|c| c.get(i).copied())).collect()
        };
        let outputs = objective
            .targets
            .iter()
            .map(|t| FitColumns {
                variable: t.variable.clone(),
                unit: None,
                measured: (0..n).map(|i| t.values.get(i).copied().unwrap_or(f64::NAN)).collect(),
                nominal: at(nominal, &t.variable),
                optimized: at(optimized, &t.variable),
            })
            .collect();
        FitTable { time: objective.times.clone(), outputs }
    }

    /// Sets each output's unit from the model description `md`.
    pub fn set_units(&mut self, md: &ModelDescription) {
        for o in &mut self.outputs {
            o.unit = unit_of(md, &o.variable);
        }
    }
}

/// How well one output's simulated values agree with its measurements on one window.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Agreement {
    /// √(mean (ŷ − y)²), in the output's unit.
    pub rms: f64,
    /// 100·(1 − ‖y − ŷ‖/‖y − ȳ‖), ȳ the mean measurement: 100 fits exactly, 0 is no better
    /// than ȳ, and it is negative when worse. NaN when the measurements are constant.
    pub fit_percent: f64,
}

impl Agreement {
    /// The agreement of `simulated` with `measured` (one entry per time each). Missing
    /// measurements (NaN) are skipped; a missing simulated value where there is a measurement
    /// makes both figures NaN. No measurement at all gives an RMS of 0 and a NaN fit.
    pub fn of(measured: &[f64], simulated: &[Option<f64>]) -> Agreement {
        let pairs: Vec<(f64, f64)> = measured
            .iter()
            .zip(simulated)
            .filter(|(y, _)| !y.is_nan())
            .map(|(y, s)| (*y, s.unwrap_or(f64::NAN)))
            .collect();
        if pairs.is_empty() {
            return Agreement { rms: 0.0, fit_percent: f64::NAN };
        }
        let n = pairs.len() as f64;
        let mean = pairs.iter().map(|p| p.0).sum::<f64>() / n;
        let residual = pairs.iter().map(|(y, s)| (s - y).powi(2)).sum::<f64>();
        let spread = pairs.iter().map(|(y, _)| (y - mean).powi(2)).sum::<f64>();
        let fit_percent = if spread > 0.0 { 100.0 * (1.0 - (residual / spread).sqrt()) } else { f64::NAN };
        Agreement { rms: (residual / n).sqrt(), fit_percent }
    }
}

/// The RMS errors of the start and the optimized model, weighted as in the objective: the
/// calibration window holds the times up to `calibration_stop`, the validation window the later
/// ones (reported only if it has a measurement). Missing measurements are skipped; a missing
/// simulated value makes its window's RMS NaN. Each output's [`Agreement`] is in its
/// [`OutputErrors`], without a unit (the model description has it: [`compare`] adds it).
pub fn error_report(
    objective: &Objective,
    calibration_stop: f64,
    nominal: Option<&SimResult>,
    optimized: Option<&SimResult>,
) -> ErrorReport {
    let fit = FitTable::new(objective, nominal, optimized);
    // Squared errors and counts per window: [calibration, validation] x [nominal, optimized].
    let mut sums = [[0.0f64; 2]; 2];
    let mut counts = [0usize; 2];
    for (i, t) in fit.time.iter().enumerate() {
        let w = usize::from(*t > calibration_stop);
        for (target, columns) in objective.targets.iter().zip(&fit.outputs) {
            let m = columns.measured[i];
            if m.is_nan() {
                continue;
            }
            counts[w] += 1;
            if target.weight == 0.0 {
                // Adds nothing, even where the error overflows (0 × inf would be NaN).
                continue;
            }
            for (k, model) in [&columns.nominal, &columns.optimized].into_iter().enumerate() {
                sums[w][k] += target.weight * (model[i].unwrap_or(f64::NAN) - m).powi(2);
            }
        }
    }
    let window = |w: usize, start: f64, stop: f64| {
        let c = counts[w].max(1) as f64;
        let (n, o) = ((sums[w][0] / c).sqrt(), (sums[w][1] / c).sqrt());
        WindowError { start_time: start, stop_time: stop, rms_start: n, rms_optimized: o, scaled_rms: o / n }
    };
    let start = fit.time.first().copied().unwrap_or(0.0);
    let end = fit.time.last().copied().unwrap_or(calibration_stop);
    let split = fit.time.iter().position(|t| *t > calibration_stop).unwrap_or(fit.time.len());
    let outputs = fit
        .outputs
        .iter()
        .map(|c| {
            let window = |r: std::ops::Range<usize>| {
                let (start, optimized) = (
                    Agreement::of(&c.measured[r.clone()], &c.nominal[r.clone()]),
                    Agreement::of(&c.measured[r.clone()], &c.optimized[r]),
                );
                OutputWindowErrors {
                    rms_start: start.rms,
                    rms_optimized: optimized.rms,
                    fit_percent_start: start.fit_percent,
                    fit_percent_optimized: optimized.fit_percent,
                }
            };
            let measured_later = c.measured[split..].iter().any(|y| !y.is_nan());
            OutputErrors {
                variable: c.variable.clone(),
                unit: None,
                calibration: window(0..split),
                validation: (counts[1] > 0 && measured_later).then(|| window(split..fit.time.len())),
            }
        })
        .collect();
    ErrorReport {
        calibration: window(0, start, calibration_stop),
        validation: (counts[1] > 0).then(|| window(1, calibration_stop, end)),
        outputs,
    }
}

/// The unit of the values of the variable `name` (its own `unit`, else its declared type's,
/// else those of the variable an alias shares its value with); `None` if it has none.
pub fn unit_of(md: &ModelDescription, name: &str) -> Option<String> {
    let v = md.variable(name)?;
    md.unit_of(v).or_else(|| md.unit_of(md.base_of(v))).map(str::to_owned)
}

/// Which models [`compare`] simulates.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Models {
    /// The optimized model and the start model.
    StartAndOptimized,
    /// The optimized model only (the start model's cells empty, its RMS NaN): one simulation,
    /// for callers that judge only the optimized model.
    Optimized,
}

/// The fit table and error report of experiment `experiment` of `job` calibrated to `x_opt`
/// (in parameter order; `data` is the experiment's table): the optimized model at `x_opt` and,
/// with [`Models::StartAndOptimized`], the start model (at the job's start values), both
/// simulated up to the experiment's validation stop time if it has one. The start model leaves
/// the parameters an earlier stage fixed at the model's own values. A failed simulation leaves
/// its cells empty.
///
/// # Errors
/// [`JobError`] if the experiment does not extend to the validation window or the FMU cannot be
/// instantiated.
pub fn compare(
    fmu: &Fmu,
    job: &Arc<PreparedJob>,
    experiment: usize,
    data: &MeasurementTable,
    x_opt: &[f64],
    models: Models,
) -> Result<(FitTable, ErrorReport), JobError> {
    let e = job
        .experiments
        .get(experiment)
        .ok_or_else(|| JobError::invalid("experiment", format!("the job has no experiment {experiment}")))?;
    let (md, interfaces) = (&fmu.description, fmu.interfaces());
    let (_, x0, _, _) = job.spec.parameter_vectors();
    let reported = match e.spec.simulation.validation_stop_time {
        Some(stop) => {
            let mut s = e.spec.clone();
            s.simulation.stop_time = Some(stop);
            s.simulation.validation_stop_time = None;
            Arc::new(job.with_experiment(experiment, e.with_spec(s, md, &interfaces, data, &x0)?))
        }
        None => job.clone(),
    };
    let mut ev = Evaluator::new(fmu, reported.clone())?;
    let optimized = ev.simulate(x_opt, experiment).ok();
    let fixed = &e.spec.simulation.fixed_from_earlier_stage;
    let nominal = if models == Models::Optimized {
        None
    } else if fixed.is_empty() {
        ev.simulate(&x0, experiment).ok()
    } else {
        let mut s = reported.experiments[experiment].spec.clone();
        s.simulation.set.retain(|k, _| !fixed.contains(k));
        let baseline = job.with_experiment(experiment, e.with_spec(s, md, &interfaces, data, &x0)?);
        Evaluator::new(fmu, Arc::new(baseline))?.simulate(&x0, experiment).ok()
    };
    let calibration_stop = e.objective.times.last().copied().unwrap_or(f64::INFINITY);
    let objective = &reported.experiments[experiment].objective;
    let (nominal, optimized) = (nominal.as_ref(), optimized.as_ref());
    let mut errors = error_report(objective, calibration_stop, nominal, optimized);
    for o in &mut errors.outputs {
        o.unit = unit_of(md, &o.variable);
    }
    let mut fit = FitTable::new(objective, nominal, optimized);
    fit.set_units(md);
    Ok((fit, errors))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::job::objective::Target;

    fn sim(a: &[f64], b: &[f64]) -> SimResult {
        SimResult {
            names: vec!["a".into(), "b".into()],
            time: vec![0.0, 1.0, 2.0, 3.0],
            columns: vec![a.to_vec(), b.to_vec()],
            event_times: vec![],
            terminated_early: false,
            stats: Default::default(),
        }
    }

    /// Output a (weight 1) and b (weight 4) at t = 0..3, one measurement of each missing.
    fn objective() -> Objective {
        Objective {
            times: vec![0.0, 1.0, 2.0, 3.0],
            targets: vec![
                Target { variable: "a".into(), weight: 1.0, values: vec![1.0, f64::NAN, 3.0, 5.0] },
                Target { variable: "b".into(), weight: 4.0, values: vec![0.0, 1.0, 1.0, f64::NAN] },
            ],
        }
    }

    fn assert_close(got: f64, want: f64) {
        assert!((got - want).abs() <= 1e-15 * want.abs().max(1.0), "{got} != {want}");
    }

    #[test]
    fn weighted_rms_per_window_skips_missing_measurements() {
        let nominal = sim(&[2.0, 2.0, 2.0, 2.0], &[1.0, 1.0, 1.0, 1.0]);
        let optimized = sim(&[1.0, 0.0, 3.0, 4.0], &[0.0, 1.0, 1.5, 0.0]);
        let r = error_report(&objective(), 1.0, Some(&nominal), Some(&optimized));
        // Calibration (t = 0, 1; a(1) missing): 3 measurements.
        //   nominal: 1·(2−1)² + 4·(1−0)² + 4·(1−1)² = 5; optimized: 0.
        let cal = &r.calibration;
        assert_eq!((cal.start_time, cal.stop_time), (0.0, 1.0));
        assert_close(cal.rms_start, (5.0f64 / 3.0).sqrt());
        assert_eq!(cal.rms_optimized, 0.0);
        assert_eq!(cal.scaled_rms, 0.0);
        // Validation (t = 2, 3; b(3) missing): 3 measurements.
        //   nominal: 1·(2−3)² + 4·(1−1)² + 1·(2−5)² = 10; optimized: 0 + 4·0.5² + 1·(4−5)² = 2.
        let val = r.validation.as_ref().expect("measurements after t = 1");
        assert_eq!((val.start_time, val.stop_time), (1.0, 3.0));
        assert_close(val.rms_start, (10.0f64 / 3.0).sqrt());
        assert_close(val.rms_optimized, (2.0f64 / 3.0).sqrt());
        assert_close(val.scaled_rms, 0.2f64.sqrt());
        assert_eq!(r.validation_split(), Some(1.0));
    }

    #[test]
    fn no_measurement_after_the_split_no_validation_window() {
        let s = sim(&[1.0, 1.0, 1.0, 1.0], &[1.0, 1.0, 1.0, 1.0]);
        let r = error_report(&objective(), 3.0, Some(&s), Some(&s));
        assert_eq!(r.validation, None);
        assert_eq!((r.calibration.start_time, r.calibration.stop_time), (0.0, 3.0));
        // 6 measurements; a: 0 + 4 + 16 = 20, b: 4·(1 + 0 + 0) = 4; √(24 / 6) = 2.
        assert_close(r.calibration.rms_start, 4.0f64.sqrt());
        assert_eq!(r.calibration.scaled_rms, 1.0);
    }

    #[test]
    fn fit_table_lines_up_measurements_and_both_models() {
        let nominal = sim(&[2.0, 2.0, 2.0, 2.0], &[1.0, 1.0, 1.0, 1.0]);
        let fit = FitTable::new(&objective(), Some(&nominal), None);
        assert_eq!(fit.time, [0.0, 1.0, 2.0, 3.0]);
        assert_eq!(fit.outputs.len(), 2);
        let b = &fit.outputs[1];
        assert_eq!(b.variable, "b");
        assert_eq!(b.measured[..3], [0.0, 1.0, 1.0]);
        assert!(b.measured[3].is_nan());
        assert_eq!(b.nominal, [Some(1.0); 4]);
        assert_eq!(b.optimized, [None; 4]);
        assert!(fit.outputs[0].measured[1].is_nan());
    }

    #[test]
    fn a_failed_or_short_simulation_leaves_gaps_and_nan_not_a_panic() {
        // The optimized model ended early (two rows) and lacks output b altogether.
        let mut short = sim(&[1.0, 0.0], &[]);
        short.names.truncate(1);
        short.columns.truncate(1);
        short.time.truncate(2);
        short.terminated_early = true;
        let nominal = sim(&[2.0, 2.0, 2.0, 2.0], &[1.0, 1.0, 1.0, 1.0]);
        let fit = FitTable::new(&objective(), Some(&nominal), Some(&short));
        assert_eq!(fit.outputs[0].optimized, [Some(1.0), Some(0.0), None, None]);
        assert_eq!(fit.outputs[1].optimized, [None; 4]);
        let r = error_report(&objective(), 1.0, Some(&nominal), Some(&short));
        assert_close(r.calibration.rms_start, (5.0f64 / 3.0).sqrt());
        assert!(r.calibration.rms_optimized.is_nan() && r.calibration.scaled_rms.is_nan());
        let r = error_report(&objective(), 1.0, None, None);
        assert!(r.calibration.rms_start.is_nan() && r.validation.is_some_and(|v| v.rms_optimized.is_nan()));
    }

    #[test]
    fn an_empty_objective_reports_zero_counts_without_dividing_by_zero() {
        let r = error_report(&Objective { times: vec![], targets: vec![] }, f64::INFINITY, None, None);
        assert_eq!((r.calibration.rms_start, r.calibration.rms_optimized), (0.0, 0.0));
        assert_eq!(r.validation, None);
    }

    #[test]
    fn agreement_of_a_constant_offset_on_a_sine_matches_the_closed_form() {
        // y = sin t on 200 points over two full periods: mean 0 and Σ y² = N/2 exactly, so
        // with ŷ = y + c, ‖y − ŷ‖ = c√N and ‖y − ȳ‖ = √(N/2): RMS = c, fit = 100·(1 − c√2).
        let n = 200;
        let y: Vec<f64> = (0..n).map(|i| (4.0 * std::f64::consts::PI * i as f64 / n as f64).sin()).collect();
        let c = 0.1;
        let a = Agreement::of(&y, &y.iter().map(|v| Some(v + c)).collect::<Vec<_>>());
        assert!((a.rms - c).abs() < 1e-15, "{a:?}");
        assert!((a.fit_percent - 100.0 * (1.0 - c * 2f64.sqrt())).abs() < 1e-12, "{a:?}");
        // An exact model fits 100 %, the measurements' mean 0 %, and a worse one below 0.
        assert_eq!(Agreement::of(&y, &y.iter().map(|v| Some(*v)).collect::<Vec<_>>()).fit_percent, 100.0);
        assert!(Agreement::of(&y, &vec![Some(0.0); n]).fit_percent.abs() < 1e-12);
        let minus = Agreement::of(&y, &y.iter().map(|v| Some(-v)).collect::<Vec<_>>());
        assert!((minus.fit_percent + 100.0).abs() < 1e-12 && (minus.rms - 2f64.sqrt()).abs() < 1e-14, "{minus:?}");
    }

    #[test]
    fn agreement_skips_missing_measurements_and_has_no_fit_on_constant_data() {
        let a = Agreement::of(&[1.0, f64::NAN, 3.0], &[Some(2.0), None, Some(3.0)]);
        // Two measurements: RMS √(1/2); ‖y − ȳ‖ = √2, ‖y − ŷ‖ = 1.
        assert_close(a.rms, 0.5f64.sqrt());
        assert_close(a.fit_percent, 100.0 * (1.0 - 0.5f64.sqrt()));
        let gap = Agreement::of(&[1.0, 3.0], &[Some(1.0), None]);
        assert!(gap.rms.is_nan() && gap.fit_percent.is_nan());
        let flat = Agreement::of(&[2.0, 2.0], &[Some(2.5), Some(2.5)]);
        assert_eq!(flat.rms, 0.5);
        assert!(flat.fit_percent.is_nan());
    }

    #[test]
    fn error_report_has_each_outputs_unweighted_errors_per_window() {
        let nominal = sim(&[2.0, 2.0, 2.0, 2.0], &[1.0, 1.0, 1.0, 1.0]);
        let optimized = sim(&[1.0, 0.0, 3.0, 4.0], &[0.0, 1.0, 1.5, 0.0]);
        let r = error_report(&objective(), 1.0, Some(&nominal), Some(&optimized));
        let (a, b) = (&r.outputs[0], &r.outputs[1]);
        assert_eq!((a.variable.as_str(), b.variable.as_str(), a.unit.as_deref()), ("a", "b", None));
        // a on the calibration window: one measurement (1; a(1) missing), start 2, optimized 1.
        assert_eq!((a.calibration.rms_start, a.calibration.rms_optimized), (1.0, 0.0));
        assert!(a.calibration.fit_percent_start.is_nan());
        // b, weight 4 in the objective but not here: measured 0, 1; start 1, 1; optimized 0, 1.
        assert_close(b.calibration.rms_start, 0.5f64.sqrt());
        assert_close(b.calibration.fit_percent_start, 100.0 * (1.0 - 2f64.sqrt()));
        assert_eq!(b.calibration.fit_percent_optimized, 100.0);
        // a on the validation window: measured 3, 5; optimized 3, 4.
        let av = a.validation.expect("a is measured after t = 1");
        assert_close(av.rms_optimized, 0.5f64.sqrt());
        assert_close(av.fit_percent_optimized, 100.0 * (1.0 - 0.5f64.sqrt()));
        // b on the validation window: measured 1 (b(3) missing); optimized 1.5.
        assert_eq!(b.validation.expect("b is measured at t = 2").rms_optimized, 0.5);
        let r = error_report(&objective(), 3.0, Some(&nominal), Some(&optimized));
        assert!(r.outputs.iter().all(|o| o.validation.is_none()));
    }
}
