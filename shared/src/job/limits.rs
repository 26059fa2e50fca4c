//! The documented caps on the size of a job, checked before anything is allocated for it: a
//! job file or a `SubmitJob` request that asks for a population of 2⁶⁴ − 1 is refused with the
//! field and the cap, not met with an allocation that aborts the process. The README's
//! Security section lists them. Each cap is far above what a calibration needs; a job that
//! truly needs more is split (several experiments, a two-stage fit).

use super::JobError;
use super::spec::JobSpec;
use super::{Algorithm, JobKind};
use crate::optim::{CmaSettings, DeSettings, GaSettings};

/// Calibrated values: `[[parameters]]` plus the effects' parameters.
pub const MAX_PARAMETERS: usize = 1_000;
/// `[[outputs]]` and `[[inputs]]`, each (per experiment).
pub const MAX_SIGNALS: usize = 1_000;
/// `[[experiments]]` and `[[effects]]`, each.
pub const MAX_EXPERIMENTS: usize = 100;
/// DE, GA and CMA-ES population (CMA-ES: after its IPOP doublings).
pub const MAX_POPULATION: usize = 100_000;
/// Optimizer iterations (rounds).
pub const MAX_ITERS: u64 = 10_000_000;
/// Objective evaluations.
pub const MAX_FEVALS: u64 = 100_000_000;
/// Points of an evaluate-points job.
pub const MAX_POINTS: usize = 100_000;
/// Rows of one measurement table.
pub const MAX_DATA_ROWS: usize = 10_000_000;
/// Values (rows × columns) of one measurement table: 800 MB of numbers (the time series'
/// own cap, [`crate::series::MAX_VALUES`]).
pub const MAX_DATA_VALUES: usize = crate::series::MAX_VALUES;
/// `[simulation] set` entries.
pub const MAX_SET_VALUES: usize = 100_000;
/// Values one round hands out: points × fitted experiments × calibrated values (80 MB), so
/// the caps above cannot multiply into a round no machine holds.
pub const MAX_ROUND_VALUES: usize = 10_000_000;
/// Residuals an evaluate-points job keeps for its result: points × residuals per point (the
/// measured values of its fitted experiments), 80 MB of numbers.
pub const MAX_KEPT_RESIDUALS: usize = 10_000_000;

/// Worker processes of a local run (`--workers`, `[workers] count`): each is a process with
/// its own FMU instances, and far more than the machine's cores only adds memory and start-up
/// time.
pub const MAX_WORKERS: usize = 256;
/// Bytes read from one measurement file (CSV or `.mat`), checked before it is read.
pub const MAX_DATA_FILE_BYTES: u64 = crate::series::MAX_FILE_BYTES;
/// Bytes of a job file and of the `result.json` its `set_from` names.
pub const MAX_JOB_FILE_BYTES: u64 = 64 << 20;

fn over(field: &str, what: &str, n: impl std::fmt::Display, cap: impl std::fmt::Display) -> JobError {
    JobError::invalid(field, format!("{n} {what} exceeds the cap of {cap}"))
}

/// Checks the sizes `spec` asks for against the caps.
///
/// # Errors
/// [`JobError::Invalid`] naming the field, the size asked for and the cap.
pub fn check_spec(spec: &JobSpec) -> Result<(), JobError> {
    let calibrated = spec.parameters.len() + spec.effects.iter().map(|e| e.parameters.len()).sum::<usize>();
    if calibrated > MAX_PARAMETERS {
        return Err(over("parameters", "calibrated values", calibrated, MAX_PARAMETERS));
    }
    for (field, n) in [("outputs", spec.outputs.len()), ("inputs", spec.inputs.len())] {
        if n > MAX_SIGNALS {
            return Err(over(field, field, n, MAX_SIGNALS));
        }
    }
    for (field, n) in [("experiments", spec.experiments.len()), ("effects", spec.effects.len())] {
        if n > MAX_EXPERIMENTS {
            return Err(over(field, field, n, MAX_EXPERIMENTS));
        }
    }
    for (k, e) in spec.experiments.iter().enumerate() {
        let (outputs, inputs) = (e.outputs.as_ref().map_or(0, Vec::len), e.inputs.as_ref().map_or(0, Vec::len));
        for (what, n) in [("outputs", outputs), ("inputs", inputs)] {
            if n > MAX_SIGNALS {
                return Err(over(&format!("experiments[{k}].{what}"), what, n, MAX_SIGNALS));
            }
        }
        if e.set.len() > MAX_SET_VALUES {
            return Err(over(&format!("experiments[{k}].set"), "values", e.set.len(), MAX_SET_VALUES));
        }
    }
    if spec.simulation.set.len() > MAX_SET_VALUES {
        return Err(over("simulation.set", "values", spec.simulation.set.len(), MAX_SET_VALUES));
    }
    if let JobKind::EvaluatePoints(points) = &spec.kind
        && points.len() > MAX_POINTS
    {
        return Err(over("points", "points", points.len(), MAX_POINTS));
    }
    check_optimizer(spec)?;
    let fitted = spec.fitted_experiments().len().max(1);
    let values = round_points(spec, calibrated).saturating_mul(fitted).saturating_mul(calibrated);
    if values > MAX_ROUND_VALUES {
        return Err(JobError::invalid(
            "optimizer.population",
            format!(
                "a round of {} points × {fitted} experiments × {calibrated} values is {values} values, \
                 which exceeds the cap of {MAX_ROUND_VALUES}",
                round_points(spec, calibrated)
            ),
        ));
    }
    Ok(())
}

/// The most points one round of `spec`'s optimizer hands out (`n` calibrated values), with
/// each optimizer's default population ([`DeSettings::new`] and the like) where none is set.
fn round_points(spec: &JobSpec, n: usize) -> usize {
    if let JobKind::EvaluatePoints(points) = &spec.kind {
        return points.len();
    }
    let o = &spec.optimizer;
    match o.algorithm() {
        Algorithm::DifferentialEvolution => o.population().unwrap_or(DeSettings::new(n).population),
        Algorithm::Genetic => o.population().unwrap_or(GaSettings::new(n).population),
        Algorithm::CmaEs => {
            let first = o.population().unwrap_or(CmaSettings::new(n).population);
            let doublings = o.restarts().unwrap_or(0).min(63);
            first.saturating_mul(1usize << doublings)
        }
        // An initial simplex or interpolation set.
        Algorithm::NelderMead | Algorithm::LeastSquares => n + 2,
    }
}

fn check_optimizer(spec: &JobSpec) -> Result<(), JobError> {
    let o = &spec.optimizer;
    if let Some(p) = o.population() {
        // CMA-ES doubles its population at each IPOP restart.
        let doublings = o.restarts().unwrap_or(0);
        let largest = 1usize.checked_shl(doublings).filter(|_| doublings < 64).and_then(|f| f.checked_mul(p));
        if largest.is_none_or(|l| l > MAX_POPULATION) {
            let what =
                if doublings > 0 { format!("(doubled {doublings} times) population") } else { "population".into() };
            return Err(over("optimizer.population", &what, p, MAX_POPULATION));
        }
    }
    if let Some(n) = o.max_iters
        && n > MAX_ITERS
    {
        return Err(over("optimizer.max_iters", "iterations", n, MAX_ITERS));
    }
    if let Some(n) = o.max_fevals
        && n > MAX_FEVALS
    {
        return Err(over("optimizer.max_fevals", "evaluations", n, MAX_FEVALS));
    }
    Ok(())
}

/// Checks that `path`, given in `field` (`data.path`, `model.path`), is a regular file
/// (a symbolic link to one is fine) of at most `max_bytes` bytes, and returns its size.
///
/// # Errors
/// [`JobError::Invalid`] naming the field and the path: missing, unreadable, a directory, a
/// device or a FIFO (`/dev/zero` never ends), or larger than the cap.
pub fn check_regular_file(field: &str, path: &std::path::Path, max_bytes: u64) -> Result<u64, JobError> {
    let shown = crate::quote::quote_user_text(&path.to_string_lossy());
    let meta = std::fs::metadata(path).map_err(|e| JobError::invalid(field, format!("{shown}: {e}")))?;
    if let Some(kind) = crate::fmu::archive::non_regular_kind(&meta) {
        return Err(JobError::invalid(field, format!("{shown} is {kind}, not a regular file")));
    }
    if meta.len() > max_bytes {
        return Err(JobError::invalid(
            field,
            format!("{shown} is {} bytes, which exceeds the cap of {max_bytes}", meta.len()),
        ));
    }
    Ok(meta.len())
}

/// Checks the residuals an evaluate-points job of `points` points keeps, `per_point` each.
///
/// # Errors
/// [`JobError::Invalid`] naming `points`, the product and the cap.
pub fn check_kept_residuals(points: usize, per_point: usize) -> Result<(), JobError> {
    let kept = points.saturating_mul(per_point);
    if kept > MAX_KEPT_RESIDUALS {
        return Err(JobError::invalid(
            "points",
            format!(
                "{points} points × {per_point} residuals each (the measured values) is {kept} residuals to keep, \
                 which exceeds the cap of {MAX_KEPT_RESIDUALS}"
            ),
        ));
    }
    Ok(())
}

/// Checks the size of a measurement table (`field` names it: `data` or `experiments[K].data`).
///
/// # Errors
/// [`JobError::Invalid`] naming the field, the size and the cap.
pub fn check_table(field: &str, rows: usize, columns: usize) -> Result<(), JobError> {
    if rows > MAX_DATA_ROWS {
        return Err(over(field, "rows", rows, MAX_DATA_ROWS));
    }
    let values = rows.saturating_mul(columns.max(1));
    if values > MAX_DATA_VALUES {
        return Err(over(field, "values (rows × columns)", values, MAX_DATA_VALUES));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use super::*;
    use crate::job::spec::tests::JOB;

    fn with(extra: &str) -> Result<(), JobError> {
        JobSpec::from_toml(&format!("{JOB}\n[optimizer]\n{extra}"), Path::new(".")).unwrap().validate()
    }

    #[test]
    fn huge_optimizer_sizes_are_refused_before_any_allocation() {
        for (setting, field) in [
            ("algorithm = \"differential-evolution\"\npopulation = 18446744073709551615", "optimizer.population"),
            ("algorithm = \"differential-evolution\"\npopulation = 10000000000", "optimizer.population"),
            ("algorithm = \"genetic\"\npopulation = 100000000", "optimizer.population"),
            ("algorithm = \"cma-es\"\npopulation = 1000\nrestarts = 10", "optimizer.population"),
            ("algorithm = \"cma-es\"\npopulation = 10\nrestarts = 4000000000", "optimizer.population"),
            ("max_iters = 18446744073709551615", "optimizer.max_iters"),
            ("max_fevals = 1000000000000", "optimizer.max_fevals"),
        ] {
            let e = with(setting).unwrap_err().to_string();
            assert!(e.starts_with(field) && e.contains("exceeds the cap"), "{setting}: {e}");
        }
        with("algorithm = \"cma-es\"\npopulation = 1000\nrestarts = 6").unwrap();
        with("algorithm = \"genetic\"\npopulation = 100000").unwrap();
    }

    #[test]
    fn too_many_parameters_or_points_are_refused() {
        let mut text = JOB.to_owned();
        for k in 0..MAX_PARAMETERS {
            text.push_str(&format!("[[parameters]]\nname = \"p{k}\"\nstart = 1.0\nlower = 0.0\nupper = 2.0\n"));
        }
        let e = JobSpec::from_toml(&text, Path::new(".")).unwrap().validate().unwrap_err().to_string();
        assert_eq!(
            e,
            format!("parameters: {} calibrated values exceeds the cap of {MAX_PARAMETERS}", MAX_PARAMETERS + 1)
        );
        let spec = JobSpec::from_toml(JOB, Path::new(".")).unwrap();
        let e = spec.evaluating_points(vec![vec![1.0]; MAX_POINTS + 1]).validate().unwrap_err().to_string();
        assert!(e.starts_with("points: 100001 points exceeds the cap"), "{e}");
    }

    #[test]
    fn caps_cannot_multiply_into_a_huge_round() {
        let mut text = JOB.to_owned();
        for k in 0..999 {
            text.push_str(&format!("[[parameters]]\nname = \"p{k}\"\nstart = 1.0\nlower = 0.0\nupper = 2.0\n"));
        }
        let spec = |optimizer: &str| JobSpec::from_toml(&format!("{text}[optimizer]\n{optimizer}"), Path::new("."));
        let e = spec("algorithm = \"differential-evolution\"\npopulation = 100000").unwrap().validate().unwrap_err();
        assert!(e.to_string().contains("a round of 100000 points × 1 experiments × 1000 values"), "{e}");
        spec("algorithm = \"differential-evolution\"\npopulation = 10000").unwrap().validate().unwrap();
        spec("").unwrap().validate().unwrap();
    }

    #[test]
    fn a_points_job_keeping_too_many_residuals_is_refused() {
        check_kept_residuals(1_000, 10_000).unwrap();
        let e = check_kept_residuals(4_000, 8_000).unwrap_err().to_string();
        assert!(e.starts_with("points: 4000 points × 8000 residuals each"), "{e}");
        assert!(e.ends_with("32000000 residuals to keep, which exceeds the cap of 10000000"), "{e}");
        assert!(check_kept_residuals(usize::MAX, 2).is_err());
    }

    #[test]
    fn huge_tables_are_refused() {
        check_table("data", MAX_DATA_ROWS, 1).unwrap();
        assert!(check_table("data", MAX_DATA_ROWS + 1, 1).unwrap_err().to_string().starts_with("data: 10000001 rows"));
        let e = check_table("experiments[1].data", 1_000_000, 101).unwrap_err().to_string();
        assert!(e.starts_with("experiments[1].data: 101000000 values"), "{e}");
    }
}
