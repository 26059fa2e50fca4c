//! `fmucal diagnose` through the real binary, on the example in `examples/diagnose/` (Furuta
//! bench data with a Coulomb friction the model lacks): the same effect, with the same values,
//! locally and on a separately started coordinator with another number of workers; the outputs
//! it writes; bad `[diagnose]` sections refused in one line naming the field before any
//! model code runs; and the diagnosis library run in this process, with no coordinator, giving
//! the command line's report.

mod common;

use std::path::{Path, PathBuf};
use std::process::Output;

use fmucal_diagnose::report::Diagnosis;

fn example_job() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/diagnose/job.toml")
}

fn fmucal(args: &[&str], dir: &Path) -> Output {
    common::fmucal_in(dir).args(args).env("FMUCAL_TOKEN", "cli-test-token").output().unwrap()
}

fn report(dir: &Path) -> Diagnosis {
    serde_json::from_str(&std::fs::read_to_string(dir.join("report.json")).unwrap()).unwrap()
}

#[test]
fn a_coordinator_and_a_local_run_name_the_same_effect_with_the_same_values() {
    let dir = tempfile::tempdir().unwrap();
    let job = example_job();
    let local = fmucal(&["diagnose", job.to_str().unwrap(), "--workers", "1", "--out", "local"], dir.path());
    assert!(local.status.success(), "{}", String::from_utf8_lossy(&local.stderr));
    let stdout = String::from_utf8_lossy(&local.stdout);
    assert!(
        stdout.contains("found: coulomb_friction on pendulumJoint.w through pendulumJoint.tauExt, force 0.00"),
        "{stdout}"
    );

    let servers = common::Servers::start(dir.path(), 3);
    let remote =
        fmucal(&["diagnose", job.to_str().unwrap(), "--coordinator", &servers.url, "--out", "remote"], dir.path());
    servers.stop();
    assert!(remote.status.success(), "{}", String::from_utf8_lossy(&remote.stderr));

    let (a, b) = (report(&dir.path().join("local")), report(&dir.path().join("remote")));
    assert_eq!(a.named, b.named);
    assert_eq!(a.named.len(), 1);
    let (ra, rb) = (&a.rounds[0], &b.rounds[0]);
    assert_eq!(ra.chosen, rb.chosen);
    let fitted = |r: &fmucal_diagnose::report::Round| {
        r.candidates
            .iter()
            .filter_map(|c| c.fit.as_ref().map(|f| (c.description.clone(), f.x_opt.clone())))
            .collect::<Vec<_>>()
    };
    assert_eq!(fitted(ra), fitted(rb), "every candidate's fit is the same for 1 and 3 workers");
    // The true friction is 0.004 N·m; the named value is within its interval.
    let force = a.named[0].effect.parameters["force"].start;
    assert!((force - 0.004).abs() < 1e-4, "{force}");
    // The job it writes calibrates with the effect.
    let kept = std::fs::read_to_string(dir.path().join("local/job.toml")).unwrap();
    assert!(kept.contains("[[effects]]") && kept.contains("coulomb_friction"), "{kept}");
    let spec = fmucal_shared::job::JobSpec::from_toml(&kept, dir.path()).unwrap();
    spec.validate().unwrap();
    for name in ["residuals", "correlation"] {
        let png = std::fs::read(dir.path().join(format!("local/{name}.png"))).unwrap();
        assert!(png.starts_with(b"\x89PNG\r\n\x1a\n") && png.len() > 1000, "{name}.png is not a PNG");
        let svg = std::fs::read_to_string(dir.path().join(format!("local/{name}.svg"))).unwrap();
        assert!(svg.contains("<svg") && svg.contains("</svg>"), "{name}.svg");
    }
}

#[test]
fn bad_diagnose_sections_are_one_line_naming_the_field() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(example_job()).unwrap();
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/diagnose/data.csv");
    let text = text.replace("path = \"data.csv\"", &format!("path = \"{}\"", data.display()));
    // The Furuta description edited to say pendulumJoint.phi depends directly on the pendulum's
    // torque input (variable 13): an effect on that port reading that angle is a loop.
    let looped = common::with_xml("furuta", dir.path(), "looped.fmu", |x| {
        x.replace(
            "<Unknown index=\"3\"/>\n    </Outputs>",
            "<Unknown index=\"3\" dependencies=\"13\"/>\n    </Outputs>",
        )
    });
    let cases = [
        (
            "port = \"armJoint.tauExt\"",
            "port = \"armFriction\"",
            "diagnose.ports[0].port: port \"armFriction\" is not a continuous Real input",
        ),
        (
            "velocities = [\"armJoint.w\"]",
            "velocities = [\"armJoint.v\"]",
            "diagnose.ports[0].velocities[0]: signal \"armJoint.v\" is not a variable",
        ),
        (
            "domain = \"mechanical\"\nvelocities = [\"armJoint.w\"]\npositions = [\"armJoint.phi\"]",
            "domain = \"thermal\"\ntemperatures = [\"armJoint.w\"]",
            "is in N.m (mechanical); convection is a thermal effect",
        ),
        ("top = 8", "top = 0", "diagnose.top: must be at least 1"),
        ("top = 8", "topp = 8", "unknown field `topp`"),
        ("top = 8", "top = 8\nsignals = [\"nope\"]", "diagnose.signals[0]: \"nope\" is not a variable of the model"),
        ("path = \"example:furuta\"", &format!("path = \"{}\"", looped.display()), "would make an algebraic loop"),
    ];
    for (from, to, want) in cases {
        assert!(text.contains(from), "{from:?}");
        std::fs::write(dir.path().join("bad.toml"), text.replacen(from, to, 1)).unwrap();
        let out = fmucal(&["diagnose", "bad.toml", "--workers", "1"], dir.path());
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{want}: {err}");
        // A TOML parse error keeps the parser's layout (the line quoted and a caret under it);
        // every other error is one line.
        let lines = if want.starts_with("unknown field") { 5 } else { 1 };
        assert_eq!(err.lines().count(), lines, "{err}");
        assert!(err.contains(want), "{want:?} not in {err:?}");
        assert!(!dir.path().join("diagnosis").exists(), "nothing is written for a bad job");
    }
    // The job.toml a diagnosis writes may not replace the job it reads.
    std::fs::create_dir_all(dir.path().join("d")).unwrap();
    std::fs::write(dir.path().join("d/job.toml"), &text).unwrap();
    let before = std::fs::read_to_string(dir.path().join("d/job.toml")).unwrap();
    let out = fmucal(&["diagnose", "d/job.toml", "--workers", "1", "--out", "d"], dir.path());
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("--out d: its job.toml would overwrite the job file"), "{err}");
    assert_eq!(std::fs::read_to_string(dir.path().join("d/job.toml")).unwrap(), before);
}

#[test]
fn a_second_round_adds_nothing_once_the_coulomb_friction_is_in_the_model() {
    let dir = tempfile::tempdir().unwrap();
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/diagnose/data.csv");
    let text = std::fs::read_to_string(example_job())
        .unwrap()
        .replace("path = \"data.csv\"", &format!("path = \"{}\"", data.display()))
        .replacen("top = 8", "top = 8\nrounds = 2", 1);
    std::fs::write(dir.path().join("two.toml"), text).unwrap();
    let out = fmucal(&["diagnose", "two.toml", "--workers", "2", "--out", "two"], dir.path());
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let d = report(&dir.path().join("two"));
    assert_eq!(d.rounds.len(), 2, "{}", d.summary());
    assert_eq!(d.named.len(), 1, "{}", d.summary());
    assert_eq!(d.rounds[1].chosen, None, "{}", d.summary());
    // Round 2 starts from the model with the friction: its base is already at the noise.
    assert!(d.rounds[1].baseline.validation_rms < 0.5 * d.rounds[0].baseline.validation_rms, "{}", d.summary());
    let kept = std::fs::read_to_string(dir.path().join("two/job.toml")).unwrap();
    assert_eq!(kept.matches("[[effects]]").count(), 1, "{kept}");
}

#[test]
fn a_once_per_process_fmu_loses_no_candidate() {
    // The driver judges each candidate fit as it ends, in its own process, while the others
    // still run: an FMU that may be instantiated only once per process must be judged one fit
    // at a time, not have candidates fail for it.
    let dir = tempfile::tempdir().unwrap();
    let once = common::once_per_process("furuta", dir.path());
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/diagnose/data.csv");
    let text = std::fs::read_to_string(example_job())
        .unwrap()
        .replace("path = \"example:furuta\"", &format!("path = \"{}\"", once.display()))
        .replace("path = \"data.csv\"", &format!("path = \"{}\"", data.display()));
    assert!(text.contains("once.fmu"), "{text}");
    std::fs::write(dir.path().join("once.toml"), text).unwrap();
    let out = fmucal(&["diagnose", "once.toml", "--workers", "2", "--out", "once"], dir.path());
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let d = report(&dir.path().join("once"));
    let fits: Vec<_> = d.rounds[0].candidates.iter().filter_map(|c| c.fit.as_ref().map(|f| (c, f))).collect();
    assert!(fits.len() >= 2, "{}", d.summary());
    for (c, f) in fits {
        assert!(f.verdict.is_some() && f.error.is_none(), "{}: {:?}", c.description, f.error);
    }
    assert_eq!(d.named.len(), 1, "{}", d.summary());
}

/// Reads `result.json`'s evaluations and the validation RMS of `fit.csv` (optimized column)
/// over (15, 20] s of a calibration folder.
fn calibration(dir: &Path) -> (u64, f64) {
    let result: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("result.json")).unwrap()).unwrap();
    let evaluations = result["evaluations"].as_u64().unwrap();
    let fit = std::fs::read_to_string(dir.join("fit.csv")).unwrap();
    let mut lines = fit.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |suffix: &str| header.iter().position(|h| h.ends_with(suffix)).unwrap();
    let (measured, optimized) = (col("measured"), col("optimized"));
    let squares: Vec<f64> = lines
        .map(|l| l.split(',').map(|v| v.parse::<f64>().unwrap_or(f64::NAN)).collect::<Vec<_>>())
        .filter(|r| r[0] > 15.0 && r[0] <= 20.0)
        .map(|r| (r[optimized] - r[measured]).powi(2))
        .collect();
    (evaluations, (squares.iter().sum::<f64>() / squares.len() as f64).sqrt())
}

#[test]
fn the_readme_example_finds_the_friction_of_a_model_with_no_port_and_its_job_reproduces_the_fit() {
    // examples/friction: a spring–mass as a tool exports it (no injection input), data with a
    // Coulomb friction of 0.05 m/s², no [diagnose] section.
    let dir = tempfile::tempdir().unwrap();
    let job = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/friction/job.toml");
    let run = fmucal(&["diagnose", job.to_str().unwrap(), "--out", "diagnosis"], dir.path());
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    assert!(stdout.contains("found: coulomb_friction on der(mass.v), force 0.05"), "{stdout}");
    assert!(stdout.contains(" m/s2"), "the strength is printed in the derivative's unit: {stdout}");
    let d = report(&dir.path().join("diagnosis"));
    assert_eq!(d.conclusion, fmucal_diagnose::report::Conclusion::Named);
    let (force, se) = (d.fitted["effects[0].force"], d.standard_errors["effects[0].force"]);
    assert!((force - 0.05).abs() < 3.0 * se, "{force} ± {se}");
    // Every fitted value is printed with its standard error.
    for name in ["k", "d", "effects[0].force"] {
        assert!(stdout.lines().any(|l| l.trim_start().starts_with(name) && l.contains(" ± ")), "{name}: {stdout}");
    }

    // The written job runs from another folder, starts at the fit, and reproduces it.
    let elsewhere = dir.path().join("elsewhere");
    std::fs::create_dir_all(&elsewhere).unwrap();
    let written = dir.path().join("diagnosis/job.toml");
    let again = fmucal(&["calibrate", written.to_str().unwrap(), "--out", "again"], &elsewhere);
    assert!(again.status.success(), "{}", String::from_utf8_lossy(&again.stderr));
    let base = fmucal(&["calibrate", job.to_str().unwrap(), "--out", "base"], &elsewhere);
    assert!(base.status.success(), "{}", String::from_utf8_lossy(&base.stderr));
    let (evaluations, validation) = calibration(&elsewhere.join("again"));
    let (base_evaluations, _) = calibration(&elsewhere.join("base"));
    let relative = (validation / d.after.validation - 1.0).abs();
    assert!(relative < 0.01, "validation RMS {validation:e} vs the diagnosis's {:e}", d.after.validation);
    // It starts at the optimum, with the solver the diagnosis polished with (the example's job
    // names none): a tenth of the base calibration's evaluations at most.
    assert!(
        evaluations * 10 <= base_evaluations,
        "the written job: {evaluations} evaluations; the base calibration: {base_evaluations}"
    );
}

/// `report` as JSON without its wall times (which no two runs share).
fn without_wall_times(mut report: serde_json::Value) -> serde_json::Value {
    fn strip(v: &mut serde_json::Value) {
        match v {
            serde_json::Value::Object(map) => {
                map.retain(|k, _| !matches!(k.as_str(), "elapsed_s" | "base_calibration_s" | "seconds"));
                map.values_mut().for_each(strip);
            }
            serde_json::Value::Array(items) => items.iter_mut().for_each(strip),
            _ => {}
        }
    }
    strip(&mut report);
    report
}

#[test]
fn the_diagnosis_library_in_this_process_gives_the_command_line_report() {
    use fmucal_diagnose::driver::{self, Context, checks, in_process::InProcess};
    // The command line, on a local cluster of two workers.
    let dir = tempfile::tempdir().unwrap();
    let job = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/friction/job.toml");
    let run = fmucal(&["diagnose", job.to_str().unwrap(), "--workers", "2", "--out", "cli"], dir.path());
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let cli: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("cli/report.json")).unwrap()).unwrap();

    // The library, with no coordinator: every job on one thread of this process.
    let mut spec = fmucal_shared::job::JobSpec::from_toml_file(&job).unwrap();
    let settings = fmucal_diagnose::spec::DiagnoseSpec::from_job_text(&std::fs::read_to_string(&job).unwrap()).unwrap();
    spec.diagnose = None;
    let model = common::example("spring-mass");
    spec.model.path = Some(model.clone());
    let data = fmucal_shared::job::data::read_all(&spec).unwrap().pop().unwrap();
    let windows = checks::windows(&mut spec, &data, &settings).unwrap();
    let fmu = std::sync::Arc::new(common::load(&model, &dir.path().join("cache")));
    let ctx = Context::new(&spec, settings, windows, fmu.clone(), data, model).unwrap();
    let rt = tokio::runtime::Runtime::new().unwrap();
    let outcome = rt.block_on(driver::diagnose(InProcess { fmu, threads: 1 }, &ctx, spec, &())).unwrap();
    let library = serde_json::to_value(&outcome.diagnosis).unwrap();

    assert_eq!(outcome.diagnosis.conclusion, fmucal_diagnose::report::Conclusion::Named);
    assert_eq!(without_wall_times(library), without_wall_times(cli));
}
