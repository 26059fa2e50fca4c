//! The Python client (`clients/python`, package `fmucal_client`) against real processes.
//!
//! - `pip install clients/python` on a fresh clone, into a fresh venv, builds the wheel (the
//!   `fmucal` binary and the package) with its cargo output in `target/python-target`, creates
//!   nothing in the clone (`git status --ignored` unchanged), and the README's five Python lines
//!   then give the CLI's `x_opt` bit for bit with the binary the wheel installed;
//! - the package's pytest suite (`clients/python/tests/`, the sources on the path of the venv of
//!   `tests/fmpy/ensure_venv.sh`, this build's binary as `FMUCAL_BIN`) runs against a
//!   coordinator and two worker processes: local runs and jobs submitted over gRPC give the
//!   CLI's result bit for bit, results carry the analysis after the fit, progress arrives in
//!   order, errors come back as exceptions naming the field, cancelling stops a job, and the
//!   examples of `examples/python` (scripts and the notebook, executed with nbclient) run. The
//!   suite also compares the client's TOML → `SubmitJobRequest` conversion with Rust's
//!   `job_to_proto`, whose requests this test writes for every job file under `examples/` and
//!   for a job that uses every field;
//! - `examples/python/calibrate_furuta.py --coordinator URL` recovers the Furuta frictions on a
//!   coordinator and writes its plot.

mod common;

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::OnceLock;
use std::time::{Duration, Instant};

use fmucal_proto::convert::{job_to_proto, result_from_proto};
use fmucal_proto::v1 as pb;
use fmucal_shared::job::JobSpec;
use prost::Message;

/// The client token of [`common::Servers`].
const TOKEN: &str = "cli-test-token";

fn repo() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// The venv's python, with `clients/python/src` on its path (a `.pth` file: the suite tests the
/// package's sources as they are, with `FMUCAL_BIN` for the binary; installing the package, which
/// builds the binary again, is [`pip_install_on_a_fresh_clone_writes_nothing_into_it_and_calibrates_as_the_cli`]'s).
/// A lock beside the venv keeps two set-ups (other test binaries, other runs) from overlapping.
fn python() -> &'static Path {
    static PY: OnceLock<PathBuf> = OnceLock::new();
    PY.get_or_init(|| {
        let py = reference_python();
        let venv = py.parent().and_then(Path::parent).expect("python is VENV/bin/python");
        // A package installed by an earlier version of this test would come before the `.pth`
        // entry on sys.path: it goes first.
        let setup = r#"
            set -euo pipefail
            exec 9>"$1"; flock 9
            site=$("$2" -c 'import sysconfig; print(sysconfig.get_path("purelib"))')
            if [ ! -f "$site/fmucal-client-src.pth" ] || [ "$(cat "$site/fmucal-client-src.pth")" != "$3" ]; then
              "$2" -m pip uninstall --yes --quiet --disable-pip-version-check fmucal-client >/dev/null 2>&1 || true
              printf '%s\n' "$3" > "$site/fmucal-client-src.pth"
            fi"#;
        let out = Command::new("bash")
            .args(["-c", setup, "setup"])
            .arg(venv.with_extension("client.lock"))
            .arg(py)
            .arg(repo().join("clients/python/src"))
            .output()
            .expect("run bash");
        assert!(
            out.status.success(),
            "putting clients/python/src on {}'s path failed:\n{}{}",
            venv.display(),
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        );
        py.to_owned()
    })
}

/// The python of `tests/fmpy/ensure_venv.sh`'s venv (FMPy, SciPy, and the Python package's
/// runtime, build and test tools).
fn reference_python() -> &'static Path {
    static PY: OnceLock<PathBuf> = OnceLock::new();
    PY.get_or_init(|| {
        let out =
            Command::new("bash").arg(repo().join("tests/fmpy/ensure_venv.sh")).output().expect("run ensure_venv.sh");
        // ensure_venv.sh says in one line why it failed (for example: PyPI unreachable).
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr).trim());
        PathBuf::from(String::from_utf8(out.stdout).unwrap().trim())
    })
}

/// Runs `cmd` (named `what`) to its end and returns its stdout; panics with its output if it fails.
fn run_ok(mut cmd: Command, what: &str) -> String {
    let out = cmd.stdin(Stdio::null()).output().unwrap_or_else(|e| panic!("{what}: {e}"));
    assert!(
        out.status.success(),
        "{what} failed ({}):\n{}{}",
        out.status,
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

/// Runs `cmd` with its output in files, killing it after `limit`; returns (success, output).
fn run_with_limit(mut cmd: Command, dir: &Path, limit: Duration) -> (bool, String) {
    let (out, err) = (dir.join("run.out"), dir.join("run.err"));
    let mut child = cmd
        .stdin(Stdio::null())
        .stdout(std::fs::File::create(&out).unwrap())
        .stderr(std::fs::File::create(&err).unwrap())
        .spawn()
        .expect("spawn");
    let start = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break Some(status);
        }
        if start.elapsed() > limit {
            let _ = child.kill();
            let _ = child.wait();
            break None;
        }
        std::thread::sleep(Duration::from_millis(100));
    };
    let text = std::fs::read_to_string(out).unwrap() + &std::fs::read_to_string(err).unwrap();
    match status {
        Some(s) => (s.success(), text),
        None => panic!("still running after {limit:?}, killed:\n{text}"),
    }
}

/// A second worker process for [`common::Servers`], stopped (SIGTERM) when dropped.
struct ExtraWorker(Child);

impl ExtraWorker {
    fn start(url: &str, cache: &Path) -> Self {
        let child = Command::new(env!("CARGO_BIN_EXE_fmucal"))
            .args(["worker", "--coordinator", url, "--slots", "1", "--cache-dir"])
            .arg(cache)
            .env("FMUCAL_TOKEN", TOKEN)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        ExtraWorker(child)
    }
}

impl Drop for ExtraWorker {
    fn drop(&mut self) {
        let _ = Command::new("kill").args(["-TERM", &self.0.id().to_string()]).status();
        let _ = self.0.wait();
    }
}

/// Every `*.toml` under `dir`, recursively, sorted.
fn job_files(dir: &Path) -> Vec<PathBuf> {
    let mut found = vec![];
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            found.extend(job_files(&path));
        } else if path.extension().is_some_and(|e| e == "toml") {
            found.push(path);
        }
    }
    found.sort();
    found
}

/// Copies the files (not the folders) of `from` into `to`.
fn copy_files(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for entry in std::fs::read_dir(from).unwrap() {
        let path = entry.unwrap().path();
        if path.is_file() {
            std::fs::copy(&path, to.join(path.file_name().unwrap())).unwrap();
        }
    }
}

/// An earlier calibration's `result.json` as the CLI writes it, for `set_from`.
fn earlier_result(path: &Path) {
    let result = result_from_proto(
        pb::JobResult {
            names: vec!["rightVolume.wallCapacity".into(), "rightVolume.wallConductance".into()],
            x_opt: vec![12345.678, 87.654_321],
            f_opt: 1.5,
            termination: "x_tol reached".into(),
            ..Default::default()
        },
        vec![],
    );
    std::fs::create_dir_all(path.parent().unwrap()).unwrap();
    std::fs::write(path, serde_json::to_string_pretty(&result).unwrap()).unwrap();
}

/// The `SubmitJobRequest` the CLI sends for the job file `toml` (as `fmucal calibrate
/// --coordinator` builds it), with the model's SHA-256 as its id.
fn rust_request(toml: &Path) -> pb::SubmitJobRequest {
    let spec = JobSpec::from_toml_file(toml).unwrap_or_else(|e| panic!("{}: {e}", toml.display()));
    spec.validate().unwrap_or_else(|e| panic!("{}: {e}", toml.display()));
    let model = spec.model.path.clone().unwrap();
    let model = match model.to_str().and_then(|p| p.strip_prefix("example:")) {
        Some(name) => common::example(name),
        None => model,
    };
    let id = fmucal_shared::fmu::archive::sha256_hex(&std::fs::read(&model).unwrap());
    let data = fmucal_shared::job::data::read_all(&spec).unwrap_or_else(|e| panic!("{}: {e}", toml.display()));
    pb::SubmitJobRequest { spec: Some(job_to_proto(&spec, &data, &id)) }
}

/// A job that sets every field of the job file, with CSV cells of every kind and a `.mat`.
const EVERY_FIELD: &str = include_str!("data/every_field.toml");

/// The other algorithms' options, each replacing the every-field job's `cma-es` options (an
/// option exists only for the algorithms that take it): with the every-field job, every
/// optimizer setting.
const OTHER_ALGORITHMS: [(&str, &str); 5] = [
    ("nelder-mead", "algorithm = \"nelder-mead\"\nparallel = false\ninitial_step = 0.2"),
    ("default", "parallel = false\ninitial_step = 0.3"),
    (
        "differential-evolution",
        "algorithm = \"differential-evolution\"\npopulation = 12\nweight = 0.7\ncrossover = 0.9",
    ),
    (
        "genetic",
        "algorithm = \"genetic\"\npopulation = 14\nbits = 16\ncrossover_rate = 0.8\nmutation_rate = 0.05\nelitism = 2",
    ),
    ("least-squares", "algorithm = \"least-squares\"\ninitial_step = 0.1"),
];

/// Writes the every-field job and its files into `dir`; returns the job file.
fn write_every_field_job(dir: &Path) -> PathBuf {
    write_every_field_job_with(dir, "algorithm = \"cma-es\"\n")
}

/// The every-field job with `options` in place of its algorithm's, written into `dir`.
fn write_every_field_job_with(dir: &Path, options: &str) -> PathBuf {
    std::fs::create_dir_all(dir.join("model")).unwrap();
    std::fs::copy(common::example("furuta"), dir.join("model/furuta.fmu")).unwrap();
    std::fs::copy(repo().join("examples/furuta/FurutaData.mat"), dir.join("FurutaData.mat")).unwrap();
    // The time column second and quoted, CRLF and LF lines, a blank line, spaces around cells,
    // empty and NaN cells, signs (-0 too), exponents and infinities.
    let shared = "phi,\"t\",theta,u,extra\r\n0.1,0,0.2,0,1\r\n\r\n ,0.5, NaN ,1e-3,+2\n.25,1,-0.5,-.5,inf\n1.5e0,1.5,,0,-inf\n3,2,7,-0,nan\n";
    std::fs::write(dir.join("shared.csv"), shared).unwrap();
    std::fs::write(dir.join("other.csv"), "time,phi,theta,u\n0,0.5,-0.3,0\n0.25,0.4,-0.25,0.125\n").unwrap();
    let cma_es = "algorithm = \"cma-es\"\n";
    let text = if options == cma_es {
        EVERY_FIELD.to_owned()
    } else {
        EVERY_FIELD
            .replace(cma_es, &format!("{options}\n"))
            .replace("initial_step = 0.2\npopulation = 12\nrestarts = 2\n", "")
    };
    common::write_file(dir, "job.toml", &text)
}

/// Writes Rust's `SubmitJobRequest` for every job file under `examples/` (each run on a copy of
/// its folder, with an earlier result where it fixes one with `set_from`) and for the
/// every-field job, and `manifest.json` listing them; returns the folder.
fn write_rust_requests(out: &Path) -> PathBuf {
    let mut manifest = vec![];
    let mut jobs: Vec<(String, PathBuf)> = vec![];
    for toml in job_files(&repo().join("examples")) {
        let name = toml.strip_prefix(repo()).unwrap().to_str().unwrap().to_owned();
        let copy = out.join("jobs").join(&name);
        copy_files(toml.parent().unwrap(), copy.parent().unwrap());
        let table: toml::Table = std::fs::read_to_string(&copy).unwrap().parse().unwrap();
        let set_from = table.get("simulation").and_then(|s| s.get("set_from")).and_then(|s| s.as_str());
        if let Some(set_from) = set_from {
            earlier_result(&copy.parent().unwrap().join(set_from));
        }
        jobs.push((name, copy));
    }
    assert!(jobs.len() >= 6, "job files under examples/: {jobs:?}");
    jobs.push(("every-field".into(), write_every_field_job(&out.join("every-field"))));
    for (algorithm, options) in OTHER_ALGORITHMS {
        let name = format!("every-field-{algorithm}");
        jobs.push((name.clone(), write_every_field_job_with(&out.join(&name), options)));
    }
    for (name, toml) in &jobs {
        let request = out.join(format!("{}.bin", name.replace('/', "_")));
        std::fs::write(&request, rust_request(toml).encode_to_vec()).unwrap();
        manifest.push(serde_json::json!({ "name": name, "toml": toml, "request": request }));
    }
    std::fs::write(out.join("manifest.json"), serde_json::to_string_pretty(&manifest).unwrap()).unwrap();
    out.to_owned()
}

/// The environment every Python run gets: no token or TLS settings of the caller's, examples
/// written into `cache`, and no bytecode in the source tree.
fn python_command(cache: &Path) -> Command {
    let mut cmd = Command::new(python());
    for var in ["FMUCAL_TOKEN", "FMUCAL_WORKER_TOKEN", "FMUCAL_TLS_CA", "FMUCAL_TLS_CERT", "FMUCAL_TLS_KEY"] {
        cmd.env_remove(var);
    }
    cmd.env("FMUCAL_BIN", env!("CARGO_BIN_EXE_fmucal"))
        .env("FMUCAL_CACHE_DIR", cache)
        .env("PYTHONDONTWRITEBYTECODE", "1")
        .env("MPLBACKEND", "Agg");
    cmd
}

#[test]
fn python_client_suite_passes_against_a_coordinator_and_workers() {
    let dir = tempfile::tempdir().unwrap();
    let requests = write_rust_requests(&dir.path().join("requests"));
    // Rust's conversion of the every-field job holds what the suite compares: own and shared
    // tables, an empty input list, every optimizer setting.
    let every = pb::SubmitJobRequest::decode(&*std::fs::read(requests.join("every-field.bin")).unwrap());
    let every = every.unwrap().spec.unwrap();
    assert_eq!(every.experiments.len(), 3);
    assert!(every.data.is_some() && every.experiments[0].data.is_some() && every.experiments[1].data.is_none());
    assert_eq!(every.experiments[1].inputs.as_ref().map(|l| l.items.len()), Some(0));
    assert_eq!(every.simulation.as_ref().unwrap().set["negzero"], "-0");
    assert!(every.effects.iter().any(|e| e.state.as_deref() == Some("armJoint.w")), "a state effect");
    assert!(every.effects.iter().any(|e| e.reaction.as_deref() == Some("armJoint.w")), "a reaction");

    let servers = common::Servers::start(dir.path(), 2);
    let worker = ExtraWorker::start(&servers.url, &dir.path().join("worker2-cache"));
    let mut cmd = python_command(&dir.path().join("cache"));
    cmd.args(["-m", "pytest", "-p", "no:cacheprovider", "-q", "-rfEs", "tests"])
        .current_dir(repo().join("clients/python"))
        .env("FMUCAL_TEST_URL", &servers.url)
        .env("FMUCAL_TEST_TOKEN", TOKEN)
        .env("FMUCAL_TEST_RUST_REQUESTS", &requests);
    let started = Instant::now();
    let (ok, output) = run_with_limit(cmd, dir.path(), Duration::from_secs(900));
    drop(worker);
    let stopped = servers.stop();
    println!("pytest ({:.1} s):\n{output}", started.elapsed().as_secs_f64());
    assert!(ok, "the Python client's tests failed:\n{output}");
    assert!(stopped, "a server did not exit cleanly on SIGTERM");
    let summary = output.lines().rev().find(|l| l.contains(" passed")).unwrap_or_default();
    let passed: usize = summary.split_whitespace().next().and_then(|n| n.parse().ok()).unwrap_or(0);
    assert!(passed >= 60, "too few tests ran: {summary:?}");
    assert!(!summary.contains("skipped") && !summary.contains("deselected"), "{summary}");
}

#[test]
fn example_script_calibrates_furuta_from_python() {
    let dir = tempfile::tempdir().unwrap();
    let servers = common::Servers::start(dir.path(), 2);
    let token_file = dir.path().join("token");
    std::fs::write(&token_file, format!("{TOKEN}\n")).unwrap();
    let png = dir.path().join("furuta.png");
    let mut cmd = python_command(&dir.path().join("cache"));
    cmd.arg(repo().join("examples/python/calibrate_furuta.py"))
        .args(["--coordinator", &servers.url, "--token-file"])
        .arg(&token_file)
        .arg("--out")
        .arg(&png)
        .current_dir(dir.path());
    let (ok, output) = run_with_limit(cmd, dir.path(), Duration::from_secs(300));
    let stopped = servers.stop();
    assert!(ok, "calibrate_furuta.py failed:\n{output}");
    assert!(stopped, "a server did not exit cleanly on SIGTERM");
    let value = |name: &str| -> f64 {
        let line = output.lines().find(|l| l.trim_start().starts_with(&format!("{name} ="))).unwrap_or_else(|| {
            panic!("no line `{name} = ...` in:\n{output}");
        });
        line.split('=').nth(1).unwrap().split_whitespace().next().unwrap().parse().unwrap()
    };
    // Generated with 0.010 and 0.0010; the README's recovered values are 0.0099987 and 0.00099754.
    let (arm, pendulum) = (value("armFriction"), value("pendulumFriction"));
    assert!((arm - 0.010).abs() < 1e-4, "armFriction = {arm}\n{output}");
    assert!((pendulum - 0.0010).abs() < 2e-5, "pendulumFriction = {pendulum}\n{output}");
    let bytes = std::fs::read(&png).unwrap_or_else(|e| panic!("{}: {e}\n{output}", png.display()));
    assert!(bytes.starts_with(b"\x89PNG\r\n\x1a\n") && bytes.len() > 10_000, "{} bytes", bytes.len());
}

/// The commit the working tree is at (what a fresh clone checks out).
fn head_commit() -> String {
    let mut git = Command::new("git");
    git.arg("-C").arg(repo()).args(["rev-parse", "HEAD"]);
    run_ok(git, "git rev-parse HEAD").trim().to_owned()
}

/// `git status --ignored --porcelain` of `clone`: every untracked and ignored file too.
fn status_ignored(clone: &Path) -> String {
    let mut git = Command::new("git");
    git.arg("-C").arg(clone).args(["status", "--ignored", "--porcelain", "--untracked-files=all"]);
    run_ok(git, "git status --ignored")
}

/// The README's Python lines (the plot saved instead of shown), then `x_opt` as JSON with each
/// value's exact bits (`float.hex`) and where the package found its binary.
const FIVE_LINES: &str = r#"
import fmucal_client as fmucal
result = fmucal.calibrate("examples/furuta/job.toml")   # local worker processes, no coordinator
print(result.x_opt)             # dict name -> value
print(result.standard_errors)
result.plot()                   # with matplotlib installed

import json
from fmucal_client import binary
print("X_OPT " + json.dumps({k: v.hex() for k, v in result.x_opt.items()}))
print("BINARY " + binary.find())
"#;

#[test]
fn pip_install_on_a_fresh_clone_writes_nothing_into_it_and_calibrates_as_the_cli() {
    let dir = tempfile::tempdir().unwrap();
    let clone = dir.path().join("fmucal");
    let mut git = Command::new("git");
    git.args(["clone", "--quiet", "--no-checkout"]).arg(repo()).arg(&clone);
    run_ok(git, "git clone");
    let mut git = Command::new("git");
    git.arg("-C").arg(&clone).args(["checkout", "--quiet", "--detach", &head_commit()]);
    run_ok(git, "git checkout");
    let before = status_ignored(&clone);
    assert_eq!(before, "", "a fresh clone is clean");

    // A fresh venv; pip builds the wheel with maturin (PyPI for the build and runtime
    // dependencies), cargo's output in this checkout's target folder (outside the clone, kept
    // between runs).
    let venv = dir.path().join("venv");
    let mut mkvenv = Command::new("python3");
    mkvenv.args(["-m", "venv"]).arg(&venv);
    run_ok(mkvenv, "python3 -m venv");
    let py = venv.join("bin/python");
    let target = repo().join("target/python-target");
    let started = Instant::now();
    let mut pip = Command::new(&py);
    pip.args(["-m", "pip", "install", "--disable-pip-version-check", "--quiet"])
        .arg(clone.join("clients/python"))
        .arg("matplotlib==3.11.2")
        .env("FMUCAL_PYTHON_TARGET_DIR", &target)
        .env_remove("CARGO_TARGET_DIR")
        .env_remove("PYTHONDONTWRITEBYTECODE")
        .current_dir(&clone);
    let log = dir.path().join("pip");
    std::fs::create_dir_all(&log).unwrap();
    let (ok, output) = run_with_limit(pip, &log, Duration::from_secs(3600));
    println!("pip install clients/python: {:.0} s", started.elapsed().as_secs_f64());
    assert!(ok, "pip install clients/python failed:\n{output}");
    assert_eq!(status_ignored(&clone), before, "installing wrote into the clone");
    assert!(target.join("release/fmucal").is_file(), "cargo's output is not in {}", target.display());

    // The README's lines, from the clone's root, with the binary the wheel installed.
    let mut five = Command::new(&py);
    five.arg("-c")
        .arg(FIVE_LINES)
        .current_dir(&clone)
        .env_remove("FMUCAL_BIN")
        .env("MPLBACKEND", "Agg")
        .env("FMUCAL_CACHE_DIR", dir.path().join("cache"));
    let printed = run_ok(five, "the README's Python lines");
    let line = |tag: &str| {
        printed
            .lines()
            .find_map(|l| l.strip_prefix(tag))
            .unwrap_or_else(|| panic!("no {tag} in:\n{printed}"))
            .to_owned()
    };
    assert_eq!(Path::new(&line("BINARY ")), venv.join("bin/fmucal"), "the package runs the binary its wheel installed");
    let x_python: std::collections::BTreeMap<String, String> = serde_json::from_str(&line("X_OPT ")).unwrap();

    // The CLI on the same job.
    let mut cli = Command::new(env!("CARGO_BIN_EXE_fmucal"));
    cli.args(["calibrate", "examples/furuta/job.toml", "--out"])
        .arg(dir.path().join("cli"))
        .current_dir(&clone)
        .env("FMUCAL_CACHE_DIR", dir.path().join("cache"));
    run_ok(cli, "fmucal calibrate");
    let result: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("cli/result.json")).unwrap()).unwrap();
    let x_cli = result["x_opt"].as_object().unwrap();
    assert_eq!(x_python.len(), 2, "{printed}");
    for (name, bits) in &x_python {
        let cli_value = x_cli[name].as_f64().unwrap();
        let python_value = parse_hex_float(bits);
        assert_eq!(python_value.to_bits(), cli_value.to_bits(), "{name}: Python {bits}, CLI {cli_value:e}");
    }
    println!("x_opt from Python and from the CLI, bit for bit: {x_python:?}");
    // Running wrote nothing into the clone either.
    assert_eq!(status_ignored(&clone), before, "calibrating from Python wrote into the clone");
}

/// A double from Python's `float.hex()` (`0x1.47ae147ae147bp-7`, `-0x0.0p+0`).
fn parse_hex_float(text: &str) -> f64 {
    let (sign, rest) = match text.strip_prefix('-') {
        Some(r) => (-1.0, r),
        None => (1.0, text),
    };
    let rest = rest.strip_prefix("0x").expect("0x");
    let (mantissa, exponent) = rest.split_once('p').expect("p");
    let (int, frac) = mantissa.split_once('.').unwrap_or((mantissa, ""));
    let mut bits = u64::from_str_radix(int, 16).unwrap();
    for c in frac.chars() {
        bits = bits * 16 + c.to_digit(16).unwrap() as u64;
    }
    let exponent: i32 = exponent.parse().unwrap();
    // Exact: at most 53 significant bits, scaled by a power of two.
    sign * bits as f64 * 2f64.powi(exponent - 4 * frac.len() as i32)
}
