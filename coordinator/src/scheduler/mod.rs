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
//!
//! The state is split by concern, each part a struct of its own: `jobs` (the job table, each
//! job's open batch, its watchers, retention), `leases` (the worker registry, the points each
//! holds and gave up, leasing), `parking` (long polls waiting for work) and `persist` (the
//! store's writes and reads). This module composes them: each change that concerns several
//! parts (a point told, a job finished, a worker expired) is one method here, and the metrics
//! are read from the parts. `commands` has one method per [`Command`] and the values the
//! commands carry.
//!
//! Nothing here knows protobuf: a [`Command`] and its answer are domain values ([`Submission`],
//! [`JobView`], [`Registration`], [`PollRequest`], [`Lease`], [`Report`], [`Progress`], ...),
//! and the service edge ([`crate::edge`]) converts the gRPC messages to them and back. The one
//! protocol value kept, the job as it was sent, is kept as opaque bytes ([`Submission::sent`]).

mod commands;
mod jobs;
mod leases;
mod parking;
mod persist;

use std::sync::{Arc, Mutex};
use std::time::Duration;

// tokio's clock, so tests can pause and advance it.
use tokio::time::Instant;

use fmucal_shared::job::{Evaluation, JobRun, JobSpec, JobStatus, MeasurementTable, PreparedJob};
use fmucal_shared::optim::Optimizer;
use tokio::sync::{mpsc, oneshot};

use crate::error::{CoordinatorError, quote};
use crate::metrics::{CoordinatorMetrics, Gauges};
use crate::models::ModelStore;
use crate::store::{JobState, Store, Told};
use jobs::{Attempt, Job, Jobs, Retry};
use leases::{Answer, Leases, impossible_result};
use parking::{MAX_POLL_WAIT, Parking, PollReply};
use persist::Persistence;

pub use commands::{JobSummary, JobView, PollAnswer, PollRequest, Registered, Registration, Submission};
pub use jobs::{Progress, Watcher};
pub use leases::{Lease, Outcome, Report};

type Reply<T> = oneshot::Sender<Result<T, CoordinatorError>>;

/// Requests to the scheduler, each answered on its `reply`.
pub enum Command {
    /// A job checked and its run built by the handler ([`Submission::new`]), off this task.
    /// Answered with the new job's id.
    Submit {
        job: Box<Submission>,
        reply: Reply<String>,
    },
    Get {
        job_id: String,
        reply: Reply<JobView>,
    },
    /// Every job, the newest first.
    List {
        reply: Reply<Vec<JobSummary>>,
    },
    /// Cancels a running job; answered with the job's status after.
    Cancel {
        job_id: String,
        reply: Reply<JobStatus>,
    },
    Delete {
        job_id: String,
        reply: Reply<()>,
    },
    /// Tells `watcher` the job's progress now, and while it runs at every completed round
    /// and at its end.
    Watch {
        job_id: String,
        watcher: Box<dyn Watcher>,
        reply: Reply<()>,
    },
    Register {
        registration: Registration,
        reply: Reply<Registered>,
    },
    Heartbeat {
        worker_id: String,
        reply: Reply<bool>,
    },
    /// The job as it was sent, encoded ([`Submission::sent`]).
    FetchJob {
        job_id: String,
        reply: Reply<Vec<u8>>,
    },
    /// Answered at once, or once points are queued, or when its wait is over.
    Poll {
        req: PollRequest,
        reply: oneshot::Sender<PollAnswer>,
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

/// How the error of a job whose state could not be written begins.
const UNSAVED: &str = "the job's state could not be saved";

fn no_job(id: &str) -> CoordinatorError {
    CoordinatorError::NotFound(format!("job {}", quote(id)))
}

/// Sends a command's answer (its caller may have gone: nothing to do then).
fn answer<T>(reply: Reply<T>, r: Result<T, CoordinatorError>) {
    let _ = reply.send(r);
}

pub struct Scheduler {
    jobs: Jobs,
    leases: Leases,
    parking: Parking,
    persist: Persistence,
    models: Arc<Mutex<ModelStore>>,
    timing: Timing,
    metrics: Option<CoordinatorMetrics>,
}

impl Scheduler {
    /// Opens the store and resumes the jobs that were running.
    pub fn new(store: Store, models: Arc<Mutex<ModelStore>>, timing: Timing) -> Result<Self, CoordinatorError> {
        let mut s = Scheduler {
            jobs: Jobs::new(),
            leases: Leases::default(),
            parking: Parking::default(),
            persist: Persistence::new(store),
            models,
            timing,
            metrics: None,
        };
        // Past every stored id, also of jobs whose state this version cannot read, or deleted.
        s.jobs.skip_past(s.persist.next_seq()?);
        for (id, sent, mut state) in s.persist.stored_jobs()? {
            s.jobs.skip_past(state.seq + 1);
            s.jobs.ended_before(state.finished_seq);
            let submitted = match crate::edge::read_sent(&sent) {
                Ok(j) => j,
                Err(e) => {
                    tracing::error!(job = %id, "the stored job cannot be read, so it is not listed: {e}");
                    continue;
                }
            };
            let model_id = submitted.spec.model.id.clone().unwrap_or_default();
            // A running job goes on only if it still checks against its model (which may be
            // gone); a finished one only says when its model is gone. Either stays listed with
            // its result.
            let models = &s.models;
            let problem = if jobs::is_running(state.status) {
                check_job(models, &submitted.spec, &submitted.data).err().map(|e| format!("cannot resume: {e}"))
            } else {
                let gone = models.lock().map_or(false, |mut m| m.describe(&model_id).is_err());
                gone.then(|| format!("the job's model {model_id} is no longer stored"))
            };
            let job_spec = submitted.spec;
            if let Some(problem) = problem {
                tracing::warn!(job = %id, model = %model_id, "{problem}");
                if jobs::is_running(state.status) {
                    state.status = JobStatus::Failed;
                    state.result = Some(state.run.take_result(&job_spec, state.elapsed_s, Some("cannot resume")));
                    state.error = Some(problem);
                    s.persist.save(&id, &state);
                } else if state.error.is_none() {
                    state.error = Some(problem);
                }
                s.jobs.insert(id.clone(), Job::new(sent, job_spec, state));
                continue;
            }
            let running = jobs::is_running(state.status);
            s.jobs.insert(id.clone(), Job::new(sent, job_spec, state));
            if running {
                s.resume(&id)?;
            }
        }
        Ok(s)
    }

    /// Resumes running job `id`: the journaled results of its open batch are told instead of
    /// evaluated again, each only to the point it was logged for (an entry of the former log
    /// has no x), and the rest is queued.
    fn resume(&mut self, id: &str) -> Result<(), CoordinatorError> {
        let logged = self.persist.journaled(id)?;
        let Some(job) = self.jobs.get_mut(id) else { return Ok(()) };
        for c in job.state.run.ask() {
            let Some(l) = logged.get(&c.id) else { continue };
            if l.x.as_ref().is_some_and(|x| !same_bits(x, &c.x)) {
                tracing::warn!(job = %id, point = c.id, "the journal logged another x for this point: it is evaluated again");
                continue;
            }
            let _ = job.state.run.tell(c.id, &c.x, &l.evaluation, 0.0);
        }
        tracing::info!(job = %id, rounds = job.state.run.optimizer().rounds(), "resuming job");
        self.refill(id)
    }

    /// Cancels those of `ids` that are running: jobs whose client went away with the previous
    /// coordinator for good (the diagnoses it ran), so that no one will follow or cancel them.
    #[must_use]
    pub fn with_orphans_cancelled(mut self, ids: &[String]) -> Self {
        for id in ids {
            if self.jobs.get(id).is_some_and(Job::is_running) {
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
        self.jobs.set_retention(keep);
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
            if job.is_running() {
                g.points_queued += job.batch.queue.len() as i64;
                g.points_leased += job.batch.leased() as i64;
            }
        }
        g.workers = self.leases.len() as i64;
        g.slots = self.leases.slots() as i64;
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
        self.persist.flush_log();
        self.parking.release_all();
    }

    /// Hands each command to its method ([`commands`]).
    fn handle(&mut self, cmd: Command) {
        match cmd {
            Command::Submit { job, reply } => answer(reply, self.submit(*job)),
            Command::Get { job_id, reply } => answer(reply, self.get(&job_id)),
            Command::List { reply } => answer(reply, self.list()),
            Command::Cancel { job_id, reply } => answer(reply, self.cancel(&job_id)),
            Command::Delete { job_id, reply } => answer(reply, self.delete(&job_id)),
            Command::Watch { job_id, watcher, reply } => answer(reply, self.watch(&job_id, watcher)),
            Command::Register { registration, reply } => answer(reply, self.register(&registration)),
            Command::Heartbeat { worker_id, reply } => answer(reply, self.heartbeat(&worker_id)),
            Command::FetchJob { job_id, reply } => answer(reply, self.fetch_job(&job_id)),
            Command::Poll { req, reply } => self.poll(req, reply),
        }
    }

    /// Stores a new job, `sent` being the job as it was sent (encoded), and queues its first
    /// batch. Returns its id.
    fn add_job(&mut self, sent: Vec<u8>, job: JobSpec, run: JobRun) -> Result<String, CoordinatorError> {
        let (seq, id) = self.jobs.next_id();
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
        self.persist.create(&id, &sent, &state)?;
        self.jobs.insert(id.clone(), Job::new(sent, job, state));
        tracing::info!(job = %id, "job submitted");
        self.refill(&id)?;
        Ok(id)
    }

    /// Cancels job `id` if it runs; returns its status.
    fn cancel_job(&mut self, id: &str) -> Result<JobStatus, CoordinatorError> {
        match self.jobs.get(id) {
            None => Err(no_job(id)),
            Some(j) if !j.is_running() => Ok(j.state.status),
            Some(_) => self.finish(id, JobStatus::Cancelled, Some("cancelled")).map(|()| JobStatus::Cancelled),
        }
    }

    /// Deletes finished job `id`.
    fn delete_job(&mut self, id: &str) -> Result<(), CoordinatorError> {
        match self.jobs.get(id) {
            None => Err(no_job(id)),
            Some(j) if j.is_running() => {
                Err(CoordinatorError::FailedPrecondition(format!("job {id} is running: cancel it before deleting it")))
            }
            Some(_) => {
                self.forget(id);
                Ok(())
            }
        }
    }

    /// Tells `watcher` job `id`'s progress now, and, while it runs, at every completed round
    /// and at its end.
    fn watch_job(&mut self, id: &str, watcher: Box<dyn Watcher>) -> Result<(), CoordinatorError> {
        let job = self.jobs.get_mut(id).ok_or_else(|| no_job(id))?;
        let _ = watcher.offer(&job.progress(0.0));
        if job.is_running() {
            job.watchers.push(watcher);
        }
        Ok(())
    }

    /// A worker's poll: takes its `reports` (at most [`Leases::max_reports`] of them), then
    /// leases it up to `max` points, waiting up to `wait` (at most [`MAX_POLL_WAIT`]) for some
    /// if none is queued.
    fn serve_poll(
        &mut self,
        wid: String,
        mut reports: Vec<Report>,
        max: usize,
        wait: Duration,
        reply: Box<dyn PollReply>,
    ) {
        if !self.leases.heartbeat(&wid) {
            // An expired worker's results: their points were sent again to others. Late, not
            // alarming.
            if !reports.is_empty() {
                tracing::debug!(worker = %wid, results = reports.len(), "results of an expired worker ignored");
            }
            if let Some(m) = &self.metrics {
                reports.iter().for_each(|_| m.late_result());
            }
            reply.answer(vec![], false);
            return;
        }
        // More results than points leased to the worker and remembered as answered or given up
        // cannot all be true: the excess is ignored unread, so a forging worker costs a bounded
        // amount of work per poll (its true results past the cut are sent again on timeout).
        let most = self.leases.max_reports(&wid);
        if reports.len() > most {
            tracing::warn!(worker = %wid, results = reports.len(), most, "a poll carried more results than its worker holds points: the excess ignored");
            if let Some(m) = &self.metrics {
                (most..reports.len()).for_each(|_| m.ignored_result());
            }
            reports.truncate(most);
        }
        for r in reports {
            if !self.take_report(&wid, r) {
                break;
            }
        }
        let leases = self.assign(&wid, max);
        if !leases.is_empty() || max == 0 || wait.is_zero() {
            reply.answer(leases, true);
        } else {
            let deadline = Instant::now() + wait.min(MAX_POLL_WAIT);
            self.parking.park(wid, max, deadline, reply);
        }
    }

    /// Takes worker `wid`'s report on a point: only a point leased to it (and not taken back
    /// since) may be answered, so a token holder cannot report values for points it was never
    /// given. False if the worker is no longer registered.
    fn take_report(&mut self, wid: &str, report: Report) -> bool {
        let Report { job_id, point_id, outcome } = report;
        match self.leases.answer(wid, (job_id.clone(), point_id)) {
            Answer::UnknownWorker => return false,
            Answer::Late => {
                // A point taken back (its job ended, or it timed out and went to another
                // worker) is answered late: normal, so counted and logged at debug only.
                tracing::debug!(job = %job_id, point = point_id, worker = %wid, "late result for a point taken back ignored");
                if let Some(m) = &self.metrics {
                    m.late_result();
                }
                return true;
            }
            Answer::NeverLeased => {
                tracing::warn!(job = %job_id, point = point_id, worker = %wid, "result for a point never leased to this worker ignored");
                if let Some(m) = &self.metrics {
                    m.ignored_result();
                }
                return true;
            }
            Answer::Leased => {}
        }
        let evaluation = match outcome {
            Outcome::NotEvaluated => {
                self.hand_back(&job_id, point_id);
                return true;
            }
            Outcome::Evaluated(evaluation) => evaluation,
        };
        if evaluation.value.is_some() {
            let job = self.jobs.get(&job_id);
            let experiment = job.and_then(|j| j.batch.open.get(&point_id)).map(|p| p.experiment);
            let residuals = job.zip(experiment).and_then(|(j, k)| j.state.run.residual_count(k));
            if let Some(why) = impossible_result(&evaluation, residuals) {
                tracing::warn!(job = %job_id, point = point_id, worker = %wid, "impossible result refused: {why}");
                if let Some(m) = &self.metrics {
                    m.refused_result();
                }
                self.attempt_failed(&job_id, point_id, wid, &format!("the worker's result was refused: {why}"));
                return true;
            }
        }
        if let Some(m) = &self.metrics {
            let job = self.jobs.get(&job_id);
            let leased_at = job.and_then(|j| j.batch.open.get(&point_id)).and_then(|p| p.assigned.as_ref());
            m.result(evaluation.value.is_none(), leased_at.map(|(_, at)| at.elapsed()));
        }
        if evaluation.value.is_some() {
            self.tell(&job_id, point_id, evaluation);
        } else {
            let why = evaluation.error.unwrap_or_default();
            tracing::debug!(job = %job_id, point = point_id, worker = %wid, "simulation failed: {why}");
            self.attempt_failed(&job_id, point_id, wid, &why);
        }
        true
    }

    /// Leases up to `max` queued points to worker `wid` ([`Leases::assign`]).
    fn assign(&mut self, wid: &str, max: usize) -> Vec<Lease> {
        self.leases.assign(wid, max, self.jobs.open_batches())
    }

    /// Offers the queued points to the parked polls.
    fn wake_parked(&mut self) {
        let (jobs, leases) = (&mut self.jobs, &mut self.leases);
        self.parking.wake(|wid, max| leases.assign(wid, max, jobs.open_batches()));
    }

    /// Queues the optimizer's open candidates, or finishes the job when it asks for none.
    fn refill(&mut self, id: &str) -> Result<(), CoordinatorError> {
        let Some(job) = self.jobs.get_mut(id) else { return Ok(()) };
        if !job.is_running() {
            return Ok(());
        }
        let batch = job.state.run.ask();
        if batch.is_empty() {
            return self.finish(id, JobStatus::Succeeded, None);
        }
        job.batch.add(batch);
        self.wake_parked();
        Ok(())
    }

    /// Ends job `id` with `status`: its watchers are told, its leases taken back, its final
    /// state written.
    fn finish(&mut self, id: &str, status: JobStatus, why: Option<&str>) -> Result<(), CoordinatorError> {
        let Some(job) = self.jobs.finish(id, status, why) else { return Ok(()) };
        let write = persist::state_write(id, &job.state)?;
        let event = job.progress(0.0);
        for w in job.watchers.drain(..) {
            let _ = w.offer(&event);
        }
        self.leases.take_back_job(id);
        self.persist.finished(id, write);
        tracing::info!(job = %id, ?status, "job finished");
        Ok(())
    }

    /// Tells a point's evaluation; when it completes the round, reports progress, saves the
    /// state and asks the next round (or finishes the job).
    fn tell(&mut self, id: &str, point: u64, evaluation: Evaluation) {
        let Some(job) = self.jobs.get_mut(id) else { return };
        let Some(p) = job.batch.take(point) else { return };
        let told = job.state.run.tell(point, &p.x, &evaluation, job.batch.started.elapsed().as_secs_f64());
        self.persist.log(Told { job: id.to_owned(), point, x: p.x, evaluation });
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
        job.notify(&job.progress(round.batch_wall_s));
        if job.state.run.is_done() {
            if let Err(e) = self.finish(id, JobStatus::Succeeded, None) {
                tracing::error!(job = %id, "cannot save the result: {e}");
            }
            return;
        }
        self.persist.checkpoint(id, &job.state);
        if let Err(e) = self.refill(id) {
            tracing::error!(job = %id, "cannot continue: {e}");
        }
    }

    /// A worker handed a point back unevaluated: it is queued again, first in line, without
    /// counting as an attempt.
    fn hand_back(&mut self, id: &str, point: u64) {
        let Some(job) = self.jobs.get_mut(id) else { return };
        if job.batch.hand_back(point) {
            self.wake_parked();
        }
    }

    /// Sends `point` again without counting an attempt against it, unless it was already sent
    /// again so [`jobs::MAX_UNCHARGED_RETRIES`] times; says whether it was.
    fn retry_uncharged(&mut self, id: &str, point: u64) -> bool {
        let Some(job) = self.jobs.get_mut(id) else { return true };
        match job.batch.retry_uncharged(point) {
            Retry::Gone => true,
            Retry::Exhausted => false,
            Retry::Queued => {
                self.wake_parked();
                true
            }
        }
    }

    /// Records a failed attempt; the point is told as failed after two different workers (or
    /// three attempts), else queued again.
    fn attempt_failed(&mut self, id: &str, point: u64, worker: &str, why: &str) {
        let Some(job) = self.jobs.get_mut(id) else { return };
        match job.batch.attempt_failed(point, worker, why) {
            None => {}
            Some(Attempt::GiveUp(last_error)) => self.tell(id, point, Evaluation::failed(last_error)),
            Some(Attempt::Queued) => self.wake_parked(),
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
        if job.is_running() {
            if let Err(e) = self.finish(id, JobStatus::Failed, Some(&why)) {
                tracing::error!(job = %id, "{e}");
            }
        } else {
            job.state.status = JobStatus::Failed;
            job.state.error = Some(why);
            self.persist.save(id, &job.state);
        }
    }

    /// Forgets a finished job and deletes it from the store (after the writes queued before).
    fn forget(&mut self, id: &str) {
        self.jobs.remove(id);
        self.persist.delete(id);
        tracing::info!(job = %id, "job deleted");
    }

    /// Deletes the finished jobs past the retention cap ([`Jobs::expired`]).
    fn apply_retention(&mut self) {
        for id in self.jobs.expired() {
            self.forget(&id);
        }
    }

    fn on_tick(&mut self) {
        self.persist.flush_log();
        self.update_gauges();
        if self.jobs.retention_due() {
            self.apply_retention();
        }
        for failure in self.persist.failures() {
            for id in &failure.jobs {
                self.fail_unsaved(id, &failure.error);
            }
        }
        let now = Instant::now();
        // Expire silent workers; their points count as failed attempts on them.
        for wid in self.leases.silent(now, self.timing.worker_expiry) {
            let inflight = self.leases.remove(&wid).expect("listed above");
            tracing::warn!(worker = %wid, points = inflight.len(), "worker expired");
            // A worker that dies holding several points says nothing of which one killed it: each
            // is sent again uncharged, a few times, before the deaths count against it.
            let shared = inflight.len() > 1;
            for (job, point) in inflight {
                if shared && self.retry_uncharged(&job, point) {
                    continue;
                }
                self.attempt_failed(&job, point, &wid, "the worker stopped answering");
            }
        }
        // Re-send points past the evaluation timeout.
        for (id, pid, w) in self.jobs.overdue(now, self.timing.evaluation_timeout) {
            tracing::warn!(job = %id, point = pid, worker = %w, "evaluation timed out");
            self.leases.take_back(&w, (id.clone(), pid));
            self.attempt_failed(&id, pid, &w, "the evaluation timed out");
        }
        // Answer long polls that waited long enough.
        let leases = &self.leases;
        self.parking.expire(now, |w| leases.contains(w));
        self.wake_parked();
    }
}

/// Whether two points are the same, bit for bit.
fn same_bits(a: &[f64], b: &[f64]) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(u, v)| u.to_bits() == v.to_bits())
}

/// Checks `job` against its model and `data` ([`Submission::new`], and a stored job resumed).
fn check_job(
    models: &Mutex<ModelStore>,
    job: &JobSpec,
    data: &[MeasurementTable],
) -> Result<Arc<PreparedJob>, CoordinatorError> {
    let model_id = job.model.id.as_deref().unwrap_or_default();
    let described =
        models.lock().map_err(|_| CoordinatorError::Storage("model store poisoned".into()))?.describe(model_id)?;
    let prepared = PreparedJob::new(job, &described.description, &described.interfaces, data)?;
    Ok(Arc::new(prepared))
}
