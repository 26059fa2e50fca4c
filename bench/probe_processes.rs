//! The process-level cases of `bench/probe.sh` (a module of `bench/probe_grpc.rs`): each starts
//! its own `fmucal coordinator` and workers ($FMUCAL) in a scratch folder, kills, restarts,
//! hangs or fills what the case needs, and reports one line per case, as the request cases do.
//! Every process it starts is killed on every path ([`Proc`]'s `Drop`).
//!
//! - [`full_disk`]: a data dir on a disk that fills up. Run inside a mount namespace with a
//!   small tmpfs mounted at the scratch folder (`bench/probe.d/grpc.sh` does it with
//!   `unshare -m`), so the disk is real and ENOSPC comes from the kernel.
//! - [`model_gone`]: a model file removed while the coordinator is down.
//! - [`hung_model`]: a model that never returns, with one slot and with two.
//! - [`killed_diagnosis`]: a SIGKILL of the coordinator during a Diagnose call.

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use fmucal_proto::convert::job_to_proto;
use fmucal_proto::v1 as pb;
use fmucal_shared::job::{JobSpec, MeasurementTable};

use super::{Client, env, report};

const RUNNING: i32 = pb::JobStatus::Running as i32;
const SUCCEEDED: i32 = pb::JobStatus::Succeeded as i32;
const FAILED: i32 = pb::JobStatus::Failed as i32;
const CANCELLED: i32 = pb::JobStatus::Cancelled as i32;

/// A child process, killed (SIGKILL) and reaped when dropped unless it has ended.
pub struct Proc(Child);

impl Proc {
    fn id(&self) -> u32 {
        self.0.id()
    }

    /// Sends SIGTERM and waits at most `limit` for the process to exit: how long it took, or
    /// `None` (it is then killed).
    fn terminate(&mut self, limit: Duration) -> Option<Duration> {
        let start = Instant::now();
        let _ = Command::new("kill").args(["-TERM", &self.id().to_string()]).status();
        while start.elapsed() < limit {
            if matches!(self.0.try_wait(), Ok(Some(_))) {
                return Some(start.elapsed());
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        self.kill();
        None
    }

    fn kill(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

impl Drop for Proc {
    fn drop(&mut self) {
        self.kill();
    }
}

fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0").and_then(|l| l.local_addr()).map(|a| a.port()).unwrap_or(9)
}

fn log_file(path: &Path) -> Stdio {
    std::fs::File::create(path).map_or_else(|_| Stdio::null(), Stdio::from)
}

/// `fmucal coordinator` on a free port with its data in `data_dir` and more `args`, logging
/// to `log`: the process and its URL.
fn coordinator(data_dir: &Path, args: &[&str], log: &Path) -> (Proc, String) {
    let addr = format!("127.0.0.1:{}", free_port());
    let child = Command::new(env("FMUCAL"))
        .args(["coordinator", "--listen", &addr, "--data-dir"])
        .arg(data_dir)
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(log_file(log))
        .spawn()
        .unwrap_or_else(|e| panic!("cannot start {}: {e}", env("FMUCAL")));
    (Proc(child), format!("http://{addr}"))
}

/// `fmucal worker` for the coordinator at `url`, with the worker token and more `args`.
fn worker(url: &str, args: &[&str], log: &Path) -> Proc {
    let child = Command::new(env("FMUCAL"))
        .args(["worker", "--coordinator", url])
        .args(args)
        .env("FMUCAL_TOKEN", env("FMUCAL_WORKER_TOKEN"))
        .env_remove("FMUCAL_WORKER_TOKEN")
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(log_file(log))
        .spawn()
        .unwrap_or_else(|e| panic!("cannot start a worker: {e}"));
    Proc(child)
}

/// A client of the coordinator at `url` once it serves (a request with the client token is
/// answered), within 60 s.
async fn serving(url: &str) -> Option<Client> {
    let end = Instant::now() + Duration::from_secs(60);
    while Instant::now() < end {
        if let Ok(Ok(ch)) = tokio::time::timeout(
            Duration::from_secs(2),
            tonic::transport::Endpoint::from_shared(url.to_owned()).ok()?.connect(),
        )
        .await
        {
            let mut c = super::client_on(ch, Some(&env("FMUCAL_TOKEN")));
            if c.list_jobs(pb::ListJobsRequest {}).await.is_ok() {
                return Some(c);
            }
        }
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
    None
}

async fn upload(c: &mut Client, example: &str) -> Result<String, String> {
    let path = fmucal_models::example(example).ok_or_else(|| format!("no {example} example"))?;
    let bytes = std::fs::read(&path).map_err(|e| format!("{}: {e}", path.display()))?;
    let chunks = bytes.chunks(1 << 20).map(|c| pb::UploadModelRequest { chunk: c.to_vec() }).collect::<Vec<_>>();
    c.upload_model(tokio_stream::iter(chunks)).await.map(|r| r.into_inner().model_id).map_err(|e| e.to_string())
}

/// A coordinator as [`coordinator`] starts it and a client of it once it serves; when it does
/// not, reports `case` failed with the end of its log.
async fn serving_coordinator(case: &str, data_dir: &Path, args: &[&str], log: &Path) -> Option<(Proc, String, Client)> {
    let (coord, url) = coordinator(data_dir, args, log);
    let Some(c) = serving(&url).await else {
        report(case, false, &format!("did not serve: {}", tail(log)));
        return None;
    };
    Some((coord, url, c))
}

/// [`serving_coordinator`] for the case folder `dir` (the data in `dir/coord`, the log
/// `dir/coordinator.log`) with example `example` uploaded, and its model id; when the upload
/// fails, reports `case` failed.
async fn serving_with_model(
    case: &str,
    dir: &Path,
    args: &[&str],
    example: &str,
) -> Option<(Proc, String, Client, String)> {
    let (data_dir, log) = (dir.join("coord"), dir.join("coordinator.log"));
    let (coord, url, mut c) = serving_coordinator(case, &data_dir, args, &log).await?;
    let model = upload(&mut c, example)
        .await
        .map_err(|e| report(case, false, &format!("cannot upload {example}: {e}")))
        .ok()?;
    Some((coord, url, c, model))
}

/// The decay model (x' = −k x, 0..2 s) evaluated at `points` of (k, crashTime), with
/// `crashMode = "hang"`: a point whose crash time is before 2 s never returns. Its data are
/// x = exp(−1.7 t) every `dt` seconds.
fn hang_points(model_id: &str, points: Vec<Vec<f64>>, dt: f64) -> pb::JobSpec {
    let toml = format!(
        "[model]\npath = \"{}\"\n[data]\n[[outputs]]\nvariable = \"x\"\ncolumn = \"x\"\n\
         [[parameters]]\nname = \"k\"\nstart = 1.0\nlower = 0.5\nupper = 3.0\n\
         [[parameters]]\nname = \"crashTime\"\nstart = 5.0\nlower = 0.5\nupper = 10.0\n\
         [simulation]\nstop_time = 2.0\nset = {{ crashMode = \"hang\" }}\n",
        fmucal_models::example("decay").expect("the decay example").display()
    );
    let spec = JobSpec::from_toml(&toml, Path::new(".")).expect("the probe's job is valid");
    let n = (2.0 / dt).round() as usize;
    #[allow(clippy::cast_precision_loss)]
    let time: Vec<f64> = (0..=n).map(|i| i as f64 * dt).collect();
    let x = time.iter().map(|t| (-1.7 * t).exp()).collect();
    let data = MeasurementTable { time, columns: vec![("x".into(), x)] };
    job_to_proto(&spec.evaluating_points(points), std::slice::from_ref(&data), model_id)
}

async fn submit(c: &mut Client, spec: pb::JobSpec) -> Result<String, String> {
    c.submit_job(pb::SubmitJobRequest { spec: Some(spec) })
        .await
        .map(|r| r.into_inner().job_id)
        .map_err(|e| format!("{:?}: {}", e.code(), e.message()))
}

async fn get(c: &mut Client, job: &str) -> Option<pb::GetJobResponse> {
    c.get_job(pb::GetJobRequest { job_id: job.into() }).await.ok().map(tonic::Response::into_inner)
}

/// The job once it is no longer running, within `limit`.
async fn wait_end(c: &mut Client, job: &str, limit: Duration) -> Option<pb::GetJobResponse> {
    super::wait_end(c, job, limit).await
}

fn status_name(status: i32) -> String {
    pb::JobStatus::try_from(status).map_or_else(|_| status.to_string(), |s| s.as_str_name().to_owned())
}

/// Reports a job that must have ended with `status` and a reason naming `field`: its error,
/// else (a cancelled job) its result's termination.
fn ended(case: &str, r: Option<&pb::GetJobResponse>, status: i32, field: &str) {
    let why = |r: &pb::GetJobResponse| {
        if r.error.is_empty() {
            r.result.as_ref().map(|res| res.termination.clone()).unwrap_or_default()
        } else {
            r.error.clone()
        }
    };
    match r {
        None => report(case, false, "the job is gone, or still running"),
        Some(r) if r.status != status => {
            report(case, false, &format!("{} (not {}): {}", status_name(r.status), status_name(status), why(r)))
        }
        Some(r) if !why(r).contains(field) => report(case, false, &format!("does not name '{field}': {}", why(r))),
        Some(r) => report(case, true, &format!("{}: {}", status_name(r.status), why(r))),
    }
}

fn tail(log: &Path) -> String {
    let text = std::fs::read_to_string(log).unwrap_or_default();
    text.lines().rev().find(|l| !l.trim().is_empty()).unwrap_or("").to_owned()
}

/// Writes zeros into `path` until the disk is full (ENOSPC): the bytes written.
fn fill(path: &Path) -> Result<u64, String> {
    use std::io::Write;
    let mut f = std::fs::File::create(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let block = vec![0u8; 1 << 20];
    let mut written = 0u64;
    loop {
        match f.write(&block) {
            Ok(0) => return Err("a write of 0 bytes".into()),
            Ok(n) => written += n as u64,
            Err(e) if e.raw_os_error() == Some(28) => break,
            Err(e) => return Err(format!("{}: {e}", path.display())),
        }
    }
    // The last partial page too.
    while f.write(&[0u8; 512]).is_ok_and(|n| n > 0) {}
    Ok(written)
}

/// The `.upload-*` files left in a data dir's model store.
fn uploads_left(data_dir: &Path) -> Vec<String> {
    std::fs::read_dir(data_dir.join("models"))
        .map(|d| {
            d.flatten()
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .filter(|n| n.starts_with(".upload-"))
                .collect()
        })
        .unwrap_or_default()
}

/// A data dir on a disk that fills up (once, after the first ENOSPC every write was
/// refused until a restart, jobs were still reported SUCCEEDED, and came back RUNNING after a
/// restart). `disk` is a small tmpfs of this process's own mount namespace. With the disk
/// full: an upload is refused naming the cause and leaves no file; a job whose evaluations
/// cannot be logged fails, saying why. Once the disk has room: a new job runs, without a
/// restart. After a restart the failed job is still FAILED.
pub async fn full_disk(disk: &Path) {
    let data_dir = disk.join("coord");
    let case = "full disk: coordinator";
    let Some((mut coord, url, mut c, model)) = serving_with_model(case, disk, &[], "decay").await else {
        return;
    };
    // A points job whose log (each point's 20,001 residuals) needs new pages of the store;
    // submitted while the disk has room, evaluated once it is full (no worker until then).
    let points: Vec<Vec<f64>> = (0..16).map(|i| vec![1.0 + 0.1 * f64::from(i), 5.0]).collect();
    let job = match submit(&mut c, hang_points(&model, points.clone(), 1e-4)).await {
        Ok(j) => j,
        Err(e) => return report("full disk: a job fails visibly", false, &format!("refused with room: {e}")),
    };
    let filler = disk.join("filler");
    let filled = match fill(&filler) {
        Ok(n) => n,
        Err(e) => return report("full disk: a job fails visibly", false, &format!("cannot fill the disk: {e}")),
    };
    let decay = std::fs::read(fmucal_models::example("decay").expect("decay")).unwrap_or_default();
    let garbage = (0..4).map(|_| pb::UploadModelRequest { chunk: decay.clone() }).collect::<Vec<_>>();
    let refused = c.upload_model(tokio_stream::iter(garbage)).await;
    let left = uploads_left(&data_dir);
    match refused {
        Ok(r) => report("full disk: an upload", false, &format!("accepted: {:?}", r.into_inner())),
        Err(e) if !left.is_empty() => report("full disk: an upload", false, &format!("left {left:?}: {}", e.message())),
        Err(e) if !e.message().contains("No space left") => {
            report("full disk: an upload", false, &format!("does not name 'No space left': {e}"))
        }
        Err(e) => report("full disk: an upload", true, &format!("{:?}: {} (no file left)", e.code(), e.message())),
    }
    let w = disk.join("worker.log");
    let mut work = worker(&url, &["--slots", "2"], &w);
    // A job whose last state cannot be saved may end SUCCEEDED (its result was told to its
    // watchers), then turns FAILED once the store reports the failed write: the status a
    // moment later is the one checked, and the first one is shown.
    let mut r = wait_end(&mut c, &job, Duration::from_secs(60)).await;
    let first = r.as_ref().map(|r| r.status);
    let ended_at = Instant::now();
    while r.as_ref().is_some_and(|r| r.status != FAILED) && ended_at.elapsed() < Duration::from_secs(5) {
        tokio::time::sleep(Duration::from_millis(50)).await;
        r = get(&mut c, &job).await;
    }
    let seen = match (first, r.as_ref().map(|r| r.status)) {
        (Some(s), Some(FAILED)) if s != FAILED => {
            format!(" (first {}, FAILED {} ms later)", status_name(s), ended_at.elapsed().as_millis())
        }
        _ => String::new(),
    };
    ended(
        &format!("full disk ({} MB filled): a job fails visibly{seen}", filled >> 20),
        r.as_ref(),
        FAILED,
        "No space left",
    );

    // Room again: a job is stored and runs (the store's writer reopens within a second; until
    // then a submission is refused).
    let _ = std::fs::remove_file(&filler);
    let start = Instant::now();
    let mut next = Err(String::new());
    while start.elapsed() < Duration::from_secs(30) {
        next = submit(&mut c, hang_points(&model, vec![vec![1.7, 5.0]], 0.01)).await;
        if next.is_ok() {
            break;
        }
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
    match next {
        Err(e) => report("full disk, then room: the store recovers", false, &format!("still refused after 30 s: {e}")),
        Ok(id) => match wait_end(&mut c, &id, Duration::from_secs(60)).await {
            Some(r) if r.status == SUCCEEDED => report(
                "full disk, then room: the store recovers",
                true,
                &format!("a new job succeeded {} ms after the room came back, no restart", start.elapsed().as_millis()),
            ),
            Some(r) => report(
                "full disk, then room: the store recovers",
                false,
                &format!("{}: {}", status_name(r.status), r.error),
            ),
            None => report("full disk, then room: the store recovers", false, "the new job did not end"),
        },
    }
    work.kill();
    drop(c);
    if coord.terminate(Duration::from_secs(20)).is_none() {
        report("full disk: restart", false, "the coordinator did not stop on SIGTERM within 20 s");
    }
    let restarted =
        serving_coordinator("full disk: after a restart", &data_dir, &[], &disk.join("restarted.log")).await;
    let Some((_coord, _, mut c)) = restarted else { return };
    ended(
        "full disk: after a restart the job is still failed",
        get(&mut c, &job).await.as_ref(),
        FAILED,
        "No space left",
    );
}

/// A model file removed while the coordinator is down (once, its finished jobs vanished
/// from the API without a log line). The finished job keeps its result and says its model is
/// gone; the job that was running fails naming the model id.
pub async fn model_gone(dir: &Path) {
    let data_dir = dir.join("coord");
    let case = "model gone at restart";
    let Some((mut coord, url, mut c, model)) = serving_with_model(case, dir, &[], "decay").await else {
        return;
    };
    let mut work = worker(&url, &[], &dir.join("worker.log"));
    let done = match submit(&mut c, super::decay_job(&model, "[optimizer]\nmax_iters = 5\n")).await {
        Ok(j) => j,
        Err(e) => return report(case, false, &format!("refused: {e}")),
    };
    let before = wait_end(&mut c, &done, Duration::from_secs(60)).await;
    if before.as_ref().is_none_or(|r| r.status != SUCCEEDED) {
        return report(case, false, &format!("the first job did not succeed: {before:?}"));
    }
    work.kill();
    // No worker left: this one is still running when the coordinator stops.
    let running = match submit(&mut c, super::decay_job(&model, "")).await {
        Ok(j) => j,
        Err(e) => return report(case, false, &format!("refused: {e}")),
    };
    drop(c);
    if coord.terminate(Duration::from_secs(20)).is_none() {
        report(case, false, "the coordinator did not stop on SIGTERM within 20 s");
    }
    let _ = std::fs::remove_file(data_dir.join("models").join(format!("{model}.fmu")));
    let _ = std::fs::remove_dir_all(data_dir.join("unpacked"));
    let Some((_coord, _, mut c)) = serving_coordinator(case, &data_dir, &[], &dir.join("restarted.log")).await else {
        return;
    };
    let after = get(&mut c, &done).await;
    let kept = after.as_ref().is_some_and(|a| before.as_ref().is_some_and(|b| a.result == b.result));
    if kept {
        ended("model gone at restart: the finished job", after.as_ref(), SUCCEEDED, "no longer stored");
    } else {
        report("model gone at restart: the finished job", false, &format!("its result changed or is gone: {after:?}"));
    }
    ended("model gone at restart: the running job", get(&mut c, &running).await.as_ref(), FAILED, "model_id");
}

/// A model that never returns (once, the stuck slot never freed, other jobs blocked,
/// SIGTERM was ignored; later a hung FMU in one job slowed a normal job on the same worker
/// from 0.03 s to 14.2 s). With one slot and a 2 s deadline, the hung point fails naming the
/// deadline and the worker (restarted in place) runs the next job; with two slots and a 60 s
/// deadline, another job's points end while the hung one is within its deadline (its time is
/// shown); SIGTERM stops a worker whose model hangs within its grace.
pub async fn hung_model(dir: &Path) {
    // The coordinator would re-send a point only after 10 minutes.
    let case = "hung model";
    let Some((_coord, url, mut c, model)) =
        serving_with_model(case, dir, &["--evaluation-timeout", "600"], "decay").await
    else {
        return;
    };

    // One slot, a 2 s deadline: the middle point hangs.
    let log = dir.join("worker-1.log");
    let mut one = worker(&url, &["--slots", "1", "--evaluation-deadline", "2", "--stop-grace", "1"], &log);
    let start = Instant::now();
    let job = submit(&mut c, hang_points(&model, vec![vec![1.7, 5.0], vec![1.7, 1.0], vec![1.0, 5.0]], 0.01)).await;
    let r = match job {
        Ok(j) => wait_end(&mut c, &j, Duration::from_secs(60)).await,
        Err(e) => return report("hung model (1 slot, deadline 2 s)", false, &format!("refused: {e}")),
    };
    let evaluated = r.as_ref().and_then(|r| r.result.clone()).map(|res| res.evaluated).unwrap_or_default();
    let oks: Vec<bool> = evaluated.iter().map(|p| p.ok).collect();
    match (&r, evaluated.get(1)) {
        (Some(r), Some(hung)) if r.status == SUCCEEDED && oks == [true, false, true] => {
            let field = "evaluation deadline";
            report(
                "hung model (1 slot, deadline 2 s): its point fails",
                hung.message.contains(field),
                &format!("in {} ms: {}", start.elapsed().as_millis(), hung.message),
            );
        }
        _ => report(
            "hung model (1 slot, deadline 2 s): its point fails",
            false,
            &format!("{oks:?}: {r:?}").chars().take(300).collect::<String>(),
        ),
    }
    let start = Instant::now();
    let next = match submit(&mut c, hang_points(&model, vec![vec![1.2, 5.0], vec![1.7, 5.0]], 0.01)).await {
        Ok(j) => wait_end(&mut c, &j, Duration::from_secs(60)).await,
        Err(e) => return report("hung model: the worker runs the next job", false, &format!("refused: {e}")),
    };
    let restarted = std::fs::read_to_string(&log).unwrap_or_default().contains("restarting the worker");
    let alive = matches!(one.0.try_wait(), Ok(None));
    report(
        "hung model: the worker runs the next job",
        next.as_ref().is_some_and(|r| r.status == SUCCEEDED) && alive,
        &format!(
            "{} in {} ms; worker {} (restarted in place: {restarted})",
            next.map_or_else(|| "still running".into(), |r| status_name(r.status)),
            start.elapsed().as_millis(),
            if alive { "alive" } else { "exited" },
        ),
    );
    one.kill();

    // Two slots, a 60 s deadline: the hung point and another job's seven, both queued before
    // the worker comes, so its first poll takes the hung point and some of the others with it.
    let hung = submit(&mut c, hang_points(&model, vec![vec![1.7, 1.0]], 0.01)).await;
    let quick: Vec<Vec<f64>> = (0..7).map(|i| vec![1.0 + 0.1 * f64::from(i), 5.0]).collect();
    let quick = submit(&mut c, hang_points(&model, quick, 0.01)).await;
    let (Ok(hung), Ok(quick)) = (hung, quick) else {
        return report("hung slot: another job's points", false, "a job was refused");
    };
    let start = Instant::now();
    let mut two =
        worker(&url, &["--slots", "2", "--evaluation-deadline", "60", "--stop-grace", "2"], &dir.join("worker-2.log"));
    let r = wait_end(&mut c, &quick, Duration::from_secs(55)).await;
    let took = start.elapsed();
    let still = get(&mut c, &hung).await.map(|h| h.status);
    match r {
        Some(r) if r.status == SUCCEEDED && still == Some(RUNNING) => report(
            "hung slot: another job ends within the deadline",
            true,
            &format!("its 7 points in {} ms (the hung point still running, deadline 60 s)", took.as_millis()),
        ),
        Some(r) => report(
            "hung slot: another job ends within the deadline",
            false,
            &format!(
                "{} after {} ms, the hung job {:?}: {}",
                status_name(r.status),
                took.as_millis(),
                still.map(status_name),
                r.error
            ),
        ),
        None => report("hung slot: another job ends within the deadline", false, "still running after 55 s"),
    }
    // SIGTERM while the model hangs, far from its deadline: the worker leaves within its
    // grace (2 s), handing the point back.
    match two.terminate(Duration::from_secs(20)) {
        Some(t) => report(
            "hung model: SIGTERM stops the worker",
            true,
            &format!("exited {} ms after SIGTERM (--stop-grace 2)", t.as_millis()),
        ),
        None => report("hung model: SIGTERM stops the worker", false, "still running 20 s after SIGTERM"),
    }
    let _ = c.cancel_job(pb::CancelJobRequest { job_id: hung }).await;
}

/// The fmucal processes whose command line mentions `needle`.
fn processes_mentioning(needle: &str) -> Vec<u32> {
    let fmucal = std::fs::canonicalize(env("FMUCAL")).unwrap_or_default();
    std::fs::read_dir("/proc")
        .map(|d| {
            d.flatten()
                .filter_map(|e| e.file_name().to_string_lossy().parse::<u32>().ok())
                .filter(|pid| std::fs::read_link(format!("/proc/{pid}/exe")).is_ok_and(|exe| exe == fmucal))
                .filter(|pid| {
                    let cmdline = std::fs::read(format!("/proc/{pid}/cmdline")).unwrap_or_default();
                    String::from_utf8_lossy(&cmdline).contains(needle)
                })
                .collect()
        })
        .unwrap_or_default()
}

/// A SIGKILL of the coordinator during a Diagnose call (once, after a restart the
/// diagnosis's calibration job stayed RUNNING forever). The diagnosis process ends with its
/// coordinator; the next coordinator cancels the job, saying why.
pub async fn killed_diagnosis(dir: &Path) {
    let case = "SIGKILL of the coordinator during Diagnose";
    let data_dir: PathBuf = dir.join("coord");
    let Some((mut coord, _, mut c, model)) = serving_with_model(case, dir, &[], "furuta").await else {
        return;
    };
    let example = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/diagnose");
    let (mut spec, data) = match (
        JobSpec::from_toml_file(&example.join("job.toml")),
        MeasurementTable::read(&example.join("data.csv"), "time"),
    ) {
        (Ok(s), Ok(d)) => (s, d),
        _ => return report(case, false, "cannot read examples/diagnose"),
    };
    let Some(Ok(settings)) = spec.diagnose.take().map(|t| fmucal_diagnose::spec::DiagnoseSpec::from_table(Some(&t)))
    else {
        return report(case, false, "no [diagnose] in the example");
    };
    let req = pb::DiagnoseRequest {
        spec: Some(job_to_proto(&spec, std::slice::from_ref(&data), &model)),
        settings: Some(fmucal_proto::diagnose::diagnose_to_proto(&settings)),
    };
    // No worker: the diagnosis's first job waits in the queue.
    let stream = match c.diagnose(req).await {
        Ok(s) => s.into_inner(),
        Err(e) => return report(case, false, &format!("Diagnose refused: {}", e.message())),
    };
    let end = Instant::now() + Duration::from_secs(60);
    let job = loop {
        let jobs = c.list_jobs(pb::ListJobsRequest {}).await.map(|r| r.into_inner().jobs).unwrap_or_default();
        if let Some(j) = jobs.into_iter().find(|j| j.status == RUNNING) {
            break j.job_id;
        }
        if Instant::now() > end {
            return report(case, false, "the diagnosis submitted no job within 60 s");
        }
        tokio::time::sleep(Duration::from_millis(100)).await;
    };
    coord.kill();
    drop((stream, c));
    // The diagnosis process ends once its coordinator is gone; the next coordinator starts
    // after it, so the job is not cancelled by the diagnosis itself.
    let needle = data_dir.to_string_lossy().into_owned();
    let start = Instant::now();
    while !processes_mentioning(&needle).is_empty() {
        if start.elapsed() > Duration::from_secs(60) {
            return report(
                case,
                false,
                &format!("the diagnosis process outlived its coordinator: {:?}", processes_mentioning(&needle)),
            );
        }
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
    let gone = start.elapsed();
    let (_coord, url) = coordinator(&data_dir, &[], &dir.join("restarted.log"));
    let Some(mut c) = serving(&url).await else {
        return report(case, false, &format!("did not serve after the restart: {}", tail(&dir.join("restarted.log"))));
    };
    let r = get(&mut c, &job).await;
    ended(&format!("{case}: restart ends its job"), r.as_ref(), CANCELLED, "diagnosis");
    report(
        &format!("{case}: its diagnosis process"),
        true,
        &format!("ended {} ms after the coordinator", gone.as_millis()),
    );
}
