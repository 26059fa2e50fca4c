//! Effects added to injection ports (issue 10): on the Furuta pendulum, whose joints have
//! viscous friction in the model's own equations and external-torque inputs, viscous damping
//! injected through the inputs must reproduce the model's own friction — exactly in Model
//! Exchange, where the term is evaluated inside every derivative evaluation, and to first
//! order in the communication step in Co-Simulation. Bad port terms are refused with one line.

mod common;

use fmucal_shared::fmu::{Fmu, Interface};
use fmucal_shared::sim::{OutputTimes, PortTerm, SimResult, SimSpec, simulate};

const OUTPUTS: [&str; 2] = ["armJoint.phi", "pendulumJoint.phi"];

fn furuta(dir: &std::path::Path) -> Fmu {
    common::load_example("furuta", &dir.join("cache"))
}

/// 4 s of the free swing from the pendulum's start angle, every 10 ms.
fn spec(interface: Interface, frictions: (f64, f64), port_terms: Vec<PortTerm>, max_step: Option<f64>) -> SimSpec {
    SimSpec {
        interface: Some(interface),
        start_time: Some(0.0),
        stop_time: Some(4.0),
        output_times: Some(OutputTimes::Interval(0.01)),
        parameters: vec![
            ("armFriction".into(), frictions.0.to_string()),
            ("pendulumFriction".into(), frictions.1.to_string()),
        ],
        outputs: OUTPUTS.iter().map(|s| s.to_string()).collect(),
        tolerance: Some(1e-9),
        max_step,
        port_terms,
        ..Default::default()
    }
}

fn damping(port: &str, signal: &str, c: f64) -> PortTerm {
    PortTerm { kind: "viscous_damping".into(), port: port.into(), signal: signal.into(), parameters: vec![c] }
}

/// The model's own frictions moved out of the model into two injected viscous dampings.
fn injected() -> Vec<PortTerm> {
    vec![damping("armJoint.tauExt", "armJoint.w", 0.012), damping("pendulumJoint.tauExt", "pendulumJoint.w", 0.002)]
}

fn max_abs_diff(a: &SimResult, b: &SimResult) -> f64 {
    OUTPUTS
        .iter()
        .map(|v| {
            let (x, y) = (a.column(v).unwrap(), b.column(v).unwrap());
            x.iter().zip(y).map(|(p, q)| (p - q).abs()).fold(0.0, f64::max)
        })
        .fold(0.0, f64::max)
}

#[test]
fn injected_viscous_damping_reproduces_the_models_own_friction_in_model_exchange() {
    let dir = tempfile::tempdir().unwrap();
    let fmu = furuta(dir.path());
    let own = simulate(&fmu, &spec(Interface::ModelExchange, (0.012, 0.002), vec![], None)).unwrap();
    let injected = simulate(&fmu, &spec(Interface::ModelExchange, (0.0, 0.0), injected(), None)).unwrap();
    let frictionless = simulate(&fmu, &spec(Interface::ModelExchange, (0.0, 0.0), vec![], None)).unwrap();
    // The same right-hand side in another order of the same floating-point operations.
    let d = max_abs_diff(&own, &injected);
    assert!(d < 1e-9, "ME: injected friction differs from the model's own by {d:e}");
    assert!(max_abs_diff(&own, &frictionless) > 1e-3, "the friction must matter in this test");
}

#[test]
fn in_co_simulation_the_error_is_first_order_in_the_communication_step() {
    let dir = tempfile::tempdir().unwrap();
    let fmu = furuta(dir.path());
    let reference = simulate(&fmu, &spec(Interface::ModelExchange, (0.012, 0.002), vec![], None)).unwrap();
    let error = |h: f64| {
        let r = simulate(&fmu, &spec(Interface::CoSimulation, (0.0, 0.0), injected(), Some(h))).unwrap();
        max_abs_diff(&reference, &r)
    };
    let (coarse, fine) = (error(0.01), error(0.0025));
    // Four times smaller a step: about four times smaller an error (first order), and small.
    let ratio = coarse / fine;
    assert!((2.5..6.0).contains(&ratio), "errors {coarse:e} at 10 ms, {fine:e} at 2.5 ms: ratio {ratio}");
    assert!(fine < 1e-2, "{fine:e}");
}

#[test]
fn bad_port_terms_are_refused_naming_the_culprit() {
    let dir = tempfile::tempdir().unwrap();
    let fmu = furuta(dir.path());
    let term = |kind: &str, port: &str, signal: &str, parameters: Vec<f64>| PortTerm {
        kind: kind.into(),
        port: port.into(),
        signal: signal.into(),
        parameters,
    };
    let cases = [
        (term("coulomb", "armJoint.tauExt", "armJoint.w", vec![0.1]), "\"coulomb\" is not an effect kind"),
        (term("sensor_offset", "armJoint.tauExt", "armJoint.w", vec![0.1]), "sensor_offset changes a measured series"),
        (term("viscous_damping", "armFriction", "armJoint.w", vec![0.1]), "port \"armFriction\" is not a continuous Real input"),
        (term("viscous_damping", "nope", "armJoint.w", vec![0.1]), "port \"nope\" is not a variable"),
        (term("viscous_damping", "armJoint.tauExt", "armJoint.v", vec![0.1]), "signal \"armJoint.v\" is not a variable"),
        (term("linear_spring", "armJoint.tauExt", "armJoint.phi", vec![0.1]), "linear_spring takes 2 parameters (k, x0), got 1"),
    ];
    for (t, want) in cases {
        let e = simulate(&fmu, &spec(Interface::ModelExchange, (0.0, 0.0), vec![t], None)).unwrap_err().to_string();
        assert!(e.contains(want), "{want:?} not in {e:?}");
    }
}
