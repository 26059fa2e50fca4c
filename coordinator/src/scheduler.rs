//! The one task that owns all job and worker state. gRPC handlers validate and convert
//! requests, then send a [`Command`] here and await the reply; no lock is held across awaits.
//!
//! Dispatch is pull-based: workers long-poll with the results of their previous points and the
//! number of free slots, and get points from the open batches (oldest job first). A "point"
//! here is a work item of the job's run: a candidate on one of its fitted experiments, so one
//! candidate's experiments run in parallel on the pool. Pull lets a
//! pool grow by simply starting more workers that point at the coordinator, through NAT or a
//! Kubernetes service, with no connection from the coordinator to the workers.
//!
//! A worker's result is taken only for a point leased to it (under the random worker id its
//! registration got) and not taken back since: a late result, after the point was re-sent or
//! the worker re-registered, is dropped, and the point's current holder answers it.
//!
//! Failures: a point whose worker expires (no heartbeat) or passes the evaluation timeout is
//! re-queued, preferably for another worker; a point that failed on two different workers (or
//! three times in all) is told to the optimizer as failed and the job goes on. The optimizer is
//! told results only through its ask/tell interface, so the trajectory is the same whatever the
//! number of workers.

use std::collections::{BTreeMap, HashMap, HashSet, VecDeque};
use std::sync::{Arc, Mutex};
use std::time::Duration;

// tokio's clock, so tests can pause and advance it.
use tokio::time::Instant;

use fmucal_proto::v1 as pb;
use fmucal_shared::job::{Evaluation, JobRun, JobSpec, JobStatus, PreparedJob};
use fmucal_shared::optim::Optimizer;
use prost::Message;
use tokio::sync::{mpsc, oneshot};

use crate::error::{CoordinatorError, quote};
use crate::metrics::{CoordinatorMetrics, Gauges};
use crate::models::ModelStore;
use crate::store::{JobState, Store, Told, Write, Writer};
use fmucal_proto::convert::{SubmittedJob, evaluation_from_proto, result_to_proto};

type Reply<T> = oneshot::Sender<Result<T, CoordinatorError>>;
pub type WatchSender = mpsc::Sender<Result<pb::WatchJobResponse, tonic::Status>>;

/// Requests to the scheduler.
pub enum Command {
    /// A job checked and its run built by the handler ([`prepare`]), off this task: as sent,
    /// as read, and its run.
    Submit {
        spec: pb::JobSpec,
        job: Box<JobSpec>,
        run: Box<JobRun>,
        reply: Reply<String>,
    },
    Get {
        job_id: String,
        reply: Reply<pb::GetJobResponse>,
    },
    List {
        reply: Reply<pb::ListJobsResponse>,
    },
    Cancel {
        job_id: String,
        reply: Reply<i32>,
    },
    Delete {
        job_id: String,
        reply: Reply<()>,
    },
    Watch {
        job_id: String,
        tx: WatchSender,
        reply: Reply<()>,
    },
    Register {
        req: pb::RegisterRequest,
        reply: Reply<pb::RegisterResponse>,
    },
    Heartbeat {
        worker_id: String,
        reply: Reply<bool>,
    },
    FetchJob {
        job_id: String,
        reply: Reply<pb::JobSpec>,
    },
    Poll {
        req: pb::PollWorkRequest,
        reply: oneshot::Sender<pb::PollWorkResponse>,
    },
}

/// Timing of the pool.
#[derive(Debug, Clone)]
pub struct Timing {
    /// How often workers heartbeat.
    pub heartbeat_interval: Duration,
    /// A worker silent this long is dropped.
    pub worker_expiry: Duration,
    /// A point not answered this long after assignment is re-sent.
    pub evaluation_timeout: Duration,
}

/// Times a point held by a dying worker beside other points is sent again before the death
/// counts against it.
const MAX_UNCHARGED_RETRIES: u32 = 3;

/// A work item of a job: a point on one experiment.
struct Point {
    x: Vec<f64>,
    experiment: usize,
    failed_on: Vec<String>,
    /// Times the point was sent again, uncharged, because a worker that held it beside other
    /// points died: any of them may have killed it ([`MAX_UNCHARGED_RETRIES`]).
    uncharged_retries: u32,
    /// Why the last attempt failed.
    last_error: String,
    assigned: Option<(String, Instant)>,
}

struct Job {
    spec: pb::JobSpec,
    /// The job as submitted: its parameter names and start, readable without the model.
    job: JobSpec,
    state: JobState,
    open: BTreeMap<u64, Point>,
    queue: VecDeque<u64>,
    watchers: Vec<WatchSender>,
    started: Instant,
    batch_started: Instant,
    /// When it finished in this process (`None`: running, or finished before it started).
    finished_at: Option<Instant>,
}

impl Job {
    /// A job with nothing queued yet; its clocks start now.
    fn new(spec: pb::JobSpec, job: JobSpec, state: JobState) -> Self {
        let now = Instant::now();
        Job {
            spec,
            job,
            state,
            open: BTreeMap::new(),
            queue: VecDeque::new(),
            watchers: vec![],
            started: now,
            batch_started: now,
            finished_at: None,
        }
    }
}

struct WorkerInfo {
    slots: usize,
    last_seen: Instant,
    inflight: HashSet<(String, u64)>,
    /// Points leased to it and answered or taken back since (their job ended, or they timed
    /// out): a result for one of them is late (or sent again), not forged.
    released: Released,
}

/// The most answered or taken-back points a worker remembers; past it the oldest are
/// forgotten (a result for one of those is then logged as never leased).
const MAX_RELEASED: usize = 4096;

/// Points answered by a worker or taken back from it, the newest [`MAX_RELEASED`].
#[derive(Default)]
struct Released {
    set: HashSet<(String, u64)>,
    order: VecDeque<(String, u64)>,
}

impl Released {
    fn insert(&mut self, point: (String, u64)) {
        if self.set.insert(point.clone()) {
            self.order.push_back(point);
        }
        while self.order.len() > MAX_RELEASED {
            if let Some(old) = self.order.pop_front() {
                self.set.remove(&old);
            }
        }
    }

    /// Whether `point` was taken back (forgetting it).
    fn take(&mut self, point: &(String, u64)) -> bool {
        self.set.remove(point)
    }
}

/// The part of a worker's chosen name that goes into its id: at most
/// [`fmucal_proto::MAX_WORKER_NAME_CHARS`] letters, digits, `.`, `-` and `_` (any other
/// character becomes `_`).
fn worker_name(name: &str) -> String {
    let kept: String = name
        .chars()
        .take(fmucal_proto::MAX_WORKER_NAME_CHARS)
        .map(|c| if c.is_ascii_alphanumeric() || matches!(c, '.' | '-' | '_') { c } else { '_' })
        .collect();
    if kept.is_empty() { "worker".into() } else { kept }
}

/// Why a worker's result for a leased point cannot be true, if it cannot: the objective is a
/// sum of squares (never negative or NaN; +inf is an overflow, kept), and a result carrying
/// residuals must carry as many as the experiment has measured values.
fn impossible_result(r: &pb::PointResult, residuals: Option<usize>) -> Option<String> {
    if r.value.is_nan() {
        return Some("value: NaN is not a sum of squares".into());
    }
    if r.value < 0.0 {
        return Some(format!("value: a sum of squares cannot be negative ({:e})", r.value));
    }
    match residuals {
        Some(n) if !r.residuals.is_empty() && r.residuals.len() != n => {
            Some(format!("residuals: {} values, but the experiment has {n} measured values", r.residuals.len()))
        }
        _ => None,
    }
}

struct Parked {
    worker_id: String,
    max: usize,
    deadline: Instant,
    reply: oneshot::Sender<pb::PollWorkResponse>,
}

pub struct Scheduler {
    jobs: BTreeMap<String, Job>,
    workers: HashMap<String, WorkerInfo>,
    parked: VecDeque<Parked>,
    store: Arc<Store>,
    writer: Writer,
    /// Told points not yet sent to the writer (sent every tick and at batch ends).
    unlogged: Vec<Told>,
    models: Arc<Mutex<ModelStore>>,
    timing: Timing,
    next_seq: u64,
    next_worker: u64,
    /// Finished jobs kept (the oldest past it are deleted); `None`: every one.
    keep_finished_jobs: Option<usize>,
    last_retention: Instant,
    /// The next job to finish gets this [`JobState::finished_seq`].
    next_finish: u64,
    metrics: Option<CoordinatorMetrics>,
}

/// How long a finished job stays at least, whatever the retention cap.
const RETENTION_GRACE: Duration = Duration::from_secs(60);

/// How the error of a job whose state could not be written begins.
const UNSAVED: &str = "the job's state could not be saved";

fn is_running(status: JobStatus) -> bool {
    status == JobStatus::Running
}

/// The write of a job's `state`; the journal written before it goes with it ([`Write::State`]).
fn state_write(id: &str, state: &JobState) -> Result<Write, serde_json::Error> {
    Ok(Write::State { id: id.to_owned(), json: serde_json::to_string(state)? })
}

/// The protocol's number for `status`.
fn wire(status: JobStatus) -> i32 {
    pb::JobStatus::from(status) as i32
}

impl Scheduler {
    /// Opens the store and resumes the jobs that were running.
    pub fn new(store: Store, models: Arc<Mutex<ModelStore>>, timing: Timing) -> Result<Self, CoordinatorError> {
        let store = Arc::new(store);
        let writer = Writer::spawn(store.clone());
        let mut s = Scheduler {
            writer,
            jobs: BTreeMap::new(),
            workers: HashMap::new(),
            parked: VecDeque::new(),
            store,
            unlogged: vec![],
            models,
            timing,
            next_seq: 0,
            next_worker: 0,
            keep_finished_jobs: None,
            last_retention: Instant::now(),
            next_finish: 0,
            metrics: None,
        };
        // Past every stored id, also of jobs whose state this version cannot read, or deleted.
        s.next_seq = s.store.next_seq()?;
        for id in s.store.job_ids()? {
            if let Some(seq) = id.strip_prefix("job-").and_then(|n| n.parse::<u64>().ok()) {
                s.next_seq = s.next_seq.max(seq.saturating_add(1));
            }
        }
        for (id, spec_bytes, mut state) in s.store.load_all()? {
            s.next_seq = s.next_seq.max(state.seq + 1);
            s.next_finish = s.next_finish.max(state.finished_seq.map_or(0, |f| f + 1));
            let spec = pb::JobSpec::decode(spec_bytes.as_slice()).unwrap_or_default();
            let job_spec = match SubmittedJob::try_from(spec.clone()) {
                Ok(j) => j.spec,
                Err(e) => {
                    tracing::error!(job = %id, "the stored job cannot be read, so it is not listed: {e}");
                    continue;
                }
            };
            // A running job goes on only if it still checks against its model (which may be
            // gone); a finished one only says when its model is gone. Either stays listed with
            // its result.
            let models = &s.models;
            let problem = if is_running(state.status) {
                prepare(models, &spec).err().map(|e| format!("cannot resume: {e}"))
            } else {
                let gone = models.lock().map_or(false, |mut m| m.describe(&spec.model_id).is_err());
                gone.then(|| format!("the job's model {} is no longer stored", spec.model_id))
            };
            if let Some(problem) = problem {
                tracing::warn!(job = %id, model = %spec.model_id, "{problem}");
                if is_running(state.status) {
                    state.status = JobStatus::Failed;
                    state.result = Some(state.run.take_result(&job_spec, state.elapsed_s, Some("cannot resume")));
                    state.error = Some(problem);
                    s.save(&id, &state);
                } else if state.error.is_none() {
                    state.error = Some(problem);
                }
                s.jobs.insert(id.clone(), Job::new(spec, job_spec, state));
                continue;
            }
            let running = is_running(state.status);
            let job = Job::new(spec, job_spec, state);
            s.jobs.insert(id.clone(), job);
            if running {
                // Tell the logged results of the open batch instead of evaluating them again,
                // each only to the point it was logged for (an entry of the former log has no x).
                let logged: HashMap<u64, _> = s.store.evaluations(&id)?.into_iter().map(|l| (l.point, l)).collect();
                let job = s.jobs.get_mut(&id).expect("just inserted");
                for c in job.state.run.ask() {
                    let Some(l) = logged.get(&c.id) else { continue };
                    if l.x.as_ref().is_some_and(|x| !same_bits(x, &c.x)) {
                        tracing::warn!(job = %id, point = c.id, "the journal logged another x for this point: it is evaluated again");
                        continue;
                    }
                    let _ = job.state.run.tell(c.id, &c.x, &l.evaluation, 0.0);
                }
                tracing::info!(job = %id, rounds = job.state.run.optimizer().rounds(), "resuming job");
                s.refill(&id)?;
            }
        }
        Ok(s)
    }

    /// Cancels those of `ids` that are running: jobs whose client went away with the previous
    /// coordinator for good (the diagnoses it ran), so that no one will follow or cancel them.
    #[must_use]
    pub fn with_orphans_cancelled(mut self, ids: &[String]) -> Self {
        for id in ids {
            if self.jobs.get(id).is_some_and(|j| is_running(j.state.status)) {
                tracing::warn!(job = %id, "cancelling a job of a diagnosis that ended with the previous coordinator");
                if let Err(e) = self.finish(id, JobStatus::Cancelled, Some("its diagnosis ended with the coordinator"))
                {
                    tracing::error!(job = %id, "cannot save the job state: {e}");
                }
            }
        }
        self
    }

    /// Keeps at most `keep` finished jobs from now on (deleting the oldest by submission,
    /// now and whenever a job finishes); `None` keeps every job.
    #[must_use]
    pub fn with_retention(mut self, keep: Option<usize>) -> Self {
        self.keep_finished_jobs = keep;
        self.apply_retention();
        self
    }

    /// Keeps `metrics` up to date (counters as results arrive, gauges every tick).
    pub fn with_metrics(mut self, metrics: Option<CoordinatorMetrics>) -> Self {
        self.metrics = metrics;
        self.update_gauges();
        self
    }

    /// Sets the metrics' gauges from the jobs and workers.
    fn update_gauges(&self) {
        let Some(m) = &self.metrics else { return };
        let mut g = Gauges::default();
        for job in self.jobs.values() {
            let state = match job.state.status {
                JobStatus::Running => 0,
                JobStatus::Succeeded => 1,
                JobStatus::Failed => 2,
                JobStatus::Cancelled => 3,
            };
            g.jobs[state] += 1;
            if is_running(job.state.status) {
                g.points_queued += job.queue.len() as i64;
                g.points_leased += job.open.values().filter(|p| p.assigned.is_some()).count() as i64;
            }
        }
        g.workers = self.workers.len() as i64;
        g.slots = self.workers.values().map(|w| w.slots as i64).sum();
        m.set(&g);
    }

    /// Runs until the command channel closes.
    pub async fn run(mut self, mut commands: mpsc::Receiver<Command>) {
        let mut tick = tokio::time::interval(Duration::from_millis(50));
        tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
        loop {
            tokio::select! {
                cmd = commands.recv() => match cmd {
                    Some(cmd) => self.handle(cmd),
                    None => break,
                },
                _ = tick.tick() => self.on_tick(),
            }
        }
        self.flush_log();
        for p in self.parked.drain(..) {
            let _ = p.reply.send(pb::PollWorkResponse { assignments: vec![], known: true });
        }
    }

    fn handle(&mut self, cmd: Command) {
        match cmd {
            Command::Submit { spec, job, run, reply } => {
                let _ = reply.send(self.submit(spec, *job, *run));
            }
            Command::Get { job_id, reply } => {
                let _ = reply.send(self.get(&job_id));
            }
            Command::List { reply } => {
                let mut jobs: Vec<(&String, &Job)> = self.jobs.iter().collect();
                jobs.sort_by_key(|(_, j)| std::cmp::Reverse(j.state.seq));
                let jobs = jobs
                    .into_iter()
                    .map(|(id, j)| pb::JobSummary {
                        job_id: id.clone(),
                        status: wire(j.state.status),
                        best_f: j.state.run.best_f(),
                        evaluations: j.state.run.optimizer().evaluations(),
                    })
                    .collect();
                let _ = reply.send(Ok(pb::ListJobsResponse { jobs }));
            }
            Command::Cancel { job_id, reply } => {
                let r = match self.jobs.get(&job_id) {
                    None => Err(CoordinatorError::NotFound(format!("job {}", quote(&job_id)))),
                    Some(j) if !is_running(j.state.status) => Ok(wire(j.state.status)),
                    Some(_) => self
                        .finish(&job_id, JobStatus::Cancelled, Some("cancelled"))
                        .map(|_| wire(JobStatus::Cancelled)),
                };
                let _ = reply.send(r);
            }
            Command::Delete { job_id, reply } => {
                let r = match self.jobs.get(&job_id) {
                    None => Err(CoordinatorError::NotFound(format!("job {}", quote(&job_id)))),
                    Some(j) if is_running(j.state.status) => Err(CoordinatorError::FailedPrecondition(format!(
                        "job {job_id} is running: cancel it before deleting it"
                    ))),
                    Some(_) => {
                        self.delete(&job_id);
                        Ok(())
                    }
                };
                let _ = reply.send(r);
            }
            Command::Watch { job_id, tx, reply } => {
                let r = match self.jobs.get_mut(&job_id) {
                    None => Err(CoordinatorError::NotFound(format!("job {}", quote(&job_id)))),
                    Some(job) => {
                        let event = progress(job, 0.0);
                        if is_running(job.state.status) {
                            let _ = tx.try_send(Ok(event));
                            job.watchers.push(tx);
                        } else {
                            let _ = tx.try_send(Ok(event));
                        }
                        Ok(())
                    }
                };
                let _ = reply.send(r);
            }
            Command::Register { req, reply } => {
                let _ = reply.send(self.register(&req));
            }
            Command::Heartbeat { worker_id, reply } => {
                let known = match self.workers.get_mut(&worker_id) {
                    Some(w) => {
                        w.last_seen = Instant::now();
                        true
                    }
                    None => false,
                };
                let _ = reply.send(Ok(known));
            }
            Command::FetchJob { job_id, reply } => {
                let r = self
                    .jobs
                    .get(&job_id)
                    .map(|j| j.spec.clone())
                    .ok_or(CoordinatorError::NotFound(format!("job {}", quote(&job_id))));
                let _ = reply.send(r);
            }
            Command::Poll { req, reply } => self.poll(req, reply),
        }
    }

    /// Registers a worker under a fresh, unguessable id that carries its (bounded) name.
    fn register(&mut self, req: &pb::RegisterRequest) -> Result<pb::RegisterResponse, CoordinatorError> {
        if req.protocol_version != fmucal_proto::PROTOCOL_VERSION {
            return Err(CoordinatorError::InvalidArgument(format!(
                "protocol_version: worker speaks {}, coordinator speaks {}",
                req.protocol_version,
                fmucal_proto::PROTOCOL_VERSION
            )));
        }
        if req.slots == 0 || req.slots > fmucal_proto::MAX_SLOTS {
            return Err(CoordinatorError::InvalidArgument(format!(
                "slots: a worker has 1 to {} slots, not {}",
                fmucal_proto::MAX_SLOTS,
                req.slots
            )));
        }
        self.next_worker += 1;
        // A random part, so a worker id cannot be guessed and used to answer another
        // worker's points.
        let id = format!("w{}-{}-{}", self.next_worker, worker_name(&req.name), random_hex());
        self.workers.insert(
            id.clone(),
            WorkerInfo {
                slots: req.slots as usize,
                last_seen: Instant::now(),
                inflight: HashSet::new(),
                released: Released::default(),
            },
        );
        tracing::info!(worker = %id, slots = req.slots, "worker registered");
        Ok(pb::RegisterResponse {
            worker_id: id,
            heartbeat_interval_ms: self.timing.heartbeat_interval.as_millis() as u64,
            evaluation_timeout_ms: self.timing.evaluation_timeout.as_millis() as u64,
        })
    }

    fn submit(&mut self, spec: pb::JobSpec, job: JobSpec, run: JobRun) -> Result<String, CoordinatorError> {
        let seq = self.next_seq;
        self.next_seq += 1;
        let id = format!("job-{seq:06}");
        let state = JobState {
            format: crate::store::STATE_FORMAT,
            seq,
            status: JobStatus::Running,
            run,
            elapsed_s: 0.0,
            result: None,
            error: None,
            finished_seq: None,
        };
        self.store.create(&id, &spec.encode_to_vec(), &state)?;
        self.jobs.insert(id.clone(), Job::new(spec, job, state));
        tracing::info!(job = %id, "job submitted");
        self.refill(&id)?;
        Ok(id)
    }

    fn get(&self, job_id: &str) -> Result<pb::GetJobResponse, CoordinatorError> {
        let j = self.jobs.get(job_id).ok_or(CoordinatorError::NotFound(format!("job {}", quote(job_id))))?;
        Ok(pb::GetJobResponse {
            job_id: job_id.to_owned(),
            status: wire(j.state.status),
            result: j.state.result.as_ref().map(|r| result_to_proto(r, &j.job.parameter_vectors().0)),
            error: j.state.error.clone().unwrap_or_default(),
        })
    }

    /// Queues the optimizer's open candidates, or finishes the job when it asks for none.
    fn refill(&mut self, id: &str) -> Result<(), CoordinatorError> {
        let Some(job) = self.jobs.get_mut(id) else { return Ok(()) };
        if !is_running(job.state.status) {
            return Ok(());
        }
        let batch = job.state.run.ask();
        if batch.is_empty() {
            return self.finish(id, JobStatus::Succeeded, None);
        }
        job.batch_started = Instant::now();
        for c in batch {
            if !job.open.contains_key(&c.id) {
                let point = Point {
                    x: c.x,
                    experiment: c.experiment,
                    failed_on: vec![],
                    uncharged_retries: 0,
                    last_error: String::new(),
                    assigned: None,
                };
                job.open.insert(c.id, point);
                job.queue.push_back(c.id);
            }
        }
        self.wake_parked();
        Ok(())
    }

    fn finish(&mut self, id: &str, status: JobStatus, why: Option<&str>) -> Result<(), CoordinatorError> {
        let Some(job) = self.jobs.get_mut(id) else { return Ok(()) };
        let elapsed = job.state.elapsed_s + job.started.elapsed().as_secs_f64();
        job.state.status = status;
        job.state.finished_seq = Some(self.next_finish);
        self.next_finish += 1;
        job.finished_at = Some(Instant::now());
        job.state.elapsed_s = elapsed;
        if status == JobStatus::Failed {
            job.state.error = why.map(str::to_owned);
        }
        job.state.result = Some(job.state.run.take_result(&job.job, elapsed, why));
        job.open.clear();
        job.queue.clear();
        let write = state_write(id, &job.state)?;
        let event = progress(job, 0.0);
        for w in job.watchers.drain(..) {
            let _ = w.try_send(Ok(event.clone()));
        }
        for w in self.workers.values_mut() {
            let taken: Vec<(String, u64)> = w.inflight.iter().filter(|(j, _)| j == id).cloned().collect();
            for point in taken {
                w.inflight.remove(&point);
                w.released.insert(point);
            }
        }
        // The ended state removes the job's log: its unwritten entries need not be written.
        self.unlogged.retain(|t| t.job != id);
        self.flush_log();
        self.writer.send(write);
        tracing::info!(job = %id, ?status, "job finished");
        Ok(())
    }

    /// Tells a point's evaluation; when it completes the round, reports progress, saves the
    /// state and asks the next round (or finishes the job).
    fn tell(&mut self, id: &str, point: u64, evaluation: Evaluation) {
        let Some(job) = self.jobs.get_mut(id) else { return };
        let Some(p) = job.open.remove(&point) else { return };
        job.queue.retain(|q| *q != point);
        let told = job.state.run.tell(point, &p.x, &evaluation, job.batch_started.elapsed().as_secs_f64());
        self.unlogged.push(Told { job: id.to_owned(), point, x: p.x, evaluation });
        if let Some(why) = job.state.run.fatal_error() {
            tracing::warn!(job = %id, "{why}");
            if let Err(e) = self.finish(id, JobStatus::Failed, Some(&why)) {
                tracing::error!(job = %id, "cannot save the result: {e}");
            }
            return;
        }
        let round = match told {
            Ok(Some(round)) => round,
            Ok(None) => return,
            Err(e) => {
                tracing::error!(job = %id, "optimizer rejected a result: {e}");
                return;
            }
        };
        let event = progress(job, round.batch_wall_s);
        job.watchers.retain(|w| w.try_send(Ok(event.clone())).is_ok() || !w.is_closed());
        if job.state.run.is_done() {
            if let Err(e) = self.finish(id, JobStatus::Succeeded, None) {
                tracing::error!(job = %id, "cannot save the result: {e}");
            }
            return;
        }
        match state_write(id, &job.state) {
            Ok(write) => {
                self.flush_log();
                self.writer.send(write);
            }
            Err(e) => tracing::error!(job = %id, "cannot save the job state: {e}"),
        }
        if let Err(e) = self.refill(id) {
            tracing::error!(job = %id, "cannot continue: {e}");
        }
    }

    /// Records a failed attempt; the point is told as failed after two different workers (or
    /// three attempts), else queued again.
    /// Sends `point` again without counting an attempt against it, unless it was already sent
    /// again so [`MAX_UNCHARGED_RETRIES`] times; says whether it was.
    fn retry_uncharged(&mut self, id: &str, point: u64) -> bool {
        let Some(job) = self.jobs.get_mut(id) else { return true };
        let Some(p) = job.open.get_mut(&point) else { return true };
        if p.uncharged_retries >= MAX_UNCHARGED_RETRIES {
            return false;
        }
        p.uncharged_retries += 1;
        p.assigned = None;
        job.queue.push_back(point);
        self.wake_parked();
        true
    }

    fn attempt_failed(&mut self, id: &str, point: u64, worker: &str, why: &str) {
        let Some(job) = self.jobs.get_mut(id) else { return };
        let Some(p) = job.open.get_mut(&point) else { return };
        p.failed_on.push(worker.to_owned());
        p.last_error = why.to_owned();
        p.assigned = None;
        let distinct: HashSet<&String> = p.failed_on.iter().collect();
        if distinct.len() >= 2 || p.failed_on.len() >= 3 {
            let evaluation = Evaluation::failed(std::mem::take(&mut p.last_error));
            self.tell(id, point, evaluation);
        } else {
            job.queue.push_back(point);
            self.wake_parked();
        }
    }

    /// A write of the job's state or log failed (a full disk): the job fails, visibly, with its
    /// best point so far; the writer writes that state once the disk has room.
    fn fail_unsaved(&mut self, id: &str, error: &str) {
        let Some(job) = self.jobs.get_mut(id) else { return };
        if job.state.error.as_deref().is_some_and(|e| e.starts_with(UNSAVED)) {
            return;
        }
        let why = format!("{UNSAVED}: {error}");
        tracing::error!(job = %id, "{why}");
        if is_running(job.state.status) {
            if let Err(e) = self.finish(id, JobStatus::Failed, Some(&why)) {
                tracing::error!(job = %id, "{e}");
            }
        } else {
            job.state.status = JobStatus::Failed;
            job.state.error = Some(why);
            let state = job.state.clone();
            self.save(id, &state);
        }
    }

    /// Forgets a finished job and deletes it from the store (after the writes queued before).
    fn delete(&mut self, id: &str) {
        self.flush_log();
        self.jobs.remove(id);
        self.writer.send(Write::Delete { id: id.to_owned() });
        tracing::info!(job = %id, "job deleted");
    }

    /// Deletes the finished jobs past the retention cap, those that finished first, once they
    /// have been finished for [`RETENTION_GRACE`] (so the client that waited for one can read
    /// its result).
    fn apply_retention(&mut self) {
        self.last_retention = Instant::now();
        let Some(keep) = self.keep_finished_jobs else { return };
        let mut finished: Vec<((u64, u64), &String, &Job)> = self
            .jobs
            .iter()
            .filter(|(_, j)| !is_running(j.state.status))
            .map(|(id, j)| ((j.state.finished_seq.unwrap_or(0), j.state.seq), id, j))
            .collect();
        if finished.len() <= keep {
            return;
        }
        finished.sort_unstable_by_key(|(order, _, _)| *order);
        let excess = finished.len() - keep;
        let expired: Vec<String> = finished
            .into_iter()
            .take(excess)
            .filter(|(_, _, j)| j.finished_at.is_none_or(|t| t.elapsed() >= RETENTION_GRACE))
            .map(|(_, id, _)| id.clone())
            .collect();
        for id in expired {
            self.delete(&id);
        }
    }

    /// A worker handed a point back unevaluated: it is queued again, first in line, without
    /// counting as an attempt.
    fn hand_back(&mut self, id: &str, point: u64) {
        let Some(job) = self.jobs.get_mut(id) else { return };
        let Some(p) = job.open.get_mut(&point) else { return };
        p.assigned = None;
        job.queue.push_front(point);
        self.wake_parked();
    }

    fn poll(&mut self, req: pb::PollWorkRequest, reply: oneshot::Sender<pb::PollWorkResponse>) {
        let wid = req.worker_id.clone();
        match self.workers.get_mut(&wid) {
            None => {
                // An expired worker's results: their points were sent again to others. Late,
                // not alarming.
                if !req.results.is_empty() {
                    tracing::debug!(worker = %wid, results = req.results.len(), "results of an expired worker ignored");
                }
                if let Some(m) = &self.metrics {
                    req.results.iter().for_each(|_| m.late_result());
                }
                let _ = reply.send(pb::PollWorkResponse { assignments: vec![], known: false });
                return;
            }
            Some(w) => w.last_seen = Instant::now(),
        }
        for r in req.results {
            // Only a point leased to this worker (and not taken back since) may be answered:
            // a token holder cannot report values for points it was never given.
            let key = (r.job_id.clone(), r.point_id);
            let Some(worker) = self.workers.get_mut(&wid) else { break };
            if !worker.inflight.remove(&key) {
                // A point taken back (its job ended, or it timed out and went to another
                // worker) is answered late: normal, so counted and logged at debug only.
                if worker.released.take(&key) {
                    tracing::debug!(job = %r.job_id, point = r.point_id, worker = %wid, "late result for a point taken back ignored");
                    if let Some(m) = &self.metrics {
                        m.late_result();
                    }
                } else {
                    tracing::warn!(job = %r.job_id, point = r.point_id, worker = %wid, "result for a point never leased to this worker ignored");
                    if let Some(m) = &self.metrics {
                        m.ignored_result();
                    }
                }
                continue;
            }
            // Answered now: the same result sent again (a worker stopping while its poll was
            // held resends what that poll carried) is late too, not forged.
            worker.released.insert(key);
            if r.status == pb::PointStatus::NotEvaluated as i32 {
                self.hand_back(&r.job_id, r.point_id);
                continue;
            }
            if r.status == pb::PointStatus::Ok as i32 {
                let job = self.jobs.get(&r.job_id);
                let experiment = job.and_then(|j| j.open.get(&r.point_id)).map(|p| p.experiment);
                let residuals = job.zip(experiment).and_then(|(j, k)| j.state.run.residual_count(k));
                if let Some(why) = impossible_result(&r, residuals) {
                    tracing::warn!(job = %r.job_id, point = r.point_id, worker = %wid, "impossible result refused: {why}");
                    if let Some(m) = &self.metrics {
                        m.refused_result();
                    }
                    self.attempt_failed(
                        &r.job_id,
                        r.point_id,
                        &wid,
                        &format!("the worker's result was refused: {why}"),
                    );
                    continue;
                }
            }
            let evaluation = evaluation_from_proto(&r);
            if let Some(m) = &self.metrics {
                let job = self.jobs.get(&r.job_id);
                let leased_at = job.and_then(|j| j.open.get(&r.point_id)).and_then(|p| p.assigned.as_ref());
                m.result(evaluation.value.is_none(), leased_at.map(|(_, at)| at.elapsed()));
            }
            if evaluation.value.is_some() {
                self.tell(&r.job_id, r.point_id, evaluation);
            } else {
                tracing::debug!(job = %r.job_id, point = r.point_id, worker = %wid, "simulation failed: {}", r.message);
                self.attempt_failed(&r.job_id, r.point_id, &wid, &r.message);
            }
        }
        let max = req.max_points as usize;
        let assignments = self.assign(&wid, max);
        if !assignments.is_empty() || max == 0 || req.wait_ms == 0 {
            let _ = reply.send(pb::PollWorkResponse { assignments, known: true });
        } else {
            let wait = Duration::from_millis(u64::from(req.wait_ms).min(10_000));
            self.parked.push_back(Parked { worker_id: wid, max, deadline: Instant::now() + wait, reply });
        }
    }

    /// Takes up to `max` queued points for a worker, oldest job first, avoiding points that
    /// already failed on it while another worker is alive. A worker may ask for several points
    /// per poll (to amortise the round trip), but gets at most its fair share of the queue,
    /// ⌈queued / live slots⌉, so expensive batches still spread over the whole pool.
    ///
    /// A point sent again after a worker died holding it beside others (a suspect: it may be
    /// the one that kills) goes only to an idle worker, alone, and that worker gets nothing
    /// else until it answers: if it dies again, the death is the point's own, and a healthy
    /// point is not charged for a neighbour's crash.
    fn assign(&mut self, wid: &str, max: usize) -> Vec<pb::Assignment> {
        let alone = self.workers.len() <= 1;
        let (idle, holds_suspect) = match self.workers.get(wid) {
            Some(w) => (
                w.inflight.is_empty(),
                w.inflight.iter().any(|(j, pid)| {
                    self.jobs.get(j).and_then(|job| job.open.get(pid)).is_some_and(|p| p.uncharged_retries > 0)
                }),
            ),
            None => (true, false),
        };
        if holds_suspect {
            return vec![];
        }
        let queued: usize = self.jobs.values().filter(|j| is_running(j.state.status)).map(|j| j.queue.len()).sum();
        let slots: usize = self.workers.values().map(|w| w.slots).sum::<usize>().max(1);
        let max = max.min(queued.div_ceil(slots).max(1));
        let mut out = vec![];
        let mut order: Vec<(&String, &mut Job)> =
            self.jobs.iter_mut().filter(|(_, j)| is_running(j.state.status)).collect();
        order.sort_by_key(|(_, j)| j.state.seq);
        let mut took_suspect = false;
        for (id, job) in order {
            let mut skipped = VecDeque::new();
            while out.len() < max && !took_suspect {
                let Some(pid) = job.queue.pop_front() else { break };
                let Some(p) = job.open.get_mut(&pid) else { continue };
                if !alone && p.failed_on.iter().any(|w| w == wid) {
                    skipped.push_back(pid);
                    continue;
                }
                let suspect = p.uncharged_retries > 0;
                if suspect && (!idle || !out.is_empty()) {
                    skipped.push_back(pid);
                    continue;
                }
                p.assigned = Some((wid.to_owned(), Instant::now()));
                out.push(pb::Assignment {
                    job_id: id.clone(),
                    point_id: pid,
                    x: p.x.clone(),
                    want_residuals: job.state.run.wants_residuals(),
                    experiment: u32::try_from(p.experiment).unwrap_or(u32::MAX),
                });
                took_suspect = suspect;
            }
            skipped.extend(job.queue.drain(..));
            job.queue = skipped;
            if out.len() >= max || took_suspect {
                break;
            }
        }
        if let Some(w) = self.workers.get_mut(wid) {
            for a in &out {
                w.inflight.insert((a.job_id.clone(), a.point_id));
            }
        }
        out
    }

    fn wake_parked(&mut self) {
        let mut still = VecDeque::new();
        while let Some(p) = self.parked.pop_front() {
            if p.reply.is_closed() {
                continue;
            }
            let a = self.assign(&p.worker_id, p.max);
            if a.is_empty() {
                still.push_back(p);
            } else {
                let _ = p.reply.send(pb::PollWorkResponse { assignments: a, known: true });
            }
        }
        self.parked = still;
    }

    fn flush_log(&mut self) {
        if !self.unlogged.is_empty() {
            self.writer.send(Write::Log(std::mem::take(&mut self.unlogged)));
        }
    }

    fn save(&self, id: &str, state: &JobState) {
        match state_write(id, state) {
            Ok(write) => self.writer.send(write),
            Err(e) => tracing::error!(job = %id, "cannot save the job state: {e}"),
        }
    }

    fn on_tick(&mut self) {
        self.flush_log();
        self.update_gauges();
        if self.last_retention.elapsed() >= Duration::from_secs(1) {
            self.apply_retention();
        }
        for failure in self.writer.failures() {
            for id in &failure.jobs {
                self.fail_unsaved(id, &failure.error);
            }
        }
        let now = Instant::now();
        // Expire silent workers; their points count as failed attempts on them.
        let expired: Vec<String> = self
            .workers
            .iter()
            .filter(|(_, w)| now.duration_since(w.last_seen) > self.timing.worker_expiry)
            .map(|(id, _)| id.clone())
            .collect();
        for wid in expired {
            let w = self.workers.remove(&wid).expect("listed above");
            tracing::warn!(worker = %wid, points = w.inflight.len(), "worker expired");
            // A worker that dies holding several points says nothing of which one killed it: each
            // is sent again uncharged, a few times, before the deaths count against it.
            let shared = w.inflight.len() > 1;
            for (job, point) in w.inflight {
                if shared && self.retry_uncharged(&job, point) {
                    continue;
                }
                self.attempt_failed(&job, point, &wid, "the worker stopped answering");
            }
        }
        // Re-send points past the evaluation timeout.
        let mut late = vec![];
        for (id, job) in &self.jobs {
            for (pid, p) in &job.open {
                if let Some((w, at)) = &p.assigned
                    && now.duration_since(*at) > self.timing.evaluation_timeout
                {
                    late.push((id.clone(), *pid, w.clone()));
                }
            }
        }
        for (id, pid, w) in late {
            tracing::warn!(job = %id, point = pid, worker = %w, "evaluation timed out");
            if let Some(info) = self.workers.get_mut(&w)
                && info.inflight.remove(&(id.clone(), pid))
            {
                info.released.insert((id.clone(), pid));
            }
            self.attempt_failed(&id, pid, &w, "the evaluation timed out");
        }
        // Answer long polls that waited long enough.
        let mut still = VecDeque::new();
        while let Some(p) = self.parked.pop_front() {
            if p.deadline <= now || p.reply.is_closed() {
                let _ = p
                    .reply
                    .send(pb::PollWorkResponse { assignments: vec![], known: self.workers.contains_key(&p.worker_id) });
            } else {
                still.push_back(p);
            }
        }
        self.parked = still;
        self.wake_parked();
    }
}

/// Whether two points are the same, bit for bit.
fn same_bits(a: &[f64], b: &[f64]) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(u, v)| u.to_bits() == v.to_bits())
}

/// 16 random hex digits from the operating system (a clock-derived fallback if it has none).
fn random_hex() -> String {
    use std::io::Read;
    let mut bytes = [0u8; 8];
    let read = std::fs::File::open("/dev/urandom").and_then(|mut f| f.read_exact(&mut bytes));
    if read.is_err() {
        let nanos = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_nanos());
        bytes = (nanos as u64).to_le_bytes();
    }
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// Checks a submitted job against its model and data: blocking work, linear in the size of the
/// job (whose sizes [`fmucal_shared::job::limits`] caps). The handlers call it before a job
/// reaches the scheduler task, so a large or bad request never holds that task up.
///
/// # Errors
/// INVALID_ARGUMENT naming the field; NOT_FOUND-like INVALID_ARGUMENT for an unknown model.
pub fn prepare(models: &Mutex<ModelStore>, spec: &pb::JobSpec) -> Result<Arc<PreparedJob>, CoordinatorError> {
    let submitted = SubmittedJob::try_from(spec.clone())?;
    let described = models
        .lock()
        .map_err(|_| CoordinatorError::Storage("model store poisoned".into()))?
        .describe(&spec.model_id)?;
    let prepared = PreparedJob::new(&submitted.spec, &described.description, &described.interfaces, &submitted.data)?;
    Ok(Arc::new(prepared))
}

fn progress(job: &Job, batch_wall_s: f64) -> pb::WatchJobResponse {
    let o = job.state.run.optimizer();
    let best = job.state.run.best();
    pb::WatchJobResponse {
        iteration: o.iterations(),
        evaluations: o.evaluations(),
        best_f: best.as_ref().map_or(f64::INFINITY, |b| b.1),
        best_x: best.map(|b| b.0).unwrap_or_default(),
        batch_wall_s,
        status: wire(job.state.status),
        rounds: job.state.run.completed_rounds(),
    }
}
