//! The service edge: every conversion between the gRPC messages (`fmucal.v1`) and the
//! scheduler's domain values ([`crate::scheduler`]), one function per message and direction,
//! so that the scheduler knows nothing of protobuf. The handlers ([`crate::services`]) convert
//! a request here into a [`Command`](crate::scheduler::Command)'s values and its answer back.
//!
//! The job as it was sent is encoded here, for the scheduler to keep as opaque bytes (stored as
//! they are, so a store written before still reads and the same bytes are written), and decoded
//! here: for a worker that fetches the job, and when a stored job is read back.
//!
//! What only the protocol knows is checked here too: a worker's protocol version.

use std::sync::Mutex;
use std::time::Duration;

use fmucal_proto::convert::{ConvertError, SubmittedJob, evaluation_from_proto, result_to_proto};
use fmucal_proto::v1 as pb;
use fmucal_shared::job::JobStatus;
use prost::Message;
use tokio::sync::mpsc;

use crate::error::CoordinatorError;
use crate::models::ModelStore;
use crate::scheduler::{
    JobSummary, JobView, Lease, Outcome, PollAnswer, PollRequest, Progress, Registered, Registration, Report,
    Submission, Watcher,
};

/// The stream a client watches a job on.
pub type WatchSender = mpsc::Sender<Result<pb::WatchJobResponse, tonic::Status>>;

/// The protocol's number for `status`.
pub fn status(status: JobStatus) -> i32 {
    pb::JobStatus::from(status) as i32
}

/// A submitted job ready for the scheduler: read, checked against its model and data, its run
/// built ([`Submission::new`]), and kept as it was sent, encoded. Blocking work: call it off
/// the scheduler task.
///
/// # Errors
/// INVALID_ARGUMENT naming the field; NOT_FOUND-like INVALID_ARGUMENT for an unknown model.
pub fn submission(models: &Mutex<ModelStore>, spec: &pb::JobSpec) -> Result<Submission, CoordinatorError> {
    let submitted = SubmittedJob::try_from(spec.clone())?;
    Submission::new(models, spec.encode_to_vec(), &submitted.spec, &submitted.data)
}

/// A stored job read back from the bytes it was sent as (bytes that do not decode read as an
/// empty job, which names what it misses).
///
/// # Errors
/// What the job misses or has wrong.
pub fn read_sent(sent: &[u8]) -> Result<SubmittedJob, ConvertError> {
    SubmittedJob::try_from(pb::JobSpec::decode(sent).unwrap_or_default())
}

/// `FetchJob`'s answer: job `job_id` as it was `sent`.
///
/// # Errors
/// A storage error if the stored bytes do not decode.
pub fn fetch_job_response(job_id: &str, sent: &[u8]) -> Result<pb::FetchJobResponse, CoordinatorError> {
    let spec = pb::JobSpec::decode(sent)
        .map_err(|e| CoordinatorError::Storage(format!("job {job_id}: its spec does not decode: {e}")))?;
    Ok(pb::FetchJobResponse { spec: Some(spec) })
}

/// `GetJob`'s answer.
pub fn get_job_response(v: JobView) -> pb::GetJobResponse {
    pb::GetJobResponse {
        status: status(v.status),
        result: v.result.as_ref().map(|r| result_to_proto(r, &v.names)),
        error: v.error.unwrap_or_default(),
        job_id: v.job_id,
    }
}

/// `ListJobs`' answer.
pub fn list_jobs_response(jobs: Vec<JobSummary>) -> pb::ListJobsResponse {
    let jobs = jobs
        .into_iter()
        .map(|j| pb::JobSummary {
            job_id: j.job_id,
            status: status(j.status),
            best_f: j.best_f,
            evaluations: j.evaluations,
        })
        .collect();
    pb::ListJobsResponse { jobs }
}

/// A watcher's event.
pub fn watch_job_response(p: &Progress) -> pb::WatchJobResponse {
    pb::WatchJobResponse {
        iteration: p.iteration,
        evaluations: p.evaluations,
        best_f: p.best_f,
        best_x: p.best_x.clone(),
        batch_wall_s: p.batch_wall_s,
        status: status(p.status),
        rounds: p.rounds,
    }
}

impl Watcher for WatchSender {
    fn offer(&self, progress: &Progress) -> bool {
        self.try_send(Ok(watch_job_response(progress))).is_ok()
    }

    fn gone(&self) -> bool {
        self.is_closed()
    }
}

/// A worker's registration, once its protocol version is this coordinator's.
///
/// # Errors
/// INVALID_ARGUMENT naming `protocol_version` for another version.
pub fn registration(req: pb::RegisterRequest) -> Result<Registration, CoordinatorError> {
    if req.protocol_version != fmucal_proto::PROTOCOL_VERSION {
        return Err(CoordinatorError::InvalidArgument(format!(
            "protocol_version: worker speaks {}, coordinator speaks {}",
            req.protocol_version,
            fmucal_proto::PROTOCOL_VERSION
        )));
    }
    Ok(Registration { name: req.name, slots: req.slots })
}

/// `Register`'s answer.
pub fn register_response(r: Registered) -> pb::RegisterResponse {
    pb::RegisterResponse {
        worker_id: r.worker_id,
        heartbeat_interval_ms: r.heartbeat_interval.as_millis() as u64,
        evaluation_timeout_ms: r.evaluation_timeout.as_millis() as u64,
    }
}

/// A worker's result as a report: handed back, or evaluated (a status other than OK is a
/// failed simulation, its message the reason).
pub fn report(r: pb::PointResult) -> Report {
    let outcome = if r.status == pb::PointStatus::NotEvaluated as i32 {
        Outcome::NotEvaluated
    } else {
        Outcome::Evaluated(evaluation_from_proto(&r))
    };
    Report { job_id: r.job_id, point_id: r.point_id, outcome }
}

/// A worker's poll.
pub fn poll_request(req: pb::PollWorkRequest) -> PollRequest {
    PollRequest {
        reports: req.results.into_iter().map(report).collect(),
        max: req.max_points as usize,
        wait: Duration::from_millis(u64::from(req.wait_ms)),
        worker_id: req.worker_id,
    }
}

/// A point leased, as it is handed out.
pub fn assignment(l: Lease) -> pb::Assignment {
    pb::Assignment {
        job_id: l.job_id,
        point_id: l.point_id,
        x: l.x,
        want_residuals: l.want_residuals,
        experiment: u32::try_from(l.experiment).unwrap_or(u32::MAX),
    }
}

/// `PollWork`'s answer.
pub fn poll_work_response(a: PollAnswer) -> pb::PollWorkResponse {
    pb::PollWorkResponse { assignments: a.leases.into_iter().map(assignment).collect(), known: a.known }
}
