//! Simulation results checked against closed forms: bouncing-ball impact times, exponential
//! decay, a time event, Integer/Boolean parameters, Robertson reference values, and
//! agreement between Model Exchange and Co-Simulation of the same model.

mod common;

use fmucal_shared::fmu::Interface;
use fmucal_shared::sim::{OutputTimes, SimResult, SimSpec, Simulator, Solver, simulate};

fn spec(interface: Interface) -> SimSpec {
    SimSpec { interface: Some(interface), ..Default::default() }
}

fn set(spec: &mut SimSpec, name: &str, value: &str) {
    spec.parameters.push((name.into(), value.into()));
}

/// Runs `spec` on the example `name`, unpacked into a cache of its own.
fn simulate_example(name: &str, spec: &SimSpec) -> SimResult {
    let cache = tempfile::tempdir().unwrap();
    simulate(&common::load_example(name, cache.path()), spec).unwrap()
}

#[test]
fn bouncing_ball_impact_times_match_closed_form() {
    let r = simulate_example("bouncing-ball", &SimSpec { tolerance: Some(1e-10), ..spec(Interface::ModelExchange) });
    let (g, e, h0) = (9.81f64, 0.7f64, 1.0f64);
    let t1 = (2.0 * h0 / g).sqrt();
    let v1 = g * t1;
    let mut expected = vec![t1];
    for k in 1..12 {
        expected.push(expected[k - 1] + 2.0 * e.powi(k as i32) * v1 / g);
    }
    assert!(r.event_times.len() >= expected.len(), "only {} events: {:?}", r.event_times.len(), r.event_times);
    for (k, (got, want)) in r.event_times.iter().zip(&expected).enumerate() {
        let rel = (got - want).abs() / want;
        assert!(rel < 1e-6, "impact {k}: got {got}, closed form {want}, relative error {rel:e}");
    }
}

#[test]
fn decay_matches_exp_within_what_the_tolerance_implies() {
    let cache = tempfile::tempdir().unwrap();
    let fmu = common::load_example("decay", cache.path());
    for solver in [Solver::Bdf, Solver::Esdirk34, Solver::TrBdf2, Solver::Tsit45] {
        let mut previous = f64::INFINITY;
        for rtol in [1e-4, 1e-6, 1e-8] {
            let mut s = spec(Interface::ModelExchange);
            s.solver = solver;
            s.tolerance = Some(rtol);
            // No cap on the step (the default, a fiftieth of the span, makes exp(−t) exact to
            // round-off at every tolerance): this checks the error control alone.
            s.max_step = Some(2.0);
            let r = simulate(&fmu, &s).unwrap();
            let x = r.column("x").unwrap();
            let err = r.time.iter().zip(x).map(|(t, x)| (x - (-t).exp()).abs()).fold(0.0, f64::max);
            // atol = rtol * nominal (1 here) bounds each step's local error; the global error of
            // an adaptive method is a modest multiple of it (measured: at most ~50x, TR-BDF2 at 1e-8).
            assert!(err < 100.0 * rtol, "{solver:?} rtol {rtol}: max absolute error {err:e}");
            assert!(err < previous, "{solver:?}: error did not shrink with the tolerance");
            previous = err;
        }
    }
}

#[test]
fn time_event_adds_the_kick_at_the_requested_time() {
    let cache = tempfile::tempdir().unwrap();
    let fmu = common::load_example("decay", cache.path());
    let exact = |t: f64| (-t).exp() + if t >= 0.755 { 0.5 * (-(t - 0.755)).exp() } else { 0.0 };
    for interface in [Interface::ModelExchange, Interface::CoSimulation] {
        let mut s = spec(interface);
        s.tolerance = Some(1e-9);
        set(&mut s, "kickTime", "0.755");
        set(&mut s, "kickAmount", "0.5");
        let r = simulate(&fmu, &s).unwrap();
        let x = r.column("x").unwrap();
        let err = r.time.iter().zip(x).map(|(t, x)| (x - exact(*t)).abs()).fold(0.0, f64::max);
        assert!(err < 1e-6, "{interface}: max error {err:e}");
        if interface == Interface::ModelExchange {
            assert_eq!(r.event_times.len(), 1);
            assert!((r.event_times[0] - 0.755).abs() < 1e-12, "event at {}", r.event_times[0]);
        }
    }
}

#[test]
fn integer_and_boolean_parameters_change_the_dynamics() {
    let mut s = spec(Interface::ModelExchange);
    s.tolerance = Some(1e-9);
    set(&mut s, "power", "2");
    let r = simulate_example("decay", &s);
    let err = r.time.iter().zip(r.column("x").unwrap()).map(|(t, x)| (x - 1.0 / (1.0 + t)).abs()).fold(0.0, f64::max);
    assert!(err < 1e-6, "x' = -x^2 should give 1/(1+t); max error {err:e}");

    let mut s = spec(Interface::CoSimulation);
    set(&mut s, "enabled", "false");
    let r = simulate_example("decay", &s);
    assert!(r.column("x").unwrap().iter().all(|x| *x == 1.0), "enabled=false must freeze x");
}

#[test]
fn robertson_reaches_reference_values_with_bdf() {
    // Reference at t = 40 (Hairer & Wanner, Solving ODEs II).
    let reference = [0.7158270687, 9.185534765e-6, 0.2841637457];
    let r = simulate_example("robertson", &SimSpec { tolerance: Some(1e-8), ..spec(Interface::ModelExchange) });
    for (name, want) in ["y1", "y2", "y3"].iter().zip(reference) {
        let got = *r.column(name).unwrap().last().unwrap();
        assert!(((got - want) / want).abs() < 1e-5, "{name}: got {got}, reference {want}");
    }
}

#[test]
fn stiff_model_needs_far_fewer_steps_with_bdf_than_explicit() {
    let cache = tempfile::tempdir().unwrap();
    let fmu = common::load_example("robertson", cache.path());
    let mut s = spec(Interface::ModelExchange);
    let bdf = simulate(&fmu, &s).unwrap().stats.steps;
    s.solver = Solver::Tsit45;
    s.max_steps = Some(200 * bdf);
    let explicit = simulate(&fmu, &s).map(|r| r.stats.steps).unwrap_or(u64::MAX);
    assert!(explicit > 20 * bdf, "BDF took {bdf} steps, Tsit45 {explicit}");
}

#[test]
fn co_simulation_and_model_exchange_agree() {
    let cache = tempfile::tempdir().unwrap();
    for (name, bound) in
        [("furuta", 1e-5), ("decay", 1e-7), ("bouncing-ball", 1e-5), ("exhaust-pipe", 1e-5), ("robertson", 1e-4)]
    {
        let fmu = common::load_example(name, cache.path());
        let mut me = spec(Interface::ModelExchange);
        me.tolerance = Some(1e-10);
        let cs = simulate(&fmu, &spec(Interface::CoSimulation)).unwrap();
        let me = simulate(&fmu, &me).unwrap();
        assert_eq!(me.time, cs.time, "{name}: grids differ");
        for (i, n) in me.names.iter().enumerate() {
            let d = common::rel_max_diff(&me.columns[i], &cs.columns[i]);
            assert!(d < bound, "{name}.{n}: ME and CS differ by {d:e} (relative to range)");
        }
    }
}

#[test]
fn explicit_output_times_are_hit_exactly() {
    let cache = tempfile::tempdir().unwrap();
    let fmu = common::load_example("decay", cache.path());
    let times = vec![0.0, 0.013, 0.5, 0.51, 1.999, 2.0];
    for interface in [Interface::ModelExchange, Interface::CoSimulation] {
        let mut s = spec(interface);
        s.output_times = Some(OutputTimes::Times(times.clone()));
        s.tolerance = Some(1e-9);
        let r = simulate(&fmu, &s).unwrap();
        assert_eq!(r.time, times);
        for (t, x) in r.time.iter().zip(r.column("x").unwrap()) {
            assert!((x - (-t).exp()).abs() < 1e-6, "{interface} at {t}: {x}");
        }
    }
}

#[test]
fn reset_then_resimulate_matches_fresh_instance() {
    let cache = tempfile::tempdir().unwrap();
    let fmu = common::load_example("furuta", cache.path());
    for interface in [Interface::ModelExchange, Interface::CoSimulation] {
        let base = spec(interface);
        let fresh = simulate(&fmu, &base).unwrap();
        let mut sim = Simulator::new(&fmu, Some(interface)).unwrap();
        let mut other = spec(interface);
        set(&mut other, "armFriction", "0.03");
        set(&mut other, "pendulumJoint.phi", "0.2");
        let first = sim.run(&other).unwrap();
        assert_ne!(first.columns, fresh.columns);
        let again = sim.run(&base).unwrap();
        assert_eq!(again.columns, fresh.columns, "{interface}: warm reset changed the result");
    }
}

#[test]
fn terminate_simulation_ends_the_run_early() {
    let cache = tempfile::tempdir().unwrap();
    let fmu = common::load_example("decay", cache.path());
    for interface in [Interface::ModelExchange, Interface::CoSimulation] {
        let mut s = spec(interface);
        s.tolerance = Some(1e-9);
        set(&mut s, "terminateTime", "1.005");
        let r = simulate(&fmu, &s).unwrap();
        assert!(r.terminated_early, "{interface}: not flagged as terminated early");
        let last = *r.time.last().unwrap();
        assert!((0.99..=1.005).contains(&last), "{interface}: results end at {last}");
        let x = *r.column("x").unwrap().last().unwrap();
        assert!((x - (-last).exp()).abs() < 1e-6, "{interface}: x({last}) = {x}");
    }
}

#[test]
fn max_step_splits_co_simulation_steps() {
    let r = simulate_example("decay", &SimSpec { max_step: Some(0.001), ..spec(Interface::CoSimulation) });
    assert_eq!(r.stats.steps, 2000, "0.01 output steps over 2 s split into 0.001 doSteps");
    assert_eq!(r.time.len(), 201);
    let err = r.time.iter().zip(r.column("x").unwrap()).map(|(t, x)| (x - (-t).exp()).abs()).fold(0.0, f64::max);
    assert!(err < 1e-9, "max error {err:e}");
}

#[test]
fn step_and_time_budgets_stop_a_simulation_with_the_time() {
    let cache = tempfile::tempdir().unwrap();
    let fmu = common::load_example("furuta", cache.path());
    let mut s = spec(Interface::ModelExchange);
    s.max_steps = Some(50);
    match simulate(&fmu, &s) {
        Err(fmucal_shared::sim::SimError::Budget { time, what }) => {
            assert!(time > 0.0 && time < 40.0, "stopped at {time}");
            assert!(what.contains("more than 50 steps"), "{what}");
        }
        other => panic!("expected a budget error, got {other:?}"),
    }
    let mut s = spec(Interface::CoSimulation);
    s.timeout = Some(std::time::Duration::from_nanos(1));
    let err = simulate(&fmu, &s).unwrap_err().to_string();
    assert!(err.contains("wall-clock timeout"), "{err}");
}
