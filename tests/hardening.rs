//! Requests a hostile or careless client or worker may send, against an in-process
//! coordinator on 127.0.0.1: sizes past the caps are refused before anything is allocated and
//! the coordinator keeps serving; a job whose evaluations all fail, or whose start point fails,
//! fails with the first error; a worker may answer only the points leased to it; workers and
//! clients hold different tokens.

mod common;

use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use common::KillOnDrop;

use fmucal_proto::auth::AttachToken;
use fmucal_proto::convert::job_to_proto;
use fmucal_proto::v1 as pb;
use fmucal_proto::v1::calibration_client::CalibrationClient;
use fmucal_proto::v1::worker_pool_client::WorkerPoolClient;
use fmucal_shared::job::{JobSpec, MeasurementTable};
use fmucal_shared::sim::{SimSpec, simulate};
use tonic::service::interceptor::InterceptedService;
use tonic::transport::Channel;

type Client = CalibrationClient<InterceptedService<Channel, AttachToken>>;
type Pool = WorkerPoolClient<InterceptedService<Channel, AttachToken>>;

const TOKEN: &str = "client-token-0123456789";
const WORKER_TOKEN: &str = "worker-token-9876543210";

struct Coordinator {
    url: String,
    stop: tokio::sync::oneshot::Sender<()>,
    task: tokio::task::JoinHandle<Result<(), fmucal_coordinator::CoordinatorError>>,
}

impl Coordinator {
    /// Stops serving and waits until the store is closed.
    async fn stop(self) {
        let _ = self.stop.send(());
        self.task.await.unwrap().unwrap();
    }
}

async fn start_coordinator(data_dir: &Path, worker_token: Option<&str>) -> Coordinator {
    start_coordinator_with(data_dir, worker_token, |_| {}).await
}

/// The configuration the tests' coordinators start from: tokens [`TOKEN`] and `worker_token`,
/// fast heartbeats.
fn config(data_dir: &Path, worker_token: Option<&str>) -> fmucal_coordinator::Config {
    fmucal_coordinator::Config {
        token: Some(TOKEN.into()),
        worker_token: worker_token.map(str::to_owned),
        timing: fmucal_coordinator::Timing {
            heartbeat_interval: Duration::from_millis(200),
            worker_expiry: Duration::from_secs(30),
            evaluation_timeout: Duration::from_secs(60),
        },
        ..fmucal_coordinator::Config::new(data_dir.to_owned())
    }
}

/// [`start_coordinator`] with `edit` applied to its configuration.
async fn start_coordinator_with(
    data_dir: &Path,
    worker_token: Option<&str>,
    edit: impl FnOnce(&mut fmucal_coordinator::Config),
) -> Coordinator {
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
    let url = format!("http://{}", listener.local_addr().unwrap());
    let (tx, rx) = tokio::sync::oneshot::channel::<()>();
    let mut config = config(data_dir, worker_token);
    edit(&mut config);
    let task = tokio::spawn(fmucal_coordinator::run(config, listener, async {
        let _ = rx.await;
    }));
    Coordinator { url, stop: tx, task }
}

async fn channel(url: &str) -> Channel {
    tonic::transport::Endpoint::from_shared(url.to_owned()).unwrap().connect().await.unwrap()
}

async fn client(url: &str, token: &str) -> Client {
    CalibrationClient::with_interceptor(channel(url).await, AttachToken::new(Some(token)).unwrap())
        .max_encoding_message_size(256 << 20)
}

async fn pool(url: &str, token: &str) -> Pool {
    WorkerPoolClient::with_interceptor(channel(url).await, AttachToken::new(Some(token)).unwrap())
}

fn start_worker(url: &str, cache: &Path, token: &str) -> KillOnDrop {
    start_worker_with(url, cache, token, &[], None)
}

/// A worker process with more `args`, logging at debug level to `log` if given.
fn start_worker_with(url: &str, cache: &Path, token: &str, args: &[&str], log: Option<&Path>) -> KillOnDrop {
    let stderr = log.map_or_else(Stdio::null, |path| Stdio::from(std::fs::File::create(path).unwrap()));
    KillOnDrop(
        Command::new(env!("CARGO_BIN_EXE_fmucal"))
            .args(["worker", "--coordinator", url, "--cache-dir"])
            .arg(cache)
            .args(args)
            .env("FMUCAL_WORKER_TOKEN", token)
            .env("FMUCAL_LOG", "fmucal=debug,fmucal_worker=debug")
            .env_remove("FMUCAL_TOKEN")
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(stderr)
            .spawn()
            .unwrap(),
    )
}

/// The decay example's job (`k` from 1.0 in [0.5, 3]) on data made with k = 1.7, with `extra`
/// tables appended, as the job spec of `model_id`.
fn decay_job(dir: &Path, extra: &str, model_id: &str) -> pb::JobSpec {
    let (spec, data) = common::decay_spec(dir, extra, &[("k", 1.0, 0.5, 3.0)]);
    job_to_proto(&spec, std::slice::from_ref(&data), model_id)
}

/// Waits until `child` exits, for at most `limit`; whether it did (it is killed if not).
fn exits_within(child: &mut Child, limit: Duration) -> bool {
    let end = Instant::now() + limit;
    while Instant::now() < end {
        if child.try_wait().unwrap().is_some() {
            return true;
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    let _ = child.kill();
    let _ = child.wait();
    false
}

/// Waits until the file at `path` contains `text`, for at most 60 s.
fn wait_for_text(path: &Path, text: &str) {
    let end = Instant::now() + Duration::from_secs(60);
    while !std::fs::read_to_string(path).unwrap_or_default().contains(text) {
        assert!(Instant::now() < end, "{text:?} never appeared in {}", path.display());
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// A coordinator with its store in `dir/coord` (workers log in with `worker_token`, if given),
/// a client, and the Decay example uploaded to it (its model id).
async fn coordinator_with_decay(dir: &Path, worker_token: Option<&str>) -> (Coordinator, Client, String) {
    let coord = start_coordinator(&dir.join("coord"), worker_token).await;
    let mut c = client(&coord.url, TOKEN).await;
    let model = upload_decay(&mut c).await;
    (coord, c, model)
}

async fn upload_decay(c: &mut Client) -> String {
    let bytes = std::fs::read(common::example("decay")).unwrap();
    let chunks = vec![pb::UploadModelRequest { chunk: bytes }];
    c.upload_model(tokio_stream::iter(chunks)).await.unwrap().into_inner().model_id
}

/// A coordinator, its store in `dir/coord`, on which a worker (stopped since) has run a Decay
/// job of 5 iterations to its end.
struct Ended {
    coord: Coordinator,
    c: Client,
    /// The uploaded model's id, and the job's spec and id.
    model: String,
    spec: pb::JobSpec,
    job: String,
    /// The job as it ended.
    before: pb::GetJobResponse,
}

async fn one_job_ended(dir: &Path) -> Ended {
    let (coord, mut c, model) = coordinator_with_decay(dir, Some(WORKER_TOKEN)).await;
    let mut worker = start_worker(&coord.url, &dir.join("wcache"), WORKER_TOKEN);
    let spec = decay_job(dir, "[optimizer]\nmax_iters = 5\n", &model);
    let job = c.submit_job(pb::SubmitJobRequest { spec: Some(spec.clone()) }).await.unwrap().into_inner().job_id;
    let before = wait_end(&mut c, &job).await;
    let _ = worker.kill();
    let _ = worker.wait();
    Ended { coord, c, model, spec, job, before }
}

async fn wait_end(c: &mut Client, job: &str) -> pb::GetJobResponse {
    let deadline = Instant::now() + Duration::from_secs(120);
    loop {
        let r = c.get_job(pb::GetJobRequest { job_id: job.into() }).await.unwrap().into_inner();
        if r.status != pb::JobStatus::Running as i32 {
            return r;
        }
        assert!(Instant::now() < deadline, "job {job} did not end");
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn sizes_past_the_caps_are_refused_and_the_coordinator_keeps_serving() {
    let dir = tempfile::tempdir().unwrap();
    let (_coord, mut c, model) = coordinator_with_decay(dir.path(), None).await;
    let base = decay_job(dir.path(), "", &model);
    let huge_population =
        |algorithm: &str, population: u64| common::proto::with_population(&base, algorithm, population);
    let mut many_parameters = base.clone();
    let p = many_parameters.parameters[0].clone();
    many_parameters.parameters =
        (0..100_000).map(|k| pb::ParameterSpec { name: format!("p{k}"), ..p.clone() }).collect();
    let mut many_fevals = base.clone();
    many_fevals.optimizer.get_or_insert_with(Default::default).max_fevals = Some(u64::MAX);
    let cases = [
        (huge_population("differential-evolution", u64::MAX), "optimizer.population"),
        (huge_population("differential-evolution", 10_000_000_000), "optimizer.population"),
        (huge_population("genetic", 100_000_000), "optimizer.population"),
        (many_parameters, "parameters: 100000 calibrated values exceeds the cap of 1000"),
        (many_fevals, "optimizer.max_fevals"),
    ];
    for (spec, says) in cases {
        let err = c.submit_job(pb::SubmitJobRequest { spec: Some(spec) }).await.unwrap_err();
        assert_eq!(err.code(), tonic::Code::InvalidArgument, "{says}: {err:?}");
        assert!(err.message().contains(says) && err.message().contains("cap"), "{says:?} not in {:?}", err.message());
    }
    // Still serving, with nothing queued.
    assert!(c.list_jobs(pb::ListJobsRequest {}).await.unwrap().into_inner().jobs.is_empty());
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_job_whose_start_point_or_every_evaluation_fails_fails_with_the_first_error() {
    let dir = tempfile::tempdir().unwrap();
    let (coord, mut c, model) = coordinator_with_decay(dir.path(), Some(WORKER_TOKEN)).await;
    let mut worker = start_worker(&coord.url, &dir.path().join("wcache"), WORKER_TOKEN);
    // crashMode = "error" at 0.5 s, within the 2 s simulated: every simulation fails.
    let failing = "[simulation]\nset = { crashMode = \"error\", crashTime = 0.5 }\n";
    let cases = [
        ("", "the start point failed: "),
        // The genetic algorithm's first member is the start point only to its bit resolution,
        // so this one runs to its end: nothing succeeded.
        (
            "[optimizer]\nalgorithm = \"genetic\"\npopulation = 4\nbits = 7\nelitism = 1\nmax_iters = 2\n",
            "no evaluation succeeded; the first error: ",
        ),
    ];
    for (optimizer, says) in cases {
        let spec = decay_job(dir.path(), &format!("{failing}{optimizer}"), &model);
        let job = c.submit_job(pb::SubmitJobRequest { spec: Some(spec) }).await.unwrap().into_inner().job_id;
        let r = wait_end(&mut c, &job).await;
        assert_eq!(r.status, pb::JobStatus::Failed as i32, "{r:?}");
        assert!(r.error.starts_with(says) && r.error.contains("crashMode=error"), "{says:?}: {:?}", r.error);
    }
    let _ = worker.kill();
    let _ = worker.wait();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_worker_may_answer_only_the_points_leased_to_it() {
    let dir = tempfile::tempdir().unwrap();
    let (coord, mut c, model) = coordinator_with_decay(dir.path(), Some(WORKER_TOKEN)).await;
    let spec = decay_job(dir.path(), "[optimizer]\nmax_iters = 3\n", &model);
    let job = c.submit_job(pb::SubmitJobRequest { spec: Some(spec) }).await.unwrap().into_inner().job_id;

    let mut w = pool(&coord.url, WORKER_TOKEN).await;
    let register = |name: &str| pb::RegisterRequest {
        protocol_version: fmucal_proto::PROTOCOL_VERSION,
        slots: 1,
        name: name.into(),
    };
    let honest = w.register(register("honest")).await.unwrap().into_inner().worker_id;
    let forger = w.register(register("forger")).await.unwrap().into_inner().worker_id;
    // Worker ids end in 16 random hex digits: one worker cannot poll as another.
    let random_part = |id: &str| id.rsplit('-').next().unwrap().to_owned();
    for id in [&honest, &forger] {
        assert!(random_part(id).len() == 16 && random_part(id).bytes().all(|b| b.is_ascii_hexdigit()), "{id}");
    }
    assert_ne!(random_part(&honest), random_part(&forger));
    let poll = |worker_id: &str, results: Vec<pb::PointResult>, max_points: u32| pb::PollWorkRequest {
        worker_id: worker_id.into(),
        results,
        max_points,
        wait_ms: 2000,
    };
    let leased = w.poll_work(poll(&honest, vec![], 1)).await.unwrap().into_inner().assignments;
    assert_eq!(leased.len(), 1, "the start point is leased to the first worker that asks");
    let forged = |point_id: u64| pb::PointResult {
        job_id: job.clone(),
        point_id,
        status: pb::PointStatus::Ok as i32,
        value: -1e300,
        ..Default::default()
    };
    // Forged values: for the honest worker's point, and for a point nobody was given.
    w.poll_work(poll(&forger, vec![forged(leased[0].point_id), forged(99)], 0)).await.unwrap();
    let summary = |jobs: Vec<pb::JobSummary>| jobs.into_iter().find(|j| j.job_id == job).unwrap();
    let s = summary(c.list_jobs(pb::ListJobsRequest {}).await.unwrap().into_inner().jobs);
    assert_eq!((s.evaluations, s.status), (0, pb::JobStatus::Running as i32), "a forged result was told: {s:?}");
    // The honest worker's answers are taken: it drives the job to its end alone (a flat
    // objective ends a Nelder–Mead run on f_tol after its first rounds).
    let mut held = leased;
    for _ in 0..100 {
        let answers = held.iter().map(|a| pb::PointResult { value: 0.25, ..forged(a.point_id) }).collect();
        held = w.poll_work(poll(&honest, answers, 1)).await.unwrap().into_inner().assignments;
        if held.is_empty() {
            break;
        }
    }
    let r = c.get_job(pb::GetJobRequest { job_id: job.clone() }).await.unwrap().into_inner();
    assert_eq!(r.status, pb::JobStatus::Succeeded as i32, "{r:?}");
    let result = r.result.unwrap();
    assert_eq!((result.f_opt, result.failed_evaluations), (0.25, 0), "{result:?}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn clients_and_workers_hold_different_tokens() {
    let dir = tempfile::tempdir().unwrap();
    let coord = start_coordinator(&dir.path().join("coord"), Some(WORKER_TOKEN)).await;
    let request = pb::RegisterRequest { protocol_version: fmucal_proto::PROTOCOL_VERSION, slots: 1, name: "w".into() };
    let err = pool(&coord.url, TOKEN).await.register(request.clone()).await.unwrap_err();
    assert_eq!(err.code(), tonic::Code::Unauthenticated, "the client token registered a worker");
    pool(&coord.url, WORKER_TOKEN).await.register(request).await.unwrap();
    let err = client(&coord.url, WORKER_TOKEN).await.list_jobs(pb::ListJobsRequest {}).await.unwrap_err();
    assert_eq!(err.code(), tonic::Code::Unauthenticated, "the worker token listed jobs");
    client(&coord.url, TOKEN).await.list_jobs(pb::ListJobsRequest {}).await.unwrap();

    // The CLI refuses to serve without a token, on loopback too, and a worker token equal to
    // the client token.
    let coordinator = |env: &[(&str, &str)]| {
        let mut cmd = Command::new(env!("CARGO_BIN_EXE_fmucal"));
        cmd.args(["coordinator", "--listen", "127.0.0.1:0", "--data-dir"])
            .arg(dir.path().join("c2"))
            .env_remove("FMUCAL_TOKEN")
            .env_remove("FMUCAL_WORKER_TOKEN");
        for (k, v) in env {
            cmd.env(k, v);
        }
        let out = cmd.output().unwrap();
        assert!(!out.status.success());
        String::from_utf8_lossy(&out.stderr).into_owned()
    };
    let stderr = coordinator(&[]);
    assert!(stderr.contains("refusing to serve without a token"), "{stderr}");
    let stderr = coordinator(&[("FMUCAL_TOKEN", TOKEN), ("FMUCAL_WORKER_TOKEN", TOKEN)]);
    assert!(stderr.contains("must differ"), "{stderr}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn jobs_whose_model_is_gone_after_a_restart_stay_readable() {
    let dir = tempfile::tempdir().unwrap();
    let data_dir = dir.path().join("coord");
    let Ended { coord, mut c, model, spec, job: done, before } = one_job_ended(dir.path()).await;
    assert_eq!(before.status, pb::JobStatus::Succeeded as i32, "{before:?}");
    // With no worker left, this one is still running when the coordinator stops.
    let running = c.submit_job(pb::SubmitJobRequest { spec: Some(spec) }).await.unwrap().into_inner().job_id;
    coord.stop().await;

    std::fs::remove_file(data_dir.join("models").join(format!("{model}.fmu"))).unwrap();
    let _ = std::fs::remove_dir_all(data_dir.join("unpacked"));
    let coord = start_coordinator(&data_dir, Some(WORKER_TOKEN)).await;
    let mut c = client(&coord.url, TOKEN).await;
    let listed: Vec<String> =
        c.list_jobs(pb::ListJobsRequest {}).await.unwrap().into_inner().jobs.into_iter().map(|j| j.job_id).collect();
    assert!(listed.contains(&done) && listed.contains(&running), "{listed:?}");
    let after = c.get_job(pb::GetJobRequest { job_id: done }).await.unwrap().into_inner();
    assert_eq!((after.status, &after.result), (before.status, &before.result));
    assert_eq!(after.error, format!("the job's model {model} is no longer stored"));
    let stopped = c.get_job(pb::GetJobRequest { job_id: running }).await.unwrap().into_inner();
    assert_eq!(stopped.status, pb::JobStatus::Failed as i32, "{stopped:?}");
    assert!(stopped.error.starts_with("cannot resume: spec.model_id: unknown model id"), "{:?}", stopped.error);
    assert_eq!(stopped.result.map(|r| r.x_opt), Some(vec![1.0]), "the start point, as nothing was evaluated");
    coord.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_rejected_upload_leaves_nothing_on_disk() {
    let dir = tempfile::tempdir().unwrap();
    let data_dir = dir.path().join("coord");
    let coord = start_coordinator(&data_dir, None).await;
    let mut c = client(&coord.url, TOKEN).await;
    // The decay FMU with 64 MB more and a model description cut short.
    let broken = common::repack("decay", dir.path(), "broken.fmu", |name, bytes| {
        Some(if name == "modelDescription.xml" { bytes[..bytes.len() / 2].to_vec() } else { bytes })
    });
    let mut entries = common::entries(&broken);
    entries.push(("resources/padding.bin".into(), vec![7; 64 << 20]));
    common::write_zip(&broken, &entries);
    let chunks: Vec<_> =
        std::fs::read(&broken).unwrap().chunks(1 << 20).map(|c| pb::UploadModelRequest { chunk: c.to_vec() }).collect();
    let err = c.upload_model(tokio_stream::iter(chunks)).await.unwrap_err();
    assert_eq!(err.code(), tonic::Code::InvalidArgument, "{err:?}");
    let left = |sub: &str| std::fs::read_dir(data_dir.join(sub)).unwrap().count();
    assert_eq!((left("models"), left("unpacked")), (0, 0), "the rejected upload left files");
    // A good upload still goes in.
    upload_decay(&mut c).await;
    assert_eq!(left("models"), 1);
    coord.stop().await;
}

/// A model that never returns (Decay with crashMode = "hang" from crashTime on) fails its
/// point at the worker's evaluation deadline instead of wedging the worker: with two slots the
/// stuck thread is replaced, with one the worker restarts its process; either way the next job
/// runs on that worker. And SIGTERM stops a worker within its grace period while a model hangs.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_model_that_never_returns_fails_its_point_and_does_not_wedge_the_worker() {
    for slots in ["2", "1"] {
        let dir = tempfile::tempdir().unwrap();
        // The coordinator would re-send a point only after 10 minutes.
        let coord = start_coordinator_with(&dir.path().join("coord"), Some(WORKER_TOKEN), |c| {
            c.timing.evaluation_timeout = Duration::from_secs(600);
        })
        .await;
        let mut c = client(&coord.url, TOKEN).await;
        let model = upload_decay(&mut c).await;
        let log = dir.path().join("worker.log");
        let args = ["--slots", slots, "--evaluation-deadline", "2", "--stop-grace", "1"];
        let mut worker = start_worker_with(&coord.url, &dir.path().join("wcache"), WORKER_TOKEN, &args, Some(&log));
        let parameters = [("k", 1.0, 0.5, 3.0), ("crashTime", 5.0, 0.5, 10.0)];
        let (spec, data) =
            common::decay_spec(dir.path(), "[simulation]\nset = { crashMode = \"hang\" }\n", &parameters);
        // The simulation ends at 2 s: the second point hangs, the others do not.
        let points = spec.evaluating_points(vec![vec![1.7, 5.0], vec![1.7, 1.0], vec![1.0, 5.0]]);
        let job = job_to_proto(&points, std::slice::from_ref(&data), &model);
        let id = c.submit_job(pb::SubmitJobRequest { spec: Some(job) }).await.unwrap().into_inner().job_id;
        let r = wait_end(&mut c, &id).await;
        assert_eq!(r.status, pb::JobStatus::Succeeded as i32, "{slots} slots: {r:?}");
        let evaluated = r.result.unwrap().evaluated;
        assert_eq!(evaluated.iter().map(|p| p.ok).collect::<Vec<_>>(), [true, false, true], "{evaluated:?}");
        assert!(evaluated[1].message.contains("did not return within the worker's evaluation deadline of 2.0 s"));
        // The worker goes on with the next job.
        let next = c.submit_job(pb::SubmitJobRequest { spec: Some(decay_job(dir.path(), "", &model)) }).await.unwrap();
        let r = wait_end(&mut c, &next.into_inner().job_id).await;
        assert_eq!(r.status, pb::JobStatus::Succeeded as i32, "{slots} slots: {r:?}");
        assert!(worker.try_wait().unwrap().is_none(), "the worker exited");
        let text = std::fs::read_to_string(&log).unwrap();
        let restarted = text.contains("restarting the worker");
        assert_eq!(restarted, slots == "1", "{slots} slots, restarted: {restarted}\n{text}");

        // SIGTERM while a model hangs, with no deadline in sight: the worker leaves within its
        // grace period (2 s), handing the point back for the coordinator to send again.
        let _ = worker.kill();
        let _ = worker.wait();
        let args = ["--evaluation-deadline", "600", "--stop-grace", "2"];
        let mut worker = start_worker_with(&coord.url, &dir.path().join("wcache"), WORKER_TOKEN, &args, Some(&log));
        let hanging = spec.evaluating_points(vec![vec![1.7, 1.0]]);
        let job = job_to_proto(&hanging, std::slice::from_ref(&data), &model);
        c.submit_job(pb::SubmitJobRequest { spec: Some(job) }).await.unwrap();
        wait_for_text(&log, "evaluating point");
        Command::new("kill").args(["-TERM", &worker.id().to_string()]).status().unwrap();
        assert!(exits_within(&mut worker, Duration::from_secs(20)), "SIGTERM did not stop a worker whose model hangs");
        wait_for_text(&log, "point handed back unevaluated");
        coord.stop().await;
    }
}

/// `fmucal coordinator` on a free port with `args`, its descriptors limited to `max_fds`.
fn coordinator_process(dir: &Path, max_fds: u32, args: &[&str]) -> (KillOnDrop, String) {
    let port = std::net::TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port();
    let child = Command::new("sh")
        .arg("-c")
        .arg(format!("ulimit -n {max_fds} && exec \"$@\""))
        .arg("sh")
        .arg(env!("CARGO_BIN_EXE_fmucal"))
        .args(["coordinator", "--listen", &format!("127.0.0.1:{port}"), "--data-dir"])
        .arg(dir)
        .args(args)
        .env("FMUCAL_TOKEN", TOKEN)
        .env_remove("FMUCAL_WORKER_TOKEN")
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    (KillOnDrop(child), format!("http://127.0.0.1:{port}"))
}

/// Lists the jobs of the coordinator at `url`, retrying for up to `limit`; whether it answered.
async fn answers_within(url: &str, limit: Duration) -> bool {
    let end = Instant::now() + limit;
    while Instant::now() < end {
        let attempt = async {
            let channel = tonic::transport::Endpoint::from_shared(url.to_owned()).ok()?.connect().await.ok()?;
            let mut c = CalibrationClient::with_interceptor(channel, AttachToken::new(Some(TOKEN)).unwrap());
            c.list_jobs(pb::ListJobsRequest {}).await.ok()
        };
        if tokio::time::timeout(Duration::from_secs(5), attempt).await.ok().flatten().is_some() {
            return true;
        }
        tokio::time::sleep(Duration::from_millis(200)).await;
    }
    false
}

/// Reads `stream` until the peer closes it; false if it is still open after `limit`.
fn read_to_end_within(mut stream: &std::net::TcpStream, limit: Duration) -> bool {
    stream.set_read_timeout(Some(limit)).unwrap();
    let mut buf = [0u8; 4096];
    loop {
        match std::io::Read::read(&mut stream, &mut buf) {
            Ok(0) => return true,
            Ok(_) => {}
            Err(e) => return e.kind() == std::io::ErrorKind::ConnectionReset,
        }
    }
}

fn open_fds(pid: u32) -> usize {
    std::fs::read_dir(format!("/proc/{pid}/fd")).map(Iterator::count).unwrap_or(0)
}

/// Connections that never send a byte cannot lock clients out: with 64 file descriptors, 150
/// of them are accepted until descriptors run out (the accept loop then backs off), closed
/// after the idle timeout (1 s), and a client is served. With `--max-connections 8` the
/// coordinator holds at most 8 of 40 such connections open at once.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn idle_connections_neither_exhaust_descriptors_nor_lock_clients_out() {
    let dir = tempfile::tempdir().unwrap();
    let (mut coord, url) =
        coordinator_process(&dir.path().join("a"), 64, &["--idle-timeout", "1", "--max-connections", "1000"]);
    assert!(answers_within(&url, Duration::from_secs(60)).await, "the coordinator did not start");
    let addr = url.trim_start_matches("http://").to_owned();
    let idle: Vec<std::net::TcpStream> = (0..150).map(|_| std::net::TcpStream::connect(&addr).unwrap()).collect();
    assert!(answers_within(&url, Duration::from_secs(60)).await, "a client was locked out by idle connections");
    assert!(coord.try_wait().unwrap().is_none(), "the coordinator died");
    // The server closed the idle connections: reading one ends (after the server's HTTP/2
    // preface, which it sends first).
    assert!(read_to_end_within(&idle[0], Duration::from_secs(10)), "an idle connection was not closed");
    drop(idle);
    let _ = coord.kill();
    let _ = coord.wait();

    let (mut coord, url) =
        coordinator_process(&dir.path().join("b"), 1024, &["--idle-timeout", "30", "--max-connections", "8"]);
    assert!(answers_within(&url, Duration::from_secs(60)).await, "the coordinator did not start");
    // The client's connection closes when it is dropped; wait until the server let it go.
    tokio::time::sleep(Duration::from_millis(500)).await;
    let before = open_fds(coord.id());
    let addr = url.trim_start_matches("http://").to_owned();
    let _held: Vec<std::net::TcpStream> = (0..40).map(|_| std::net::TcpStream::connect(&addr).unwrap()).collect();
    tokio::time::sleep(Duration::from_secs(1)).await;
    let during = open_fds(coord.id());
    assert!(during <= before + 8, "{} descriptors more with 40 idle connections and a cap of 8", during - before);
    let _ = coord.kill();
    let _ = coord.wait();
}

/// A peer without a token cannot hold a connection open (`--auth-timeout 2`, `--idle-timeout 1`):
/// one trickling a byte every 200 ms, never idle, is closed once 2 s pass without a request
/// carrying a valid token, and so is a live HTTP/2 client that only asks the (open) health
/// service, while a client whose request carried the token keeps its connection.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_peer_without_a_token_cannot_hold_a_connection_open() {
    let dir = tempfile::tempdir().unwrap();
    let args = ["--idle-timeout", "1", "--auth-timeout", "2"];
    let (mut coord, url) = coordinator_process(dir.path(), 1024, &args);
    assert!(answers_within(&url, Duration::from_secs(60)).await, "the coordinator did not start");
    // The probing client's connection closes when it is dropped; wait until the server let it go.
    tokio::time::sleep(Duration::from_millis(500)).await;
    let baseline = open_fds(coord.id());

    let addr = url.trim_start_matches("http://").to_owned();
    let trickler = std::net::TcpStream::connect(&addr).unwrap();
    let mut writer = trickler.try_clone().unwrap();
    let trickling = std::thread::spawn(move || {
        let preface = b"PRI * HTTP/2.0\r\n\r\nSM\r\n\r\n";
        for byte in preface.iter().cycle().take(100) {
            if std::io::Write::write_all(&mut writer, &[*byte]).is_err() {
                return;
            }
            std::thread::sleep(Duration::from_millis(200));
        }
    });
    let opened = Instant::now();
    assert!(read_to_end_within(&trickler, Duration::from_secs(10)), "a trickling peer kept its connection");
    let held = opened.elapsed();
    assert!(held >= Duration::from_millis(1900), "closed after {held:?}, before the auth timeout");
    trickling.join().unwrap();

    let mut health = tonic_health::pb::health_client::HealthClient::new(channel(&url).await);
    let req = tonic_health::pb::HealthCheckRequest { service: String::new() };
    assert_eq!(health.check(req).await.unwrap().into_inner().status, 1, "not SERVING");
    let mut authenticated = client(&url, TOKEN).await;
    authenticated.list_jobs(pb::ListJobsRequest {}).await.unwrap();
    tokio::time::sleep(Duration::from_millis(300)).await;
    assert_eq!(open_fds(coord.id()), baseline + 2, "the two clients' connections are not open");
    tokio::time::sleep(Duration::from_secs(4)).await;
    assert_eq!(open_fds(coord.id()), baseline + 1, "not only the authenticated connection is left open");
    authenticated.list_jobs(pb::ListJobsRequest {}).await.unwrap();
    let _ = coord.kill();
    let _ = coord.wait();
}

/// A points job keeps its residuals once and within a cap: with 10,001 measured values a
/// point, 1,000 points (10,001,000 residuals) are refused by `SubmitJob`, and 999 are evaluated
/// with every residual vector in the result while the coordinator process stays under 1 GB
/// (measured: about 700 MB at the end, when the result is stored as JSON and sent; a
/// 4,000-point job once kept 1.9 GB resident: no cap, and each point held twice in memory).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_points_job_keeps_its_residuals_once_and_within_the_cap() {
    let dir = tempfile::tempdir().unwrap();
    let (mut coord, url) = coordinator_process(&dir.path().join("coord"), 1024, &[]);
    assert!(answers_within(&url, Duration::from_secs(60)).await, "the coordinator did not start");
    let mut c = client(&url, TOKEN).await.max_decoding_message_size(256 << 20);
    let model = upload_decay(&mut c).await;
    let fmu = common::load_example("decay", &dir.path().join("cache"));
    let sim = SimSpec {
        parameters: vec![("k".into(), "1.7".into())],
        output_times: Some(fmucal_shared::sim::OutputTimes::Interval(2e-4)),
        ..Default::default()
    };
    let r = simulate(&fmu, &sim).unwrap();
    assert_eq!(r.time.len(), 10_001);
    let data = MeasurementTable { time: r.time.clone(), columns: vec![("x".into(), r.column("x").unwrap().to_vec())] };
    let toml = common::job_toml(&common::example("decay"), None, &[("x", "x")], &[], &[("k", 1.0, 0.5, 3.0)], "");
    let spec = JobSpec::from_toml(&toml, dir.path()).unwrap();
    let points = |n: usize| {
        let job = spec.evaluating_points((0..n).map(|i| vec![0.5 + 2.5 * i as f64 / n as f64]).collect());
        pb::SubmitJobRequest { spec: Some(job_to_proto(&job, std::slice::from_ref(&data), &model)) }
    };
    let refused = c.submit_job(points(1_000)).await.unwrap_err();
    assert_eq!(refused.code(), tonic::Code::InvalidArgument, "{refused:?}");
    assert!(refused.message().contains("10001000 residuals to keep, which exceeds the cap"), "{}", refused.message());

    let mut worker = start_worker_with(&url, &dir.path().join("wcache"), TOKEN, &["--slots", "2"], None);
    let job = c.submit_job(points(999)).await.unwrap().into_inner().job_id;
    let done = wait_end(&mut c, &job).await;
    assert_eq!(done.status, pb::JobStatus::Succeeded as i32, "{}", done.error);
    let evaluated = done.result.unwrap().evaluated;
    assert_eq!(evaluated.len(), 999);
    assert!(evaluated.iter().all(|p| p.ok && p.residuals.len() == 10_001));
    let peak = peak_rss_mb(coord.id());
    eprintln!("coordinator peak RSS with a 999-point job of 10,001 residuals each: {peak:.0} MB");
    assert!(peak < 1024.0, "the coordinator peaked at {peak:.0} MB");
    let _ = worker.kill();
    let _ = worker.wait();
    let _ = coord.kill();
    let _ = coord.wait();
}

/// A job store one flipped byte made unreadable (here its first, redb's magic number): the
/// coordinator refuses to start on it, `fmucal coordinator --salvage` gives back the finished
/// job, keeping the damaged file aside, and the coordinator then serves the job's result.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn salvage_gives_back_the_jobs_of_a_damaged_store() {
    let dir = tempfile::tempdir().unwrap();
    let data_dir = dir.path().join("coord");
    let Ended { coord, job, before, .. } = one_job_ended(dir.path()).await;
    coord.stop().await;

    let store = data_dir.join("jobs.redb");
    let mut bytes = std::fs::read(&store).unwrap();
    bytes[0] ^= 0x20;
    std::fs::write(&store, &bytes).unwrap();
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
    let refused = fmucal_coordinator::run(config(&data_dir, None), listener, async {}).await.unwrap_err().to_string();
    assert!(refused.contains("Not a redb database"), "{refused}");
    // The refusal says what gives the jobs back.
    assert!(refused.contains("jobs.redb") && refused.contains("--salvage"), "{refused}");

    let out = Command::new(env!("CARGO_BIN_EXE_fmucal"))
        .args(["coordinator", "--salvage", "--data-dir"])
        .arg(&data_dir)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{stdout}{}", String::from_utf8_lossy(&out.stderr));
    assert!(stdout.starts_with("kept 1 jobs"), "{stdout}");
    let aside: Vec<_> = std::fs::read_dir(&data_dir)
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().starts_with("jobs.redb.damaged-"))
        .collect();
    assert_eq!(aside.len(), 1, "the damaged store is not kept aside");
    assert_eq!(std::fs::read(aside[0].path()).unwrap(), bytes);

    let coord = start_coordinator(&data_dir, Some(WORKER_TOKEN)).await;
    let mut c = client(&coord.url, TOKEN).await;
    let after = c.get_job(pb::GetJobRequest { job_id: job }).await.unwrap().into_inner();
    assert_eq!((after.status, after.result), (before.status, before.result));
    coord.stop().await;
}

fn peak_rss_mb(pid: u32) -> f64 {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).unwrap();
    let line = status.lines().find(|l| l.starts_with("VmHWM:")).unwrap();
    line.split_whitespace().nth(1).unwrap().parse::<f64>().unwrap() / 1024.0
}

/// A 256 MiB upload of garbage is refused without ever being held in memory: the coordinator
/// streams it to a file and reads the archive from the file (it peaked at 1 GB for 1 GiB when
/// the check read the whole archive into memory).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_large_garbage_upload_is_never_held_in_memory() {
    let dir = tempfile::tempdir().unwrap();
    let (mut coord, url) = coordinator_process(dir.path(), 1024, &[]);
    assert!(answers_within(&url, Duration::from_secs(60)).await, "the coordinator did not start");
    let mut c = client(&url, TOKEN).await;
    let chunks = (0..256u32).map(|i| pb::UploadModelRequest { chunk: vec![(i % 251) as u8; 1 << 20] });
    let err = c.upload_model(tokio_stream::iter(chunks)).await.unwrap_err();
    assert_eq!(err.code(), tonic::Code::InvalidArgument, "{err:?}");
    let peak = peak_rss_mb(coord.id());
    assert!(peak < 128.0, "the coordinator peaked at {peak:.0} MB for a 256 MiB upload");
    let _ = coord.kill();
    let _ = coord.wait();
}
