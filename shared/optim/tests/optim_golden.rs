//! The optimizers' results, bit for bit, against a dump taken before the crates were split
//! along the layers: Nelder–Mead (sequential and parallel), differential evolution, CMA-ES and
//! least squares on the Moré–Garbow–Hillstrom problems. A refactoring that changes behaviour
//! changes a bit here. After an intended change, write the dump again with
//! `FMUCAL_BLESS=1 cargo test --release -p fmucal-shared --test optim_golden` and say why in the
//! commit.

use std::fmt::Write;

use fmucal_optim::least_squares_problems::MGH_LS;
use fmucal_optim::test_problems::{MGH, run};
use fmucal_optim::{
    CmaEs, CmaSettings, DeSettings, DifferentialEvolution, LeastSquares, LsSettings, NelderMead, NmSettings, Optimizer,
    Outcome, Stopping,
};

const DUMP: &str = "tests/data/optim_golden.txt";

/// One line: the run, its evaluations, and the best point and value as bit patterns.
fn line(out: &mut String, what: &str, problem: &str, opt: &dyn Optimizer) {
    let (x, f) = opt.best().unwrap_or((vec![], f64::NAN));
    let bits: Vec<String> = x.iter().map(|v| format!("{:016x}", v.to_bits())).collect();
    writeln!(out, "{what} {problem} evals={} f={:016x} x={}", opt.evaluations(), f.to_bits(), bits.join(",")).unwrap();
}

fn dump() -> String {
    let mut out = String::new();
    for p in MGH {
        let n = p.x0.len();
        let f = |x: &[f64]| Outcome::Value((p.f)(x));
        for parallel in [false, true] {
            let (neg, inf) = (vec![f64::NEG_INFINITY; n], vec![f64::INFINITY; n]);
            let settings = NmSettings {
                parallel,
                stopping: Stopping { x_tol: Some(1e-10), f_tol: Some(1e-14), max_iters: None, max_fevals: Some(4000) },
                ..NmSettings::new(n)
            };
            let mut nm = NelderMead::new(&neg, &inf, p.x0, settings).unwrap();
            run(&mut nm, &f, u64::MAX);
            line(&mut out, if parallel { "nelder-mead-parallel" } else { "nelder-mead" }, p.name, &nm);
        }
        let de_settings = DeSettings {
            population: 10 * n,
            weight: 0.8,
            crossover: 0.9,
            seed: 7,
            stopping: Stopping { x_tol: None, f_tol: None, max_iters: Some(60), max_fevals: None },
        };
        let mut de = DifferentialEvolution::new(p.lower, p.upper, None, de_settings).unwrap();
        run(&mut de, &f, u64::MAX);
        line(&mut out, "differential-evolution", p.name, &de);
        let cma_settings = CmaSettings {
            seed: 7,
            restarts: 1,
            stopping: Stopping { max_fevals: Some(3000), ..Stopping::default_for(n) },
            ..CmaSettings::new(n)
        };
        let mut cma = CmaEs::new(p.lower, p.upper, Some(p.x0), cma_settings).unwrap();
        run(&mut cma, &f, u64::MAX);
        line(&mut out, "cma-es", p.name, &cma);
    }
    for p in MGH_LS {
        let n = p.x0.len();
        let (lower, upper) = match p.bounds {
            Some((l, u)) => (l.to_vec(), u.to_vec()),
            None => (vec![f64::NEG_INFINITY; n], vec![f64::INFINITY; n]),
        };
        let mut ls = LeastSquares::new(&lower, &upper, p.x0, LsSettings::new(n)).unwrap();
        loop {
            let batch = ls.ask();
            if batch.is_empty() {
                break;
            }
            for c in batch {
                let r = (p.residuals)(&c.x);
                ls.tell_residuals(c.id, Some(&r)).unwrap();
            }
        }
        line(&mut out, "least-squares", p.name, &ls);
    }
    out
}

#[test]
fn optimizer_results_are_bit_identical_to_the_recorded_dump() {
    let now = dump();
    if std::env::var_os("FMUCAL_BLESS").is_some() {
        std::fs::write(DUMP, &now).unwrap();
        return;
    }
    let recorded = std::fs::read_to_string(DUMP).expect("the recorded dump (FMUCAL_BLESS=1 writes it)");
    for (k, (a, b)) in recorded.lines().zip(now.lines()).enumerate() {
        assert_eq!(a, b, "line {} of {DUMP} changed", k + 1);
    }
    assert_eq!(recorded.lines().count(), now.lines().count(), "the number of runs changed");
}
