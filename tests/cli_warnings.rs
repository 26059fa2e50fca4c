//! The checks after every fit, through `fmucal calibrate`: each warning is printed as
//! `warning: ...` and listed in result.json's `warnings`; `--strict` turns any of them into exit
//! code 3 after the results are written; a validation window past the data is refused; the
//! summary says "start" and when a budget ended the run.

mod common;

use std::path::Path;

/// Decay data (k = 1.7) over [0, 2], every 4th sample, with `row` choosing and changing rows,
/// and a job fitting k in [0.1, `upper`] from 1.0 with `extra` in its `[optimizer]` (with tight tolerances unless it sets x_tol).
fn write_job(dir: &Path, upper: f64, extra: &str, row: impl Fn(f64, f64) -> Option<f64>) -> std::path::PathBuf {
    let samples = common::decay_samples(&dir.join("cache"), Some(1e-10), 4);
    common::write_decay_csv(dir, samples.into_iter().filter_map(|(t, x)| row(t, x).map(|x| (t, x))));
    let job = dir.join("job.toml");
    let text = common::decay_job_toml(
        upper,
        &if extra.contains("x_tol") {
            format!("[optimizer]\n{extra}")
        } else {
            format!("[optimizer]\nx_tol = 1e-8\nf_tol = 1e-14\n{extra}")
        },
    );
    std::fs::write(&job, text).unwrap();
    job
}

/// Appends `tables` to the job file.
fn append(job: &Path, tables: &str) {
    common::edit_file(job, |text| text + tables);
}

fn fmucal(args: &[&str], dir: &Path) -> std::process::Output {
    common::fmucal_in(dir).args(args).output().unwrap()
}

fn calibrate(dir: &Path, strict: bool) -> (std::process::Output, String, String) {
    let mut args = vec!["calibrate", "job.toml", "--workers", "2", "--out", "out"];
    if strict {
        args.push("--strict");
    }
    let out = fmucal(&args, dir);
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    (out, stdout, stderr)
}

fn warnings(dir: &Path) -> Vec<String> {
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("out/result.json")).unwrap()).unwrap();
    r["warnings"].as_array().expect("result.json lists its warnings").iter().map(|w| w.to_string()).collect()
}

fn has(warnings: &[String], text: &str) -> bool {
    warnings.iter().any(|w| w.contains(text))
}

#[test]
fn a_clean_fit_warns_nothing_and_says_start() {
    let dir = tempfile::tempdir().unwrap();
    write_job(dir.path(), 5.0, "", |_, x| Some(x));
    let (out, stdout, stderr) = calibrate(dir.path(), true);
    assert!(out.status.success(), "{stderr}");
    assert!(!stderr.contains("warning:"), "{stderr}");
    assert_eq!(warnings(dir.path()), Vec::<String>::new());
    assert!(stdout.contains("scaled RMS error (optimized / start): calibration"), "{stdout}");
    assert!(!stdout.contains("nominal") && !stdout.contains("a budget"), "{stdout}");
    assert!(stdout.contains("(standard error"), "{stdout}");
}

#[test]
fn a_parameter_at_its_bound_warns_and_strict_exits_3() {
    let dir = tempfile::tempdir().unwrap();
    write_job(dir.path(), 1.5, "", |_, x| Some(x));
    let (out, stdout, stderr) = calibrate(dir.path(), false);
    assert!(out.status.success(), "{stderr}");
    assert!(stdout.contains("k = 1.500000e0  (at upper bound)"), "{stdout}");
    assert!(!stdout.contains("standard error"), "{stdout}");
    assert!(stderr.contains("warning: k = 1.500000e0 is at its upper bound 1.5"), "{stderr}");
    assert!(has(&warnings(dir.path()), "is at its upper bound"));

    std::fs::remove_dir_all(dir.path().join("out")).unwrap();
    let (out, _, stderr) = calibrate(dir.path(), true);
    assert_eq!(out.status.code(), Some(3), "{stderr}");
    assert!(stderr.contains("warning: k = "), "{stderr}");
    // The results are written before the exit.
    assert!(has(&warnings(dir.path()), "is at its upper bound"));
}

#[test]
fn a_run_ended_by_its_budget_warns() {
    let dir = tempfile::tempdir().unwrap();
    write_job(dir.path(), 5.0, "max_iters = 2\n", |_, x| Some(x));
    let (out, stdout, stderr) = calibrate(dir.path(), false);
    assert!(out.status.success(), "{stderr}");
    assert!(stdout.contains("termination: max_iters reached (a budget, not convergence, ended the run)"), "{stdout}");
    assert!(stderr.contains("warning: the run ended on its budget (max_iters reached)"), "{stderr}");
    assert!(has(&warnings(dir.path()), "ended on its budget"));
}

#[test]
fn max_time_stops_the_run_with_its_best_point() {
    let dir = tempfile::tempdir().unwrap();
    // 0.1 s per simulation and no tolerance rule: only the wall time can end the run.
    let job = write_job(dir.path(), 5.0, "x_tol = 0\nf_tol = 0\nmax_iters = 100000\nmax_time = 4.0\n", |_, x| Some(x));
    append(&job, "[simulation]\nset = { delay = 0.1 }\n");
    let (out, stdout, stderr) = calibrate(dir.path(), false);
    assert!(out.status.success(), "{stderr}");
    assert!(stdout.contains("termination: max_time reached (a budget, not convergence, ended the run)"), "{stdout}");
    assert!(has(&warnings(dir.path()), "ended on its budget (max_time reached)"));
}

#[test]
fn data_starting_late_warns_of_the_defaulted_start_time() {
    let dir = tempfile::tempdir().unwrap();
    write_job(dir.path(), 5.0, "", |t, x| (t >= 0.5).then_some(x));
    let (out, _, stderr) = calibrate(dir.path(), true);
    assert_eq!(out.status.code(), Some(3), "{stderr}");
    assert!(stderr.contains("warning: simulation.start_time was defaulted to the data's first sample 0.5"), "{stderr}");
    assert!(has(&warnings(dir.path()), "start_time was defaulted"));
}

#[test]
fn a_validation_error_worse_than_at_the_start_warns() {
    let dir = tempfile::tempdir().unwrap();
    // The data leave the decay after 1 s: the fitted k = 1.7 extrapolates worse than k = 1.
    let job = write_job(dir.path(), 5.0, "", |t, x| Some(if t > 1.0 { 1.0 } else { x }));
    append(&job, "[simulation]\nstop_time = 1.0\nvalidation_stop_time = 2.0\n");
    let (out, stdout, stderr) = calibrate(dir.path(), false);
    assert!(out.status.success(), "{stderr}");
    assert!(stdout.contains("scaled RMS error (optimized / start): calibration"), "{stdout}");
    assert!(stderr.contains("warning: the validation error is worse than at the start point"), "{stderr}");
    assert!(has(&warnings(dir.path()), "validation error is worse"));
}

#[test]
fn a_validation_window_past_the_data_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let job = write_job(dir.path(), 5.0, "", |_, x| Some(x));
    append(&job, "[simulation]\nstop_time = 1.0\nvalidation_stop_time = 20.0\n");
    let (out, _, stderr) = calibrate(dir.path(), false);
    assert!(!out.status.success());
    assert_ne!(out.status.code(), Some(3));
    let line = stderr.lines().find(|l| l.contains("validation_stop_time")).unwrap_or_else(|| panic!("{stderr}"));
    assert!(line.contains("simulation.validation_stop_time: 20 is past the end of the data (2)"), "{stderr}");
    assert!(!dir.path().join("out").exists());
}

#[test]
fn the_largest_correlation_is_printed_with_its_sign_and_pair() {
    let dir = tempfile::tempdir().unwrap();
    let job = write_job(dir.path(), 5.0, "", |_, x| Some(x + 0.05));
    let text = std::fs::read_to_string(&job).unwrap().replace(
        "[optimizer]",
        "[[effects]]\nkind = \"sensor_offset\"\noutput = \"x\"\n\
         parameters = { offset = { start = 0.0, lower = -0.2, upper = 0.2 } }\n[optimizer]",
    );
    std::fs::write(&job, text).unwrap();
    let (out, stdout, stderr) = calibrate(dir.path(), false);
    assert!(out.status.success(), "{stderr}");
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("out/result.json")).unwrap()).unwrap();
    let id = &r["identifiability"];
    let names: Vec<&str> = id["names"].as_array().unwrap().iter().map(|n| n.as_str().unwrap()).collect();
    let c = id["correlation"][0][1].as_f64().unwrap();
    let line = format!("largest parameter correlation: {c:+.3} ({}, {})", names[0], names[1]);
    assert!(stdout.contains(&line), "{line} not in\n{stdout}");
}

#[test]
fn a_max_time_that_is_not_a_positive_number_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    write_job(dir.path(), 5.0, "max_time = -1.0\n", |_, x| Some(x));
    let (out, _, stderr) = calibrate(dir.path(), false);
    assert!(!out.status.success());
    assert!(stderr.contains("optimizer.max_time: must be a positive number of seconds, got -1"), "{stderr}");
}
