//! Derivative-free optimizers as pure ask/tell state machines (Andersson et al. 2012, section 4).
//!
//! An optimizer never calls the objective: [`Optimizer::ask`] hands out a batch of candidate
//! points, [`Optimizer::tell`] takes each result back (in any order), and the next batch is
//! formed only once the whole batch is told, so the trajectory does not depend on the order of
//! tells or on how many workers evaluated the points. There is no I/O, no clock and no thread;
//! randomness comes from a seeded generator kept in the state, and the whole state is
//! `serde`-serializable, so a checkpointed optimizer resumes with exactly the same asks.
//!
//! Points are reported in user units; internally each optimizer works on scaled variables
//! ([`space::Space`]). A failed evaluation ranks worse than any value ([`fitness::Fitness`]);
//! NaN counts as failed.
//!
//! As in argmin, an optimizer's algorithm is kept apart from the state of its run: each public
//! optimizer is a [`BatchOptimizer`] of the bookkeeping they share (space, current batch, best
//! point, ids and counters; the internal `RunState`) and its own algorithm part, which is handed
//! that state to take a step (the internal `Step` trait). `ask`, `tell` and the getters are
//! implemented once, on `BatchOptimizer` (all in the private module `run`).
//!
//! - [`nelder_mead`]: Nelder–Mead with bounds, parallel (batches of 4) or sequential.
//! - [`differential_evolution`]: DE rand/1/bin.
//! - [`cma_es`]: CMA-ES with bounds and IPOP restarts.
//! - [`genetic`]: a bit-string genetic algorithm, as the paper describes it.
//! - [`least_squares`]: a derivative-free trust-region Gauss–Newton solver (after DFO-LS) that
//!   is told residual vectors; it keeps its own bookkeeping, as it stores residuals.
//! - [`point_batch`]: one batch of given points (for analyses that choose their own points).

#![forbid(unsafe_code)]

pub mod any;
mod batch;
pub mod cma_es;
pub mod differential_evolution;
pub mod fitness;
pub mod genetic;
pub mod least_squares;
#[cfg(any(test, feature = "test-problems"))]
pub mod least_squares_problems;
pub mod nelder_mead;
pub mod point_batch;
mod random;
mod run;
pub mod serde_float;
pub mod space;
#[cfg(any(test, feature = "test-problems"))]
pub mod test_problems;

use serde::{Deserialize, Serialize};

pub use any::AnyOptimizer;
pub use cma_es::{CmaEs, CmaSettings};
pub use differential_evolution::{DeSettings, DifferentialEvolution};
pub use fitness::Fitness;
pub use genetic::{GaSettings, GeneticAlgorithm};
pub use least_squares::{LeastSquares, LsSettings};
pub use nelder_mead::{NelderMead, NmSettings};
pub use point_batch::PointBatch;
pub use run::BatchOptimizer;
pub use space::Space;

/// Identifies a candidate between `ask` and `tell`; unique within one optimizer run.
pub type CandidateId = u64;

/// A point to evaluate, in user units.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Candidate {
    pub id: CandidateId,
    pub x: Vec<f64>,
}

/// The result of evaluating a candidate.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum Outcome {
    /// The objective value (NaN is treated as [`Outcome::Failed`]).
    Value(#[serde(with = "serde_float")] f64),
    /// The simulation did not complete; ranks worse than any value.
    Failed,
}

/// Why an optimizer stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Termination {
    /// The simplex or population is smaller than `x_tol` in scaled variables (least squares:
    /// the trust radius would go below `x_tol`).
    XTol,
    /// The spread of objective values is below `f_tol` (least squares: the objective fell to
    /// `f_tol` × its start value, its model predicts less gain than `min_predicted_gain` (a
    /// job's `f_tol`), or progress stalled; see [`least_squares`]).
    FTol,
    /// `max_iters` iterations (generations for DE and GA) were done.
    MaxIters,
    /// `max_fevals` evaluations were used.
    MaxFevals,
}

impl std::fmt::Display for Termination {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Termination::XTol => "x_tol reached",
            Termination::FTol => "f_tol reached",
            Termination::MaxIters => "max_iters reached",
            Termination::MaxFevals => "max_fevals reached",
        })
    }
}

/// Whether an optimizer wants more evaluations.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Status {
    Running,
    Done(Termination),
}

/// Stopping rules shared by all optimizers. The first rule met stops the run (the paper's
/// "one of which has to be fulfilled"); `None` disables a rule.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Stopping {
    /// Size of the simplex (NM) or population (DE, GA) in scaled variables: the largest
    /// infinity-norm distance from the best point; for least squares, the smallest trust
    /// radius. Default: 1e-6.
    pub x_tol: Option<f64>,
    /// Spread of objective values over the simplex or population (max − min); for least
    /// squares, the objective relative to its value at x0 (a job passes its `f_tol` to least
    /// squares as `LsSettings::min_predicted_gain` instead). Default: 1e-8.
    pub f_tol: Option<f64>,
    /// Iterations (NM, least squares) or generations (DE, GA). Default: 1000 × dimension.
    pub max_iters: Option<u64>,
    /// Objective evaluations. Default: none.
    pub max_fevals: Option<u64>,
}

impl Stopping {
    /// The defaults for an `n`-dimensional problem.
    pub fn default_for(n: usize) -> Self {
        Stopping { x_tol: Some(1e-6), f_tol: Some(1e-8), max_iters: Some(1000 * n.max(1) as u64), max_fevals: None }
    }

    /// Checks the settings.
    ///
    /// # Errors
    /// [`OptimError::Setting`] naming `x_tol`, `f_tol`, `max_iters` or `max_fevals`.
    pub fn validate(&self) -> Result<(), OptimError> {
        for (field, v) in [("x_tol", self.x_tol), ("f_tol", self.f_tol)] {
            if let Some(v) = v
                && !(v > 0.0 && v.is_finite())
            {
                return Err(OptimError::setting(field, format!("must be a positive number, got {v}")));
            }
        }
        for (field, v) in [("max_iters", self.max_iters), ("max_fevals", self.max_fevals)] {
            if v == Some(0) {
                return Err(OptimError::setting(field, "must be at least 1"));
            }
        }
        Ok(())
    }

    /// The rules applied to a simplex or population: its scaled points (in any order), their
    /// values and its best point.
    pub(crate) fn check_set<'a>(
        &self,
        best: &[f64],
        points: impl IntoIterator<Item = &'a [f64]>,
        values: impl IntoIterator<Item = Fitness>,
        iterations: u64,
        evaluations: u64,
    ) -> Option<Termination> {
        self.check(extent(best, points), fitness::spread(values), iterations, evaluations)
    }

    /// The first rule that holds, checked in the order x_tol, f_tol, max_iters, max_fevals.
    pub(crate) fn check(&self, x_size: f64, f_spread: f64, iterations: u64, evaluations: u64) -> Option<Termination> {
        if self.x_tol.is_some_and(|t| x_size <= t) {
            Some(Termination::XTol)
        } else if self.f_tol.is_some_and(|t| f_spread <= t) {
            Some(Termination::FTol)
        } else if self.max_iters.is_some_and(|m| iterations >= m) {
            Some(Termination::MaxIters)
        } else if self.max_fevals.is_some_and(|m| evaluations >= m) {
            Some(Termination::MaxFevals)
        } else {
            None
        }
    }
}

/// Largest ∞-norm distance of `points` from `best`: the size the x_tol rule measures.
pub(crate) fn extent<'a>(best: &[f64], points: impl IntoIterator<Item = &'a [f64]>) -> f64 {
    points.into_iter().map(|z| z.iter().zip(best).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max)).fold(0.0, f64::max)
}

/// Errors of optimizer construction and of `tell`.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum OptimError {
    /// A setting is out of range; `field` names it.
    #[error("invalid optimizer setting {field}: {message}")]
    Setting { field: &'static str, message: String },
    /// `tell` with an id that is not in the current batch.
    #[error("candidate {0} is not awaiting a result")]
    UnknownCandidate(CandidateId),
    /// `tell` with only a value, to an optimizer that needs the residual vector
    /// ([`Optimizer::wants_residuals`]).
    #[error("candidate {0}: this optimizer needs the residual vector, not only the objective value")]
    ResidualsNeeded(CandidateId),
}

impl OptimError {
    pub(crate) fn setting(field: &'static str, message: impl Into<String>) -> Self {
        OptimError::Setting { field, message: message.into() }
    }
}

/// The ask/tell interface every optimizer implements.
///
/// The loop a caller runs, here with the objective evaluated in place (fmucal sends each batch
/// to workers and tells the results as they come back, in any order):
///
/// ```
/// use fmucal_optim::nelder_mead::{NelderMead, NmSettings};
/// use fmucal_optim::{Optimizer, Outcome, Status};
///
/// // (x − 1)² + (y + 2)² on [−5, 5]², from the origin.
/// let mut nm = NelderMead::new(&[-5.0, -5.0], &[5.0, 5.0], &[0.0, 0.0], NmSettings::new(2)).unwrap();
/// while nm.status() == Status::Running {
///     for c in nm.ask() {
///         let f = (c.x[0] - 1.0).powi(2) + (c.x[1] + 2.0).powi(2);
///         nm.tell(c.id, Outcome::Value(f)).unwrap();
///     }
/// }
/// let (x, f) = nm.best().unwrap();
/// assert!((x[0] - 1.0).abs() < 1e-3 && (x[1] + 2.0).abs() < 1e-3, "{x:?}");
/// assert!(f < 1e-6);
/// ```
pub trait Optimizer {
    /// The candidates of the current batch that still await a result (a new batch once the
    /// previous one is fully told). Empty when done. Asking twice returns the same candidates.
    fn ask(&mut self) -> Vec<Candidate>;

    /// Reports the result of candidate `id`. The next batch is formed when the whole current
    /// batch has been told.
    ///
    /// # Errors
    /// [`OptimError::UnknownCandidate`] if `id` is not awaiting a result.
    fn tell(&mut self, id: CandidateId, outcome: Outcome) -> Result<(), OptimError>;

    /// Whether candidate `id` awaits a result (what [`Optimizer::tell`] accepts), without
    /// copying the batch as [`Optimizer::ask`] does.
    fn is_open(&self, id: CandidateId) -> bool;

    /// Running, or done with the reason.
    fn status(&self) -> Status;

    /// The best point evaluated so far (user units) and its value.
    fn best(&self) -> Option<(Vec<f64>, f64)>;

    /// Objective evaluations told so far.
    fn evaluations(&self) -> u64;

    /// Iterations (NM), trust-region iterations (least squares) or generations (DE, GA)
    /// completed.
    fn iterations(&self) -> u64;

    /// Batches handed out so far.
    fn rounds(&self) -> u64;

    /// Whether results should be told as residual vectors ([`Optimizer::tell_residuals`]): true
    /// for the least-squares solvers, which use the residuals and not only their sum of squares.
    fn wants_residuals(&self) -> bool {
        false
    }

    /// Reports candidate `id`'s residual vector r, whose objective is Σ r² (`None`: the
    /// evaluation failed). An optimizer that uses only the objective is told Σ r².
    ///
    /// # Errors
    /// [`OptimError::UnknownCandidate`] if `id` is not awaiting a result.
    fn tell_residuals(&mut self, id: CandidateId, residuals: Option<&[f64]>) -> Result<(), OptimError> {
        let outcome = match residuals {
            Some(r) => Outcome::Value(r.iter().map(|v| v * v).sum()),
            None => Outcome::Failed,
        };
        self.tell(id, outcome)
    }
}
