//! The checks after every fit: answers that may be wrong although the run ended
//! normally. Each check gives one sentence for `result.json`'s `warnings` (the CLI prints each
//! as `warning: ...`): a parameter at a bound, a run ended by its budget, a validation error
//! worse than at the start point, a correlation near ±1, a defaulted start time that is not
//! the model's own, and an integration error the tolerance guard could not make small against
//! the noise. The misfit check (the diagnosis's [`crate::residuals::Misfit`])
//! needs the fit's series and is added by the caller that has them.

use super::result::CalibrationResult;
use super::spec::JobSpec;

/// How near a bound (relative to the parameter's range) counts as at it.
pub const BOUND_TOLERANCE: f64 = 1e-6;

/// How near ±1 a correlation counts as the data not telling two parameters apart.
pub const CORRELATION_TOLERANCE: f64 = 0.01;

/// Which bound `x` is at or within [`BOUND_TOLERANCE`] of its range: "lower" or "upper".
pub fn at_bound(x: f64, lower: f64, upper: f64) -> Option<&'static str> {
    let tol = BOUND_TOLERANCE * (upper - lower).abs();
    if x - lower <= tol {
        Some("lower")
    } else if upper - x <= tol {
        Some("upper")
    } else {
        None
    }
}

/// Whether a termination names a budget (iterations, evaluations, wall time), not a tolerance.
pub fn ended_on_budget(termination: &str) -> bool {
    ["max_iters", "max_fevals", "max_time"].iter().any(|b| termination.starts_with(b))
}

/// The warnings of `result` (with its errors and identifiability filled in) for `spec`.
/// `model_start` is the FMU's DefaultExperiment startTime (or 0); `data_start` the first
/// sample of the (first) data table.
pub fn check(spec: &JobSpec, result: &CalibrationResult, model_start: f64, data_start: Option<f64>) -> Vec<String> {
    let mut warnings = vec![];
    let (names, _, lower, upper) = spec.parameter_vectors();
    for (i, name) in names.iter().enumerate() {
        let Some(&x) = result.x_opt.get(name) else { continue };
        if let Some(side) = at_bound(x, lower[i], upper[i]) {
            let bound = if side == "lower" { lower[i] } else { upper[i] };
            warnings.push(format!(
                "{name} = {x:.6e} is at its {side} bound {bound}: the best fit may lie outside the bounds, \
                 and no standard error is given for it"
            ));
        }
    }
    if let Some(guard) = &result.tolerance_guard
        && let Some(last) = guard.checks.last()
        && !last.passed()
    {
        warnings.push(format!(
            "even at rtol {:e}, the tightest tried, the integration error on {} may move an estimate by {:.2} \
             standard errors ({:.3} × the noise): the integrator, not the data, may decide the estimate (a \
             Co-Simulation FMU may ignore the tolerance: use Model Exchange if it has it)",
            last.tolerance, last.output, last.shift, last.ratio
        ));
    }
    if ended_on_budget(&result.termination) {
        warnings.push(format!(
            "the run ended on its budget ({}) after {} evaluations, not on a tolerance: it may not have converged; \
             raise the budget or start nearer",
            result.termination, result.evaluations
        ));
    }
    let worse = |w: &super::result::WindowError| w.scaled_rms.is_finite() && w.scaled_rms > 1.0;
    if let Some(v) = result.errors.as_ref().and_then(|e| e.validation.as_ref())
        && worse(v)
    {
        warnings.push(format!(
            "the validation error is worse than at the start point (scaled RMS {:.3} on the validation window)",
            v.scaled_rms
        ));
    }
    for x in &result.experiments {
        if let Some(v) = x.errors.validation.as_ref().filter(|v| worse(v)) {
            warnings.push(format!(
                "experiment {}: the validation error is worse than at the start point (scaled RMS {:.3} on the \
                 validation window)",
                x.name, v.scaled_rms
            ));
        }
        if x.role != "fit" && worse(&x.errors.calibration) {
            warnings.push(format!(
                "experiment {} (validation): the error is worse than at the start point (scaled RMS {:.3})",
                x.name, x.errors.calibration.scaled_rms
            ));
        }
    }
    if let Some(id) = &result.identifiability {
        for i in 0..id.names.len() {
            for j in i + 1..id.names.len() {
                let c = id.correlation[i][j];
                if c.abs() >= 1.0 - CORRELATION_TOLERANCE {
                    warnings.push(format!(
                        "{} and {} are correlated at {c:+.4}: the data cannot tell them apart; fix one or add data",
                        id.names[i], id.names[j]
                    ));
                }
            }
        }
    }
    if spec.simulation.start_time.is_none()
        && let Some(t0) = data_start
        && t0 != model_start
    {
        warnings.push(format!(
            "simulation.start_time was defaulted to the data's first sample {t0}, which is not the model's own \
             start time {model_start}: the model starts at {t0} from its initial state; set start_time if that \
             is not meant"
        ));
    }
    warnings
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bounds_are_relative_to_the_range() {
        assert_eq!(at_bound(0.0, 0.0, 10.0), Some("lower"));
        assert_eq!(at_bound(10.0 - 5e-6, 0.0, 10.0), Some("upper"));
        assert_eq!(at_bound(10.0 - 2e-5, 0.0, 10.0), None);
        assert_eq!(at_bound(5.0, 0.0, 10.0), None);
    }

    #[test]
    fn budgets_not_tolerances() {
        for t in ["max_iters reached", "max_fevals reached", "max_time reached"] {
            assert!(ended_on_budget(t), "{t}");
        }
        for t in ["x_tol reached", "f_tol reached", "interrupted"] {
            assert!(!ended_on_budget(t), "{t}");
        }
    }

    fn result(x: &[(&str, f64)], termination: &str) -> CalibrationResult {
        CalibrationResult {
            x_opt: x.iter().map(|(n, v)| ((*n).to_owned(), *v)).collect(),
            f_opt: 1.0,
            iterations: 1,
            evaluations: 1,
            rounds: 1,
            failed_evaluations: 0,
            termination: termination.into(),
            elapsed_s: 1.0,
            history: vec![],
            ..Default::default()
        }
    }

    const JOB: &str = "[model]\npath = \"m.fmu\"\n[data]\npath = \"d.csv\"\n[[outputs]]\nvariable = \"y\"\ncolumn = \"y\"\n\
        [[parameters]]\nname = \"a\"\nstart = 1.0\nlower = 0.0\nupper = 2.0\n\
        [[parameters]]\nname = \"b\"\nstart = 1.0\nlower = 0.0\nupper = 2.0\n";

    #[test]
    fn each_check_gives_its_sentence() {
        let spec = JobSpec::from_toml(JOB, std::path::Path::new(".")).unwrap();
        let clean = result(&[("a", 1.2), ("b", 0.7)], "x_tol reached");
        assert_eq!(check(&spec, &clean, 0.0, Some(0.0)), Vec::<String>::new());

        let mut r = result(&[("a", 2.0), ("b", 0.7)], "max_fevals reached");
        r.identifiability = Some(crate::job::identifiability::Identifiability {
            names: vec!["a".into(), "b".into()],
            standard_errors: vec![0.1, 0.1],
            correlation: vec![vec![1.0, -0.995], vec![-0.995, 1.0]],
            residuals: 10,
            steps: vec![1e-3, 1e-3],
        });
        let w = check(&spec, &r, 0.0, Some(0.5));
        assert_eq!(w.len(), 4, "{w:#?}");
        assert!(w[0].starts_with("a = 2.000000e0 is at its upper bound 2"), "{w:#?}");
        assert!(w[1].starts_with("the run ended on its budget (max_fevals reached)"), "{w:#?}");
        assert!(w[2].starts_with("a and b are correlated at -0.9950"), "{w:#?}");
        assert!(w[3].starts_with("simulation.start_time was defaulted to the data's first sample 0.5"), "{w:#?}");
        // 0.98 is not within 0.01 of 1; a start time given in the job is not questioned.
        r.identifiability.as_mut().unwrap().correlation = vec![vec![1.0, 0.98], vec![0.98, 1.0]];
        let mut given = spec.clone();
        given.simulation.start_time = Some(0.5);
        assert_eq!(check(&given, &r, 0.0, Some(0.5)).len(), 2);
    }
}
