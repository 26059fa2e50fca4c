//! Builds the job's optimizer from its kind and `[optimizer]` settings: the one place where each
//! algorithm's options ([`super::options::AlgorithmOptions`]) are merged with its optimizer's
//! defaults (`*Settings::new(n)`); unset options keep them. A parameter with `scale = "log"` enters the optimizer as its logarithm
//! (start and bounds alike); [`super::run::JobRun`] turns the points back into user units.

use super::choices::{Algorithm, JobKind};
use super::options::AlgorithmOptions;
use super::spec::JobSpec;
use crate::optim::{
    AnyOptimizer, CmaEs, CmaSettings, DeSettings, DifferentialEvolution, GaSettings, GeneticAlgorithm, LeastSquares,
    LsSettings, NelderMead, NmSettings, OptimError, PointBatch, Stopping,
};

/// The default budget `(max_iters, max_fevals)` of `algorithm` on `n` parameters, for a job
/// that sets neither; it grows with n and follows SciPy where SciPy has one: Nelder–Mead
/// 200·n iterations (`scipy.optimize.minimize`'s `maxiter`), least squares 100·n evaluations
/// (`scipy.optimize.least_squares`'s `max_nfev`); differential evolution, the genetic algorithm
/// and CMA-ES 1000·n generations.
pub fn default_budget(algorithm: Algorithm, n: usize) -> (Option<u64>, Option<u64>) {
    let n = n.max(1) as u64;
    match algorithm {
        Algorithm::NelderMead => (Some(200 * n), None),
        Algorithm::LeastSquares => (None, Some(100 * n)),
        Algorithm::DifferentialEvolution | Algorithm::Genetic | Algorithm::CmaEs => (Some(1000 * n), None),
    }
}

/// The stopping rules of `spec`'s optimizer on `n` parameters: each tolerance as the job sets it
/// (0 turns its rule off), else [`Stopping::default_for`]; the budget exactly as the job sets
/// it, else the algorithm's [`default_budget`].
pub fn stopping(spec: &JobSpec, n: usize) -> Stopping {
    let o = &spec.optimizer;
    let defaults = Stopping::default_for(n);
    // 0 disables a tolerance rule; unset takes the default.
    let rule = |v: Option<f64>, default: Option<f64>| match v {
        Some(t) if t == 0.0 => None,
        Some(t) => Some(t),
        None => default,
    };
    // A job that sets either budget gets exactly what it set; else the algorithm's default.
    let (max_iters, max_fevals) = match (o.max_iters, o.max_fevals) {
        (None, None) => default_budget(o.algorithm(), n),
        set => set,
    };
    Stopping { x_tol: rule(o.x_tol, defaults.x_tol), f_tol: rule(o.f_tol, defaults.f_tol), max_iters, max_fevals }
}

/// The optimizer of `spec`, starting at the parameters' start values (for an
/// [`JobKind::EvaluatePoints`] job: one batch of its points).
///
/// # Errors
/// [`OptimError::Setting`] naming the bad field.
pub fn build(spec: &JobSpec) -> Result<AnyOptimizer, OptimError> {
    let (_, mut x0, mut lower, mut upper) = spec.parameter_vectors();
    if let JobKind::EvaluatePoints(points) = &spec.kind {
        // Given points are in user units, and so is this optimizer (see `JobRun::new`).
        return Ok(AnyOptimizer::Points(PointBatch::new(&lower, &upper, points)?));
    }
    for (i, log) in spec.log_scaled().into_iter().enumerate() {
        if log {
            for v in [&mut x0[i], &mut lower[i], &mut upper[i]] {
                *v = v.ln();
            }
        }
    }
    let o = &spec.optimizer;
    let n = x0.len();
    let stopping = stopping(spec, n);
    Ok(match &o.options {
        AlgorithmOptions::DifferentialEvolution(opts) => {
            let d = DeSettings::new(n);
            let s = DeSettings {
                population: opts.population.unwrap_or(d.population),
                weight: opts.weight.unwrap_or(d.weight),
                crossover: opts.crossover.unwrap_or(d.crossover),
                seed: o.seed,
                stopping,
            };
            AnyOptimizer::DifferentialEvolution(DifferentialEvolution::new(&lower, &upper, Some(&x0), s)?)
        }
        AlgorithmOptions::Genetic(opts) => {
            let d = GaSettings::new(n);
            let s = GaSettings {
                population: opts.population.unwrap_or(d.population),
                bits: opts.bits.unwrap_or(d.bits),
                crossover_rate: opts.crossover_rate.unwrap_or(d.crossover_rate),
                mutation_rate: opts.mutation_rate.unwrap_or(d.mutation_rate),
                elitism: opts.elitism.unwrap_or(d.elitism),
                seed: o.seed,
                stopping,
            };
            AnyOptimizer::Genetic(GeneticAlgorithm::new(&lower, &upper, Some(&x0), s)?)
        }
        AlgorithmOptions::CmaEs(opts) => {
            let d = CmaSettings::new(n);
            let s = CmaSettings {
                population: opts.population.unwrap_or(d.population),
                sigma0: opts.initial_step.unwrap_or(d.sigma0),
                // A job restarts only when it asks to (the library's default is 9).
                restarts: opts.restarts.unwrap_or(0),
                seed: o.seed,
                stopping,
            };
            AnyOptimizer::CmaEs(CmaEs::new(&lower, &upper, Some(&x0), s)?)
        }
        AlgorithmOptions::LeastSquares(opts) => {
            let d = LsSettings::new(n);
            // Its own f_tol rule (f below f_tol × f(x0)) is not the spread the job's f_tol means;
            // the job's f_tol is the gain below which a step is not worth a round.
            let s = LsSettings {
                initial_radius: opts.initial_step.unwrap_or(d.initial_radius),
                min_predicted_gain: stopping.f_tol,
                stopping: Stopping { f_tol: None, ..stopping },
                ..d
            };
            AnyOptimizer::LeastSquares(LeastSquares::new(&lower, &upper, &x0, s)?)
        }
        AlgorithmOptions::NelderMead(opts) | AlgorithmOptions::Unnamed(opts) => {
            let d = NmSettings::new(n);
            let s = NmSettings {
                parallel: opts.parallel,
                initial_step: opts.initial_step.unwrap_or(d.initial_step),
                stopping,
                nominal: None,
            };
            AnyOptimizer::NelderMead(NelderMead::new(&lower, &upper, &x0, s)?)
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_budgets_grow_with_n_and_follow_scipy() {
        assert_eq!(default_budget(Algorithm::NelderMead, 3), (Some(600), None));
        assert_eq!(default_budget(Algorithm::LeastSquares, 3), (None, Some(300)));
        for a in [Algorithm::DifferentialEvolution, Algorithm::Genetic, Algorithm::CmaEs] {
            assert_eq!(default_budget(a, 3), (Some(3000), None), "{a:?}");
        }
        assert_eq!(default_budget(Algorithm::NelderMead, 0), (Some(200), None));
    }
}
