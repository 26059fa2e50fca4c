//! The gRPC side of `bench/probe.sh`: hostile and careless requests that only a gRPC client or
//! a worker can send, replayed against a running `fmucal coordinator` (the script starts it,
//! with no worker). Run by `bench/probe.d/grpc.sh`; alone:
//!
//! ```text
//! FMUCAL=target/release/fmucal FMUCAL_PROBE_URL=http://127.0.0.1:PORT \
//!     FMUCAL_TOKEN=... FMUCAL_WORKER_TOKEN=... cargo bench --bench probe_grpc
//! ```
//!
//! Each case sends one request that must be refused: with the expected status code, a message
//! naming the field, and a short message (under 1,500 bytes, whatever the request quoted).
//! Results a worker cannot have computed (a negative sum of squares, the wrong number of
//! residuals, a point never leased to it) must not be told to the job. At the end the
//! coordinator must still serve: a well-formed job succeeds on a worker started last ($FMUCAL).
//! One line per case, `CASE<TAB>PASS|FAIL<TAB>DETAIL`, for the script to count; the exit code is
//! 0 when every case was run, whatever their verdicts.

use std::path::Path;
use std::time::{Duration, Instant};

use fmucal_coordinator::services::MAX_MODEL_BYTES;
use fmucal_proto::auth::AttachToken;
use fmucal_proto::convert::job_to_proto;
use fmucal_proto::v1 as pb;
use fmucal_proto::v1::calibration_client::CalibrationClient;
use fmucal_proto::v1::worker_pool_client::WorkerPoolClient;
use fmucal_shared::job::{JobSpec, MeasurementTable};
use tonic::service::interceptor::InterceptedService;
use tonic::transport::Channel;

type Client = CalibrationClient<InterceptedService<Channel, AttachToken>>;
type Pool = WorkerPoolClient<InterceptedService<Channel, AttachToken>>;

/// The coordinator's peak resident memory (`VmHWM`), MB.
fn peak_rss_mb(pid: &str) -> Option<f64> {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    line.split_whitespace().nth(1)?.parse::<f64>().ok().map(|kb| kb / 1024.0)
}

/// The longest error message a refusal may carry, whatever it quotes.
const MAX_MESSAGE: usize = 1500;

fn env(name: &str) -> String {
    std::env::var(name).unwrap_or_else(|_| panic!("{name} is not set (see bench/probe_grpc.rs)"))
}

fn report(case: &str, pass: bool, detail: &str) {
    let detail: String = detail.chars().filter(|c| !c.is_control()).take(150).collect();
    println!("{case}\t{}\t{detail}", if pass { "PASS" } else { "FAIL" });
}

/// Reports a request that must be refused with `code`, naming `field` in a short message.
fn refused<T: std::fmt::Debug>(case: &str, got: Result<T, tonic::Status>, code: tonic::Code, field: &str) {
    match got {
        Ok(v) => report(case, false, &format!("accepted: {v:?}")),
        Err(s) if s.code() != code => report(case, false, &format!("{:?} (not {code:?}): {}", s.code(), s.message())),
        Err(s) if s.message().len() > MAX_MESSAGE => {
            report(case, false, &format!("a {}-byte message", s.message().len()))
        }
        Err(s) if !s.message().contains(field) => {
            report(case, false, &format!("does not name '{field}': {}", s.message()))
        }
        Err(s) => report(case, true, &format!("{:?}: {}", s.code(), s.message())),
    }
}

async fn channel(url: &str) -> Channel {
    let endpoint = tonic::transport::Endpoint::from_shared(url.to_owned()).expect("FMUCAL_PROBE_URL is a URL");
    endpoint.connect().await.unwrap_or_else(|e| panic!("cannot reach {url}: {e}"))
}

async fn client(url: &str, token: Option<&str>) -> Client {
    client_on(channel(url).await, token)
}

fn client_on(channel: Channel, token: Option<&str>) -> Client {
    CalibrationClient::with_interceptor(channel, AttachToken::new(token).expect("a token"))
        .max_encoding_message_size(256 << 20)
        .max_decoding_message_size(256 << 20)
}

async fn pool(url: &str, token: &str) -> Pool {
    WorkerPoolClient::with_interceptor(channel(url).await, AttachToken::new(Some(token)).expect("a token"))
        .max_encoding_message_size(64 << 20)
}

/// Decay's `k` (start 1.0 in [0.5, 3]) on x = exp(−1.7 t), 0..2 s, with `extra` tables, as sent.
fn decay_job(model_id: &str, extra: &str) -> pb::JobSpec {
    decay_job_with(model_id, "[simulation]\n", extra)
}

/// [`decay_job`] with `simulation` lines (a `[simulation]` header and more) before its stop
/// time.
fn decay_job_with(model_id: &str, simulation: &str, extra: &str) -> pb::JobSpec {
    let toml = format!(
        "[model]\npath = \"{}\"\n[data]\n[[outputs]]\nvariable = \"x\"\ncolumn = \"x\"\n[[parameters]]\nname = \"k\"\n\
         start = 1.0\nlower = 0.5\nupper = 3.0\n{simulation}stop_time = 2.0\n{extra}",
        fmucal_models::example("decay").expect("the decay example").display()
    );
    let spec = JobSpec::from_toml(&toml, Path::new(".")).expect("the probe's job is valid");
    let time: Vec<f64> = (0..=200).map(|i| f64::from(i) * 0.01).collect();
    let x = time.iter().map(|t| (-1.7 * t).exp()).collect();
    let data = MeasurementTable { time, columns: vec![("x".into(), x)] };
    job_to_proto(&spec, std::slice::from_ref(&data), model_id)
}

fn submit(spec: pb::JobSpec) -> pb::SubmitJobRequest {
    pb::SubmitJobRequest { spec: Some(spec) }
}

async fn wait_end(c: &mut Client, job: &str, limit: Duration) -> Option<pb::GetJobResponse> {
    let end = Instant::now() + limit;
    while Instant::now() < end {
        let r = c.get_job(pb::GetJobRequest { job_id: job.into() }).await.ok()?.into_inner();
        if r.status != pb::JobStatus::Running as i32 {
            return Some(r);
        }
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    None
}

/// Requests a client sends: job specs past the caps, values no run can use, over-long strings.
async fn client_cases(url: &str, c: &mut Client, model: &str) {
    use tonic::Code::InvalidArgument;
    let base = decay_job(model, "");
    let edited = |edit: &dyn Fn(&mut pb::JobSpec)| {
        let mut j = base.clone();
        edit(&mut j);
        submit(j)
    };
    let cases: Vec<(&str, pb::SubmitJobRequest, &str)> = vec![
        (
            "grpc: validation_stop_time nan",
            edited(&|j| j.simulation.get_or_insert_with(Default::default).validation_stop_time = Some(f64::NAN)),
            "validation_stop_time",
        ),
        (
            "grpc: validation_stop_time before stop_time",
            edited(&|j| j.simulation.get_or_insert_with(Default::default).validation_stop_time = Some(1.0)),
            "validation_stop_time",
        ),
        (
            "grpc: stop_time inf",
            edited(&|j| j.simulation.get_or_insert_with(Default::default).stop_time = Some(f64::INFINITY)),
            "stop_time",
        ),
        (
            "grpc: tolerance 1e-300",
            edited(&|j| j.simulation.get_or_insert_with(Default::default).tolerance = Some(1e-300)),
            "tolerance",
        ),
        (
            "grpc: 20,000-character parameter name",
            edited(&|j| j.parameters[0].name = "p".repeat(20_000)),
            "parameters[0]",
        ),
        (
            "grpc: 1 MB set value",
            edited(&|j| {
                j.simulation.get_or_insert_with(Default::default).set.insert("crashTime".into(), "x".repeat(1 << 20));
            }),
            "crashTime",
        ),
        (
            "grpc: bounds of -1e308 and 1e308",
            edited(&|j| (j.parameters[0].lower, j.parameters[0].upper) = (-1e308, 1e308)),
            "parameters[0]",
        ),
        (
            "grpc: duplicate column names",
            edited(&|j| {
                let d = j.data.as_mut().expect("data");
                let twin = d.columns[0].clone();
                d.columns.push(twin);
            }),
            "data.columns",
        ),
        (
            "grpc: an inf data cell",
            edited(&|j| j.data.as_mut().expect("data").columns[0].values[3] = f64::INFINITY),
            "data.columns[x]",
        ),
        ("grpc: a nan time stamp", edited(&|j| j.data.as_mut().expect("data").time[3] = f64::NAN), "data.time"),
        ("grpc: points on a calibration job", edited(&|j| j.points = vec![pb::Point { x: vec![1.2] }]), "points"),
        (
            "grpc: 4,000-point evaluation past the residual cap",
            edited(&|j| {
                j.kind = pb::JobKind::EvaluatePoints as i32;
                j.points = vec![pb::Point { x: vec![1.2] }; 4000];
                let d = j.data.as_mut().expect("data");
                let n = 4000;
                d.time = (0..n).map(|i| f64::from(i) * 0.0005).collect();
                d.columns[0].values = d.time.iter().map(|t| (-1.7 * t).exp()).collect();
            }),
            "cap",
        ),
        ("grpc: an unknown model id", edited(&|j| j.model_id = "0".repeat(64)), "model_id"),
        ("grpc: no data", edited(&|j| j.data = None), "data"),
        ("grpc: DE population 2^64-1", population(&base, "differential-evolution", u64::MAX), "optimizer.population"),
        (
            "grpc: DE population 1e10",
            population(&base, "differential-evolution", 10_000_000_000),
            "optimizer.population",
        ),
        ("grpc: GA population 1e8", population(&base, "genetic", 100_000_000), "optimizer.population"),
        (
            "grpc: max_fevals 2^64-1",
            edited(&|j| j.optimizer.get_or_insert_with(Default::default).max_fevals = Some(u64::MAX)),
            "optimizer.max_fevals",
        ),
        (
            "grpc: 100,000 parameters",
            edited(&|j| {
                let p = j.parameters[0].clone();
                j.parameters = (0..100_000).map(|k| pb::ParameterSpec { name: format!("p{k}"), ..p.clone() }).collect();
            }),
            "parameters",
        ),
    ];
    for (case, request, field) in cases {
        refused(case, c.submit_job(request).await, InvalidArgument, field);
    }
    let long_id = "j".repeat(10 << 20);
    refused(
        "grpc: 10 MB job id (GetJob)",
        c.get_job(pb::GetJobRequest { job_id: long_id.clone() }).await,
        InvalidArgument,
        "job_id",
    );
    refused(
        "grpc: 10 MB job id (CancelJob)",
        c.cancel_job(pb::CancelJobRequest { job_id: long_id }).await,
        InvalidArgument,
        "job_id",
    );
    let bidi = c.get_job(pb::GetJobRequest { job_id: format!("job-\u{202e}{}", "1".repeat(100)) }).await;
    match bidi {
        Err(s) if s.message().contains('\u{202e}') => report("grpc: U+202E in a job id", false, "echoed raw"),
        other => refused("grpc: U+202E in a job id", other, tonic::Code::NotFound, "\\u{202e}"),
    }
    let garbage = vec![pb::UploadModelRequest { chunk: vec![0x5a; 20 << 20] }];
    match c.upload_model(tokio_stream::iter(garbage)).await {
        Err(s) if s.message().contains(".upload-") || s.message().contains('/') => {
            report("grpc: a 20 MB upload that is not an FMU", false, &format!("names a server path: {}", s.message()))
        }
        other => refused("grpc: a 20 MB upload that is not an FMU", other, InvalidArgument, "zip"),
    }
    // Past the per-model cap: 1 GiB and 1 MiB of garbage, made chunk by chunk as it is sent
    // (never held whole by either side), refused at the cap.
    let start = Instant::now();
    let mib = (MAX_MODEL_BYTES >> 20) + 1;
    let chunks = (0..mib).map(|i| pb::UploadModelRequest { chunk: vec![(i % 251) as u8; 1 << 20] });
    let case = format!("grpc: a {mib} MiB upload (past the {} MiB cap)", MAX_MODEL_BYTES >> 20);
    match c.upload_model(tokio_stream::iter(chunks)).await {
        Err(s) if s.message().contains(".upload-") || s.message().contains('/') => {
            report(&case, false, &format!("names a server path: {}", s.message()))
        }
        Err(s) if s.code() == InvalidArgument && s.message().contains("exceeds") => {
            let peak = std::env::var("FMUCAL_PROBE_COORDINATOR_PID").ok().and_then(|pid| peak_rss_mb(&pid));
            let peak = peak.map_or_else(|| "unknown".into(), |mb| format!("{mb:.0} MB"));
            report(
                &case,
                true,
                &format!(
                    "{}: {} (in {} ms; coordinator peak RSS {peak})",
                    s.code(),
                    s.message(),
                    start.elapsed().as_millis()
                ),
            );
        }
        other => refused(&case, other, InvalidArgument, "exceeds"),
    }
    // The decay FMU with its model description cut short and 64 MiB more (2 MB zipped): the
    // unpacking check refuses it, naming the description.
    match broken_archive() {
        Ok(bytes) => {
            let chunks: Vec<_> = bytes.chunks(1 << 20).map(|c| pb::UploadModelRequest { chunk: c.to_vec() }).collect();
            let case = format!("grpc: a {} kB archive with a broken description", bytes.len() >> 10);
            refused(&case, c.upload_model(tokio_stream::iter(chunks)).await, InvalidArgument, "modelDescription.xml");
        }
        Err(e) => report("grpc: an archive with a broken description", false, &format!("cannot make it: {e}")),
    }
    // What the refused uploads left in the store: nothing, archive or unpacked.
    if let Ok(dir) = std::env::var("FMUCAL_PROBE_DATA_DIR") {
        let list = |sub: &str| -> Vec<String> {
            std::fs::read_dir(Path::new(&dir).join(sub))
                .map(|d| d.flatten().map(|e| e.file_name().to_string_lossy().into_owned()).collect())
                .unwrap_or_default()
        };
        let (models, unpacked) = (list("models"), list("unpacked"));
        let stray: Vec<&String> = models.iter().chain(&unpacked).filter(|n| !n.starts_with(model)).collect();
        report(
            "grpc: refused uploads leave no file",
            stray.is_empty(),
            &format!(
                "{} file(s) in models/, {} in unpacked/; {:?} not the accepted model's",
                models.len(),
                unpacked.len(),
                stray
            ),
        );
    }
    // Credentials: none, and the worker's.
    let mut anonymous = client(url, None).await;
    refused("grpc: no token", anonymous.list_jobs(pb::ListJobsRequest {}).await, tonic::Code::Unauthenticated, "token");
    let mut as_worker = client(url, Some(&env("FMUCAL_WORKER_TOKEN"))).await;
    refused(
        "grpc: the worker token as a client",
        as_worker.list_jobs(pb::ListJobsRequest {}).await,
        tonic::Code::Unauthenticated,
        "token",
    );
}

/// The decay example's archive with `modelDescription.xml` cut in half and a 64 MiB entry
/// of one repeated byte added.
fn broken_archive() -> Result<Vec<u8>, Box<dyn std::error::Error>> {
    use std::io::{Read, Write};
    let path = fmucal_models::example("decay").ok_or("no decay example")?;
    let mut zip = zip::ZipArchive::new(std::fs::File::open(path)?)?;
    let mut out = zip::ZipWriter::new(std::io::Cursor::new(Vec::new()));
    let opts = zip::write::SimpleFileOptions::default();
    for i in 0..zip.len() {
        let mut f = zip.by_index(i)?;
        let name = f.name()?.into_owned();
        let mut bytes = vec![];
        f.read_to_end(&mut bytes)?;
        if name == "modelDescription.xml" {
            bytes.truncate(bytes.len() / 2);
        }
        out.start_file(name.as_str(), opts)?;
        out.write_all(&bytes)?;
    }
    out.start_file("resources/padding.bin", opts)?;
    out.write_all(&vec![7u8; 64 << 20])?;
    Ok(out.finish()?.into_inner())
}

fn population(base: &pb::JobSpec, algorithm: &str, population: u64) -> pb::SubmitJobRequest {
    submit(proto::with_population(base, algorithm, population))
}

/// Requests a worker (or a holder of the worker token) sends: registrations past the caps, and
/// results it cannot have computed.
async fn worker_cases(url: &str, c: &mut Client, model: &str) {
    use tonic::Code::InvalidArgument;
    let client_token = env("FMUCAL_TOKEN");
    let worker_token = env("FMUCAL_WORKER_TOKEN");
    let register = |slots: u32, name: String| pb::RegisterRequest {
        protocol_version: fmucal_proto::PROTOCOL_VERSION,
        slots,
        name,
    };
    let mut as_client = pool(url, &client_token).await;
    refused(
        "grpc: the client token registering a worker",
        as_client.register(register(1, "w".into())).await,
        tonic::Code::Unauthenticated,
        "token",
    );
    let mut w = pool(url, &worker_token).await;
    refused("grpc: Register with 0 slots", w.register(register(0, "w".into())).await, InvalidArgument, "slots");
    refused(
        "grpc: Register with 4e9 slots",
        w.register(register(4_000_000_000, "w".into())).await,
        InvalidArgument,
        "slots",
    );
    // A long name is taken, cut: it must not make the worker id long.
    match w.register(register(1, "n".repeat(100_000))).await {
        Ok(r) => {
            let id = r.into_inner().worker_id;
            report("grpc: Register with a 100 KB name", id.len() <= 128, &format!("a worker id of {} bytes", id.len()));
        }
        Err(e) => refused::<()>("grpc: Register with a 100 KB name", Err(e), InvalidArgument, "name"),
    }
    refused(
        "grpc: Register with another protocol version",
        w.register(pb::RegisterRequest { protocol_version: u32::MAX, ..register(1, "w".into()) }).await,
        InvalidArgument,
        "protocol_version",
    );

    // A job for this forger alone (no other worker is running yet): it answers with values no
    // simulation gives, each for a point freshly leased to it (a refused result sends its point
    // back to the queue). None may be told.
    let job = match c.submit_job(submit(decay_job(model, "[optimizer]\nmax_iters = 3\n"))).await {
        Ok(r) => r.into_inner().job_id,
        Err(e) => return report("grpc: forged results", false, &format!("the job was refused: {}", e.message())),
    };
    let forger = match w.register(register(1, "forger".into())).await {
        Ok(r) => r.into_inner().worker_id,
        Err(e) => return report("grpc: forged results", false, &format!("cannot register: {}", e.message())),
    };
    let poll = |results: Vec<pb::PointResult>, max_points: u32| pb::PollWorkRequest {
        worker_id: forger.clone(),
        results,
        max_points,
        wait_ms: 200,
    };
    let result = |point_id: u64, value: f64, residuals: Vec<f64>| pb::PointResult {
        job_id: job.clone(),
        point_id,
        status: pb::PointStatus::Ok as i32,
        value,
        residuals,
        ..Default::default()
    };
    type Forge = fn(u64) -> (u64, f64, Vec<f64>);
    let forged: [(&str, Forge); 4] = [
        ("grpc: a result for a point never leased", |p| (p + 1000, 0.0, vec![])),
        ("grpc: a result of -1e300 for a leased point", |p| (p, -1e300, vec![])),
        ("grpc: a NaN result for a leased point", |p| (p, f64::NAN, vec![])),
        ("grpc: a result with the wrong number of residuals", |p| (p, 1.0, vec![0.5; 7])),
    ];
    let mut held: Option<u64> = None;
    for (case, forge) in forged {
        let end = Instant::now() + Duration::from_secs(20);
        while held.is_none() && Instant::now() < end {
            let leased = w.poll_work(poll(vec![], 1)).await.map(|r| r.into_inner().assignments).unwrap_or_default();
            held = leased.first().map(|a| a.point_id);
        }
        let Some(point) = held else {
            report(case, false, "the forger was never leased a point");
            continue;
        };
        let (id, value, residuals) = forge(point);
        if id == point {
            held = None;
        }
        let answered = w.poll_work(poll(vec![result(id, value, residuals)], 0)).await;
        let told = c.list_jobs(pb::ListJobsRequest {}).await.map(|r| r.into_inner().jobs);
        let told = told.map(|jobs| jobs.into_iter().find(|j| j.job_id == job));
        match (answered, told) {
            (Err(e), _) => report(case, true, &format!("{:?}: {}", e.code(), e.message())),
            (Ok(_), Ok(Some(j))) => report(
                case,
                j.evaluations == 0 && j.status == pb::JobStatus::Running as i32,
                &format!("not told: the job has {} evaluations and is still running", j.evaluations),
            ),
            (Ok(_), Ok(None)) => report(case, false, "the job is gone"),
            (Ok(_), Err(e)) => report(case, false, &format!("cannot list the jobs: {}", e.message())),
        }
    }
    let _ = c.cancel_job(pb::CancelJobRequest { job_id: job }).await;
}

#[path = "probe_processes.rs"]
mod processes;
#[path = "../tests/common/proto.rs"]
mod proto;

/// `probe_grpc` replays the request cases against $FMUCAL_PROBE_URL; `probe_grpc processes
/// DIR` the process-level cases, in the scratch folder DIR; `probe_grpc full-disk DIR` the
/// full-disk case, DIR being a small disk of its own (arguments starting with `-`, such as
/// cargo's `--bench`, are ignored).
#[tokio::main]
async fn main() {
    let args: Vec<String> = std::env::args().skip(1).filter(|a| !a.starts_with('-')).collect();
    match args.iter().map(String::as_str).collect::<Vec<_>>()[..] {
        [] => requests().await,
        ["processes", dir] => {
            let sub = |name: &str| {
                let d = Path::new(dir).join(name);
                let _ = std::fs::create_dir_all(&d);
                d
            };
            processes::model_gone(&sub("model-gone")).await;
            processes::hung_model(&sub("hung")).await;
            processes::killed_diagnosis(&sub("diagnosis")).await;
        }
        ["full-disk", dir] => processes::full_disk(Path::new(dir)).await,
        _ => panic!("usage: probe_grpc [processes DIR | full-disk DIR] (see bench/probe_grpc.rs)"),
    }
}

async fn requests() {
    let url = env("FMUCAL_PROBE_URL");
    let mut c = client(&url, Some(&env("FMUCAL_TOKEN"))).await;
    let bytes = std::fs::read(fmucal_models::example("decay").expect("the decay example")).expect("decay.fmu");
    let model = match c.upload_model(tokio_stream::iter(vec![pb::UploadModelRequest { chunk: bytes }])).await {
        Ok(r) => r.into_inner().model_id,
        Err(e) => panic!("cannot upload the decay example: {e}"),
    };
    client_cases(&url, &mut c, &model).await;
    worker_cases(&url, &mut c, &model).await;
    // Still serving: a well-formed job succeeds on a real worker (started only now, so that the
    // forged results above were the only ones).
    let mut worker = match std::process::Command::new(env("FMUCAL"))
        .args(["worker", "--coordinator", &url, "--slots", "1"])
        .env("FMUCAL_TOKEN", env("FMUCAL_WORKER_TOKEN"))
        .stdin(std::process::Stdio::null())
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
    {
        Ok(w) => w,
        Err(e) => return report("grpc: a good job after all that", false, &format!("cannot start a worker: {e}")),
    };
    let start = Instant::now();
    let done = match c.submit_job(submit(decay_job(&model, ""))).await {
        Ok(r) => wait_end(&mut c, &r.into_inner().job_id, Duration::from_secs(60)).await,
        Err(e) => return report("grpc: a good job after all that", false, &format!("refused: {}", e.message())),
    };
    match done {
        Some(r) if r.status == pb::JobStatus::Succeeded as i32 => {
            let x = r.result.map(|res| res.x_opt).unwrap_or_default();
            report(
                "grpc: a good job after all that",
                true,
                &format!("ok in {} ms: x_opt {x:?}", start.elapsed().as_millis()),
            )
        }
        Some(r) => report("grpc: a good job after all that", false, &format!("status {} {}", r.status, r.error)),
        None => report("grpc: a good job after all that", false, "still running after 60 s"),
    }
    // Jobs whose evaluations all fail, or whose start point fails, fail with the first error
    // (crashMode = "error" at 0.5 s, within the 2 s simulated: every simulation fails).
    let failing = "[simulation]\nset = { crashMode = \"error\", crashTime = 0.5 }\n";
    for (case, optimizer, says) in [
        ("grpc: a job whose start point fails", "", "the start point failed"),
        (
            "grpc: a job whose every evaluation fails",
            "[optimizer]\nalgorithm = \"genetic\"\npopulation = 4\nbits = 7\nelitism = 1\nmax_iters = 2\n",
            "no evaluation succeeded",
        ),
    ] {
        let spec = decay_job_with(&model, failing, optimizer);
        let done = match c.submit_job(submit(spec)).await {
            Ok(r) => wait_end(&mut c, &r.into_inner().job_id, Duration::from_secs(60)).await,
            Err(e) => {
                report(case, false, &format!("refused: {}", e.message()));
                continue;
            }
        };
        match done {
            Some(r) if r.status == pb::JobStatus::Failed as i32 && r.error.contains(says) => {
                report(case, true, &format!("FAILED: {}", r.error))
            }
            Some(r) => report(case, false, &format!("status {} (not FAILED naming '{says}'): {}", r.status, r.error)),
            None => report(case, false, "still running after 60 s"),
        }
    }
    let _ = worker.kill();
    let _ = worker.wait();
}
