//! One batch of the least-squares solver between `ask` and `tell`: the optimizers' [`Batch`],
//! keeping each point's residual vector. A result is stored as residuals only when
//! every residual and their sum of squares are finite; anything else (a failed simulation, NaN,
//! ±∞) is stored as a failure, so the state holds finite numbers only.

use serde::{Deserialize, Serialize};

use crate::batch::Batch;

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

/// A batch whose results keep the residual vectors.
pub(super) type LsBatch = Batch<Told>;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::OptimError;
    use crate::space::Space;

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
        assert_eq!(b.record(4, Told::Failed), Ok(false));
        assert_eq!(b.record(4, Told::Failed), Err(OptimError::UnknownCandidate(4)));
        assert_eq!(b.open().len(), 1);
        assert_eq!(b.record(3, Told::Residuals(vec![1.0])), Ok(true));
    }
}
