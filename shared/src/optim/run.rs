//! What every batch optimizer keeps besides its own algorithm, and the one
//! [`Optimizer`] implementation they all share.
//!
//! - [`RunState`] holds the search space, the current [`Batch`], the best point so far, the next
//!   candidate id and the evaluation, iteration and round counters. Each optimizer embeds it as
//!   its field `run`, marked `#[serde(flatten)]`, so a checkpoint keeps the same JSON keys as
//!   when these fields sat in every optimizer (states saved before still load).
//! - An optimizer implements the internal trait [`BatchStep`]: where its `RunState` is, whether
//!   it is done, and `advance`, which consumes the batch that has just been fully told and
//!   either asks the next one ([`RunState::start_batch`]) or stops ([`RunState::stop_if`]).
//! - The blanket `impl<T: BatchStep> Optimizer for T` does the rest: `ask` returns the batch's
//!   open candidates, `tell` records a result and calls `advance` once the batch is complete,
//!   and the getters read the `RunState`. Nothing in here does I/O, keeps time or spawns threads.
//!   Being generic, this impl is compiled in whichever crate uses an optimizer, so the `Batch`
//!   methods it calls are `#[inline]` (else the bench loses ~2 % to cross-crate calls).
//!
//! The pieces only DE and GA share (the generational [`PopulationPhase`] and
//! [`population_space`]) live here too.

use serde::{Deserialize, Serialize};

use super::batch::Batch;
use super::fitness::Fitness;
use super::space::Space;
use super::{Candidate, CandidateId, OptimError, Optimizer, Outcome, Status, Stopping, Termination};

/// The bookkeeping shared by all batch optimizers; see the module docs.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub(crate) struct RunState {
    pub space: Space,
    /// The candidates handed out and the results told so far (empty once stopped).
    pub batch: Batch,
    pub best: BestSoFar,
    pub next_id: CandidateId,
    /// Objective evaluations told.
    pub evaluations: u64,
    /// Iterations (NM) or generations (DE, GA) completed; each optimizer counts its own.
    pub iterations: u64,
    /// Batches handed out.
    pub rounds: u64,
}

impl RunState {
    /// A run in `space` that has not asked anything yet.
    pub fn new(space: Space) -> Self {
        RunState {
            space,
            batch: Batch::default(),
            best: BestSoFar::default(),
            next_id: 0,
            evaluations: 0,
            iterations: 0,
            rounds: 0,
        }
    }

    /// Hands out the scaled `points` as the next batch.
    pub fn start_batch(&mut self, points: Vec<Vec<f64>>) {
        self.batch = Batch::new(points, &self.space, &mut self.next_id);
        self.rounds += 1;
    }

    /// Counts the batch that has just been completed and offers its points as the best so far;
    /// returns its values in creation order.
    pub fn absorb(&mut self) -> Vec<Fitness> {
        let values = self.batch.values();
        self.evaluations += values.len() as u64;
        for (z, f) in self.batch.z.iter().zip(&values) {
            self.best.offer(z, *f);
        }
        values
    }

    /// Applies the `stopping` rules to a simplex or population (its best point, its scaled
    /// points and their values) with this run's counters. When a rule holds, nothing more is
    /// asked (the batch is emptied) and the rule is returned for the optimizer to record.
    pub fn stop_if<'a>(
        &mut self,
        stopping: &Stopping,
        best: &[f64],
        points: impl IntoIterator<Item = &'a [f64]>,
        values: impl IntoIterator<Item = Fitness>,
    ) -> Option<Termination> {
        let stop = stopping.check_set(best, points, values, self.iterations, self.evaluations);
        if stop.is_some() {
            self.batch = Batch::default();
        }
        stop
    }
}

/// Tracks the best point seen, in scaled variables.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub(crate) struct BestSoFar(Option<(Vec<f64>, f64)>);

impl BestSoFar {
    /// Keeps `z` if its value is finite and strictly below the best so far.
    pub fn offer(&mut self, z: &[f64], f: Fitness) {
        if let Some(v) = f.finite()
            && self.0.as_ref().is_none_or(|(_, b)| v < *b)
        {
            self.0 = Some((z.to_vec(), v));
        }
    }

    pub fn get(&self, space: &Space) -> Option<(Vec<f64>, f64)> {
        self.0.as_ref().map(|(z, f)| (space.to_user(z), *f))
    }
}

/// One step of a batch optimizer: everything [`Optimizer`] needs beyond the [`RunState`].
pub(crate) trait BatchStep {
    fn state(&self) -> &RunState;

    fn state_mut(&mut self) -> &mut RunState;

    /// Why the run ended, if it has.
    fn done(&self) -> Option<Termination>;

    /// Consumes the batch that has just been completed: asks the next one or stops.
    fn advance(&mut self);
}

impl<T: BatchStep> Optimizer for T {
    fn ask(&mut self) -> Vec<Candidate> {
        if self.done().is_some() { vec![] } else { self.state().batch.open() }
    }

    fn tell(&mut self, id: CandidateId, outcome: Outcome) -> Result<(), OptimError> {
        if self.done().is_some() {
            return Err(OptimError::UnknownCandidate(id));
        }
        if self.state_mut().batch.tell(id, outcome)? {
            self.advance();
        }
        Ok(())
    }

    fn status(&self) -> Status {
        match self.done() {
            Some(t) => Status::Done(t),
            None => Status::Running,
        }
    }

    fn best(&self) -> Option<(Vec<f64>, f64)> {
        let run = self.state();
        run.best.get(&run.space)
    }

    fn evaluations(&self) -> u64 {
        self.state().evaluations
    }

    fn iterations(&self) -> u64 {
        self.state().iterations
    }

    fn rounds(&self) -> u64 {
        self.state().rounds
    }
}

/// Where a generational optimizer (DE, GA) stands: what its batch holds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(crate) enum PopulationPhase {
    /// The initial population.
    Initial,
    /// The children or trials of the next generation.
    Generation,
    Done(Termination),
}

impl PopulationPhase {
    pub fn done(&self) -> Option<Termination> {
        match self {
            PopulationPhase::Done(t) => Some(*t),
            _ => None,
        }
    }
}

/// The space of a population-based optimizer (`who`, for the message): bounds must be finite
/// and the population at least 4.
///
/// # Errors
/// [`OptimError::Setting`] naming the bounds, `x0` or `population`.
pub(crate) fn population_space(
    lower: &[f64],
    upper: &[f64],
    x0: Option<&[f64]>,
    population: usize,
    who: &str,
) -> Result<Space, OptimError> {
    let space = Space::new(lower, upper, x0, None)?;
    if !space.is_bounded() {
        return Err(OptimError::setting("lower", format!("{who} needs finite lower and upper bounds")));
    }
    if population < 4 {
        return Err(OptimError::setting("population", format!("must be at least 4, got {population}")));
    }
    Ok(space)
}

#[cfg(test)]
mod tests {
    use crate::optim::{AnyOptimizer, Optimizer};

    /// A sequential Nelder–Mead checkpoint written before `RunState` existed, when every
    /// optimizer had its own `space`, `batch`, `best`, `next_id` and counters.
    const OLD_CHECKPOINT: &str = r#"{"NelderMead":{"space":{"lower":["-inf","-inf"],"upper":["inf","inf"],"offset":[0.0,0.0],"scale":[1.2,1.0]},"settings":{"parallel":false,"initial_step":0.05,"stopping":{"x_tol":1e-6,"f_tol":1e-8,"max_iters":2000,"max_fevals":null},"nominal":null},"simplex":[{"z":[-0.8999999999999999,1.125],"f":{"Value":4.4977959999999975}},{"z":[-0.8999999999999999,1.0749999999999997],"f":{"Value":5.161795999999999}},{"z":[-1.0,1.05],"f":{"Value":20.049999999999994}}],"phase":"Reflect","batch":{"z":[[-0.7999999999999998,1.1499999999999997]],"candidates":[{"id":7,"x":[-0.9599999999999997,1.1499999999999997]}],"results":[null]},"projected":false,"next_id":8,"evaluations":7,"iterations":2,"rounds":6,"best":[[-0.8999999999999999,1.125],4.4977959999999975]}}"#;

    #[test]
    fn checkpoints_keep_their_json_keys_and_older_ones_resume() {
        let mut opt: AnyOptimizer = serde_json::from_str(OLD_CHECKPOINT).unwrap();
        let old: serde_json::Value = serde_json::from_str(OLD_CHECKPOINT).unwrap();
        assert_eq!(serde_json::to_value(&opt).unwrap(), old);
        assert_eq!((opt.evaluations(), opt.iterations(), opt.rounds()), (7, 2, 6));
        assert_eq!(opt.best(), Some((vec![-1.0799999999999998, 1.125], 4.4977959999999975)));
        let asked = opt.ask();
        assert_eq!(asked.len(), 1);
        assert_eq!((asked[0].id, asked[0].x.as_slice()), (7, [-0.9599999999999997, 1.1499999999999997].as_slice()));
        opt.tell(7, crate::optim::Outcome::Value(1.0)).unwrap();
        assert_eq!(opt.ask()[0].id, 8);
    }
}
