//! Unit tests of CMA-ES: convergence on sphere, 10-D Rosenbrock and a bound optimum, IPOP
//! against a single run on Rastrigin, failures, the evaluation budget, restarts and settings.

use super::*;
use crate::test_problems::{self as tp, run};
use crate::{Optimizer, Outcome, Status};

fn settings(n: usize, seed: u64, max_fevals: u64) -> CmaSettings {
    let mut s = CmaSettings::new(n);
    s.seed = seed;
    s.stopping.max_fevals = Some(max_fevals);
    s
}

fn minimize(lower: &[f64], upper: &[f64], x0: Option<&[f64]>, s: CmaSettings, f: fn(&[f64]) -> f64) -> CmaEs {
    let mut es = CmaEs::new(lower, upper, x0, s).unwrap();
    run(&mut es, &|x| Outcome::Value(f(x)), u64::MAX);
    es
}

#[test]
fn sphere_converges_to_the_interior_optimum_in_one_run() {
    let s = CmaSettings { restarts: 0, ..settings(5, 1, 20_000) };
    let es = minimize(&[-3.0; 5], &[4.0; 5], Some(&[2.0; 5]), s, tp::sphere);
    let (x, f) = es.best().unwrap();
    assert!(f < 1e-9 && x.iter().all(|v| v.abs() < 1e-4), "f = {f} at {x:?}");
    assert_eq!(es.status(), Status::Done(Termination::XTol), "the default x_tol ends the single run");
    assert!(es.evaluations() < 5000, "{} evaluations", es.evaluations());
}

#[test]
fn rosenbrock_10d_converges() {
    let es = minimize(&[-2.0; 10], &[2.0; 10], Some(&[0.0; 10]), settings(10, 3, 50_000), tp::rosenbrock);
    let (x, f) = es.best().unwrap();
    assert!(f < 1e-10 && x.iter().all(|v| (v - 1.0).abs() < 1e-4), "f = {f} at {x:?}");
}

#[test]
fn optima_on_bounds_and_corners_are_reached() {
    let es = minimize(&[2.0, -1.0], &[5.0, 3.0], None, settings(2, 0, 5000), tp::shifted_sphere);
    let (x, _) = es.best().unwrap();
    assert!((x[0] - 2.0).abs() < 1e-8 && (x[1] + 1.0).abs() < 1e-8, "{x:?}");
    // Five dimensions: two at the lower bound, one at the upper one, two inside.
    let f = |x: &[f64]| x.iter().zip([-1.5, -0.5, 2.0, 0.3, 0.7]).map(|(a, b)| (a - b) * (a - b)).sum();
    let es = minimize(
        &[-1.0, 0.0, -1.0, -1.0, -1.0],
        &[1.0, 1.0, 1.0, 1.0, 1.0],
        Some(&[0.0; 5]),
        settings(5, 2, 20_000),
        f,
    );
    let (x, _) = es.best().unwrap();
    let expect = [-1.0, 0.0, 1.0, 0.3, 0.7];
    assert!(x.iter().zip(expect).all(|(a, b)| (a - b).abs() < 1e-6), "{x:?} vs {expect:?}");
}

#[test]
fn ipop_finds_a_lower_rastrigin_minimum_than_a_single_run_with_the_same_budget() {
    let median = |restarts: u32| {
        let mut best: Vec<f64> = (0..7)
            .map(|seed| {
                let s = CmaSettings { restarts, ..settings(10, seed, 20_000) };
                minimize(&[-5.12; 10], &[5.12; 10], None, s, tp::rastrigin).best().unwrap().1
            })
            .collect();
        best.sort_by(f64::total_cmp);
        best[3]
    };
    let (single, ipop) = (median(0), median(9));
    assert!(ipop < 0.5 * single, "median best: IPOP {ipop}, single run {single}");
}

#[test]
fn failed_and_nan_points_rank_worst_and_the_optimum_next_to_them_is_found() {
    // Sphere centred at 0.3; it fails for x₀ > 0.35 and is NaN for x₁ < 0.
    let f = |x: &[f64]| {
        if x[0] > 0.35 {
            Outcome::Failed
        } else if x[1] < 0.0 {
            Outcome::Value(f64::NAN)
        } else {
            Outcome::Value(x.iter().map(|v| (v - 0.3) * (v - 0.3)).sum())
        }
    };
    let mut es = CmaEs::new(&[-1.0; 3], &[1.0; 3], Some(&[-0.5, 0.5, 0.5]), settings(3, 5, 10_000)).unwrap();
    run(&mut es, &f, u64::MAX);
    let (x, v) = es.best().unwrap();
    assert!(v < 1e-9 && x.iter().all(|c| (c - 0.3).abs() < 1e-4), "f = {v} at {x:?}");
}

#[test]
fn an_objective_that_always_fails_ends_without_a_best_point() {
    let mut s = settings(2, 0, 1_000_000);
    s.stopping.max_iters = Some(200);
    let mut es = CmaEs::new(&[0.0, 0.0], &[1.0, 1.0], None, s).unwrap();
    run(&mut es, &|_| Outcome::Failed, 10_000);
    assert!(es.best().is_none());
    assert!(matches!(es.status(), Status::Done(_)), "{:?}", es.status());
    for v in [f64::INFINITY, f64::NEG_INFINITY] {
        let mut es = CmaEs::new(&[0.0, 0.0], &[1.0, 1.0], None, settings(2, 0, 5000)).unwrap();
        run(&mut es, &|_| Outcome::Value(v), 10_000);
        assert!(es.best().is_none() && matches!(es.status(), Status::Done(_)));
    }
}

/// Runs `es` on the sphere to its end; the size of every batch it asked.
fn batch_sizes_on_the_sphere(es: &mut CmaEs) -> Vec<usize> {
    let mut sizes = vec![];
    loop {
        let batch = es.ask();
        if batch.is_empty() {
            return sizes;
        }
        sizes.push(batch.len());
        for c in batch {
            es.tell(c.id, Outcome::Value(tp::sphere(&c.x))).unwrap();
        }
    }
}

#[test]
fn max_fevals_cuts_the_last_batch() {
    let s = CmaSettings { population: 10, ..settings(3, 0, 25) };
    let mut es = CmaEs::new(&[-1.0; 3], &[1.0; 3], None, s).unwrap();
    let sizes = batch_sizes_on_the_sphere(&mut es);
    assert_eq!(sizes, [10, 10, 5]);
    assert_eq!((es.evaluations(), es.iterations()), (25, 2));
    assert_eq!(es.status(), Status::Done(Termination::MaxFevals));
}

#[test]
fn each_restart_doubles_the_population_and_the_last_run_ends_the_optimization() {
    let mut s = CmaSettings { population: 6, restarts: 2, ..settings(2, 4, 1_000_000) };
    s.stopping.x_tol = Some(1e-3);
    let mut es = CmaEs::new(&[-1.0; 2], &[1.0; 2], Some(&[0.5, 0.5]), s).unwrap();
    let mut sizes = batch_sizes_on_the_sphere(&mut es);
    sizes.dedup();
    assert_eq!(sizes, [6, 12, 24]);
    assert_eq!(es.status(), Status::Done(Termination::XTol));
    assert_eq!(es.iterations(), es.rounds(), "every generation is one batch");
}

#[test]
fn a_degenerate_distribution_still_serializes_and_ends_its_local_run() {
    let s = CmaSettings { population: 6, restarts: 1, ..settings(2, 0, 1000) };
    let mut es = CmaEs::new(&[-1.0; 2], &[1.0; 2], None, s).unwrap();
    es.algorithm.distribution.sigma = f64::INFINITY;
    let json = serde_json::to_string(&es).unwrap();
    let resumed: CmaEs = serde_json::from_str(&json).unwrap();
    assert_eq!(resumed.algorithm.distribution.sigma, f64::INFINITY);
    for c in es.ask() {
        es.tell(c.id, Outcome::Value(tp::sphere(&c.x))).unwrap();
    }
    assert_eq!((es.status(), es.ask().len()), (Status::Running, 12), "the next run starts, population doubled");
    assert!(es.algorithm.distribution.sigma.is_finite());
}

#[test]
fn fixed_parameters_keep_their_value() {
    let mut es = CmaEs::new(&[-1.0, 2.5, -1.0], &[1.0, 2.5, 1.0], None, settings(3, 0, 3000)).unwrap();
    run(&mut es, &|x| Outcome::Value((x[0] - 0.2).powi(2) + (x[2] + 0.4).powi(2)), u64::MAX);
    let (x, f) = es.best().unwrap();
    assert!(x[1] == 2.5 && f < 1e-12, "f = {f} at {x:?}");
    let mut all_fixed = CmaEs::new(&[1.0], &[1.0], None, settings(1, 0, 100)).unwrap();
    assert_eq!(run(&mut all_fixed, &|x| Outcome::Value(x[0]), 100), 1, "nothing to search after one generation");
    assert_eq!(all_fixed.status(), Status::Done(Termination::XTol));
}

#[test]
fn bad_settings_name_the_field() {
    let check = |s: CmaSettings, lower: f64, field: &str| {
        tp::assert_names_setting(CmaEs::new(&[lower, 0.0], &[1.0, 1.0], None, s), field)
    };
    check(CmaSettings { population: 3, ..CmaSettings::new(2) }, 0.0, "population");
    check(CmaSettings { sigma0: 0.0, ..CmaSettings::new(2) }, 0.0, "sigma0");
    check(CmaSettings { sigma0: f64::NAN, ..CmaSettings::new(2) }, 0.0, "sigma0");
    check(CmaSettings { restarts: 64, ..CmaSettings::new(2) }, 0.0, "restarts");
    check(CmaSettings { restarts: 19, ..CmaSettings::new(2) }, 0.0, "restarts");
    check(
        CmaSettings { stopping: Stopping { x_tol: Some(-1.0), ..Stopping::default_for(2) }, ..CmaSettings::new(2) },
        0.0,
        "x_tol",
    );
    check(CmaSettings::new(2), f64::NEG_INFINITY, "lower");
    check(CmaSettings::new(2), 2.0, "lower");
    assert_eq!(CmaSettings::new(10).population, 10);
    assert_eq!(CmaSettings::new(1).population, 4);
}
