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
//! - Serialized, both parts are flattened (`#[serde(flatten)]`) into one object with the same
//!   keys and values as when all these fields sat in one struct per optimizer, so states saved
//!   before still load. `Deserialize` is written out ([`AlgorithmEntries`]): it reads the
//!   algorithm's own fields straight from the input and buffers only the other entries for the
//!   `RunState`, because serde buffers every flattened field in a form without 128-bit integers
//!   and the DE and GA random generators keep a `u128`.
//!
//! The pieces only DE and GA share (the generational [`PopulationPhase`] and
//! [`population_space`]) live here too.

use std::marker::PhantomData;

use serde::de::{DeserializeSeed, Error as _, IntoDeserializer, MapAccess, Visitor};
use serde::{Deserialize, Deserializer, Serialize};

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
#[derive(Debug, Clone, Serialize)]
pub struct BatchOptimizer<A> {
    #[serde(flatten)]
    pub(super) run: RunState,
    #[serde(flatten)]
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

/// Reads the object `Serialize` writes: the algorithm's own fields straight into `A` (so its
/// `u128` generator state survives), every other entry into the `RunState`.
impl<'de, A: Deserialize<'de>> Deserialize<'de> for BatchOptimizer<A> {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        deserializer.deserialize_map(BatchOptimizerVisitor(PhantomData))
    }
}

struct BatchOptimizerVisitor<A>(PhantomData<A>);

impl<'de, A: Deserialize<'de>> Visitor<'de> for BatchOptimizerVisitor<A> {
    type Value = BatchOptimizer<A>;

    fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str("an optimizer state")
    }

    fn visit_map<M: MapAccess<'de>>(self, mut map: M) -> Result<Self::Value, M::Error> {
        let mut rest = serde_json::Map::new();
        let algorithm = A::deserialize(AlgorithmEntries { map: &mut map, rest: &mut rest })?;
        let run = RunState::deserialize(serde_json::Value::Object(rest)).map_err(M::Error::custom)?;
        Ok(BatchOptimizer { run, algorithm })
    }
}

/// The entries of an optimizer's object, as a deserializer for its algorithm struct: the
/// entries named by that struct's fields are passed on, the others are kept in `rest`.
struct AlgorithmEntries<'a, M> {
    map: &'a mut M,
    rest: &'a mut serde_json::Map<String, serde_json::Value>,
}

impl<'de, M: MapAccess<'de>> Deserializer<'de> for AlgorithmEntries<'_, M> {
    type Error = M::Error;

    fn deserialize_struct<V: Visitor<'de>>(
        self,
        _name: &'static str,
        fields: &'static [&'static str],
        visitor: V,
    ) -> Result<V::Value, M::Error> {
        visitor.visit_map(FieldEntries { map: self.map, fields, rest: self.rest })
    }

    fn deserialize_any<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, M::Error> {
        self.deserialize_struct("", &[], visitor)
    }

    serde::forward_to_deserialize_any! {
        bool i8 i16 i32 i64 i128 u8 u16 u32 u64 u128 f32 f64 char str string
        bytes byte_buf option unit unit_struct newtype_struct seq tuple
        tuple_struct map enum identifier ignored_any
    }
}

/// The map access behind [`AlgorithmEntries`].
struct FieldEntries<'a, M> {
    map: &'a mut M,
    fields: &'static [&'static str],
    rest: &'a mut serde_json::Map<String, serde_json::Value>,
}

impl<'de, M: MapAccess<'de>> MapAccess<'de> for FieldEntries<'_, M> {
    type Error = M::Error;

    fn next_key_seed<K: DeserializeSeed<'de>>(&mut self, seed: K) -> Result<Option<K::Value>, M::Error> {
        while let Some(key) = self.map.next_key::<String>()? {
            if self.fields.contains(&key.as_str()) {
                return seed.deserialize(key.into_deserializer()).map(Some);
            }
            let value = self.map.next_value()?;
            self.rest.insert(key, value);
        }
        Ok(None)
    }

    fn next_value_seed<V: DeserializeSeed<'de>>(&mut self, seed: V) -> Result<V::Value, M::Error> {
        self.map.next_value_seed(seed)
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
    use crate::optim::{
        AnyOptimizer, DeSettings, DifferentialEvolution, GaSettings, GeneticAlgorithm, Optimizer, Outcome,
    };

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

    /// DE and GA keep their generator state as a `u128`, which serde cannot buffer for a
    /// flattened field: it must come back exactly, and the run go on as if never stopped.
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
