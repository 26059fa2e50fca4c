//! One job's run, the same wherever its points are evaluated: the optimizer built from the job
//! ([`super::optimizer::build`]), and the bookkeeping around its ask/tell loop — failed
//! evaluations, the history of completed rounds, the points of an
//! [`EvaluatePoints`](super::JobKind::EvaluatePoints) job with their residuals — and the
//! [`CalibrationResult`] it ends with. It is serializable, so the coordinator stores it after
//! every round and resumes from it.
//!
//! [`super::executor::execute`] drives a run to its end on a synchronous backend (threads in
//! this process); the coordinator drives the same type from worker results as they arrive.
//! Neither does any bookkeeping of its own. Like the optimizers, a run reads no clock: the
//! driver passes the wall time of a round.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use super::evaluator::Evaluation;
use super::objective::PreparedJob;
use super::optimizer;
use super::result::{CalibrationResult, EvaluatedPoint, HistoryPoint};
use crate::optim::{AnyOptimizer, Candidate, CandidateId, OptimError, Optimizer, Outcome, Status};

/// A job's optimizer and the bookkeeping of its rounds.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct JobRun {
    optimizer: AnyOptimizer,
    history: Vec<HistoryPoint>,
    failed_evaluations: u64,
    /// Kept for jobs that want residuals: each told point, by candidate id.
    evaluated: BTreeMap<CandidateId, EvaluatedPoint>,
    keep_points: bool,
}

impl JobRun {
    /// A run of `job` that has asked nothing yet.
    ///
    /// # Errors
    /// [`OptimError::Setting`] naming the bad optimizer setting.
    pub fn new(job: &PreparedJob) -> Result<Self, OptimError> {
        Ok(JobRun {
            optimizer: optimizer::build(&job.spec)?,
            history: vec![],
            failed_evaluations: 0,
            evaluated: BTreeMap::new(),
            keep_points: job.spec.kind.wants_residuals(),
        })
    }

    /// The candidates of the current round still awaiting a result; empty once the run is done.
    pub fn ask(&mut self) -> Vec<Candidate> {
        self.optimizer.ask()
    }

    /// Tells the evaluation of candidate `id` (at `x`). When it completes the round, the round
    /// is added to the history (with `round_wall_s`, the round's wall time so far) and returned.
    ///
    /// # Errors
    /// [`OptimError::UnknownCandidate`] if `id` is not awaiting a result; nothing is recorded.
    pub fn tell(
        &mut self,
        id: CandidateId,
        x: &[f64],
        evaluation: &Evaluation,
        round_wall_s: f64,
    ) -> Result<Option<HistoryPoint>, OptimError> {
        let outcome = evaluation.value.map_or(Outcome::Failed, Outcome::Value);
        // The optimizer forms its next round once the current one is fully told.
        let rounds_before = self.optimizer.rounds();
        self.optimizer.tell(id, outcome)?;
        if evaluation.value.is_none() {
            self.failed_evaluations += 1;
            tracing::debug!(?x, error = ?evaluation.error, "evaluation failed");
        }
        if self.keep_points {
            self.evaluated.insert(id, EvaluatedPoint::new(x, evaluation));
        }
        if self.optimizer.rounds() == rounds_before && !self.is_done() {
            return Ok(None);
        }
        let round = HistoryPoint {
            round: self.optimizer.rounds(),
            evaluations: self.optimizer.evaluations(),
            best_f: self.best_f(),
            batch_wall_s: round_wall_s,
        };
        self.history.push(round.clone());
        Ok(Some(round))
    }

    /// Whether the optimizer has stopped.
    pub fn is_done(&self) -> bool {
        matches!(self.optimizer.status(), Status::Done(_))
    }

    /// The optimizer, for its counters and best point.
    pub fn optimizer(&self) -> &AnyOptimizer {
        &self.optimizer
    }

    /// The best value so far (infinite before any success).
    pub fn best_f(&self) -> f64 {
        self.optimizer.best().map_or(f64::INFINITY, |b| b.1)
    }

    /// The result so far: the optimum (the start point if nothing succeeded), counters, history
    /// and evaluated points. `termination` overrides the optimizer's reason (e.g. "cancelled").
    pub fn result(&self, job: &PreparedJob, elapsed_s: f64, termination: Option<&str>) -> CalibrationResult {
        let (x, f) = self.optimizer.best().unwrap_or_else(|| (job.spec.parameter_vectors().1, f64::INFINITY));
        let termination = match (termination, self.optimizer.status()) {
            (Some(why), _) => why.to_owned(),
            (None, Status::Done(t)) => t.to_string(),
            (None, Status::Running) => "stopped".into(),
        };
        CalibrationResult {
            x_opt: job.parameter_names.iter().cloned().zip(x).collect(),
            f_opt: f,
            iterations: self.optimizer.iterations(),
            evaluations: self.optimizer.evaluations(),
            rounds: self.optimizer.rounds(),
            failed_evaluations: self.failed_evaluations,
            termination,
            elapsed_s,
            history: self.history.clone(),
            evaluated: self.evaluated.values().cloned().collect(),
            errors: None,
            identifiability: None,
        }
    }
}
