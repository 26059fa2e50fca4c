//! What the optimizers' property tests share: a hostile objective, driving an optimizer for
//! some rounds, telling each batch in a reproducible shuffled order, and the checks every
//! optimizer is held to.
#![allow(dead_code)]

use fmucal_optim::{Candidate, Optimizer, Outcome};
use proptest::prelude::*;

/// Whether the test objectives fail at `x`: about one point in seven, by a hash of its bits.
pub fn fails_at(x: &[f64]) -> bool {
    x.iter().fold(0u64, |h, v| h.rotate_left(7) ^ v.to_bits()) % 7 == 0
}

/// A deterministic, multimodal objective that fails at about one point in seven.
pub fn objective(x: &[f64]) -> Outcome {
    if fails_at(x) {
        return Outcome::Failed;
    }
    Outcome::Value(x.iter().map(|v| (v - 0.3).powi(2) + 0.1 * (13.0 * v).sin()).sum())
}

/// A reproducible shuffle of a batch (`seed` 0: as asked).
pub fn shuffled(mut batch: Vec<Candidate>, seed: u64, round: usize) -> Vec<Candidate> {
    if seed != 0 {
        let mut s = seed ^ (round as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15);
        for i in (1..batch.len()).rev() {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            batch.swap(i, (s % (i as u64 + 1)) as usize);
        }
    }
    batch
}

/// Runs `rounds` batches, telling each candidate with `tell` in the order `order_seed` gives,
/// and returns every batch asked.
pub fn drive(
    opt: &mut dyn Optimizer,
    rounds: usize,
    order_seed: u64,
    mut tell: impl FnMut(&mut dyn Optimizer, &Candidate),
) -> Vec<Vec<Candidate>> {
    let mut asked = vec![];
    for round in 0..rounds {
        let batch = opt.ask();
        if batch.is_empty() {
            break;
        }
        asked.push(batch.clone());
        for c in shuffled(batch, order_seed, round) {
            tell(opt, &c);
        }
    }
    asked
}

/// What the failure tests tell for the choice `choice` at `x`: 0 a failure, 1 NaN, 2 +∞, 3 −∞,
/// anything else the true value.
pub fn hostile_outcome(choice: u8, x: &[f64]) -> Outcome {
    match choice {
        0 => Outcome::Failed,
        1 => Outcome::Value(f64::NAN),
        2 => Outcome::Value(f64::INFINITY),
        3 => Outcome::Value(f64::NEG_INFINITY),
        _ => objective(x),
    }
}

/// Runs up to `rounds` batches, telling each candidate in the order asked through `tell`, which
/// is handed `pattern[k % pattern.len()]` for the k-th candidate of the run (to choose a
/// failure, a NaN, ... or the true value); `after_batch` checks the optimizer after each batch.
pub fn tell_by_pattern<O: Optimizer + ?Sized>(
    opt: &mut O,
    rounds: usize,
    pattern: &[u8],
    mut tell: impl FnMut(&mut O, &Candidate, u8),
    mut after_batch: impl FnMut(&O) -> Result<(), TestCaseError>,
) -> Result<(), TestCaseError> {
    let mut k = 0;
    for _ in 0..rounds {
        let batch = opt.ask();
        if batch.is_empty() {
            break;
        }
        for cand in batch {
            tell(opt, &cand, pattern[k % pattern.len()]);
            k += 1;
        }
        after_batch(opt)?;
    }
    Ok(())
}

/// Fails unless every point asked is finite and inside the bounds.
pub fn within_bounds(asked: &[Vec<Candidate>], lower: &[f64], upper: &[f64]) -> Result<(), TestCaseError> {
    for cand in asked.iter().flatten() {
        for (i, x) in cand.x.iter().enumerate() {
            prop_assert!(x.is_finite() && *x >= lower[i] && *x <= upper[i], "{:?} outside at {}", cand.x, i);
        }
    }
    Ok(())
}

/// Fails unless the best point so far, if any, and its value are finite.
pub fn best_is_finite(opt: &dyn Optimizer) -> Result<(), TestCaseError> {
    if let Some((x, f)) = opt.best() {
        prop_assert!(f.is_finite());
        prop_assert!(x.iter().all(|v| v.is_finite()));
    }
    Ok(())
}
