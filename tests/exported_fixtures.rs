//! The exported-shape fixtures (`fmucal_models::Fixture::*Exported*`): the spring–mass, Furuta
//! and exhaust pipe models described as Dymola exports them for FMI 2.0, without injection ports
//! (`der(x)` an alias of the velocity state, `declaredType`s, `dependencies`), and hidden-effect
//! variants of them, some outside fmucal's effect kinds. Checked here:
//!
//! - each simulates in FMPy 0.3.32 (Model Exchange, its validation on) and fmucal's
//!   `sim::simulate` agrees with it on every output to 1e-4 of the output's range (CVode and
//!   fmucal's BDF, both at rtol 1e-8; the smoothed frictions, tanh(v/1e-3), are the stiffest);
//! - each exported base simulates exactly as the ported base it was described from (the
//!   description changed, the physics did not): SpringMass with `mass.x` started at 0.5 and
//!   `mass.Fext` = 0, with and without a driving force, Furuta and ExhaustPipe as they are;
//! - each hidden variant changes its base's outputs by the amount its doc comment states
//!   (largest over the outputs of max |Δy| / range(y), within 1 percentage point), inside the
//!   band 2 % to 40 %; the sensor offset changes `mass.x` by exactly 0.05 and nothing else;
//! - SpringMassExported's description has the exported shape: `der(mass.x)` shares `mass.v`'s
//!   value reference, `mass.a` shares `der(mass.v)`'s, the only input in N is `F`.

mod common;

use std::path::Path;
use std::process::Command;

use fmucal_models::Fixture;
use fmucal_shared::fmu::schema::Causality;
use fmucal_shared::fmu::{Fmu, Interface};
use fmucal_shared::sim::{InputTable, OutputTimes, SimResult, SimSpec, simulate};

/// Agreement of fmucal with FMPy, relative to each output's range.
const FMPY_BOUND: f64 = 1e-4;

/// (fixture, its exported base, outputs, stop time, output interval, stated change in % or
/// `None` for a base).
struct Case {
    fixture: Fixture,
    base: Fixture,
    outputs: &'static [&'static str],
    stop: f64,
    dt: f64,
    change: Option<f64>,
}

const SPRING: &[&str] = &["mass.x", "mass.v", "mass.a"];
const FURUTA: &[&str] = &["armJoint.phi", "pendulumJoint.phi"];
const EXHAUST: &[&str] = &["outlet.T"];

fn spring(fixture: Fixture, change: Option<f64>) -> Case {
    Case { fixture, base: Fixture::SpringMassExported, outputs: SPRING, stop: 20.0, dt: 0.01, change }
}

fn cases() -> Vec<Case> {
    vec![
        spring(Fixture::SpringMassExported, None),
        spring(Fixture::SpringMassExportedHiddenCoulomb, Some(10.6)),
        spring(Fixture::SpringMassExportedHiddenStribeck, Some(13.4)),
        spring(Fixture::SpringMassExportedHiddenViscous, Some(11.6)),
        spring(Fixture::SpringMassExportedHiddenQuadraticDrag, Some(13.5)),
        spring(Fixture::SpringMassExportedHiddenCubic, Some(7.9)),
        spring(Fixture::SpringMassExportedHiddenSensorOffset, Some(5.6)),
        spring(Fixture::SpringMassExportedDriftingStiffness, Some(16.4)),
        spring(Fixture::SpringMassExportedPeriodicForce, Some(12.4)),
        spring(Fixture::SpringMassExportedOneSidedFriction, Some(11.8)),
        spring(Fixture::SpringMassExportedGrowingMass, Some(15.9)),
        Case {
            fixture: Fixture::FurutaExported,
            base: Fixture::FurutaExported,
            outputs: FURUTA,
            stop: 40.0,
            dt: 0.01,
            change: None,
        },
        Case {
            fixture: Fixture::FurutaExportedHiddenCoulomb,
            base: Fixture::FurutaExported,
            outputs: FURUTA,
            stop: 40.0,
            dt: 0.01,
            change: Some(14.9),
        },
        Case {
            fixture: Fixture::ExhaustPipeExported,
            base: Fixture::ExhaustPipeExported,
            outputs: EXHAUST,
            stop: 1800.0,
            dt: 1.0,
            change: None,
        },
        Case {
            fixture: Fixture::ExhaustPipeExportedHiddenRadiation,
            base: Fixture::ExhaustPipeExported,
            outputs: EXHAUST,
            stop: 1800.0,
            dt: 1.0,
            change: Some(15.9),
        },
    ]
}

fn load(f: Fixture, dir: &Path) -> Fmu {
    common::load(&f.path(), &dir.join("cache"))
}

fn name(f: Fixture) -> String {
    f.path().file_stem().unwrap().to_string_lossy().into_owned()
}

/// Model Exchange at rtol 1e-8 from 0 to `stop`, reporting `outputs` every `dt`.
fn spec(stop: f64, dt: f64, outputs: &[&str]) -> SimSpec {
    SimSpec {
        interface: Some(Interface::ModelExchange),
        start_time: Some(0.0),
        stop_time: Some(stop),
        output_times: Some(OutputTimes::Interval(dt)),
        outputs: outputs.iter().map(|s| s.to_string()).collect(),
        tolerance: Some(1e-8),
        ..Default::default()
    }
}

fn run(f: Fixture, case: &Case, dir: &Path) -> SimResult {
    simulate(&load(f, dir), &spec(case.stop, case.dt, case.outputs))
        .unwrap_or_else(|e| panic!("fmucal simulating {}: {e}", name(f)))
}

fn max_abs_diff(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len(), "series lengths differ");
    a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max)
}

fn range(a: &[f64]) -> f64 {
    a.iter().fold(f64::NEG_INFINITY, |m, v| m.max(*v)) - a.iter().fold(f64::INFINITY, |m, v| m.min(*v))
}

/// FMPy's Model Exchange run of `case.fixture` (validated), as (header, rows).
fn fmpy(case: &Case, dir: &Path) -> (Vec<String>, Vec<Vec<f64>>) {
    let out = dir.join(format!("fmpy-{}.csv", name(case.fixture)));
    let mut cmd = Command::new(common::fmpy_python());
    cmd.arg(Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fmpy/simulate.py"))
        .args(["--fmu", case.fixture.path().to_str().unwrap(), "--interface", "me", "--rtol", "1e-8"])
        .args(["--interval", &case.dt.to_string(), "--stop", &case.stop.to_string()])
        .args(["--out", out.to_str().unwrap()]);
    for o in case.outputs {
        cmd.args(["--output", o]);
    }
    let status = cmd.output().unwrap();
    assert!(status.status.success(), "FMPy on {}: {}", name(case.fixture), String::from_utf8_lossy(&status.stderr));
    let text = std::fs::read_to_string(&out).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap().split(',').map(str::to_owned).collect();
    let rows = lines.map(|l| l.split(',').map(|v| v.parse().unwrap()).collect()).collect();
    (header, rows)
}

#[test]
fn every_exported_fixture_simulates_in_fmpy_and_fmucal_agrees() {
    let dir = tempfile::tempdir().unwrap();
    for case in cases() {
        let ours = run(case.fixture, &case, dir.path());
        let (header, rows) = fmpy(&case, dir.path());
        assert_eq!(rows.len(), ours.time.len(), "{}: FMPy and fmucal report different grids", name(case.fixture));
        for (row, t) in rows.iter().zip(&ours.time) {
            assert!((row[0] - t).abs() < 1e-9, "{}: FMPy's time {} vs fmucal's {t}", name(case.fixture), row[0]);
        }
        for o in case.outputs {
            let k = header.iter().position(|h| h == o).unwrap_or_else(|| panic!("FMPy did not record {o}"));
            let theirs: Vec<f64> = rows.iter().map(|r| r[k]).collect();
            let d = max_abs_diff(ours.column(o).unwrap(), &theirs) / range(&theirs);
            println!("{:<40} {o:<18} fmucal vs FMPy: max |diff| / range {d:.2e}", name(case.fixture));
            assert!(d <= FMPY_BOUND, "{}: {o} differs from FMPy's by {d:e} of its range", name(case.fixture));
        }
    }
}

/// F = 3 sin(t) N every 10 ms over 20 s.
fn spring_force() -> InputTable {
    let time: Vec<f64> = (0..=2000).map(|k| k as f64 * 0.01).collect();
    let force = time.iter().map(|t| 3.0 * t.sin()).collect();
    common::table(time, vec![("F", force)])
}

fn assert_same_outputs(a: &SimResult, b: &SimResult, outputs: &[&str], what: &str) {
    assert_eq!(a.time, b.time, "{what}: different grids");
    for o in outputs {
        let d = max_abs_diff(a.column(o).unwrap(), b.column(o).unwrap());
        println!("{what:<44} {o:<18} max |diff| {d:e}");
        assert!(d <= 1e-12, "{what}: {o} differs by {d:e}");
    }
}

#[test]
fn exported_bases_simulate_exactly_as_the_ported_bases() {
    let dir = tempfile::tempdir().unwrap();
    let cache = dir.path().join("cache");
    // SpringMass: mass.x started at 0.5 (the exported build's start), mass.Fext left at 0.
    let ported = common::load(&Fixture::SpringMass.path(), &cache);
    let exported = load(Fixture::SpringMassExported, dir.path());
    let outputs = ["mass.x", "mass.v", "der(mass.v)"];
    for (label, inputs) in [("F = 0", None), ("F = 3 sin(t)", Some(spring_force()))] {
        let s = SimSpec { inputs: inputs.clone(), ..spec(20.0, 0.01, &outputs) };
        let old = simulate(
            &ported,
            &SimSpec {
                parameters: vec![("mass.x".into(), "0.5".into()), ("mass.Fext".into(), "0".into())],
                ..s.clone()
            },
        )
        .unwrap();
        let new = simulate(&exported, &s).unwrap();
        assert_same_outputs(&new, &old, &outputs, &format!("SpringMassExported vs SpringMass, {label}"));
        let a = SimSpec { outputs: vec!["mass.a".into(), "der(mass.v)".into()], ..s };
        let new = simulate(&exported, &a).unwrap();
        assert_eq!(new.column("mass.a"), new.column("der(mass.v)"), "mass.a is der(mass.v)'s alias");
    }
    let furuta = common::load_example("furuta", &cache);
    let s = spec(40.0, 0.01, FURUTA);
    let old = simulate(&furuta, &s).unwrap();
    let new = simulate(&load(Fixture::FurutaExported, dir.path()), &s).unwrap();
    assert_same_outputs(&new, &old, FURUTA, "FurutaExported vs Furuta");
    let exhaust = common::load_example("exhaust-pipe", &cache);
    let s = spec(1800.0, 1.0, &["outlet.T", "rightVolume.T"]);
    let old = simulate(&exhaust, &s).unwrap();
    let new = simulate(&load(Fixture::ExhaustPipeExported, dir.path()), &s).unwrap();
    assert_same_outputs(&new, &old, &["outlet.T", "rightVolume.T"], "ExhaustPipeExported vs ExhaustPipe");
    assert_eq!(new.column("outlet.T"), new.column("rightVolume.T"), "outlet.T is rightVolume.T's alias");
}

#[test]
fn each_hidden_variant_changes_its_base_by_the_stated_amount() {
    let dir = tempfile::tempdir().unwrap();
    for case in cases() {
        let Some(stated) = case.change else { continue };
        let (hidden, base) = (run(case.fixture, &case, dir.path()), run(case.base, &case, dir.path()));
        let change = case
            .outputs
            .iter()
            .map(|o| {
                let b = base.column(o).unwrap();
                max_abs_diff(hidden.column(o).unwrap(), b) / range(b)
            })
            .fold(0.0, f64::max);
        println!("{:<40} changes its base by {:.1} % (stated {stated} %)", name(case.fixture), 100.0 * change);
        assert!((0.02..=0.40).contains(&change), "{}: change {change} outside 2 %..40 %", name(case.fixture));
        assert!(
            (100.0 * change - stated).abs() <= 1.0,
            "{}: change {:.2} %, stated {stated} %",
            name(case.fixture),
            100.0 * change
        );
        if case.fixture == Fixture::SpringMassExportedHiddenSensorOffset {
            let shifted: Vec<f64> = base.column("mass.x").unwrap().iter().map(|x| x + 0.05).collect();
            assert!(max_abs_diff(hidden.column("mass.x").unwrap(), &shifted) < 1e-12);
            for o in ["mass.v", "mass.a"] {
                assert_eq!(hidden.column(o), base.column(o), "the sensor offset changes {o}");
            }
        }
    }
}

#[test]
fn spring_mass_exported_has_the_exported_shape() {
    let dir = tempfile::tempdir().unwrap();
    let fmu = load(Fixture::SpringMassExported, dir.path());
    let md = &fmu.description;
    let var = |n: &str| md.variable(n).unwrap_or_else(|| panic!("no variable {n}"));
    assert_eq!(var("der(mass.x)").value_reference, var("mass.v").value_reference);
    assert_eq!(var("mass.a").value_reference, var("der(mass.v)").value_reference);
    assert_ne!(var("mass.x").value_reference, var("mass.v").value_reference);
    let states: Vec<(&str, &str)> = md.states().iter().map(|(s, d)| (s.name.as_str(), d.name.as_str())).collect();
    assert_eq!(states, [("mass.x", "der(mass.x)"), ("mass.v", "der(mass.v)")]);
    assert_eq!(md.unit_of(var("mass.x")), Some("m"));
    assert_eq!(md.unit_of(var("mass.v")), Some("m/s"));
    let outputs: Vec<&str> = md.outputs().iter().map(|v| v.name.as_str()).collect();
    assert_eq!(outputs, ["mass.x", "mass.v", "mass.a"]);
    let forces: Vec<&str> = md
        .variables
        .iter()
        .filter(|v| v.causality == Causality::Input && md.unit_of(v) == Some("N"))
        .map(|v| v.name.as_str())
        .collect();
    assert_eq!(forces, ["F"], "the only force input is the driving force");
    assert!(md.variable("mass.Fext").is_none());
    assert!(md.variables.iter().all(|v| v.value_reference != 5), "the port's value reference is undeclared");
    // The other exported bases declare no injection port either.
    for (f, ports, driving) in [
        (Fixture::FurutaExported, &["armJoint.tauExt", "pendulumJoint.tauExt"][..], &["u"][..]),
        (
            Fixture::ExhaustPipeExported,
            &["rightVolume.wallQext"][..],
            &["inlet.T", "inlet.p", "turbine1.w", "turbine2.w", "outlet.p"][..],
        ),
    ] {
        let fmu = load(f, dir.path());
        for p in ports {
            assert!(fmu.description.variable(p).is_none(), "{} declares {p}", name(f));
        }
        let inputs: Vec<&str> = fmu
            .description
            .variables
            .iter()
            .filter(|v| v.causality == Causality::Input)
            .map(|v| v.name.as_str())
            .collect();
        assert_eq!(inputs, driving, "{}: the inputs are the measured driving inputs only", name(f));
    }
}
