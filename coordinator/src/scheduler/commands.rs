//! The scheduler's commands: one method per [`Command`](super::Command), each calling the
//! domain methods of the scheduler's parts, and the plain values those commands take and
//! answer ([`Submission`], [`JobView`], [`JobSummary`], [`Registration`], [`Registered`],
//! [`PollRequest`], [`PollAnswer`]). No protobuf here: the service edge ([`crate::edge`])
//! converts the gRPC messages into these values and their answers back, so the state machine
//! is driven and tested without proto.
//!
//! The job as it was sent is the one protocol value the scheduler keeps, and it keeps it as
//! opaque bytes (its encoding, made at the edge): stored as they are (so a store written before
//! still reads), handed as they are to a worker that fetches the job, and read back through the
//! edge when a stored job is resumed.

use std::sync::Mutex;
use std::time::Duration;

use fmucal_shared::job::{CalibrationResult, JobRun, JobSpec, JobStatus, MeasurementTable};
use fmucal_shared::optim::Optimizer;
use tokio::sync::oneshot;

use super::jobs::{Job, Watcher};
use super::leases::{Lease, Report};
use super::parking::PollReply;
use super::{Scheduler, no_job};
use crate::error::CoordinatorError;
use crate::models::ModelStore;

/// A job ready for the scheduler: checked against its model, and its run built, off the
/// scheduler task ([`Submission::new`]).
pub struct Submission {
    /// The job as it was sent, encoded (opaque to the scheduler): stored as it is, and handed
    /// to the workers that fetch the job.
    pub sent: Vec<u8>,
    /// The job as read.
    pub job: JobSpec,
    pub run: JobRun,
}

impl Submission {
    /// Checks `job` against its model and `data` and builds its run: blocking work, linear in
    /// the size of the job (whose sizes [`fmucal_shared::job::limits`] caps). The handlers call
    /// it before a job reaches the scheduler task, so a large or bad request never holds that
    /// task up. `sent` is the job as it was sent.
    ///
    /// # Errors
    /// INVALID_ARGUMENT naming the field; NOT_FOUND-like INVALID_ARGUMENT for an unknown model.
    pub fn new(
        models: &Mutex<ModelStore>,
        sent: Vec<u8>,
        job: &JobSpec,
        data: &[MeasurementTable],
    ) -> Result<Self, CoordinatorError> {
        let prepared = super::check_job(models, job, data)?;
        let run = JobRun::new(&prepared).map_err(|e| CoordinatorError::InvalidArgument(e.to_string()))?;
        Ok(Submission { sent, job: prepared.spec.clone(), run })
    }
}

/// A job as [`Command::Get`](super::Command::Get) tells it.
#[derive(Debug, Clone, PartialEq)]
pub struct JobView {
    pub job_id: String,
    pub status: JobStatus,
    /// The job's calibrated parameters, in order (the order of a point's x).
    pub names: Vec<String>,
    /// Its result, once it ended.
    pub result: Option<CalibrationResult>,
    /// Why it failed, or what keeps it from going on.
    pub error: Option<String>,
}

/// A job as [`Command::List`](super::Command::List) lists it.
#[derive(Debug, Clone, PartialEq)]
pub struct JobSummary {
    pub job_id: String,
    pub status: JobStatus,
    /// The best value so far (+inf before any point succeeded).
    pub best_f: f64,
    pub evaluations: u64,
}

/// A worker's registration ([`Command::Register`](super::Command::Register)), its protocol
/// version checked already.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Registration {
    /// The name it chose (cut and cleaned into its id).
    pub name: String,
    /// Points it evaluates at once: 1 to [`fmucal_proto::MAX_SLOTS`].
    pub slots: u32,
}

/// What a registered worker is told.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Registered {
    pub worker_id: String,
    /// How often it must heartbeat.
    pub heartbeat_interval: Duration,
    /// How long a point may take before it is sent to another worker.
    pub evaluation_timeout: Duration,
}

/// A worker's poll ([`Command::Poll`](super::Command::Poll)): its reports on the points it
/// held, and how many more it takes.
#[derive(Debug, Clone, PartialEq)]
pub struct PollRequest {
    pub worker_id: String,
    pub reports: Vec<Report>,
    /// Points it takes at most.
    pub max: usize,
    /// How long it waits for points if none is queued (at most 10 s).
    pub wait: Duration,
}

/// The answer to a poll: the points leased to the worker, and whether it is still registered.
#[derive(Debug, Clone, PartialEq)]
pub struct PollAnswer {
    pub leases: Vec<Lease>,
    pub known: bool,
}

impl PollReply for oneshot::Sender<PollAnswer> {
    fn answer(self: Box<Self>, leases: Vec<Lease>, known: bool) {
        let _ = (*self).send(PollAnswer { leases, known });
    }

    fn gone(&self) -> bool {
        self.is_closed()
    }
}

impl Scheduler {
    /// [`Command::Submit`](super::Command::Submit): the job is kept as it was sent.
    pub(super) fn submit(&mut self, s: Submission) -> Result<String, CoordinatorError> {
        self.add_job(s.sent, s.job, s.run)
    }

    /// [`Command::Get`](super::Command::Get).
    pub(super) fn get(&self, job_id: &str) -> Result<JobView, CoordinatorError> {
        let j = self.jobs.get(job_id).ok_or_else(|| no_job(job_id))?;
        Ok(JobView {
            job_id: job_id.to_owned(),
            status: j.state.status,
            names: j.job.parameter_vectors().0,
            result: j.state.result.clone(),
            error: j.state.error.clone(),
        })
    }

    /// [`Command::List`](super::Command::List): the newest first.
    pub(super) fn list(&self) -> Result<Vec<JobSummary>, CoordinatorError> {
        let mut jobs: Vec<(&String, &Job)> = self.jobs.iter().collect();
        jobs.sort_by_key(|(_, j)| std::cmp::Reverse(j.state.seq));
        Ok(jobs
            .into_iter()
            .map(|(id, j)| JobSummary {
                job_id: id.clone(),
                status: j.state.status,
                best_f: j.state.run.best_f(),
                evaluations: j.state.run.optimizer().evaluations(),
            })
            .collect())
    }

    /// [`Command::Cancel`](super::Command::Cancel): the job's status after.
    pub(super) fn cancel(&mut self, job_id: &str) -> Result<JobStatus, CoordinatorError> {
        self.cancel_job(job_id)
    }

    /// [`Command::Delete`](super::Command::Delete).
    pub(super) fn delete(&mut self, job_id: &str) -> Result<(), CoordinatorError> {
        self.delete_job(job_id)
    }

    /// [`Command::Watch`](super::Command::Watch).
    pub(super) fn watch(&mut self, job_id: &str, watcher: Box<dyn Watcher>) -> Result<(), CoordinatorError> {
        self.watch_job(job_id, watcher)
    }

    /// [`Command::Register`](super::Command::Register): checks the worker's slots.
    pub(super) fn register(&mut self, r: &Registration) -> Result<Registered, CoordinatorError> {
        if r.slots == 0 || r.slots > fmucal_proto::MAX_SLOTS {
            return Err(CoordinatorError::InvalidArgument(format!(
                "slots: a worker has 1 to {} slots, not {}",
                fmucal_proto::MAX_SLOTS,
                r.slots
            )));
        }
        let worker_id = self.leases.register(&r.name, r.slots as usize);
        Ok(Registered {
            worker_id,
            heartbeat_interval: self.timing.heartbeat_interval,
            evaluation_timeout: self.timing.evaluation_timeout,
        })
    }

    /// [`Command::Heartbeat`](super::Command::Heartbeat): whether the worker is still registered.
    pub(super) fn heartbeat(&mut self, worker_id: &str) -> Result<bool, CoordinatorError> {
        Ok(self.leases.heartbeat(worker_id))
    }

    /// [`Command::FetchJob`](super::Command::FetchJob): the job as it was sent, encoded.
    pub(super) fn fetch_job(&self, job_id: &str) -> Result<Vec<u8>, CoordinatorError> {
        let j = self.jobs.get(job_id).ok_or_else(|| no_job(job_id))?;
        Ok(j.sent.clone())
    }

    /// [`Command::Poll`](super::Command::Poll): answered now, or parked until points are
    /// queued or its wait is over.
    pub(super) fn poll(&mut self, req: PollRequest, reply: oneshot::Sender<PollAnswer>) {
        self.serve_poll(req.worker_id, req.reports, req.max, req.wait, Box::new(reply));
    }
}
