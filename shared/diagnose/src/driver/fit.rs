//! A candidate's fit on the workers: a calibration to the accuracy the decision needs
//! ([`Fit::for_decision`]), Gauss–Newton steps from its optimum on difference points
//! ([`Fit::gauss_newton`]), and the chosen candidate's polish to the job's own tolerances
//! ([`polish`]).

use std::path::Path;
use std::time::{Duration, Instant};

use fmucal_shared::job::choices::Algorithm;
use fmucal_shared::job::identifiability::{self, DifferencePlan, Identifiability};
use fmucal_shared::job::{CalibrationResult, JobSpec, MeasurementTable, PreparedJob};

use super::{Context, Evaluate, prepare};
use crate::error::{Context as _, Error};
use crate::jobs::{decision_f_tol, decision_optimizer, gauss_newton, polish_step, stopped_early};
use crate::report::CandidateFit;

/// A fitted candidate as it comes back from the workers.
pub struct Fitted {
    pub job: JobSpec,
    pub result: Result<(CalibrationResult, Result<Identifiability, Error>), Error>,
    pub elapsed: Duration,
    /// Simulations of the fit and of its identifiability points.
    pub simulations: u64,
}

/// A calibration job on the workers, with what its identifiability points need.
pub struct Fit<'a, E> {
    pub eval: &'a mut E,
    pub job: &'a PreparedJob,
    pub data: &'a MeasurementTable,
    pub model: &'a Path,
}

/// The last point a Gauss–Newton run kept.
pub struct Refined {
    pub ssr: f64,
    pub x: Vec<f64>,
    /// What a step from it was predicted to gain.
    pub gain: f64,
}

/// One Gauss–Newton iterate: its point, SSR, difference plan and residuals, and what the
/// step from it was predicted to gain.
struct Iterate {
    ssr: f64,
    x: Vec<f64>,
    plan: DifferencePlan,
    residuals: Vec<Vec<f64>>,
    gain: f64,
}

impl<E: Evaluate> Fit<'_, E> {
    /// The fit of a candidate to the accuracy the decision needs ([`decision_optimizer`] at
    /// `ssr`, the lower of the start's SSR and the noise's), then its identifiability from the
    /// difference points at its optimum. Those also say what a Gauss–Newton step would still
    /// gain ([`gauss_newton`]): more than [`stopped_early`] allows means the fit stopped on
    /// a slope, and Gauss–Newton steps go on ([`Fit::gauss_newton`]). The result counts the
    /// evaluations of the fit and `simulations` adds the difference points.
    pub async fn for_decision(
        mut self,
        ssr: f64,
        n_eff: f64,
        simulations: &mut u64,
    ) -> Result<(CalibrationResult, Result<Identifiability, Error>), Error> {
        let (optimizer, f_tol) = decision_optimizer(&self.job.spec.optimizer, ssr, n_eff);
        let mut job = self.job.spec.clone();
        job.optimizer = optimizer;
        let mut result = self.eval.calibrate(&job, self.data, self.model, &|_| {}).await?;
        *simulations += result.evaluations;
        let x = result.x_opt_in(&self.job.parameter_names);
        let done = |ssr: f64, gain: f64| !stopped_early(gain, f_tol, ssr, n_eff);
        let (refined, id) = self.gauss_newton(x, done, simulations).await?;
        if let Some(r) = refined.filter(|r| r.ssr < result.f_opt) {
            result.f_opt = r.ssr;
            result.x_opt = self.job.parameter_names.iter().cloned().zip(r.x).collect();
        }
        Ok((result, id))
    }

    /// Gauss–Newton from `x`: each iteration is one job that evaluates the difference points
    /// at the current point (2n + 1 simulations side by side on the workers), which give its
    /// SSR, its identifiability and the next step ([`gauss_newton`]). It stops when
    /// `done(ssr, predicted gain)`, when a step does not lower the SSR (the point before it is
    /// kept) or lowers it by less than a quarter of its predicted gain, or after
    /// [`GAUSS_NEWTON_ITERATIONS`]. Returns the last point kept (`None` if the points at `x`
    /// failed), and its identifiability.
    pub async fn gauss_newton(
        &mut self,
        mut x: Vec<f64>,
        done: impl Fn(f64, f64) -> bool,
        simulations: &mut u64,
    ) -> Result<(Option<Refined>, Result<Identifiability, Error>), Error> {
        let (_, _, lower, upper) = self.job.spec.parameter_vectors();
        let mut best: Option<Iterate> = None;
        let mut failed = None;
        for iteration in 0..GAUSS_NEWTON_ITERATIONS {
            let plan = identifiability::difference_points(self.job, &x);
            *simulations += plan.points.len() as u64;
            let evaluated = self.eval.evaluate(&self.job.spec, plan.points.clone(), self.data, self.model).await?;
            let residuals = match identifiability::residuals_of(&evaluated) {
                Ok(r) => r,
                Err(e) => {
                    failed = Some(Error::from(e));
                    break;
                }
            };
            let ssr: f64 = residuals[0].iter().map(|r| r * r).sum();
            if best.as_ref().is_some_and(|b| ssr >= b.ssr) {
                break;
            }
            // A step that realised less than a quarter of its predicted gain: the linear model
            // does not hold here, and further steps would not either.
            let poor = best.as_ref().is_some_and(|b| b.ssr - ssr < 0.25 * b.gain);
            let next = gauss_newton(&plan, &residuals, &lower, &upper);
            tracing::debug!(
                "Gauss–Newton {iteration}: SSR {ssr:.6e}, a step would gain {:.2e}",
                next.as_ref().map_or(f64::NAN, |n| n.1)
            );
            let gain = next.as_ref().map_or(f64::NAN, |n| n.1);
            best = Some(Iterate { ssr, x: x.clone(), plan, residuals, gain });
            match next {
                Some((next, gain)) if !poor && !done(ssr, gain) => x = next,
                _ => break,
            }
        }
        Ok(match best {
            Some(Iterate { ssr, x, plan, residuals, gain }) => {
                let id = identifiability::from_residuals(&self.job.parameter_names, &plan, &residuals);
                (Some(Refined { ssr, x, gain }), id.map_err(Error::from))
            }
            None => (None, Err(failed.unwrap_or_else(|| Error::msg("no difference point was evaluated")))),
        })
    }
}

/// Gauss–Newton iterations after a fit, at most.
const GAUSS_NEWTON_ITERATIONS: usize = 4;

/// The chosen candidate's fit, polished from its optimum to the job's own tolerances, so that
/// its values (and the starts of `job.toml`) are as precise as a calibration's: Gauss–Newton
/// ([`Fit::gauss_newton`], each step 2n + 1 simulations side by side) until a step is predicted
/// to gain less than the job's f_tol. Where the model is too nonlinear for that (the last
/// step's predicted gain is still above the decision's accuracy, [`decision_f_tol`] at
/// `n_eff`), the least-squares solver goes on from there with the job's own x_tol, from a
/// small trust region ([`polish_step`]; its interpolation model follows the curvature the
/// difference steps miss). Evaluations and wall time include the decision's
/// fit; `simulations` only the polish's.
pub async fn polish(
    eval: &mut impl Evaluate,
    ctx: &Context,
    job: &JobSpec,
    fit: &CandidateFit,
    n_eff: f64,
) -> Result<Fitted, Error> {
    let t = Instant::now();
    let prepared = prepare(ctx, job)?;
    let names = prepared.parameter_names.clone();
    let f_tol = job.optimizer.f_tol.filter(|t| *t > 0.0).unwrap_or(1e-8);
    let x: Vec<f64> = names.iter().map(|n| fit.x_opt.get(n).copied().unwrap_or(f64::NAN)).collect();
    let mut simulations = 0;
    let mut gn = Fit { eval, job: &prepared, data: &ctx.data, model: &ctx.model };
    let (refined, mut id) = gn.gauss_newton(x, |_, gain| gain <= f_tol, &mut simulations).await?;
    let Refined { mut ssr, mut x, gain } = refined.context("the polish's first point failed")?;
    let mut termination = "Gauss–Newton polish";
    if gain > decision_f_tol(ssr, n_eff) {
        let mut ls = job.clone().with_starts(&names.iter().cloned().zip(x.iter().copied()).collect());
        ls.optimizer.set_algorithm(Algorithm::LeastSquares);
        ls.optimizer.set_initial_step(Some(polish_step(ls.optimizer.x_tol, ls.optimizer.initial_step())));
        let r = gn.eval.calibrate(&ls, &ctx.data, &ctx.model, &|_| {}).await?;
        simulations += r.evaluations;
        if r.f_opt < ssr {
            let (_, again) = gn.gauss_newton(r.x_opt_in(&names), |_, _| true, &mut simulations).await?;
            (ssr, x, id) = (r.f_opt, r.x_opt_in(&names), again);
            termination = "Gauss–Newton and least-squares polish";
        }
    }
    tracing::debug!(
        "polish ({termination}): {simulations} simulations, SSR {:.6e} → {ssr:.6e}",
        fit.evidence.as_ref().map_or(f64::NAN, |e| e.ssr)
    );
    let elapsed = t.elapsed() + Duration::from_secs_f64(fit.elapsed_s);
    let result = CalibrationResult {
        x_opt: names.iter().cloned().zip(x).collect(),
        f_opt: ssr,
        iterations: 0,
        evaluations: fit.evaluations + simulations,
        rounds: 0,
        failed_evaluations: 0,
        termination: termination.into(),
        elapsed_s: elapsed.as_secs_f64(),
        history: vec![],
        ..Default::default()
    };
    Ok(Fitted { job: job.clone(), result: Ok((result, id)), elapsed, simulations })
}
