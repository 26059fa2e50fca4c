//! FMUs as exporting tools write them, simulated with the `fmucal` binary and with FMPy 0.3.32
//! (from the venv of `tests/fmpy/ensure_venv.sh`, through `tests/fmpy/simulate.py`), which must
//! agree: Model Exchange to 1e-4 relative (different integrators at rtol 1e-8), Co-Simulation to
//! 1e-9 (the FMU's own integrator at the same communication points). The fixtures are built from
//! the project's C sources by `models/build.rs`, each shaped after the Modelica Reference FMUs'
//! descriptions or the FMI standard's examples:
//!
//! - aliases in every position (an output, a state, a state derivative, a parameter, an input)
//!   in FMI 3.0 (`<Alias>` children), 2.0 (variables sharing a value reference) and 1.0
//!   (`alias="alias"` and `alias="negatedAlias"`): recorded, set and fed as their base
//!   variables, and listed by `inspect --json` with the base they stand for;
//! - String and Binary variables with start values (`<Start value=…/>` in FMI 3.0, a Binary
//!   start in hexadecimal): loaded, listed, settable, and changing a numeric output as FMPy's
//!   start values do; a String output cannot be recorded in a CSV of numbers;
//! - an FMI 3.0 array output sized by a structural parameter, recorded by its own name as its
//!   elements `y[1]`, `y[2]`, `y[3]` (FMPy keeps the array in one field);
//! - a Co-Simulation counter that asks to terminate at t = 9 and refuses to go on: the run ends
//!   there, without an error, as FMPy's does;
//! - a calibration whose output, input, parameter and effect port and signal are named by
//!   aliases gives the very result of the same job named by the base variables.
//!
//! "Relative" is the largest difference over the grid divided by the largest magnitude of the
//! reference series.

mod common;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use fmucal_models::Fixture;

/// Model Exchange: fmucal's BDF against FMPy's CVode, both at rtol 1e-8.
const ME_BOUND: f64 = 1e-4;
/// Co-Simulation: the FMU's own integrator, the same communication points.
const CS_BOUND: f64 = 1e-9;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Iface {
    Me,
    Cs,
}

impl Iface {
    fn arg(self) -> &'static str {
        match self {
            Iface::Me => "me",
            Iface::Cs => "cs",
        }
    }

    fn bound(self) -> f64 {
        match self {
            Iface::Me => ME_BOUND,
            Iface::Cs => CS_BOUND,
        }
    }
}

/// A CSV result: a `time` column, then one column per variable.
#[derive(Debug)]
struct Table {
    names: Vec<String>,
    time: Vec<f64>,
    columns: Vec<Vec<f64>>,
}

impl Table {
    fn read(path: &Path) -> Table {
        let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let mut lines = text.lines().filter(|l| !l.trim().is_empty());
        let header = split_csv(lines.next().unwrap_or_else(|| panic!("{}: empty", path.display())));
        assert_eq!(header[0], "time", "{}: first column {:?}", path.display(), header[0]);
        let mut time = vec![];
        let mut columns = vec![vec![]; header.len() - 1];
        for line in lines {
            let cells = split_csv(line);
            assert_eq!(cells.len(), header.len(), "{}: row {line:?}", path.display());
            let num = |c: &str| c.trim().parse::<f64>().unwrap_or_else(|_| panic!("{}: cell {c:?}", path.display()));
            time.push(num(&cells[0]));
            for (col, cell) in columns.iter_mut().zip(&cells[1..]) {
                col.push(num(cell));
            }
        }
        Table { names: header[1..].to_vec(), time, columns }
    }

    fn col(&self, name: &str) -> &[f64] {
        let i = self.names.iter().position(|n| n == name);
        &self.columns[i.unwrap_or_else(|| panic!("no column {name:?} in {:?}", self.names))]
    }

    /// The column `name` at the rows whose times are `times` (every one must be there).
    fn at(&self, name: &str, times: &[f64]) -> Vec<f64> {
        let col = self.col(name);
        times
            .iter()
            .map(|t| {
                let r = self.time.iter().position(|x| (x - t).abs() < 1e-9);
                col[r.unwrap_or_else(|| panic!("no row at t={t} for {name}"))]
            })
            .collect()
    }
}

/// One CSV line's cells (double-quoted cells may hold commas and doubled quotes).
fn split_csv(line: &str) -> Vec<String> {
    let mut cells = vec![String::new()];
    let mut quoted = false;
    let mut chars = line.chars().peekable();
    while let Some(c) = chars.next() {
        match c {
            '"' if quoted && chars.peek() == Some(&'"') => {
                chars.next();
                cells.last_mut().unwrap().push('"');
            }
            '"' => quoted = !quoted,
            ',' if !quoted => cells.push(String::new()),
            _ => cells.last_mut().unwrap().push(c),
        }
    }
    cells
}

/// Largest |a − b| over the grid, relative to the largest |b|.
fn rel_diff(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len(), "series lengths differ");
    let scale = b.iter().fold(0.0f64, |m, v| m.max(v.abs())).max(1e-300);
    a.iter().zip(b).fold(0.0f64, |m, (x, y)| m.max((x - y).abs())) / scale
}

fn fmucal(args: &[&str], dir: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_fmucal")).args(args).env("FMUCAL_CACHE_DIR", dir.join("cache")).output().unwrap()
}

/// What one simulation asks for, in both tools' terms.
#[derive(Clone)]
struct Run<'a> {
    fmu: PathBuf,
    iface: Iface,
    stop: f64,
    interval: f64,
    /// `--output` names (none: each tool's default outputs).
    outputs: &'a [&'a str],
    /// NAME=VALUE start values.
    set: &'a [(&'a str, &'a str)],
    /// An input CSV (`time`, then one column per input).
    input: Option<&'a Path>,
}

impl Run<'_> {
    /// `fmu` through `iface` to `stop`, sampled every `interval`: its default outputs, no start
    /// values and no input.
    fn new(fmu: PathBuf, iface: Iface, stop: f64, interval: f64) -> Self {
        Run { fmu, iface, stop, interval, outputs: &[], set: &[], input: None }
    }

    fn tag(&self) -> String {
        format!("{} {:?}", self.fmu.file_stem().unwrap().to_string_lossy(), self.iface)
    }
}

/// `fmucal simulate` of `run`; the raw process output and, if it succeeded, the table.
fn try_fmucal(run: &Run, dir: &Path, label: &str) -> (Output, Option<Table>) {
    let out_csv = dir.join(format!("fmucal-{}-{label}.csv", run.tag().replace(' ', "-")));
    let stop = run.stop.to_string();
    let interval = run.interval.to_string();
    let mut args: Vec<String> = vec![
        "simulate".into(),
        run.fmu.to_str().unwrap().into(),
        "--interface".into(),
        run.iface.arg().into(),
        "--stop-time".into(),
        stop,
        "--output-interval".into(),
        interval,
        "--tolerance".into(),
        "1e-8".into(),
        "-o".into(),
        out_csv.to_str().unwrap().into(),
    ];
    for o in run.outputs {
        args.extend(["--output".into(), o.to_string()]);
    }
    for (n, v) in run.set {
        args.extend(["--set".into(), format!("{n}={v}")]);
    }
    if let Some(input) = run.input {
        args.extend(["--input".into(), input.to_str().unwrap().into()]);
    }
    let refs: Vec<&str> = args.iter().map(String::as_str).collect();
    let out = fmucal(&refs, dir);
    let table = out.status.success().then(|| Table::read(&out_csv));
    (out, table)
}

fn simulate_fmucal(run: &Run, dir: &Path, label: &str) -> Table {
    let (out, table) = try_fmucal(run, dir, label);
    table.unwrap_or_else(|| {
        panic!("fmucal simulate {} ({label}) failed: {}", run.tag(), String::from_utf8_lossy(&out.stderr).trim())
    })
}

/// FMPy 0.3.32 on `run`; `text` are String or Binary (hex) start values, passed unconverted.
fn simulate_fmpy(run: &Run, text: &[(&str, &str)], dir: &Path, label: &str) -> Table {
    let out_csv = dir.join(format!("fmpy-{}-{label}.csv", run.tag().replace(' ', "-")));
    let mut cmd = Command::new(common::fmpy_python());
    cmd.arg(Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fmpy/simulate.py"))
        .args(["--fmu", run.fmu.to_str().unwrap(), "--interface", run.iface.arg()])
        .args(["--rtol", "1e-8", "--interval", &run.interval.to_string(), "--stop", &run.stop.to_string()])
        .args(["--out", out_csv.to_str().unwrap()]);
    for o in run.outputs {
        cmd.args(["--output", o]);
    }
    for (n, v) in run.set {
        cmd.args(["--set", &format!("{n}={v}")]);
    }
    for (n, v) in text {
        cmd.args(["--set-text", &format!("{n}={v}")]);
    }
    if let Some(input) = run.input {
        cmd.args(["--input", input.to_str().unwrap()]);
    }
    let out = cmd.output().unwrap();
    assert!(out.status.success(), "FMPy on {} ({label}): {}", run.tag(), String::from_utf8_lossy(&out.stderr));
    Table::read(&out_csv)
}

/// Asserts that `ours[ours_name]` matches `theirs[their_name]` on fmucal's grid, within the
/// interface's bound, after checking that both runs end at the same time.
fn assert_matches(ours: &Table, ours_name: &str, theirs: &Table, their_name: &str, iface: Iface, what: &str) {
    let (a, b) = (ours.time.last().unwrap(), theirs.time.last().unwrap());
    assert!((a - b).abs() < 1e-9, "{what}: fmucal ends at {a}, FMPy at {b}");
    let reference = theirs.at(their_name, &ours.time);
    let d = rel_diff(ours.col(ours_name), &reference);
    println!("{what:<48} {ours_name:<26} vs FMPy {their_name:<22} relative difference {d:.2e}");
    assert!(d <= iface.bound(), "{what}: {ours_name} differs from FMPy's {their_name} by {d:e} > {:e}", iface.bound());
}

/// Asserts that two columns of one fmucal run are the same series (an alias and its base share
/// one value reference, so they are equal, not close).
fn assert_same(t: &Table, a: &str, b: &str, sign: f64, what: &str) {
    let (x, y) = (t.col(a), t.col(b));
    let d = x.iter().zip(y).fold(0.0f64, |m, (p, q)| m.max((p - sign * q).abs()));
    assert!(d == 0.0, "{what}: {a} differs from {}{b} by up to {d:e}", if sign < 0.0 { "-" } else { "" });
}

/// A staircase torque (levels held 0.5 s, each jump written as two rows at the same time), so
/// that FMPy's held inputs and fmucal's interpolated ones are the same signal.
fn torque_csv(dir: &Path, column: &str) -> PathBuf {
    let level = |k: usize| 0.02 * (0.7 * k as f64).sin();
    let mut text = format!("time,{column}\n0,{}\n", level(0));
    for k in 1..=20 {
        let t = k as f64 * 0.5;
        text.push_str(&format!("{t},{}\n{t},{}\n", level(k - 1), level(k)));
    }
    common::write_file(dir, format!("torque-{column}.csv"), text)
}

/// `fmucal inspect --json` of `fmu`: its `variables`.
fn inspect_variables(fmu: &Path, dir: &Path) -> Vec<serde_json::Value> {
    let out = fmucal(&["inspect", "--json", fmu.to_str().unwrap()], dir);
    assert!(out.status.success(), "inspect {}: {}", fmu.display(), String::from_utf8_lossy(&out.stderr));
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    json["variables"].as_array().unwrap_or_else(|| panic!("no variables array in {json}")).clone()
}

fn variable<'a>(vars: &'a [serde_json::Value], name: &str, fmu: &Path) -> &'a serde_json::Value {
    vars.iter()
        .find(|v| v["name"] == name)
        .unwrap_or_else(|| panic!("inspect --json of {} does not list {name:?}", fmu.display()))
}

// ---- aliases ---------------------------------------------------------------------------------

/// (alias, base) of the alias fixtures: an output, a state that is not an output, a state
/// derivative, a parameter and an input, in every version.
const ALIASES: &[(&str, &str)] = &[
    ("armAngleSensor.phi", "armJoint.phi"),
    ("pendulumSpeedSensor.w", "pendulumJoint.w"),
    ("der(armAngleSensor.phi)", "der(armJoint.phi)"),
    ("armBearing.d", "armFriction"),
    ("motor.tau", "u"),
];

/// The alias fixtures and the interfaces each offers (an FMI 1.0 FMU offers one).
fn alias_fixtures() -> [(Fixture, &'static [Iface]); 3] {
    [
        (Fixture::FurutaAliasesFmi3, &[Iface::Me, Iface::Cs]),
        (Fixture::FurutaAliases, &[Iface::Me, Iface::Cs]),
        (Fixture::FurutaAliasesFmi1Me, &[Iface::Me]),
    ]
}

#[test]
fn alias_outputs_follow_their_base_variables_as_in_fmpy() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let recorded = ["armAngleSensor.phi", "pendulumSpeedSensor.w", "der(armAngleSensor.phi)", "armJoint.phi"];
    for (fixture, ifaces) in alias_fixtures() {
        for &iface in ifaces {
            let run = Run { outputs: &recorded, ..Run::new(fixture.path(), iface, 10.0, 0.01) };
            let what = run.tag();
            let ours = simulate_fmucal(&run, d, "outputs");
            assert_same(&ours, "armAngleSensor.phi", "armJoint.phi", 1.0, &what);
            // The reference records the base variables: an alias's series is its base's. (FMPy
            // 0.3.32 also records an FMI 3.0 <Alias> by name, as a copy of its base variable,
            // but reads an FMI 1.0 negatedAlias without its sign; the base is the reference
            // both ways.)
            let bases = ["armJoint.phi", "pendulumJoint.w", "der(armJoint.phi)"];
            let theirs = simulate_fmpy(&Run { outputs: &bases, ..run }, &[], d, "outputs");
            for (alias, base) in &ALIASES[..3] {
                assert_matches(&ours, alias, &theirs, base, iface, &what);
            }
        }
    }
}

#[test]
fn default_outputs_are_the_outputs_fmpy_records_less_the_fmi3_aliases() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for (fixture, _) in alias_fixtures() {
        let run = Run::new(fixture.path(), Iface::Me, 2.0, 0.01);
        let what = run.tag();
        let ours = simulate_fmucal(&run, d, "defaults");
        let theirs = simulate_fmpy(&run, &[], d, "defaults");
        let vars = inspect_variables(&fixture.path(), d);
        let is_fmi3_alias = |name: &str| {
            let v = variable(&vars, name, &fixture.path());
            v["aliasOf"].is_string() && v.get("fmi3").is_some()
        };
        // fmucal records the outputs ModelStructure lists (FMI 1.0: every causality output,
        // a negated alias among them); FMPy 0.3.32 adds a copy of each FMI 3.0 <Alias> of an
        // output, which fmucal records when it is named.
        let mut want: Vec<&String> = theirs.names.iter().filter(|n| !is_fmi3_alias(n)).collect();
        let mut got: Vec<&String> = ours.names.iter().collect();
        want.sort();
        got.sort();
        assert_eq!(got, want, "{what}: default outputs");
        for name in &ours.names {
            if variable(&vars, name, &fixture.path())["negated"] == true {
                // FMPy reads a negated alias without its sign; the standard wins.
                let base = variable(&vars, name, &fixture.path())["aliasOf"].as_str().unwrap().to_owned();
                assert_matches(
                    &Table {
                        names: vec![base.clone()],
                        time: ours.time.clone(),
                        columns: vec![ours.col(name).iter().map(|v| -v).collect()],
                    },
                    &base,
                    &theirs,
                    name,
                    Iface::Me,
                    &what,
                );
            } else {
                assert_matches(&ours, name, &theirs, name, Iface::Me, &what);
            }
        }
    }
}

#[test]
fn parameter_and_input_aliases_set_and_feed_their_base_variables_as_in_fmpy() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let by_alias = torque_csv(d, "motor.tau");
    let by_base = torque_csv(d, "u");
    let outputs = ["armJoint.phi", "pendulumJoint.phi"];
    for (fixture, ifaces) in alias_fixtures() {
        for &iface in ifaces {
            let base = Run {
                outputs: &outputs,
                set: &[("armFriction", "0.03")],
                input: Some(&by_base),
                ..Run::new(fixture.path(), iface, 10.0, 0.01)
            };
            let what = base.tag();
            let alias = Run { set: &[("armBearing.d", "0.03")], input: Some(&by_alias), ..base.clone() };
            let ours = simulate_fmucal(&alias, d, "by-alias");
            let ours_base = simulate_fmucal(&base, d, "by-base");
            let theirs = simulate_fmpy(&base, &[], d, "by-base");
            for name in outputs {
                // Setting an alias is setting its base: the same runs, to the last bit.
                assert_eq!(ours.col(name), ours_base.col(name), "{what}: {name} by alias and by base differ");
                assert_matches(&ours, name, &theirs, name, iface, &what);
            }
        }
    }
}

#[test]
fn fmi1_negated_alias_reads_and_sets_the_negative_of_its_base() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let fmu = Fixture::FurutaAliasesFmi1Me.path();
    let outputs = ["pendulumJoint.phiNeg", "pendulumJoint.phi"];
    // armBearing.tauPerSpeed is the negated alias of armFriction: −0.03 there is 0.03 here.
    let ours = simulate_fmucal(
        &Run {
            outputs: &outputs,
            set: &[("armBearing.tauPerSpeed", "-0.03")],
            ..Run::new(fmu.clone(), Iface::Me, 10.0, 0.01)
        },
        d,
        "negated",
    );
    assert_same(&ours, "pendulumJoint.phiNeg", "pendulumJoint.phi", -1.0, "FMI 1.0 negatedAlias");
    let run = Run {
        fmu,
        iface: Iface::Me,
        stop: 10.0,
        interval: 0.01,
        outputs: &outputs,
        set: &[("armFriction", "0.03")],
        input: None,
    };
    let theirs = simulate_fmpy(&run, &[], d, "negated");
    assert_matches(&ours, "pendulumJoint.phi", &theirs, "pendulumJoint.phi", Iface::Me, "FMI 1.0 negatedAlias");
    // FMPy 0.3.32 reads a negatedAlias without its sign (and sets it so too): its phiNeg
    // equals phi. The FMI 1.0 standard wins: a negatedAlias is the negative of its base
    // (section 2.5, attribute alias), so fmucal's phiNeg is −FMPy's phiNeg.
    let fmpy_neg = theirs.at("pendulumJoint.phiNeg", &ours.time);
    assert_eq!(fmpy_neg, theirs.at("pendulumJoint.phi", &ours.time), "FMPy now reads negatedAlias with its sign");
    let minus: Vec<f64> = fmpy_neg.iter().map(|v| -v).collect();
    let dd = rel_diff(ours.col("pendulumJoint.phiNeg"), &minus);
    assert!(dd <= ME_BOUND, "pendulumJoint.phiNeg differs from minus FMPy's base by {dd:e}");
}

#[test]
fn inspect_json_names_the_base_of_every_alias() {
    let dir = tempfile::tempdir().unwrap();
    for (fixture, _) in alias_fixtures() {
        let fmu = fixture.path();
        let vars = inspect_variables(&fmu, dir.path());
        for (alias, base) in ALIASES {
            let v = variable(&vars, alias, &fmu);
            assert_eq!(v["aliasOf"], *base, "{}: {alias} in {v}", fmu.display());
            assert!(v["negated"].is_null() || v["negated"] == false, "{}: {alias} in {v}", fmu.display());
            // The base itself is no alias.
            assert!(variable(&vars, base, &fmu)["aliasOf"].is_null(), "{}: {base} has aliasOf", fmu.display());
        }
    }
    let fmu = Fixture::FurutaAliasesFmi1Me.path();
    let vars = inspect_variables(&fmu, dir.path());
    for (alias, base) in [("pendulumJoint.phiNeg", "pendulumJoint.phi"), ("armBearing.tauPerSpeed", "armFriction")] {
        let v = variable(&vars, alias, &fmu);
        assert_eq!(v["aliasOf"], base, "{alias} in {v}");
        assert_eq!(v["negated"], true, "{alias} in {v}");
    }
}

#[test]
fn inspect_shows_the_structure_with_derivative_aliases_and_ports() {
    let dir = tempfile::tempdir().unwrap();
    let fmu = Fixture::FurutaAliases.path();
    let out = fmucal(&["inspect", fmu.to_str().unwrap()], dir.path());
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("\nStructure (4 states, 3 injection ports)\n"), "{text}");
    let line = |start: &str| {
        let section = text.split("\nStructure (").nth(1).unwrap_or_default();
        section
            .lines()
            .map(|l| l.split_whitespace().collect::<Vec<_>>().join(" "))
            .find(|l| l.starts_with(start))
            .unwrap_or_else(|| panic!("no line for {start}:\n{text}"))
    };
    assert_eq!(
        line("armJoint.phi rotational"),
        "armJoint.phi rotational position velocity armJoint.w (prefix and unit) der(armAngleSensor.phi)"
    );
    assert_eq!(
        line("pendulumJoint.w rotational"),
        "pendulumJoint.w rotational velocity position pendulumJoint.phi (prefix and unit) -"
    );
    assert_eq!(
        line("pendulumJoint.tauExt"),
        "pendulumJoint.tauExt N.m mechanical pendulumJoint.w (velocity), pendulumJoint.phi (position)"
    );
    assert!(line("u ").contains("[no state shares its prefix: all]"), "{text}");

    let out = fmucal(&["inspect", "--json", fmu.to_str().unwrap()], dir.path());
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let structure = &json["structure"];
    assert_eq!(structure["states"][0]["name"], "armJoint.phi", "{structure}");
    assert_eq!(structure["states"][0]["velocity"], "armJoint.w");
    assert_eq!(structure["states"][0]["quantity"], "rotational");
    assert_eq!(structure["states"][0]["derivative_aliases"][0], "der(armAngleSensor.phi)");
    let port = structure["ports"].as_array().unwrap().iter().find(|p| p["name"] == "armJoint.tauExt").unwrap();
    assert_eq!((port["domain"].as_str(), port["velocities"][0].as_str()), (Some("mechanical"), Some("armJoint.w")));
    assert!(json["variables"].is_array(), "the description stays at the top level");
}

// ---- String and Binary variables -------------------------------------------------------------

/// The String fixtures, their interfaces, and whether they have the Binary variables (FMI 3.0).
fn string_fixtures() -> [(Fixture, &'static [Iface], bool); 3] {
    [
        (Fixture::StringsFmi3, &[Iface::Me, Iface::Cs], true),
        (Fixture::Strings, &[Iface::Me, Iface::Cs], false),
        (Fixture::StringsFmi1Me, &[Iface::Me], false),
    ]
}

#[test]
fn string_and_binary_fmus_load_and_their_numeric_outputs_match_fmpy() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for (fixture, ifaces, binary) in string_fixtures() {
        let numeric: &[&str] = if binary { &["x", "y", "Binary_length"] } else { &["x", "y"] };
        for &iface in ifaces {
            let run = Run::new(fixture.path(), iface, 2.0, 0.01);
            let what = run.tag();
            // The default outputs are the numeric ones; a CSV of numbers has no place for a
            // String or Binary value.
            let ours = simulate_fmucal(&run, d, "default");
            for name in numeric {
                assert!(ours.names.iter().any(|n| n == name), "{what}: default outputs {:?} lack {name}", ours.names);
            }
            for name in ["String_output", "Binary_output"] {
                assert!(!ours.names.iter().any(|n| n == name), "{what}: default outputs {:?} hold {name}", ours.names);
            }
            let theirs = simulate_fmpy(&Run { outputs: numeric, ..run }, &[], d, "default");
            for name in numeric {
                assert_matches(&ours, name, &theirs, name, iface, &what);
            }
            // "Set me!" has 7 bytes, the Binary start 666f6f 3: y = 7 e^(-t).
            let y = ours.col("y");
            let worst = ours.time.iter().zip(y).map(|(t, y)| (y - 7.0 * (-t).exp()).abs()).fold(0.0, f64::max);
            assert!(worst < 1e-5 * 7.0, "{what}: y is {worst:e} off 7 e^(-t)");
            if binary {
                assert!(ours.col("Binary_length").iter().all(|&v| v == 3.0), "{what}: Binary_length is not 3");
            }
        }
    }
}

#[test]
fn string_and_binary_start_values_change_the_outputs_as_fmpy_start_values_do() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for (fixture, ifaces, binary) in string_fixtures() {
        // Two bytes of String and, in FMI 3.0, five bytes of Binary (written in hex, as a
        // Binary start value is): y = 2 x, Binary_length = 5.
        let set: &[(&str, &str)] = if binary {
            &[("String_parameter", "ab"), ("Binary_input", "0102030405")]
        } else {
            &[("String_parameter", "ab")]
        };
        let numeric: &[&str] = if binary { &["y", "Binary_length"] } else { &["y"] };
        for &iface in ifaces {
            let run = Run { outputs: numeric, set, ..Run::new(fixture.path(), iface, 2.0, 0.01) };
            let what = run.tag();
            let ours = simulate_fmucal(&run, d, "set");
            let theirs = simulate_fmpy(&Run { set: &[], ..run }, set, d, "set");
            for name in numeric {
                assert_matches(&ours, name, &theirs, name, iface, &what);
            }
            let worst =
                ours.time.iter().zip(ours.col("y")).map(|(t, y)| (y - 2.0 * (-t).exp()).abs()).fold(0.0, f64::max);
            assert!(worst < 2e-5, "{what}: with String_parameter=ab, y is {worst:e} off 2 e^(-t)");
            if binary {
                assert!(ours.col("Binary_length").iter().all(|&v| v == 5.0), "{what}: Binary_length is not 5");
            }
        }
    }
}

#[test]
fn inspect_lists_string_and_binary_variables_with_their_starts() {
    let dir = tempfile::tempdir().unwrap();
    for (fixture, _, binary) in string_fixtures() {
        let fmu = fixture.path();
        let vars = inspect_variables(&fmu, dir.path());
        assert_eq!(variable(&vars, "String_parameter", &fmu)["start"], "Set me!", "{}", fmu.display());
        variable(&vars, "String_output", &fmu);
        if binary {
            // A Binary start is shown as it is written: hexadecimal, two digits per byte.
            let start = &variable(&vars, "Binary_input", &fmu)["start"];
            assert_eq!(
                start.as_str().map(str::to_ascii_lowercase).as_deref(),
                Some("666f6f"),
                "Binary_input start {start}"
            );
            variable(&vars, "Binary_output", &fmu);
        }
        let out = fmucal(&["inspect", fmu.to_str().unwrap()], dir.path());
        assert!(out.status.success(), "inspect {}: {}", fmu.display(), String::from_utf8_lossy(&out.stderr));
        let text = String::from_utf8_lossy(&out.stdout);
        assert!(text.lines().any(|l| l.contains("String_parameter") && l.contains("Set me!")), "{text}");
        if binary {
            assert!(
                text.lines().any(|l| l.contains("Binary_input") && l.to_ascii_lowercase().contains("666f6f")),
                "{text}"
            );
        }
    }
}

#[test]
fn recording_a_string_output_is_refused_in_one_line_naming_it() {
    let dir = tempfile::tempdir().unwrap();
    for (fixture, _, binary) in string_fixtures() {
        let names: &[&str] = if binary { &["String_output", "Binary_output"] } else { &["String_output"] };
        for name in names {
            let run = Run { outputs: &[name, "y"], ..Run::new(fixture.path(), Iface::Me, 1.0, 0.1) };
            let (out, _) = try_fmucal(&run, dir.path(), "string-output");
            assert!(!out.status.success(), "{}: --output {name} succeeded", run.tag());
            let err = String::from_utf8_lossy(&out.stderr).trim().to_owned();
            assert_eq!(err.lines().count(), 1, "{}: not one line: {err}", run.tag());
            assert!(err.contains(name), "{}: the error does not name {name}: {err}", run.tag());
        }
    }
}

// ---- arrays ----------------------------------------------------------------------------------

#[test]
fn an_array_output_by_name_gives_its_elements_as_fmpy_does() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let elements = ["y[1]", "y[2]", "y[3]"];
    for iface in [Iface::Me, Iface::Cs] {
        let run = Run { outputs: &["y"], ..Run::new(Fixture::ArrayOutputsFmi3.path(), iface, 5.0, 0.01) };
        let what = run.tag();
        let ours = simulate_fmucal(&run, d, "y");
        assert_eq!(ours.names, elements, "{what}: --output y");
        // FMPy keeps the array in one field of shape (3,); simulate.py writes it as y[1], y[2], y[3].
        let theirs = simulate_fmpy(&run, &[], d, "y");
        for (k, name) in elements.iter().enumerate() {
            assert_matches(&ours, name, &theirs, name, iface, &what);
            let worst = ours
                .time
                .iter()
                .zip(ours.col(name))
                .map(|(t, y)| (y - (k + 1) as f64 * (-t).exp()).abs())
                .fold(0.0, f64::max);
            assert!(worst < 1e-5, "{what}: {name} is {worst:e} off {} e^(-t)", k + 1);
        }
        // One element by its own name, in both versions.
        for fixture in [Fixture::ArrayOutputsFmi3, Fixture::ArrayOutputs] {
            let one = simulate_fmucal(&Run { fmu: fixture.path(), outputs: &["y[2]"], ..run }, d, "y2");
            assert_eq!(one.names, ["y[2]"]);
            assert_matches(&one, "y[2]", &theirs, "y[2]", iface, &format!("{what} {fixture:?}"));
        }
    }
}

#[test]
fn default_outputs_include_every_element_of_an_array_output() {
    let dir = tempfile::tempdir().unwrap();
    for fixture in [Fixture::ArrayOutputsFmi3, Fixture::ArrayOutputs] {
        for iface in [Iface::Me, Iface::Cs] {
            let run = Run::new(fixture.path(), iface, 1.0, 0.1);
            let ours = simulate_fmucal(&run, dir.path(), "default");
            assert_eq!(ours.names, ["y[1]", "y[2]", "y[3]"], "{}: default outputs", run.tag());
        }
    }
}

// ---- a Co-Simulation FMU that terminates itself -----------------------------------------------

#[test]
fn co_simulation_ends_where_the_fmu_asks_to_terminate_as_in_fmpy() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for fixture in [Fixture::StairFmi3, Fixture::Stair] {
        // The default experiment's step (0.2), and a step that makes t = 9 the end of a short
        // step (0.02: the last step before 10 would start at 9.98).
        for interval in [0.2, 0.02] {
            let run = Run { outputs: &["counter"], ..Run::new(fixture.path(), Iface::Cs, 10.0, interval) };
            let what = format!("{} interval {interval}", run.tag());
            let ours = simulate_fmucal(&run, d, &format!("{interval}"));
            let theirs = simulate_fmpy(&run, &[], d, &format!("{interval}"));
            let end = *ours.time.last().unwrap();
            assert!((end - 9.0).abs() < 1e-9, "{what}: fmucal ends at {end}, not where the FMU terminated (9)");
            assert_eq!(*ours.col("counter").last().unwrap(), 10.0, "{what}: the last counter");
            // Same end, same counter at every time both have.
            assert_matches(&ours, "counter", &theirs, "counter", Iface::Cs, &what);
            for (t, c) in ours.time.iter().zip(ours.col("counter")) {
                let expected = 1.0 + (t + 1e-9).floor();
                assert_eq!(*c, expected, "{what}: counter at t={t}");
            }
        }
    }
}

#[test]
fn model_exchange_ends_at_the_event_where_the_fmu_asks_to_terminate() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for fixture in [Fixture::StairFmi3, Fixture::Stair] {
        let run = Run { outputs: &["counter"], ..Run::new(fixture.path(), Iface::Me, 10.0, 0.2) };
        let what = run.tag();
        let ours = simulate_fmucal(&run, d, "me");
        let theirs = simulate_fmpy(&run, &[], d, "me");
        // The FMU asks to terminate in the event iteration at t = 9, so the run ends there
        // (FMI 2.0 section 3.2.3, FMI 3.0 section 3.2.3). FMPy 0.3.32's Model Exchange loop
        // leaves before it records that event's time (its last row is at 8.8 on this grid):
        // the standard wins, and the comparison covers the times FMPy has.
        let end = *ours.time.last().unwrap();
        assert!((end - 9.0).abs() < 1e-9, "{what}: fmucal ends at {end}, not where the FMU terminated (9)");
        let fmpy_end = *theirs.time.last().unwrap();
        assert!(fmpy_end <= 9.0 + 1e-9, "{what}: FMPy ends at {fmpy_end}, after the FMU terminated");
        // Between the events (the value at an event time is the next test's subject).
        let between = |t: &f64| *t < 9.0 - 1e-9 && (t - t.round()).abs() > 1e-9;
        let shared: Vec<f64> = theirs.time.iter().copied().filter(between).collect();
        assert_eq!(ours.at("counter", &shared), theirs.at("counter", &shared), "{what}: counters differ");
    }
}

/// The Furuta example's data calibrated on `fmu` with the names `n` gives for the arm angle,
/// the motor torque input, the arm friction and the pendulum velocity (the signal of an
/// injected damping on the torque port); returns `result.json`.
fn calibrate_furuta_named(fmu: &Path, n: [&str; 4], dir: &Path, label: &str) -> serde_json::Value {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/furuta/furuta_data.csv");
    let [phi, torque, friction, speed] = n;
    let job = common::job_toml(
        fmu,
        Some(&data),
        &[(phi, "phi"), ("pendulumJoint.phi", "theta")],
        &[("u", torque)],
        &[(friction, 0.02, 0.0, 0.05)],
        &format!(
            r#"[[effects]]
kind = "viscous_damping"
port = "{torque}"
signal = "{speed}"
parameters = {{ c = {{ start = 0.001, lower = 0.0, upper = 0.01 }} }}
[simulation]
stop_time = 4.0
tolerance = 1e-8
[optimizer]
max_iters = 15
"#
        ),
    );
    let path = dir.join(format!("{label}.toml"));
    std::fs::write(&path, job).unwrap();
    let out_dir = dir.join(label);
    let out = fmucal(&["calibrate", path.to_str().unwrap(), "--workers", "1", "--out", out_dir.to_str().unwrap()], dir);
    assert!(out.status.success(), "{label}: {}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_str(&std::fs::read_to_string(out_dir.join("result.json")).unwrap()).unwrap()
}

#[test]
fn a_calibration_through_aliases_is_the_calibration_through_their_bases() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for fixture in [Fixture::FurutaAliasesFmi3, Fixture::FurutaAliases] {
        let fmu = fixture.path();
        // An output, an input, a calibrated parameter and an effect's port and signal, all
        // named by their aliases, against the same job with the base names.
        let aliased = ["armAngleSensor.phi", "motor.tau", "armBearing.d", "pendulumSpeedSensor.w"];
        let bases = ["armJoint.phi", "u", "armFriction", "pendulumJoint.w"];
        let a = calibrate_furuta_named(&fmu, aliased, d, "aliased");
        let b = calibrate_furuta_named(&fmu, bases, d, "bases");
        let what = fmu.file_stem().unwrap().to_string_lossy().into_owned();
        assert!(a["x_opt"]["armBearing.d"].is_f64() && a["x_opt"]["effects[0].c"].is_f64(), "{what}: {a}");
        assert_eq!(a["x_opt"]["armBearing.d"], b["x_opt"]["armFriction"], "{what}: {a} vs {b}");
        assert_eq!(a["x_opt"]["effects[0].c"], b["x_opt"]["effects[0].c"], "{what}");
        assert_eq!(a["f_opt"], b["f_opt"], "{what}");
    }
}
