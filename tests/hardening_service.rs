//! The service side of careless and hostile input, against real `fmucal` processes (and, for
//! the gRPC requests, an in-process coordinator on 127.0.0.1):
//! - over-long strings in requests answer INVALID_ARGUMENT naming the field, with a bounded
//!   quote; upload errors name no path of the coordinator;
//! - nonsense durations, slot counts and environment values are refused in one line naming the
//!   flag or variable;
//! - `fmucal health --timeout` may take its whole timeout to connect;
//! - a data dir in use or not a folder, TLS files that do not fit, and a plaintext client of a
//!   TLS coordinator get errors that say so;
//! - a diagnosis killed with its coordinator leaves no job running after the restart;
//! - a flood of held sockets locks out neither health probes nor clients with a token, and a
//!   hung model of one job does not hold back another job's points on the same worker;
//! - the test helpers stop every process they started.

mod common;

use std::io::{Read, Write};
use std::net::{TcpListener, TcpStream};
use std::path::Path;
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

use fmucal_proto::auth::AttachToken;
use fmucal_proto::convert::job_to_proto;
use fmucal_proto::v1 as pb;
use fmucal_proto::v1::calibration_client::CalibrationClient;
use fmucal_shared::job::{JobSpec, MeasurementTable};
use tonic::service::interceptor::InterceptedService;
use tonic::transport::Channel;

type Client = CalibrationClient<InterceptedService<Channel, AttachToken>>;

const TOKEN: &str = "service-test-token-0123";

/// `fmucal ARGS` with the token set and the TLS variables unset.
fn fmucal(args: &[&str]) -> Command {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_fmucal"));
    cmd.args(args).env("FMUCAL_TOKEN", TOKEN).stdin(Stdio::null());
    for var in ["FMUCAL_WORKER_TOKEN", "FMUCAL_TLS_CA", "FMUCAL_TLS_CERT", "FMUCAL_TLS_KEY", "FMUCAL_LOG"] {
        cmd.env_remove(var);
    }
    cmd
}

/// Runs `cmd` to its end, killing it past `limit` (then `None`).
fn output_within(cmd: &mut Command, limit: Duration) -> Option<Output> {
    let mut child = cmd.stdout(Stdio::piped()).stderr(Stdio::piped()).spawn().unwrap();
    let end = Instant::now() + limit;
    while Instant::now() < end {
        if child.try_wait().unwrap().is_some() {
            return Some(child.wait_with_output().unwrap());
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let _ = child.kill();
    let _ = child.wait();
    None
}

/// The one-line error of a command that must fail fast: exit code 1 or 2 (clap), no panic,
/// one line of stderr. Returns that line.
fn refused(cmd: &mut Command, what: &str) -> String {
    let out = output_within(cmd, Duration::from_secs(20)).unwrap_or_else(|| panic!("{what}: still running after 20 s"));
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(matches!(out.status.code(), Some(1 | 2)), "{what}: {:?}\n{stderr}", out.status);
    assert!(!stderr.contains("panicked"), "{what}: {stderr}");
    let lines: Vec<&str> = stderr.lines().filter(|l| !l.trim().is_empty()).collect();
    // clap's usage errors add a usage hint after the error line.
    assert!(lines.len() == 1 || lines[0].starts_with("error: ") && out.status.code() == Some(2), "{what}: {stderr}");
    lines[0].to_owned()
}

fn free_port() -> u16 {
    TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port()
}

/// A process a test started: stopped (SIGTERM, then SIGKILL after 5 s) when dropped, so a
/// failing test leaves none behind.
struct Proc(Child);

impl Drop for Proc {
    fn drop(&mut self) {
        common::stop_child(&mut self.0, Duration::from_secs(5));
    }
}

/// `fmucal coordinator` on `port` with `args`, its stderr in `log`.
fn coordinator(data_dir: &Path, port: u16, args: &[&str], log: &Path) -> Proc {
    let child = fmucal(&["coordinator", "--listen", &format!("127.0.0.1:{port}"), "--data-dir"])
        .arg(data_dir)
        .args(args)
        .stdout(Stdio::null())
        .stderr(Stdio::from(std::fs::File::create(log).unwrap()))
        .spawn()
        .unwrap();
    Proc(child)
}

/// Waits until `url` answers a health check (over `tls_ca` if given), for up to 60 s.
fn wait_healthy(url: &str, tls_ca: Option<&Path>) {
    let end = Instant::now() + Duration::from_secs(60);
    loop {
        let mut cmd = fmucal(&["health", url, "--timeout", "2"]);
        if let Some(ca) = tls_ca {
            cmd.arg("--tls-ca").arg(ca);
        }
        if output_within(&mut cmd, Duration::from_secs(10)).is_some_and(|o| o.status.success()) {
            return;
        }
        assert!(Instant::now() < end, "{url} never became healthy");
        std::thread::sleep(Duration::from_millis(100));
    }
}

/// Stops a process the test started (SIGTERM, then SIGKILL after 5 s).
fn stop(process: Proc) {
    drop(process);
}

fn alive(pid: u32) -> bool {
    // A reaped process is gone; a zombie would say so in its status.
    std::fs::read_to_string(format!("/proc/{pid}/status")).is_ok_and(|s| !s.contains("State:\tZ"))
}

/// `fmucal certs` into `dir`.
fn certs(dir: &Path) {
    let out = fmucal(&["certs", "--out"]).arg(dir).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
}

async fn client(url: &str) -> Client {
    let channel = common::channel_within(url, Duration::from_secs(30)).await;
    CalibrationClient::with_interceptor(channel, AttachToken::new(Some(TOKEN)).unwrap())
        .max_encoding_message_size(256 << 20)
        .max_decoding_message_size(256 << 20)
}

async fn upload(c: &mut Client, example: &str) -> String {
    let bytes = std::fs::read(common::example(example)).unwrap();
    let chunks = vec![pb::UploadModelRequest { chunk: bytes }];
    c.upload_model(tokio_stream::iter(chunks)).await.unwrap().into_inner().model_id
}

async fn status_of(c: &mut Client, job: &str) -> i32 {
    c.get_job(pb::GetJobRequest { job_id: job.into() }).await.unwrap().into_inner().status
}

const RUNNING: i32 = pb::JobStatus::Running as i32;

/// An in-process coordinator on a free port; stopped when the returned sender is dropped or
/// sent to.
async fn coordinator_in_process(data_dir: &Path) -> (String, tokio::sync::oneshot::Sender<()>) {
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
    let url = format!("http://{}", listener.local_addr().unwrap());
    let (tx, rx) = tokio::sync::oneshot::channel::<()>();
    let config = fmucal_coordinator::Config {
        token: Some(TOKEN.into()),
        ..fmucal_coordinator::Config::new(data_dir.to_owned())
    };
    tokio::spawn(fmucal_coordinator::run(config, listener, async {
        let _ = rx.await;
    }));
    (url, tx)
}

/// A 20,000-character parameter name, a 1 MB `set` value and a 10 MB job id answer
/// INVALID_ARGUMENT naming the field, in a short message (not RESOURCE_EXHAUSTED about the
/// size of the header that carried the echoed input); an upload that is not an FMU is refused
/// without naming the coordinator's files.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn over_long_strings_are_refused_naming_the_field_in_a_short_message() {
    let dir = tempfile::tempdir().unwrap();
    let data_dir = dir.path().join("coord");
    let (url, _stop) = coordinator_in_process(&data_dir).await;
    let mut c = client(&url).await;
    let model = upload(&mut c, "decay").await;
    let check = |what: &str, s: tonic::Status, field: &str| {
        assert_eq!(s.code(), tonic::Code::InvalidArgument, "{what}: {:?} {:.300}", s.code(), s.message());
        assert!(s.message().contains(field), "{what}: {:.300}", s.message());
        assert!(s.message().len() < 1500, "{what}: {} bytes", s.message().len());
    };
    let (spec, data) = common::decay_spec(dir.path(), "", &[("k", 1.0, 0.5, 3.0)]);
    let mut job = job_to_proto(&spec, std::slice::from_ref(&data), &model);
    job.parameters[0].name = "p".repeat(20_000);
    let e = c.submit_job(pb::SubmitJobRequest { spec: Some(job) }).await.unwrap_err();
    check("a long parameter name", e, "parameters[0]");

    let (spec, data) = common::decay_spec(
        dir.path(),
        &format!("[simulation]\nset = {{ crashTime = \"{}\" }}\n", "x".repeat(1 << 20)),
        &[("k", 1.0, 0.5, 3.0)],
    );
    let job = job_to_proto(&spec, std::slice::from_ref(&data), &model);
    let e = c.submit_job(pb::SubmitJobRequest { spec: Some(job) }).await.unwrap_err();
    check("a long set value", e, "crashTime");

    let long_id = "j".repeat(10 << 20);
    let e = c.get_job(pb::GetJobRequest { job_id: long_id.clone() }).await.unwrap_err();
    check("a long job id", e, "job_id");
    let e = c.cancel_job(pb::CancelJobRequest { job_id: long_id }).await.unwrap_err();
    check("a long job id", e, "job_id");
    let e = c.get_job(pb::GetJobRequest { job_id: format!("job-\u{202e}{}", "1".repeat(100)) }).await.unwrap_err();
    assert_eq!(e.code(), tonic::Code::NotFound, "{e:?}");
    assert!(e.message().contains("\\u{202e}") && !e.message().contains('\u{202e}'), "{}", e.message());

    let chunks = vec![pb::UploadModelRequest { chunk: b"not a zip archive at all".to_vec() }];
    let e = c.upload_model(tokio_stream::iter(chunks)).await.unwrap_err();
    assert_eq!(e.code(), tonic::Code::InvalidArgument, "{e:?}");
    let root = dir.path().to_string_lossy();
    assert!(!e.message().contains(&*root) && !e.message().contains(".upload-"), "{}", e.message());
}

/// Durations, slot counts and environment values that make no sense are refused at start, in
/// one line naming the flag or the variable (`--worker-expiry 0` once made every worker expire
/// every second, in silence).
#[test]
fn nonsense_durations_slot_counts_and_environment_values_are_refused_in_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let data_dir = dir.path().join("coord");
    let listen = format!("127.0.0.1:{}", free_port());
    for (flag, value) in [
        ("--worker-expiry", "0"),
        ("--worker-expiry", "-1"),
        ("--worker-expiry", "NaN"),
        ("--worker-expiry", "inf"),
        ("--worker-expiry", "1e300"),
        ("--worker-expiry", "0.5"),
        ("--evaluation-timeout", "0"),
        ("--evaluation-timeout", "1e300"),
        ("--idle-timeout", "inf"),
        ("--auth-timeout", "-3"),
    ] {
        let mut cmd = fmucal(&["coordinator", "--listen", &listen, "--data-dir"]);
        cmd.arg(&data_dir).args([&format!("{flag}={value}")]);
        let line = refused(&mut cmd, &format!("{flag} {value}"));
        assert!(line.contains(flag), "{flag} {value}: {line}");
    }
    for slots in ["0", "257", "4000000000", "-1"] {
        let mut cmd = fmucal(&["worker", "--coordinator", "http://127.0.0.1:9", &format!("--slots={slots}")]);
        let line = refused(&mut cmd, &format!("--slots {slots}"));
        assert!(line.contains("--slots"), "--slots {slots}: {line}");
    }
    let example = common::example("decay");
    for (var, value) in [
        ("FMUCAL_MAX_UNPACK_BYTES", "abc"),
        ("FMUCAL_MAX_UNPACK_BYTES", "0"),
        ("FMUCAL_MAX_UNPACK_ENTRIES", "-1"),
        ("FMUCAL_LOG", "[[["),
    ] {
        let mut cmd = fmucal(&["inspect"]);
        cmd.arg(&example).env(var, value);
        let line = refused(&mut cmd, &format!("{var}={value}"));
        assert!(line.contains(var), "{var}={value}: {line}");
    }
}

/// A data dir another coordinator holds, or a path that is not a folder, is refused naming it,
/// before the coordinator says it listens.
#[test]
fn a_data_dir_in_use_or_not_a_folder_is_named_before_listening() {
    let dir = tempfile::tempdir().unwrap();
    let data_dir = dir.path().join("coord");
    let port = free_port();
    let first = coordinator(&data_dir, port, &[], &dir.path().join("first.log"));
    wait_healthy(&format!("http://127.0.0.1:{port}"), None);
    let out = output_within(
        fmucal(&["coordinator", "--listen", &format!("127.0.0.1:{}", free_port()), "--data-dir"]).arg(&data_dir),
        Duration::from_secs(20),
    );
    stop(first);
    let out = out.expect("a second coordinator on the same data dir kept running");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{stderr}");
    assert!(!stderr.contains("listening"), "{stderr}");
    assert!(stderr.contains(&*data_dir.to_string_lossy()) && stderr.contains("in use"), "{stderr}");

    let file = dir.path().join("passwd");
    std::fs::write(&file, "root:x:0:0\n").unwrap();
    let line = refused(
        fmucal(&["coordinator", "--listen", &format!("127.0.0.1:{}", free_port()), "--data-dir"]).arg(&file),
        "a file as data dir",
    );
    assert!(line.contains(&*file.to_string_lossy()) && line.contains("not a directory"), "{line}");
}

/// Forwards each connection to `upstream`, `delay` after accepting it, until the test ends.
fn delaying_proxy(upstream: String, delay: Duration) -> u16 {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let port = listener.local_addr().unwrap().port();
    std::thread::spawn(move || {
        for conn in listener.incoming() {
            let Ok(down) = conn else { return };
            let upstream = upstream.clone();
            std::thread::spawn(move || {
                std::thread::sleep(delay);
                let Ok(up) = TcpStream::connect(&upstream) else { return };
                let pump = |mut from: TcpStream, mut to: TcpStream| {
                    std::thread::spawn(move || {
                        let mut buf = [0u8; 16384];
                        while let Ok(n) = from.read(&mut buf) {
                            if n == 0 || to.write_all(&buf[..n]).is_err() {
                                break;
                            }
                        }
                        let _ = to.shutdown(std::net::Shutdown::Write);
                    })
                };
                pump(down.try_clone().unwrap(), up.try_clone().unwrap());
                pump(up, down);
            });
        }
    });
    port
}

/// `fmucal health --timeout 20` waits up to 20 s for a TLS handshake that takes 3 s (it once
/// gave up after the clients' usual 2 s to connect). And TLS mistakes are named: a key that is
/// not the certificate's, a file that holds no certificate, a worker trusting another CA, and a
/// plaintext client of a TLS coordinator.
#[test]
fn health_waits_its_whole_timeout_and_tls_mistakes_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let (ours, other) = (dir.path().join("certs"), dir.path().join("other-certs"));
    certs(&ours);
    certs(&other);
    let port = free_port();
    let tls = |cert: &str, key: &str| {
        vec![
            "--tls-cert".to_owned(),
            ours.join(cert).display().to_string(),
            "--tls-key".into(),
            ours.join(key).display().to_string(),
        ]
    };
    let args = tls("coordinator.pem", "coordinator-key.pem");
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let coord = coordinator(&dir.path().join("coord"), port, &args, &dir.path().join("coord.log"));
    let ca = ours.join("ca.pem");
    wait_healthy(&format!("https://localhost:{port}"), Some(&ca));

    let proxy = delaying_proxy(format!("127.0.0.1:{port}"), Duration::from_secs(3));
    let url = format!("https://localhost:{proxy}");
    let started = Instant::now();
    let out = fmucal(&["health", &url, "--timeout", "20", "--tls-ca"]).arg(&ca).output().unwrap();
    let took = started.elapsed();
    assert!(out.status.success(), "after {took:?}: {}", String::from_utf8_lossy(&out.stderr));
    assert!(took >= Duration::from_secs(3), "{took:?}");

    // A plaintext client of the TLS coordinator is told about TLS.
    for _ in 0..3 {
        let line = refused(&mut fmucal(&["health", &format!("http://127.0.0.1:{port}")]), "http to TLS");
        assert!(line.contains("TLS"), "{line}");
    }
    let line =
        refused(&mut fmucal(&["worker", "--coordinator", &format!("http://127.0.0.1:{port}")]), "a worker on http");
    assert!(line.contains("TLS"), "{line}");
    // A worker trusting another CA names the CA file and says certificate.
    let other_ca = other.join("ca.pem");
    let mut worker = fmucal(&["worker", "--coordinator", &format!("https://localhost:{port}"), "--tls-ca"]);
    worker.arg(&other_ca);
    let out = output_within(&mut worker, Duration::from_secs(60)).expect("a worker with the wrong CA kept running");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{stderr}");
    assert!(stderr.contains(&*other_ca.to_string_lossy()) && stderr.contains("certificate"), "{stderr}");
    stop(coord);

    // A key that is not the certificate's, and a file that holds no certificate.
    let listen = format!("127.0.0.1:{}", free_port());
    let mismatched = tls("coordinator.pem", "client-key.pem");
    let mut cmd = fmucal(&["coordinator", "--listen", &listen, "--data-dir"]);
    cmd.arg(dir.path().join("coord2")).args(&mismatched);
    let line = refused(&mut cmd, "a mismatched key");
    assert!(line.contains(&*ours.join("client-key.pem").to_string_lossy()) && line.contains("certificate"), "{line}");
    let garbage = dir.path().join("garbage.pem");
    std::fs::write(&garbage, "-----BEGIN CERTIFICATE-----\nnot base64 at all!\n-----END CERTIFICATE-----\n").unwrap();
    let mut cmd = fmucal(&["coordinator", "--listen", &listen, "--data-dir"]);
    cmd.arg(dir.path().join("coord2"))
        .arg("--tls-cert")
        .arg(&garbage)
        .arg("--tls-key")
        .arg(ours.join("coordinator-key.pem"));
    let line = refused(&mut cmd, "a garbage certificate");
    assert!(line.contains(&*garbage.to_string_lossy()) && line.contains("certificate"), "{line}");
    let mut cmd = fmucal(&["health", "https://localhost:9", "--tls-ca"]);
    cmd.arg(&garbage);
    let line = refused(&mut cmd, "a garbage CA");
    assert!(line.contains(&*garbage.to_string_lossy()), "{line}");
}

/// A flood of held sockets (200 against `--max-connections 16`) locks out neither a health
/// probe, which answers within its `--timeout`, nor a client with a token: connections not yet
/// vouched for hold at most three quarters of the cap, the oldest closed first.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn health_and_token_holders_are_served_under_a_flood_of_held_sockets() {
    let dir = tempfile::tempdir().unwrap();
    let port = free_port();
    let coord =
        coordinator(&dir.path().join("coord"), port, &["--max-connections", "16"], &dir.path().join("coord.log"));
    let url = format!("http://127.0.0.1:{port}");
    wait_healthy(&url, None);
    let mut c = client(&url).await;
    c.list_jobs(pb::ListJobsRequest {}).await.unwrap();
    let held: Vec<TcpStream> = (0..200).map(|_| TcpStream::connect(("127.0.0.1", port)).unwrap()).collect();
    tokio::time::sleep(Duration::from_millis(500)).await;
    for _ in 0..3 {
        let out = output_within(&mut fmucal(&["health", &url, "--timeout", "5"]), Duration::from_secs(10)).unwrap();
        assert!(out.status.success(), "health under the flood: {}", String::from_utf8_lossy(&out.stderr));
    }
    // A client with a token, on its existing connection and on a new one.
    c.list_jobs(pb::ListJobsRequest {}).await.unwrap();
    let fresh = tokio::time::timeout(Duration::from_secs(5), async {
        client(&url).await.list_jobs(pb::ListJobsRequest {}).await
    });
    assert!(fresh.await.is_ok_and(|r| r.is_ok()), "a new client with a token was not served under the flood");
    drop(held);
    stop(coord);
}

/// A hung model in one job does not hold back another job's points on the same worker: the
/// slot stuck on it hands back the points it fetched with it, and the worker's other slot
/// evaluates them, so the other job ends while the hung point is still within its 60 s
/// deadline.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_hung_model_in_one_job_does_not_hold_back_another_jobs_points() {
    let dir = tempfile::tempdir().unwrap();
    let port = free_port();
    let coord = coordinator(&dir.path().join("coord"), port, &[], &dir.path().join("coord.log"));
    let url = format!("http://127.0.0.1:{port}");
    let mut c = client(&url).await;
    let model = upload(&mut c, "decay").await;
    let parameters = [("k", 1.0, 0.5, 3.0), ("crashTime", 5.0, 0.5, 10.0)];
    let (spec, data) = common::decay_spec(dir.path(), "[simulation]\nset = { crashMode = \"hang\" }\n", &parameters);
    // The simulation ends at 2 s: a crash time of 1 s hangs, 5 s does not.
    let hung = job_to_proto(&spec.evaluating_points(vec![vec![1.7, 1.0]]), std::slice::from_ref(&data), &model);
    let quick: Vec<Vec<f64>> = (0..7).map(|i| vec![1.0 + 0.1 * f64::from(i), 5.0]).collect();
    let quick = job_to_proto(&spec.evaluating_points(quick), std::slice::from_ref(&data), &model);
    // Both queued before the worker comes, so its first poll takes the hung point and some of
    // the other job's with it.
    let hung = c.submit_job(pb::SubmitJobRequest { spec: Some(hung) }).await.unwrap().into_inner().job_id;
    let quick = c.submit_job(pb::SubmitJobRequest { spec: Some(quick) }).await.unwrap().into_inner().job_id;
    let worker = Proc(
        fmucal(&["worker", "--coordinator", &url, "--slots", "2", "--evaluation-deadline", "60", "--cache-dir"])
            .arg(dir.path().join("wcache"))
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap(),
    );
    let end = Instant::now() + Duration::from_secs(45);
    while status_of(&mut c, &quick).await == RUNNING {
        assert!(Instant::now() < end, "the quick job did not end within 45 s");
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
    let r = c.get_job(pb::GetJobRequest { job_id: quick }).await.unwrap().into_inner();
    assert_eq!(r.status, pb::JobStatus::Succeeded as i32, "{r:?}");
    assert!(r.result.unwrap().evaluated.iter().all(|p| p.ok));
    assert_eq!(status_of(&mut c, &hung).await, RUNNING, "the hung point ended before the other job did");
    stop(worker);
    stop(coord);
}

/// The fmucal processes whose command line mentions `needle`.
fn processes_mentioning(needle: &str) -> Vec<u32> {
    let mut pids = vec![];
    for entry in std::fs::read_dir("/proc").unwrap().flatten() {
        let Ok(pid) = entry.file_name().to_string_lossy().parse::<u32>() else { continue };
        let cmdline = std::fs::read(entry.path().join("cmdline")).unwrap_or_default();
        if String::from_utf8_lossy(&cmdline).contains(needle) && alive(pid) {
            pids.push(pid);
        }
    }
    pids
}

/// A diagnosis's calibration job does not stay RUNNING after its coordinator was killed
/// (SIGKILL) during the Diagnose call and restarted: the new coordinator cancels it.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_diagnosis_killed_with_its_coordinator_leaves_no_job_running() {
    let dir = tempfile::tempdir().unwrap();
    let data_dir = dir.path().join("coord");
    let port = free_port();
    let mut coord = coordinator(&data_dir, port, &[], &dir.path().join("first.log"));
    let url = format!("http://127.0.0.1:{port}");
    let mut c = client(&url).await;
    let model = upload(&mut c, "furuta").await;
    let example = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/diagnose");
    let mut spec = JobSpec::from_toml_file(&example.join("job.toml")).unwrap();
    let data = MeasurementTable::read(&example.join("data.csv"), "time").unwrap();
    let settings = fmucal_diagnose::spec::DiagnoseSpec::from_table(spec.diagnose.take().as_ref()).unwrap();
    let req = pb::DiagnoseRequest {
        spec: Some(job_to_proto(&spec, std::slice::from_ref(&data), &model)),
        settings: Some(fmucal_proto::diagnose::diagnose_to_proto(&settings)),
    };
    // No worker: the diagnosis's first job waits in the queue.
    let _stream = c.diagnose(req).await.unwrap().into_inner();
    let end = Instant::now() + Duration::from_secs(60);
    let job = loop {
        let jobs = c.list_jobs(pb::ListJobsRequest {}).await.unwrap().into_inner().jobs;
        if let Some(j) = jobs.into_iter().find(|j| j.status == RUNNING) {
            break j.job_id;
        }
        assert!(Instant::now() < end, "the diagnosis submitted no job");
        tokio::time::sleep(Duration::from_millis(100)).await;
    };
    coord.0.kill().unwrap();
    coord.0.wait().unwrap();
    drop(c);
    // The diagnosis process ends once its coordinator is gone (its stdin closes); the next
    // coordinator starts after it, so the job is not cancelled by it.
    let needle = data_dir.to_string_lossy().into_owned();
    let end = Instant::now() + Duration::from_secs(60);
    while !processes_mentioning(&needle).is_empty() {
        assert!(Instant::now() < end, "the diagnosis process outlived its coordinator");
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
    let port = free_port();
    let coord = coordinator(&data_dir, port, &[], &dir.path().join("second.log"));
    let mut c = client(&format!("http://127.0.0.1:{port}")).await;
    let r = c.get_job(pb::GetJobRequest { job_id: job.clone() }).await.unwrap().into_inner();
    assert_eq!(r.status, pb::JobStatus::Cancelled as i32, "{job}: {r:?}");
    stop(coord);
}

/// `Servers::stop` stops the coordinator even when the worker did not exit cleanly (it once
/// stopped at the first unclean exit, and the coordinator outlived the test).
#[test]
fn stopping_the_test_servers_stops_every_process_whatever_the_first_did() {
    let dir = tempfile::tempdir().unwrap();
    let servers = common::Servers::start(dir.path(), 1);
    let pids = servers.pids();
    assert_eq!(pids.len(), 2);
    wait_healthy(&servers.url, None);
    // The worker dies uncleanly first.
    let _ = Command::new("kill").args(["-KILL", &pids[0].to_string()]).status();
    assert!(!servers.stop(), "a killed worker counted as a clean stop");
    for pid in pids {
        assert!(!alive(pid), "process {pid} outlived Servers::stop");
    }
}

/// Ordinary jobs leave no warning about results in the coordinator's log. A worker stopped
/// (SIGTERM) while the coordinator holds its poll, the one that carried its last results,
/// sends those results again, not knowing whether they arrived: the coordinator counts the
/// repeat as late, at debug, instead of warning of a result for a point never leased (it did,
/// each time a probe stopped its worker after a job).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_worker_stopped_after_its_jobs_leaves_no_warning_about_results() {
    let dir = tempfile::tempdir().unwrap();
    let port = free_port();
    let log = dir.path().join("coord.log");
    let coord = coordinator(&dir.path().join("coord"), port, &[], &log);
    let url = format!("http://127.0.0.1:{port}");
    let mut c = client(&url).await;
    let model = upload(&mut c, "decay").await;
    let (spec, data) = common::decay_spec(dir.path(), "", &[("k", 1.0, 0.5, 3.0)]);
    for round in 0..3 {
        let worker = Proc(
            fmucal(&["worker", "--coordinator", &url, "--cache-dir"])
                .arg(dir.path().join("wcache"))
                .stdout(Stdio::null())
                .stderr(Stdio::null())
                .spawn()
                .unwrap(),
        );
        let points = spec.evaluating_points(vec![vec![1.2], vec![1.7], vec![2.2]]);
        let job = job_to_proto(&points, std::slice::from_ref(&data), &model);
        let id = c.submit_job(pb::SubmitJobRequest { spec: Some(job) }).await.unwrap().into_inner().job_id;
        let end = Instant::now() + Duration::from_secs(60);
        while status_of(&mut c, &id).await == RUNNING {
            assert!(Instant::now() < end, "round {round}: the job did not end");
            tokio::time::sleep(Duration::from_millis(10)).await;
        }
        assert_eq!(status_of(&mut c, &id).await, pb::JobStatus::Succeeded as i32, "round {round}");
        // The worker's poll that carried the results waits for more work (2 s): stop the
        // worker during it.
        stop(worker);
    }
    stop(coord);
    let text = std::fs::read_to_string(&log).unwrap();
    assert!(!text.contains("never leased"), "{text}");
}

/// `fmucal health --timeout T` against a server that never answers (a listener that accepts
/// nothing) gives up after T, not before and not much after: it once went on for 2 s more,
/// looking for a TLS server behind a silent port.
#[test]
fn health_gives_up_on_a_silent_server_after_its_timeout() {
    let silent = TcpListener::bind("127.0.0.1:0").unwrap();
    let url = format!("http://{}", silent.local_addr().unwrap());
    let started = Instant::now();
    let line = refused(&mut fmucal(&["health", &url, "--timeout", "2"]), "a silent server");
    let took = started.elapsed();
    assert!(line.contains("did not answer within 2 s"), "{line}");
    assert!(took >= Duration::from_secs(2) && took < Duration::from_millis(3500), "gave up after {took:?}: {line}");
    drop(silent);
}
