//! Unit tests of the least-squares solver as a whole: convergence on the Moré–Garbow–Hillstrom
//! problems and the calibrations (whose minima were computed independently, with SciPy),
//! bounds, failures, the stopping rules and the settings' checks.

use super::*;
use crate::least_squares_problems::{CALIBRATION, LsProblem, MGH_LS};
use crate::{NelderMead, NmSettings};

fn problem(name: &str) -> &'static LsProblem {
    MGH_LS.iter().chain(CALIBRATION).find(|p| p.name == name).expect("a problem of that name")
}

fn unbounded(n: usize) -> (Vec<f64>, Vec<f64>) {
    (vec![f64::NEG_INFINITY; n], vec![f64::INFINITY; n])
}

fn tight(n: usize) -> LsSettings {
    LsSettings {
        stopping: Stopping { x_tol: Some(1e-10), f_tol: None, max_iters: None, max_fevals: Some(5000) },
        ..LsSettings::new(n)
    }
}

/// Runs `opt` on `residuals` (None: a failed evaluation) until it stops, checking that every
/// asked point is within the bounds; returns the rounds.
fn run(opt: &mut dyn Optimizer, residuals: &dyn Fn(&[f64]) -> Option<Vec<f64>>, lower: &[f64], upper: &[f64]) -> u64 {
    let mut rounds = 0;
    while rounds < 100_000 {
        let batch = opt.ask();
        if batch.is_empty() {
            break;
        }
        rounds += 1;
        for c in batch {
            for (i, x) in c.x.iter().enumerate() {
                assert!(x.is_finite() && *x >= lower[i] && *x <= upper[i], "{:?} outside the box", c.x);
            }
            let r = residuals(&c.x);
            if opt.wants_residuals() {
                opt.tell_residuals(c.id, r.as_deref()).expect("tell an asked candidate");
            } else {
                let f = r.map_or(Outcome::Failed, |r| Outcome::Value(r.iter().map(|v| v * v).sum()));
                opt.tell(c.id, f).expect("tell an asked candidate");
            }
        }
    }
    rounds
}

fn solve(p: &LsProblem, settings: LsSettings) -> LeastSquares {
    let n = p.x0.len();
    let (lower, upper) = match p.bounds {
        Some((l, u)) => (l.to_vec(), u.to_vec()),
        None => unbounded(n),
    };
    let mut ls = LeastSquares::new(&lower, &upper, p.x0, settings).expect("valid settings");
    run(&mut ls, &|x| Some((p.residuals)(x)), &lower, &upper);
    ls
}

#[test]
fn rosenbrock_converges_from_the_standard_start() {
    let ls = solve(problem("Rosenbrock"), tight(2));
    let (x, f) = ls.best().expect("a best point");
    assert!(f < 1e-20, "f = {f:e} at {x:?}");
    assert!((x[0] - 1.0).abs() < 1e-9 && (x[1] - 1.0).abs() < 1e-9, "{x:?}");
    assert_eq!(ls.status(), Status::Done(Termination::XTol));
    assert!(ls.evaluations() < 100, "{} evaluations", ls.evaluations());
}

#[test]
fn mgh_problems_reach_their_known_minima() {
    for name in [
        "Freudenstein-Roth",
        "Beale",
        "Jennrich-Sampson",
        "Helical valley",
        "Bard",
        "Gaussian",
        "Box 3-D",
        "Powell singular",
        "Wood",
        "Kowalik-Osborne",
        "Osborne 1",
        "Penalty I",
    ] {
        let p = problem(name);
        let ls = solve(p, tight(p.x0.len()));
        let (_, f) = ls.best().expect("a best point");
        let gap = (f - p.f_star) / (p.f(p.x0) - p.f_star);
        assert!(gap < 1e-8, "{name}: f = {f:e}, f* = {:e}", p.f_star);
    }
}

#[test]
fn calibrations_take_a_fraction_of_nelder_meads_rounds_and_simulations() {
    // Both to f ≤ f* + 1e-5 (f(x0) − f*), in the calibration's box.
    for p in CALIBRATION {
        let n = p.x0.len();
        let Some((lower, upper)) = p.bounds else { panic!("calibrations are bounded") };
        let target = p.f_star + 1e-5 * (p.f(p.x0) - p.f_star);
        let count = |opt: &mut dyn Optimizer| {
            let (mut evals, mut rounds) = (0, 0);
            while opt.best().is_none_or(|b| b.1 > target) {
                let batch = opt.ask();
                assert!(!batch.is_empty(), "{}: stopped before the target", p.name);
                rounds += 1;
                for c in batch {
                    evals += 1;
                    let r = (p.residuals)(&c.x);
                    opt.tell_residuals(c.id, Some(&r)).expect("tell");
                }
            }
            (evals, rounds)
        };
        let mut ls = LeastSquares::new(lower, upper, p.x0, LsSettings::new(n)).expect("settings");
        let mut nm = NelderMead::new(lower, upper, p.x0, NmSettings::new(n)).expect("settings");
        let (ls_evals, ls_rounds) = count(&mut ls);
        let (nm_evals, nm_rounds) = count(&mut nm);
        assert!(ls_evals * 100 <= 20 * nm_evals, "{}: {ls_evals} vs {nm_evals} evaluations", p.name);
        assert!(ls_rounds * 100 <= 60 * nm_rounds, "{}: {ls_rounds} vs {nm_rounds} rounds", p.name);
    }
}

#[test]
fn an_optimum_on_a_bound_is_found_and_no_point_leaves_the_box() {
    // Rosenbrock with x ≤ 0.5: the minimum is at (0.5, 0.25), where f = 0.25.
    let (lower, upper) = ([-2.0, -1.0], [0.5, 2.0]);
    let mut ls = LeastSquares::new(&lower, &upper, &[-1.2, 1.0], tight(2)).expect("settings");
    run(&mut ls, &|x| Some(crate::least_squares_problems::rosenbrock(x)), &lower, &upper);
    let (x, f) = ls.best().expect("a best point");
    assert!((x[0] - 0.5).abs() < 1e-9 && (x[1] - 0.25).abs() < 1e-7, "{x:?}");
    assert!((f - 0.25).abs() < 1e-12, "{f}");
    // A corner: (x0 − 1, x1 + 2) over [2, 5] × [−1, 3] is smallest at (2, −1).
    let (lower, upper) = ([2.0, -1.0], [5.0, 3.0]);
    let mut ls = LeastSquares::new(&lower, &upper, &[4.0, 2.0], tight(2)).expect("settings");
    run(&mut ls, &|x| Some(vec![x[0] - 1.0, x[1] + 2.0]), &lower, &upper);
    let (x, f) = ls.best().expect("a best point");
    assert_eq!(x, vec![2.0, -1.0]);
    assert!((f - 2.0).abs() < 1e-12);
}

#[test]
fn one_parameter_and_one_residual_work() {
    let mut ls = LeastSquares::new(&[0.0], &[10.0], &[9.0], tight(1)).expect("settings");
    run(&mut ls, &|x| Some(vec![(x[0] - 3.0).powi(3) + (x[0] - 3.0)]), &[0.0], &[10.0]);
    let (x, f) = ls.best().expect("a best point");
    assert!((x[0] - 3.0).abs() < 1e-9 && f < 1e-18, "{x:?} {f:e}");
}

#[test]
fn failed_points_rank_worst_and_the_search_goes_on() {
    let p = problem("Rosenbrock");
    let (lower, upper) = unbounded(2);
    // Everything with x0 > 1.5 "crashes", and NaN or infinite residuals come back elsewhere.
    let residuals = |x: &[f64]| -> Option<Vec<f64>> {
        if x[0] > 1.5 {
            None
        } else if x[1] > 1.6 {
            Some(vec![f64::NAN, 1.0])
        } else if x[1] < -1.0 {
            Some(vec![f64::INFINITY, 1.0])
        } else {
            Some((p.residuals)(x))
        }
    };
    let mut ls = LeastSquares::new(&lower, &upper, p.x0, tight(2)).expect("settings");
    run(&mut ls, &residuals, &lower, &upper);
    let (_, f) = ls.best().expect("a best point");
    assert!(f < 1e-12, "{f:e}");
}

#[test]
fn a_failing_start_is_retried_closer_and_every_run_ends() {
    // x0 and its neighbourhood up to 0.04 away fail: the design is retried at half the radius
    // until a point succeeds.
    let residuals = |x: &[f64]| -> Option<Vec<f64>> {
        if x[0] < 0.56 && x[1] < 0.56 { None } else { Some(vec![x[0] - 0.2, x[1] - 0.9]) }
    };
    let mut ls = LeastSquares::new(&[0.0, 0.0], &[1.0, 1.0], &[0.5, 0.5], LsSettings::new(2)).expect("settings");
    run(&mut ls, &residuals, &[0.0, 0.0], &[1.0, 1.0]);
    assert!(ls.best().is_some_and(|(_, f)| f < 1.0), "{:?}", ls.best());
    // Nothing ever succeeds: the radius shrinks to x_tol and the run stops.
    let mut ls = LeastSquares::new(&[0.0, 0.0], &[1.0, 1.0], &[0.5, 0.5], LsSettings::new(2)).expect("settings");
    run(&mut ls, &|_| None, &[0.0, 0.0], &[1.0, 1.0]);
    assert_eq!((ls.status(), ls.best()), (Status::Done(Termination::XTol), None));
    assert!(ls.evaluations() < 100);
}

#[test]
fn residual_vectors_of_another_length_count_as_failures() {
    let mut ls = LeastSquares::new(&[0.0, 0.0], &[1.0, 1.0], &[0.5, 0.5], tight(2)).expect("settings");
    let residuals = |x: &[f64]| -> Option<Vec<f64>> {
        if x[0] > 0.7 { Some(vec![1.0]) } else { Some(vec![x[0] - 0.6, x[1] - 0.4, x[0] * x[1] - 0.24]) }
    };
    run(&mut ls, &residuals, &[0.0, 0.0], &[1.0, 1.0]);
    let (x, f) = ls.best().expect("a best point");
    assert!(f < 1e-16 && (x[0] - 0.6).abs() < 1e-8, "{x:?} {f:e}");
}

#[test]
fn the_first_batch_is_x0_and_coordinate_steps_and_values_are_refused() {
    let mut ls = LeastSquares::new(&[0.0, -5.0], &[1.0, 5.0], &[0.95, 1.0], LsSettings::new(2)).expect("settings");
    let batch = ls.ask();
    let xs: Vec<Vec<f64>> = batch.iter().map(|c| c.x.clone()).collect();
    // Steps of 0.1 of each range; the first goes backwards, as 0.95 + 0.1 would leave [0, 1].
    assert_eq!(xs.len(), 3);
    assert_eq!(xs[0], vec![0.95, 1.0]);
    assert!((xs[1][0] - 0.85).abs() < 1e-12 && xs[1][1] == 1.0, "{xs:?}");
    assert!(xs[2][0] == 0.95 && (xs[2][1] - 2.0).abs() < 1e-12, "{xs:?}");
    assert!(ls.wants_residuals());
    assert_eq!(ls.tell(batch[0].id, Outcome::Value(1.0)), Err(OptimError::ResidualsNeeded(batch[0].id)));
    assert_eq!(ls.tell(999, Outcome::Value(1.0)), Err(OptimError::UnknownCandidate(999)));
    assert_eq!(ls.tell(batch[0].id, Outcome::Failed), Ok(()));
    assert_eq!(ls.tell(batch[0].id, Outcome::Failed), Err(OptimError::UnknownCandidate(batch[0].id)));
    assert_eq!(ls.ask().len(), 2, "asking again returns the open candidates");
    assert_eq!((ls.rounds(), ls.evaluations(), ls.iterations()), (1, 0, 0));
}

#[test]
fn termination_reports_the_rule_that_fired() {
    let p = problem("Rosenbrock");
    let with = |stopping: Stopping, max_slow_iterations: Option<u64>| {
        solve(p, LsSettings { stopping, max_slow_iterations, ..LsSettings::new(2) })
    };
    let none = Stopping { x_tol: None, f_tol: None, max_iters: None, max_fevals: None };
    let ls = with(Stopping { max_iters: Some(7), ..none }, None);
    assert_eq!((ls.status(), ls.iterations()), (Status::Done(Termination::MaxIters), 7));
    for max in [1, 2, 3, 4, 17] {
        let ls = with(Stopping { max_fevals: Some(max), ..none }, None);
        assert_eq!((ls.status(), ls.evaluations()), (Status::Done(Termination::MaxFevals), max));
    }
    let ls = with(Stopping { x_tol: Some(1e-3), ..none }, None);
    assert_eq!(ls.status(), Status::Done(Termination::XTol));
    assert!(ls.rho <= 1e-3);
    let ls = with(Stopping { f_tol: Some(1e-4), ..none }, None);
    assert_eq!(ls.status(), Status::Done(Termination::FTol));
    assert!(ls.best().is_some_and(|(_, f)| f <= 1e-4 * 24.2));
    // The predicted gain: it stops with f within about the gain of the minimum 0, long before
    // the radius would reach its floor, and no later for a larger gain.
    let gain = |g: f64| solve(p, LsSettings { stopping: none, min_predicted_gain: Some(g), ..LsSettings::new(2) });
    let (loose, tight) = (gain(1e-3), gain(1e-12));
    for ls in [&loose, &tight] {
        assert_eq!(ls.status(), Status::Done(Termination::FTol));
    }
    assert!(loose.best().is_some_and(|(_, f)| f < 1e-2), "{:?}", loose.best());
    assert!(tight.best().is_some_and(|(_, f)| f < 1e-10), "{:?}", tight.best());
    let without = with(none, None);
    assert!(loose.evaluations() <= tight.evaluations() && tight.evaluations() < without.evaluations());
    // Slow progress: Beale from (−10, 10) creeps along its valley towards x → −∞.
    let beale = problem("Beale");
    let (lower, upper) = unbounded(2);
    let settings = LsSettings { stopping: none, max_slow_iterations: Some(3), ..LsSettings::new(2) };
    let mut ls = LeastSquares::new(&lower, &upper, &[-10.0, 10.0], settings).expect("settings");
    run(&mut ls, &|x| Some((beale.residuals)(x)), &lower, &upper);
    assert_eq!(ls.status(), Status::Done(Termination::FTol));
    assert!(ls.best().is_some_and(|(x, _)| x[0] < -100.0), "it crept along the valley");
}

#[test]
fn bad_settings_name_the_field() {
    let build = |s: LsSettings, x0: &[f64]| LeastSquares::new(&[0.0, 0.0], &[1.0, 1.0], x0, s).unwrap_err();
    let field = |e: OptimError| match e {
        OptimError::Setting { field, .. } => field,
        other => panic!("{other}"),
    };
    let mut s = LsSettings::new(2);
    s.stopping.x_tol = Some(-1.0);
    assert_eq!(field(build(s, &[0.5, 0.5])), "x_tol");
    for r in [0.0, f64::NAN, f64::INFINITY] {
        assert_eq!(field(build(LsSettings { initial_radius: r, ..LsSettings::new(2) }, &[0.5, 0.5])), "initial_radius");
    }
    assert_eq!(
        field(build(LsSettings { max_slow_iterations: Some(0), ..LsSettings::new(2) }, &[0.5, 0.5])),
        "max_slow_iterations"
    );
    assert_eq!(field(build(LsSettings::new(2), &[0.5, 1.5])), "x0");
    let e = LeastSquares::new(&[0.0, 1.0], &[1.0, 1.0], &[0.5, 1.0], LsSettings::new(2)).unwrap_err();
    assert_eq!(field(e), "upper");
}

#[test]
fn a_checkpoint_resumes_with_the_same_asks() {
    let p = problem("Kowalik-Osborne");
    let (lower, upper) = unbounded(4);
    let mut a = AnyOptimizer::LeastSquares(LeastSquares::new(&lower, &upper, p.x0, tight(4)).expect("settings"));
    for _ in 0..6 {
        for c in a.ask() {
            a.tell_residuals(c.id, Some(&(p.residuals)(&c.x))).expect("tell");
        }
    }
    let json = serde_json::to_string(&a).expect("serialize");
    let mut b: AnyOptimizer = serde_json::from_str(&json).expect("deserialize");
    assert_eq!(serde_json::to_string(&b).expect("serialize"), json);
    assert!(b.wants_residuals());
    while !a.ask().is_empty() {
        let asked = a.ask();
        assert_eq!(b.ask(), asked);
        for c in asked {
            let r = (p.residuals)(&c.x);
            a.tell_residuals(c.id, Some(&r)).expect("tell");
            b.tell_residuals(c.id, Some(&r)).expect("tell");
        }
    }
    assert_eq!((a.status(), a.best()), (b.status(), b.best()));
}
