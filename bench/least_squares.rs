//! Least-squares benchmark, the fmucal side of `bench/least_squares.sh`: on the
//! Moré–Garbow–Hillstrom least-squares problems (`least_squares_problems::MGH_LS`, unbounded,
//! standard starts) and the two-parameter calibrations (`CALIBRATION`, in their boxes), the
//! evaluations and rounds (batches) each solver needs to reach
//!
//!   f ≤ f* + τ (f(x0) − f*),  τ = 1e-5,
//!
//! the convergence test of Moré & Wild (2009, "Benchmarking derivative-free optimization
//! algorithms") used in the DFO-LS papers, with f* the known minimum.
//!
//! Solvers: fmucal's least-squares solver (default settings, but x_tol 1e-8 as DFO-LS's
//! rhoend, no f_tol, at most 5000 evaluations) and, for reference, Nelder–Mead on Σ r² with the
//! settings of `bench/optim.rs` (parallel: 4 points per round, and sequential; x_tol 1e-12,
//! f_tol 1e-14, at most 20 000 evaluations).
//!
//! For the calibrations it also runs both solvers as a calibration job would, with their
//! default settings (`LsSettings::new`, `NmSettings::new`: parallel, x_tol 1e-6, f_tol 1e-8)
//! until they stop, and records the simulations, rounds and final f.
//!
//! Prints JSON (one object per problem) to stdout or `--json FILE`; `--tau T` changes τ.

#[path = "json_rows.rs"]
mod json_rows;

use fmucal_shared::optim::least_squares_problems::{CALIBRATION, LsProblem, MGH_LS};
use fmucal_shared::optim::{LeastSquares, LsSettings, NelderMead, NmSettings, Optimizer, Outcome, Stopping};

const LS_MAX_FEVALS: u64 = 5000;
const NM_MAX_FEVALS: u64 = 20_000;

/// Evaluations and rounds to the threshold, totals, and the final best value.
#[derive(Debug, Default)]
struct Trace {
    evals_hit: Option<u64>,
    rounds_hit: Option<u64>,
    evals: u64,
    rounds: u64,
    best: f64,
}

/// Drives `opt` to the end, telling residuals or Σ r² as it wants.
fn drive(opt: &mut dyn Optimizer, p: &LsProblem, target: f64) -> Trace {
    let mut t = Trace { best: f64::INFINITY, ..Trace::default() };
    loop {
        let batch = opt.ask();
        if batch.is_empty() {
            break;
        }
        t.rounds += 1;
        for c in batch {
            let r = (p.residuals)(&c.x);
            let f: f64 = r.iter().map(|v| v * v).sum();
            t.evals += 1;
            if f < t.best {
                t.best = f;
            }
            if t.evals_hit.is_none() && t.best <= target {
                t.evals_hit = Some(t.evals);
            }
            if opt.wants_residuals() {
                opt.tell_residuals(c.id, Some(&r)).expect("tell");
            } else {
                opt.tell(c.id, Outcome::Value(f)).expect("tell");
            }
        }
        if t.rounds_hit.is_none() && t.best <= target {
            t.rounds_hit = Some(t.rounds);
        }
    }
    t
}

/// The problem's box, or no bounds.
fn bounds(p: &LsProblem) -> (Vec<f64>, Vec<f64>) {
    match p.bounds {
        Some((l, u)) => (l.to_vec(), u.to_vec()),
        None => (vec![f64::NEG_INFINITY; p.x0.len()], vec![f64::INFINITY; p.x0.len()]),
    }
}

fn least_squares(p: &LsProblem, target: f64) -> Trace {
    let (lower, upper) = bounds(p);
    let settings = LsSettings {
        stopping: Stopping { x_tol: Some(1e-8), f_tol: None, max_iters: None, max_fevals: Some(LS_MAX_FEVALS) },
        ..LsSettings::new(p.x0.len())
    };
    let mut ls = LeastSquares::new(&lower, &upper, p.x0, settings).expect("settings");
    drive(&mut ls, p, target)
}

fn nelder_mead(p: &LsProblem, target: f64, parallel: bool) -> Trace {
    let (lower, upper) = bounds(p);
    let settings = NmSettings {
        parallel,
        stopping: Stopping { x_tol: Some(1e-12), f_tol: Some(1e-14), max_iters: None, max_fevals: Some(NM_MAX_FEVALS) },
        ..NmSettings::new(p.x0.len())
    };
    let mut nm = NelderMead::new(&lower, &upper, p.x0, settings).expect("settings");
    drive(&mut nm, p, target)
}

/// Both solvers with their default settings until they stop: (evaluations, rounds, best f) of
/// the least-squares solver and of parallel Nelder–Mead.
fn default_runs(p: &LsProblem) -> ((u64, u64, f64), (u64, u64, f64)) {
    let (lower, upper) = bounds(p);
    let n = p.x0.len();
    let mut ls = LeastSquares::new(&lower, &upper, p.x0, LsSettings::new(n)).expect("settings");
    let mut nm = NelderMead::new(&lower, &upper, p.x0, NmSettings::new(n)).expect("settings");
    let (a, b) = (drive(&mut ls, p, f64::NEG_INFINITY), drive(&mut nm, p, f64::NEG_INFINITY));
    ((a.evals, a.rounds, a.best), (b.evals, b.rounds, b.best))
}

fn main() {
    let tau: f64 = json_rows::option("--tau").map_or(1e-5, |t| t.parse().expect("--tau takes a number"));
    let mut rows = vec![];
    for (p, calibration) in MGH_LS.iter().map(|p| (p, false)).chain(CALIBRATION.iter().map(|p| (p, true))) {
        let f0 = p.f(p.x0);
        let target = p.f_star + tau * (f0 - p.f_star);
        let ls = least_squares(p, target);
        let par = nelder_mead(p, target, true);
        let seq = nelder_mead(p, target, false);
        let defaults = calibration.then(|| default_runs(p));
        let row = serde_json::json!({
            "problem": p.name, "calibration": calibration, "n": p.x0.len(), "m": p.m(),
            "x0": p.x0, "bounds": p.bounds, "f0": f0, "f_star": p.f_star, "tau": tau, "target": target,
            "ls_evals": ls.evals_hit, "ls_rounds": ls.rounds_hit, "ls_total_evals": ls.evals,
            "ls_total_rounds": ls.rounds, "ls_best": ls.best,
            "nm_par_evals": par.evals_hit, "nm_par_rounds": par.rounds_hit, "nm_par_best": par.best,
            "nm_seq_evals": seq.evals_hit, "nm_seq_best": seq.best,
            "default_runs": defaults.map(|(ls, nm)| serde_json::json!({
                "ls_evals": ls.0, "ls_rounds": ls.1, "ls_best": ls.2,
                "nm_evals": nm.0, "nm_rounds": nm.1, "nm_best": nm.2,
            })),
        });
        eprintln!("{row}");
        rows.push(row);
    }
    json_rows::write(&rows);
}
