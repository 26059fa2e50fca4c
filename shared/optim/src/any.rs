//! One serializable type for whichever optimizer a job uses, so the coordinator can store and
//! resume any of them the same way.

use serde::{Deserialize, Serialize};

use super::{
    Candidate, CandidateId, DifferentialEvolution, GeneticAlgorithm, LeastSquares, NelderMead, OptimError, Optimizer,
    Outcome, PointBatch, Status,
};

#[derive(Debug, Clone, Serialize, Deserialize)]
pub enum AnyOptimizer {
    NelderMead(NelderMead),
    DifferentialEvolution(DifferentialEvolution),
    Genetic(GeneticAlgorithm),
    LeastSquares(LeastSquares),
    Points(PointBatch),
    CmaEs(super::CmaEs),
}

/// `$body` with `$o` bound to the optimizer `$any` holds, whichever it is.
macro_rules! each {
    ($any:expr, $o:ident => $body:expr) => {
        match $any {
            AnyOptimizer::NelderMead($o) => $body,
            AnyOptimizer::DifferentialEvolution($o) => $body,
            AnyOptimizer::Genetic($o) => $body,
            AnyOptimizer::LeastSquares($o) => $body,
            AnyOptimizer::Points($o) => $body,
            AnyOptimizer::CmaEs($o) => $body,
        }
    };
}

impl AnyOptimizer {
    fn inner(&self) -> &dyn Optimizer {
        each!(self, o => o)
    }

    fn inner_mut(&mut self) -> &mut dyn Optimizer {
        each!(self, o => o)
    }
}

impl Optimizer for AnyOptimizer {
    fn ask(&mut self) -> Vec<Candidate> {
        self.inner_mut().ask()
    }
    fn tell(&mut self, id: CandidateId, outcome: Outcome) -> Result<(), OptimError> {
        self.inner_mut().tell(id, outcome)
    }
    fn is_open(&self, id: CandidateId) -> bool {
        self.inner().is_open(id)
    }
    fn status(&self) -> Status {
        self.inner().status()
    }
    fn best(&self) -> Option<(Vec<f64>, f64)> {
        self.inner().best()
    }
    fn evaluations(&self) -> u64 {
        self.inner().evaluations()
    }
    fn iterations(&self) -> u64 {
        self.inner().iterations()
    }
    fn rounds(&self) -> u64 {
        self.inner().rounds()
    }
    fn wants_residuals(&self) -> bool {
        self.inner().wants_residuals()
    }
    fn tell_residuals(&mut self, id: CandidateId, residuals: Option<&[f64]>) -> Result<(), OptimError> {
        self.inner_mut().tell_residuals(id, residuals)
    }
}
