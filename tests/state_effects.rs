//! State effects (Model Exchange): a term added to a continuous state's derivative equals the
//! same term on an injection port where the port enters that one derivative through a
//! constant (force/mass, heat flow/capacity), and reaches the outputs that are the derivative.

mod common;

use std::path::Path;

use common::{port_term, state_term};
use fmucal_models::Fixture;
use fmucal_shared::fmu::{Fmu, Interface};
use fmucal_shared::sim::{InputTable, PortTerm, SimError, SimResult, SimSpec, StateTerm, simulate};

fn spec(stop: f64, dt: f64, inputs: InputTable, outputs: &[&str], set: &[(&str, &str)]) -> SimSpec {
    SimSpec {
        parameters: set.iter().map(|(n, v)| (n.to_string(), v.to_string())).collect(),
        ..common::model_exchange_spec(stop, dt, inputs, outputs)
    }
}

fn max_abs_diff(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max)
}

/// Simulates `base` with `on_port` injected on a port, with `on_state` on a state, and with
/// neither: the two terms must give the same `outputs`, and the output `moved` must be far from
/// where it is without them. Returns the runs with the port term and with the state term.
fn port_and_state_terms_agree(
    fmu: &Fmu,
    base: &SimSpec,
    on_port: PortTerm,
    on_state: StateTerm,
    outputs: &[&str],
    moved: &str,
) -> (SimResult, SimResult) {
    let with_port = SimSpec { port_terms: vec![on_port], ..base.clone() };
    let with_state = SimSpec { state_terms: vec![on_state], ..base.clone() };
    let (on_port, on_state, without) =
        (simulate(fmu, &with_port).unwrap(), simulate(fmu, &with_state).unwrap(), simulate(fmu, base).unwrap());
    assert_eq!(on_port.time, on_state.time);
    for name in outputs {
        let d = max_abs_diff(on_port.column(name).unwrap(), on_state.column(name).unwrap());
        println!("{name}: state term vs port term: max |diff| {d:e}");
        assert!(d < 1e-6, "{name}: the state term differs from the port term by {d:e}");
    }
    // The effect matters: without it the output is far from both.
    let d = max_abs_diff(on_port.column(moved).unwrap(), without.column(moved).unwrap());
    assert!(d > 1e-2, "{moved}: the effect moves it by only {d:e}");
    (on_port, on_state)
}

/// [`port_and_state_terms_agree`] on the spring–mass with `set`, under [`common::spring_force`]
/// for 20 s: the term `kind` reading `signal`, with `port_parameters` on the force port and
/// `state_parameters` on der(mass.v), moves mass.x.
fn spring_mass_terms_agree(
    set: &[(&str, &str)],
    outputs: &[&str],
    kind: &str,
    signal: &str,
    port_parameters: Vec<f64>,
    state_parameters: Vec<f64>,
) -> (SimResult, SimResult) {
    let dir = tempfile::tempdir().unwrap();
    let fmu = common::fixture(Fixture::SpringMass, dir.path());
    let base = spec(20.0, 0.01, common::spring_force(), outputs, set);
    let on_port = port_term(kind, "mass.Fext", signal, port_parameters);
    let on_state = state_term(kind, "mass.v", signal, state_parameters);
    port_and_state_terms_agree(&fmu, &base, on_port, on_state, outputs, "mass.x")
}

#[test]
fn coulomb_friction_on_der_v_equals_the_force_over_the_mass_on_the_force_port() {
    // m = 2 kg, so the state term's strength (an acceleration) is F/m.
    let (force, mass) = (0.3, 2.0);
    // der(mass.v) is recorded too: an output that is the derivative carries the term.
    let outputs = ["mass.x", "mass.v", "der(mass.v)"];
    spring_mass_terms_agree(&[("m", "2")], &outputs, "coulomb_friction", "mass.v", vec![force], vec![force / mass]);
}

#[test]
fn a_spring_on_der_v_reads_the_position_and_equals_the_port_spring() {
    spring_mass_terms_agree(&[("m", "2")], &["mass.x", "mass.v"], "cubic_spring", "mass.x", vec![0.6], vec![0.3]);
}

#[test]
fn a_dead_zone_on_a_state_stops_the_integrator_at_its_edges_as_on_the_port() {
    let (p, s) = spring_mass_terms_agree(
        &[],
        &["mass.x", "mass.v"],
        "dead_zone_spring",
        "mass.x",
        vec![3.0, 0.4],
        vec![3.0, 0.4],
    );
    // The kinks are events of both.
    assert_eq!(p.stats.events, s.stats.events);
    assert!(s.stats.events > 0);
}

#[test]
fn radiation_on_der_t_equals_the_heat_flow_over_the_capacity_on_the_heat_port() {
    let dir = tempfile::tempdir().unwrap();
    let fmu = common::load_example("exhaust-pipe", &dir.path().join("cache"));
    let capacity = 12_000.0;
    let outputs = ["outlet.T", "rightVolume.wallT"];
    let base = spec(1800.0, 1.0, common::exhaust_inputs(), &outputs, &[("rightVolume.wallCapacity", "12000")]);
    let on_port = port_term("radiation", "rightVolume.wallQext", "rightVolume.wallT", vec![0.2, 293.15]);
    let on_state = state_term("radiation", "rightVolume.wallT", "rightVolume.wallT", vec![0.2 / capacity, 293.15]);
    port_and_state_terms_agree(&fmu, &base, on_port, on_state, &outputs, "outlet.T");
}

#[test]
fn a_generic_relaxation_follows_its_closed_form_on_a_state_without_dynamics_of_its_own() {
    // SpringMass at rest with k = 0, d = 0, F = 0: der(v) = 0, so a relaxation −r·(v − v₀)
    // on der(v) gives v(t) = v₀ + (v(0) − v₀)·e^{−r t}.
    let dir = tempfile::tempdir().unwrap();
    let fmu = common::fixture(Fixture::SpringMass, dir.path());
    let time: Vec<f64> = vec![0.0, 5.0];
    let zero = common::table(time, vec![("F", vec![0.0, 0.0])]);
    let s = SimSpec {
        state_terms: vec![state_term("linear_relaxation", "mass.v", "mass.v", vec![0.7, 0.5])],
        tolerance: Some(1e-12),
        ..spec(5.0, 0.05, zero, &["mass.v"], &[("k", "0"), ("d", "0"), ("mass.v", "2")])
    };
    let r = simulate(&fmu, &s).unwrap();
    for (t, v) in r.time.iter().zip(r.column("mass.v").unwrap()) {
        let want = 0.5 + 1.5 * (-0.7 * t).exp();
        assert!((v - want).abs() < 1e-7, "t = {t}: {v} vs {want}");
    }
}

#[test]
fn bad_state_terms_are_refused_before_any_model_code_runs() {
    let dir = tempfile::tempdir().unwrap();
    let fmu = common::fixture(Fixture::SpringMass, dir.path());
    let base = spec(1.0, 0.1, common::spring_force(), &["mass.x"], &[]);
    let refused = |t: StateTerm, interface: Interface| -> String {
        let s = SimSpec { state_terms: vec![t], interface: Some(interface), ..base.clone() };
        match simulate(&fmu, &s) {
            Err(SimError::Invalid(m)) => m,
            other => panic!("accepted: {:?}", other.map(|r| r.time.len())),
        }
    };
    let m = refused(state_term("viscous_damping", "m", "mass.v", vec![1.0]), Interface::ModelExchange);
    assert!(
        m.starts_with("state \"m\" is not a continuous state of the model (its states: \"mass.x, mass.v\")"),
        "{m}"
    );
    let m = refused(state_term("viscous_damping", "mass.v", "F", vec![1.0]), Interface::ModelExchange);
    assert!(m.starts_with("signal \"F\" is not a continuous state"), "{m}");
    let m = refused(state_term("viscous_damping", "mass.v", "mass.v", vec![1.0]), Interface::CoSimulation);
    assert!(m.starts_with("state effects need Model Exchange"), "{m}");
    let m = refused(state_term("sensor_offset", "mass.v", "mass.v", vec![1.0]), Interface::ModelExchange);
    assert!(m.contains("changes a measured series"), "{m}");
    let m = refused(state_term("viscous_damping", "mass.v", "mass.v", vec![1.0, 2.0]), Interface::ModelExchange);
    assert!(m.starts_with("viscous_damping takes 1 parameters"), "{m}");
}

/// `fmucal calibrate` on a job on `model` that fits `parameter` to data for `output` and whose
/// one effect is `effect` (TOML lines); returns whether it succeeded, and its standard error.
fn calibrate_with(model: &Path, output: &str, parameter: &str, effect: &str, dir: &Path) -> (bool, String) {
    let rows: String = (0..=20).map(|k| format!("{},{}\n", k as f64 * 0.1, 0.5 - 0.01 * k as f64)).collect();
    std::fs::write(dir.join("data.csv"), format!("time,y\n{rows}")).unwrap();
    let job = format!(
        "[model]\npath = {model:?}\n[data]\npath = \"data.csv\"\n[[outputs]]\nvariable = \"{output}\"\ncolumn = \"y\"\n\
         [[parameters]]\nname = \"{parameter}\"\nstart = 4.0\nlower = 0.0\nupper = 8.0\n[[effects]]\n{effect}\n"
    );
    std::fs::write(dir.join("job.toml"), job).unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_fmucal"))
        .args(["calibrate", "--workers", "1", "--out"])
        .arg(dir.join("out"))
        .arg(dir.join("job.toml"))
        .output()
        .unwrap();
    (out.status.success(), String::from_utf8_lossy(&out.stderr).into_owned())
}

#[test]
fn bad_state_effects_in_a_job_are_one_line_naming_the_field() {
    let dir = tempfile::tempdir().unwrap();
    let spring = Fixture::SpringMassExported.path();
    let c = r#"parameters = { force = { start = 0.0, lower = 0.0, upper = 1.0 } }"#;
    let cr = r#"parameters = { force = { start = 0.0, lower = 0.0, upper = 1.0 }, reaction = { start = 0.0, lower = -1.0, upper = 1.0 } }"#;
    let cases = [
        (
            format!("kind = \"coulomb_friction\"\nstate = \"k\"\n{c}"),
            "effects[0].state: \"k\" is not a continuous state of the model (its states: \"mass.x, mass.v\")",
        ),
        (
            format!("kind = \"coulomb_friction\"\nstate = \"mass.v\"\nport = \"F\"\nsignal = \"mass.v\"\n{c}"),
            "effects[0].state: give a port or a state, not both",
        ),
        (
            "kind = \"radiation\"\nstate = \"mass.v\"\nparameters = { emissivity_area = { start = 0.0, lower = 0.0, upper = 1.0 }, t_ambient = { start = 293.0, lower = 200.0, upper = 400.0 } }".to_owned(),
            "effects[0].kind: radiation acts on a temperature; state \"mass.v\" is a translational velocity (m/s)",
        ),
        (
            "kind = \"linear_relaxation\"\nport = \"F\"\nsignal = \"mass.v\"\nparameters = { k = { start = 0.0, lower = 0.0, upper = 1.0 }, x0 = { start = 0.0, lower = -1.0, upper = 1.0 } }".to_owned(),
            "effects[0].state: linear_relaxation needs a state",
        ),
        (
            format!("kind = \"coulomb_friction\"\nstate = \"mass.x\"\n{c}"),
            "effects[0].kind: coulomb_friction acts on a velocity; state \"mass.x\" is a translational position (m)",
        ),
        (
            format!("kind = \"coulomb_friction\"\nstate = \"mass.v\"\nreaction = \"mass.x\"\n{cr}"),
            "effects[0].reaction: a reaction acts on a velocity; state \"mass.x\" is a translational position (m)",
        ),
        (
            format!("kind = \"coulomb_friction\"\nstate = \"mass.v\"\nreaction = \"k\"\n{cr}"),
            "effects[0].reaction: \"k\" is not a continuous state of the model",
        ),
        (
            format!("kind = \"coulomb_friction\"\nstate = \"mass.v\"\nreaction = \"mass.v\"\n{cr}"),
            "effects[0].reaction: \"mass.v\" is the effect's own state",
        ),
        (
            format!("kind = \"coulomb_friction\"\nport = \"F\"\nsignal = \"mass.v\"\nreaction = \"mass.v\"\n{cr}"),
            "effects[0].reaction: a reaction is a second state's derivative: give the effect a state first",
        ),
        (
            "kind = \"stribeck_friction\"\nstate = \"mass.v\"\nreaction = \"mass.v\"\nparameters = { coulomb = { start = 0.0, lower = 0.0, upper = 1.0 }, static = { start = 0.0, lower = 0.0, upper = 1.0 }, stribeck_velocity = { start = 0.1, lower = 0.01, upper = 1.0 }, reaction = { start = 0.0, lower = -1.0, upper = 1.0 } }".to_owned(),
            "effects[0].reaction: stribeck_friction has two strengths",
        ),
        (
            format!("kind = \"coulomb_friction\"\nstate = \"mass.v\"\nreaction = \"mass.x\"\n{c}"),
            "effects[0].parameters: coulomb_friction with a reaction state needs parameter \"reaction\"",
        ),
        (
            "kind = \"constant_rate\"\nstate = \"mass.v\"\nreaction = \"mass.x\"\nparameters = { rate = { start = 0.0, lower = 0.0, upper = 1.0 }, reaction = { start = 0.0, lower = -1.0, upper = 1.0 } }".to_owned(),
            "effects[0].reaction: constant_rate is not mechanical",
        ),
        (
            // Dymola's der(mass.x) is another name of the velocity mass.v itself.
            format!("kind = \"coulomb_friction\"\nstate = \"mass.v\"\nreaction = \"der(mass.x)\"\n{cr}"),
            "effects[0].reaction: \"der(mass.x)\" is the effect's own state \"mass.v\"",
        ),
        (
            format!("kind = \"coulomb_friction\"\nstate = \"mass.v\"\n{cr}"),
            "effects[0].parameters: coulomb_friction has a parameter \"reaction\" only with a reaction state",
        ),
    ];
    for (effect, want) in cases {
        let (ok, err) = calibrate_with(&spring, "mass.x", "k", &effect, dir.path());
        assert!(!ok, "accepted:\n{effect}");
        assert_eq!(err.lines().filter(|l| !l.trim().is_empty()).count(), 1, "one line: {err}");
        assert!(err.contains(want), "{effect}\n→ {err}\nwanted {want}");
    }
    // A Co-Simulation-only FMU has no state effects.
    let (ok, err) = calibrate_with(
        &Fixture::FurutaFmi1Cs.path(),
        "armJoint.phi",
        "armFriction",
        "kind = \"viscous_damping\"\nstate = \"armJoint.w\"\nparameters = { c = { start = 0.0, lower = 0.0, upper = 1.0 } }",
        dir.path(),
    );
    assert!(!ok && err.contains("effects[0].state: the FMU offers Co-Simulation only"), "{err}");
}

#[test]
fn a_reaction_adds_the_same_term_at_its_own_strength_to_the_coupled_velocity() {
    // The Furuta pendulum as Dymola exports it: pendulumJoint.w and armJoint.w are coupled
    // (each derivative depends on the other velocity), which the structure reports.
    let dir = tempfile::tempdir().unwrap();
    let fmu = common::fixture(Fixture::FurutaExported, dir.path());
    let structure = fmucal_shared::structure::Structure::read(&fmu.description, &[]);
    assert_eq!(structure.state("pendulumJoint.w").unwrap().coupled, ["armJoint.w"]);
    assert_eq!(structure.state("armJoint.w").unwrap().coupled, ["pendulumJoint.w"]);
    assert!(structure.state("armJoint.phi").unwrap().coupled.is_empty(), "positions are not coupled");

    let rows: String = (0..=20).map(|k| format!("{},{}\n", k as f64 * 0.1, 0.0)).collect();
    let data_path = dir.path().join("data.csv");
    std::fs::write(&data_path, format!("time,y\n{rows}")).unwrap();
    let text = format!(
        "[model]\npath = {:?}\n[data]\npath = {:?}\n[[outputs]]\nvariable = \"armJoint.phi\"\ncolumn = \"y\"\n\
         [[parameters]]\nname = \"armFriction\"\nstart = 0.012\nlower = 0.0\nupper = 0.05\n[[effects]]\n\
         kind = \"quadratic_drag\"\nstate = \"pendulumJoint.w\"\nreaction = \"armJoint.w\"\n\
         parameters = {{ c = {{ start = 0.5, lower = 0.0, upper = 1.0 }}, reaction = {{ start = -0.1, lower = -1.0, upper = 1.0 }} }}\n",
        Fixture::FurutaExported.path(),
        data_path
    );
    let job = fmucal_shared::job::JobSpec::from_toml(&text, dir.path()).unwrap();
    assert_eq!(job.parameter_vectors().0, ["armFriction", "effects[0].c", "effects[0].reaction"]);
    let data = fmucal_shared::job::MeasurementTable::read(&data_path, "time").unwrap();
    let prepared =
        fmucal_shared::job::PreparedJob::new(&job, &fmu.description, &fmu.interfaces(), std::slice::from_ref(&data))
            .unwrap();
    let sim = prepared.single().sim_spec(&[0.012, 0.7, -0.2]);
    assert_eq!(
        sim.state_terms,
        [
            state_term("quadratic_drag", "pendulumJoint.w", "pendulumJoint.w", vec![0.7]),
            state_term("quadratic_drag", "armJoint.w", "pendulumJoint.w", vec![-0.2]),
        ]
    );
    // The arm's acceleration gets −(−0.2)·w|w| of the pendulum's velocity: against the same
    // simulation without the reaction, the arm moves otherwise.
    let outputs = ["armJoint.phi"];
    let mut with = spec(2.0, 0.01, common::table(vec![0.0, 2.0], vec![]), &outputs, &[]);
    with.state_terms = sim.state_terms.clone();
    let mut without = with.clone();
    without.state_terms.truncate(1);
    let (a, b) = (simulate(&fmu, &with).unwrap(), simulate(&fmu, &without).unwrap());
    assert!(max_abs_diff(a.column("armJoint.phi").unwrap(), b.column("armJoint.phi").unwrap()) > 1e-4);
}
