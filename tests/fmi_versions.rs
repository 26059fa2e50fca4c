//! FMI 1.0 and 3.0 import: the FMI 1.0 (ME and CS) and 3.0 builds of the example
//! models, from the same C sources as their FMI 2.0 builds (`models/c`, `-DFMUCAL_FMI1`,
//! `-DFMUCAL_FMI3`), simulate to the 2.0 results; the Furuta calibration recovers the same
//! frictions whichever version the job names; one element of an array parameter is calibrated
//! (checked against the analytic solution of the model); and FMUs or jobs fmucal cannot serve
//! are refused with one line naming the reason. The cross-check of these FMUs against FMPy is
//! in `fmpy_crosscheck.rs`.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

use fmucal_models::Fixture;
use fmucal_shared::fmu::Interface;
use fmucal_shared::sim::{OutputTimes, SimSpec, simulate};

fn fmucal(args: &[&str], cache: &Path) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_fmucal")).args(args).env("FMUCAL_CACHE_DIR", cache).output().unwrap()
}

/// Simulates `fmu` on a 0.01 s grid to `stop` and returns its outputs and states.
fn run(
    fmu: &Path,
    interface: Interface,
    stop: f64,
    set: &[(&str, &str)],
    cache: &Path,
) -> (Vec<String>, Vec<Vec<f64>>) {
    let fmu = common::load(fmu, cache);
    let spec = SimSpec {
        interface: Some(interface),
        stop_time: Some(stop),
        output_times: Some(OutputTimes::Interval(0.01)),
        tolerance: Some(1e-8),
        parameters: set.iter().map(|(n, v)| (n.to_string(), v.to_string())).collect(),
        ..Default::default()
    };
    let r = simulate(&fmu, &spec).unwrap_or_else(|e| panic!("{}: {e}", fmu.description.model_name));
    (r.names.clone(), r.columns.clone())
}

#[test]
fn fmi1_and_fmi3_builds_simulate_as_their_fmi2_builds_do() {
    let dir = tempfile::tempdir().unwrap();
    let cache = dir.path().join("cache");
    let (me, cs) = (Interface::ModelExchange, Interface::CoSimulation);
    let cases = [
        ("furuta", Fixture::FurutaFmi3, vec![me, cs], 10.0),
        ("bouncing-ball", Fixture::BouncingBallFmi3, vec![me, cs], 3.0),
        ("robertson", Fixture::RobertsonFmi3, vec![me, cs], 40.0),
        // An FMI 1.0 FMU offers one interface.
        ("furuta", Fixture::FurutaFmi1Me, vec![me], 10.0),
        ("furuta", Fixture::FurutaFmi1Cs, vec![cs], 10.0),
        ("bouncing-ball", Fixture::BouncingBallFmi1Me, vec![me], 3.0),
        ("bouncing-ball", Fixture::BouncingBallFmi1Cs, vec![cs], 3.0),
        ("robertson", Fixture::RobertsonFmi1Me, vec![me], 40.0),
        ("robertson", Fixture::RobertsonFmi1Cs, vec![cs], 40.0),
    ];
    for (example, fixture, interfaces, stop) in cases {
        let (fmi2, other) = (common::example(example), fixture.path());
        for interface in interfaces {
            let (names2, cols2) = run(&fmi2, interface, stop, &[], &cache);
            let (names, cols) = run(&other, interface, stop, &[], &cache);
            assert_eq!(names2, names, "{}: different outputs", other.display());
            for ((name, a), b) in names2.iter().zip(&cols2).zip(&cols) {
                assert_eq!(a.len(), b.len(), "{name}: different grids");
                let d = common::rel_max_diff(b, a);
                // The same C code and the same integrator: equal but for the order of calls.
                assert!(d <= 1e-9, "{} {interface:?} {name}: differs from FMI 2.0 by {d:e}", other.display());
            }
        }
    }
}

#[test]
fn inspect_shows_the_version_and_array_dimensions() {
    let dir = tempfile::tempdir().unwrap();
    let out = fmucal(&["inspect", Fixture::ArrayParamsFmi3.path().to_str().unwrap()], dir.path());
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.lines().any(|l| l.starts_with("FMI version") && l.ends_with("3.0")), "{text}");
    assert!(text.contains("x86_64-linux"), "{text}");
    for k in 1..=3 {
        assert!(
            text.lines().any(|l| l.trim_start().starts_with(&format!("k[{k}]")) && l.contains("Float64[3]")),
            "k[{k}] missing:\n{text}"
        );
    }
}

/// x'' = k3 − k1·x − k2·x', x(0) = 1, x'(0) = 0, for k1 = 1 and k3 = 3 and damping k2 = 2·ζ:
/// x(t) = 3 − 2·e^(−ζt)·(cos ωt + ζ/ω·sin ωt), ω = √(1 − ζ²) (ζ < 1), or 3 − 2·(1 + t)·e^(−t) at ζ = 1.
fn analytic_x(t: f64, k2: f64) -> f64 {
    let zeta: f64 = k2 / 2.0;
    if (zeta - 1.0).abs() < 1e-12 {
        return 3.0 - 2.0 * (1.0 + t) * (-t).exp();
    }
    let w = (1.0 - zeta * zeta).sqrt();
    3.0 - 2.0 * (-zeta * t).exp() * ((w * t).cos() + zeta / w * (w * t).sin())
}

#[test]
fn an_array_element_is_set_and_read_as_the_model_equations_say() {
    let dir = tempfile::tempdir().unwrap();
    let cache = dir.path().join("cache");
    for (k2, set) in [(2.0, vec![]), (0.6, vec![("k[2]", "0.6")])] {
        let (names, cols) = run(&Fixture::ArrayParamsFmi3.path(), Interface::ModelExchange, 10.0, &set, &cache);
        let x = &cols[names.iter().position(|n| n == "x").unwrap()];
        let worst = x.iter().enumerate().map(|(i, v)| (v - analytic_x(i as f64 * 0.01, k2)).abs()).fold(0.0, f64::max);
        assert!(worst < 1e-5, "k[2] = {k2}: x is {worst:e} off the analytic solution");
    }
}

/// A job calibrating `parameters` of `model` against `data.csv` (columns time, x).
fn job(dir: &Path, model: &Path, parameters: &[(&str, f64, f64, f64)]) -> PathBuf {
    let tables = "[optimizer]\nalgorithm = \"nelder-mead\"\nx_tol = 1e-8\nf_tol = 1e-14\n[workers]\ncount = 1\n";
    let text = common::job_toml(model, Some(Path::new("data.csv")), &[("x", "x")], &[], parameters, tables);
    common::write_file(dir, "job.toml", text)
}

#[test]
fn one_element_of_an_array_parameter_is_calibrated() {
    let dir = tempfile::tempdir().unwrap();
    // Measurements from the analytic solution with k[2] = 0.8 (underdamped).
    let mut csv = String::from("time,x\n");
    for i in 0..=500 {
        let t = i as f64 * 0.02;
        csv.push_str(&format!("{t},{}\n", analytic_x(t, 0.8)));
    }
    std::fs::write(dir.path().join("data.csv"), csv).unwrap();
    let job = job(dir.path(), &Fixture::ArrayParamsFmi3.path(), &[("k[2]", 2.0, 0.1, 4.0)]);
    let out_dir = dir.path().join("out");
    let out = fmucal(&["calibrate", job.to_str().unwrap(), "--out", out_dir.to_str().unwrap()], &dir.path().join("c"));
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out_dir.join("result.json")).unwrap()).unwrap();
    let k2 = r["x_opt"]["k[2]"].as_f64().unwrap();
    assert!((k2 - 0.8).abs() < 1e-4, "recovered k[2] = {k2}, the data were made with 0.8");
}

#[test]
fn furuta_frictions_are_the_same_whichever_fmi_version_the_job_names() {
    let dir = tempfile::tempdir().unwrap();
    let example = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/furuta");
    let text = std::fs::read_to_string(example.join("job.toml")).unwrap();
    let mut results = vec![];
    let versions = [
        ("2.0", "example:furuta".to_owned()),
        ("3.0", Fixture::FurutaFmi3.path().display().to_string()),
        ("1.0", Fixture::FurutaFmi1Me.path().display().to_string()),
    ];
    for (label, model) in versions {
        let job_text = text
            .replace("path = \"example:furuta\"", &format!("path = \"{model}\""))
            .replace("path = \"FurutaData.mat\"", &format!("path = \"{}\"", example.join("FurutaData.mat").display()));
        let job = dir.path().join(format!("job-{label}.toml"));
        std::fs::write(&job, job_text).unwrap();
        let out_dir = dir.path().join(label);
        let out =
            fmucal(&["calibrate", job.to_str().unwrap(), "--out", out_dir.to_str().unwrap()], &dir.path().join("c"));
        assert!(out.status.success(), "FMI {label}: {}", String::from_utf8_lossy(&out.stderr));
        let r: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out_dir.join("result.json")).unwrap()).unwrap();
        results.push(r);
    }
    for (r, version) in results.iter().zip(["2.0", "3.0", "1.0"]) {
        assert_eq!(r["fmi_version"], version);
    }
    for name in ["armFriction", "pendulumFriction"] {
        let a = results[0]["x_opt"][name].as_f64().unwrap();
        for (r, version) in results.iter().zip(["2.0", "3.0", "1.0"]).skip(1) {
            let b = r["x_opt"][name].as_f64().unwrap();
            assert!((a - b).abs() <= 1e-6 * a.abs(), "{name}: {a} from FMI 2.0, {b} from FMI {version}");
        }
    }
}

/// The FMI 3.0 Furuta with its description edited by `f`, as `dir/name`.
fn furuta3_with_xml(dir: &Path, name: &str, f: impl Fn(String) -> String) -> PathBuf {
    let entries: Vec<(String, Vec<u8>)> = common::entries(&Fixture::FurutaFmi3.path())
        .into_iter()
        .map(|(n, b)| {
            let b = if n == "modelDescription.xml" { f(String::from_utf8(b).unwrap()).into_bytes() } else { b };
            (n, b)
        })
        .collect();
    let path = dir.join(name);
    common::write_zip(&path, &entries);
    path
}

/// The one line `fmucal` printed on stderr for a failed command.
fn one_line_error(out: &std::process::Output) -> String {
    assert!(!out.status.success(), "succeeded: {}", String::from_utf8_lossy(&out.stdout));
    let err = String::from_utf8_lossy(&out.stderr).trim().to_owned();
    assert_eq!(err.lines().count(), 1, "not one line: {err}");
    err
}

#[test]
fn what_fmucal_cannot_serve_is_refused_in_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let cache = dir.path().join("cache");
    let d = dir.path();
    let scheduled = furuta3_with_xml(d, "scheduled.fmu", |x| {
        let start = x.find("<ModelExchange").unwrap();
        let end = x.find("<UnitDefinitions").or_else(|| x.find("<TypeDefinitions")).unwrap();
        format!("{}<ScheduledExecution modelIdentifier=\"Furuta\"/>\n  {}", &x[..start], &x[end..])
    });
    let clocked = furuta3_with_xml(d, "clocked.fmu", |x| {
        x.replace(
            "</ModelVariables>",
            "<Clock name=\"sample\" valueReference=\"900\" causality=\"input\" variability=\"discrete\" intervalVariability=\"constant\" intervalDecimal=\"0.1\"/></ModelVariables>",
        )
    });
    let unprefixed = Fixture::UnprefixedFmi1.path();
    for (fmu, want) in [
        (&scheduled, "offers only Scheduled Execution"),
        (&clocked, "has clocks (Clock variable \"sample\")"),
        (&unprefixed, "without the model identifier prefix: FMI 1.0 requires Furuta_fmiGetVersion"),
    ] {
        let err = one_line_error(&fmucal(&["simulate", fmu.to_str().unwrap(), "-o", "/dev/null"], &cache));
        assert!(err.contains(want), "{err}");
    }

    // Jobs: a String or Binary parameter, an array index out of range, an array named whole.
    let typed = furuta3_with_xml(d, "typed.fmu", |x| {
        x.replace(
            "</ModelVariables>",
            "<String name=\"label\" valueReference=\"901\" causality=\"parameter\" variability=\"fixed\"><Start value=\"a\"/></String>\
             <Binary name=\"blob\" valueReference=\"902\" causality=\"parameter\" variability=\"fixed\"/></ModelVariables>",
        )
    });
    std::fs::write(d.join("data.csv"), "time,x\n0,1\n1,2\n").unwrap();
    let cases: [(&Path, &str, &str); 4] = [
        (&typed, "label", "label is String; only Real parameters can be calibrated"),
        (&typed, "blob", "blob is Binary; only Real parameters can be calibrated"),
        (&Fixture::ArrayParamsFmi3.path(), "k[4]", "k[4]: index out of range; k is an array of 3 (k[1] to k[3])"),
        (&Fixture::ArrayParamsFmi3.path(), "k", "k is an array of 3: name one element, k[1] to k[3]"),
    ];
    for (model, parameter, want) in cases {
        let job = job(d, model, &[(parameter, 1.0, 0.0, 2.0)]);
        let err = one_line_error(&fmucal(
            &["calibrate", job.to_str().unwrap(), "--out", d.join("o").to_str().unwrap()],
            &cache,
        ));
        assert!(err.contains("parameters[0].name") && err.contains(want), "{parameter}: {err}");
    }
}

/// Archives of every version go through the same checks: an entry that climbs out of the
/// archive is refused, and so is one past the entry cap, before any description is read.
#[test]
fn archives_of_every_version_are_checked_the_same_way() {
    use fmucal_shared::fmu::{ArchiveLimits, Fmu, LoadOptions};
    let dir = tempfile::tempdir().unwrap();
    let fixtures = [Fixture::FurutaFmi1Me, Fixture::FurutaFmi1Cs, Fixture::FurutaFmi3];
    for fixture in fixtures {
        let mut entries = common::entries(&fixture.path());
        let count = entries.len();
        entries.push(("resources/../../escape.txt".into(), b"x".to_vec()));
        let slip = dir.path().join("slip.fmu");
        common::write_zip(&slip, &entries);
        let opts = LoadOptions { cache_dir: dir.path().join("cache"), limits: ArchiveLimits::default() };
        let err = Fmu::load_with(&slip, &opts).unwrap_err().to_string();
        assert!(err.contains("climbs out of the archive"), "{}: {err}", fixture.path().display());
        assert!(!dir.path().join("escape.txt").exists());

        let capped = LoadOptions {
            cache_dir: dir.path().join("cache2"),
            limits: ArchiveLimits { max_entries: count - 1, ..ArchiveLimits::default() },
        };
        let err = Fmu::load_with(&fixture.path(), &capped).unwrap_err().to_string();
        assert!(err.contains("entries"), "{}: {err}", fixture.path().display());
    }
}
