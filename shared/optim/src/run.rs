//! The shape every batch optimizer shares, as in argmin: the solver's state is kept apart from
//! the solver and handed to it.
//!
//! - [`RunState`] holds the search space, the current [`Batch`], the best point so far, the next
//!   candidate id and the evaluation, iteration and round counters.
//! - An algorithm (Nelder–Mead's simplex, DE's or GA's population, a point list) implements the
//!   internal trait [`Step`]: whether it is done, and `advance`, which gets the `RunState` whose
//!   batch has just been fully told and either asks the next batch ([`RunState::start_batch`])
//!   or stops ([`RunState::stop_if`]).
//! - [`BatchOptimizer<A>`] pairs the two and implements [`Optimizer`] once: `ask` returns the
//!   batch's open candidates, `tell` records a result and calls `advance` once the batch is
//!   complete, and the getters read the `RunState`. The public optimizers are its instances
//!   (`NelderMead = BatchOptimizer<NelderMeadSteps>` and so on) with their constructors as
//!   inherent impls. Nothing in here does I/O, keeps time or spawns threads. Being generic, the
//!   impl is compiled in whichever crate uses an optimizer, so the `Batch` methods it calls are
//!   `#[inline]` (else the bench loses ~2 % to cross-crate calls).
//! - Serialized, a checkpoint is `{"run": {...}, "algorithm": {...}}` (derived serde, no
//!   flattening: serde cannot buffer the DE and GA generators' `u128` through a flattened
//!   field).
//!
//! The pieces only DE and GA share (the generational [`PopulationPhase`] and
//! [`population_space`]) live here too, and [`local_space`], which Nelder–Mead and least
//! squares share.

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

/// The algorithm part of a batch optimizer: everything [`Optimizer`] needs beyond the
/// [`RunState`], which it is given.
pub(crate) trait Step {
    /// Why the run ended, if it has.
    fn done(&self) -> Option<Termination>;

    /// Consumes `run`'s batch, which has just been completed: asks the next one or stops.
    fn advance(&mut self, run: &mut RunState);
}

/// A batch optimizer: the run's bookkeeping and the algorithm `A` that steps it; see the module
/// docs. [`NelderMead`](super::NelderMead), [`DifferentialEvolution`](super::DifferentialEvolution),
/// [`GeneticAlgorithm`](super::GeneticAlgorithm) and [`PointBatch`](super::PointBatch) are its
/// instances.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct BatchOptimizer<A> {
    pub(super) run: RunState,
    pub(super) algorithm: A,
}

impl<A: Step> Optimizer for BatchOptimizer<A> {
    fn ask(&mut self) -> Vec<Candidate> {
        if self.algorithm.done().is_some() { vec![] } else { self.run.batch.open() }
    }

    fn tell(&mut self, id: CandidateId, outcome: Outcome) -> Result<(), OptimError> {
        if self.algorithm.done().is_some() {
            return Err(OptimError::UnknownCandidate(id));
        }
        if self.run.batch.tell(id, outcome)? {
            self.algorithm.advance(&mut self.run);
        }
        Ok(())
    }

    fn is_open(&self, id: CandidateId) -> bool {
        self.algorithm.done().is_none() && self.run.batch.awaiting(id).is_ok()
    }

    fn status(&self) -> Status {
        match self.algorithm.done() {
            Some(t) => Status::Done(t),
            None => Status::Running,
        }
    }

    fn best(&self) -> Option<(Vec<f64>, f64)> {
        self.run.best.get(&self.run.space)
    }

    fn evaluations(&self) -> u64 {
        self.run.evaluations
    }

    fn iterations(&self) -> u64 {
        self.run.iterations
    }

    fn rounds(&self) -> u64 {
        self.run.rounds
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

/// The space of a local search from `x0` (Nelder–Mead, least squares), after checking the
/// stopping rules and that the first step (`step`: its field and value) is positive.
///
/// # Errors
/// [`OptimError::Setting`] naming the bounds, `x0`, `nominal`, a stopping rule or the step's
/// field.
pub(crate) fn local_space(
    lower: &[f64],
    upper: &[f64],
    x0: &[f64],
    nominal: Option<&[f64]>,
    stopping: &Stopping,
    (field, step): (&'static str, f64),
) -> Result<Space, OptimError> {
    let space = Space::new(lower, upper, Some(x0), nominal)?;
    stopping.validate()?;
    if !(step > 0.0 && step.is_finite()) {
        return Err(OptimError::setting(field, format!("must be positive, got {step}")));
    }
    Ok(space)
}

#[cfg(test)]
mod tests {
    use crate::{AnyOptimizer, DeSettings, DifferentialEvolution, GaSettings, GeneticAlgorithm, Optimizer, Outcome};

    /// `is_open` answers what `tell` would accept: the asked candidates until each is told,
    /// and nothing else.
    #[test]
    fn is_open_is_what_tell_accepts() {
        let de = DifferentialEvolution::new(&[0.0], &[1.0], None, DeSettings::new(1)).unwrap();
        let mut opt = AnyOptimizer::DifferentialEvolution(de);
        let asked = opt.ask();
        let beyond = asked.iter().map(|c| c.id).max().unwrap() + 1;
        assert!(asked.iter().all(|c| opt.is_open(c.id)) && !opt.is_open(beyond));
        opt.tell(asked[0].id, Outcome::Value(1.0)).unwrap();
        assert!(!opt.is_open(asked[0].id) && opt.is_open(asked[1].id));
        assert!(opt.tell(asked[0].id, Outcome::Value(1.0)).is_err());
    }

    /// DE and GA keep their generator state as a `u128`: it must come back exactly, and the
    /// run go on as if never stopped.
    #[test]
    fn generator_states_survive_a_checkpoint() {
        let (lower, upper) = ([0.0, -1.0], [2.0, 1.0]);
        let de = DifferentialEvolution::new(&lower, &upper, None, DeSettings::new(2)).unwrap();
        let ga = GeneticAlgorithm::new(&lower, &upper, None, GaSettings::new(2)).unwrap();
        for mut opt in [AnyOptimizer::DifferentialEvolution(de), AnyOptimizer::Genetic(ga)] {
            let json = serde_json::to_string(&opt).unwrap();
            let mut resumed: AnyOptimizer = serde_json::from_str(&json).unwrap();
            assert_eq!(serde_json::to_string(&resumed).unwrap(), json);
            for _ in 0..3 {
                let asked = opt.ask();
                assert_eq!(resumed.ask(), asked);
                for c in asked {
                    let f = Outcome::Value(c.x.iter().map(|x| x * x).sum());
                    opt.tell(c.id, f).unwrap();
                    resumed.tell(c.id, f).unwrap();
                }
            }
        }
    }
}
