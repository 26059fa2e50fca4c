//! gRPC handlers: check what the request alone allows (required fields, id lengths), convert it
//! at the service edge ([`crate::edge`]) into a [`Command`] for the scheduler, and convert its
//! answer back. They hold no state and no lock across an await; blocking work (checking a job,
//! storing a model) runs off the async threads.

use std::sync::{Arc, Mutex};

use fmucal_diagnose::spec::DiagnoseSpec;
use fmucal_proto::convert::SubmittedJob;
use fmucal_proto::v1 as pb;
use fmucal_shared::job::JobKind;
use tokio::io::AsyncWriteExt;
use tokio::sync::{mpsc, oneshot};
use tokio_stream::wrappers::ReceiverStream;
use tonic::{Request, Response, Status, Streaming};

use crate::diagnoses::Diagnoses;
use crate::edge;
use crate::error::CoordinatorError;
use crate::models::ModelStore;
use crate::scheduler::Command;

/// Largest model accepted by `UploadModel`.
pub const MAX_MODEL_BYTES: usize = 1 << 30;

/// Refuses an id longer than any id this coordinator hands out, naming `field`, before it is
/// looked up or quoted.
fn check_id(field: &str, id: &str) -> Result<(), Status> {
    if id.len() > fmucal_proto::MAX_ID_BYTES {
        return Err(Status::invalid_argument(format!(
            "{field}: {} is not an id (ids have at most {} bytes)",
            crate::error::quote(id),
            fmucal_proto::MAX_ID_BYTES
        )));
    }
    Ok(())
}

/// `id`, once [`check_id`] accepts it.
fn checked_id(field: &str, id: String) -> Result<String, Status> {
    check_id(field, &id)?;
    Ok(id)
}

/// Runs `f` on the model store (call from a blocking thread).
fn with_models<T>(
    models: &Mutex<ModelStore>,
    f: impl FnOnce(&mut ModelStore) -> Result<T, CoordinatorError>,
) -> Result<T, CoordinatorError> {
    let mut guard = models.lock().map_err(|_| CoordinatorError::Storage("model store poisoned".into()))?;
    f(&mut guard)
}

#[derive(Clone)]
pub struct Handlers {
    pub commands: mpsc::Sender<Command>,
    pub models: Arc<Mutex<ModelStore>>,
    /// The store's `models` folder, where uploads are streamed to.
    pub models_dir: std::path::PathBuf,
    pub diagnoses: Arc<Diagnoses>,
}

impl Handlers {
    async fn ask<T>(
        &self,
        make: impl FnOnce(oneshot::Sender<Result<T, CoordinatorError>>) -> Command,
    ) -> Result<T, Status> {
        let (tx, rx) = oneshot::channel();
        self.commands.send(make(tx)).await.map_err(|_| Status::unavailable("the coordinator is shutting down"))?;
        rx.await.map_err(|_| Status::unavailable("the coordinator is shutting down"))?.map_err(Status::from)
    }
}

#[tonic::async_trait]
impl pb::calibration_server::Calibration for Handlers {
    async fn upload_model(
        &self,
        req: Request<Streaming<pb::UploadModelRequest>>,
    ) -> Result<Response<pb::UploadModelResponse>, Status> {
        // Streamed to a temporary file in the store (removed unless accepted), cut off at the
        // per-model cap; the store's own cap is checked when the file is put. No lock is taken
        // here: the check of another upload may hold the store's.
        let mut stream = req.into_inner();
        let file = crate::models::upload_file(&self.models_dir);
        let limit = MAX_MODEL_BYTES as u64;
        let mut out = tokio::fs::File::create(file.path()).await.map_err(|e| Status::internal(e.to_string()))?;
        let mut written = 0u64;
        while let Some(m) = stream.message().await? {
            written += m.chunk.len() as u64;
            if written > limit {
                return Err(Status::invalid_argument(format!("chunk: the model exceeds {MAX_MODEL_BYTES} bytes")));
            }
            out.write_all(&m.chunk).await.map_err(|e| Status::internal(format!("cannot store the upload: {e}")))?;
        }
        out.flush().await.map_err(|e| Status::internal(format!("cannot store the upload: {e}")))?;
        drop(out);
        if written == 0 {
            return Err(Status::invalid_argument("chunk: no bytes were uploaded"));
        }
        let models = self.models.clone();
        let (model_id, model_name) = tokio::task::spawn_blocking(move || with_models(&models, |m| m.put_file(file)))
            .await
            .map_err(|e| Status::internal(e.to_string()))??;
        Ok(Response::new(pb::UploadModelResponse { model_id, model_name }))
    }

    async fn submit_job(&self, req: Request<pb::SubmitJobRequest>) -> Result<Response<pb::SubmitJobResponse>, Status> {
        let spec = req.into_inner().spec.ok_or_else(|| Status::invalid_argument("spec is required"))?;
        check_id("spec.model_id", &spec.model_id)?;
        // Checking the job (and unpacking a new model) is blocking work: keep it off the
        // scheduler task, which every other request waits on.
        let models = self.models.clone();
        let job = tokio::task::spawn_blocking(move || edge::submission(&models, &spec).map(Box::new))
            .await
            .map_err(|e| Status::internal(e.to_string()))??;
        let job_id = self.ask(|reply| Command::Submit { job, reply }).await?;
        Ok(Response::new(pb::SubmitJobResponse { job_id }))
    }

    type WatchJobStream = ReceiverStream<Result<pb::WatchJobResponse, Status>>;

    async fn watch_job(&self, req: Request<pb::WatchJobRequest>) -> Result<Response<Self::WatchJobStream>, Status> {
        let job_id = checked_id("job_id", req.into_inner().job_id)?;
        let (tx, rx): (edge::WatchSender, _) = mpsc::channel(1024);
        self.ask(|reply| Command::Watch { job_id, watcher: Box::new(tx), reply }).await?;
        Ok(Response::new(ReceiverStream::new(rx)))
    }

    async fn get_job(&self, req: Request<pb::GetJobRequest>) -> Result<Response<pb::GetJobResponse>, Status> {
        let job_id = checked_id("job_id", req.into_inner().job_id)?;
        let job = self.ask(|reply| Command::Get { job_id, reply }).await?;
        Ok(Response::new(edge::get_job_response(job)))
    }

    async fn cancel_job(&self, req: Request<pb::CancelJobRequest>) -> Result<Response<pb::CancelJobResponse>, Status> {
        let job_id = checked_id("job_id", req.into_inner().job_id)?;
        let status = self.ask(|reply| Command::Cancel { job_id, reply }).await?;
        Ok(Response::new(pb::CancelJobResponse { status: edge::status(status) }))
    }

    async fn delete_job(&self, req: Request<pb::DeleteJobRequest>) -> Result<Response<pb::DeleteJobResponse>, Status> {
        let job_id = checked_id("job_id", req.into_inner().job_id)?;
        self.ask(|reply| Command::Delete { job_id, reply }).await?;
        Ok(Response::new(pb::DeleteJobResponse {}))
    }

    async fn list_jobs(&self, _req: Request<pb::ListJobsRequest>) -> Result<Response<pb::ListJobsResponse>, Status> {
        let jobs = self.ask(|reply| Command::List { reply }).await?;
        Ok(Response::new(edge::list_jobs_response(jobs)))
    }

    type DiagnoseStream = ReceiverStream<Result<pb::DiagnoseResponse, Status>>;

    async fn diagnose(&self, req: Request<pb::DiagnoseRequest>) -> Result<Response<Self::DiagnoseStream>, Status> {
        let req = req.into_inner();
        let spec = req.spec.ok_or_else(|| Status::invalid_argument("spec is required"))?;
        let settings = req.settings.ok_or_else(|| Status::invalid_argument("settings is required"))?;
        let settings = DiagnoseSpec::try_from(settings).map_err(CoordinatorError::from)?;
        let job = SubmittedJob::try_from(spec).map_err(CoordinatorError::from)?;
        if !matches!(job.spec.kind, JobKind::Calibration) {
            return Err(Status::invalid_argument("spec.kind: a diagnosis starts from a calibration job"));
        }
        if !job.spec.experiments.is_empty() {
            return Err(Status::invalid_argument("spec.experiments: a diagnosis takes a job with one experiment"));
        }
        let models = self.models.clone();
        let id = job.spec.model.id.clone().unwrap_or_default();
        let model = tokio::task::spawn_blocking(move || with_models(&models, |m| m.archive(&id)))
            .await
            .map_err(|e| Status::internal(e.to_string()))??;
        let diagnoses = self.diagnoses.clone();
        // Writing the data file is blocking work.
        let events = tokio::task::spawn_blocking(move || diagnoses.start(job.spec, &job.data[0], settings, model))
            .await
            .map_err(|e| Status::internal(e.to_string()))??;
        Ok(Response::new(ReceiverStream::new(events)))
    }
}

#[tonic::async_trait]
impl pb::worker_pool_server::WorkerPool for Handlers {
    async fn register(&self, req: Request<pb::RegisterRequest>) -> Result<Response<pb::RegisterResponse>, Status> {
        let registration = edge::registration(req.into_inner())?;
        let registered = self.ask(|reply| Command::Register { registration, reply }).await?;
        Ok(Response::new(edge::register_response(registered)))
    }

    async fn heartbeat(&self, req: Request<pb::HeartbeatRequest>) -> Result<Response<pb::HeartbeatResponse>, Status> {
        let worker_id = checked_id("worker_id", req.into_inner().worker_id)?;
        let known = self.ask(|reply| Command::Heartbeat { worker_id, reply }).await?;
        Ok(Response::new(pb::HeartbeatResponse { known }))
    }

    type FetchModelStream = ReceiverStream<Result<pb::FetchModelResponse, Status>>;

    async fn fetch_model(
        &self,
        req: Request<pb::FetchModelRequest>,
    ) -> Result<Response<Self::FetchModelStream>, Status> {
        let id = checked_id("model_id", req.into_inner().model_id)?;
        let models = self.models.clone();
        let bytes = tokio::task::spawn_blocking(move || with_models(&models, |m| m.bytes(&id)))
            .await
            .map_err(|e| Status::internal(e.to_string()))??;
        let (tx, rx) = mpsc::channel(4);
        tokio::spawn(async move {
            for chunk in bytes.chunks(fmucal_proto::MODEL_CHUNK_BYTES) {
                if tx.send(Ok(pb::FetchModelResponse { chunk: chunk.to_vec() })).await.is_err() {
                    break;
                }
            }
        });
        Ok(Response::new(ReceiverStream::new(rx)))
    }

    async fn fetch_job(&self, req: Request<pb::FetchJobRequest>) -> Result<Response<pb::FetchJobResponse>, Status> {
        let job_id = checked_id("job_id", req.into_inner().job_id)?;
        let sent = self.ask(|reply| Command::FetchJob { job_id: job_id.clone(), reply }).await?;
        Ok(Response::new(edge::fetch_job_response(&job_id, &sent)?))
    }

    async fn poll_work(&self, req: Request<pb::PollWorkRequest>) -> Result<Response<pb::PollWorkResponse>, Status> {
        let req = req.into_inner();
        if req.worker_id.is_empty() {
            return Err(Status::invalid_argument("worker_id is required"));
        }
        check_id("worker_id", &req.worker_id)?;
        for (k, r) in req.results.iter().enumerate() {
            check_id(&format!("results[{k}].job_id"), &r.job_id)?;
        }
        let req = edge::poll_request(req);
        let (tx, rx) = oneshot::channel();
        self.commands.send(Command::Poll { req, reply: tx }).await.map_err(|_| Status::unavailable("shutting down"))?;
        let answer = rx.await.map_err(|_| Status::unavailable("shutting down"))?;
        Ok(Response::new(edge::poll_work_response(answer)))
    }
}
