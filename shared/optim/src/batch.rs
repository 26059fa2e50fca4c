//! One batch of candidates between `ask` and `tell`, shared by the optimizers (through
//! [`super::run::RunState`], and by least squares with its residual vectors as results): ids,
//! scaled and user points, and the results told so far.

use serde::{Deserialize, Serialize};

use super::space::Space;
use super::{Candidate, CandidateId, Fitness, OptimError, Outcome};

/// A batch whose results are `R`: an objective value ([`Fitness`]) by default.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(crate) struct Batch<R = Fitness> {
    /// Scaled points, in the order they were created.
    pub z: Vec<Vec<f64>>,
    pub candidates: Vec<Candidate>,
    pub results: Vec<Option<R>>,
}

impl<R> Default for Batch<R> {
    fn default() -> Self {
        Batch { z: vec![], candidates: vec![], results: vec![] }
    }
}

impl<R: Clone> Batch<R> {
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

    /// The position of candidate `id` if it awaits a result.
    #[inline] // called from the generic `Optimizer` impl, which is instantiated in other crates
    pub fn awaiting(&self, id: CandidateId) -> Result<usize, OptimError> {
        // `Batch::new` numbers a batch consecutively, so `id` is normally at its offset from the
        // first id; any other layout (a hand-edited state) is searched.
        let first = self.candidates.first().map_or(0, |c| c.id);
        usize::try_from(id.wrapping_sub(first))
            .ok()
            .filter(|&i| self.candidates.get(i).is_some_and(|c| c.id == id))
            .or_else(|| self.candidates.iter().position(|c| c.id == id))
            .filter(|&i| self.results[i].is_none())
            .ok_or(OptimError::UnknownCandidate(id))
    }

    /// Records candidate `id`'s result; returns true when the batch is complete.
    #[inline] // called from the generic `Optimizer` impl, which is instantiated in other crates
    pub fn record(&mut self, id: CandidateId, result: R) -> Result<bool, OptimError> {
        let i = self.awaiting(id)?;
        self.results[i] = Some(result);
        Ok(self.results.iter().all(Option::is_some))
    }
}

impl Batch {
    /// Records an objective value; returns true when the batch is complete.
    #[inline] // called from the generic `Optimizer` impl, which is instantiated in other crates
    pub fn tell(&mut self, id: CandidateId, outcome: Outcome) -> Result<bool, OptimError> {
        self.record(id, outcome.into())
    }

    /// The results, in creation order (only valid once complete).
    pub fn values(&self) -> Vec<Fitness> {
        self.results.iter().map(|r| r.unwrap_or(Fitness::Failed)).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tell_finds_each_id_once_whether_or_not_ids_are_consecutive() {
        let space = Space::new(&[0.0], &[1.0], None, None).unwrap();
        let mut next_id = 5;
        let consecutive = Batch::new(vec![vec![0.1], vec![0.2], vec![0.3]], &space, &mut next_id);
        let mut renumbered = consecutive.clone();
        for (c, id) in renumbered.candidates.iter_mut().zip([9, 2, 7]) {
            c.id = id;
        }
        for (mut batch, ids) in [(consecutive, [6, 5, 7]), (renumbered, [7, 9, 2])] {
            for (k, id) in ids.into_iter().enumerate() {
                assert!(batch.tell(4, Outcome::Failed).is_err());
                assert_eq!(batch.tell(id, Outcome::Value(1.0)), Ok(k == 2));
                assert_eq!(batch.tell(id, Outcome::Value(1.0)), Err(OptimError::UnknownCandidate(id)));
            }
        }
    }
}
