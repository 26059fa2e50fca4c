//! A derivative-free least-squares solver: a trust-region Gauss–Newton method on linear
//! interpolation models of the residual vector, after DFO-GN / DFO-LS (Cartis & Roberts 2019,
//! "A derivative-free Gauss–Newton method"), with box bounds and batches of parallel
//! evaluations. It minimises f(x) = Σ r_j(x)² and is told the residual vectors r(x)
//! ([`Optimizer::tell_residuals`]).
//!
//! **Method** (in scaled variables, [`Space`]; the constants are DFO-LS's defaults):
//! - The first batch is x0 plus n coordinate steps of length Δ₀ (`initial_radius`; backwards
//!   where a forward step leaves the box): n + 1 points evaluated in parallel.
//! - The n + 1 points of the interpolation set give the model r(x_k + d) ≈ r(x_k) + J d
//!   (module `model`), centred on the best point x_k.
//! - Each round takes a trust-region step: the minimiser d of ‖r + J d‖² subject to ‖d‖ ≤ Δ
//!   and lower ≤ x_k + d ≤ upper, found exactly as a bounded-variable Levenberg–Marquardt
//!   problem (module `subproblem`: an active-set solve per damping, the damping by
//!   bisection). Bounds hold by construction, and every asked point is also projected onto
//!   the box.
//! - The step is accepted or not by the ratio of actual to predicted decrease, and Δ updated
//!   as in DFO-LS (η₁ 0.1, η₂ 0.7: ×½ or down to ‖d‖ on failure, ×2 and at least 4‖d‖ on
//!   success, at most 10¹⁰). Every evaluated point enters the set, replacing the point chosen
//!   by the Lagrange-polynomial criterion; the best point is the centre.
//! - A lower radius ρ ≤ Δ (starting at Δ₀) is the resolution. A step shorter than ρ/2 is a
//!   *safety step*: if a point of the set is farther than 10ρ, a geometry step replaces it;
//!   otherwise ρ goes down (×0.1, to at most twice the step length, towards `x_tol`). A failed
//!   step at Δ = ρ with no far point lowers ρ too.
//!
//! **Parallel rounds.** Sequential DFO-LS spends one evaluation, and so one round, per
//! iteration. Here a round asks, with the trust-region step, the points that make the next
//! iteration better:
//! - when the trust region cuts the Gauss–Newton step, the step further along the
//!   Levenberg–Marquardt path, of radius min(‖GN step‖, 4Δ): when the model holds that far, one
//!   round does the work of two radius expansions;
//! - otherwise, when the set's farthest point is more than 3 step lengths from x_k (the model
//!   is stale compared with the step, which slows Gauss–Newton to linear convergence), n − 1
//!   points next to the trial point, orthogonal to the step and at its length; when all are
//!   evaluated, the set is renewed as {x_k, trial point, these points}, so the next Jacobian is
//!   local;
//! - in a safety round, the short step together with the geometry step;
//! - when none of these applies and the step is longer than ρ, half the step: a backtracking
//!   step evaluated beside the step, so that a round whose step the model overshoots still
//!   makes progress (on Furuta 7 rounds instead of 8, and one simulation fewer; it costs
//!   evaluations where steps succeed: `bench/least_squares.sh`, see the README).
//!
//! **Failures.** A failed evaluation, or residuals that are not all finite, ranks worst: the
//! point never enters the set; a failed trial step shrinks Δ below its length (the model is
//! unchanged, so the next step differs); a failed geometry step shrinks Δ, and at Δ = ρ lowers
//! ρ; a set left incomplete is filled along the missing directions; if every initial point
//! fails, the design is retried at half the radius. Rounds with geometry steps that make no
//! progress (more than n since ρ last changed) lower ρ, so every run ends. Nothing panics.
//!
//! **Termination** (the first rule met, checked between rounds; see [`Stopping`]):
//! - `x_tol`: ρ would have to go below `x_tol` (the trust radius in scaled variables, DFO-LS's
//!   `rhoend`) → [`Termination::XTol`]. Without `x_tol` the floor is 1e-15.
//! - `f_tol`: f(x_k) ≤ f_tol · f(x₀) ("objective sufficiently small" relative to the start,
//!   DFO-LS's `model.rel_tol` rule) → [`Termination::FTol`].
//! - slow progress: `max_slow_iterations` consecutive improving rounds in which log f fell by
//!   less than 10⁻⁴ per round, averaged over the last 5 (DFO-LS's `slow.*` rule) →
//!   [`Termination::FTol`].
//! - predicted gain (`min_predicted_gain`, a job's `f_tol`): the model, built from points no
//!   farther than 10ρ from x_k, predicts that the Gauss–Newton step in the box lowers f by
//!   less than it → [`Termination::FTol`]. f is then known to about that accuracy.
//! - `max_iters` trust-region iterations (rounds after the first) → [`Termination::MaxIters`];
//!   `max_fevals` evaluations → [`Termination::MaxFevals`]; a batch never asks beyond it (the
//!   trial step has priority).
//!
//! Like the other optimizers it has no I/O, clock or thread; the next batch is formed only once
//! the whole batch is told, in creation order, so the order of tells does not matter; and the
//! state is serde-serializable (with the residuals of the interpolation set).

mod batch;
mod iteration;
pub(crate) mod model;
pub(crate) mod subproblem;

use serde::{Deserialize, Serialize};

use self::batch::{LsBatch, Told};
use self::model::InterpolationSet;
#[cfg(test)]
use super::AnyOptimizer;
use super::run::local_space;
use super::space::Space;
use super::{Candidate, CandidateId, OptimError, Optimizer, Outcome, Status, Stopping, Termination};

/// Least-squares solver settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LsSettings {
    /// Initial trust-region radius Δ₀ in scaled variables (a fraction of the range where both
    /// bounds are finite), also the length of the initial coordinate steps. Default: 0.1.
    pub initial_radius: f64,
    /// Stopping rules; see the module docs for their meaning here. Default:
    /// [`Stopping::default_for`] the dimension (x_tol 1e-6, f_tol 1e-8, 1000·n iterations).
    pub stopping: Stopping,
    /// Consecutive slow successful iterations before stopping (see the module docs); `None`
    /// disables the rule. Default: 20·n, as DFO-LS.
    pub max_slow_iterations: Option<u64>,
    /// Stop once the model, on a set no farther than 10ρ from the centre, predicts that the
    /// best step in the box lowers f by less than this (absolute; a job's `f_tol`). `None`
    /// disables the rule. Default: `None`.
    pub min_predicted_gain: Option<f64>,
    /// Scale of parameters without two finite bounds. Default: |x0| (0.005 where x0 is 0).
    pub nominal: Option<Vec<f64>>,
}

impl LsSettings {
    /// Defaults for an `n`-dimensional problem.
    pub fn new(n: usize) -> Self {
        LsSettings {
            initial_radius: 0.1,
            stopping: Stopping::default_for(n),
            max_slow_iterations: Some(20 * n.max(1) as u64),
            min_predicted_gain: None,
            nominal: None,
        }
    }
}

/// What the current batch holds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
enum Phase {
    /// The initial design: x0 and one coordinate step per parameter (without x0 when retried
    /// closer to it after every point failed).
    Initial,
    /// A round: one role per point.
    Round {
        roles: Vec<Role>,
    },
    Done(Termination),
}

/// Why a point of a round was asked.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
enum Role {
    /// A trust-region step: the radius it was computed for, its length and the decrease of f
    /// the model predicts; `backtrack` for the half step asked beside the step (the two lie on
    /// one line with the centre, so only the better enters the set).
    Trial {
        radius: f64,
        norm: f64,
        predicted: f64,
        #[serde(default)]
        backtrack: bool,
    },
    /// A geometry step: the point that replaces the set's point at `replaces` (scaled
    /// position), or fills a missing direction (`None`).
    Geometry { replaces: Option<Vec<f64>> },
    /// A point next to the trial step, orthogonal to it, so that the set can be renewed around
    /// the step.
    Refresh,
}

/// Slow-progress bookkeeping: f at the centre after the last successful iterations, and how
/// many in a row were slow.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
struct Progress {
    history: Vec<f64>,
    slow: u64,
}

/// The derivative-free least-squares solver; see the module docs.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct LeastSquares {
    settings: LsSettings,
    space: Space,
    x0: Vec<f64>,
    batch: LsBatch,
    next_id: CandidateId,
    evaluations: u64,
    iterations: u64,
    rounds: u64,
    set: InterpolationSet,
    /// Trust-region radius Δ.
    delta: f64,
    /// Lower radius ρ ≤ Δ.
    rho: f64,
    /// f at the first centre (normally x0), for the f_tol rule.
    f0: Option<f64>,
    /// Length of the residual vectors (set by the first successful evaluation).
    m: Option<usize>,
    progress: Progress,
    /// Rounds with geometry steps and without progress since ρ last changed.
    stalled: u64,
    phase: Phase,
}

impl LeastSquares {
    /// Starts a search from `x0` within `[lower, upper]` (infinite bounds allowed).
    ///
    /// # Errors
    /// [`OptimError::Setting`] naming the bad field: bounds, `x0`, `nominal`, `initial_radius`,
    /// `max_slow_iterations` or a stopping rule.
    pub fn new(lower: &[f64], upper: &[f64], x0: &[f64], settings: LsSettings) -> Result<Self, OptimError> {
        let radius = ("initial_radius", settings.initial_radius);
        let space = local_space(lower, upper, x0, settings.nominal.as_deref(), &settings.stopping, radius)?;
        if settings.min_predicted_gain.is_some_and(|g| !(g >= 0.0 && g.is_finite())) {
            return Err(OptimError::setting("f_tol", "must be finite and not negative"));
        }
        if settings.max_slow_iterations == Some(0) {
            return Err(OptimError::setting("max_slow_iterations", "must be at least 1"));
        }
        if let Some(i) = (0..space.dim()).find(|&i| lower[i] == upper[i]) {
            return Err(OptimError::setting(
                "upper",
                format!("parameter {i} has lower == upper; the least-squares solver needs a range"),
            ));
        }
        let delta = settings.initial_radius;
        let mut ls = LeastSquares {
            x0: space.to_scaled(x0),
            space,
            settings,
            batch: LsBatch::default(),
            next_id: 0,
            evaluations: 0,
            iterations: 0,
            rounds: 0,
            set: InterpolationSet::default(),
            delta,
            rho: delta,
            f0: None,
            m: None,
            progress: Progress::default(),
            stalled: 0,
            phase: Phase::Initial,
        };
        ls.ask_initial(false);
        Ok(ls)
    }

    /// The trust-region radius Δ (scaled variables).
    pub fn radius(&self) -> f64 {
        self.delta
    }
}

impl Optimizer for LeastSquares {
    fn ask(&mut self) -> Vec<Candidate> {
        if matches!(self.phase, Phase::Done(_)) { vec![] } else { self.batch.open() }
    }

    /// Only [`Outcome::Failed`] is accepted: a value needs the residual vector.
    ///
    /// # Errors
    /// [`OptimError::UnknownCandidate`] if `id` is not awaiting a result, else
    /// [`OptimError::ResidualsNeeded`] for a value.
    fn tell(&mut self, id: CandidateId, outcome: Outcome) -> Result<(), OptimError> {
        match outcome {
            Outcome::Failed => self.tell_residuals(id, None),
            Outcome::Value(_) => {
                self.batch.awaiting(id)?;
                Err(OptimError::ResidualsNeeded(id))
            }
        }
    }

    fn is_open(&self, id: CandidateId) -> bool {
        !matches!(self.phase, Phase::Done(_)) && self.batch.awaiting(id).is_ok()
    }

    fn status(&self) -> Status {
        match self.phase {
            Phase::Done(t) => Status::Done(t),
            _ => Status::Running,
        }
    }

    fn best(&self) -> Option<(Vec<f64>, f64)> {
        let c = self.set.points.get(self.set.centre)?;
        Some((self.space.to_user(&c.z), c.f))
    }

    fn evaluations(&self) -> u64 {
        self.evaluations
    }

    fn iterations(&self) -> u64 {
        self.iterations
    }

    fn rounds(&self) -> u64 {
        self.rounds
    }

    fn wants_residuals(&self) -> bool {
        true
    }

    fn tell_residuals(&mut self, id: CandidateId, residuals: Option<&[f64]>) -> Result<(), OptimError> {
        if matches!(self.phase, Phase::Done(_)) {
            return Err(OptimError::UnknownCandidate(id));
        }
        if self.batch.record(id, Told::from_residuals(residuals))? {
            self.advance();
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests;
