//! One job's run, the same wherever its points are evaluated: the optimizer built from the job
//! ([`super::optimizer::build`]), and the bookkeeping around its ask/tell loop — failed
//! evaluations, the history of completed rounds, the points of an
//! [`EvaluatePoints`](super::JobKind::EvaluatePoints) job with their residuals — and the
//! [`CalibrationResult`] it ends with. It is serializable, so the coordinator stores it after
//! every round and resumes from it.
//!
//! A run hands out [`WorkItem`]s: one simulation each, a candidate point on one fitted
//! experiment ([`WorkItemId`]: candidate `c` on the `k`-th of the K fitted experiments is item
//! `c·K + k` on the wire, so a one-experiment job's items are its candidates). Once all K items of a candidate are told, the
//! optimizer is told the candidate's total ([`Evaluation::combine`]): its residual vector for a
//! least-squares optimizer, else its value. Parameters with `scale = "log"` are optimized as
//! their logarithm; items, results and progress are in user units.
//!
//! [`super::executor::execute`] drives a run to its end on a synchronous backend (threads in
//! this process); the coordinator drives the same type from worker results as they arrive.
//! Neither does any bookkeeping of its own. Like the optimizers, a run reads no clock: the
//! driver passes the wall time of a round.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use super::JobKind;
use super::evaluator::Evaluation;
use super::optimizer;
use super::prepared::PreparedJob;
use super::result::{CalibrationResult, EvaluatedPoint, HistoryPoint};
use super::spec::JobSpec;
use crate::optim::{AnyOptimizer, CandidateId, OptimError, Optimizer, Outcome, Status};

/// Which simulation a work item is: `candidate` on the `part`-th fitted experiment. The one
/// place its number (the `id` of a [`WorkItem`], what workers and the store see) is made and
/// read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct WorkItemId {
    pub candidate: CandidateId,
    /// The fitted experiment's position among the run's `parts` fitted experiments.
    pub part: usize,
}

impl WorkItemId {
    /// The item's number in a run with `parts` fitted experiments: `candidate·parts + part`.
    pub fn encode(self, parts: usize) -> u64 {
        self.candidate * parts.max(1) as u64 + self.part as u64
    }

    /// The item numbered `id` in a run with `parts` fitted experiments.
    pub fn decode(id: u64, parts: usize) -> WorkItemId {
        let k = parts.max(1) as u64;
        WorkItemId { candidate: id / k, part: (id % k) as usize }
    }
}

/// One simulation to run: a candidate point (user units) on one experiment.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct WorkItem {
    /// Unique within the run: a [`WorkItemId`] encoded.
    pub id: u64,
    /// The experiment's index in the job.
    pub experiment: usize,
    pub x: Vec<f64>,
}

/// A job's optimizer and the bookkeeping of its rounds.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct JobRun {
    optimizer: AnyOptimizer,
    history: Vec<HistoryPoint>,
    failed_evaluations: u64,
    /// Kept for jobs that want residuals: each told point, by candidate id.
    evaluated: BTreeMap<CandidateId, EvaluatedPoint>,
    keep_points: bool,
    /// The fitted experiments, in item order.
    #[serde(default = "one_experiment")]
    experiments: Vec<usize>,
    /// Their names, for the error of a failed part.
    #[serde(default)]
    experiment_names: Vec<String>,
    /// The parts told so far of candidates whose items are not all told.
    #[serde(default)]
    partial: BTreeMap<CandidateId, Vec<Option<Evaluation>>>,
    /// Which values the optimizer sees as their logarithm (empty: none).
    #[serde(default)]
    log: Vec<bool>,
    /// The start point (user units) of a calibration; empty for a points job.
    #[serde(default)]
    start: Vec<f64>,
    /// Why the first failed evaluation failed.
    #[serde(default)]
    first_error: Option<String>,
    /// Why the start point failed, if it did.
    #[serde(default)]
    start_error: Option<String>,
    /// Evaluations whose objective was not finite (the squared errors overflowed).
    #[serde(default)]
    overflowed: u64,
    /// How many residuals an evaluation of each experiment gives, by experiment index (empty
    /// for a run stored before they were kept: then not known).
    #[serde(default)]
    residual_counts: Vec<usize>,
}

fn one_experiment() -> Vec<usize> {
    vec![0]
}

impl JobRun {
    /// A run of `job` that has asked nothing yet.
    ///
    /// # Errors
    /// [`OptimError::Setting`] naming the bad optimizer setting.
    pub fn new(job: &PreparedJob) -> Result<Self, OptimError> {
        // A points job's optimizer works in user units (see `optimizer::build`).
        let log = if matches!(job.spec.kind, JobKind::EvaluatePoints(_)) { vec![] } else { job.spec.log_scaled() };
        Ok(JobRun {
            optimizer: optimizer::build(&job.spec)?,
            history: vec![],
            failed_evaluations: 0,
            evaluated: BTreeMap::new(),
            keep_points: job.spec.kind.wants_residuals(),
            experiments: job.fitted.clone(),
            experiment_names: job.fitted.iter().map(|&k| job.experiments[k].name.clone()).collect(),
            partial: BTreeMap::new(),
            log: if log.contains(&true) { log } else { vec![] },
            start: if job.spec.kind.wants_residuals() { vec![] } else { job.spec.parameter_vectors().1 },
            first_error: None,
            start_error: None,
            overflowed: 0,
            residual_counts: job.experiments.iter().map(|e| e.objective.residual_count()).collect(),
        })
    }

    /// How many residuals an evaluation of `experiment` gives (`None`: not known).
    pub fn residual_count(&self, experiment: usize) -> Option<usize> {
        self.residual_counts.get(experiment).copied()
    }

    /// Whether the items' residual vectors are wanted back, not only their values.
    pub fn wants_residuals(&self) -> bool {
        self.keep_points || self.optimizer.wants_residuals()
    }

    /// A point of the optimizer in user units.
    fn to_user(&self, mut x: Vec<f64>) -> Vec<f64> {
        for (v, log) in x.iter_mut().zip(&self.log) {
            if *log {
                *v = v.exp();
            }
        }
        x
    }

    /// The items of the current round still awaiting a result; empty once the run is done.
    pub fn ask(&mut self) -> Vec<WorkItem> {
        let parts = self.experiments.len();
        let mut items = vec![];
        for c in self.optimizer.ask() {
            let told = self.partial.get(&c.id);
            let x = self.to_user(c.x);
            for (j, &experiment) in self.experiments.iter().enumerate() {
                if told.is_none_or(|parts| parts[j].is_none()) {
                    let id = WorkItemId { candidate: c.id, part: j }.encode(parts);
                    items.push(WorkItem { id, experiment, x: x.clone() });
                }
            }
        }
        items
    }

    /// Tells the evaluation of item `id` (at `x`). When it completes its candidate, the
    /// optimizer is told; when that completes the round, the round is added to the history
    /// (with `round_wall_s`, the round's wall time so far) and returned.
    ///
    /// # Errors
    /// [`OptimError::UnknownCandidate`] if item `id` is not awaiting a result; nothing is
    /// recorded.
    pub fn tell(
        &mut self,
        id: u64,
        x: &[f64],
        evaluation: &Evaluation,
        round_wall_s: f64,
    ) -> Result<Option<HistoryPoint>, OptimError> {
        let k = self.experiments.len().max(1);
        let WorkItemId { candidate, part } = WorkItemId::decode(id, k);
        let combined;
        let evaluation = if k == 1 {
            evaluation
        } else {
            if !self.optimizer.is_open(candidate) {
                return Err(OptimError::UnknownCandidate(id));
            }
            let parts = self.partial.entry(candidate).or_insert_with(|| vec![None; k]);
            if parts[part].is_some() {
                return Err(OptimError::UnknownCandidate(id));
            }
            parts[part] = Some(evaluation.clone());
            if parts.iter().any(Option::is_none) {
                return Ok(None);
            }
            let parts = self.partial.remove(&candidate).unwrap_or_default().into_iter().flatten().collect();
            let names: Vec<&str> = self.experiment_names.iter().map(String::as_str).collect();
            combined = Evaluation::combine(parts, &names);
            &combined
        };
        self.tell_candidate(candidate, x, evaluation, round_wall_s)
    }

    /// Tells the optimizer candidate `id`'s evaluation (over every fitted experiment).
    fn tell_candidate(
        &mut self,
        id: CandidateId,
        x: &[f64],
        evaluation: &Evaluation,
        round_wall_s: f64,
    ) -> Result<Option<HistoryPoint>, OptimError> {
        // The optimizer forms its next round once the current one is fully told.
        let rounds_before = self.optimizer.rounds();
        if self.optimizer.wants_residuals() {
            if evaluation.value.is_some() && evaluation.residuals.is_none() {
                tracing::error!(candidate = id, "an evaluation came back without the residuals asked for");
            }
            let residuals = evaluation.value.and(evaluation.residuals.as_deref());
            self.optimizer.tell_residuals(id, residuals)?;
        } else {
            self.optimizer.tell(id, evaluation.value.map_or(Outcome::Failed, Outcome::Value))?;
        }
        if evaluation.value.is_some_and(|f| !f.is_finite()) {
            self.overflowed += 1;
        }
        if evaluation.value.is_none() {
            self.failed_evaluations += 1;
            tracing::debug!(?x, error = ?evaluation.error, "evaluation failed");
            let why = evaluation.error.clone().unwrap_or_else(|| "the simulation failed".into());
            // Only in the first round: later, a failure at the start point (a simplex that came
            // back to it, a lost worker) does not mean the job is wrong, and the round is the
            // same whatever order its results arrive in.
            if self.start_error.is_none() && self.history.is_empty() && is_same_point(x, &self.start) {
                self.start_error = Some(why.clone());
            }
            self.first_error.get_or_insert(why);
        }
        if self.keep_points {
            self.evaluated.insert(id, EvaluatedPoint::new(x, evaluation));
        }
        if self.optimizer.rounds() == rounds_before && !self.is_done() {
            return Ok(None);
        }
        // The round completed is the one out before this tell (the optimizer may have handed
        // out the next one since).
        let round = HistoryPoint {
            round: rounds_before,
            evaluations: self.optimizer.evaluations(),
            best_f: self.best_f(),
            batch_wall_s: round_wall_s,
            best_x: self.best().map(|b| b.0).unwrap_or_default(),
        };
        self.history.push(round.clone());
        Ok(Some(round))
    }

    /// Rounds completed so far (the optimizer's count also holds the round still out).
    pub fn completed_rounds(&self) -> u64 {
        self.history.last().map_or(0, |h| h.round)
    }

    /// Why the run must stop without a result: a calibration whose start point failed (the
    /// job cannot be what the user meant), or whose optimizer stopped before any evaluation
    /// succeeded. A points job reports each point's failure in its result instead.
    pub fn fatal_error(&self) -> Option<String> {
        if let Some(why) = &self.start_error {
            return Some(format!("the start point failed: {why}"));
        }
        if self.start.is_empty() || !self.is_done() || self.optimizer.best().is_some() {
            return None;
        }
        let overflowed = (self.overflowed > 0).then(|| {
            format!(
                "{} evaluated points gave an objective that overflowed (f = inf: the squared errors exceed \
                 the largest number; the measurements or the model's outputs are too large, scale them)",
                self.overflowed
            )
        });
        Some(match (overflowed, self.first_error.as_deref()) {
            (Some(o), None) => format!("no evaluation gave a finite objective: {o}"),
            (Some(o), Some(first)) => {
                format!("no evaluation gave a finite objective: {o}; the others failed, the first with: {first}")
            }
            (None, first) => {
                format!("no evaluation succeeded; the first error: {}", first.unwrap_or("none was evaluated"))
            }
        })
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

    /// The best point so far (user units) and its value.
    pub fn best(&self) -> Option<(Vec<f64>, f64)> {
        self.optimizer.best().map(|(x, f)| (self.to_user(x), f))
    }

    /// The result the run ends with: the optimum (the start point if nothing succeeded),
    /// counters, history and evaluated points, which move into it (a points job's residuals are
    /// its bulk; the run keeps no second copy). `termination` overrides the optimizer's reason
    /// (e.g. "cancelled").
    pub fn take_result(&mut self, job: &JobSpec, elapsed_s: f64, termination: Option<&str>) -> CalibrationResult {
        let (names, start, _, _) = job.parameter_vectors();
        let (x, f) = self.best().unwrap_or((start, f64::INFINITY));
        let termination = match (termination, self.optimizer.status()) {
            (Some(why), _) => why.to_owned(),
            (None, Status::Done(t)) => t.to_string(),
            (None, Status::Running) => "stopped".into(),
        };
        let mut result = CalibrationResult {
            x_opt: names.into_iter().zip(x).collect(),
            f_opt: f,
            iterations: self.optimizer.iterations(),
            evaluations: self.optimizer.evaluations(),
            rounds: self.optimizer.rounds(),
            failed_evaluations: self.failed_evaluations,
            termination,
            elapsed_s,
            history: self.history.clone(),
            evaluated: std::mem::take(&mut self.evaluated).into_values().collect(),
            ..Default::default()
        };
        // The checks the result alone allows (bounds, budget), for every client; the CLI
        // adds those that need simulations.
        if job.kind == super::choices::JobKind::Calibration {
            result.warnings = super::warnings::check(job, &result, 0.0, None);
        }
        result
    }
}

/// Whether `x` is `start` (a log-scaled value comes back through exp(ln v), so to rounding).
fn is_same_point(x: &[f64], start: &[f64]) -> bool {
    !start.is_empty()
        && x.len() == start.len()
        && x.iter().zip(start).all(|(a, b)| a == b || (a - b).abs() <= 1e-12 * a.abs().max(b.abs()))
}

#[cfg(test)]
mod tests {
    use super::WorkItemId;

    #[test]
    fn a_work_item_id_is_candidate_times_parts_plus_part_and_reads_back() {
        for parts in [1usize, 3] {
            for candidate in [0u64, 7, 1 << 40] {
                for part in 0..parts {
                    let id = WorkItemId { candidate, part };
                    assert_eq!(id.encode(parts), candidate * parts as u64 + part as u64);
                    assert_eq!(WorkItemId::decode(id.encode(parts), parts), id);
                }
            }
        }
    }
}
