//! The ask → evaluate → tell loop, once, for every job kind and optimizer (as argmin's
//! `Executor` owns the loop for every solver). [`execute`] runs a [`JobRun`] to its end on a
//! synchronous [`Backend`]; [`PoolBackend`] evaluates on this process's warm-evaluator pool.
//! The coordinator, which gets results from workers one at a time, drives the same
//! [`JobRun`] from its scheduler instead of calling [`execute`].

use std::sync::Arc;
use std::time::Instant;

use super::JobError;
use super::evaluator::Evaluation;
use super::pool::EvaluatorPool;
use super::prepared::PreparedJob;
use super::result::HistoryPoint;
use super::run::{JobRun, WorkItem};
use crate::fmu::Fmu;

/// Evaluates a round of work items.
pub trait Backend {
    /// The evaluations of `round`, in its order, with their residual vectors if
    /// `want_residuals`.
    fn evaluate(&mut self, round: &[WorkItem], want_residuals: bool) -> Vec<Evaluation>;
}

/// Asks rounds from `run` until it is done, evaluates each on `backend` and tells the results
/// in item order, so the run is the same whatever the backend's parallelism;
/// `on_round` sees every completed round.
///
/// # Errors
/// [`JobError::Invalid`] (field `executor`) if the backend answers a different number of points
/// than asked; [`JobError::Optim`] if the run refuses a result; [`JobError::Failed`] if the run
/// cannot give a result ([`JobRun::fatal_error`]).
pub fn execute(
    run: &mut JobRun,
    backend: &mut dyn Backend,
    mut on_round: impl FnMut(&HistoryPoint),
) -> Result<(), JobError> {
    loop {
        let round = run.ask();
        if round.is_empty() {
            return Ok(());
        }
        let started = Instant::now();
        let evaluations = backend.evaluate(&round, run.wants_residuals());
        if evaluations.len() != round.len() {
            return Err(JobError::invalid(
                "executor",
                format!("{} evaluations came back for {} points", evaluations.len(), round.len()),
            ));
        }
        let wall = started.elapsed().as_secs_f64();
        for (c, e) in round.iter().zip(&evaluations) {
            if let Some(done) = run.tell(c.id, &c.x, e, wall)? {
                on_round(&done);
            }
            if let Some(why) = run.fatal_error() {
                return Err(JobError::Failed(why));
            }
        }
    }
}

/// Evaluates one job's rounds on a warm-evaluator pool.
pub struct PoolBackend<'a> {
    pub pool: &'a EvaluatorPool,
    pub fmu: Arc<Fmu>,
    pub job: Arc<PreparedJob>,
    /// Names the job's warm instances in the pool.
    pub job_key: String,
}

impl Backend for PoolBackend<'_> {
    fn evaluate(&mut self, round: &[WorkItem], want_residuals: bool) -> Vec<Evaluation> {
        self.pool.evaluate_items(&self.job_key, &self.fmu, &self.job, round, want_residuals)
    }
}
