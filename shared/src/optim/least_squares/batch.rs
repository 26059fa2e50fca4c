//! One batch of the least-squares solver between `ask` and `tell`: like the other optimizers'
//! batch, but it keeps each point's residual vector. A result is stored as residuals only when
//! every residual and their sum of squares are finite; anything else (a failed simulation, NaN,
//! ±∞) is stored as a failure, so the state holds finite numbers only.

use serde::{Deserialize, Serialize};

use crate::optim::space::Space;
use crate::optim::{Candidate, CandidateId, OptimError};

/// A told result.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(super) enum Told {
    Residuals(Vec<f64>),
    Failed,
}

impl Told {
    pub fn from_residuals(r: Option<&[f64]>) -> Self {
        match r {
            Some(r) if r.iter().all(|v| v.is_finite()) && r.iter().map(|v| v * v).sum::<f64>().is_finite() => {
                Told::Residuals(r.to_vec())
            }
            _ => Told::Failed,
        }
    }
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub(super) struct LsBatch {
    /// Scaled points, in the order they were created.
    pub z: Vec<Vec<f64>>,
    pub candidates: Vec<Candidate>,
    pub results: Vec<Option<Told>>,
}

impl LsBatch {
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
        LsBatch { z: points, candidates, results: vec![None; n] }
    }

    /// Candidates still awaiting a result.
    pub fn open(&self) -> Vec<Candidate> {
        self.candidates.iter().zip(&self.results).filter(|(_, r)| r.is_none()).map(|(c, _)| c.clone()).collect()
    }

    /// The position of candidate `id` if it awaits a result.
    pub fn awaiting(&self, id: CandidateId) -> Result<usize, OptimError> {
        self.candidates
            .iter()
            .position(|c| c.id == id)
            .filter(|&i| self.results[i].is_none())
            .ok_or(OptimError::UnknownCandidate(id))
    }

    /// Records a result; returns true when the batch is complete.
    pub fn tell(&mut self, id: CandidateId, told: Told) -> Result<bool, OptimError> {
        let i = self.awaiting(id)?;
        self.results[i] = Some(told);
        Ok(self.results.iter().all(Option::is_some))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn non_finite_residuals_are_stored_as_failures() {
        assert_eq!(Told::from_residuals(Some(&[1.0, f64::NAN])), Told::Failed);
        assert_eq!(Told::from_residuals(Some(&[f64::INFINITY])), Told::Failed);
        assert_eq!(Told::from_residuals(Some(&[1e200, 1e200])), Told::Failed, "Σr² overflows");
        assert_eq!(Told::from_residuals(None), Told::Failed);
        assert_eq!(Told::from_residuals(Some(&[1.0, -2.0])), Told::Residuals(vec![1.0, -2.0]));
    }

    #[test]
    fn each_id_is_told_once() {
        let space = Space::new(&[0.0], &[1.0], None, None).unwrap();
        let mut next_id = 3;
        let mut b = LsBatch::new(vec![vec![0.1], vec![0.2]], &space, &mut next_id);
        assert_eq!(next_id, 5);
        assert_eq!(b.tell(4, Told::Failed), Ok(false));
        assert_eq!(b.tell(4, Told::Failed), Err(OptimError::UnknownCandidate(4)));
        assert_eq!(b.open().len(), 1);
        assert_eq!(b.tell(3, Told::Residuals(vec![1.0])), Ok(true));
    }
}
