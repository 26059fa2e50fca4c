//! A trivial ask/tell "optimizer" that asks a given list of points as one batch and stops: the
//! way to have the workers evaluate points chosen outside an optimizer, such as the
//! finite-difference points of an identifiability analysis.

use serde::{Deserialize, Serialize};

use super::run::{BatchOptimizer, RunState, Step};
use super::space::Space;
use super::{OptimError, Termination};

/// One batch of given points, then done; see the module docs.
pub type PointBatch = BatchOptimizer<PointBatchSteps>;

/// The algorithm part of [`PointBatch`]: whether the batch has been told.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct PointBatchSteps {
    done: bool,
}

impl PointBatch {
    /// The points (user units) to evaluate, each within `[lower, upper]`.
    ///
    /// # Errors
    /// [`OptimError::Setting`] naming `points` if the list is empty or a point is outside the
    /// bounds or of the wrong length.
    pub fn new(lower: &[f64], upper: &[f64], points: &[Vec<f64>]) -> Result<Self, OptimError> {
        if points.is_empty() {
            return Err(OptimError::setting("points", "at least one point is needed"));
        }
        let space = Space::new(lower, upper, None, None)?;
        for (k, p) in points.iter().enumerate() {
            if p.len() != lower.len() {
                return Err(OptimError::setting(
                    "points",
                    format!("point {k} has {} values for {} parameters", p.len(), lower.len()),
                ));
            }
            if p.iter().zip(lower.iter().zip(upper)).any(|(x, (l, u))| !(x >= l && x <= u)) {
                return Err(OptimError::setting("points", format!("point {k} is outside the bounds")));
            }
        }
        let scaled = points.iter().map(|p| space.to_scaled(p)).collect();
        let mut run = RunState::new(space);
        run.start_batch(scaled);
        // Ask exactly the given points, not their round trip through the scaled space.
        for (c, p) in run.batch.candidates.iter_mut().zip(points) {
            c.x.clone_from(p);
        }
        Ok(BatchOptimizer { run, algorithm: PointBatchSteps { done: false } })
    }
}

impl Step for PointBatchSteps {
    fn done(&self) -> Option<Termination> {
        self.done.then_some(Termination::MaxIters)
    }

    fn advance(&mut self, run: &mut RunState) {
        run.absorb();
        run.iterations = 1;
        self.done = true;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Optimizer, Outcome, Status};

    #[test]
    fn asks_the_points_once_then_stops() {
        let pts = vec![vec![0.5, 1.0], vec![0.25, 2.0]];
        let mut pb = PointBatch::new(&[0.0, 0.0], &[1.0, 2.0], &pts).unwrap();
        let asked = pb.ask();
        assert_eq!(asked.iter().map(|c| c.x.clone()).collect::<Vec<_>>(), pts);
        for c in asked {
            pb.tell(c.id, Outcome::Value(c.x[0])).unwrap();
        }
        assert_eq!(pb.status(), Status::Done(Termination::MaxIters));
        assert!(pb.ask().is_empty());
        assert_eq!(pb.best().unwrap().1, 0.25);
        assert!(PointBatch::new(&[0.0], &[1.0], &[vec![2.0]]).is_err());
    }
}
