//! Bookkeeping of one batch of candidates between `ask` and `tell`, shared by the optimizers:
//! ids, scaled and user points, and the results told so far.

use serde::{Deserialize, Serialize};

use super::space::Space;
use super::{Candidate, CandidateId, Fitness, OptimError, Outcome};

#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub(crate) struct Batch {
    /// Scaled points, in the order they were created.
    pub z: Vec<Vec<f64>>,
    pub candidates: Vec<Candidate>,
    pub results: Vec<Option<Fitness>>,
}

impl Batch {
    /// A batch of scaled points; ids continue from `next_id`.
    pub fn new(points: Vec<Vec<f64>>, space: &Space, next_id: &mut CandidateId) -> Self {
        let candidates = points
            .iter()
            .map(|z| {
                let id = *next_id;
                *next_id += 1;
                Candidate { id, x: space.to_user(z) }
            })
            .collect();
        let n = points.len();
        Batch { z: points, candidates, results: vec![None; n] }
    }

    /// Candidates still awaiting a result.
    pub fn open(&self) -> Vec<Candidate> {
        self.candidates.iter().zip(&self.results).filter(|(_, r)| r.is_none()).map(|(c, _)| c.clone()).collect()
    }

    /// Records a result; returns true when the batch is complete.
    pub fn tell(&mut self, id: CandidateId, outcome: Outcome) -> Result<bool, OptimError> {
        let i = self
            .candidates
            .iter()
            .position(|c| c.id == id)
            .filter(|&i| self.results[i].is_none())
            .ok_or(OptimError::UnknownCandidate(id))?;
        self.results[i] = Some(outcome.into());
        Ok(self.results.iter().all(Option::is_some))
    }

    /// The results, in creation order (only valid once complete).
    pub fn values(&self) -> Vec<Fitness> {
        self.results.iter().map(|r| r.unwrap_or(Fitness::Failed)).collect()
    }
}

/// Tracks the best point seen, in scaled variables.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub(crate) struct BestSoFar(Option<(Vec<f64>, f64)>);

impl BestSoFar {
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

/// Counts a completed batch and offers its points as the best so far; returns its values in
/// creation order.
pub(crate) fn absorb(batch: &Batch, evaluations: &mut u64, best: &mut BestSoFar) -> Vec<Fitness> {
    let values = batch.values();
    *evaluations += values.len() as u64;
    for (z, f) in batch.z.iter().zip(&values) {
        best.offer(z, *f);
    }
    values
}

/// Implements [`super::Optimizer`] for a batch optimizer with fields `space`, `batch`, `best`,
/// `evaluations`, `iterations` and `rounds`, a `fn done(&self) -> Option<Termination>` and a
/// `fn advance(&mut self)` called when the batch is complete.
macro_rules! impl_batch_optimizer {
    ($t:ty) => {
        impl $crate::optim::Optimizer for $t {
            fn ask(&mut self) -> Vec<$crate::optim::Candidate> {
                if self.done().is_some() { vec![] } else { self.batch.open() }
            }

            fn tell(
                &mut self,
                id: $crate::optim::CandidateId,
                outcome: $crate::optim::Outcome,
            ) -> Result<(), $crate::optim::OptimError> {
                if self.done().is_some() {
                    return Err($crate::optim::OptimError::UnknownCandidate(id));
                }
                if self.batch.tell(id, outcome)? {
                    self.advance();
                }
                Ok(())
            }

            fn status(&self) -> $crate::optim::Status {
                match self.done() {
                    Some(t) => $crate::optim::Status::Done(t),
                    None => $crate::optim::Status::Running,
                }
            }

            fn best(&self) -> Option<(Vec<f64>, f64)> {
                self.best.get(&self.space)
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
        }
    };
}
pub(crate) use impl_batch_optimizer;
