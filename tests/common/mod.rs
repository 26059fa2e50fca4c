//! Helpers shared by the integration tests: example FMUs, a per-test unpack cache, repacking an
//! example with edited entries (to build hostile or unusual archives), input tables and their
//! CSV files, and the TOML text of jobs.
#![allow(dead_code)]

use std::io::{Read, Write};
use std::path::{Path, PathBuf};

use fmucal_shared::fmu::{ArchiveLimits, Fmu, LoadOptions};
use fmucal_shared::sim::{InputTable, PortTerm, StateTerm};

pub mod diagnosis;
pub mod proto;

pub fn example(name: &str) -> PathBuf {
    fmucal_models::example(name).unwrap_or_else(|| panic!("no example {name}"))
}

/// Loads with a private cache directory so tests do not share unpacked files.
pub fn load(path: &Path, cache: &Path) -> Fmu {
    Fmu::load_with(path, &LoadOptions { cache_dir: cache.to_owned(), limits: ArchiveLimits::default() })
        .unwrap_or_else(|e| panic!("loading {}: {e}", path.display()))
}

pub fn load_example(name: &str, cache: &Path) -> Fmu {
    load(&example(name), cache)
}

/// Loads fixture `f` with its unpacked files under `dir/cache`.
pub fn fixture(f: fmucal_models::Fixture, dir: &Path) -> Fmu {
    load(&f.path(), &dir.join("cache"))
}

/// Reads every entry of a zip archive as (name, bytes).
pub fn entries(path: &Path) -> Vec<(String, Vec<u8>)> {
    let mut zip = zip::ZipArchive::new(std::fs::File::open(path).unwrap()).unwrap();
    (0..zip.len())
        .map(|i| {
            let mut f = zip.by_index(i).unwrap();
            let name = f.name().unwrap().to_string();
            let mut bytes = vec![];
            f.read_to_end(&mut bytes).unwrap();
            (name, bytes)
        })
        .collect()
}

/// Writes a zip with the given entries.
pub fn write_zip(path: &Path, entries: &[(String, Vec<u8>)]) {
    let mut zip = zip::ZipWriter::new(std::fs::File::create(path).unwrap());
    let opts = zip::write::SimpleFileOptions::default();
    for (name, bytes) in entries {
        zip.start_file(name.as_str(), opts).unwrap();
        zip.write_all(bytes).unwrap();
    }
    zip.finish().unwrap();
}

/// Copies example `name` to `dir/file`, passing each entry through `edit` (None drops it).
pub fn repack(name: &str, dir: &Path, file: &str, edit: impl Fn(&str, Vec<u8>) -> Option<Vec<u8>>) -> PathBuf {
    let out = dir.join(file);
    let kept: Vec<_> = entries(&example(name)).into_iter().filter_map(|(n, b)| edit(&n, b).map(|b| (n, b))).collect();
    write_zip(&out, &kept);
    out
}

/// Copies example `name` with its modelDescription.xml text edited by `f`.
pub fn with_xml(name: &str, dir: &Path, file: &str, f: impl Fn(String) -> String) -> PathBuf {
    repack(name, dir, file, |n, b| {
        if n == "modelDescription.xml" { Some(f(String::from_utf8(b).unwrap()).into_bytes()) } else { Some(b) }
    })
}

/// The fixture `name` repacked as `dir/once.fmu` with each interface declared
/// `canBeInstantiatedOnlyOncePerProcess`; returns that path.
pub fn once_per_process(name: &str, dir: &Path) -> PathBuf {
    with_xml(name, dir, "once.fmu", |xml| {
        let interfaces = xml.matches("<ModelExchange ").count() + xml.matches("<CoSimulation ").count();
        let edited = xml
            .replace("<ModelExchange ", "<ModelExchange canBeInstantiatedOnlyOncePerProcess=\"true\" ")
            .replace("<CoSimulation ", "<CoSimulation canBeInstantiatedOnlyOncePerProcess=\"true\" ");
        let marked = edited.matches("canBeInstantiatedOnlyOncePerProcess=\"true\"").count();
        assert!(interfaces > 0 && marked == interfaces, "{edited}");
        edited
    })
}

/// Writes `contents` to `dir/name`; returns that path.
pub fn write_file(dir: &Path, name: impl AsRef<Path>, contents: impl AsRef<[u8]>) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, contents).unwrap();
    path
}

/// Rewrites the text file at `path` with `edit`.
pub fn edit_file(path: &Path, edit: impl FnOnce(String) -> String) {
    let text = std::fs::read_to_string(path).unwrap();
    std::fs::write(path, edit(text)).unwrap();
}

/// Largest |a - b| over all points, relative to the largest |b|.
pub fn rel_max_diff(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len(), "series lengths differ");
    let scale = b.iter().fold(0.0f64, |m, v| m.max(v.abs())).max(1e-300);
    a.iter().zip(b).fold(0.0f64, |m, (x, y)| m.max((x - y).abs())) / scale
}

/// An input table from (column name, samples) pairs.
pub fn table(time: Vec<f64>, columns: Vec<(&str, Vec<f64>)>) -> InputTable {
    InputTable { time, columns: columns.into_iter().map(|(n, v)| (n.to_owned(), v)).collect() }
}

/// The term `kind` reading `signal`, with `parameters`, injected on the input `port`.
pub fn port_term(kind: &str, port: &str, signal: &str, parameters: Vec<f64>) -> PortTerm {
    PortTerm { kind: kind.into(), port: port.into(), signal: signal.into(), parameters }
}

/// The term `kind` reading `signal`, with `parameters`, added to the derivative of `state`.
pub fn state_term(kind: &str, state: &str, signal: &str, parameters: Vec<f64>) -> StateTerm {
    StateTerm { kind: kind.into(), state: state.into(), signal: signal.into(), parameters }
}

/// F = 2.2 sin(0.8 t), sampled every 0.05 s: several stick and slip phases in both directions.
pub fn sine_force() -> InputTable {
    let time: Vec<f64> = (0..=400).map(|k| k as f64 * 0.05).collect();
    let force = time.iter().map(|t| 2.2 * (0.8 * t).sin()).collect();
    table(time, vec![("F", force)])
}

/// F = 3 sin(t) N every 10 ms over 20 s: below the SpringMass resonance (2 rad/s), it drives
/// the mass to about ±1 m.
pub fn spring_force() -> InputTable {
    let time: Vec<f64> = (0..=2000).map(|k| k as f64 * 0.01).collect();
    let force = time.iter().map(|t| 3.0 * t.sin()).collect();
    table(time, vec![("F", force)])
}

/// The exhaust example's five measured inputs.
pub const EXHAUST_INPUTS: [&str; 5] = ["inlet.T", "inlet.p", "turbine1.w", "turbine2.w", "outlet.p"];

/// The exhaust example's data (`examples/exhaust/exhaust_data.csv`).
pub fn exhaust_data() -> fmucal_shared::job::MeasurementTable {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/exhaust/exhaust_data.csv");
    fmucal_shared::job::MeasurementTable::read(&path, "time").expect("the exhaust data reads")
}

/// The exhaust example's five inputs over its whole record.
pub fn exhaust_inputs() -> InputTable {
    let data = exhaust_data();
    table(data.time.clone(), EXHAUST_INPUTS.iter().map(|n| (*n, data.column(n).unwrap().to_vec())).collect())
}

/// Model Exchange at tolerance 1e-10 from 0 to `stop` on `inputs`, reporting `outputs` every `dt`.
pub fn model_exchange_spec(stop: f64, dt: f64, inputs: InputTable, outputs: &[&str]) -> fmucal_shared::sim::SimSpec {
    fmucal_shared::sim::SimSpec {
        interface: Some(fmucal_shared::fmu::Interface::ModelExchange),
        start_time: Some(0.0),
        stop_time: Some(stop),
        output_times: Some(fmucal_shared::sim::OutputTimes::Interval(dt)),
        inputs: Some(inputs),
        outputs: outputs.iter().map(|s| s.to_string()).collect(),
        tolerance: Some(1e-10),
        ..Default::default()
    }
}

/// uc ramps (continuous); ud, n and b change between output points (held).
pub fn every_kind_of_input() -> InputTable {
    table(
        vec![0.0, 0.7005, 1.5005, 2.2505, 3.0005, 4.0],
        vec![
            ("uc", vec![0.0, 0.7005, 1.5005, 0.5, 3.0, -1.0]),
            ("ud", vec![0.5, -1.0, -1.0, 2.0, 2.0, 2.0]),
            ("n", vec![0.0, 0.0, 3.0, 3.0, -2.0, -2.0]),
            ("b", vec![0.0, 1.0, 1.0, 0.0, 0.0, 0.0]),
        ],
    )
}

/// Writes `table` as a CSV file with a `time` column, as `fmucal simulate --input` and FMPy
/// read it.
pub fn write_input_csv(table: &InputTable, path: &Path) {
    let mut text = String::from("time");
    for (name, _) in &table.columns {
        text.push_str(&format!(",{name}"));
    }
    text.push('\n');
    for (i, t) in table.time.iter().enumerate() {
        text.push_str(&format!("{t}"));
        for (_, values) in &table.columns {
            text.push_str(&format!(",{}", values[i]));
        }
        text.push('\n');
    }
    std::fs::write(path, text).unwrap();
}

/// The TOML text of a job on the FMU at `model`: `data` is the measurement file (`None`: the
/// table is handed over separately), then one `[[outputs]]` per (variable, column), one
/// `[[inputs]]` per (column, variable), one `[[parameters]]` per (name, start, lower, upper),
/// and last `tables` (`[simulation]`, `[optimizer]`, ...) as written.
pub fn job_toml(
    model: &Path,
    data: Option<&Path>,
    outputs: &[(&str, &str)],
    inputs: &[(&str, &str)],
    parameters: &[(&str, f64, f64, f64)],
    tables: &str,
) -> String {
    let mut text = format!("[model]\npath = \"{}\"\n[data]\n", model.display());
    if let Some(data) = data {
        text.push_str(&format!("path = \"{}\"\n", data.display()));
    }
    for (variable, column) in outputs {
        text.push_str(&format!("[[outputs]]\nvariable = \"{variable}\"\ncolumn = \"{column}\"\n"));
    }
    for (column, variable) in inputs {
        text.push_str(&format!("[[inputs]]\ncolumn = \"{column}\"\nvariable = \"{variable}\"\n"));
    }
    // `{:?}` keeps the decimal point (1.0, not 1) and every digit.
    for (name, start, lower, upper) in parameters {
        text.push_str(&format!(
            "[[parameters]]\nname = \"{name}\"\nstart = {start:?}\nlower = {lower:?}\nupper = {upper:?}\n"
        ));
    }
    text + tables
}

/// The Decay example's `x` at k = 1.7 (simulated at `tolerance`, if given, with its unpacked
/// files in `cache`) as (time, x), every `every`-th sample of its default output grid.
pub fn decay_samples(cache: &Path, tolerance: Option<f64>, every: usize) -> Vec<(f64, f64)> {
    let fmu = load_example("decay", cache);
    let spec =
        fmucal_shared::sim::SimSpec { parameters: vec![("k".into(), "1.7".into())], tolerance, ..Default::default() };
    let r = fmucal_shared::sim::simulate(&fmu, &spec).unwrap();
    r.time.iter().copied().zip(r.column("x").unwrap().iter().copied()).step_by(every).collect()
}

/// Writes `samples` as `dir/data.csv`, with the columns `time` and `x`.
pub fn write_decay_csv(dir: &Path, samples: impl IntoIterator<Item = (f64, f64)>) {
    let mut csv = String::from("time,x\n");
    for (t, x) in samples {
        csv.push_str(&format!("{t},{x}\n"));
    }
    std::fs::write(dir.join("data.csv"), csv).unwrap();
}

/// The TOML text of a job fitting the Decay example's k (from 1.0, in [0.1, `upper`]) to `x`
/// in `data.csv`, then `tables` as written.
pub fn decay_job_toml(upper: f64, tables: &str) -> String {
    job_toml(
        Path::new("example:decay"),
        Some(Path::new("data.csv")),
        &[("x", "x")],
        &[],
        &[("k", 1.0, 0.1, upper)],
        tables,
    )
}

/// The Decay example's job calibrating `parameters` (name, start, lower, upper) on data made
/// with k = 1.7 (handed over separately, not named in the job), with `extra` tables appended,
/// and its data.
pub fn decay_spec(
    dir: &Path,
    extra: &str,
    parameters: &[(&str, f64, f64, f64)],
) -> (fmucal_shared::job::JobSpec, fmucal_shared::job::MeasurementTable) {
    let (time, x) = decay_samples(&dir.join("cache"), None, 1).into_iter().unzip();
    let data = fmucal_shared::job::MeasurementTable { time, columns: vec![("x".into(), x)] };
    let toml = job_toml(&example("decay"), None, &[("x", "x")], &[], parameters, extra);
    (fmucal_shared::job::JobSpec::from_toml(&toml, dir).unwrap(), data)
}

/// A channel to the coordinator at `url`, tried again every 100 ms until it answers; panics if
/// it has not after `patience`.
pub async fn channel_within(url: &str, patience: std::time::Duration) -> tonic::transport::Channel {
    let endpoint = tonic::transport::Endpoint::from_shared(url.to_owned()).unwrap();
    let end = std::time::Instant::now() + patience;
    loop {
        match endpoint.connect().await {
            Ok(c) => return c,
            Err(e) if std::time::Instant::now() > end => panic!("cannot reach {url}: {e}"),
            Err(_) => tokio::time::sleep(std::time::Duration::from_millis(100)).await,
        }
    }
}

/// `fmucal` to be run in `dir`, with its FMU cache in `dir/cache`: add the arguments, then run.
pub fn fmucal_in(dir: &Path) -> std::process::Command {
    let mut cmd = std::process::Command::new(env!("CARGO_BIN_EXE_fmucal"));
    cmd.current_dir(dir).env("FMUCAL_CACHE_DIR", dir.join("cache"));
    cmd
}

/// A coordinator (`fmucal coordinator` on a free 127.0.0.1 port, state in `dir/coord`) and one
/// worker process with `slots` slots, both with the token `cli-test-token`; [`Servers::stop`]
/// sends them SIGTERM and returns whether both exited cleanly (a process stopped before it has
/// set up its signal handler does not); dropping them unstopped kills them.
#[allow(dead_code)]
pub struct Servers {
    pub url: String,
    children: Vec<std::process::Child>,
}

#[allow(dead_code)]
impl Servers {
    pub fn start(dir: &Path, slots: usize) -> Servers {
        Self::start_with(dir, slots, &[], &[])
    }

    /// [`Self::start`] with more arguments for the coordinator and the worker.
    pub fn start_with(dir: &Path, slots: usize, coordinator_args: &[&str], worker_args: &[&str]) -> Servers {
        let port = std::net::TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port();
        let url = format!("http://127.0.0.1:{port}");
        let spawn = |args: &[&str]| {
            std::process::Command::new(env!("CARGO_BIN_EXE_fmucal"))
                .args(args)
                .env("FMUCAL_TOKEN", "cli-test-token")
                .stdout(std::process::Stdio::null())
                .stderr(std::process::Stdio::null())
                .spawn()
                .unwrap()
        };
        let data_dir = dir.join("coord");
        let listen = format!("127.0.0.1:{port}");
        let mut coord = spawn(
            &[&["coordinator", "--listen", &listen, "--data-dir", data_dir.to_str().unwrap()], coordinator_args]
                .concat(),
        );
        // Clients (the Python client among them) wait a few seconds only for an answer: on a
        // loaded machine the coordinator may take longer than that to listen and open its store.
        wait_until_serving(&url, &mut coord);
        let cache = dir.join("worker-cache");
        let worker = spawn(
            &["worker", "--coordinator", &url, "--slots", &slots.to_string(), "--cache-dir", cache.to_str().unwrap()]
                .iter()
                .chain(worker_args)
                .copied()
                .collect::<Vec<_>>(),
        );
        Servers { url, children: vec![worker, coord] }
    }

    /// The processes' ids: the worker's, then the coordinator's.
    pub fn pids(&self) -> Vec<u32> {
        self.children.iter().map(std::process::Child::id).collect()
    }

    /// Sends every child SIGTERM and waits for each (killing one that has not exited 30 s
    /// later), whatever the others did; whether all exited cleanly.
    pub fn stop(mut self) -> bool {
        let mut clean = true;
        for mut child in std::mem::take(&mut self.children) {
            clean &= stop_child(&mut child, std::time::Duration::from_secs(30));
        }
        clean
    }
}

/// Waits until the coordinator at `url` answers a health check SERVING (`fmucal health`, up to
/// 2 minutes), or until `child` has exited (the test then fails on its own terms, with the
/// child's error). Accepting connections is not enough: a coordinator listens before it opens
/// its stores and serves, and the Python client waits 5 s for an answer (in a CI run of
/// 2026-12-02 it gave up after those 5 s while another test built a wheel and wrote to the
/// disk; opening the store syncs it to disk).
pub fn wait_until_serving(url: &str, child: &mut std::process::Child) {
    let end = std::time::Instant::now() + std::time::Duration::from_secs(120);
    while std::time::Instant::now() < end && matches!(child.try_wait(), Ok(None)) {
        let health = std::process::Command::new(env!("CARGO_BIN_EXE_fmucal"))
            .args(["health", url, "--timeout", "2"])
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .status();
        if health.is_ok_and(|s| s.success()) {
            return;
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
}

/// Sends `child` SIGTERM and waits up to `grace` for it to exit, then kills it; whether it
/// exited cleanly by itself. The child is reaped on every path.
pub fn stop_child(child: &mut std::process::Child, grace: std::time::Duration) -> bool {
    let _ = std::process::Command::new("kill").args(["-TERM", &child.id().to_string()]).status();
    let end = std::time::Instant::now() + grace;
    loop {
        match child.try_wait() {
            Ok(Some(status)) => return status.success(),
            Ok(None) if std::time::Instant::now() < end => std::thread::sleep(std::time::Duration::from_millis(20)),
            _ => {
                let _ = child.kill();
                let _ = child.wait();
                return false;
            }
        }
    }
}

/// A test that panicked before [`Servers::stop`] leaves no process behind.
impl Drop for Servers {
    fn drop(&mut self) {
        for child in &mut self.children {
            let _ = child.kill();
            let _ = child.wait();
        }
    }
}

/// Copies the folder `from` (its files and subfolders) to `to`.
pub fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for entry in std::fs::read_dir(from).unwrap() {
        let entry = entry.unwrap();
        let target = to.join(entry.file_name());
        if entry.file_type().unwrap().is_dir() {
            copy_dir(&entry.path(), &target);
        } else {
            std::fs::copy(entry.path(), target).unwrap();
        }
    }
}

/// The Python of the cross-checks' venv (FMPy, SciPy), made once by `tests/fmpy/ensure_venv.sh`.
pub fn fmpy_python() -> &'static Path {
    static PY: std::sync::OnceLock<PathBuf> = std::sync::OnceLock::new();
    PY.get_or_init(|| {
        let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fmpy/ensure_venv.sh");
        let out = std::process::Command::new("bash").arg(&script).output().expect("run ensure_venv.sh");
        // ensure_venv.sh says in one line why it failed (for example: PyPI unreachable).
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr).trim());
        PathBuf::from(String::from_utf8(out.stdout).unwrap().trim())
    })
}

/// A child process killed and reaped when dropped, so that a test that panics (a failed
/// assertion) leaves no process behind. It derefs to the [`std::process::Child`].
#[allow(dead_code)]
pub struct KillOnDrop(pub std::process::Child);

impl std::ops::Deref for KillOnDrop {
    type Target = std::process::Child;
    fn deref(&self) -> &std::process::Child {
        &self.0
    }
}

impl std::ops::DerefMut for KillOnDrop {
    fn deref_mut(&mut self) -> &mut std::process::Child {
        &mut self.0
    }
}

impl Drop for KillOnDrop {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}
