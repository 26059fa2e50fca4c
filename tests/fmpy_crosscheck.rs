//! Cross-checks against Python references (FMPy and SciPy, installed from PyPI into a venv by
//! `tests/fmpy/ensure_venv.sh`). MATLAB v5 files written by SciPy's `savemat` are read back.
//! FMPy:
//! every example and conformance fixture FMU, the FMI 3.0 builds of Furuta, the bouncing ball,
//! Robertson and the array-parameter model, and the FMI 1.0 ME and CS builds of the first three,
//! passes FMPy's validation, and FMPy and fmucal
//! simulate it to the same outputs and states, ending at the same time: Model Exchange at rtol
//! 1e-8 to 1e-4 relative, Co-Simulation at the same communication step to 1e-9. "Relative" is
//! the largest difference over the grid divided by the largest magnitude of the FMPy result.
//!
//! Inputs of every kind are covered (continuous Real, discrete Real, Integer, Boolean). FMPy's
//! Model Exchange driver holds continuous inputs constant between output points, while fmucal
//! interpolates them inside each step; for ME with continuous inputs the comparison with FMPy
//! runs on a fine grid (1 ms) with a bound that allows for FMPy's hold, and the tight reference
//! is analytic or fmucal at a thousandth of the step (`fmi2_conformance.rs`).

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

use fmucal_shared::fmu::Interface;
use fmucal_shared::fmu::schema::{ModelDescription, VarType};
use fmucal_shared::sim::{InputTable, OutputTimes, SimSpec, csv_io, simulate};

struct Case<'a> {
    fmu: PathBuf,
    interface: Interface,
    interval: f64,
    stop: f64,
    input: Option<&'a Path>,
    /// Start values, NAME=VALUE.
    set: &'a [(&'a str, &'a str)],
}

impl Case<'_> {
    fn new(fmu: PathBuf, interface: Interface, interval: f64, stop: f64) -> Case<'static> {
        Case { fmu, interface, interval, stop, input: None, set: &[] }
    }

    fn example(model: &str, interface: Interface, interval: f64, stop: f64) -> Case<'static> {
        Case::new(common::example(model), interface, interval, stop)
    }

    fn label(&self) -> String {
        format!("{} {:?}", self.fmu.file_stem().unwrap().to_string_lossy(), self.interface)
    }
}

fn fmpy(case: &Case, variables: &[String], dir: &Path) -> InputTable {
    let out = dir.join(format!("fmpy-{}.csv", case.label().replace(' ', "-")));
    let mut cmd = Command::new(common::fmpy_python());
    cmd.arg(Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fmpy/simulate.py"))
        .args(["--fmu", case.fmu.to_str().unwrap()])
        .args(["--interface", if case.interface == Interface::ModelExchange { "me" } else { "cs" }])
        .args(["--rtol", "1e-8", "--interval", &case.interval.to_string(), "--stop", &case.stop.to_string()])
        .args(["--out", out.to_str().unwrap()]);
    for v in variables {
        cmd.args(["--output", v]);
    }
    for (name, value) in case.set {
        cmd.args(["--set", &format!("{name}={value}")]);
    }
    if let Some(input) = case.input {
        cmd.args(["--input", input.to_str().unwrap()]);
    }
    let run = cmd.output().unwrap();
    assert!(run.status.success(), "FMPy on {}: {}", case.label(), String::from_utf8_lossy(&run.stderr));
    csv_io::read_table(&out).unwrap()
}

/// What a cross-check compares: the outputs and the continuous states (a model without
/// outputs is still checked, and states catch what outputs may hide).
fn compared_variables(md: &ModelDescription) -> Vec<String> {
    let mut names: Vec<String> =
        md.outputs().into_iter().filter(|v| v.var_type != VarType::String).map(|v| v.name.clone()).collect();
    for (state, _) in md.states() {
        if !names.contains(&state.name) {
            names.push(state.name.clone());
        }
    }
    names
}

/// Simulates `case` with fmucal and FMPy and returns the largest relative difference over the
/// compared variables. Fails if the runs end at different times or their grids differ. FMPy
/// rows off fmucal's grid (it also records at input events in Co-Simulation) are left out,
/// after the end times are compared.
fn compare(case: &Case, dir: &Path) -> f64 {
    let fmu = common::load(&case.fmu, &dir.join("cache"));
    let variables = compared_variables(&fmu.description);
    let spec = SimSpec {
        interface: Some(case.interface),
        stop_time: Some(case.stop),
        output_times: Some(OutputTimes::Interval(case.interval)),
        tolerance: Some(1e-8),
        inputs: case.input.map(|p| csv_io::read_table(p).unwrap()),
        parameters: case.set.iter().map(|(n, v)| (n.to_string(), v.to_string())).collect(),
        outputs: variables.clone(),
        ..Default::default()
    };
    let ours = simulate(&fmu, &spec).unwrap();
    let theirs = fmpy(case, &variables, dir);
    let (ours_end, theirs_end) = (*ours.time.last().unwrap(), *theirs.time.last().unwrap());
    assert!((ours_end - theirs_end).abs() < 1e-9, "{}: fmucal ends at {ours_end}, FMPy at {theirs_end}", case.label());
    let rows: Vec<usize> = ours
        .time
        .iter()
        .map(|t| {
            theirs.time.iter().position(|x| (x - t).abs() < 1e-9).unwrap_or_else(|| {
                panic!("{}: FMPy has no row at t={t}", case.label());
            })
        })
        .collect();
    let mut worst = 0.0f64;
    for (i, name) in ours.names.iter().enumerate() {
        let theirs: Vec<f64> = rows.iter().map(|&r| theirs.columns[i].1[r]).collect();
        let d = common::rel_max_diff(&ours.columns[i], &theirs);
        println!("{:<28} {name:<22} relative difference {d:.2e}", case.label());
        worst = worst.max(d);
    }
    worst
}

/// Writes `table` as `dir/name` for both simulators to read.
fn input_file(dir: &Path, name: &str, table: &InputTable) -> PathBuf {
    let path = dir.join(name);
    common::write_input_csv(table, &path);
    path
}

fn check(case: Case, bound: f64, dir: &Path) {
    let d = compare(&case, dir);
    assert!(d <= bound, "{}: fmucal and FMPy differ by {d:e} > {bound:e}", case.label());
}

/// A staircase torque on the arm and a pulse on the pendulum, written with repeated time stamps
/// at each step. FMPy holds continuous inputs constant between communication points during
/// Model Exchange integration while fmucal interpolates linearly inside each step; on a
/// piecewise-constant signal both semantics agree, so the comparison checks input plumbing
/// (jumps handled as events) rather than that design difference.
fn torque_profile(dir: &Path) -> PathBuf {
    let level = |k: usize| (0.05 * (0.05 * k as f64).sin(), if (100..150).contains(&k) { 0.01 } else { 0.0 });
    let mut text = String::from("time,u,pendulumJoint.tauExt\n");
    let (u0, p0) = level(0);
    text.push_str(&format!("0,{u0},{p0}\n"));
    for k in 1..=400 {
        let t = k as f64 / 10.0;
        let (ua, pa) = level(k - 1);
        let (ub, pb) = level(k);
        text.push_str(&format!("{t},{ua},{pa}\n{t},{ub},{pb}\n"));
    }
    common::write_file(dir, "torque.csv", text)
}

#[test]
fn every_example_matches_fmpy_in_both_interfaces() {
    let tmp = tempfile::tempdir().unwrap();
    let examples = [
        ("furuta", 0.01, 40.0),
        ("bouncing-ball", 0.01, 3.0),
        ("decay", 0.01, 2.0),
        ("robertson", 0.1, 40.0),
        ("exhaust-pipe", 1.0, 1800.0),
    ];
    for (model, interval, stop) in examples {
        for (interface, bound) in [(Interface::ModelExchange, 1e-4), (Interface::CoSimulation, 1e-9)] {
            check(Case::example(model, interface, interval, stop), bound, tmp.path());
        }
    }
}

#[test]
fn fmi3_builds_match_fmpy_in_both_interfaces() {
    let tmp = tempfile::tempdir().unwrap();
    let fixtures = [
        (fmucal_models::Fixture::FurutaFmi3, 0.01, 40.0),
        (fmucal_models::Fixture::BouncingBallFmi3, 0.01, 3.0),
        (fmucal_models::Fixture::RobertsonFmi3, 0.1, 40.0),
        (fmucal_models::Fixture::ArrayParamsFmi3, 0.01, 10.0),
    ];
    for (fixture, interval, stop) in fixtures {
        for (interface, bound) in [(Interface::ModelExchange, 1e-4), (Interface::CoSimulation, 1e-9)] {
            check(Case::new(fixture.path(), interface, interval, stop), bound, tmp.path());
        }
    }
}

#[test]
fn fmi1_builds_match_fmpy() {
    use fmucal_models::Fixture;
    let tmp = tempfile::tempdir().unwrap();
    let (me, cs) = ((Interface::ModelExchange, 1e-4), (Interface::CoSimulation, 1e-9));
    let fixtures = [
        (Fixture::FurutaFmi1Me, me, 0.01, 40.0),
        (Fixture::FurutaFmi1Cs, cs, 0.01, 40.0),
        (Fixture::BouncingBallFmi1Me, me, 0.01, 3.0),
        (Fixture::BouncingBallFmi1Cs, cs, 0.01, 3.0),
        (Fixture::RobertsonFmi1Me, me, 0.1, 40.0),
        (Fixture::RobertsonFmi1Cs, cs, 0.1, 40.0),
    ];
    for (fixture, (interface, bound), interval, stop) in fixtures {
        check(Case::new(fixture.path(), interface, interval, stop), bound, tmp.path());
    }
}

/// FMPy alone, on each pair of builds of one C source: the FMI 1.0 and 3.0 FMUs simulate as the
/// FMI 2.0 one does (`tests/fmpy/compare_versions.py`: ME to 1e-6, CS to 1e-9, with inputs and start
/// values, arrays included), so what fmucal is compared with above is the same model.
#[test]
fn fmpy_simulates_the_fmi1_and_fmi3_builds_as_the_fmi2_builds() {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fmpy/compare_versions.py");
    let fmus = fmucal_models::fmu_dir();
    let out =
        Command::new(common::fmpy_python()).arg(&script).args(["--fmu-dir", fmus.to_str().unwrap()]).output().unwrap();
    println!("{}", String::from_utf8_lossy(&out.stdout));
    assert!(out.status.success(), "{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
}

#[test]
fn inputs_are_applied_as_fmpy_applies_them() {
    let tmp = tempfile::tempdir().unwrap();
    let input = torque_profile(tmp.path());
    for (interface, bound) in [(Interface::ModelExchange, 1e-4), (Interface::CoSimulation, 1e-9)] {
        check(Case { input: Some(&input), ..Case::example("furuta", interface, 0.01, 40.0) }, bound, tmp.path());
    }
}

/// Checks `fmu` driven by `inputs` (written to `file`) up to `stop`: in Co-Simulation every
/// 0.01 s, at the same communication points and with the same held values, to round-off; in
/// Model Exchange on a 1 ms grid to `me_bound`, since FMPy holds continuous inputs over each
/// output interval there while fmucal interpolates them.
fn check_driven(fmu: PathBuf, inputs: &InputTable, file: &str, stop: f64, me_bound: f64) {
    let tmp = tempfile::tempdir().unwrap();
    let input = input_file(tmp.path(), file, inputs);
    let case = |interface, interval| Case { input: Some(&input), ..Case::new(fmu.clone(), interface, interval, stop) };
    check(case(Interface::CoSimulation, 0.01), 1e-9, tmp.path());
    check(case(Interface::ModelExchange, 1e-3), me_bound, tmp.path());
}

#[test]
fn inputs_of_every_kind_are_applied_as_fmpy_applies_them() {
    // x differs by about |uc'| · 1 ms · t / 2 in Model Exchange (analytic check of fmucal in
    // fmi2_conformance.rs).
    check_driven(fmucal_models::Fixture::InputKinds.path(), &common::every_kind_of_input(), "kinds.csv", 4.0, 1e-3);
}

#[test]
fn stick_slip_friction_matches_fmpy() {
    // Stick and slip times move by up to the 1 ms output interval in Model Exchange.
    check_driven(fmucal_models::Fixture::StickSlip.path(), &common::sine_force(), "force.csv", 20.0, 2e-3);
}

#[test]
fn a_model_without_states_matches_fmpy_in_co_simulation() {
    let tmp = tempfile::tempdir().unwrap();
    let u = common::table(vec![0.0, 1.0, 1.205, 1.41, 3.0], vec![("u", vec![0.0, 0.0, 2.0, 0.0, 0.0])]);
    let input = input_file(tmp.path(), "u.csv", &u);
    // Model Exchange is checked against the analytic switch times in fmi2_conformance.rs: FMPy
    // holds u between output points there, which moves the switches to output points.
    let case = Case::new(fmucal_models::Fixture::Threshold.path(), Interface::CoSimulation, 0.01, 3.0);
    check(Case { input: Some(&input), ..case }, 1e-9, tmp.path());
}

#[test]
fn tool_style_derivative_attributes_match_fmpy() {
    let tmp = tempfile::tempdir().unwrap();
    for (interface, bound) in [(Interface::ModelExchange, 1e-4), (Interface::CoSimulation, 1e-9)] {
        check(Case::new(fmucal_models::Fixture::DerivativeAttributes.path(), interface, 0.01, 3.0), bound, tmp.path());
    }
}

#[test]
fn a_terminating_fmu_ends_where_fmpy_ends() {
    let tmp = tempfile::tempdir().unwrap();
    let set = [("terminateTime", "0.555")];
    // CS: the last row is at fmi2LastSuccessfulTime (0.555); ME: at the last output time.
    for (interface, bound) in [(Interface::ModelExchange, 1e-4), (Interface::CoSimulation, 1e-9)] {
        check(Case { set: &set, ..Case::example("decay", interface, 0.1, 1.0) }, bound, tmp.path());
    }
}

#[test]
fn an_unreachable_package_registry_is_one_clear_line() {
    let tmp = tempfile::tempdir().unwrap();
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fmpy/ensure_venv.sh");
    // A registry on a loopback port where nothing listens, and no local wheels.
    let out = Command::new("bash")
        .arg(&script)
        .env("FMUCAL_PYENV", tmp.path().join("venv"))
        .env("PIP_INDEX_URL", "http://127.0.0.1:9/simple")
        .env("PIP_FIND_LINKS", tmp.path())
        .env("PIP_RETRIES", "0")
        .env("PIP_DEFAULT_TIMEOUT", "2")
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
    assert!(
        stderr.contains("cannot install") && stderr.contains("fmpy==0.3.32") && stderr.contains("PyPI"),
        "{stderr}"
    );
    assert!(!tmp.path().join("venv").exists(), "a half-made venv is left behind");
}

#[test]
fn matlab_v5_files_written_by_scipy_are_read() {
    let dir = tempfile::tempdir().unwrap();
    let mat = dir.path().join("FurutaData.mat");
    let script = format!(
        "import numpy as np, scipy.io\nt = np.linspace(0, 1, 11)\nscipy.io.savemat(r'{}', {{'time': t.reshape(-1, 1), 'phi': np.sin(t).reshape(-1, 1), 'theta': np.cos(t).reshape(-1, 1)}})\n",
        mat.display()
    );
    let run = Command::new(common::fmpy_python()).args(["-c", &script]).output().unwrap();
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let table = fmucal_shared::job::MeasurementTable::read(&mat, "time").unwrap();
    assert_eq!(table.time.len(), 11);
    assert!((table.time[10] - 1.0).abs() < 1e-15);
    let phi = table.column("phi").unwrap();
    let theta = table.column("theta").unwrap();
    for (i, t) in table.time.iter().enumerate() {
        assert!((phi[i] - t.sin()).abs() < 1e-15 && (theta[i] - t.cos()).abs() < 1e-15);
    }
}
