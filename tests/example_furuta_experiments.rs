//! The multi-experiment example end to end: `fmucal calibrate
//! examples/furuta_experiments/job.toml` fits one pair of frictions and one initial pendulum
//! angle per fitted experiment to two experiments, reports the held-out third, and gives the
//! same result with 1 and 3 workers. The data were generated with frictions 0.010 and
//! 0.0010 and release angles 1.0 and 0.5 rad (`examples/furuta_experiments/generate.sh`).

use std::path::Path;
use std::process::Command;

fn calibrate(workers: &str, out: &Path) -> (serde_json::Value, String) {
    let job = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/furuta_experiments/job.toml");
    calibrate_job(&job, workers, out)
}

fn calibrate_job(job: &Path, workers: &str, out: &Path) -> (serde_json::Value, String) {
    let run = Command::new(env!("CARGO_BIN_EXE_fmucal"))
        .args(["calibrate", job.to_str().unwrap(), "--workers", workers, "--out"])
        .arg(out)
        .env("FMUCAL_CACHE_DIR", out.join("cache"))
        .output()
        .unwrap();
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let r = serde_json::from_str(&std::fs::read_to_string(out.join("result.json")).unwrap()).unwrap();
    (r, String::from_utf8_lossy(&run.stdout).into_owned())
}

#[test]
fn shared_frictions_and_per_experiment_angles_are_recovered_the_same_with_1_and_3_workers() {
    let dir = tempfile::tempdir().unwrap();
    let (one, stdout) = calibrate("1", &dir.path().join("one"));
    let (three, _) = calibrate("3", &dir.path().join("three"));
    assert_eq!(one["x_opt"], three["x_opt"], "the optimum depends on the number of workers");
    assert_eq!(one["evaluations"], three["evaluations"]);
    assert_eq!(one["f_opt"], three["f_opt"]);

    let x = &one["x_opt"];
    for (name, truth, tol) in [
        ("armFriction", 0.010, 0.01),
        ("pendulumFriction", 0.0010, 0.01),
        ("pendulumJoint.phi@sine", 1.0, 0.002),
        ("pendulumJoint.phi@steps", 0.5, 0.002),
    ] {
        let got = x[name].as_f64().unwrap_or_else(|| panic!("no {name} in {x}"));
        assert!((got - truth).abs() <= tol * truth, "{name}: recovered {got}, generated with {truth}");
    }
    assert!(x.get("pendulumJoint.phi@chirp").is_none(), "a validation experiment calibrates nothing: {x}");

    let experiments = one["experiments"].as_array().unwrap();
    let names: Vec<(&str, &str)> =
        experiments.iter().map(|e| (e["name"].as_str().unwrap(), e["role"].as_str().unwrap())).collect();
    assert_eq!(names, [("sine", "fit"), ("steps", "fit"), ("chirp", "validation")]);
    for e in experiments {
        // 5 mrad of noise on angles of order 1 rad: the optimized model's error is the noise.
        let window = &e["errors"]["calibration"];
        let rms = window["rms_optimized"].as_f64().unwrap();
        assert!(rms < 0.0055 && window["scaled_rms"].as_f64().unwrap() < 0.05, "{e}");
        let folder = dir.path().join("one").join(e["name"].as_str().unwrap());
        for file in ["fit.csv", "fit.svg", "fit.png", "error.png"] {
            assert!(folder.join(file).is_file(), "{} is missing", folder.join(file).display());
        }
    }
    assert!(stdout.contains("experiment chirp (validation)"), "{stdout}");

    // `fmucal plot` redraws every experiment's plots from the folder.
    let folder = dir.path().join("one");
    std::fs::remove_file(folder.join("steps/fit.svg")).unwrap();
    let plot = Command::new(env!("CARGO_BIN_EXE_fmucal")).arg("plot").arg(&folder).output().unwrap();
    assert!(plot.status.success(), "{}", String::from_utf8_lossy(&plot.stderr));
    assert!(folder.join("steps/fit.svg").is_file());
}

/// Least squares over the same experiments: the workers send back each experiment's residual
/// vector, the run concatenates them, and the solver reaches Nelder–Mead's optimum with far
/// fewer points.
#[test]
fn least_squares_fits_the_experiments_with_concatenated_residuals() {
    let dir = tempfile::tempdir().unwrap();
    let (nm, _) = calibrate("2", &dir.path().join("nm"));
    let examples = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/furuta_experiments");
    let text = std::fs::read_to_string(examples.join("job.toml")).unwrap();
    let text = text
        .replace("algorithm = \"nelder-mead\"", "algorithm = \"least-squares\"")
        .replace("path = \"", &format!("path = \"{}/", examples.display()))
        .replace(&format!("path = \"{}/example:", examples.display()), "path = \"example:");
    let job = dir.path().join("ls.toml");
    std::fs::write(&job, text).unwrap();
    let (ls, _) = calibrate_job(&job, "2", &dir.path().join("ls"));
    let (f_nm, f_ls) = (nm["f_opt"].as_f64().unwrap(), ls["f_opt"].as_f64().unwrap());
    assert!(f_ls <= 1.01 * f_nm, "least squares ends at {f_ls}, Nelder–Mead at {f_nm}");
    let (n_nm, n_ls) = (nm["evaluations"].as_u64().unwrap(), ls["evaluations"].as_u64().unwrap());
    assert!(3 * n_ls < n_nm, "least squares took {n_ls} points, Nelder–Mead {n_nm}");
    let angle = ls["x_opt"]["pendulumJoint.phi@steps"].as_f64().unwrap();
    assert!((angle - 0.5).abs() < 0.002, "{angle}");
}
