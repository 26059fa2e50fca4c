//! Effects added to injection ports: on the Furuta pendulum, whose joints have
//! viscous friction in the model's own equations and external-torque inputs, viscous damping
//! injected through the inputs must reproduce the model's own friction — exactly in Model
//! Exchange, where the term is evaluated inside every derivative evaluation, and to first
//! order in the communication step in Co-Simulation. Bad port terms are refused with one line.

mod common;

use common::port_term;
use fmucal_shared::fmu::{Fmu, Interface};
use fmucal_shared::job::{JobSpec, MeasurementTable, PreparedJob, local};
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
    port_term("viscous_damping", port, signal, vec![c])
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
    let cases = [
        (port_term("coulomb", "armJoint.tauExt", "armJoint.w", vec![0.1]), "\"coulomb\" is not an effect kind"),
        (
            port_term("sensor_offset", "armJoint.tauExt", "armJoint.w", vec![0.1]),
            "sensor_offset changes a measured series",
        ),
        (
            port_term("viscous_damping", "armFriction", "armJoint.w", vec![0.1]),
            "port \"armFriction\" is not a continuous Real input",
        ),
        (port_term("viscous_damping", "nope", "armJoint.w", vec![0.1]), "port \"nope\" is not a variable"),
        (
            port_term("viscous_damping", "armJoint.tauExt", "armJoint.v", vec![0.1]),
            "signal \"armJoint.v\" is not a variable",
        ),
        (
            port_term("linear_spring", "armJoint.tauExt", "armJoint.phi", vec![0.1]),
            "linear_spring takes 2 parameters (k, x0), got 1",
        ),
    ];
    for (t, want) in cases {
        let e = simulate(&fmu, &spec(Interface::ModelExchange, (0.0, 0.0), vec![t], None)).unwrap_err().to_string();
        assert!(e.contains(want), "{want:?} not in {e:?}");
    }
}

/// A job on the Furuta example FMU fitting both angles to `data` (time, phi, theta, u) with
/// the motor torque as input; `body` holds its `[[parameters]]` and `[[effects]]`, then the
/// `[simulation]` and `[optimizer]` entries.
fn furuta_toml(data: &std::path::Path, body: &str, simulation: &str, optimizer: &str) -> String {
    common::job_toml(
        &common::example("furuta"),
        Some(data),
        &[("armJoint.phi", "phi"), ("pendulumJoint.phi", "theta")],
        &[("u", "u")],
        &[],
        &format!("{body}\n[simulation]\n{simulation}\n[optimizer]\n{optimizer}\n"),
    )
}

/// The Furuta example's job up to 10 s, calibrating either the model's own frictions or, with
/// those set to zero, two injected viscous dampings.
fn furuta_job(dir: &std::path::Path, injected: bool) -> JobSpec {
    let data = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/furuta/FurutaData.mat");
    let (parameters, effects) = if injected {
        ("", include_str!("data/effects/furuta_injected_damping.toml"))
    } else {
        (include_str!("data/effects/furuta_frictions.toml"), "")
    };
    let set = if injected { "set = { armFriction = 0.0, pendulumFriction = 0.0 }" } else { "" };
    let toml = furuta_toml(
        &data,
        &format!("{parameters}\n{effects}"),
        &format!("stop_time = 10.0\ntolerance = 1e-8\n{set}"),
        "x_tol = 1e-4\nf_tol = 1e-6",
    );
    let spec = JobSpec::from_toml(&toml, dir).unwrap();
    spec.validate().unwrap();
    spec
}

fn calibrate(dir: &std::path::Path, spec: &JobSpec) -> fmucal_shared::job::CalibrationResult {
    let fmu = std::sync::Arc::new(furuta(dir));
    let data = MeasurementTable::read(spec.data.path.as_ref().unwrap(), "time").unwrap();
    let job = PreparedJob::new(spec, &fmu.description, &fmu.interfaces(), std::slice::from_ref(&data)).unwrap();
    local::calibrate(fmu, std::sync::Arc::new(job), 2, |_| {}).unwrap()
}

#[test]
fn a_job_with_injected_damping_recovers_the_frictions_the_model_itself_finds() {
    let dir = tempfile::tempdir().unwrap();
    let own = calibrate(dir.path(), &furuta_job(dir.path(), false));
    let injected = calibrate(dir.path(), &furuta_job(dir.path(), true));
    let (a, b) = (injected.x_opt["effects[0].c"], injected.x_opt["effects[1].c"]);
    assert!((a - own.x_opt["armFriction"]).abs() < 1e-6, "{a} vs {:?}", own.x_opt);
    assert!((b - own.x_opt["pendulumFriction"]).abs() < 1e-6, "{b} vs {:?}", own.x_opt);
    assert!((injected.f_opt - own.f_opt).abs() <= 1e-6 * own.f_opt, "{} vs {}", injected.f_opt, own.f_opt);
}

#[test]
fn a_sensor_offset_in_the_data_is_calibrated_as_an_effect() {
    let dir = tempfile::tempdir().unwrap();
    let fmu = std::sync::Arc::new(common::load_example("decay", &dir.path().join("cache")));
    let truth = SimSpec { parameters: vec![("k".into(), "1.7".into())], tolerance: Some(1e-10), ..Default::default() };
    let r = simulate(&fmu, &truth).unwrap();
    let mut csv = String::from("time,x\n");
    for (t, x) in r.time.iter().zip(r.column("x").unwrap()).step_by(5) {
        csv.push_str(&format!("{t},{}\n", x + 0.05));
    }
    std::fs::write(dir.path().join("d.csv"), csv).unwrap();
    let toml = common::job_toml(
        &common::example("decay"),
        Some(std::path::Path::new("d.csv")),
        &[("x", "x")],
        &[],
        &[("k", 1.0, 0.1, 5.0)],
        r#"[[effects]]
kind = "sensor_offset"
output = "x"
parameters = { offset = { start = 0.0, lower = -0.2, upper = 0.2 } }
[simulation]
tolerance = 1e-10
[optimizer]
x_tol = 1e-9
f_tol = 1e-16
"#,
    );
    let spec = JobSpec::from_toml(&toml, dir.path()).unwrap();
    let data = MeasurementTable::read(&dir.path().join("d.csv"), "time").unwrap();
    let job = PreparedJob::new(&spec, &fmu.description, &fmu.interfaces(), std::slice::from_ref(&data)).unwrap();
    assert_eq!(job.parameter_names, ["k", "effects[0].offset"]);
    let r = local::calibrate(fmu, std::sync::Arc::new(job), 2, |_| {}).unwrap();
    assert!((r.x_opt["k"] - 1.7).abs() < 1e-5, "{:?}", r.x_opt);
    assert!((r.x_opt["effects[0].offset"] - 0.05).abs() < 1e-6, "{:?}", r.x_opt);
}

#[test]
fn bad_effects_in_a_job_name_the_field() {
    let dir = tempfile::tempdir().unwrap();
    let good = toml::to_string(&furuta_job(dir.path(), true)).unwrap();
    let fmu = furuta(dir.path());
    let data = MeasurementTable::read(
        &std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/furuta/FurutaData.mat"),
        "time",
    )
    .unwrap();
    let cases = [
        ("kind = \"viscous_damping\"", "kind = \"viscous\"", "effects[0].kind: \"viscous\" is not an effect kind"),
        (
            "[effects.parameters.c]",
            "[effects.parameters.cc]",
            "effects[0].parameters: viscous_damping has no parameter \"cc\"",
        ),
        ("port = \"armJoint.tauExt\"\n", "", "effects[0].port: viscous_damping needs a port"),
        (
            "port = \"armJoint.tauExt\"",
            "port = \"armFriction\"",
            "effects[0]: port \"armFriction\" is not a continuous Real input",
        ),
        ("signal = \"armJoint.w\"", "signal = \"armJoint.x\"", "effects[0]: signal \"armJoint.x\" is not a variable"),
        (
            "kind = \"viscous_damping\"",
            "kind = \"sensor_offset\"",
            "effects[0].parameters: sensor_offset has no parameter \"c\"",
        ),
        ("start = 0.012", "start = 0.5", "effects[0].parameters.c.start: start 0.5 is outside [0, 0.022]"),
    ];
    for (from, to, want) in cases {
        assert!(good.contains(from), "{from:?} not in {good}");
        let text = good.replacen(from, to, 1);
        let err = match JobSpec::from_toml(&text, dir.path()) {
            Err(e) => e.to_string(),
            Ok(spec) => PreparedJob::new(&spec, &fmu.description, &fmu.interfaces(), std::slice::from_ref(&data))
                .err()
                .map(|e| e.to_string())
                .unwrap_or_default(),
        };
        assert!(err.starts_with(want), "{want:?} is not the start of {err:?}");
    }
}

/// Writes `time,phi,theta,u` from the hidden-Coulomb Furuta variant driven by the example's
/// motor torque over 10 s: data with an effect the base model's equations lack.
fn hidden_coulomb_data(dir: &std::path::Path) -> std::path::PathBuf {
    let example = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/furuta/FurutaData.mat");
    let measured = MeasurementTable::read(&example, "time").unwrap();
    let u = measured.column("u").unwrap().to_vec();
    let fmu = common::load(&fmucal_models::Fixture::FurutaHiddenCoulomb.path(), &dir.join("cache"));
    let spec = SimSpec {
        stop_time: Some(10.0),
        output_times: Some(OutputTimes::Interval(0.01)),
        inputs: Some(common::table(measured.time.clone(), vec![("u", u.clone())])),
        outputs: OUTPUTS.iter().map(|s| s.to_string()).collect(),
        tolerance: Some(1e-9),
        ..Default::default()
    };
    let r = simulate(&fmu, &spec).unwrap();
    let mut csv = String::from("time,phi,theta,u\n");
    for (i, t) in r.time.iter().enumerate() {
        let k = measured.time.partition_point(|m| m <= t).saturating_sub(1);
        csv.push_str(&format!("{t},{},{},{}\n", r.columns[0][i], r.columns[1][i], u[k]));
    }
    common::write_file(dir, "hidden.csv", csv)
}

#[test]
fn a_coulomb_friction_hidden_in_the_models_c_code_is_recovered_as_an_effect() {
    let dir = tempfile::tempdir().unwrap();
    let data = hidden_coulomb_data(dir.path());
    let job = |effect: &str| {
        let parameters = "[[parameters]]\nname = \"pendulumFriction\"\nstart = 0.003\nlower = 0.0\nupper = 0.012";
        let toml = furuta_toml(
            &data,
            &format!("{parameters}\n{effect}"),
            "stop_time = 10.0\ntolerance = 1e-9",
            "x_tol = 1e-6\nf_tol = 1e-14",
        );
        JobSpec::from_toml(&toml, dir.path()).unwrap()
    };
    let without = calibrate(dir.path(), &job(""));
    let with = calibrate(
        dir.path(),
        &job(
            "[[effects]]\nkind = \"coulomb_friction\"\nport = \"pendulumJoint.tauExt\"\nsignal = \"pendulumJoint.w\"\n\
             parameters = { force = { start = 0.001, lower = 0.0, upper = 0.02 } }",
        ),
    );
    let force = with.x_opt["effects[0].force"];
    assert!((force - 0.004).abs() < 1e-5, "force {force}, {:?}", with.x_opt);
    assert!((with.x_opt["pendulumFriction"] - 0.002).abs() < 1e-5, "{:?}", with.x_opt);
    // The gap shrinks: the base model cannot fit the data, the model with the effect can.
    assert!(with.f_opt < 1e-6 * without.f_opt, "f_opt {} with the effect, {} without", with.f_opt, without.f_opt);
}
