//! Careless and hostile input on the command line, in job files and in data, through the real
//! `fmucal` binary: each is refused in one line naming the field (or flag) at fault, quickly,
//! without a panic; what a run leaves behind (worker processes, its run folder, an empty
//! `--out` folder) is gone when it ends, however it ends.

mod common;

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

/// Runs `fmucal ARGS` in `dir` (its own unpack cache and temporary folder), killed after 60 s.
fn fmucal(dir: &Path, args: &[&str]) -> Output {
    let mut child = command(dir, args).stdout(Stdio::piped()).stderr(Stdio::piped()).spawn().unwrap();
    let started = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if started.elapsed() > Duration::from_secs(60) {
            let _ = child.kill();
            panic!("fmucal {args:?} ran for over 60 s");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    child.wait_with_output().unwrap()
}

fn command(dir: &Path, args: &[&str]) -> Command {
    let mut cmd = common::fmucal_in(dir);
    cmd.args(args).env("TMPDIR", tmp(dir)).env_remove("FMUCAL_TOKEN").env_remove("FMUCAL_LOG");
    cmd
}

/// The temporary folder the runs of a test get (run folders are made there).
fn tmp(dir: &Path) -> PathBuf {
    let t = dir.join("tmp");
    std::fs::create_dir_all(&t).unwrap();
    t
}

/// Asserts `out` is a clean failure: exit code 1, no panic, one `error:` line containing every
/// needle. Returns that line.
fn refused(out: &Output, needles: &[&str]) -> String {
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!stderr.contains("panicked"), "panic: {stderr}");
    assert_eq!(out.status.code(), Some(1), "exit code; stderr: {stderr}");
    let lines: Vec<&str> = stderr.lines().filter(|l| l.starts_with("error: ")).collect();
    assert_eq!(lines.len(), 1, "expected one error line, got: {stderr}");
    for n in needles {
        assert!(lines[0].contains(n), "{n:?} is not in {:?}", lines[0]);
    }
    lines[0].to_owned()
}

/// A one-parameter job on the `decay` example (x' = -k x, k = 1.7 in the data) in `dir`:
/// `data.csv` and `job.toml`, with `extra` appended (TOML tables).
fn decay_job(dir: &Path, extra: &str) -> PathBuf {
    let mut csv = String::from("time,x\n");
    for i in 0..=20 {
        let t = i as f64 * 0.1;
        csv.push_str(&format!("{t},{}\n", (-1.7 * t).exp()));
    }
    std::fs::write(dir.join("data.csv"), csv).unwrap();
    write_job(dir, "job.toml", &decay_text(extra))
}

fn decay_text(extra: &str) -> String {
    common::decay_job_toml(5.0, &format!("[optimizer]\nx_tol = 1e-4\nf_tol = 1e-10\n{extra}"))
}

fn write_job(dir: &Path, name: &str, text: &str) -> PathBuf {
    common::write_file(dir, name, text)
}

/// `examples/NAME`'s job file and its data copied into `dir`, the job's text edited by `edit`.
fn example_job(dir: &Path, name: &str, edit: impl Fn(String) -> String) -> PathBuf {
    let from = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples").join(name);
    for entry in std::fs::read_dir(&from).unwrap() {
        let p = entry.unwrap().path();
        if p.extension().is_some_and(|e| e == "csv" || e == "mat") {
            std::fs::copy(&p, dir.join(p.file_name().unwrap())).unwrap();
        }
    }
    let text = std::fs::read_to_string(from.join("job.toml")).unwrap();
    write_job(dir, "job.toml", &edit(text))
}

fn calibrate(dir: &Path, job: &Path, extra: &[&str]) -> Output {
    fmucal(dir, &[&["calibrate", job.to_str().unwrap(), "--out", "out"], extra].concat())
}

#[test]
fn worker_counts_past_the_cap_or_zero_are_refused_before_any_process_starts() {
    let dir = tempfile::tempdir().unwrap();
    let job = decay_job(dir.path(), "");
    let started = Instant::now();
    refused(&calibrate(dir.path(), &job, &["--workers", "100000"]), &["--workers: 100000 is not in 1..=256"]);
    refused(&calibrate(dir.path(), &job, &["--workers", "0"]), &["--workers: 0"]);
    let many = decay_job(dir.path(), "[workers]\ncount = 1000000\n");
    refused(&calibrate(dir.path(), &many, &[]), &["workers.count: 1000000 is not in 1..=256"]);
    let none = decay_job(dir.path(), "[workers]\ncount = 0\n");
    refused(&calibrate(dir.path(), &none, &[]), &["workers.count: 0 is not in 1..=256"]);
    refused(&fmucal(dir.path(), &["diagnose", many.to_str().unwrap()]), &["workers.count"]);
    assert!(started.elapsed() < Duration::from_secs(20), "{:?}", started.elapsed());
    // Up to the cap is fine (a job with one worker runs).
    let one = decay_job(dir.path(), "[workers]\ncount = 1\n");
    let out = calibrate(dir.path(), &one, &[]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
}

#[test]
fn data_and_model_paths_that_are_not_regular_files_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    decay_job(d, "");
    let fifo = d.join("fifo.csv");
    assert!(Command::new("mkfifo").arg(&fifo).status().unwrap().success());
    std::fs::create_dir(d.join("folder.csv")).unwrap();
    let text = decay_text("");
    for (path, kind) in
        [("/dev/zero", "a character device"), (fifo.to_str().unwrap(), "a FIFO"), ("folder.csv", "a directory")]
    {
        let job = write_job(d, "bad.toml", &text.replace("path = \"data.csv\"", &format!("path = \"{path}\"")));
        let line = refused(&calibrate(d, &job, &[]), &["data.path: ", path, kind, "not a regular file"]);
        assert!(line.len() < 300, "{line}");
        let line = refused(&fmucal(d, &["diagnose", job.to_str().unwrap()]), &["data.path: ", path, kind]);
        assert!(line.len() < 300, "{line}");
        let job = write_job(d, "bad.toml", &text.replace("path = \"example:decay\"", &format!("path = \"{path}\"")));
        refused(&calibrate(d, &job, &[]), &["model.path: ", path, kind]);
    }
    let job = write_job(d, "bad.toml", &text.replace("path = \"data.csv\"", "path = \"missing.csv\""));
    refused(&calibrate(d, &job, &[]), &["data.path: ", "missing.csv", "No such file"]);
    // `fmucal inspect` and `simulate` read models through the same archive check.
    refused(&fmucal(d, &["inspect", "/dev/zero"]), &["/dev/zero is a character device, not a regular file"]);
    // The job file itself, the result an earlier stage's set_from names, and a simulation's
    // input table.
    refused(&calibrate(d, Path::new("/dev/zero"), &[]), &["job file: \"/dev/zero\" is a character device"]);
    refused(&fmucal(d, &["diagnose", fifo.to_str().unwrap()]), &["job file: ", "is a FIFO"]);
    let job =
        write_job(d, "bad.toml", &text.replace("[optimizer]", "[simulation]\nset_from = \"/dev/zero\"\n[optimizer]"));
    refused(&calibrate(d, &job, &[]), &["simulation.set_from: \"/dev/zero\" is a character device"]);
    let out = fmucal(d, &["simulate", "example:decay", "--input", fifo.to_str().unwrap(), "-o", "sim.csv"]);
    refused(&out, &["fifo.csv", "is a FIFO, not a regular file"]);
    assert!(!d.join("out").exists());
}

/// The pids of the processes whose parent is `parent`.
fn children_of(parent: u32) -> Vec<u32> {
    let mut out = vec![];
    for entry in std::fs::read_dir("/proc").unwrap().flatten() {
        let Ok(pid) = entry.file_name().to_string_lossy().parse::<u32>() else { continue };
        let Ok(stat) = std::fs::read_to_string(entry.path().join("stat")) else { continue };
        let Some(after) = stat.rfind(')').map(|i| &stat[i + 1..]) else { continue };
        if after.split_whitespace().nth(1).and_then(|p| p.parse::<u32>().ok()) == Some(parent) {
            out.push(pid);
        }
    }
    out
}

fn alive(pid: u32) -> bool {
    std::fs::read_to_string(format!("/proc/{pid}/stat"))
        .is_ok_and(|s| s.rfind(')').is_some_and(|i| !s[i + 1..].trim_start().starts_with('Z')))
}

fn run_folders(tmp: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(tmp)
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.file_name().unwrap().to_string_lossy().starts_with("fmucal-run-"))
        .collect();
    v.sort();
    v
}

#[test]
fn a_killed_calibration_takes_its_workers_and_the_next_run_removes_its_folder() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // Runs until killed: no tolerance ends it.
    let job = decay_job(d, "max_iters = 10000000\n[workers]\ncount = 3\n").to_str().unwrap().to_owned();
    let job = write_job(
        d,
        "job.toml",
        &std::fs::read_to_string(&job).unwrap().replace("x_tol = 1e-4\nf_tol = 1e-10", "x_tol = 0.0\nf_tol = 0.0"),
    );
    let mut run = common::KillOnDrop(
        command(d, &["calibrate", job.to_str().unwrap(), "--out", "out"])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap(),
    );
    let started = Instant::now();
    let workers = loop {
        let w = children_of(run.id());
        // Its 3 workers are one worker process of 3 slots.
        if w.len() == 1 && !run_folders(&tmp(d)).is_empty() {
            break w;
        }
        assert!(started.elapsed() < Duration::from_secs(30), "the run did not start its worker process: {w:?}");
        std::thread::sleep(Duration::from_millis(50));
    };
    // Let the workers register and evaluate for a moment.
    std::thread::sleep(Duration::from_millis(1500));
    run.kill().unwrap();
    run.wait().unwrap();
    let killed = Instant::now();
    while workers.iter().any(|&w| alive(w)) {
        assert!(killed.elapsed() < Duration::from_secs(5), "workers still running 5 s after SIGKILL: {workers:?}");
        std::thread::sleep(Duration::from_millis(50));
    }
    let stale = run_folders(&tmp(d));
    assert_eq!(stale.len(), 1, "{stale:?}");
    // Folders the next run must not touch: another program's, one without an owner file, and
    // a running run's (this test process stands for it).
    let other = tmp(d).join("other-program-folder");
    std::fs::create_dir(&other).unwrap();
    let unowned = tmp(d).join("fmucal-run-unowned");
    std::fs::create_dir(&unowned).unwrap();
    let running = tmp(d).join("fmucal-run-running");
    std::fs::create_dir(&running).unwrap();
    let me = std::process::id();
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap();
    let start: u64 = stat[stat.rfind(')').unwrap() + 1..].split_whitespace().nth(19).unwrap().parse().unwrap();
    let ns = std::fs::read_link("/proc/self/ns/pid").unwrap().to_string_lossy().into_owned();
    std::fs::write(running.join("owner"), format!("{me} {start} {ns}\n")).unwrap();

    let quick = decay_job(d, "[workers]\ncount = 1\n");
    let out = calibrate(d, &quick, &[]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(!stale[0].exists(), "the killed run's folder is still there");
    assert!(other.exists() && unowned.exists() && running.exists());
    assert_eq!(run_folders(&tmp(d)), vec![running, unowned], "the quick run's own folder is gone too");
}

#[test]
fn two_inputs_mapped_to_the_same_fmu_input_or_an_output_given_twice_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let twice = "[[inputs]]\ncolumn = \"u\"\nvariable = \"u\"\n";
    let job = example_job(dir.path(), "furuta", |t| {
        t.replace(twice, &format!("{twice}[[inputs]]\ncolumn = \"phi\"\nvariable = \"u\"\n"))
    });
    refused(&calibrate(dir.path(), &job, &[]), &["inputs[1].variable: \"u\" is already mapped by inputs[0]"]);
    let output = "[[outputs]]\nvariable = \"pendulumJoint.phi\"\ncolumn = \"theta\"\n";
    let job = example_job(dir.path(), "furuta", |t| t.replace(output, &format!("{output}{output}")));
    refused(
        &calibrate(dir.path(), &job, &[]),
        &["outputs[2]: \"pendulumJoint.phi\" against column \"theta\" is the same as outputs[1]"],
    );
    assert!(!dir.path().join("out").exists());
}

#[test]
fn validation_stop_time_is_checked_alike_by_calibrate_and_diagnose() {
    let dir = tempfile::tempdir().unwrap();
    for (value, says) in [
        ("10.0", "simulation.validation_stop_time: 10 is not a finite time after the calibration stop time 15"),
        ("15.0", "simulation.validation_stop_time: 15 is not a finite time after"),
        ("nan", "simulation.validation_stop_time: NaN is not a finite time"),
        ("inf", "simulation.validation_stop_time: inf is not a finite time"),
    ] {
        let job = example_job(dir.path(), "diagnose", |t| {
            t.replace("validation_stop_time = 20.0", &format!("validation_stop_time = {value}"))
        });
        let a = refused(&calibrate(dir.path(), &job, &[]), &[says]);
        let b = refused(&fmucal(dir.path(), &["diagnose", job.to_str().unwrap(), "--out", "out"]), &[says]);
        assert_eq!(a, b);
    }
    // Without a stop time, the data's last time is the calibration stop (20 s here).
    let job = example_job(dir.path(), "diagnose", |t| {
        t.replace("stop_time = 15.0", "").replace("validation_stop_time = 20.0", "validation_stop_time = 18.0")
    });
    let says = "simulation.validation_stop_time: 18 is not a finite time after the calibration stop time 20";
    let a = refused(&calibrate(dir.path(), &job, &[]), &[says]);
    assert_eq!(a, refused(&fmucal(dir.path(), &["diagnose", job.to_str().unwrap(), "--out", "out"]), &[says]));
    // `nan` for the other times names them too.
    let job = example_job(dir.path(), "diagnose", |t| t.replace("stop_time = 15.0", "stop_time = nan"));
    refused(&calibrate(dir.path(), &job, &[]), &["simulation.stop_time: NaN is not a finite time"]);
}

#[test]
fn an_objective_that_overflows_is_reported_as_such_and_a_zero_weight_prints_no_nan() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let job = decay_job(d, "max_fevals = 40\n[workers]\ncount = 1\n");
    let mut csv = String::from("time,x\n");
    for i in 0..=20 {
        csv.push_str(&format!("{},{}\n", i as f64 * 0.1, if i % 2 == 0 { 1e308 } else { -1e308 }));
    }
    std::fs::write(d.join("data.csv"), &csv).unwrap();
    let line = refused(&calibrate(d, &job, &[]), &["no evaluation gave a finite objective", "overflowed (f = inf"]);
    assert!(!line.contains("none was evaluated"), "{line}");
    // A failed local job leaves no `--out` folder it made.
    assert!(!d.join("out").exists(), "a failed run left its --out folder");
    // ...but one that existed before stays.
    std::fs::create_dir(d.join("out")).unwrap();
    refused(&calibrate(d, &job, &[]), &["overflowed"]);
    assert!(d.join("out").is_dir());

    let text = std::fs::read_to_string(&job).unwrap().replace("column = \"x\"\n", "column = \"x\"\nweight = 0.0\n");
    let zero = write_job(d, "zero.toml", &text);
    let out = calibrate(d, &zero, &[]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(stdout.contains("scaled RMS error") && !stdout.contains("NaN"), "{stdout}");
    assert!(stdout.contains("n/a (the start error is 0"), "{stdout}");
}

#[test]
fn errors_quote_user_text_bounded_and_escaped() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    decay_job(d, "");
    let long = "p".repeat(10_000_000);
    let job = write_job(d, "long.toml", &decay_text("").replace("name = \"k\"", &format!("name = \"{long}\"")));
    let out = calibrate(d, &job, &[]);
    let line = refused(&out, &["parameters[0].name: unknown variable \"ppp", "…\" (10000000 bytes)"]);
    assert!(out.stderr.len() < 1_000, "{} bytes of error", out.stderr.len());
    assert!(line.len() < 400, "{line}");
    // NUL and a right-to-left override in a job file come back escaped, never raw.
    let job = write_job(d, "bidi.toml", &decay_text("").replace("name = \"k\"", "name = \"k\\u0000\\u202Eevil\""));
    let out = calibrate(d, &job, &[]);
    refused(&out, &["parameters[0].name", r#""k\0\u{202e}evil""#]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!stderr.contains('\0') && !stderr.contains('\u{202e}'), "{stderr:?}");
    // A TOML syntax error quotes the line it is on: bounded as well.
    let job = write_job(d, "syntax.toml", &format!("{}\nbogus = \"{}\u{202e}", decay_text(""), "y".repeat(100_000)));
    let out = calibrate(d, &job, &[]);
    let line = refused(&out, &["toml: "]);
    assert!(line.len() < 4_500 && !line.contains('\u{202e}'), "{} bytes", line.len());
}

#[test]
fn diagnose_port_problems_name_the_port_field() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let diagnose = |job: &Path| fmucal(d, &["diagnose", job.to_str().unwrap(), "--out", "out"]);
    let job = example_job(d, "diagnose", |t| t.replace("port = \"armJoint.tauExt\"", "port = \"armJoint.nope\""));
    refused(&diagnose(&job), &["diagnose.ports[0].port: port \"armJoint.nope\" is not a variable of the model"]);
    let job = example_job(d, "diagnose", |t| {
        t.replace("velocities = [\"pendulumJoint.w\"]", "velocities = [\"pendulumJoint.tauExt\"]")
    });
    refused(&diagnose(&job), &["diagnose.ports[1].velocities[0]: \"pendulumJoint.tauExt\" is the port itself"]);
    let job = example_job(d, "diagnose", |t| {
        t.replace("positions = [\"armJoint.phi\"]", "positions = [\"armJoint.phi\"]\nambient = 293.15")
    });
    refused(&diagnose(&job), &["diagnose.ports[0].ambient: a mechanical port takes no ambient temperature"]);
    let effect = "[[effects]]\nkind = \"viscous_damping\"\nport = \"pendulumJoint.tauExt\"\nsignal = \"pendulumJoint.tauExt\"\nparameters = { c = { start = 0.0, lower = 0.0, upper = 0.1 } }\n";
    let job = example_job(d, "diagnose", |t| t.replace("\n[diagnose]\n", &format!("\n{effect}[diagnose]\n")));
    let line = refused(&calibrate(d, &job, &[]), &["effects[0].signal: \"pendulumJoint.tauExt\" is the port itself"]);
    assert_eq!(line, refused(&diagnose(&job), &[]));
}

#[test]
fn careless_command_line_values_are_refused_naming_the_flag() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for host in ["", "../../etc", &"a".repeat(300), "bad host", "x-.example"] {
        let out = fmucal(d, &["certs", "--out", "certs", "--host", host]);
        let line = refused(&out, &["--host: ", "is not an IP address or a DNS name"]);
        assert!(line.len() < 400, "{line}");
        assert!(!d.join("certs").exists() && !d.join("etc").exists());
    }
    let out = fmucal(
        d,
        &["certs", "--out", "certs", "--host", "coordinator", "--host", "10.0.0.7", "--host", "*.example.org"],
    );
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));

    let job = decay_job(d, "");
    for url in ["ftp://example.org", "example.org:50051", "http://", "unix:/tmp/x"] {
        refused(&calibrate(d, &job, &["--coordinator", url]), &["--coordinator: "]);
    }
    let token = d.join("token");
    for text in ["x", "x\n", "short"] {
        std::fs::write(&token, text).unwrap();
        let out = calibrate(d, &job, &["--coordinator", "http://127.0.0.1:9", "--token-file", token.to_str().unwrap()]);
        refused(&out, &["--token-file: ", "a token needs at least 12"]);
    }
    let out = calibrate(d, &job, &["--coordinator", "http://127.0.0.1:9", "--token-file", "/dev/zero"]);
    refused(&out, &["--token-file: ", "not a regular file"]);
    assert!(!d.join("out").exists());
}
