//! The coordinator and real worker processes on 127.0.0.1: results equal the in-process
//! reference for any number of workers, survive a killed worker and a killed coordinator, go on
//! past an FMU that segfaults, reject invalid requests with INVALID_ARGUMENT naming the field,
//! and refuse calls without the token.

mod common;

use std::collections::{BTreeMap, HashSet};
use std::path::Path;
use std::process::{Command, Stdio};

use common::KillOnDrop;
use std::sync::Arc;
use std::time::{Duration, Instant};

use fmucal_proto::auth::AttachToken;
use fmucal_proto::convert::job_to_proto;
use fmucal_proto::v1 as pb;
use fmucal_proto::v1::calibration_client::CalibrationClient;
use fmucal_shared::job::{JobSpec, MeasurementTable, PreparedJob, local};
use fmucal_shared::sim::{InputTable, SimSpec, simulate};
use tonic::service::interceptor::InterceptedService;
use tonic::transport::Channel;

type Client = CalibrationClient<InterceptedService<Channel, AttachToken>>;
const TOKEN: &str = "test-token-0123456789";

/// Furuta data from frictions 0.010 / 0.0010 with a torque profile, 10 s every 0.05 s.
fn furuta_job(dir: &Path, max_iters: u64) -> (JobSpec, MeasurementTable) {
    let fmu = common::load_example("furuta", &dir.join("cache"));
    let time: Vec<f64> = (0..=200).map(|i| i as f64 * 0.05).collect();
    let u: Vec<f64> = time.iter().map(|t| 0.05 * (1.3 * t).sin()).collect();
    let spec = SimSpec {
        parameters: vec![("armFriction".into(), "0.010".into()), ("pendulumFriction".into(), "0.0010".into())],
        stop_time: Some(10.0),
        output_times: Some(fmucal_shared::sim::OutputTimes::Times(time.clone())),
        inputs: Some(InputTable { time: time.clone(), columns: vec![("u".into(), u.clone())] }),
        tolerance: Some(1e-8),
        ..Default::default()
    };
    let r = simulate(&fmu, &spec).unwrap();
    let data = MeasurementTable {
        time,
        columns: vec![
            ("phi".into(), r.column("armJoint.phi").unwrap().to_vec()),
            ("theta".into(), r.column("pendulumJoint.phi").unwrap().to_vec()),
            ("u".into(), u),
        ],
    };
    let toml = common::job_toml(
        &common::example("furuta"),
        None,
        &[("armJoint.phi", "phi"), ("pendulumJoint.phi", "theta")],
        &[("u", "u")],
        &[("armFriction", 0.012, 0.0, 0.022), ("pendulumFriction", 0.002, 0.0, 0.012)],
        &format!("[simulation]\ntolerance = 1e-8\n[optimizer]\nx_tol = 1e-6\nf_tol = 1e-14\nmax_iters = {max_iters}\n"),
    );
    (JobSpec::from_toml(&toml, dir).unwrap(), data)
}

/// The in-process reference result.
fn reference(spec: &JobSpec, data: &MeasurementTable, dir: &Path) -> fmucal_shared::job::CalibrationResult {
    let fmu = Arc::new(common::load(spec.model.path.as_ref().unwrap(), &dir.join("cache")));
    let job =
        Arc::new(PreparedJob::new(spec, &fmu.description, &fmu.interfaces(), std::slice::from_ref(data)).unwrap());
    local::calibrate(fmu, job, 1, |_| {}).unwrap()
}

/// A coordinator on a free port; it serves until this is dropped.
struct Coordinator {
    url: String,
    _stop: Option<tokio::sync::oneshot::Sender<()>>,
    _task: tokio::task::JoinHandle<Result<(), fmucal_coordinator::CoordinatorError>>,
}

async fn start_coordinator(data_dir: &Path) -> Coordinator {
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
    let url = format!("http://{}", listener.local_addr().unwrap());
    let (tx, rx) = tokio::sync::oneshot::channel::<()>();
    let timing = fmucal_coordinator::Timing {
        heartbeat_interval: Duration::from_millis(200),
        worker_expiry: Duration::from_millis(1500),
        evaluation_timeout: Duration::from_secs(60),
    };
    let config = fmucal_coordinator::Config {
        token: Some(TOKEN.into()),
        timing,
        ..fmucal_coordinator::Config::new(data_dir.to_owned())
    };
    let task = tokio::spawn(fmucal_coordinator::run(config, listener, async {
        let _ = rx.await;
    }));
    Coordinator { url, _stop: Some(tx), _task: task }
}

fn start_worker(url: &str, cache: &Path, token: &str) -> KillOnDrop {
    start_worker_logging(url, cache, token, None)
}

/// A worker; with `log`, its stderr goes to that file, with a line for every point it
/// evaluates (read by [`evaluated_points`]).
fn start_worker_logging(url: &str, cache: &Path, token: &str, log: Option<&Path>) -> KillOnDrop {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_fmucal"));
    cmd.args(["worker", "--coordinator", url, "--cache-dir"])
        .arg(cache)
        .env("FMUCAL_TOKEN", token)
        .stdin(Stdio::null())
        .stdout(Stdio::null());
    match log {
        Some(log) => {
            cmd.env("FMUCAL_LOG", "warn,fmucal_worker::slot=debug").stderr(std::fs::File::create(log).unwrap())
        }
        None => cmd.stderr(Stdio::null()),
    };
    KillOnDrop(cmd.spawn().unwrap())
}

/// The (job, point) of every evaluation in a worker's log, in order.
fn evaluated_points(log: &Path) -> Vec<(String, u64)> {
    let text = std::fs::read_to_string(log).unwrap();
    let lines = text.lines().filter(|l| l.contains("point evaluated"));
    lines
        .map(|l| {
            let field = |name| l.split_whitespace().find_map(|w| w.strip_prefix(name)).expect(l).to_owned();
            (field("job="), field("point=").parse().expect(l))
        })
        .collect()
}

async fn client(url: &str, token: Option<&str>) -> Client {
    let ch = tonic::transport::Endpoint::from_shared(url.to_owned()).unwrap().connect().await.unwrap();
    CalibrationClient::with_interceptor(ch, AttachToken::new(token).unwrap()).max_encoding_message_size(256 << 20)
}

async fn upload(c: &mut Client, path: &Path) -> Result<String, tonic::Status> {
    let bytes = std::fs::read(path).unwrap();
    let chunks: Vec<_> = bytes.chunks(100_000).map(|c| pb::UploadModelRequest { chunk: c.to_vec() }).collect();
    Ok(c.upload_model(tokio_stream::iter(chunks)).await?.into_inner().model_id)
}

async fn submit(c: &mut Client, spec: &JobSpec, data: &MeasurementTable) -> String {
    let id = upload(c, spec.model.path.as_ref().unwrap()).await.unwrap();
    c.submit_job(pb::SubmitJobRequest { spec: Some(job_to_proto(spec, std::slice::from_ref(data), &id)) })
        .await
        .unwrap()
        .into_inner()
        .job_id
}

/// Polls until the job leaves RUNNING; `during` runs once the job has completed `after_rounds`.
/// Polls the job until it ends; `during` runs once, while the job is still running, after
/// `after_rounds` × 4 evaluations. Returns the final state and whether `during` ran.
async fn wait_done(
    c: &mut Client,
    job: &str,
    after_rounds: u64,
    mut during: impl FnMut(),
) -> (pb::GetJobResponse, bool) {
    let deadline = Instant::now() + Duration::from_secs(300);
    let mut fired = false;
    loop {
        assert!(Instant::now() < deadline, "job {job} did not finish in time");
        if let Ok(r) = c.get_job(pb::GetJobRequest { job_id: job.into() }).await {
            let r = r.into_inner();
            if r.status != pb::JobStatus::Running as i32 {
                return (r, fired);
            }
        }
        if !fired {
            let evs = c.list_jobs(pb::ListJobsRequest {}).await.map(|r| r.into_inner().jobs).unwrap_or_default();
            if evs.iter().any(|j| j.job_id == job && j.evaluations >= after_rounds.saturating_mul(4)) {
                during();
                fired = true;
            }
        }
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
}

fn x_opt(r: &pb::GetJobResponse) -> Vec<f64> {
    r.result.as_ref().expect("a result").x_opt.clone()
}

fn kill_all(children: &mut [KillOnDrop]) {
    for c in children {
        let _ = c.kill();
        let _ = c.wait();
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn one_and_three_workers_give_the_in_process_result() {
    let dir = tempfile::tempdir().unwrap();
    let (spec, data) = furuta_job(dir.path(), 25);
    let want = reference(&spec, &data, dir.path());
    let want_x: Vec<f64> = ["armFriction", "pendulumFriction"].iter().map(|n| want.x_opt[*n]).collect();
    for n in [1, 3] {
        let coord = start_coordinator(&dir.path().join(format!("coord{n}"))).await;
        let mut workers: Vec<KillOnDrop> =
            (0..n).map(|_| start_worker(&coord.url, &dir.path().join("wcache"), TOKEN)).collect();
        let mut c = client(&coord.url, Some(TOKEN)).await;
        let job = submit(&mut c, &spec, &data).await;
        let (r, _) = wait_done(&mut c, &job, u64::MAX, || {}).await;
        kill_all(&mut workers);
        assert_eq!(r.status, pb::JobStatus::Succeeded as i32, "{r:?}");
        assert_eq!(x_opt(&r), want_x, "{n} workers");
        assert_eq!(r.result.as_ref().unwrap().evaluations, want.evaluations);
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn killing_a_worker_mid_job_changes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    // Long enough (60 iterations) that the kill after 8 evaluations lands while it runs.
    let (spec, data) = furuta_job(dir.path(), 60);
    let want = reference(&spec, &data, dir.path());
    let coord = start_coordinator(&dir.path().join("coord")).await;
    let mut workers: Vec<KillOnDrop> =
        (0..3).map(|_| start_worker(&coord.url, &dir.path().join("wcache"), TOKEN)).collect();
    let mut c = client(&coord.url, Some(TOKEN)).await;
    let job = submit(&mut c, &spec, &data).await;
    let victim = workers[1].id();
    let (r, killed_mid_job) = wait_done(&mut c, &job, 2, || {
        sigkill(victim);
    })
    .await;
    assert!(killed_mid_job, "the job ended before the worker was killed");
    let status = workers[1].wait().unwrap();
    assert_eq!(std::os::unix::process::ExitStatusExt::signal(&status), Some(9), "victim {status:?}");
    kill_all(&mut workers);
    assert_eq!(r.status, pb::JobStatus::Succeeded as i32);
    assert_eq!(x_opt(&r), vec![want.x_opt["armFriction"], want.x_opt["pendulumFriction"]]);
}

/// SIGKILL through the `kill` command (no unsafe libc call in tests).
fn sigkill(pid: u32) {
    let _ = Command::new("kill").args(["-9", &pid.to_string()]).status();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn coordinator_killed_and_restarted_resumes_the_job() {
    let dir = tempfile::tempdir().unwrap();
    let (spec, data) = furuta_job(dir.path(), 30);
    let want = reference(&spec, &data, dir.path());
    let port = free_port();
    let data_dir = dir.path().join("coord");
    let start = || coordinator_process(port, &data_dir);
    let url = format!("http://127.0.0.1:{port}");
    let mut coord = start();
    tokio::time::sleep(Duration::from_millis(500)).await;
    // The workers log every evaluation: the count, not the job's own counter, shows what was
    // evaluated again.
    let logs: Vec<_> = (0..2).map(|i| dir.path().join(format!("worker{i}.log"))).collect();
    let mut workers: Vec<KillOnDrop> =
        logs.iter().map(|log| start_worker_logging(&url, &dir.path().join("wcache"), TOKEN, Some(log))).collect();
    let mut c = client(&url, Some(TOKEN)).await;
    let job = submit(&mut c, &spec, &data).await;
    // Wait for some progress, then SIGKILL the coordinator and start it again. The store is
    // written behind the scheduler: if the kill came before enough of the job was on disk to
    // make the test mean something, start the coordinator again and kill it later (each kill
    // is one more resumption the job must survive).
    let mut kills = 0;
    let mut wanted = 30;
    let (logged_before, told, first_open) = loop {
        let deadline = Instant::now() + Duration::from_secs(120);
        loop {
            let jobs = c.list_jobs(pb::ListJobsRequest {}).await.unwrap().into_inner().jobs;
            if jobs.iter().any(|j| j.evaluations >= wanted) {
                break;
            }
            assert!(Instant::now() < deadline, "the job did not reach {wanted} evaluations");
            tokio::time::sleep(Duration::from_millis(20)).await;
        }
        coord.kill().unwrap();
        coord.wait().unwrap();
        kills += 1;
        // What the workers had logged by then; later lines are evaluations after the kill.
        let logged_before: Vec<usize> = logs.iter().map(|l| evaluated_points(l).len()).collect();
        // What was on disk when the coordinator died: the first point of the batch after the
        // last saved state (the batches before it are complete), and the points of that open
        // batch told since (the journal).
        let (told, first_open): (HashSet<u64>, u64) = {
            let store = fmucal_coordinator::store::Store::open(&data_dir).unwrap();
            let told = store.evaluations(&job).unwrap().into_iter().map(|l| l.point).collect();
            let (_, _, mut state) = store.load_all().unwrap().into_iter().find(|(id, _, _)| *id == job).unwrap();
            (told, state.run.ask().iter().map(|c| c.id).min().expect("the job was running"))
        };
        // The journal holds only the open batch's told points (a saved state replaces the
        // journal before it): enough was on disk once the saved state covers 20 points.
        if first_open >= 20 {
            break (logged_before, told, first_open);
        }
        assert!(kills < 5, "after {kills} kills, little was saved: the state up to point {first_open}");
        wanted = first_open + 30;
        coord = start();
        tokio::time::sleep(Duration::from_millis(500)).await;
        c = client(&url, Some(TOKEN)).await;
    };
    let mut coord = start();
    tokio::time::sleep(Duration::from_millis(500)).await;
    let mut c = client(&url, Some(TOKEN)).await;
    let (r, _) = wait_done(&mut c, &job, u64::MAX, || {}).await;
    kill_all(&mut workers);
    let _ = coord.kill();
    assert_eq!(r.status, pb::JobStatus::Succeeded as i32, "{r:?}");
    assert_eq!(x_opt(&r), vec![want.x_opt["armFriction"], want.x_opt["pendulumFriction"]]);
    let res = r.result.unwrap();
    assert_eq!(res.evaluations, want.evaluations);
    let mut runs: BTreeMap<u64, usize> = BTreeMap::new();
    for (j, point) in logs.iter().flat_map(|log| evaluated_points(log)) {
        if j == job {
            *runs.entry(point).or_default() += 1;
        }
    }
    let total: usize = runs.values().sum();
    assert!(
        total as u64 >= res.evaluations,
        "the workers evaluated {total} points, the job counts {}",
        res.evaluations
    );
    // Every point the workers evaluated was one the job counts (the resumed optimizer asked
    // the same points again, not new ones).
    assert_eq!(runs.len() as u64, res.evaluations, "points evaluated: {runs:?}");
    // Only points whose results were not on disk at the kill ran again, once: those the workers
    // held then and those reported since the last write, all from batches after the saved
    // state. (How many depends on how far the workers got while the write was on its way.)
    assert!(runs.values().all(|n| *n <= 1 + kills), "a point ran more than once a kill and once more: {runs:?}");
    let after: Vec<u64> = logs
        .iter()
        .zip(&logged_before)
        .flat_map(|(log, n)| evaluated_points(log).into_iter().skip(*n))
        .filter(|(j, _)| *j == job)
        .map(|(_, p)| p)
        .collect();
    assert!(after.iter().all(|p| !told.contains(p)), "points told before the kill ran again: {after:?}");
    assert!(after.iter().all(|p| *p >= first_open), "a completed batch ran again: {after:?}, saved up to {first_open}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_fmu_that_segfaults_or_aborts_fails_points_not_the_job() {
    for mode in ["segfault", "abort"] {
        crashing_job(mode).await;
    }
}

async fn crashing_job(mode: &str) {
    let dir = tempfile::tempdir().unwrap();
    let cache = dir.path().join("cache");
    let fmu = common::load_example("decay", &cache);
    let r = simulate(&fmu, &SimSpec { parameters: vec![("k".into(), "1.7".into())], ..Default::default() }).unwrap();
    let data = MeasurementTable { time: r.time.clone(), columns: vec![("x".into(), r.column("x").unwrap().to_vec())] };
    // crashTime below the stop time (2 s) kills the worker process (SIGSEGV or SIGABRT).
    let toml = common::job_toml(
        &common::example("decay"),
        None,
        &[("x", "x")],
        &[],
        &[("k", 1.0, 0.5, 3.0), ("crashTime", 2.5, 1.0, 3.0)],
        &format!(
            "[simulation]\nset = {{ crashMode = \"{mode}\" }}\n[optimizer]\nalgorithm = \"differential-evolution\"\n\
             population = 8\nmax_iters = 4\nseed = 1\n"
        ),
    );
    let spec = JobSpec::from_toml(&toml, dir.path()).unwrap();
    let coord = start_coordinator(&dir.path().join("coord")).await;
    let wcache = dir.path().join("wcache");
    let mut workers: Vec<KillOnDrop> = (0..2).map(|_| start_worker(&coord.url, &wcache, TOKEN)).collect();
    let mut c = client(&coord.url, Some(TOKEN)).await;
    let job = submit(&mut c, &spec, &data).await;
    // Replace crashed workers, as `fmucal calibrate` does.
    let deadline = Instant::now() + Duration::from_secs(240);
    let r = loop {
        for w in workers.iter_mut() {
            if let Ok(Some(_)) = w.try_wait() {
                *w = start_worker(&coord.url, &wcache, TOKEN);
            }
        }
        let r = c.get_job(pb::GetJobRequest { job_id: job.clone() }).await.unwrap().into_inner();
        if r.status != pb::JobStatus::Running as i32 {
            break r;
        }
        assert!(Instant::now() < deadline, "job did not finish");
        tokio::time::sleep(Duration::from_millis(100)).await;
    };
    kill_all(&mut workers);
    assert_eq!(r.status, pb::JobStatus::Succeeded as i32, "{mode}: {r:?}");
    let res = r.result.unwrap();
    assert!(res.failed_evaluations > 0, "{mode}: no point crashed: {res:?}");
    assert!(res.x_opt[1] >= 2.0, "the best point cannot be one that crashed: {res:?}");
    // The coordinator still serves.
    assert!(!c.list_jobs(pb::ListJobsRequest {}).await.unwrap().into_inner().jobs.is_empty());
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn invalid_requests_get_invalid_argument_naming_the_field() {
    let dir = tempfile::tempdir().unwrap();
    let (spec, data) = furuta_job(dir.path(), 5);
    let coord = start_coordinator(&dir.path().join("coord")).await;
    let mut c = client(&coord.url, Some(TOKEN)).await;
    let model = upload(&mut c, &common::example("furuta")).await.unwrap();
    let base = job_to_proto(&spec, std::slice::from_ref(&data), &model);
    let cases: Vec<(Box<dyn Fn(&mut pb::JobSpec)>, &str)> = vec![
        (Box::new(|j| j.parameters[0].name = "armFrction".into()), "parameters[0].name"),
        (Box::new(|j| j.parameters[1].lower = 0.5), "parameters[1].lower"),
        (Box::new(|j| j.parameters[0].start = 1.0), "parameters[0].start"),
        (Box::new(|j| j.outputs[0].variable = "nope".into()), "outputs[0].variable"),
        (Box::new(|j| j.data.as_mut().unwrap().time.clear()), "data"),
        (
            Box::new(|j| {
                j.data.as_mut().unwrap().columns[0].values.pop();
            }),
            "data.columns[phi]",
        ),
        (Box::new(|j| j.data.as_mut().unwrap().time.swap(3, 4)), "data.time"),
        (Box::new(|j| j.model_id = "0".repeat(64)), "spec.model_id"),
        (Box::new(|j| j.data = None), "spec.data"),
    ];
    for (edit, field) in cases {
        let mut j = base.clone();
        edit(&mut j);
        let err = c.submit_job(pb::SubmitJobRequest { spec: Some(j) }).await.unwrap_err();
        assert_eq!(err.code(), tonic::Code::InvalidArgument, "{field}: {err:?}");
        assert!(err.message().contains(field), "{field:?} not in {:?}", err.message());
    }
    let tmp = dir.path().join("not.fmu");
    std::fs::write(&tmp, b"these bytes are not an FMU").unwrap();
    let err = upload(&mut c, &tmp).await.unwrap_err();
    assert_eq!(err.code(), tonic::Code::InvalidArgument, "{err:?}");
    assert!(err.message().contains("not a usable FMU"), "{}", err.message());

    // A worker speaking another protocol version.
    let ch = tonic::transport::Endpoint::from_shared(coord.url.clone()).unwrap().connect().await.unwrap();
    let mut w = pb::worker_pool_client::WorkerPoolClient::with_interceptor(ch, AttachToken::new(Some(TOKEN)).unwrap());
    let err = w.register(pb::RegisterRequest { protocol_version: 99, slots: 1, name: "old".into() }).await.unwrap_err();
    assert_eq!(err.code(), tonic::Code::InvalidArgument);
    assert!(err.message().contains("protocol_version"), "{}", err.message());
    drop(coord);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn calls_without_the_token_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let coord = start_coordinator(&dir.path().join("coord")).await;
    for token in [None, Some("wrong")] {
        let mut c = client(&coord.url, token).await;
        let err = c.list_jobs(pb::ListJobsRequest {}).await.unwrap_err();
        assert_eq!(err.code(), tonic::Code::Unauthenticated, "{token:?}");
    }
    // A worker with the wrong token cannot register: it exits with an error.
    let out = Command::new(env!("CARGO_BIN_EXE_fmucal"))
        .args(["worker", "--coordinator", &coord.url, "--cache-dir"])
        .arg(dir.path().join("w"))
        .env("FMUCAL_TOKEN", "wrong")
        .output()
        .unwrap();
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("registration refused") && stderr.contains("bearer token"), "{stderr}");
    // A coordinator refuses to serve without a token.
    let out = Command::new(env!("CARGO_BIN_EXE_fmucal"))
        .args(["coordinator", "--listen", "0.0.0.0:0", "--data-dir"])
        .arg(dir.path().join("c2"))
        .env_remove("FMUCAL_TOKEN")
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("without a token"),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_once_per_process_fmu_runs_on_a_multi_slot_worker() {
    let dir = tempfile::tempdir().unwrap();
    let once = common::once_per_process("decay", dir.path());
    let fmu = common::load(&once, &dir.path().join("cache"));
    let r = simulate(&fmu, &SimSpec { parameters: vec![("k".into(), "1.7".into())], ..Default::default() }).unwrap();
    let data = MeasurementTable { time: r.time.clone(), columns: vec![("x".into(), r.column("x").unwrap().to_vec())] };
    let toml = common::job_toml(
        &once,
        None,
        &[("x", "x")],
        &[],
        &[("k", 1.0, 0.1, 5.0)],
        "[optimizer]\nalgorithm = \"differential-evolution\"\npopulation = 12\nmax_iters = 3\n",
    );
    let spec = JobSpec::from_toml(&toml, dir.path()).unwrap();
    let coord = start_coordinator(&dir.path().join("coord")).await;
    let mut worker = Command::new(env!("CARGO_BIN_EXE_fmucal"))
        .args(["worker", "--coordinator", &coord.url, "--slots", "3", "--cache-dir"])
        .arg(dir.path().join("w"))
        .env("FMUCAL_TOKEN", TOKEN)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let mut c = client(&coord.url, Some(TOKEN)).await;
    let job = submit(&mut c, &spec, &data).await;
    let (r, _) = wait_done(&mut c, &job, u64::MAX, || {}).await;
    let _ = worker.kill();
    assert_eq!(r.status, pb::JobStatus::Succeeded as i32, "{r:?}");
    assert_eq!(r.result.unwrap().failed_evaluations, 0, "a second instance was attempted");
}

/// A coordinator's data folder as the coordinator of the single-core-crate layout left it: two
/// finished jobs and a third SIGKILLed mid-run (`FMUCAL_BLESS_STORE=1` writes it again, from
/// the coordinator being built), with `expected.json` naming them.
const STORE_FIXTURE: &str = "tests/data/store_v1";

/// A coordinator process on `port`.
fn coordinator_process(port: u16, data_dir: &Path) -> KillOnDrop {
    KillOnDrop(
        Command::new(env!("CARGO_BIN_EXE_fmucal"))
            .args(["coordinator", "--listen", &format!("127.0.0.1:{port}"), "--data-dir"])
            .arg(data_dir)
            // Long enough that a loaded machine never expires a worker, which would re-send its
            // points and blur the count of re-evaluations.
            .args(["--worker-expiry", "30"])
            .env("FMUCAL_TOKEN", TOKEN)
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap(),
    )
}

fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port()
}

/// A coordinator process on a free port with its store in `data_dir`, one worker (its cache in
/// `dir/wcache`) and a client.
async fn coordinator_with_a_worker(dir: &Path, data_dir: &Path) -> (KillOnDrop, Vec<KillOnDrop>, Client) {
    let port = free_port();
    let url = format!("http://127.0.0.1:{port}");
    let coord = coordinator_process(port, data_dir);
    tokio::time::sleep(Duration::from_millis(500)).await;
    let workers = vec![start_worker(&url, &dir.join("wcache"), TOKEN)];
    (coord, workers, client(&url, Some(TOKEN)).await)
}

/// Writes [`STORE_FIXTURE`]: runs a coordinator process on a fresh folder, finishes two short
/// jobs, SIGKILLs it while a third runs.
async fn bless_store(fixture: &Path) {
    let dir = tempfile::tempdir().unwrap();
    let _ = std::fs::remove_dir_all(fixture);
    let data_dir = dir.path().join("coord");
    let (mut coord, mut workers, mut c) = coordinator_with_a_worker(dir.path(), &data_dir).await;
    let mut finished = serde_json::Map::new();
    for iters in [3, 4] {
        let (spec, data) = furuta_job(dir.path(), iters);
        let job = submit(&mut c, &spec, &data).await;
        let (r, _) = wait_done(&mut c, &job, u64::MAX, || {}).await;
        assert_eq!(r.status, pb::JobStatus::Succeeded as i32, "{r:?}");
        finished.insert(job, serde_json::json!(x_opt(&r)));
    }
    let (spec, data) = furuta_job(dir.path(), 30);
    let running = submit(&mut c, &spec, &data).await;
    let deadline = Instant::now() + Duration::from_secs(120);
    loop {
        let jobs = c.list_jobs(pb::ListJobsRequest {}).await.unwrap().into_inner().jobs;
        if jobs.iter().any(|j| j.job_id == running && j.evaluations >= 24) {
            break;
        }
        assert!(Instant::now() < deadline);
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    coord.kill().unwrap();
    coord.wait().unwrap();
    kill_all(&mut workers);
    common::copy_dir(&data_dir, fixture);
    // The unpacked archives are a cache the coordinator makes again from models/.
    std::fs::remove_dir_all(fixture.join("unpacked")).unwrap();
    let expected = serde_json::json!({ "finished": finished, "running": running, "running_max_iters": 30 });
    std::fs::write(fixture.join("expected.json"), serde_json::to_string_pretty(&expected).unwrap()).unwrap();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_store_left_by_the_earlier_coordinator_resumes_and_keeps_its_results() {
    let fixture = Path::new(env!("CARGO_MANIFEST_DIR")).join(STORE_FIXTURE);
    if std::env::var_os("FMUCAL_BLESS_STORE").is_some() {
        bless_store(&fixture).await;
    }
    let expected: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(fixture.join("expected.json")).unwrap()).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let data_dir = dir.path().join("coord");
    common::copy_dir(&fixture, &data_dir);
    let (mut coord, mut workers, mut c) = coordinator_with_a_worker(dir.path(), &data_dir).await;
    for (job, x) in expected["finished"].as_object().unwrap() {
        let r = c.get_job(pb::GetJobRequest { job_id: job.clone() }).await.unwrap().into_inner();
        assert_eq!(r.status, pb::JobStatus::Succeeded as i32, "{job}: {r:?}");
        let want: Vec<f64> = serde_json::from_value(x.clone()).unwrap();
        assert_eq!(x_opt(&r), want, "{job}");
    }
    let running = expected["running"].as_str().unwrap();
    let (spec, data) = furuta_job(dir.path(), expected["running_max_iters"].as_u64().unwrap());
    let want = reference(&spec, &data, dir.path());
    let (r, _) = wait_done(&mut c, running, u64::MAX, || {}).await;
    kill_all(&mut workers);
    let _ = coord.kill();
    let _ = coord.wait();
    assert_eq!(r.status, pb::JobStatus::Succeeded as i32, "{r:?}");
    assert_eq!(x_opt(&r), vec![want.x_opt["armFriction"], want.x_opt["pendulumFriction"]]);
    assert_eq!(r.result.unwrap().evaluations, want.evaluations);
}
