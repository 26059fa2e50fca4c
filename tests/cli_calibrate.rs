//! `fmucal calibrate` through the real binary: a local run (in-process coordinator and worker
//! processes) writes result.json, convergence.csv and fit.csv; the summary and result.json hold
//! each output's RMS error in its unit and its fit %, as recomputed from fit.csv; `--coordinator
//! URL` gives the same result, bit for bit, on a separately started coordinator; a bad job is one clean
//! error line.

mod common;

use std::path::Path;
use std::process::Command;

/// Decay data (k = 1.7) every 4th sample, and a job fitting k in [0.1, 5] from 1.0 at tight
/// tolerances, with `extra` in its `[optimizer]`.
fn write_job(dir: &Path, extra: &str) -> std::path::PathBuf {
    common::write_decay_csv(dir, common::decay_samples(&dir.join("cache"), Some(1e-10), 4));
    let job = dir.join("job.toml");
    let text = common::decay_job_toml(
        5.0,
        &format!("[simulation]\ntolerance = 1e-10\n[optimizer]\nx_tol = 1e-8\nf_tol = 1e-14\n{extra}"),
    );
    std::fs::write(&job, text).unwrap();
    job
}

/// Writes the job (see [`write_job`]) and calibrates it with `workers` local workers (the
/// slots of one worker process) into `dir/out`, which must succeed.
fn calibrate_locally(dir: &Path, extra: &str, workers: &str) -> std::process::Output {
    let job = write_job(dir, extra);
    let out = fmucal(&["calibrate", job.to_str().unwrap(), "--workers", workers, "--out", "out"], dir);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    out
}

fn fmucal(args: &[&str], dir: &Path) -> std::process::Output {
    common::fmucal_in(dir).args(args).output().unwrap()
}

fn result(dir: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("result.json")).unwrap()).unwrap()
}

#[test]
fn local_run_writes_result_convergence_and_fit() {
    let dir = tempfile::tempdir().unwrap();
    let out = calibrate_locally(dir.path(), "", "2");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("k = 1.7"), "{stdout}");
    let r = result(&dir.path().join("out"));
    assert!((r["x_opt"]["k"].as_f64().unwrap() - 1.7).abs() < 1e-5, "{r}");
    for field in ["f_opt", "iterations", "evaluations", "termination", "elapsed_s"] {
        assert!(!r[field].is_null(), "result.json lacks {field}: {r}");
    }
    let conv = std::fs::read_to_string(dir.path().join("out/convergence.csv")).unwrap();
    assert!(conv.starts_with("round,evaluations,best_f,batch_wall_s\n") && conv.lines().count() > 3);
    let fit = std::fs::read_to_string(dir.path().join("out/fit.csv")).unwrap();
    assert!(fit.starts_with("time,x:measured,x:start,x:optimized\n"), "{}", &fit[..80]);
    let plots = ["fit", "error", "convergence"];
    for name in plots {
        let png = std::fs::read(dir.path().join(format!("out/{name}.png"))).unwrap();
        assert!(png.starts_with(b"\x89PNG\r\n\x1a\n") && png.len() > 1000, "{name}.png is not a PNG");
        let svg = std::fs::read_to_string(dir.path().join(format!("out/{name}.svg"))).unwrap();
        assert!(svg.contains("<svg") && svg.contains("</svg>"), "{name}.svg is not an SVG");
        std::fs::remove_file(dir.path().join(format!("out/{name}.png"))).unwrap();
    }
    // `fmucal plot` redraws them from the folder.
    let out = fmucal(&["plot", "out"], dir.path());
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    for name in plots {
        assert!(dir.path().join(format!("out/{name}.png")).is_file());
    }
    let out = fmucal(&["plot", "no-such-folder"], dir.path());
    assert_eq!(out.status.code(), Some(1));
    assert_eq!(String::from_utf8_lossy(&out.stderr).lines().count(), 1);
}

/// RMS error and fit % (100·(1 − ‖y − ŷ‖/‖y − ȳ‖)) of columns `model` against `measured` of
/// `fit.csv`'s rows with `lo < time <= hi` (the first row included when `lo` is -inf).
fn from_fit_csv(fit: &str, measured: usize, model: usize, lo: f64, hi: f64) -> (f64, f64) {
    let rows: Vec<Vec<f64>> = fit
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(|c| c.parse().unwrap()).collect::<Vec<f64>>())
        .filter(|r| r[0] > lo && r[0] <= hi)
        .collect();
    let n = rows.len() as f64;
    let mean = rows.iter().map(|r| r[measured]).sum::<f64>() / n;
    let residual: f64 = rows.iter().map(|r| (r[model] - r[measured]).powi(2)).sum();
    let spread: f64 = rows.iter().map(|r| (r[measured] - mean).powi(2)).sum();
    ((residual / n).sqrt(), 100.0 * (1.0 - (residual / spread).sqrt()))
}

#[test]
fn the_summary_has_each_outputs_rms_in_its_unit_and_fit_percent() {
    // The spring-mass example (mass.x in m, mass.v in m/s) measured at k = 5, d = 0.5 over
    // 10 s; k and d fitted from 4 and 0.3 on [0, 6] s and judged on (6, 10] s.
    let dir = tempfile::tempdir().unwrap();
    let fmu = common::load_example("spring-mass", &dir.path().join("cache"));
    let spec = fmucal_shared::sim::SimSpec {
        parameters: vec![("k".into(), "5".into()), ("d".into(), "0.5".into())],
        stop_time: Some(10.0),
        tolerance: Some(1e-10),
        ..Default::default()
    };
    let r = fmucal_shared::sim::simulate(&fmu, &spec).unwrap();
    let mut csv = String::from("time,x,v\n");
    let (x, v) = (r.column("mass.x").unwrap(), r.column("mass.v").unwrap());
    for i in (0..r.time.len()).step_by(10) {
        csv.push_str(&format!("{},{},{}\n", r.time[i], x[i], v[i]));
    }
    std::fs::write(dir.path().join("data.csv"), csv).unwrap();
    let text = common::job_toml(
        Path::new("example:spring-mass"),
        Some(Path::new("data.csv")),
        &[("mass.x", "x"), ("mass.v", "v")],
        &[],
        &[("k", 4.0, 1.0, 10.0), ("d", 0.3, 0.05, 2.0)],
        "[simulation]\ntolerance = 1e-10\nstop_time = 6.0\nvalidation_stop_time = 10.0\n[optimizer]\nx_tol = 1e-8\nf_tol = 1e-14\n",
    );
    std::fs::write(dir.path().join("job.toml"), text).unwrap();
    let out = fmucal(&["calibrate", "job.toml", "--workers", "2", "--out", "out"], dir.path());
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let stdout = String::from_utf8_lossy(&out.stdout);

    // The table: a header, then one row per output and window, with the output's unit.
    assert!(stdout.contains("per output (RMS error in the output's unit; fit % ="), "{stdout}");
    let header = stdout.lines().find(|l| l.contains("RMS start")).expect("a table header");
    for column in ["output", "unit", "window", "RMS start", "RMS optimized", "fit % start", "fit % optimized"] {
        assert!(header.contains(column), "{header}");
    }
    let row = |variable: &str, window: &str| -> Vec<String> {
        let line = stdout
            .lines()
            .find(|l| l.split_whitespace().next() == Some(variable) && l.contains(window))
            .unwrap_or_else(|| panic!("no row for {variable} {window}: {stdout}"));
        line.split_whitespace().map(str::to_owned).collect()
    };
    assert_eq!(row("mass.x", "calibration")[1], "m");
    assert_eq!(row("mass.v", "validation")[1], "m/s");

    // result.json: the same figures, which fit.csv's columns reproduce.
    let r = result(&dir.path().join("out"));
    let outputs = r["errors"]["outputs"].as_array().expect("errors.outputs in result.json");
    assert_eq!(outputs.len(), 2, "{r}");
    assert_eq!((outputs[0]["variable"].as_str(), outputs[0]["unit"].as_str()), (Some("mass.x"), Some("m")));
    assert_eq!((outputs[1]["variable"].as_str(), outputs[1]["unit"].as_str()), (Some("mass.v"), Some("m/s")));
    // "start" in the files, and the old name kept beside it.
    let window = &r["errors"]["calibration"];
    assert!(window["rms_start"].as_f64().is_some() && window["rms_nominal"] == window["rms_start"], "{r}");
    let fit = std::fs::read_to_string(dir.path().join("out/fit.csv")).unwrap();
    assert!(fit.starts_with("time,mass.x:measured,mass.x:start,mass.x:optimized,mass.v:measured,"), "{fit:.80}");
    let close = |got: &serde_json::Value, want: f64| {
        let got = got.as_f64().unwrap();
        assert!((got - want).abs() <= 1e-9 * want.abs().max(1e-12), "{got} != {want}");
    };
    for (k, o) in outputs.iter().enumerate() {
        let measured = 1 + 3 * k;
        for (name, lo, hi) in [("calibration", f64::NEG_INFINITY, 6.0), ("validation", 6.0, 10.0)] {
            let w = &o[name];
            let (rms_start, fit_start) = from_fit_csv(&fit, measured, measured + 1, lo, hi);
            let (rms_opt, fit_opt) = from_fit_csv(&fit, measured, measured + 2, lo, hi);
            close(&w["rms_start"], rms_start);
            close(&w["fit_percent_start"], fit_start);
            close(&w["rms_optimized"], rms_opt);
            close(&w["fit_percent_optimized"], fit_opt);
            // The start point fits worse than the optimum, which fits all but exactly.
            assert!(fit_start < 90.0 && fit_opt > 99.9, "{name} of {o}");
            // The printed row says the same, to its digits.
            let cells = row(o["variable"].as_str().unwrap(), name);
            assert_eq!(
                cells[3..7],
                [
                    format!("{rms_start:.3e}"),
                    format!("{rms_opt:.3e}"),
                    format!("{fit_start:.1}"),
                    format!("{fit_opt:.1}")
                ]
            );
        }
    }
}

/// The Furuta example with a validation window after 30 s, calibrated into `dir/out`.
fn calibrate_furuta_with_validation(dir: &Path) {
    let example = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/furuta");
    std::fs::copy(example.join("FurutaData.mat"), dir.join("FurutaData.mat")).unwrap();
    let job = std::fs::read_to_string(example.join("job.toml")).unwrap();
    let job = job.replace("stop_time = 40.0", "stop_time = 30.0\nvalidation_stop_time = 40.0");
    assert!(job.contains("validation_stop_time"), "{job}");
    std::fs::write(dir.join("job.toml"), job).unwrap();
    let out = fmucal(&["calibrate", "job.toml", "--out", "out"], dir);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
}

#[test]
fn plots_show_units_the_validation_split_and_parameter_paths_and_plot_redraws_them() {
    let dir = tempfile::tempdir().unwrap();
    calibrate_furuta_with_validation(dir.path());
    let out = dir.path().join("out");
    let r = result(&out);
    assert_eq!(r["units"]["armJoint.phi"], "rad", "{r}");
    assert_eq!(r["parameters"][1]["name"], "pendulumFriction", "{r}");
    let history = r["history"].as_array().unwrap();
    assert_eq!(history.last().unwrap()["best_x"].as_array().map(Vec::len), Some(2), "{r}");
    let check = |when: &str| {
        let fit = std::fs::read_to_string(out.join("fit.svg")).unwrap();
        for label in ["armJoint.phi [rad]", "pendulumJoint.phi [rad]", "time [s]", "validation →"] {
            assert!(fit.contains(&format!(">\n{label}\n</text>")), "{when}: fit.svg lacks {label}");
        }
        let error = std::fs::read_to_string(out.join("error.svg")).unwrap();
        assert!(error.contains("[rad]\n</text>"), "{when}: error.svg has no unit");
        let conv = std::fs::read_to_string(out.join("convergence.svg")).unwrap();
        for label in
            ["armFriction [0, 0.022]", "pendulumFriction [0, 0.012]", "parameters: best point after each batch"]
        {
            assert!(conv.contains(&format!(">\n{label}\n</text>")), "{when}: convergence.svg lacks {label}");
        }
    };
    check("calibrate");
    // `fmucal plot` redraws them from result.json and fit.csv, units and paths included.
    for name in ["fit", "error", "convergence"] {
        std::fs::remove_file(out.join(format!("{name}.svg"))).unwrap();
    }
    let plot = fmucal(&["plot", "out"], dir.path());
    assert!(plot.status.success(), "{}", String::from_utf8_lossy(&plot.stderr));
    check("plot");
}

#[test]
fn coordinator_url_gives_the_same_result() {
    let dir = tempfile::tempdir().unwrap();
    let job = write_job(dir.path(), "");
    let local = fmucal(&["calibrate", job.to_str().unwrap(), "--workers", "1", "--out", "local"], dir.path());
    assert!(local.status.success());
    let servers = common::Servers::start(dir.path(), 1);
    let out = Command::new(env!("CARGO_BIN_EXE_fmucal"))
        .args(["calibrate", job.to_str().unwrap(), "--coordinator", &servers.url, "--out", "remote"])
        .current_dir(dir.path())
        .env("FMUCAL_TOKEN", "cli-test-token")
        .output()
        .unwrap();
    // SIGTERM both servers: they shut down cleanly.
    assert!(servers.stop(), "a server did not exit cleanly on SIGTERM");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    // Bit for bit: the local run's model is the CLI's unpacked copy, the remote one an upload.
    let (local, remote) = (result(&dir.path().join("local")), result(&dir.path().join("remote")));
    for key in ["x_opt", "f_opt", "evaluations"] {
        assert_eq!(local[key], remote[key], "{key}");
    }
    // The wall time the CLI measured, not a coordinator's 0.
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains(" s\n") && !stdout.contains(" in 0.00 s"), "{stdout}");
    assert!(result(&dir.path().join("remote"))["elapsed_s"].as_f64().unwrap() > 0.0);
}

#[test]
fn a_bad_job_is_one_error_line() {
    let dir = tempfile::tempdir().unwrap();
    let job = write_job(dir.path(), "");
    common::edit_file(&job, |text| text.replace("name = \"k\"", "name = \"kk\""));
    let out = fmucal(&["calibrate", job.to_str().unwrap(), "--workers", "1"], dir.path());
    assert_eq!(out.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    assert!(stderr.contains("parameters[0].name: unknown variable \"kk\""), "{stderr}");
}

#[test]
fn an_output_with_weight_zero_leaves_the_result_unchanged() {
    // Stopped early, so the objective is far from zero and an extra output would show in it.
    let plain = tempfile::tempdir().unwrap();
    calibrate_locally(plain.path(), "max_iters = 3\n", "1");
    let zero = tempfile::tempdir().unwrap();
    let extra = "max_iters = 3\n[[outputs]]\nvariable = \"xAlias\"\ncolumn = \"x\"\nweight = 0.0\n";
    calibrate_locally(zero.path(), extra, "1");
    let (a, b) = (result(&plain.path().join("out")), result(&zero.path().join("out")));
    assert!(a["f_opt"].as_f64().unwrap() > 1e-3, "{a}");
    assert_eq!(a["f_opt"], b["f_opt"]);
    assert_eq!(a["x_opt"], b["x_opt"]);
}

/// The command lines of the processes running now that mention `text`.
fn processes_mentioning(text: &str) -> Vec<String> {
    let mut found = vec![];
    for entry in std::fs::read_dir("/proc").unwrap().flatten() {
        if let Ok(cmdline) = std::fs::read(entry.path().join("cmdline")) {
            let cmdline = String::from_utf8_lossy(&cmdline).replace('\0', " ");
            if cmdline.contains(text) {
                found.push(cmdline);
            }
        }
    }
    found
}

#[test]
fn ctrl_c_keeps_the_best_point_and_leaves_no_worker_or_temporary_folder() {
    let dir = tempfile::tempdir().unwrap();
    // Each simulation sleeps 0.3 s, and the tolerances cannot be met in 500 rounds: the run
    // is still going when it is interrupted.
    let job = write_job(dir.path(), "max_iters = 500\n");
    common::edit_file(&job, |text| text.replace("[optimizer]", "set = { delay = 0.3 }\n[optimizer]"));
    // A private temporary folder, to see what the run leaves there.
    let tmp = dir.path().join("tmp");
    std::fs::create_dir_all(&tmp).unwrap();
    let mut child = common::KillOnDrop(
        common::fmucal_in(dir.path())
            .args(["calibrate", job.to_str().unwrap(), "--workers", "2", "--out", "out"])
            .env("TMPDIR", &tmp)
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap(),
    );
    // Wait until the worker process of 2 slots runs, then for a few rounds.
    let marker = tmp.to_string_lossy().into_owned();
    let started = std::time::Instant::now();
    while !processes_mentioning(&marker).iter().any(|c| c.contains(" worker ") && c.contains(" --slots 2 ")) {
        assert!(started.elapsed().as_secs() < 60, "the workers did not start");
        std::thread::sleep(std::time::Duration::from_millis(100));
    }
    std::thread::sleep(std::time::Duration::from_secs(3));
    let _ = Command::new("kill").args(["-INT", &child.id().to_string()]).status();
    let status = child.wait().unwrap();
    let mut stderr = String::new();
    std::io::Read::read_to_string(child.stderr.as_mut().unwrap(), &mut stderr).unwrap();
    assert_eq!(status.code(), Some(130), "{stderr}");
    assert!(stderr.contains("interrupted: wrote the best point so far"), "{stderr}");
    let r = result(&dir.path().join("out"));
    assert_eq!(r["termination"], "interrupted", "{r}");
    assert!(r["evaluations"].as_u64().unwrap() >= 2 && r["f_opt"].as_f64().unwrap().is_finite(), "{r}");
    // The workers are gone at once, and so is the run's temporary folder.
    std::thread::sleep(std::time::Duration::from_millis(500));
    assert!(processes_mentioning(&marker).is_empty(), "{:?}", processes_mentioning(&marker));
    let left: Vec<_> = std::fs::read_dir(&tmp).unwrap().flatten().map(|e| e.path()).collect();
    assert!(left.is_empty(), "left in the temporary folder: {left:?}");
}

#[test]
fn a_once_per_process_fmu_gets_the_same_follow_up_points() {
    // A local run evaluates its follow-up points (the tolerance guard's first-order move, the
    // standard errors) in its own process: for an FMU that may be instantiated only once per
    // process they share one thread, and none fails for it. The Furuta example takes the
    // guard's move; without the guard, the standard errors come from points of their own.
    let dir = tempfile::tempdir().unwrap();
    let once = common::once_per_process("furuta", dir.path());
    let example = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/furuta");
    let text = std::fs::read_to_string(example.join("job.toml"))
        .unwrap()
        .replace("path = \"FurutaData.mat\"", &format!("path = \"{}\"", example.join("FurutaData.mat").display()));
    for (name, extra) in [("guarded", ""), ("unguarded", "tolerance_guard = false\n")] {
        let text = text.replace("[simulation]\n", &format!("[simulation]\n{extra}"));
        let plain = dir.path().join(format!("{name}.toml"));
        std::fs::write(&plain, &text).unwrap();
        let once_job = dir.path().join(format!("{name}_once.toml"));
        std::fs::write(&once_job, text.replace("path = \"example:furuta\"", &format!("path = \"{}\"", once.display())))
            .unwrap();
        let mut results = vec![];
        for job in [&plain, &once_job] {
            let out_dir = dir.path().join(job.file_stem().unwrap());
            let out = fmucal(
                &["calibrate", job.to_str().unwrap(), "--workers", "2", "--out", out_dir.to_str().unwrap()],
                dir.path(),
            );
            assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
            assert!(
                !String::from_utf8_lossy(&out.stderr).contains("no identifiability"),
                "{}",
                String::from_utf8_lossy(&out.stderr)
            );
            let mut r = result(&out_dir);
            without_seconds(&mut r);
            let kept: Vec<_> = ["x_opt", "f_opt", "evaluations", "identifiability", "tolerance_guard"]
                .iter()
                .map(|k| r[*k].clone())
                .collect();
            results.push(kept);
        }
        assert!(!results[0][3].is_null(), "{name}: no identifiability: {:?}", results[0]);
        assert_eq!(results[0], results[1], "{name}");
    }
}

/// `v` without its wall times (every `seconds` key).
fn without_seconds(v: &mut serde_json::Value) {
    match v {
        serde_json::Value::Object(m) => {
            m.remove("seconds");
            m.values_mut().for_each(without_seconds);
        }
        serde_json::Value::Array(a) => a.iter_mut().for_each(without_seconds),
        _ => {}
    }
}
