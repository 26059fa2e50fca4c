//! The hidden-effect fixtures (`fmucal_models::Fixture::*Hidden*`): models whose C code has
//! physics their description does not mention, the truth a discrepancy diagnosis must find.
//! Each is checked against an independent reference, not only for differing from its base:
//!
//! - the sensor offset against the base model's output plus the offset;
//! - the port effects (arm drag, cubic spring, radiation) against the base FMU simulated with
//!   fmucal's injected effect of the same formula, in Model Exchange at a tight tolerance, which
//!   must reproduce them to round-off (each hidden term is added where its port's value enters
//!   the equations, so in practice they agree exactly) while the base model without it is off
//!   by more than 1 % of the output's range;
//! - the SpringMass base model against the closed-form damped oscillation.

mod common;

use std::path::Path;

use common::port_term;
use fmucal_models::Fixture;
use fmucal_shared::fmu::{Fmu, Interface};
use fmucal_shared::job::MeasurementTable;
use fmucal_shared::sim::{InputTable, PortTerm, SimResult, SimSpec, simulate};

fn example_data(relative: &str) -> MeasurementTable {
    MeasurementTable::read(&Path::new(env!("CARGO_MANIFEST_DIR")).join(relative), "time").unwrap()
}

/// The Furuta example's motor torque `u` (examples/furuta/FurutaData.mat).
fn furuta_torque() -> InputTable {
    let data = example_data("examples/furuta/FurutaData.mat");
    common::table(data.time.clone(), vec![("u", data.column("u").unwrap().to_vec())])
}

/// Model Exchange at a tight tolerance from 0 to `stop`, reporting `outputs` every `dt`.
fn spec(stop: f64, dt: f64, inputs: InputTable, outputs: &[&str], port_terms: Vec<PortTerm>) -> SimSpec {
    SimSpec { port_terms, ..common::model_exchange_spec(stop, dt, inputs, outputs) }
}

fn max_abs_diff(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max)
}

fn range(a: &[f64]) -> f64 {
    a.iter().fold(f64::NEG_INFINITY, |m, v| m.max(*v)) - a.iter().fold(f64::INFINITY, |m, v| m.min(*v))
}

/// The hidden-effect fixture `hidden`, the base model (the FMU at `base`) with `term` injected,
/// and the base model alone, each simulated as `spec` (given the port terms) says.
fn hidden_injected_and_base(
    hidden: Fixture,
    base: &Path,
    term: PortTerm,
    spec: impl Fn(Vec<PortTerm>) -> SimSpec,
) -> (SimResult, SimResult, SimResult) {
    let dir = tempfile::tempdir().unwrap();
    let (hidden, base) = (common::fixture(hidden, dir.path()), common::load(base, &dir.path().join("cache")));
    let run = |fmu: &Fmu, terms: Vec<PortTerm>| simulate(fmu, &spec(terms)).unwrap();
    (run(&hidden, vec![]), run(&base, vec![term]), run(&base, vec![]))
}

/// Checks the hidden variant's `outputs` against the base model with the effect injected (must
/// agree to `bound`) and the output `matters.0` against the base model without it (must differ
/// by more than the fraction `matters.1` of its range).
fn check_port_effect(
    hidden: &SimResult,
    injected: &SimResult,
    without: &SimResult,
    outputs: &[&str],
    bound: f64,
    matters: (&str, f64),
) {
    assert_eq!(hidden.time, injected.time);
    for name in outputs {
        let (h, i) = (hidden.column(name).unwrap(), injected.column(name).unwrap());
        let d = max_abs_diff(h, i);
        println!("{name}: injected effect vs hidden variant: max |diff| {d:e}");
        assert!(d < bound, "{name}: the injected effect differs from the hidden variant by {d:e}");
    }
    let (name, least) = matters;
    let h = hidden.column(name).unwrap();
    let effect = max_abs_diff(h, without.column(name).unwrap()) / range(h);
    println!("{name}: the hidden effect changes it by {:.2} % of its range {:.4}", 100.0 * effect, range(h));
    assert!(effect > least, "{name}: the hidden effect changes it by only {effect:e} of its range");
}

#[test]
fn the_sensor_offset_variant_reports_the_arm_angle_plus_the_offset_and_nothing_else() {
    let dir = tempfile::tempdir().unwrap();
    let base = common::load_example("furuta", &dir.path().join("cache"));
    let hidden = common::fixture(Fixture::FurutaHiddenSensorOffset, dir.path());
    let outputs = ["armJoint.phi", "pendulumJoint.phi"];
    for interface in [Interface::ModelExchange, Interface::CoSimulation] {
        let s = SimSpec { interface: Some(interface), ..spec(10.0, 0.01, furuta_torque(), &outputs, vec![]) };
        let (b, h) = (simulate(&base, &s).unwrap(), simulate(&hidden, &s).unwrap());
        assert_eq!(b.time, h.time);
        let (bp, hp) = (b.column("armJoint.phi").unwrap(), h.column("armJoint.phi").unwrap());
        let shifted: Vec<f64> = bp.iter().map(|p| p + 0.1).collect();
        let d = max_abs_diff(hp, &shifted);
        assert!(d < 1e-12, "{interface}: armJoint.phi differs from the base's + 0.1 by {d:e}");
        let d = max_abs_diff(h.column("pendulumJoint.phi").unwrap(), b.column("pendulumJoint.phi").unwrap());
        assert!(d < 1e-12, "{interface}: pendulumJoint.phi differs from the base's by {d:e}");
    }
}

#[test]
fn injected_quadratic_drag_reproduces_the_hidden_arm_drag() {
    let outputs = ["armJoint.phi", "pendulumJoint.phi"];
    let drag = port_term("quadratic_drag", "armJoint.tauExt", "armJoint.w", vec![1e-3]);
    let (h, i, w) = hidden_injected_and_base(Fixture::FurutaHiddenArmDrag, &common::example("furuta"), drag, |terms| {
        spec(10.0, 0.01, furuta_torque(), &outputs, terms)
    });
    check_port_effect(&h, &i, &w, &outputs, 1e-9, ("armJoint.phi", 0.01));
}

#[test]
fn injected_cubic_spring_reproduces_the_hidden_hardening_spring() {
    let outputs = ["mass.x", "mass.v"];
    let spring = port_term("cubic_spring", "mass.Fext", "mass.x", vec![0.2]);
    let (h, i, w) =
        hidden_injected_and_base(Fixture::SpringMassHiddenCubic, &Fixture::SpringMass.path(), spring, |terms| {
            spec(20.0, 0.01, common::spring_force(), &outputs, terms)
        });
    // The input drives the base model to about ±1 m, where the cubic force is 5 % of the
    // linear one.
    let amplitude = w.column("mass.x").unwrap().iter().fold(0.0f64, |m, x| m.max(x.abs()));
    assert!((0.9..1.3).contains(&amplitude), "amplitude {amplitude}");
    check_port_effect(&h, &i, &w, &outputs, 1e-9, ("mass.x", 0.01));
}

#[test]
fn injected_radiation_reproduces_the_hidden_radiation_of_the_outlet_wall() {
    let outputs = ["outlet.T", "rightVolume.wallT"];
    let radiation = port_term("radiation", "rightVolume.wallQext", "rightVolume.wallT", vec![0.2, 293.15]);
    let (h, i, w) = hidden_injected_and_base(
        Fixture::ExhaustPipeHiddenRadiation,
        &common::example("exhaust-pipe"),
        radiation,
        |terms| spec(1800.0, 1.0, common::exhaust_inputs(), &outputs, terms),
    );
    check_port_effect(&h, &i, &w, &outputs, 1e-9, ("outlet.T", 0.01));
}

#[test]
fn the_spring_mass_free_response_is_the_damped_oscillation() {
    let dir = tempfile::tempdir().unwrap();
    let fmu = common::fixture(Fixture::SpringMass, dir.path());
    let (m, k, d, x0) = (1.0f64, 4.0f64, 0.3f64, 1.0f64);
    let s = SimSpec {
        parameters: vec![("mass.x".into(), x0.to_string())],
        tolerance: Some(1e-12),
        inputs: None,
        ..spec(20.0, 0.01, common::spring_force(), &["mass.x", "mass.v"], vec![])
    };
    let r = simulate(&fmu, &s).unwrap();
    // m x'' + d x' + k x = 0, x(0) = x0, x'(0) = 0 (underdamped).
    let w0 = (k / m).sqrt();
    let zeta = d / (2.0 * (k * m).sqrt());
    let wd = w0 * (1.0 - zeta * zeta).sqrt();
    let a = zeta * w0;
    for (i, t) in r.time.iter().enumerate() {
        let e = (-a * t).exp();
        let x = x0 * e * ((wd * t).cos() + a / wd * (wd * t).sin());
        let v = -x0 * e * (w0 * w0 / wd) * (wd * t).sin();
        let (xs, vs) = (r.columns[0][i], r.columns[1][i]);
        assert!((xs - x).abs() < 1e-8 * x0, "x at {t}: {xs} vs {x}");
        assert!((vs - v).abs() < 1e-8 * x0 * w0, "v at {t}: {vs} vs {v}");
    }
}

/// The free spring–mass (m = 1, k = 4, d = 0.3) with an injected dead-zone spring (k₂, width w)
/// is piecewise linear: in each region a damped oscillation about its own rest point. Stepping
/// the closed form region by region (each switch the root of the closed form, by bisection)
/// gives x(t) and the switching times exactly.
fn dead_zone_reference(x0: f64, k2: f64, w: f64, times: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let (k, d) = (4.0f64, 0.3f64);
    // Region −1, 0 or 1 of x: stiffness and rest point.
    let region = |x: f64| {
        if x > w {
            1.0
        } else if x < -w {
            -1.0
        } else {
            0.0
        }
    };
    let law = |r: f64| if r == 0.0 { (k, 0.0) } else { (k + k2, r * k2 * w / (k + k2)) };
    // State after time s in region r from (x, v).
    let flow = |r: f64, x: f64, v: f64, s: f64| {
        let (kk, rest) = law(r);
        let a = d / 2.0;
        let b = (kk - a * a).sqrt();
        let (y, e) = (x - rest, (-a * s).exp());
        let big_b = (v + a * y) / b;
        let (c, sn) = ((b * s).cos(), (b * s).sin());
        let xs = rest + e * (y * c + big_b * sn);
        let vs = e * ((-a * y + b * big_b) * c + (-a * big_b - b * y) * sn);
        (xs, vs)
    };
    // Leaving region r: the edge it crosses, signed so that g > 0 inside.
    let inside = |r: f64, x: f64| if r == 0.0 { w - x.abs() } else { r * x - w };
    let (mut t0, mut x, mut v, mut r) = (0.0, x0, 0.0, region(x0));
    let mut switches = vec![];
    let mut out = vec![];
    let mut next = 0;
    let stop = *times.last().unwrap();
    while next < times.len() {
        // The first time this region is left: scan, then bisect the sign change.
        let mut s_exit = f64::INFINITY;
        let mut s = 0.0;
        while t0 + s < stop + 1.0 {
            let s1 = s + 1e-3;
            let (x1, _) = flow(r, x, v, s1);
            if inside(r, x1) < 0.0 {
                let (mut lo, mut hi) = (s, s1);
                for _ in 0..200 {
                    let mid = 0.5 * (lo + hi);
                    if inside(r, flow(r, x, v, mid).0) < 0.0 { hi = mid } else { lo = mid }
                }
                s_exit = hi;
                break;
            }
            s = s1;
        }
        while next < times.len() && times[next] - t0 <= s_exit {
            out.push(flow(r, x, v, times[next] - t0).0);
            next += 1;
        }
        if s_exit.is_infinite() {
            break;
        }
        (x, v) = flow(r, x, v, s_exit);
        t0 += s_exit;
        switches.push(t0);
        r = if r == 0.0 { x.signum() } else { 0.0 };
    }
    (out, switches)
}

#[test]
fn a_dead_zone_springs_edges_are_events_and_the_motion_is_the_piecewise_closed_form() {
    let dir = tempfile::tempdir().unwrap();
    let fmu = common::fixture(Fixture::SpringMass, dir.path());
    let (x0, k2, w) = (1.0, 12.0, 0.3);
    let s = SimSpec {
        parameters: vec![("mass.x".into(), x0.to_string())],
        tolerance: Some(1e-10),
        inputs: None,
        ..spec(
            10.0,
            0.01,
            common::spring_force(),
            &["mass.x"],
            vec![port_term("dead_zone_spring", "mass.Fext", "mass.x", vec![k2, w])],
        )
    };
    let r = simulate(&fmu, &s).unwrap();
    let (x, switches) = dead_zone_reference(x0, k2, w, &r.time);
    assert!(switches.len() >= 8, "the motion crosses the zone's edges: {switches:?}");
    let error = max_abs_diff(r.column("mass.x").unwrap(), &x);
    eprintln!("{} switches, {} events, {} steps, error {error:e}", switches.len(), r.stats.events, r.stats.steps);
    assert!(error < 1e-7, "x differs from the closed form by {error:e}");
    // One event per edge crossing: the edges are event indicators of their own (the base model
    // has none), so the integrator stops at each kink rather than stepping across it.
    assert_eq!(r.stats.events, switches.len() as u64, "{switches:?}");
}
