//! What the optimizers' property tests share: driving an optimizer for some rounds, telling
//! each batch in a reproducible shuffled order.

use fmucal_optim::{Candidate, Optimizer};

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
