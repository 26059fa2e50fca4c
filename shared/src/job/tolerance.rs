//! The integration-tolerance guard: a calibration's integration error must be small against
//! the noise in its data, or the integrator's error, not the data, decides the estimate.
//!
//! [`check`] simulates a point at the job's tolerance and at a [`FINER`]-times smaller one
//! (in Co-Simulation, where an FMU may ignore the tolerance and the error comes from the
//! communication step, the finer run also splits every output interval into ten steps) and
//! compares, output by output, the difference on the measured times with the output's noise
//! estimate σ ([`crate::residuals::noise_sigma`] of the residual, with the
//! same floor as the diagnosis: a millionth of the output's range, or of its magnitude when it is
//! constant). Two numbers judge it: the RMS of the difference over σ, which must not exceed
//! [`GUARD_RATIO`], and its norm ‖e‖ over σ, which must not exceed [`GUARD_SHIFT`]. The second
//! is the one that matters with many samples: to first order, an error e in the outputs moves
//! each estimate by at most ‖e‖/σ of its standard error (Cauchy–Schwarz on the linearised
//! least-squares estimate), so a systematic error far below the noise still biases an estimate
//! from thousands of samples. [`tighten`] divides the job's tolerance by [`FINER`] until
//! the check passes, down to [`MIN_GUARDED_TOLERANCE`]. `fmucal calibrate` runs it at the
//! start point before calibrating and at the optimum after. A failure at the optimum is then
//! measured instead of bounded: the residuals at the tighter tolerance give the Jacobian, and
//! the Gauss–Newton step that the change in the residuals makes is the estimates' move to first
//! order ([`LinearisedMove`]). Only a move of more than [`GUARD_SHIFT`] standard errors that is
//! also larger than the optimizer's x_tol refits from the optimum at the tighter tolerance.
//! `[simulation] tolerance_guard = false` turns it off.

use std::sync::Arc;
use std::time::Instant;

use serde::{Deserialize, Serialize};

use super::JobError;
use super::data::MeasurementTable;
use super::prepared::PreparedJob;
use super::spec::JobSpec;
use crate::fmu::{Fmu, Interface};
use crate::residuals::noise_sigma;
use crate::sim::{SimResult, simulate};

/// The largest integration error allowed, as a fraction of the noise estimate.
pub const GUARD_RATIO: f64 = 0.1;

/// The largest shift, in standard errors, that the integration error may make in an estimate
/// (its bound ‖e‖/σ).
pub const GUARD_SHIFT: f64 = 0.2;

/// How much finer the comparison run is, and the step by which [`tighten`] tightens.
pub const FINER: f64 = 100.0;

/// [`tighten`] goes no tighter than this (the job file accepts down to 1e-14, but a comparison
/// run a hundred times finer must still be one an integrator meets).
pub const MIN_GUARDED_TOLERANCE: f64 = 1e-12;

/// The tolerance a simulation uses when the job gives none: the model's default experiment's,
/// else this (as in [`crate::sim`]).
pub const FALLBACK_TOLERANCE: f64 = 1e-6;

/// One check of the integration error at one point.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ToleranceCheck {
    /// Where: `start` or `optimum`.
    pub at: String,
    /// The relative tolerance checked.
    pub tolerance: f64,
    /// The output (`experiment: variable` in a job with several experiments) where the
    /// integration error is largest against the noise; there, the RMS of the error over the
    /// noise estimate, and the bound ‖e‖/σ on the shift it can make in an estimate, in
    /// standard errors.
    pub output: String,
    #[serde(with = "crate::optim::serde_float")]
    pub ratio: f64,
    #[serde(with = "crate::optim::serde_float")]
    pub shift: f64,
    /// Simulations the check ran, and their wall time.
    pub simulations: u64,
    pub seconds: f64,
}

impl ToleranceCheck {
    pub fn passed(&self) -> bool {
        self.ratio <= GUARD_RATIO && self.shift <= GUARD_SHIFT
    }

    /// How far past its limits the check is (≤ 1: passed).
    fn excess(&self) -> f64 {
        (self.ratio / GUARD_RATIO).max(self.shift / GUARD_SHIFT)
    }
}

/// What the guard did in one calibration (`result.json`'s `tolerance_guard`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Guard {
    /// The tolerance the final calibration used.
    pub tolerance: f64,
    /// Every check, in order: at the start point (tightening before the calibration), then at
    /// the optimum.
    pub checks: Vec<ToleranceCheck>,
    /// When the check at the optimum failed: how far the estimates move at the tighter
    /// tolerance, to first order, and whether that calls for a refit.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub linearised_move: Option<LinearisedMove>,
    /// The refit at a tighter tolerance, when the check at the optimum failed and the move
    /// calls for one (or could not be computed).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub refit: Option<Refit>,
}

/// The first-order move of the estimates at the optimum when the tolerance tightens: the
/// Gauss–Newton step that the change in the residuals makes
/// ([`super::identifiability::linearised_step`]). The check's ‖e‖/σ is an upper bound of its
/// size in standard errors. A refit is worth its local search only where the move is both
/// larger than [`GUARD_SHIFT`] standard errors and larger than the optimizer's x_tol, the
/// precision the job asks of its optimum (in the optimizer's scaled variables: a fraction of
/// the parameter's range, of its logarithm's with `scale = "log"`): a refit ends where it
/// starts when the move is below x_tol.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LinearisedMove {
    /// The tighter tolerance.
    pub tolerance: f64,
    /// The parameter that moves most in standard errors, and by how many.
    pub parameter: String,
    #[serde(with = "crate::optim::serde_float")]
    pub shift: f64,
    /// The optimizer's x_tol the move was compared with (none: no x_tol rule).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub x_tol: Option<f64>,
    /// Whether some parameter moves by more than [`GUARD_SHIFT`] standard errors and by more
    /// than x_tol: then the calibration refits from the optimum.
    pub refit_needed: bool,
    /// Simulations it took (the difference points at the tighter tolerance, whose residuals
    /// also give the standard errors when there is no refit, and the optimum at the first
    /// tolerance), and their wall time.
    pub simulations: u64,
    pub seconds: f64,
}

impl LinearisedMove {
    /// The move of the estimates `x` by `step` (user units), with their standard errors, for a
    /// job whose parameters have these bounds and log scales and whose optimizer stops at
    /// `x_tol`.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        tolerance: f64,
        names: &[String],
        x: &[f64],
        step: &[f64],
        standard_errors: &[f64],
        (lower, upper, log): (&[f64], &[f64], &[bool]),
        x_tol: Option<f64>,
    ) -> LinearisedMove {
        let shifts: Vec<f64> = step.iter().zip(standard_errors).map(|(d, se)| d.abs() / se).collect();
        // The move as a fraction of the range the optimizer scales by; infinite (so x_tol
        // cannot excuse it) where the range is not a finite positive width.
        let scaled = |i: usize| {
            let (moved, range) = if log[i] {
                let moved = x[i] + step[i];
                let ratio = if x[i] > 0.0 && moved > 0.0 { moved / x[i] } else { f64::INFINITY };
                (ratio.ln().abs(), (upper[i] / lower[i]).ln())
            } else {
                (step[i].abs(), upper[i] - lower[i])
            };
            if range.is_finite() && range > 0.0 { moved / range } else { f64::INFINITY }
        };
        // NaN (a zero standard error or range) counts as needing a refit.
        let refit_needed =
            (0..shifts.len()).any(|i| !(shifts[i] <= GUARD_SHIFT) && !(scaled(i) <= x_tol.unwrap_or(0.0)));
        let largest = (0..shifts.len()).max_by(|&a, &b| shifts[a].total_cmp(&shifts[b])).unwrap_or(0);
        LinearisedMove {
            tolerance,
            parameter: names.get(largest).cloned().unwrap_or_default(),
            shift: shifts.get(largest).copied().unwrap_or(0.0),
            x_tol,
            refit_needed,
            simulations: 0,
            seconds: 0.0,
        }
    }
}

/// The cost of a refit: the calibration at the tighter tolerance that started from the first
/// optimum (its evaluations are also counted in the result's).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Refit {
    /// The tolerance of the first calibration.
    pub from_tolerance: f64,
    pub evaluations: u64,
    pub seconds: f64,
}

impl Guard {
    /// Whether the last check passed (if not, the tolerance could not be tightened enough).
    pub fn passed(&self) -> bool {
        self.checks.last().is_none_or(ToleranceCheck::passed)
    }

    /// Simulations and seconds the checks took (without the refit).
    pub fn cost(&self) -> (u64, f64) {
        (self.checks.iter().map(|c| c.simulations).sum(), self.checks.iter().map(|c| c.seconds).sum())
    }

    /// One line for the summary (SE: the estimates' standard errors; the summary says
    /// "standard error" only of a parameter's own).
    pub fn summary(&self) -> String {
        let (simulations, seconds) = self.cost();
        let last = self.checks.last();
        let verdict = match last {
            Some(c) if c.passed() => format!(
                "at rtol {:e} the integration error is {:.3} × the noise and moves no estimate by more than \
                 {:.2} SE ({})",
                self.tolerance, c.ratio, c.shift, c.output
            ),
            Some(c) => format!(
                "even at rtol {:e}, the tightest tried, the integration error is {:.3} × the noise and may move \
                 an estimate by {:.2} SE ({})",
                c.tolerance, c.ratio, c.shift, c.output
            ),
            None => format!("rtol {:e}", self.tolerance),
        };
        let moved = match &self.linearised_move {
            Some(m) => {
                let verdict = match (m.refit_needed, m.x_tol) {
                    (true, _) => "",
                    (false, _) if m.shift <= GUARD_SHIFT => ": no refit",
                    (false, Some(t)) => &format!(": no refit, as no estimate moves by more than x_tol ({t:e})"),
                    (false, None) => ": no refit",
                };
                format!(
                    "; at rtol {:e} the optimum moves by {:.2} SE ({}), to first order{verdict}",
                    m.tolerance, m.shift, m.parameter
                )
            }
            None => String::new(),
        };
        let refit = match &self.refit {
            Some(r) => format!(
                "; refitted from rtol {:e}: {} evaluations, {:.2} s",
                r.from_tolerance, r.evaluations, r.seconds
            ),
            None => String::new(),
        };
        format!("tolerance guard: {verdict} ({simulations} simulations, {seconds:.2} s){moved}{refit}")
    }
}

/// The tolerance `job`'s simulations use: its own, else the model's default experiment's,
/// else [`FALLBACK_TOLERANCE`].
pub fn effective_tolerance(job: &JobSpec, fmu: &Fmu) -> f64 {
    job.simulation
        .tolerance
        .or_else(|| fmu.description.default_experiment.as_ref().and_then(|d| d.tolerance))
        .unwrap_or(FALLBACK_TOLERANCE)
}

/// Checks the integration error of `job` at the point `x` (every calibrated value, in order),
/// on each fitted experiment.
///
/// # Errors
/// [`JobError`] if a simulation fails (the calibration itself would fail there too).
pub fn check(fmu: &Fmu, job: &PreparedJob, x: &[f64], at: &str) -> Result<ToleranceCheck, JobError> {
    let started = Instant::now();
    let tolerance = effective_tolerance(&job.spec, fmu);
    let mut worst: Option<ToleranceCheck> = None;
    let mut simulations = 0;
    for &k in &job.fitted {
        let e = &job.experiments[k];
        let mut spec = e.sim_spec(x);
        spec.tolerance = Some(tolerance);
        let coarse = simulate(fmu, &spec).map_err(|err| JobError::invalid("simulation", err.to_string()))?;
        spec.tolerance = Some(tolerance / FINER);
        if job.interface == Interface::CoSimulation {
            spec.max_step = smallest_interval(&e.objective.times).map(|dt| dt / 10.0);
        }
        let fine = simulate(fmu, &spec).map_err(|err| JobError::invalid("simulation", err.to_string()))?;
        simulations += 2;
        for t in &e.objective.targets {
            let (ratio, shift) = error_over_noise(&coarse, &fine, &t.variable, &t.values);
            let output =
                if job.experiments.len() > 1 { format!("{}: {}", e.name, t.variable) } else { t.variable.clone() };
            let this =
                ToleranceCheck { at: at.to_owned(), tolerance, output, ratio, shift, simulations: 0, seconds: 0.0 };
            if worst.as_ref().is_none_or(|w| this.excess() > w.excess()) {
                worst = Some(this);
            }
        }
    }
    let worst = worst.unwrap_or(ToleranceCheck {
        at: at.to_owned(),
        tolerance,
        output: String::new(),
        ratio: 0.0,
        shift: 0.0,
        simulations: 0,
        seconds: 0.0,
    });
    Ok(ToleranceCheck { simulations, seconds: started.elapsed().as_secs_f64(), ..worst })
}

/// The RMS and the norm of `coarse − fine` for `variable` at the measured (not missing)
/// samples, each over the noise estimate of the coarse run's residual against `measured`.
/// Infinite if a run lacks the variable or has another length (the check then fails and says
/// which output).
fn error_over_noise(coarse: &SimResult, fine: &SimResult, variable: &str, measured: &[f64]) -> (f64, f64) {
    let (Some(a), Some(b)) = (coarse.column(variable), fine.column(variable)) else {
        return (f64::INFINITY, f64::INFINITY);
    };
    if a.len() != measured.len() || b.len() != measured.len() {
        return (f64::INFINITY, f64::INFINITY);
    }
    let rows = (0..measured.len()).filter(|&i| measured[i].is_finite());
    let (mut sum, mut n) = (0.0, 0usize);
    let mut residual = Vec::with_capacity(measured.len());
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for i in rows {
        sum += (a[i] - b[i]).powi(2);
        n += 1;
        residual.push(a[i] - measured[i]);
        lo = lo.min(measured[i]);
        hi = hi.max(measured[i]);
    }
    if n == 0 {
        return (0.0, 0.0);
    }
    // A constant output has no range: a millionth of its magnitude then.
    let scale = if hi > lo { hi - lo } else { hi.abs().max(lo.abs()) };
    let floor = crate::residuals::NOISE_FLOOR * scale;
    let noise = noise_sigma(&residual).max(floor).max(f64::MIN_POSITIVE);
    ((sum / n as f64).sqrt() / noise, sum.sqrt() / noise)
}

fn smallest_interval(times: &[f64]) -> Option<f64> {
    times.windows(2).map(|w| w[1] - w[0]).filter(|d| *d > 0.0).min_by(f64::total_cmp)
}

/// What [`tighten`] found: the job at the tolerance that passed (or the tightest that helped),
/// and every check on the way.
pub struct Tightened {
    pub spec: JobSpec,
    pub job: Arc<PreparedJob>,
    pub checks: Vec<ToleranceCheck>,
}

impl Tightened {
    /// Whether the last check passed.
    pub fn passed(&self) -> bool {
        self.checks.last().is_none_or(ToleranceCheck::passed)
    }

    /// Whether the job's tolerance changed.
    pub fn tightened(&self, from: &JobSpec) -> bool {
        self.spec.simulation.tolerance != from.simulation.tolerance
    }
}

/// Checks `job` at `x`; while the check fails, divides the tolerance by [`FINER`] (down to
/// [`MIN_GUARDED_TOLERANCE`]) and checks again. A tighter tolerance that does not at least
/// halve the error is not kept, and the tightening stops there.
///
/// # Errors
/// As [`check`], or if the tightened job no longer prepares.
pub fn tighten(
    fmu: &Fmu,
    job: Arc<PreparedJob>,
    data: &[MeasurementTable],
    x: &[f64],
    at: &str,
) -> Result<Tightened, JobError> {
    let mut spec = job.spec.clone();
    let mut job = job;
    let mut checks = vec![check(fmu, &job, x, at)?];
    while let Some(last) = checks.last()
        && !last.passed()
    {
        let next = last.tolerance / FINER;
        if next < MIN_GUARDED_TOLERANCE {
            break;
        }
        let mut tighter = spec.clone();
        tighter.simulation.tolerance = Some(next);
        let tighter_job = Arc::new(PreparedJob::new(&tighter, &fmu.description, &fmu.interfaces(), data)?);
        let c = check(fmu, &tighter_job, x, at)?;
        // A tolerance that does not shrink the error (a Co-Simulation FMU that ignores it, or
        // an error that comes from elsewhere) is not worth its cost: keep the job as it was.
        let helped = c.excess() <= 0.5 * last.excess();
        checks.push(c);
        if !helped {
            break;
        }
        (spec, job) = (tighter, tighter_job);
    }
    Ok(Tightened { spec, job, checks })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(values: &[f64]) -> SimResult {
        SimResult {
            names: vec!["y".into()],
            time: (0..values.len()).map(|i| i as f64).collect(),
            columns: vec![values.to_vec()],
            event_times: vec![],
            terminated_early: false,
            stats: Default::default(),
        }
    }

    #[test]
    fn the_error_is_measured_against_the_noise_of_the_residual() {
        // Measured: a line plus alternating noise ±0.01 (noise_sigma of an alternating
        // sequence ±s is s·2/√(2·0.4549…)); the runs differ by a constant 0.001.
        let n = 200;
        let measured: Vec<f64> = (0..n).map(|i| i as f64 * 0.01 + if i % 2 == 0 { 0.01 } else { -0.01 }).collect();
        let fine: Vec<f64> = (0..n).map(|i| i as f64 * 0.01).collect();
        let coarse: Vec<f64> = fine.iter().map(|y| y + 0.001).collect();
        let (ratio, shift) = error_over_noise(&run(&coarse), &run(&fine), "y", &measured);
        let sigma = noise_sigma(&coarse.iter().zip(&measured).map(|(a, m)| a - m).collect::<Vec<_>>());
        assert!((ratio - 0.001 / sigma).abs() < 1e-12, "{ratio} vs {}", 0.001 / sigma);
        // ‖e‖ = 0.001·√200.
        assert!((shift - 0.001 * 200f64.sqrt() / sigma).abs() < 1e-12, "{shift}");
        assert!(ratio < GUARD_RATIO && shift > GUARD_SHIFT, "{ratio} {shift}");
        // Missing samples are skipped; a missing variable fails the check.
        let mut gaps = measured.clone();
        gaps[3] = f64::NAN;
        assert!(error_over_noise(&run(&coarse), &run(&fine), "y", &gaps).1 < shift);
        assert_eq!(error_over_noise(&run(&coarse), &run(&fine), "z", &measured).0, f64::INFINITY);
    }

    #[test]
    fn a_refit_is_needed_only_for_a_move_beyond_both_the_standard_error_and_x_tol() {
        let names = ["a".to_owned(), "b".to_owned()];
        let linear = (&[0.0, 0.0][..], &[1.0, 10.0][..], &[false, false][..]);
        let moved = |step: [f64; 2], se: [f64; 2], x_tol| {
            LinearisedMove::new(1e-8, &names, &[0.5, 5.0], &step, &se, linear, x_tol)
        };
        // b moves by 3 SE (the largest), but 3e-5 of its range: below x_tol 1e-3.
        let m = moved([1e-6, -3e-4], [1e-5, 1e-4], Some(1e-3));
        assert_eq!((m.parameter.as_str(), m.refit_needed), ("b", false), "{m:?}");
        assert!((m.shift - 3.0).abs() < 1e-12, "{m:?}");
        // The same move against a finer x_tol, or no x_tol rule: a refit.
        assert!(moved([1e-6, -3e-4], [1e-5, 1e-4], Some(1e-6)).refit_needed);
        assert!(moved([1e-6, -3e-4], [1e-5, 1e-4], None).refit_needed);
        // Beyond x_tol but within 0.2 SE: none.
        assert!(!moved([1e-6, -3e-2], [1e-5, 1.0], Some(1e-6)).refit_needed);
        // A zero standard error cannot say the move is small.
        assert!(moved([1e-6, -3e-2], [1e-5, 0.0], None).refit_needed);
        // Unbounded, the range cannot scale the move: x_tol does not excuse it.
        let open = (&[0.0, f64::NEG_INFINITY][..], &[1.0, f64::INFINITY][..], &[false, false][..]);
        let m = LinearisedMove::new(1e-8, &names, &[0.5, 5.0], &[1e-6, -3e-4], &[1e-5, 1e-4], open, Some(1e-3));
        assert!(m.refit_needed, "{m:?}");
        // With scale = "log", x_tol is a fraction of the logarithm's range: ln(1.01) of
        // ln(1000) is 1.4e-3.
        let log = (&[0.01, 0.01][..], &[10.0, 10.0][..], &[true, true][..]);
        let m = LinearisedMove::new(1e-8, &names, &[1.0, 1.0], &[0.01, 0.0], &[1e-3, 1.0], log, Some(1e-3));
        assert!(m.refit_needed, "{m:?}");
        let m = LinearisedMove::new(1e-8, &names, &[1.0, 1.0], &[0.01, 0.0], &[1e-3, 1.0], log, Some(2e-3));
        assert!(!m.refit_needed, "{m:?}");
    }

    #[test]
    fn noise_free_data_fall_back_to_a_floor_of_the_range() {
        let fine: Vec<f64> = (0..100).map(|i| (i as f64 * 0.1).sin()).collect();
        let coarse: Vec<f64> = fine.iter().map(|y| y + 1e-9).collect();
        // The data are the fine run itself: no noise, so the floor (1e-6 of the range, 2)
        // decides: 1e-9 / 2e-6 = 5e-4.
        let (ratio, _) = error_over_noise(&run(&coarse), &run(&fine), "y", &fine);
        let range =
            fine.iter().copied().fold(f64::NEG_INFINITY, f64::max) - fine.iter().copied().fold(f64::INFINITY, f64::min);
        assert!((ratio - 1e-9 / (1e-6 * range)).abs() < 1e-6 * ratio, "{ratio}");
    }
}
