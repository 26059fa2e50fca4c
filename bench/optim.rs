//! Optimizer benchmark, the fmucal side of `bench/optim.sh`: on the
//! Moré–Garbow–Hillstrom problems, the evaluations sequential Nelder–Mead needs and the rounds
//! (batches) parallel Nelder–Mead needs to reach f ≤ f* + 1e-6·(1 + |f*|) from the standard
//! start, unbounded; and differential evolution's best value after a fixed budget in each
//! problem's box (population 15·n, rand/1/bin, F 0.8, CR 0.9, median of 5 seeds).
//! Prints JSON (one object per problem) to stdout or `--json FILE`.

#[path = "json_rows.rs"]
mod json_rows;

use std::cell::Cell;

use fmucal_shared::optim::test_problems::{MGH, Problem};
use fmucal_shared::optim::{DeSettings, DifferentialEvolution, NelderMead, NmSettings, Optimizer, Outcome, Stopping};

const MAX_FEVALS: u64 = 20_000;
pub const DE_GENERATIONS: u64 = 100;

fn threshold(p: &Problem) -> f64 {
    p.f_star + 1e-6 * (1.0 + p.f_star.abs())
}

/// Runs NM; returns (evaluations to threshold, rounds to threshold, final best).
fn nelder_mead(p: &Problem, parallel: bool) -> (Option<u64>, Option<u64>, f64) {
    let n = p.x0.len();
    let inf = vec![f64::INFINITY; n];
    let neg = vec![f64::NEG_INFINITY; n];
    let settings = NmSettings {
        parallel,
        stopping: Stopping { x_tol: Some(1e-12), f_tol: Some(1e-14), max_iters: None, max_fevals: Some(MAX_FEVALS) },
        ..NmSettings::new(n)
    };
    let mut nm = NelderMead::new(&neg, &inf, p.x0, settings).expect("settings");
    let (target, evals, best) = (threshold(p), Cell::new(0u64), Cell::new(f64::INFINITY));
    let (mut evals_hit, mut rounds_hit, mut rounds) = (None, None, 0u64);
    loop {
        let batch = nm.ask();
        if batch.is_empty() {
            break;
        }
        rounds += 1;
        for c in batch {
            let f = (p.f)(&c.x);
            evals.set(evals.get() + 1);
            if f < best.get() {
                best.set(f);
            }
            if evals_hit.is_none() && best.get() <= target {
                evals_hit = Some(evals.get());
            }
            nm.tell(c.id, Outcome::Value(f)).expect("tell");
        }
        if rounds_hit.is_none() && best.get() <= target {
            rounds_hit = Some(rounds);
        }
    }
    (evals_hit, rounds_hit, best.get())
}

fn differential_evolution(p: &Problem, seed: u64) -> (f64, u64) {
    let n = p.x0.len();
    let settings = DeSettings {
        population: 15 * n,
        weight: 0.8,
        crossover: 0.9,
        seed,
        stopping: Stopping { x_tol: None, f_tol: None, max_iters: Some(DE_GENERATIONS), max_fevals: None },
    };
    let mut de = DifferentialEvolution::new(p.lower, p.upper, None, settings).expect("settings");
    fmucal_shared::optim::test_problems::run(&mut de, &|x| Outcome::Value((p.f)(x)), u64::MAX);
    (de.best().map(|b| b.1).unwrap_or(f64::INFINITY), de.evaluations())
}

fn main() {
    let mut rows = vec![];
    for p in MGH {
        let (seq_evals, _, seq_best) = nelder_mead(p, false);
        let (par_evals, par_rounds, par_best) = nelder_mead(p, true);
        let mut de: Vec<(f64, u64)> = (0..5).map(|s| differential_evolution(p, s)).collect();
        de.sort_by(|a, b| a.0.total_cmp(&b.0));
        let row = serde_json::json!({
            "problem": p.name, "n": p.x0.len(), "f_star": p.f_star,
            "nm_seq_evals": seq_evals, "nm_seq_best": seq_best,
            "nm_par_evals": par_evals, "nm_par_rounds": par_rounds, "nm_par_best": par_best,
            "de_median_best": de[2].0, "de_evals": de[2].1,
        });
        eprintln!("{row}");
        rows.push(row);
    }
    json_rows::write(&rows);
}
