//! `fmucal export`: the exported FMU simulates as fmucal simulates the original with the job's
//! effects (Model Exchange to 1e-9, Co-Simulation over Model Exchange to 1e-6 at rtol 1e-8),
//! FMPy validates and runs it, its effect parameters are ordinary parameters (FMPy's start
//! values, a calibration), and what cannot be exported is refused in one line with no file
//! written.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

use fmucal_models::Fixture;
use fmucal_shared::fmu::Interface;
use fmucal_shared::sim::{InputTable, OutputTimes, SimResult, SimSpec, Simulator, simulate};

const FMUCAL: &str = env!("CARGO_BIN_EXE_fmucal");
const REPO: &str = env!("CARGO_MANIFEST_DIR");

fn fmucal(args: &[&str]) -> std::process::Output {
    Command::new(FMUCAL).args(args).output().unwrap()
}

/// `fmucal export original.toml --result RESULT -o x.fmu` in `dir`.
fn export_result(dir: &Path, result: &Path) -> std::process::Output {
    let job = dir.join("original.toml");
    let out = dir.join("x.fmu");
    fmucal(&["export", job.to_str().unwrap(), "--result", result.to_str().unwrap(), "-o", out.to_str().unwrap()])
}

/// F = 3 sin(t) every 0.05 s over 10 s, with a column `x` of zeros (the export reads the data but
/// not its values).
fn write_data(path: &Path) -> InputTable {
    let time: Vec<f64> = (0..=200).map(|k| k as f64 * 0.05).collect();
    let force: Vec<f64> = time.iter().map(|t| 3.0 * t.sin()).collect();
    let table = common::table(time.clone(), vec![("F", force), ("x", vec![0.0; time.len()])]);
    common::write_input_csv(&table, path);
    common::table(time, vec![("F", table.columns[0].1.clone())])
}

fn spec(interface: Interface, tol: f64, inputs: Option<InputTable>, outputs: &[&str], set: &[(&str, f64)]) -> SimSpec {
    SimSpec {
        interface: Some(interface),
        start_time: Some(0.0),
        stop_time: Some(10.0),
        output_times: Some(OutputTimes::Interval(0.05)),
        inputs,
        outputs: outputs.iter().map(|s| s.to_string()).collect(),
        parameters: set.iter().map(|(n, v)| (n.to_string(), format!("{v}"))).collect(),
        tolerance: Some(tol),
        ..SimSpec::default()
    }
}

fn column<'a>(r: &'a SimResult, name: &str) -> &'a [f64] {
    r.column(name).unwrap_or_else(|| panic!("no column {name} in {:?}", r.names))
}

fn export(dir: &Path, job: &str, out: &str) -> PathBuf {
    let job_path = dir.join(format!("{out}.toml"));
    std::fs::write(&job_path, job).unwrap();
    let fmu = dir.join(out);
    let o = fmucal(&["export", job_path.to_str().unwrap(), "-o", fmu.to_str().unwrap()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stdout).contains("FMI 2.0"), "{}", String::from_utf8_lossy(&o.stdout));
    fmu
}

/// A job on the Furuta pendulum as an FMI 1.0 Co-Simulation FMU fitting armJoint.phi to two
/// zero samples (written to `data`), with `parameters` and then `tables`.
fn fmi1_cs_job(data: &Path, parameters: &[(&str, f64, f64, f64)], tables: &str) -> String {
    common::write_input_csv(&common::table(vec![0.0, 1.0], vec![("phi", vec![0.0, 0.0])]), data);
    common::job_toml(&Fixture::FurutaFmi1Cs.path(), Some(data), &[("armJoint.phi", "phi")], &[], parameters, tables)
}

/// A job on the spring–mass FMU `model` fitting k to mass.x in the data of [`write_data`]
/// (written to `dir/data.csv`), with `inputs` and `effects`; also the force it writes.
fn spring_mass_job_on(dir: &Path, model: &Path, inputs: &[(&str, &str)], effects: &str) -> (String, InputTable) {
    let data = dir.join("data.csv");
    let force = write_data(&data);
    (common::job_toml(model, Some(&data), &[("mass.x", "x")], inputs, &[("k", 5.0, 1.0, 10.0)], effects), force)
}

/// The spring–mass with an input force and an injection port, with a port, a sensor and an
/// actuator effect (a gain of 2).
fn spring_mass_job(dir: &Path) -> (String, InputTable) {
    let effects = include_str!("data/effects/spring_mass_port_sensor_actuator.toml");
    spring_mass_job_on(dir, &Fixture::SpringMass.path(), &[("F", "F")], effects)
}

/// The spring–mass as Dymola exports it (no ports), with two state effects, one with kinks.
fn exported_spring_mass_job(dir: &Path) -> String {
    let effects = include_str!("data/effects/spring_mass_exported_state.toml");
    spring_mass_job_on(dir, &common::example("spring-mass"), &[], effects).0
}

#[test]
fn port_sensor_and_actuator_effects_run_inside_the_exported_model_exchange_fmu() {
    let dir = tempfile::tempdir().unwrap();
    let (job, force) = spring_mass_job(dir.path());
    let fmu = export(dir.path(), &job, "corrected.fmu");
    let exported = common::load(&fmu, &dir.path().join("cache"));
    let names: Vec<&str> = exported.description.variables.iter().map(|v| v.name.as_str()).collect();
    for v in ["effects[0].force", "effects[1].offset", "effects[2].gain", "effects[1].output", "mass.x", "F"] {
        assert!(names.contains(&v), "{v} missing from {names:?}");
    }
    // The calibrated value is the new default.
    let k = exported.description.variable("k").unwrap();
    assert_eq!(k.start, Some(fmucal_shared::fmu::schema::Value::Real(5.0)));

    let original = common::load(&Fixture::SpringMass.path(), &dir.path().join("cache"));
    // The job scales the input's samples, the FMU the value between them: the same numbers
    // to the last bit for a gain of 2.
    let gained = common::table(force.time.clone(), vec![("F", force.columns[0].1.iter().map(|f| 2.0 * f).collect())]);
    let mut with_effects = spec(Interface::ModelExchange, 1e-8, Some(gained), &["mass.x", "mass.v"], &[("k", 5.0)]);
    with_effects.port_terms = vec![common::port_term("coulomb_friction", "mass.Fext", "mass.v", vec![0.4])];
    let want = simulate(&original, &with_effects).unwrap();
    let got = simulate(
        &exported,
        &spec(
            Interface::ModelExchange,
            1e-8,
            Some(force),
            &["mass.x", "mass.v", "effects[1].output", "mass.Fext"],
            &[],
        ),
    )
    .unwrap();
    // The port reads back the value set (its start, 0), not base + friction.
    assert!(column(&got, "mass.Fext").iter().all(|f| *f == 0.0));
    for name in ["mass.x", "mass.v"] {
        let d = common::rel_max_diff(column(&got, name), column(&want, name));
        assert!(d < 1e-9, "{name}: {d:e}");
    }
    let shifted: Vec<f64> = column(&want, "mass.x").iter().map(|x| x + 0.1).collect();
    assert!(common::rel_max_diff(column(&got, "effects[1].output"), &shifted) < 1e-9);
    // An actuated input nobody sets is its start value, transformed: F = 0 through a gain of 2
    // is 0, so an offset shows it; the original sees F = 0.7.
    let offset = job
        .replace("kind = \"actuator_gain\"", "kind = \"actuator_offset\"")
        .replace("gain = {", "offset = {")
        .replace("start = 2.0, lower = 0.5, upper = 3.0", "start = 0.7, lower = 0.0, upper = 3.0");
    let offset = common::load(&export(dir.path(), &offset, "offset.fmu"), &dir.path().join("cache"));
    let mut held = spec(Interface::ModelExchange, 1e-8, None, &["mass.x"], &[("k", 5.0), ("F", 0.7)]);
    held.port_terms = with_effects.port_terms.clone();
    let want_held = simulate(&original, &held).unwrap();
    let got_held = simulate(&offset, &spec(Interface::ModelExchange, 1e-8, None, &["mass.x"], &[])).unwrap();
    assert!(common::rel_max_diff(column(&got_held, "mass.x"), column(&want_held, "mass.x")) < 1e-9);
    // The friction matters: without it the motion differs.
    let plain = simulate(&original, &spec(Interface::ModelExchange, 1e-8, None, &["mass.x"], &[("k", 5.0)])).unwrap();
    assert!(common::rel_max_diff(column(&plain, "mass.x"), column(&want, "mass.x")) > 1e-2);
}

#[test]
fn state_effects_run_inside_both_interfaces_and_instances_are_independent() {
    let dir = tempfile::tempdir().unwrap();
    let fmu = export(dir.path(), &exported_spring_mass_job(dir.path()), "corrected.fmu");
    let exported = common::load(&fmu, &dir.path().join("cache"));
    let original = common::load(&common::example("spring-mass"), &dir.path().join("cache"));
    // The dead zone's two kinks are event indicators of the exported model.
    assert_eq!(exported.description.number_of_event_indicators, original.description.number_of_event_indicators + 2);
    assert_eq!(exported.interfaces(), [Interface::ModelExchange, Interface::CoSimulation]);

    let outputs = ["mass.x", "mass.v", "mass.a"];
    let mut with_effects = spec(Interface::ModelExchange, 1e-8, None, &outputs, &[("k", 5.0)]);
    with_effects.state_terms = vec![
        common::state_term("coulomb_friction", "mass.v", "mass.v", vec![0.05]),
        common::state_term("dead_zone_spring", "mass.v", "mass.x", vec![2.0, 0.3]),
    ];
    let want = simulate(&original, &with_effects).unwrap();
    let me = simulate(&exported, &spec(Interface::ModelExchange, 1e-8, None, &outputs, &[])).unwrap();
    let cs = simulate(&exported, &spec(Interface::CoSimulation, 1e-8, None, &outputs, &[])).unwrap();
    for name in outputs {
        let d = common::rel_max_diff(column(&me, name), column(&want, name));
        assert!(d < 1e-9, "ME {name}: {d:e}");
        let d = common::rel_max_diff(column(&cs, name), column(&want, name));
        assert!(d < 1e-6, "CS {name}: {d:e}");
    }

    // Two live instances of each interface, each run twice (the second after fmi2Reset), agree.
    let mut a = Simulator::new(&exported, Some(Interface::ModelExchange)).unwrap();
    let mut b = Simulator::new(&exported, Some(Interface::ModelExchange)).unwrap();
    let s = spec(Interface::ModelExchange, 1e-8, None, &outputs, &[("effects[0].force", 0.2)]);
    let (a1, b1) = (a.run(&s).unwrap(), b.run(&s).unwrap());
    let a2 = a.run(&spec(Interface::ModelExchange, 1e-8, None, &outputs, &[])).unwrap();
    assert_eq!(a1.columns, b1.columns);
    assert_eq!(a2.columns, me.columns, "after fmi2Reset the exported defaults are back");
    assert_ne!(a1.columns, me.columns, "effects[0].force changes the motion");
    // fmi2DoStep before initialisation is refused, not run on the original.
    let mut raw = fmucal_shared::fmu::Instance::new(&exported, Interface::CoSimulation, "early").unwrap();
    assert!(raw.call("fmi2DoStep", |c| c.do_step(0.0, 0.1)).is_err());
    drop(raw);
    let mut c = Simulator::new(&exported, Some(Interface::CoSimulation)).unwrap();
    let cs_spec = spec(Interface::CoSimulation, 1e-8, None, &outputs, &[]);
    assert_eq!(c.run(&cs_spec).unwrap().columns, cs.columns);
    assert_eq!(c.run(&cs_spec).unwrap().columns, cs.columns);
}

#[test]
fn a_joint_friction_with_its_reaction_runs_inside_the_exported_fmu_and_its_strengths_are_parameters() {
    // The Furuta pendulum as Dymola exports it: a Coulomb friction on the pendulum's
    // acceleration and its reaction on the arm's, both reading the pendulum's velocity.
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("data.csv");
    write_data(&data);
    let job = common::job_toml(
        &Fixture::FurutaExported.path(),
        Some(&data),
        &[("armJoint.phi", "x")],
        &[],
        &[("armFriction", 0.012, 0.0, 0.05)],
        include_str!("data/effects/furuta_exported_reaction.toml"),
    );
    let fmu = export(dir.path(), &job, "corrected.fmu");
    let exported = common::load(&fmu, &dir.path().join("cache"));
    let original = common::load(&Fixture::FurutaExported.path(), &dir.path().join("cache"));
    let md = &exported.description;
    for name in ["effects[0].force", "effects[0].reaction"] {
        let v = md.variable(name).unwrap_or_else(|| panic!("{name} missing"));
        assert_eq!(md.unit_of(v), Some("rad/s2"), "{name}: a strength in der(w)'s unit");
    }
    let outputs = ["armJoint.phi", "pendulumJoint.phi", "armJoint.w", "pendulumJoint.w"];
    let terms = |force: f64, reaction: f64| {
        vec![
            common::state_term("coulomb_friction", "pendulumJoint.w", "pendulumJoint.w", vec![force]),
            common::state_term("coulomb_friction", "armJoint.w", "pendulumJoint.w", vec![reaction]),
        ]
    };
    for (set, (force, reaction)) in [(vec![], (0.8, -0.15)), (vec![("effects[0].reaction", -0.4)], (0.8, -0.4))] {
        let mut want = spec(Interface::ModelExchange, 1e-8, None, &outputs, &[("armFriction", 0.012)]);
        want.state_terms = terms(force, reaction);
        let want = simulate(&original, &want).unwrap();
        let got = simulate(&exported, &spec(Interface::ModelExchange, 1e-8, None, &outputs, &set)).unwrap();
        for name in outputs {
            let d = common::rel_max_diff(column(&got, name), column(&want, name));
            assert!(d < 1e-9, "{set:?} {name}: {d:e}");
        }
    }
    // The reaction moves the arm: without it the arm turns otherwise.
    let mut plain = spec(Interface::ModelExchange, 1e-8, None, &outputs, &[("armFriction", 0.012)]);
    plain.state_terms = terms(0.8, 0.0);
    let plain = simulate(&original, &plain).unwrap();
    let me = simulate(&exported, &spec(Interface::ModelExchange, 1e-8, None, &outputs, &[])).unwrap();
    let moved = common::rel_max_diff(column(&me, "armJoint.phi"), column(&plain, "armJoint.phi"));
    assert!(moved > 1e-3, "the reaction moves the arm by {moved:e} only");
}

#[test]
fn a_co_simulation_only_original_exports_co_simulation_with_its_port_effect() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("data.csv");
    let time: Vec<f64> = (0..=100).map(|k| k as f64 * 0.1).collect();
    let table =
        common::table(time.clone(), vec![("u", time.iter().map(|t| 0.1 * t.sin()).collect()), ("phi", vec![0.0; 101])]);
    common::write_input_csv(&table, &data);
    let job = common::job_toml(
        &Fixture::FurutaFmi1Cs.path(),
        Some(&data),
        &[("armJoint.phi", "phi")],
        &[("u", "u")],
        &[("armFriction", 0.02, 0.0, 0.1)],
        "[[effects]]\nkind = \"viscous_damping\"\nport = \"pendulumJoint.tauExt\"\nsignal = \"pendulumJoint.w\"\nparameters = { c = { start = 0.01, lower = 0.0, upper = 1.0 } }\n\
         [[effects]]\nkind = \"sensor_gain\"\noutput = \"armJoint.phi\"\nparameters = { gain = { start = 1.25, lower = 0.5, upper = 2.0 } }\n",
    );
    let fmu = export(dir.path(), &job, "corrected.fmu");
    let exported = common::load(&fmu, &dir.path().join("cache"));
    assert_eq!(exported.description.fmi_version, "2.0");
    assert_eq!(exported.interfaces(), [Interface::CoSimulation]);
    let original = common::load(&Fixture::FurutaFmi1Cs.path(), &dir.path().join("cache"));
    let inputs = common::table(time, vec![("u", table.columns[0].1.clone())]);
    let outputs = ["armJoint.phi", "pendulumJoint.phi"];
    let mut s = SimSpec {
        stop_time: Some(10.0),
        output_times: Some(OutputTimes::Interval(0.1)),
        ..spec(Interface::CoSimulation, 1e-8, Some(inputs.clone()), &outputs, &[("armFriction", 0.02)])
    };
    s.port_terms = vec![common::port_term("viscous_damping", "pendulumJoint.tauExt", "pendulumJoint.w", vec![0.01])];
    let want = simulate(&original, &s).unwrap();
    let mut plain = SimSpec { port_terms: vec![], parameters: vec![], ..s.clone() };
    plain.outputs.push("effects[1].output".into());
    let got = simulate(&exported, &plain).unwrap();
    for name in outputs {
        let d = common::rel_max_diff(column(&got, name), column(&want, name));
        assert!(d < 1e-9, "{name}: {d:e}");
    }
    let gained: Vec<f64> = column(&want, "armJoint.phi").iter().map(|x| 1.25 * x).collect();
    assert!(common::rel_max_diff(column(&got, "effects[1].output"), &gained) < 1e-12);
}

#[test]
fn fmpy_validates_and_runs_the_exported_fmu_as_fmucal_does() {
    let dir = tempfile::tempdir().unwrap();
    let job = exported_spring_mass_job(dir.path());
    let fmu = export(dir.path(), &job, "corrected.fmu");
    // The same job with another friction: FMPy's start value must give its trajectory.
    let stronger = export(dir.path(), &job.replace("start = 0.05", "start = 0.2"), "stronger.fmu");
    // Two more shapes for validate_fmu: an original with an input, a port, a sensor and an
    // actuator effect; an FMI 1.0 Co-Simulation original.
    let (ports, _) = spring_mass_job(dir.path());
    let ports = export(dir.path(), &ports, "ports.fmu");
    let fmi1 = fmi1_cs_job(&dir.path().join("phi.csv"), &[("armFriction", 0.02, 0.0, 0.1)], "");
    let fmi1 = export(dir.path(), &fmi1, "fmi1.fmu");
    let exported = common::load(&fmu, &dir.path().join("cache"));
    let outputs = ["mass.x", "mass.v"];
    let mut refs = vec![];
    for (interface, tag) in [(Interface::ModelExchange, "ME"), (Interface::CoSimulation, "CS")] {
        let r = simulate(
            &exported,
            &SimSpec { output_times: Some(OutputTimes::Interval(0.01)), ..spec(interface, 1e-8, None, &outputs, &[]) },
        )
        .unwrap();
        let csv = dir.path().join(format!("fmucal_{tag}.csv"));
        let mut text = String::from("time,mass.x,mass.v\n");
        for (i, t) in r.time.iter().enumerate() {
            text.push_str(&format!("{t},{},{}\n", r.columns[0][i], r.columns[1][i]));
        }
        std::fs::write(&csv, text).unwrap();
        refs.push(csv);
    }
    let script = Path::new(REPO).join("tests/fmpy/exported.py");
    let o = Command::new(common::fmpy_python())
        .arg(&script)
        .args([&fmu, &stronger, &refs[0], &refs[1], &ports, &fmi1])
        .output()
        .unwrap();
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{out}\n{}", String::from_utf8_lossy(&o.stderr));
    assert!(out.contains("valid: no problem"), "{out}");
    assert!(out.contains("start value: same as the job"), "{out}");
}

#[test]
fn calibrating_the_exported_fmu_reproduces_the_job() {
    let dir = tempfile::tempdir().unwrap();
    let data = Path::new(REPO).join("examples/friction/data.csv");
    let tables = "[simulation]\nstop_time = 15.0\ntolerance = 1e-8\ntolerance_guard = false\n[optimizer]\nx_tol = 1e-6\nf_tol = 1e-12\n";
    let effect = "[[effects]]\nkind = \"coulomb_friction\"\nstate = \"mass.v\"\nparameters = { force = { start = 0.03, lower = 0.0, upper = 0.2 } }\n";
    let job = common::job_toml(
        &common::example("spring-mass"),
        Some(&data),
        &[("mass.x", "x")],
        &[],
        &[("k", 3.5, 0.5, 10.0), ("d", 0.4, 0.0, 2.0)],
        &format!("{effect}{tables}"),
    );
    let fmu = export(dir.path(), &job, "corrected.fmu");
    let plain = common::job_toml(
        &fmu,
        Some(&data),
        &[("mass.x", "x")],
        &[],
        &[("k", 3.5, 0.5, 10.0), ("d", 0.4, 0.0, 2.0), ("effects[0].force", 0.03, 0.0, 0.2)],
        tables,
    );
    let mut f_opt = vec![];
    for (name, text) in [("original", &job), ("exported", &plain)] {
        let path = dir.path().join(format!("{name}.toml"));
        std::fs::write(&path, text).unwrap();
        let out = dir.path().join(name);
        let o = fmucal(&["calibrate", path.to_str().unwrap(), "--out", out.to_str().unwrap(), "--workers", "2"]);
        assert!(o.status.success(), "{name}: {}", String::from_utf8_lossy(&o.stderr));
        let result: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("result.json")).unwrap()).unwrap();
        f_opt.push(result["f_opt"].as_f64().unwrap());
    }
    assert!((f_opt[0] - f_opt[1]).abs() <= 1e-6 * f_opt[0], "{f_opt:?}");

    // A result of a job with other parameters is refused.
    let other = dir.path().join("other");
    std::fs::create_dir(&other).unwrap();
    for f in ["result.json", "fit.csv"] {
        let text = std::fs::read_to_string(dir.path().join("original").join(f)).unwrap();
        std::fs::write(other.join(f), text.replace("\"k\"", "\"spring.k\"")).unwrap();
    }
    let o = export_result(dir.path(), &other);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("--result") && err.contains("another job"), "{err}");
    // A value outside the job's bounds is refused.
    let text = std::fs::read_to_string(dir.path().join("original/result.json")).unwrap();
    let mut v: serde_json::Value = serde_json::from_str(&text).unwrap();
    v["x_opt"]["k"] = serde_json::json!(1e308);
    std::fs::write(other.join("result.json"), v.to_string()).unwrap();
    let o = export_result(dir.path(), &other);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("outside the job's bounds"), "{err}");
    // With the original's own result, its values become the defaults.
    let o = export_result(dir.path(), &dir.path().join("original"));
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

#[test]
fn what_cannot_be_exported_is_refused_in_one_line_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let (job, _) = spring_mass_job(dir.path());
    let cases = [
        (
            job.replace("kind = \"sensor_offset\"", "kind = \"sensor_lag\"").replace("offset = {", "time_constant = {"),
            "effects[1].kind: sensor_lag cannot be exported",
        ),
        (job.replace(&format!("path = \"{}\"", Fixture::SpringMass.path().display()), "path = \"OUT\""), "-o:"),
    ];
    for (k, (text, want)) in cases.iter().enumerate() {
        let out = dir.path().join(format!("bad{k}.fmu"));
        let text = text.replace("OUT", out.to_str().unwrap());
        if want.starts_with("-o") {
            std::fs::copy(Fixture::SpringMass.path(), &out).unwrap();
        }
        let before = std::fs::read(&out).ok();
        let path = dir.path().join(format!("bad{k}.toml"));
        std::fs::write(&path, text).unwrap();
        let o = fmucal(&["export", path.to_str().unwrap(), "-o", out.to_str().unwrap()]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "case {k} succeeded");
        assert_eq!(err.trim().lines().count(), 1, "{err}");
        assert!(err.contains(want), "case {k}: {err}");
        assert_eq!(std::fs::read(&out).ok(), before, "case {k} touched {}", out.display());
    }
    // `-o` onto the job's data (not an .fmu name) leaves it as it was.
    let data_path = dir.path().join("data.csv");
    let before = std::fs::read(&data_path).unwrap();
    let path = dir.path().join("good.toml");
    std::fs::write(&path, &job).unwrap();
    let o = fmucal(&["export", path.to_str().unwrap(), "-o", data_path.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("-o:") && err.contains(".fmu"), "{err}");
    assert_eq!(std::fs::read(&data_path).unwrap(), before);
    // A state effect on a Co-Simulation-only original.
    let job = fmi1_cs_job(
        &dir.path().join("d.csv"),
        &[],
        "[[effects]]\nkind = \"viscous_damping\"\nstate = \"pendulumJoint.w\"\nparameters = { c = { start = 0.01, lower = 0.0, upper = 1.0 } }\n",
    );
    let path = dir.path().join("cs.toml");
    std::fs::write(&path, job).unwrap();
    let out = dir.path().join("cs.fmu");
    let o = fmucal(&["export", path.to_str().unwrap(), "-o", out.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.trim().lines().count() == 1 && err.contains("Co-Simulation only"), "{err}");
    assert!(!out.exists());
}
