//! The `Diagnose` RPC as a gRPC client uses it, on a separately started coordinator
//! (`fmucal coordinator`) and worker.
//! - It streams progress, then a result that names the same effect, with the same values, as
//!   `fmucal diagnose` run locally on the example in `examples/diagnose/`.
//! - It refuses bad requests with INVALID_ARGUMENT naming the field as the job file does.
//! - A client that goes away stops the diagnosis: its jobs are cancelled and its scratch folder
//!   is removed.

mod common;

use std::path::Path;
use std::time::{Duration, Instant};

use fmucal_diagnose::report::Diagnosis;
use fmucal_proto::auth::AttachToken;
use fmucal_proto::convert::job_to_proto;
use fmucal_proto::diagnose::diagnose_to_proto;
use fmucal_proto::v1 as pb;
use fmucal_proto::v1::calibration_client::CalibrationClient;
use fmucal_shared::job::{JobSpec, MeasurementTable};
use tonic::service::interceptor::InterceptedService;
use tonic::transport::Channel;

type Rpc = CalibrationClient<InterceptedService<Channel, AttachToken>>;

fn example_dir() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/diagnose")
}

async fn connect(url: &str) -> Rpc {
    let attach = AttachToken::new(Some("cli-test-token")).unwrap();
    let channel = common::channel_within(url, Duration::from_secs(10)).await;
    CalibrationClient::with_interceptor(channel, attach).max_decoding_message_size(fmucal_proto::MAX_MESSAGE_BYTES)
}

/// The example's job and settings as protocol messages, with its model uploaded.
async fn example_request(rpc: &mut Rpc) -> pb::DiagnoseRequest {
    let bytes = std::fs::read(common::example("furuta")).unwrap();
    let chunks = vec![pb::UploadModelRequest { chunk: bytes }];
    let model_id = rpc.upload_model(tokio_stream::iter(chunks)).await.unwrap().into_inner().model_id;
    let mut spec = JobSpec::from_toml_file(&example_dir().join("job.toml")).unwrap();
    let data = MeasurementTable::read(&example_dir().join("data.csv"), "time").unwrap();
    let settings = fmucal_diagnose::spec::DiagnoseSpec::from_table(spec.diagnose.take().as_ref()).unwrap();
    pb::DiagnoseRequest {
        spec: Some(job_to_proto(&spec, std::slice::from_ref(&data), &model_id)),
        settings: Some(diagnose_to_proto(&settings)),
    }
}

/// Servers with `slots` worker slots in `dir`, a client of their coordinator, and the example's
/// request with its model uploaded there.
async fn serving_the_example(dir: &Path, slots: usize) -> (common::Servers, Rpc, pb::DiagnoseRequest) {
    let servers = common::Servers::start(dir, slots);
    let mut rpc = connect(&servers.url).await;
    let req = example_request(&mut rpc).await;
    (servers, rpc, req)
}

/// Every event of a diagnosis: its progress lines and its result (or the error ending it).
async fn run(rpc: &mut Rpc, req: pb::DiagnoseRequest) -> Result<(Vec<String>, pb::DiagnoseResult), tonic::Status> {
    let mut stream = rpc.diagnose(req).await?.into_inner();
    let mut lines = vec![];
    while let Some(ev) = stream.message().await? {
        match ev.event {
            Some(pb::diagnose_response::Event::Progress(line)) => lines.push(line),
            Some(pb::diagnose_response::Event::Result(r)) => {
                assert!(stream.message().await?.is_none(), "the result is the last message");
                return Ok((lines, r));
            }
            None => panic!("an empty event"),
        }
    }
    panic!("the stream ended without a result: {lines:?}")
}

/// Scratch folders of running diagnoses (the unpacked-model cache aside).
fn scratch_folders(data_dir: &Path) -> Vec<String> {
    std::fs::read_dir(data_dir.join("diagnoses"))
        .map(|d| d.filter_map(|e| e.ok()?.file_name().into_string().ok()).filter(|n| n != "cache").collect::<Vec<_>>())
        .unwrap_or_default()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_grpc_client_diagnoses_the_example_as_the_cli_does() {
    let dir = tempfile::tempdir().unwrap();
    let (servers, mut rpc, req) = serving_the_example(dir.path(), 2).await;
    let (lines, result) = run(&mut rpc, req).await.unwrap();
    assert_eq!(lines.first().map(String::as_str), Some("round 1: calibrating the base model"), "{lines:?}");
    assert!(lines.iter().any(|l| l.starts_with("round 1: fitting the")), "{lines:?}");
    assert_eq!(result.named.len(), 1, "{}", result.summary);
    assert!(
        result.named[0].starts_with("coulomb_friction on pendulumJoint.w through pendulumJoint.tauExt, force 0.00"),
        "{:?}",
        result.named
    );
    assert!(result.summary.contains("found: coulomb_friction"), "{}", result.summary);
    assert_eq!(result.effects.len(), 1);
    assert_eq!(result.effects[0].kind, "coulomb_friction");
    assert_eq!(result.effects[0].port.as_deref(), Some("pendulumJoint.tauExt"));
    let report: Diagnosis = serde_json::from_str(&result.report_json).unwrap();
    assert_eq!(report.named[0].effect.parameters["force"].start, result.effects[0].parameters["force"].start);
    assert!(scratch_folders(&dir.path().join("coord")).is_empty(), "the scratch folder is removed");

    // The same diagnosis run locally by the CLI names the same effect with the same values.
    let local = std::process::Command::new(env!("CARGO_BIN_EXE_fmucal"))
        .args(["diagnose", "job.toml", "--workers", "1", "--out"])
        .arg(dir.path().join("local"))
        .current_dir(example_dir())
        .env("FMUCAL_CACHE_DIR", dir.path().join("cache"))
        .output()
        .unwrap();
    assert!(local.status.success(), "{}", String::from_utf8_lossy(&local.stderr));
    let local: Diagnosis =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("local/report.json")).unwrap()).unwrap();
    assert_eq!(local.named, report.named);
    assert!(servers.stop());
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn bad_diagnose_requests_name_the_field() {
    let dir = tempfile::tempdir().unwrap();
    let (servers, mut rpc, good) = serving_the_example(dir.path(), 1).await;
    let refused = async |rpc: &mut Rpc, req: pb::DiagnoseRequest| {
        let status = run(rpc, req).await.map(|_| ()).unwrap_err();
        assert_eq!(status.code(), tonic::Code::InvalidArgument, "{status:?}");
        status.message().to_owned()
    };

    let mut req = good.clone();
    req.settings = None;
    assert_eq!(refused(&mut rpc, req).await, "settings is required");

    let mut req = good.clone();
    req.settings.as_mut().unwrap().top = Some(0);
    assert_eq!(refused(&mut rpc, req).await, "diagnose.top: must be at least 1");

    let mut req = good.clone();
    req.spec.as_mut().unwrap().model_id = "0".repeat(64);
    assert!(refused(&mut rpc, req).await.contains("unknown model id"));

    // Caught by the diagnosis's own checks, before any model code runs: a port that is a
    // state, not an input.
    let mut req = good.clone();
    req.settings.as_mut().unwrap().ports[0].port = "armJoint.w".into();
    let message = refused(&mut rpc, req).await;
    assert!(message.starts_with("diagnose.ports[0]"), "{message}");
    assert!(!message.contains('\n'), "{message}");
    assert!(scratch_folders(&dir.path().join("coord")).is_empty());
    servers.stop();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_client_that_goes_away_stops_its_diagnosis() {
    let dir = tempfile::tempdir().unwrap();
    let (servers, mut rpc, mut req) = serving_the_example(dir.path(), 1).await;
    // A base calibration of minutes (10,000 generations of 40), so only a stop ends it soon.
    let optimizer = req.spec.as_mut().unwrap().optimizer.as_mut().unwrap();
    optimizer.algorithm =
        Some(pb::optimizer_spec::Algorithm::DifferentialEvolution(pb::DifferentialEvolutionOptions {
            population: Some(40),
            ..Default::default()
        }));
    optimizer.max_iters = Some(10_000);
    optimizer.x_tol = Some(1e-300);
    optimizer.f_tol = Some(1e-300);
    let mut stream = rpc.diagnose(req).await.unwrap().into_inner();
    let first = stream.message().await.unwrap().unwrap();
    assert!(matches!(first.event, Some(pb::diagnose_response::Event::Progress(_))));
    let data_dir = dir.path().join("coord");
    assert_eq!(scratch_folders(&data_dir).len(), 1, "one diagnosis runs");
    // Go away once its base calibration runs on the workers.
    let deadline = Instant::now() + Duration::from_secs(20);
    loop {
        let jobs = rpc.list_jobs(pb::ListJobsRequest {}).await.unwrap().into_inner().jobs;
        if jobs.iter().any(|j| j.status == pb::JobStatus::Running as i32) {
            break;
        }
        assert!(Instant::now() < deadline, "the base calibration did not start: {jobs:?}");
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    drop(stream);
    let deadline = Instant::now() + Duration::from_secs(10);
    while !scratch_folders(&data_dir).is_empty() {
        assert!(Instant::now() < deadline, "the diagnosis was not stopped");
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
    // It cancelled the base calibration it had submitted.
    let jobs = rpc.list_jobs(pb::ListJobsRequest {}).await.unwrap().into_inner().jobs;
    assert!(!jobs.is_empty());
    for job in jobs {
        assert_eq!(job.status, pb::JobStatus::Cancelled as i32, "{job:?}");
    }
    servers.stop();
}
