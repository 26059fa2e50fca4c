//! CMA-ES benchmark, the fmucal side of `bench/cma_es.sh`: the best value fmucal's CMA-ES
//! (IPOP, 9 restarts, population 10 doubling at each restart) finds within a budget of
//! evaluations on 10-D Rosenbrock in [−2, 2]¹⁰ from x0 = 0 and 10-D Rastrigin in [−5, 5]¹⁰ from
//! x0 = (3, …, 3), with σ₀ = 0.3 of the range, for budgets of 2 000, 10 000 and 50 000
//! evaluations and seeds 1 to 11. Local runs end on the internal criteria only (no user x_tol
//! or f_tol), as pycma's do with its defaults. Prints JSON (one object per run) to stdout or
//! `--json FILE`; `bench/cma_es_pycma.py` runs pycma on the same cases.

#[path = "json_rows.rs"]
mod json_rows;

use fmucal_shared::optim::test_problems::{rastrigin, rosenbrock, run};
use fmucal_shared::optim::{CmaEs, CmaSettings, Optimizer, Outcome, Stopping};

pub const N: usize = 10;
pub const BUDGETS: [u64; 3] = [2_000, 10_000, 50_000];
pub const SEEDS: std::ops::RangeInclusive<u64> = 1..=11;

/// A benchmark problem: its objective and, the same in every dimension, its bounds and x0.
pub struct Case {
    pub name: &'static str,
    pub f: fn(&[f64]) -> f64,
    pub lower: f64,
    pub upper: f64,
    pub x0: f64,
}

pub const CASES: [Case; 2] = [
    Case { name: "rosenbrock", f: rosenbrock, lower: -2.0, upper: 2.0, x0: 0.0 },
    Case { name: "rastrigin", f: rastrigin, lower: -5.0, upper: 5.0, x0: 3.0 },
];

fn main() {
    let mut rows = vec![];
    for Case { name, f, lower, upper, x0 } in CASES {
        for budget in BUDGETS {
            for seed in SEEDS {
                let settings = CmaSettings {
                    restarts: 9,
                    seed,
                    stopping: Stopping { x_tol: None, f_tol: None, max_iters: None, max_fevals: Some(budget) },
                    ..CmaSettings::new(N)
                };
                let start = std::time::Instant::now();
                let mut es = CmaEs::new(&[lower; N], &[upper; N], Some(&[x0; N]), settings).expect("settings");
                run(&mut es, &|x| Outcome::Value(f(x)), u64::MAX);
                let best = es.best().map_or(f64::INFINITY, |b| b.1);
                let row = serde_json::json!({
                    "function": name, "budget": budget, "seed": seed, "best": best,
                    "evaluations": es.evaluations(), "generations": es.iterations(),
                    "status": format!("{:?}", es.status()), "seconds": start.elapsed().as_secs_f64(),
                });
                eprintln!("{row}");
                rows.push(row);
            }
        }
    }
    json_rows::write(&rows);
}
