//! The scheduler's protobuf edge: one method per [`Command`](super::Command), each converting
//! its request into the domain calls of the scheduler's parts and their answers back into
//! protocol messages. Only this module (and the `Command` enum with its `WatchSender`) names
//! protobuf types, so the parts are tested without them.
//!
//! The job as it was sent is the one protobuf value the scheduler keeps, and it keeps it
//! encoded: it is stored as those bytes (so a store written before still reads) and decoded
//! here for a worker that fetches the job, or when a stored job is read back.

use std::sync::{Arc, Mutex};
use std::time::Duration;

use fmucal_proto::convert::{ConvertError, SubmittedJob, evaluation_from_proto, result_to_proto};
use fmucal_proto::v1 as pb;
use fmucal_shared::job::{JobRun, JobSpec, JobStatus, PreparedJob};
use fmucal_shared::optim::Optimizer;
use prost::Message;
use tokio::sync::oneshot;

use super::jobs::{Job, Progress, Watcher};
use super::leases::{Lease, Outcome, Report};
use super::parking::PollReply;
use super::{Scheduler, WatchSender, no_job};
use crate::error::CoordinatorError;
use crate::models::ModelStore;

/// The protocol's number for `status`.
fn wire(status: JobStatus) -> i32 {
    pb::JobStatus::from(status) as i32
}

fn progress_to_proto(p: &Progress) -> pb::WatchJobResponse {
    pb::WatchJobResponse {
        iteration: p.iteration,
        evaluations: p.evaluations,
        best_f: p.best_f,
        best_x: p.best_x.clone(),
        batch_wall_s: p.batch_wall_s,
        status: wire(p.status),
        rounds: p.rounds,
    }
}

fn assignment(l: Lease) -> pb::Assignment {
    pb::Assignment {
        job_id: l.job_id,
        point_id: l.point_id,
        x: l.x,
        want_residuals: l.want_residuals,
        experiment: u32::try_from(l.experiment).unwrap_or(u32::MAX),
    }
}

/// A worker's result as a report: handed back, or evaluated (a status other than OK is a
/// failed simulation, its message the reason).
fn report(r: pb::PointResult) -> Report {
    let outcome = if r.status == pb::PointStatus::NotEvaluated as i32 {
        Outcome::NotEvaluated
    } else {
        Outcome::Evaluated(evaluation_from_proto(&r))
    };
    Report { job_id: r.job_id, point_id: r.point_id, outcome }
}

impl Watcher for WatchSender {
    fn offer(&self, progress: &Progress) -> bool {
        self.try_send(Ok(progress_to_proto(progress))).is_ok()
    }

    fn gone(&self) -> bool {
        self.is_closed()
    }
}

impl PollReply for oneshot::Sender<pb::PollWorkResponse> {
    fn answer(self: Box<Self>, leases: Vec<Lease>, known: bool) {
        let assignments = leases.into_iter().map(assignment).collect();
        let _ = (*self).send(pb::PollWorkResponse { assignments, known });
    }

    fn gone(&self) -> bool {
        self.is_closed()
    }
}

/// A stored job read back from the bytes it was sent as (bytes that do not decode read as an
/// empty job, which names what it misses).
pub(super) fn read_sent(sent: &[u8]) -> Result<SubmittedJob, ConvertError> {
    SubmittedJob::try_from(pb::JobSpec::decode(sent).unwrap_or_default())
}

/// Checks a submitted job against its model and data: blocking work, linear in the size of the
/// job (whose sizes [`fmucal_shared::job::limits`] caps). The handlers call it before a job
/// reaches the scheduler task, so a large or bad request never holds that task up.
///
/// # Errors
/// INVALID_ARGUMENT naming the field; NOT_FOUND-like INVALID_ARGUMENT for an unknown model.
pub fn prepare(models: &Mutex<ModelStore>, spec: &pb::JobSpec) -> Result<Arc<PreparedJob>, CoordinatorError> {
    let submitted = SubmittedJob::try_from(spec.clone())?;
    super::check_job(models, &submitted.spec, &submitted.data)
}

impl Scheduler {
    /// [`Command::Submit`](super::Command::Submit): the job is kept as it was sent, encoded.
    pub(super) fn submit(&mut self, spec: pb::JobSpec, job: JobSpec, run: JobRun) -> Result<String, CoordinatorError> {
        self.add_job(spec.encode_to_vec(), job, run)
    }

    /// [`Command::Get`](super::Command::Get).
    pub(super) fn get(&self, job_id: &str) -> Result<pb::GetJobResponse, CoordinatorError> {
        let j = self.jobs.get(job_id).ok_or_else(|| no_job(job_id))?;
        Ok(pb::GetJobResponse {
            job_id: job_id.to_owned(),
            status: wire(j.state.status),
            result: j.state.result.as_ref().map(|r| result_to_proto(r, &j.job.parameter_vectors().0)),
            error: j.state.error.clone().unwrap_or_default(),
        })
    }

    /// [`Command::List`](super::Command::List): the newest first.
    pub(super) fn list(&self) -> Result<pb::ListJobsResponse, CoordinatorError> {
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
        Ok(pb::ListJobsResponse { jobs })
    }

    /// [`Command::Cancel`](super::Command::Cancel): the job's status after.
    pub(super) fn cancel(&mut self, job_id: &str) -> Result<i32, CoordinatorError> {
        self.cancel_job(job_id).map(wire)
    }

    /// [`Command::Delete`](super::Command::Delete).
    pub(super) fn delete(&mut self, job_id: &str) -> Result<(), CoordinatorError> {
        self.delete_job(job_id)
    }

    /// [`Command::Watch`](super::Command::Watch).
    pub(super) fn watch(&mut self, job_id: &str, tx: WatchSender) -> Result<(), CoordinatorError> {
        self.watch_job(job_id, Box::new(tx))
    }

    /// [`Command::Register`](super::Command::Register): checks the worker's protocol version
    /// and slots.
    pub(super) fn register(&mut self, req: &pb::RegisterRequest) -> Result<pb::RegisterResponse, CoordinatorError> {
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
        let worker_id = self.leases.register(&req.name, req.slots as usize);
        Ok(pb::RegisterResponse {
            worker_id,
            heartbeat_interval_ms: self.timing.heartbeat_interval.as_millis() as u64,
            evaluation_timeout_ms: self.timing.evaluation_timeout.as_millis() as u64,
        })
    }

    /// [`Command::Heartbeat`](super::Command::Heartbeat): whether the worker is still registered.
    pub(super) fn heartbeat(&mut self, worker_id: &str) -> Result<bool, CoordinatorError> {
        Ok(self.leases.heartbeat(worker_id))
    }

    /// [`Command::FetchJob`](super::Command::FetchJob): the job as it was sent.
    pub(super) fn fetch_job(&self, job_id: &str) -> Result<pb::JobSpec, CoordinatorError> {
        let j = self.jobs.get(job_id).ok_or_else(|| no_job(job_id))?;
        pb::JobSpec::decode(j.sent.as_slice())
            .map_err(|e| CoordinatorError::Storage(format!("job {job_id}: its spec does not decode: {e}")))
    }

    /// [`Command::Poll`](super::Command::Poll): answered now, or parked until points are
    /// queued or its wait is over.
    pub(super) fn poll(&mut self, req: pb::PollWorkRequest, reply: oneshot::Sender<pb::PollWorkResponse>) {
        let reports = req.results.into_iter().map(report).collect();
        let wait = Duration::from_millis(u64::from(req.wait_ms));
        self.serve_poll(req.worker_id, reports, req.max_points as usize, wait, Box::new(reply));
    }
}
