//! The scheduler on tokio's paused clock, driven through its command channel with its domain
//! values: the test plays the workers (Register, Heartbeat, Poll with results it computes
//! itself), so no process, network, protobuf message or simulation is involved and each test
//! runs in milliseconds. (A job is submitted as it is sent, through the service edge; the
//! scheduler keeps it as those bytes.) Covered: worker
//! expiry (a dead worker's points come back one at a time), the evaluation timeout, the "failed on 2 workers or 3 tries" rule, fair-share polls,
//! cancel, and resuming a job from the store after the scheduler died mid-batch.

use std::collections::{BTreeMap, HashSet};
use std::path::Path;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use fmucal_coordinator::CoordinatorError;
use fmucal_coordinator::edge;
use fmucal_coordinator::metrics::CoordinatorMetrics;
use fmucal_coordinator::models::{DEFAULT_MAX_STORE_BYTES, ModelStore};
use fmucal_coordinator::scheduler::{
    Command, JobView, Lease, Outcome, PollAnswer, PollRequest, Registration, Report, Scheduler, Timing,
};
use fmucal_coordinator::store::Store;
use fmucal_proto::convert::job_to_proto;
use fmucal_proto::v1 as pb;
use fmucal_shared::job::{CalibrationResult, EvaluatedPoint, Evaluation, JobSpec, JobStatus, MeasurementTable};
use tokio::sync::{mpsc, oneshot};

const HEARTBEAT: Duration = Duration::from_secs(1);
const EXPIRY: Duration = Duration::from_secs(5);
const TIMEOUT: Duration = Duration::from_secs(30);

/// The residuals of an evaluation of [`job`]: its 21 measured values.
const RESIDUALS: usize = 21;

const RUNNING: JobStatus = JobStatus::Running;
const SUCCEEDED: JobStatus = JobStatus::Succeeded;
const CANCELLED: JobStatus = JobStatus::Cancelled;

/// The workers' objective: a function of x alone, so no test simulates.
fn objective(x: &[f64]) -> f64 {
    x.iter().map(|v| (v - 1.7).powi(2)).sum()
}

/// A worker's report on `a` with `outcome`.
fn report(a: &Lease, outcome: Outcome) -> Report {
    Report { job_id: a.job_id.clone(), point_id: a.point_id, outcome }
}

fn ok(a: &Lease) -> Report {
    let residuals = if a.want_residuals { (0..RESIDUALS).map(|i| a.x[0] + i as f64).collect() } else { vec![] };
    let evaluation =
        Evaluation { value: Some(objective(&a.x)), residuals: Some(residuals), error: None, wall: Duration::ZERO };
    report(a, Outcome::Evaluated(evaluation))
}

fn failed(a: &Lease) -> Report {
    report(a, Outcome::Evaluated(Evaluation::failed("test failure")))
}

/// `r` with its evaluation changed by `change` (a worker that reports something else).
fn changed(mut r: Report, change: impl FnOnce(&mut Evaluation)) -> Report {
    let Outcome::Evaluated(e) = &mut r.outcome else { panic!("not evaluated: {r:?}") };
    change(e);
    r
}

fn ids(leases: &[Lease]) -> Vec<u64> {
    leases.iter().map(|a| a.point_id).collect()
}

/// The distinct points among `leases`, by id, with the x they were handed out with.
fn by_id(leases: &[Lease]) -> BTreeMap<u64, Vec<f64>> {
    leases.iter().map(|a| (a.point_id, a.x.clone())).collect()
}

/// A job on the Decay example (one parameter, k) with the given `[optimizer]` table, as a
/// client sends it: the model is stored in `dir`'s model store, as an upload would.
fn job(dir: &Path, optimizer: &str) -> pb::JobSpec {
    let bytes = std::fs::read(fmucal_models::example("decay").expect("the decay example")).unwrap();
    let (model_id, _) = ModelStore::open(dir, DEFAULT_MAX_STORE_BYTES).unwrap().put(&bytes).unwrap();
    let toml = format!(
        "[model]\n[data]\n[[outputs]]\nvariable = \"x\"\ncolumn = \"x\"\n\
         [[parameters]]\nname = \"k\"\nstart = 1.0\nlower = 0.5\nupper = 3.0\n[optimizer]\n{optimizer}\n"
    );
    let spec = JobSpec::from_toml(&toml, dir).unwrap();
    let time: Vec<f64> = (0..=20).map(|i| f64::from(i) * 0.1).collect();
    let x = time.iter().map(|t| (-1.7 * t).exp()).collect();
    job_to_proto(&spec, &[MeasurementTable { time, columns: vec![("x".into(), x)] }], &model_id)
}

/// Differential evolution: batches of `population` points, `max_iters` generations after the
/// initial population.
fn de_job(dir: &Path, population: usize, max_iters: u64) -> pb::JobSpec {
    let stop = format!("max_iters = {max_iters}\nx_tol = 0.0\nf_tol = 0.0");
    job(dir, &format!("algorithm = \"differential-evolution\"\npopulation = {population}\nseed = 3\n{stop}"))
}

/// One batch of `n` given points (what identifiability analyses submit).
fn points_job(dir: &Path, n: usize) -> pb::JobSpec {
    let mut spec = job(dir, "");
    spec.kind = pb::JobKind::EvaluatePoints as i32;
    spec.points = (0..n).map(|i| pb::Point { x: vec![0.6 + 0.2 * i as f64] }).collect();
    spec
}

/// A scheduler task on a data directory.
struct Sched {
    tx: mpsc::Sender<Command>,
    task: tokio::task::JoinHandle<()>,
    models: Arc<Mutex<ModelStore>>,
}

impl Sched {
    /// Opens the store and models in `dir` (resuming what runs there) and starts the task.
    fn start(dir: &Path) -> Sched {
        Sched::start_with(dir, Store::open(dir).unwrap(), None)
    }

    /// [`Sched::start`] on `store`, keeping at most `keep` finished jobs.
    fn start_with(dir: &Path, store: Store, keep: Option<usize>) -> Sched {
        Sched::start_full(dir, store, keep, None)
    }

    /// A scheduler on `dir` whose metrics are registered in the returned registry.
    fn start_with_metrics(dir: &Path) -> (Sched, prometheus_client::registry::Registry) {
        let mut registry = prometheus_client::registry::Registry::default();
        let metrics = CoordinatorMetrics::register(&mut registry);
        (Sched::start_full(dir, Store::open(dir).unwrap(), None, Some(metrics)), registry)
    }

    /// [`Sched::start_with`], keeping `metrics` up to date.
    fn start_full(dir: &Path, store: Store, keep: Option<usize>, metrics: Option<CoordinatorMetrics>) -> Sched {
        let models = Arc::new(Mutex::new(ModelStore::open(dir, DEFAULT_MAX_STORE_BYTES).unwrap()));
        let timing = Timing { heartbeat_interval: HEARTBEAT, worker_expiry: EXPIRY, evaluation_timeout: TIMEOUT };
        let (tx, rx) = mpsc::channel(64);
        let scheduler =
            Scheduler::new(store, models.clone(), timing).unwrap().with_retention(keep).with_metrics(metrics);
        let task = tokio::spawn(scheduler.run(rx));
        Sched { tx, task, models }
    }

    /// Stops the task as a crash would: mid-loop, without the orderly shutdown, so told points
    /// not yet sent to the store writer are lost. (What the writer was sent is committed while
    /// the scheduler drops, as if it had reached the disk before the crash.)
    async fn kill(self) {
        self.task.abort();
        assert!(self.task.await.unwrap_err().is_cancelled());
    }

    async fn call<T>(&self, cmd: impl FnOnce(oneshot::Sender<T>) -> Command) -> T {
        let (reply, rx) = oneshot::channel();
        assert!(self.tx.send(cmd(reply)).await.is_ok(), "the scheduler stopped");
        rx.await.expect("the scheduler dropped a reply")
    }

    async fn register(&self, name: &str, slots: u32) -> String {
        let registration = Registration { name: name.into(), slots };
        self.call(|reply| Command::Register { registration, reply }).await.unwrap().worker_id
    }

    async fn heartbeat(&self, worker_id: &str) -> bool {
        self.call(|reply| Command::Heartbeat { worker_id: worker_id.into(), reply }).await.unwrap()
    }

    /// Returns `results` and asks for up to `max` points, without waiting.
    async fn poll(&self, worker_id: &str, reports: Vec<Report>, max: u32) -> PollAnswer {
        let req = PollRequest { worker_id: worker_id.into(), reports, max: max as usize, wait: Duration::ZERO };
        let resp = self.call(|reply| Command::Poll { req, reply }).await;
        assert!(resp.leases.len() <= max as usize, "more points than asked for: {resp:?}");
        resp
    }

    /// The points a poll for up to `max` hands to a known worker.
    async fn take(&self, worker_id: &str, max: u32) -> Vec<Lease> {
        let resp = self.poll(worker_id, vec![], max).await;
        assert!(resp.known, "{worker_id} is not known");
        resp.leases
    }

    /// Returns results without asking for more.
    async fn answer(&self, worker_id: &str, reports: Vec<Report>) {
        assert!(self.poll(worker_id, reports, 0).await.known);
    }

    async fn submit(&self, spec: pb::JobSpec) -> String {
        // As the SubmitJob handler does: checked and built off the scheduler task.
        let job = Box::new(edge::submission(&self.models, &spec).unwrap());
        self.call(|reply| Command::Submit { job, reply }).await.unwrap()
    }

    async fn get(&self, job_id: &str) -> JobView {
        self.call(|reply| Command::Get { job_id: job_id.into(), reply }).await.unwrap()
    }

    async fn delete(&self, job_id: &str) -> Result<(), CoordinatorError> {
        self.call(|reply| Command::Delete { job_id: job_id.into(), reply }).await
    }

    async fn listed(&self) -> Vec<String> {
        self.call(|reply| Command::List { reply }).await.unwrap().into_iter().map(|j| j.job_id).collect()
    }

    async fn cancel(&self, job_id: &str) -> Result<JobStatus, CoordinatorError> {
        self.call(|reply| Command::Cancel { job_id: job_id.into(), reply }).await
    }

    /// Lets `d` pass on the paused clock in heartbeat-long steps; the `alive` workers heartbeat
    /// after each step. Each step ends with a round trip, so the ticks it made due have run.
    async fn pass(&self, d: Duration, alive: &[&str]) {
        let mut left = d;
        while !left.is_zero() {
            let step = left.min(HEARTBEAT);
            tokio::time::advance(step).await;
            left -= step;
            for w in alive {
                assert!(self.heartbeat(w).await, "{w} expired");
            }
            self.call(|reply| Command::List { reply }).await.unwrap();
        }
    }

    /// The `workers` in turn return what they hold, answered by `answer(worker, point)`, and
    /// ask for up to 4 more, until the job ends. Returns its final state and every hand-out
    /// as (worker, assignment), in order.
    async fn drive(
        &self,
        job_id: &str,
        workers: &[&str],
        mut answer: impl FnMut(&str, &Lease) -> Report,
    ) -> (JobView, Vec<(String, Lease)>) {
        let mut held: Vec<Vec<Lease>> = vec![vec![]; workers.len()];
        let mut handed = vec![];
        for _ in 0..10_000 {
            let r = self.get(job_id).await;
            if r.status != RUNNING {
                return (r, handed);
            }
            for (w, held) in workers.iter().zip(held.iter_mut()) {
                let results = held.drain(..).map(|a| answer(w, &a)).collect();
                let resp = self.poll(w, results, 4).await;
                assert!(resp.known, "{w} is not known");
                handed.extend(resp.leases.iter().map(|a| (w.to_string(), a.clone())));
                *held = resp.leases;
            }
        }
        panic!("job {job_id} did not end");
    }
}

/// The result of a finished job, without its wall time.
fn result(r: &JobView) -> CalibrationResult {
    let mut res = r.result.clone().unwrap_or_else(|| panic!("no result: {r:?}"));
    res.elapsed_s = 0.0;
    res
}

/// The result of a finished job as a client reads it (GetJob, through the service edge),
/// without its wall time.
fn client_result(r: &JobView) -> pb::JobResult {
    let mut res = edge::get_job_response(r.clone()).result.unwrap_or_else(|| panic!("no result: {r:?}"));
    res.elapsed_s = 0.0;
    res
}

/// The values of a points job's result, in order (NaN for a failed point).
fn values(res: &CalibrationResult) -> Vec<f64> {
    res.evaluated.iter().map(|e| e.value.unwrap_or(f64::NAN)).collect()
}

#[tokio::test(start_paused = true)]
async fn a_silent_worker_expires_and_its_points_go_to_another() {
    let dir = tempfile::tempdir().unwrap();
    let s = Sched::start(dir.path());
    let (a, b) = (s.register("a", 1).await, s.register("b", 1).await);
    let job = s.submit(de_job(dir.path(), 4, 2)).await;
    let held_by_a = s.take(&a, 2).await;
    assert_eq!(held_by_a.len(), 2);
    let first = s.take(&b, 1).await;

    // Within the expiry a's points stay a's: b, answering and asking, gets only the last one.
    s.pass(EXPIRY - HEARTBEAT, &[&b]).await;
    let resp = s.poll(&b, first.iter().map(ok).collect(), 4).await;
    assert_eq!(resp.leases.len(), 1, "{resp:?}");
    assert!(!ids(&held_by_a).contains(&resp.leases[0].point_id));
    s.answer(&b, resp.leases.iter().map(ok).collect()).await;
    assert!(s.take(&b, 4).await.is_empty(), "a's points were re-sent before a expired");

    // Past the expiry a is dropped and b gets a's points: one at a time, since a died holding
    // both and either may have killed it.
    s.pass(2 * HEARTBEAT, &[&b]).await;
    let first = s.take(&b, 4).await;
    assert_eq!(first.len(), 1, "{first:?}");
    let late = s.poll(&a, held_by_a.iter().map(ok).collect(), 4).await;
    assert!(!late.known && late.leases.is_empty(), "{late:?}");
    assert!(!s.heartbeat(&a).await);
    assert!(s.take(&b, 4).await.is_empty(), "a suspect point was leased beside another");
    let resp = s.poll(&b, first.iter().map(ok).collect(), 4).await;
    assert_eq!(resp.leases.len(), 1, "{resp:?}");
    let resent: Vec<_> = first.into_iter().chain(resp.leases).collect();
    assert_eq!(by_id(&resent), by_id(&held_by_a));

    s.answer(&b, resent[1..].iter().map(ok).collect()).await;
    let (r, _) = s.drive(&job, &[&b], |_, p| ok(p)).await;
    assert_eq!(r.status, SUCCEEDED, "{r:?}");
    let res = result(&r);
    assert_eq!((res.evaluations, res.failed_evaluations), (12, 0), "{res:?}");
}

#[tokio::test(start_paused = true)]
async fn a_point_past_the_evaluation_timeout_is_sent_to_another_worker() {
    let dir = tempfile::tempdir().unwrap();
    let s = Sched::start(dir.path());
    let (a, b) = (s.register("a", 1).await, s.register("b", 1).await);
    let job = s.submit(points_job(dir.path(), 2)).await;
    let slow = s.take(&a, 1).await;
    let quick = s.take(&b, 1).await;
    assert_eq!((slow.len(), quick.len()), (1, 1));
    s.answer(&b, quick.iter().map(ok).collect()).await;

    // Both workers stay alive; a holds its point until just before the timeout...
    s.pass(TIMEOUT - HEARTBEAT, &[&a, &b]).await;
    assert!(s.take(&b, 4).await.is_empty(), "re-sent before the timeout");
    // ...and past it the point is b's (and not a's again).
    s.pass(2 * HEARTBEAT, &[&a, &b]).await;
    assert!(s.take(&a, 4).await.is_empty(), "the late point went back to its slow worker");
    let resent = s.take(&b, 4).await;
    assert_eq!(ids(&resent), ids(&slow));
    assert_eq!(resent[0].x, slow[0].x);

    // b answers; a's late answer (a different value) changes nothing.
    s.answer(&b, resent.iter().map(ok).collect()).await;
    let late = changed(ok(&slow[0]), |e| e.value = Some(99.0));
    s.answer(&a, vec![late]).await;
    let r = s.get(&job).await;
    assert_eq!(r.status, SUCCEEDED, "{r:?}");
    let res = result(&r);
    assert_eq!((res.evaluations, res.failed_evaluations), (2, 0));
    assert_eq!(values(&res), vec![objective(&slow[0].x), objective(&quick[0].x)]);
}

#[tokio::test(start_paused = true)]
async fn a_late_failure_does_not_requeue_a_point_held_by_another_worker() {
    let dir = tempfile::tempdir().unwrap();
    let s = Sched::start(dir.path());
    let (a, b, c) = (s.register("a", 1).await, s.register("b", 1).await, s.register("c", 1).await);
    s.submit(points_job(dir.path(), 1)).await;
    let slow = s.take(&a, 1).await;
    s.pass(TIMEOUT + HEARTBEAT, &[&a, &b, &c]).await;
    assert_eq!(ids(&s.take(&b, 1).await), ids(&slow));
    // a gives up on the point it no longer holds: b still has it, so c must not get it.
    s.answer(&a, slow.iter().map(failed).collect()).await;
    let dup = s.take(&c, 1).await;
    assert!(dup.is_empty(), "handed out while b holds it: {dup:?}");
}

/// The point [`first_point_failing`] fails: the initial population's second member (the first
/// is the start point, whose failure fails the job).
const FAILING_POINT: u64 = 1;

/// Drives a differential-evolution job to its end on `workers` (1 slot each); `fails(attempt)`
/// says whether the `attempt`-th hand-out (from 1) of [`FAILING_POINT`] fails. Returns the
/// result and the workers that point was handed to, in order.
async fn first_point_failing(workers: &[&str], fails: impl Fn(usize) -> bool) -> (CalibrationResult, Vec<String>) {
    let dir = tempfile::tempdir().unwrap();
    let s = Sched::start(dir.path());
    let mut ws = vec![];
    for w in workers {
        ws.push(s.register(w, 1).await);
    }
    let job = s.submit(de_job(dir.path(), 4, 2)).await;
    let mut attempts = 0;
    let wr: Vec<&str> = ws.iter().map(String::as_str).collect();
    let (r, handed) = s
        .drive(&job, &wr, |_, p| {
            if p.point_id != FAILING_POINT {
                return ok(p);
            }
            attempts += 1;
            if fails(attempts) { failed(p) } else { ok(p) }
        })
        .await;
    assert_eq!(r.status, SUCCEEDED, "{r:?}");
    let to = handed.into_iter().filter(|(_, p)| p.point_id == FAILING_POINT).map(|(w, _)| w).collect();
    (result(&r), to)
}

#[tokio::test(start_paused = true)]
async fn a_point_failing_on_two_workers_is_told_as_failed_and_the_job_goes_on() {
    let (res, to) = first_point_failing(&["a", "b"], |_| true).await;
    assert_eq!(to.len(), 2, "handed out {to:?}");
    assert_ne!(to[0], to[1], "retried on the worker it failed on");
    assert_eq!(res.failed_evaluations, 1, "{res:?}");
    // The job went on: the initial population and both generations were evaluated.
    assert_eq!((res.evaluations, res.rounds), (12, 3), "{res:?}");
}

#[tokio::test(start_paused = true)]
async fn a_point_failing_once_is_retried_elsewhere_not_told() {
    let (res, to) = first_point_failing(&["a", "b"], |n| n == 1).await;
    assert_eq!(to.len(), 2, "handed out {to:?}");
    assert_ne!(to[0], to[1]);
    assert_eq!(res.failed_evaluations, 0, "{res:?}");
    assert_eq!(res.evaluations, 12);
}

#[tokio::test(start_paused = true)]
async fn a_lone_worker_gets_a_failing_point_three_times() {
    let (res, to) = first_point_failing(&["a"], |_| true).await;
    assert_eq!(to.len(), 3, "handed out {to:?}");
    assert_eq!(res.failed_evaluations, 1, "{res:?}");
    assert_eq!(res.evaluations, 12);
    // Two failures are not enough to give up.
    let (res, to) = first_point_failing(&["a"], |n| n <= 2).await;
    assert_eq!(to.len(), 3, "handed out {to:?}");
    assert_eq!(res.failed_evaluations, 0, "{res:?}");
}

#[tokio::test(start_paused = true)]
async fn a_poll_gets_at_most_its_fair_share_of_the_queue() {
    let dir = tempfile::tempdir().unwrap();
    let s = Sched::start(dir.path());
    // 4 live slots.
    let (a, b, c) = (s.register("a", 1).await, s.register("b", 2).await, s.register("c", 1).await);
    let queued = 10;
    s.submit(points_job(dir.path(), queued)).await;
    let mut left = queued;
    let mut seen = HashSet::new();
    let mut sizes = vec![];
    // A poll counts as one for k = ⌈max / 4⌉ of its worker's slots (at most the slots it has)
    // and gets ⌈queued × k / 4⌉.
    for (w, own, max) in
        [(&a, 1, 8), (&b, 2, 8), (&c, 1, 1), (&a, 1, 8), (&b, 2, 8), (&c, 1, 8), (&a, 1, 8), (&b, 2, 8)]
    {
        let got = s.take(w, max).await;
        let k = own.min((max as usize).div_ceil(4));
        let share = (max as usize).min((left * k).div_ceil(4)).min(left);
        assert_eq!(got.len(), share, "{left} queued, {max} asked by a worker of {own} slots: {got:?}");
        assert!(got.iter().all(|p| seen.insert(p.point_id)), "a point handed out twice: {got:?}");
        left -= got.len();
        sizes.push(got.len());
    }
    assert_eq!(sizes, vec![3, 4, 1, 1, 1, 0, 0, 0]);
    assert_eq!(seen.len(), queued);
}

/// A cancelled job's state: CANCELLED, with a result of `evaluations` points and the best x.
fn assert_cancelled(r: &JobView, evaluations: u64, x_opt: &[f64]) {
    assert_eq!(r.status, CANCELLED, "{r:?}");
    let res = result(r);
    assert_eq!((res.termination.as_str(), res.evaluations), ("cancelled", evaluations), "{res:?}");
    let x: Vec<f64> = r.names.iter().map(|n| res.x_opt.get(n).copied().unwrap_or(f64::NAN)).collect();
    assert_eq!(x, x_opt);
}

#[tokio::test(start_paused = true)]
async fn a_cancelled_job_ends_hands_out_nothing_more_and_keeps_its_result() {
    let dir = tempfile::tempdir().unwrap();
    let s = Sched::start(dir.path());
    let a = s.register("a", 1).await;
    let job = s.submit(de_job(dir.path(), 4, 50)).await;
    let batch1 = s.take(&a, 4).await;
    let held = s.poll(&a, batch1.iter().map(ok).collect(), 2).await.leases;
    assert_eq!((batch1.len(), held.len()), (4, 2));
    let best = batch1.iter().map(|p| p.x.clone()).min_by(|x, y| objective(x).total_cmp(&objective(y))).unwrap();

    assert_eq!(s.cancel(&job).await.unwrap(), CANCELLED);
    assert_cancelled(&s.get(&job).await, 4, &best);
    // The points in hand are answered in vain; nothing more comes from the job.
    let resp = s.poll(&a, held.iter().map(ok).collect(), 4).await;
    assert!(resp.known && resp.leases.is_empty(), "{resp:?}");
    assert_cancelled(&s.get(&job).await, 4, &best);
    // Another job's points are all that polls get.
    let other = s.submit(points_job(dir.path(), 2)).await;
    let got = s.take(&a, 4).await;
    assert_eq!(got.len(), 2);
    assert!(got.iter().all(|p| p.job_id == other), "{got:?}");
    // Cancelling again changes nothing; a finished job is not cancelled; an unknown one is not found.
    assert_eq!(s.cancel(&job).await.unwrap(), CANCELLED);
    s.answer(&a, got.iter().map(ok).collect()).await;
    assert_eq!(s.cancel(&other).await.unwrap(), SUCCEEDED);
    assert!(matches!(s.cancel("job-999999").await, Err(CoordinatorError::NotFound(_))));

    // The cancellation survives a restart.
    s.kill().await;
    let s = Sched::start(dir.path());
    assert_cancelled(&s.get(&job).await, 4, &best);
    let a = s.register("a", 1).await;
    assert!(s.take(&a, 4).await.is_empty());
}

#[tokio::test(start_paused = true)]
async fn a_job_cancelled_before_its_first_batch_survives_a_restart() {
    let dir = tempfile::tempdir().unwrap();
    let s = Sched::start(dir.path());
    let job = s.submit(de_job(dir.path(), 4, 50)).await;
    assert_eq!(s.cancel(&job).await.unwrap(), CANCELLED);
    assert_cancelled(&s.get(&job).await, 0, &[1.0]);
    s.kill().await;
    let s = Sched::start(dir.path());
    assert_cancelled(&s.get(&job).await, 0, &[1.0]);
}

/// How the told points are stored when the scheduler dies.
#[derive(Clone, Copy, PartialEq)]
enum Logged {
    /// As this version writes them: the binary journal.
    Journal,
    /// As coordinators before the journal wrote them: one JSON evaluation per point.
    FormerJson,
    /// The journal, with the x of its lowest point changed: that point is not told from the
    /// journal but evaluated again.
    JournalOtherX,
}

/// The former log's table: (job, point) → the point's `Evaluation` as JSON.
const FORMER_LOG: redb::TableDefinition<(&str, u64), &str> = redb::TableDefinition::new("evaluations");
const JOURNAL: redb::TableDefinition<(&str, u64), &[u8]> = redb::TableDefinition::new("journal");

/// Rewrites what the journal of `dir`'s store holds as `how` says (the scheduler is stopped);
/// returns the points it held.
fn rewrite_log(dir: &Path, how: Logged) -> Vec<u64> {
    let store = Store::open(dir).unwrap();
    let logged: Vec<(String, Vec<fmucal_coordinator::journal::Logged>)> =
        store.job_ids().unwrap().into_iter().map(|id| (id.clone(), store.evaluations(&id).unwrap())).collect();
    drop(store);
    let points = logged.iter().flat_map(|(_, l)| l.iter().map(|l| l.point)).collect();
    let db = redb::Database::create(dir.join("jobs.redb")).unwrap();
    let tx = db.begin_write().unwrap();
    match how {
        Logged::Journal => {}
        Logged::FormerJson => {
            // A store of the former version has no journal table at all.
            assert!(tx.delete_table(JOURNAL).unwrap());
            let mut former = tx.open_table(FORMER_LOG).unwrap();
            for (id, entries) in &logged {
                for l in entries {
                    let json = serde_json::to_string(&l.evaluation).unwrap();
                    former.insert((id.as_str(), l.point), json.as_str()).unwrap();
                }
            }
        }
        Logged::JournalOtherX => {
            let mut journal = tx.open_table(JOURNAL).unwrap();
            journal.retain(|_, _| false).unwrap();
            for (id, entries) in &logged {
                let mut xs: Vec<Vec<f64>> = entries.iter().map(|l| l.x.clone().unwrap()).collect();
                let lowest = (0..entries.len()).min_by_key(|&i| entries[i].point).unwrap();
                xs[lowest][0] += 0.125;
                let block = fmucal_coordinator::journal::encode(
                    entries.iter().zip(&xs).map(|(l, x)| (l.point, x.as_slice(), &l.evaluation)),
                );
                journal.insert((id.as_str(), entries[0].point), block.as_slice()).unwrap();
            }
        }
    }
    tx.commit().unwrap();
    points
}

/// Runs a 6-point, 3-generation DE job on one worker, killing the scheduler in the second
/// batch after the worker answered `answered` of its points, and resuming on the same data
/// directory with a new worker, the told points stored as `logged` says. The job's point
/// `failing` fails on every attempt (3 before the kill, for the lone worker). Checks that
/// answered points are not handed out again (but the one whose logged x changed), and that the
/// result and every hand-out match an uninterrupted run's.
async fn resume_mid_batch(answered: usize, failing: Option<u64>, logged: Logged) {
    const POP: u32 = 6;
    let answer = |p: &Lease| if Some(p.point_id) == failing { failed(p) } else { ok(p) };
    let spec = |dir: &Path| de_job(dir, POP as usize, 2);

    let reference = tempfile::tempdir().unwrap();
    let s = Sched::start(reference.path());
    let w = s.register("w", 1).await;
    let job = s.submit(spec(reference.path())).await;
    let (want, want_handed) = s.drive(&job, &[&w], |_, p| answer(p)).await;
    assert_eq!(want.status, SUCCEEDED);
    s.kill().await;
    let want_points = by_id(&want_handed.into_iter().map(|(_, p)| p).collect::<Vec<_>>());

    let dir = tempfile::tempdir().unwrap();
    let s = Sched::start(dir.path());
    let a = s.register("a", 1).await;
    let job = s.submit(spec(dir.path())).await;
    let batch1 = s.take(&a, POP).await;
    let resp = s.poll(&a, batch1.iter().map(answer).collect(), POP).await;
    let batch2 = resp.leases;
    assert_eq!((batch1.len(), batch2.len()), (POP as usize, POP as usize));
    let (done, open) = batch2.split_at(answered);
    assert!(failing.is_none_or(|f| ids(done).contains(&f)), "point {failing:?} is not among {done:?}");
    for p in done {
        // A failing point is re-sent to the lone worker until its third failure.
        let mut attempt = p.clone();
        for _ in 0..if Some(p.point_id) == failing { 3 } else { 1 } {
            let again = s.poll(&a, vec![answer(&attempt)], 1).await.leases;
            if let Some(p) = again.first() {
                assert_eq!(p.point_id, attempt.point_id, "{again:?}");
                attempt = p.clone();
            }
        }
    }
    // A tick sends the told points to the store; then the scheduler dies.
    s.pass(Duration::from_millis(100), &[&a]).await;
    assert_eq!(s.get(&job).await.status, RUNNING);
    s.kill().await;
    let mut told = rewrite_log(dir.path(), logged);
    told.sort_unstable();
    let mut answered_ids = ids(done);
    answered_ids.sort_unstable();
    assert_eq!(told, answered_ids, "the log holds the answered points of the open batch, and only those");
    // The point whose logged x changed is evaluated again, first (ids in order).
    let (again, expected): (&[Lease], Vec<Lease>) = match logged {
        Logged::JournalOtherX => (&done[..1], [&done[..1], open].concat()),
        _ => (&[], open.to_vec()),
    };

    let s = Sched::start(dir.path());
    let b = s.register("b", 1).await;
    let resent = s.take(&b, POP).await;
    assert_eq!(ids(&resent), ids(&expected), "after the restart, only the unanswered points of the batch");
    assert_eq!(by_id(&resent), by_id(&expected));
    s.answer(&b, resent.iter().map(answer).collect()).await;
    let (got, handed) = s.drive(&job, &[&b], |_, p| answer(p)).await;
    assert_eq!(got.status, SUCCEEDED, "{got:?}");
    assert_eq!(
        client_result(&got),
        client_result(&want),
        "the resumed job's result differs from an uninterrupted run's"
    );
    // The points open at the kill were handed out before it and again after it.
    let mut all: Vec<Lease> = [&batch1[..], done, &resent].concat();
    all.extend(handed.into_iter().map(|(_, p)| p));
    // Each point once; the one whose logged x changed twice (before the kill and after it).
    let mut times: BTreeMap<u64, usize> = BTreeMap::new();
    for p in all.iter().filter(|p| Some(p.point_id) != failing) {
        *times.entry(p.point_id).or_default() += 1;
    }
    let twice: Vec<u64> = times.iter().filter(|(_, n)| **n == 2).map(|(p, _)| *p).collect();
    assert!(times.values().all(|n| *n <= 2), "a point was handed out more than twice: {times:?}");
    assert_eq!(twice, ids(again), "points handed out twice");
    assert_eq!(by_id(&all), want_points, "other points than in an uninterrupted run");
}

#[tokio::test(start_paused = true)]
async fn a_resumed_job_skips_answered_points_and_ends_as_an_uninterrupted_one() {
    resume_mid_batch(3, None, Logged::Journal).await;
}

#[tokio::test(start_paused = true)]
async fn a_job_resumed_from_the_former_json_log_skips_its_answered_points_and_ends_the_same() {
    resume_mid_batch(3, None, Logged::FormerJson).await;
}

#[tokio::test(start_paused = true)]
async fn a_job_resumed_from_the_former_json_log_counts_its_failed_points() {
    resume_mid_batch(3, Some(6), Logged::FormerJson).await;
}

#[tokio::test(start_paused = true)]
async fn a_journal_entry_for_another_x_is_not_told_but_evaluated_again() {
    resume_mid_batch(3, None, Logged::JournalOtherX).await;
}

#[tokio::test(start_paused = true)]
async fn a_resumed_job_counts_the_failed_points_it_tells_from_the_log() {
    // Point 6 is the first of the second batch.
    resume_mid_batch(3, Some(6), Logged::Journal).await;
}

#[tokio::test(start_paused = true)]
async fn a_resumed_points_job_reports_every_point() {
    let dir = tempfile::tempdir().unwrap();
    let s = Sched::start(dir.path());
    let a = s.register("a", 1).await;
    let job = s.submit(points_job(dir.path(), 4)).await;
    let points = s.take(&a, 4).await;
    s.answer(&a, points[..2].iter().map(ok).collect()).await;
    s.pass(Duration::from_millis(100), &[&a]).await;
    s.kill().await;

    let s = Sched::start(dir.path());
    let b = s.register("b", 1).await;
    let (r, handed) = s.drive(&job, &[&b], |_, p| ok(p)).await;
    assert_eq!(ids(&handed.into_iter().map(|(_, p)| p).collect::<Vec<_>>()), ids(&points[2..]));
    let res = result(&r);
    let want: Vec<EvaluatedPoint> = points
        .iter()
        .map(|p| {
            let Outcome::Evaluated(e) = ok(p).outcome else { unreachable!() };
            let residuals = e.residuals.unwrap_or_default();
            EvaluatedPoint { x: p.x.clone(), value: e.value, residuals, message: String::new() }
        })
        .collect();
    assert_eq!(res.evaluated, want, "every point, in the order given");
}

#[tokio::test(start_paused = true)]
async fn a_job_whose_state_cannot_be_read_is_left_out_and_its_id_not_reused() {
    let dir = tempfile::tempdir().unwrap();
    let s = Sched::start(dir.path());
    let old = s.submit(de_job(dir.path(), 4, 2)).await;
    s.kill().await;
    // As a state written by another version of fmucal would be.
    {
        let store = Arc::new(Store::open(dir.path()).unwrap());
        let writer = fmucal_coordinator::store::Writer::spawn(store);
        writer.send(fmucal_coordinator::store::Write::State { id: old.clone(), json: "{\"status\":2}".into() });
    }
    let s = Sched::start(dir.path());
    let gone = s.call(|reply| Command::Get { job_id: old.clone(), reply }).await;
    assert!(matches!(gone, Err(CoordinatorError::NotFound(_))), "{gone:?}");
    let new = s.submit(de_job(dir.path(), 4, 2)).await;
    assert_ne!(new, old, "a new job took the id of one whose state could not be read");
    let listed = s.call(|reply| Command::List { reply }).await.unwrap();
    assert_eq!(listed.iter().map(|j| j.job_id.clone()).collect::<Vec<_>>(), vec![new]);
}

#[tokio::test(start_paused = true)]
async fn a_state_of_a_later_format_is_left_out_and_one_without_a_format_resumes() {
    let dir = tempfile::tempdir().unwrap();
    let s = Sched::start(dir.path());
    let (later, earlier) = (s.submit(de_job(dir.path(), 4, 2)).await, s.submit(de_job(dir.path(), 4, 2)).await);
    s.kill().await;
    {
        let store = Arc::new(Store::open(dir.path()).unwrap());
        let states = store.load_all().unwrap();
        let writer = fmucal_coordinator::store::Writer::spawn(store);
        // Edited as text: a DE state holds a u128, which serde_json's `Value` cannot.
        let format = format!("\"format\":{},", fmucal_coordinator::store::STATE_FORMAT);
        for (id, _, state) in states {
            let json = serde_json::to_string(&state).unwrap();
            assert!(json.starts_with(&format!("{{{format}")), "a state is written with its format: {json:.40}");
            let json = if id == later {
                json.replacen(&format, &format!("\"format\":{},", fmucal_coordinator::store::STATE_FORMAT + 1), 1)
            } else {
                // As the version before the field wrote it.
                json.replacen(&format, "", 1)
            };
            writer.send(fmucal_coordinator::store::Write::State { id, json });
        }
    }
    let s = Sched::start(dir.path());
    let gone = s.call(|reply| Command::Get { job_id: later.clone(), reply }).await;
    assert!(matches!(gone, Err(CoordinatorError::NotFound(_))), "{gone:?}");
    let kept = s.call(|reply| Command::Get { job_id: earlier.clone(), reply }).await;
    assert!(kept.is_ok(), "{kept:?}");
}

/// A point handed back unevaluated (a stopping worker) is sent again, first, and does not
/// count as an attempt: the job ends as if it had never been handed out.
#[tokio::test(start_paused = true)]
async fn a_point_handed_back_unevaluated_is_sent_again_without_counting_as_an_attempt() {
    let dir = tempfile::tempdir().unwrap();
    let s = Sched::start(dir.path());
    let w = s.register("w", 1).await;
    let id = s.submit(points_job(dir.path(), 3)).await;
    let first = s.take(&w, 4).await;
    assert_eq!(ids(&first), [0, 1, 2]);
    let back = |a: &Lease| report(a, Outcome::NotEvaluated);
    // Point 0 answered, 1 and 2 handed back, three times over: never told as failed.
    s.answer(&w, vec![ok(&first[0]), back(&first[1]), back(&first[2])]).await;
    for _ in 0..3 {
        let again = s.take(&w, 4).await;
        let mut again_ids = ids(&again);
        again_ids.sort_unstable();
        assert_eq!(again_ids, [1, 2], "handed-back points are sent again");
        s.answer(&w, again.iter().map(back).collect()).await;
    }
    let again = s.take(&w, 4).await;
    s.answer(&w, again.iter().map(ok).collect()).await;
    let r = s.get(&id).await;
    assert_eq!(r.status, SUCCEEDED, "{r:?}");
    let evaluated = result(&r).evaluated;
    assert!(evaluated.iter().all(|p| p.value.is_some()), "{evaluated:?}");
}

/// DeleteJob removes a finished job (refusing a running one), a restart does not bring it
/// back, and its id is not reused; with a retention of 2, a minute after a third job finished
/// the one that finished first (not the first submitted) is deleted.
#[tokio::test(start_paused = true)]
async fn finished_jobs_can_be_deleted_and_retention_keeps_the_newest() {
    let dir = tempfile::tempdir().unwrap();
    let s = Sched::start(dir.path());
    let w = s.register("w", 4).await;
    let running = s.submit(de_job(dir.path(), 4, 2)).await;
    let refused = s.delete(&running).await;
    assert!(matches!(refused, Err(CoordinatorError::FailedPrecondition(_))), "{refused:?}");
    let (r, _) = s.drive(&running, &[&w], |_, a| ok(a)).await;
    assert_eq!(r.status, SUCCEEDED);
    s.delete(&running).await.unwrap();
    assert!(matches!(s.delete(&running).await, Err(CoordinatorError::NotFound(_))));
    assert!(s.listed().await.is_empty());
    s.kill().await;

    let s = Sched::start_with(dir.path(), Store::open(dir.path()).unwrap(), Some(2));
    assert!(s.listed().await.is_empty(), "a deleted job came back after a restart");
    let w = s.register("w", 4).await;
    let mut done = vec![];
    for _ in 0..3 {
        let id = s.submit(de_job(dir.path(), 4, 2)).await;
        assert!(!done.contains(&id) && id != running, "id {id} reused");
        done.push(id);
    }
    // The second is cancelled and so finishes first; the first submitted finishes second
    // (its points go out first), the third last. Retention goes by when jobs finished.
    s.cancel(&done[1]).await.unwrap();
    s.drive(&done[2], &[&w], |_, a| ok(a)).await;
    assert_eq!(s.get(&done[0]).await.status, SUCCEEDED);
    // A finished job stays for a minute whatever the cap, so its client can read it.
    assert_eq!(s.listed().await.len(), 3);
    s.pass(Duration::from_secs(61), &[&w]).await;
    assert_eq!(s.listed().await, [done[2].clone(), done[0].clone()], "retention keeps the 2 that finished last");
}

/// A full disk fails the job whose state cannot be written, visibly (GetJob says FAILED and
/// why); once the disk has room the store recovers without a restart, and a restart finds
/// the job failed, not running.
#[tokio::test(start_paused = true)]
async fn a_job_whose_state_cannot_be_written_fails_visibly_and_the_store_recovers() {
    use fmucal_coordinator::fillable_disk::FillableDisk;
    let dir = tempfile::tempdir().unwrap();
    let disk = FillableDisk::default();
    let on_disk = |disk: &FillableDisk| {
        let disk = disk.clone();
        Store::with_opener(Box::new(move || disk.open())).unwrap()
    };
    let s = Sched::start_with(dir.path(), on_disk(&disk), None);
    let w = s.register("w", 4).await;
    let id = s.submit(de_job(dir.path(), 4, 50)).await;
    let first = s.take(&w, 4).await;
    disk.set_full(true);
    s.answer(&w, first.iter().map(ok).collect()).await;
    // The writer thread runs on the real clock.
    let deadline = std::time::Instant::now() + Duration::from_secs(30);
    let r = loop {
        s.pass(Duration::from_millis(100), &[&w]).await;
        let r = s.get(&id).await;
        if r.status != RUNNING {
            break r;
        }
        assert!(std::time::Instant::now() < deadline, "the job did not fail");
        std::thread::sleep(Duration::from_millis(20));
    };
    assert_eq!(r.status, JobStatus::Failed, "{r:?}");
    let error = r.error.clone().unwrap_or_default();
    assert!(error.starts_with("the job's state could not be saved") && error.contains("No space left"), "{error:?}");
    assert!(s.take(&w, 4).await.is_empty(), "a failed job hands out points");
    // Room again: a new job is stored and runs, without a restart.
    disk.set_full(false);
    // The store's writer reopens the database within a second (real time); until then a
    // submission is refused.
    let spec = de_job(dir.path(), 4, 2);
    let deadline = std::time::Instant::now() + Duration::from_secs(30);
    let next = loop {
        let job = Box::new(edge::submission(&s.models, &spec).unwrap());
        match s.call(|reply| Command::Submit { job, reply }).await {
            Ok(id) => break id,
            Err(e) => assert!(std::time::Instant::now() < deadline, "the store did not recover: {e}"),
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    let (r, _) = s.drive(&next, &[&w], |_, a| ok(a)).await;
    assert_eq!(r.status, SUCCEEDED);
    drop(s.tx);
    s.task.await.unwrap();
    let s = Sched::start_with(dir.path(), on_disk(&disk), None);
    let r = s.get(&id).await;
    assert_eq!(r.status, JobStatus::Failed, "after a restart: {r:?}");
}

/// A metric's value in the Prometheus text of `registry`.
fn metric(registry: &prometheus_client::registry::Registry, name: &str) -> f64 {
    let mut text = String::new();
    prometheus_client::encoding::prometheus_text::encode(&mut text, registry).unwrap();
    let line =
        text.lines().find(|l| l.split(' ').next() == Some(name)).unwrap_or_else(|| panic!("no {name} in\n{text}"));
    line.rsplit(' ').next().unwrap().parse().unwrap()
}

#[tokio::test(start_paused = true)]
async fn registration_refuses_nonsense_slot_counts_and_bounds_the_name() {
    let dir = tempfile::tempdir().unwrap();
    let s = Sched::start(dir.path());
    for slots in [0, fmucal_proto::MAX_SLOTS + 1, 4_000_000_000] {
        let registration = Registration { name: "w".into(), slots };
        let e = s.call(|reply| Command::Register { registration, reply }).await.unwrap_err();
        assert!(matches!(e, CoordinatorError::InvalidArgument(_)), "{slots}: {e}");
        assert!(e.to_string().starts_with("slots: "), "{slots}: {e}");
    }
    assert!(!s.register("max", fmucal_proto::MAX_SLOTS).await.is_empty());
    // A 100 kB name, with spaces, NUL and a right-to-left override, is cut and cleaned.
    let name = format!("{}\u{0} \u{202e}x", "n".repeat(100_000));
    let id = s.register(&name, 1).await;
    assert!(id.len() <= 100, "{} bytes", id.len());
    assert!(id.chars().all(|c| c.is_ascii_alphanumeric() || "-_.".contains(c)), "{id}");
    let id = s.register("host \u{0}\u{202e}1", 1).await;
    assert!(id.contains("-host___1-"), "{id}");
}

#[tokio::test(start_paused = true)]
async fn an_impossible_result_is_refused_and_its_point_tried_again() {
    let dir = tempfile::tempdir().unwrap();
    let (s, registry) = Sched::start_with_metrics(dir.path());
    let (a, b) = (s.register("a", 1).await, s.register("b", 1).await);
    // A points job wants residuals: their count is checked too.
    let job = s.submit(points_job(dir.path(), 3)).await;
    // (Two polls: one gets its fair share of the queue, two of three points for two workers.)
    let mut held = s.take(&a, 3).await;
    held.extend(s.take(&a, 3).await);
    assert_eq!(held.len(), 3);
    let bad = vec![
        changed(ok(&held[0]), |e| e.value = Some(-1e300)),
        changed(ok(&held[1]), |e| e.value = Some(f64::NAN)),
        changed(ok(&held[2]), |e| e.residuals = Some(vec![1.0; RESIDUALS + 1])),
    ];
    s.answer(&a, bad).await;
    assert_eq!(metric(&registry, "fmucal_refused_results_total"), 3.0);
    // Not told: the points go to the other worker, whose true results end the job.
    let (r, handed) = s.drive(&job, &[&b], |_, p| ok(p)).await;
    assert_eq!(r.status, SUCCEEDED, "{r:?}");
    let mut again = ids(&handed.into_iter().map(|(_, p)| p).collect::<Vec<_>>());
    again.sort_unstable();
    assert_eq!(again, ids(&held));
    let res = result(&r);
    assert_eq!(res.failed_evaluations, 0, "{res:?}");
    assert_eq!(values(&res), held.iter().map(|p| objective(&p.x)).collect::<Vec<_>>());
    assert!(res.evaluated.iter().all(|e| e.residuals.len() == RESIDUALS));

    // A calibration: -1e300 cannot become its optimum.
    let job = s.submit(de_job(dir.path(), 4, 1)).await;
    let (r, _) =
        s.drive(&job, &[&a, &b], |w, p| if w == a { changed(ok(p), |e| e.value = Some(-1e300)) } else { ok(p) }).await;
    assert_eq!(r.status, SUCCEEDED, "{r:?}");
    assert!(result(&r).f_opt >= 0.0, "{:?}", result(&r));
}

#[tokio::test(start_paused = true)]
async fn late_results_are_counted_apart_from_results_never_leased() {
    let dir = tempfile::tempdir().unwrap();
    let (s, registry) = Sched::start_with_metrics(dir.path());
    let (a, b) = (s.register("a", 1).await, s.register("b", 1).await);
    let job = s.submit(points_job(dir.path(), 2)).await;
    let slow = s.take(&a, 1).await;
    // Past the evaluation timeout the point goes to b; a's answer is then late.
    s.pass(TIMEOUT + HEARTBEAT, &[&a, &b]).await;
    // (A poll gets its fair share of the queue: one point of two, for two workers.)
    let mut resent = s.take(&b, 2).await;
    resent.extend(s.take(&b, 2).await);
    assert!(ids(&resent).contains(&slow[0].point_id), "{resent:?}");
    s.answer(&a, slow.iter().map(ok).collect()).await;
    // A job that ended (cancelled) is answered late too.
    let other = s.submit(points_job(dir.path(), 1)).await;
    let held = s.take(&a, 1).await;
    assert_eq!(held[0].job_id, other);
    s.cancel(&other).await.unwrap();
    s.answer(&a, held.iter().map(ok).collect()).await;
    assert_eq!(metric(&registry, "fmucal_late_results_total"), 2.0);
    assert_eq!(metric(&registry, "fmucal_ignored_results_total"), 0.0);
    // A result for a point never leased to a (b holds it; job-999999 does not exist) is not.
    let forged = vec![ok(&resent[0]), Report { job_id: "job-999999".into(), ..ok(&resent[0]) }];
    s.answer(&a, forged).await;
    assert_eq!(metric(&registry, "fmucal_ignored_results_total"), 2.0);
    assert_eq!(metric(&registry, "fmucal_late_results_total"), 2.0);
    // An expired worker's results are late.
    s.pass(EXPIRY + 2 * HEARTBEAT, &[&b]).await;
    assert!(!s.poll(&a, slow.iter().map(ok).collect(), 0).await.known);
    assert_eq!(metric(&registry, "fmucal_late_results_total"), 3.0);
    s.answer(&b, resent.iter().map(ok).collect()).await;
    assert_eq!(s.get(&job).await.status, SUCCEEDED);
    // The same results sent again (a worker that stopped while its poll was held resends what
    // that poll carried) are late too, not forged.
    s.answer(&b, resent.iter().map(ok).collect()).await;
    assert_eq!(metric(&registry, "fmucal_ignored_results_total"), 2.0);
    assert_eq!(metric(&registry, "fmucal_late_results_total"), 5.0);
}

#[tokio::test(start_paused = true)]
async fn a_poll_carrying_more_results_than_its_worker_holds_is_cut_there() {
    let dir = tempfile::tempdir().unwrap();
    let (s, registry) = Sched::start_with_metrics(dir.path());
    let a = s.register("a", 2).await;
    let job = s.submit(points_job(dir.path(), 2)).await;
    let held = s.take(&a, 8).await;
    assert_eq!(held.len(), 2, "{held:?}");
    // Two points leased and none answered yet: a poll's first two results are read, the rest
    // (a point never leased twice, then a true result past the cut) are ignored unread.
    let forged = Report { point_id: 99, ..ok(&held[0]) };
    s.answer(&a, vec![ok(&held[0]), forged.clone(), forged, ok(&held[1])]).await;
    assert_eq!(metric(&registry, "fmucal_ignored_results_total"), 3.0);
    assert_eq!(s.get(&job).await.status, RUNNING);
    // Within the cut every result is read: held[1] is still leased, held[0] is remembered as
    // answered (late).
    s.answer(&a, vec![ok(&held[1]), ok(&held[0])]).await;
    assert_eq!(metric(&registry, "fmucal_ignored_results_total"), 3.0);
    assert_eq!(metric(&registry, "fmucal_late_results_total"), 1.0);
    assert_eq!(s.get(&job).await.status, SUCCEEDED);
}

#[tokio::test(start_paused = true)]
async fn running_jobs_named_as_orphans_are_cancelled_at_start() {
    let dir = tempfile::tempdir().unwrap();
    let s = Sched::start(dir.path());
    let (orphan, kept) = (s.submit(points_job(dir.path(), 1)).await, s.submit(points_job(dir.path(), 1)).await);
    s.kill().await;
    let models = Arc::new(Mutex::new(ModelStore::open(dir.path(), DEFAULT_MAX_STORE_BYTES).unwrap()));
    let timing = Timing { heartbeat_interval: HEARTBEAT, worker_expiry: EXPIRY, evaluation_timeout: TIMEOUT };
    let scheduler = Scheduler::new(Store::open(dir.path()).unwrap(), models.clone(), timing)
        .unwrap()
        .with_orphans_cancelled(&[orphan.clone(), "job-424242".into()]);
    let (tx, rx) = mpsc::channel(64);
    let s = Sched { tx, task: tokio::spawn(scheduler.run(rx)), models };
    assert_eq!(s.get(&orphan).await.status, CANCELLED);
    assert_eq!(s.get(&kept).await.status, RUNNING);
}

/// A result carries the warnings the result alone allows, for every client: a run ended by its
/// budget, and an optimum at a bound.
#[tokio::test(start_paused = true)]
async fn a_result_says_when_a_budget_ended_it_or_it_sits_at_a_bound() {
    let dir = tempfile::tempdir().unwrap();
    let s = Sched::start(dir.path());
    let w = s.register("w", 4).await;
    let budget = s.submit(de_job(dir.path(), 4, 2)).await;
    let (r, _) = s.drive(&budget, &[&w], |_, p| ok(p)).await;
    let warnings = result(&r).warnings;
    assert!(warnings.iter().any(|w| w.contains("ended on its budget")), "{warnings:?}");

    // The workers' objective is least at k = 1.7, above this upper bound.
    let mut at_bound = job(dir.path(), "x_tol = 1e-9\nf_tol = 0.0");
    at_bound.parameters[0].upper = 1.5;
    let at_bound = s.submit(at_bound).await;
    let (r, _) = s.drive(&at_bound, &[&w], |_, p| ok(p)).await;
    assert_eq!(r.status, SUCCEEDED, "{r:?}");
    let warnings = result(&r).warnings;
    assert!(warnings.iter().any(|w| w.starts_with("k = ") && w.contains("upper bound")), "{warnings:?}");
}
