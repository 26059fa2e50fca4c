//! One batch of candidates between `ask` and `tell`, shared by the optimizers (through
//! [`super::run::RunState`]): ids, scaled and user points, and the results told so far.

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
    #[inline] // called from the generic `Optimizer` impl, which is instantiated in other crates
    pub fn open(&self) -> Vec<Candidate> {
        self.candidates.iter().zip(&self.results).filter(|(_, r)| r.is_none()).map(|(c, _)| c.clone()).collect()
    }

    /// Records a result; returns true when the batch is complete.
    #[inline] // called from the generic `Optimizer` impl, which is instantiated in other crates
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
