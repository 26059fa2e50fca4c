//! The CLI's gRPC client of a coordinator: connects (retrying while a coordinator started a
//! moment ago does not listen yet), uploads the model and submits jobs, follows a job's
//! `WatchJob` stream (a calibration with a progress bar), and runs given points on the workers
//! as a job that evaluates them (a run's follow-up points on `--coordinator`).

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use anyhow::{Context, Result, bail};
use fmucal_proto::auth::AttachToken;
use fmucal_proto::convert::{job_to_proto, result_from_proto};
use fmucal_proto::tls::ClientTls;
use fmucal_proto::v1 as pb;
use fmucal_proto::v1::calibration_client::CalibrationClient;
use fmucal_shared::job::{CalibrationResult, EvaluatedPoint, HistoryPoint, JobSpec, MeasurementTable};
use tonic::service::interceptor::InterceptedService;
use tonic::transport::Channel;

/// Where `calibrate` and `diagnose` run: a coordinator already running (`--coordinator URL`,
/// with its token and TLS settings), else a local cluster they start themselves.
#[derive(clap::Args, Debug, Default)]
pub struct RemoteArgs {
    /// Run on a running coordinator (its workers simulate) instead of starting one.
    #[arg(long)]
    pub coordinator: Option<String>,
    /// Token file for --coordinator (else FMUCAL_TOKEN).
    #[arg(long)]
    pub token_file: Option<PathBuf>,
    #[command(flatten)]
    pub tls: super::tls::ClientArgs,
}

impl RemoteArgs {
    /// Refuses a `--coordinator` that is no http:// or https:// URL with a host, before
    /// anything runs.
    ///
    /// # Errors
    /// One line naming `--coordinator`.
    pub fn check(&self) -> Result<()> {
        match &self.coordinator {
            Some(url) => check_url("--coordinator", url),
            None => Ok(()),
        }
    }

    /// A client of `--coordinator` with the token and TLS settings; `None` for a local run.
    ///
    /// # Errors
    /// An unreadable token or certificate, or a coordinator that cannot be reached.
    pub async fn connect(&self) -> Result<Option<Client>> {
        let Some(url) = &self.coordinator else { return Ok(None) };
        let token = super::token::load(self.token_file.as_deref())?;
        Ok(Some(Client::connect(url, token.as_deref(), self.tls.load()?.as_ref()).await?))
    }
}

/// Checks a coordinator URL given in `flag`: `http://` or `https://` and a host.
///
/// # Errors
/// In one line naming the flag and quoting the URL.
pub fn check_url(flag: &str, url: &str) -> Result<()> {
    let rest = url.strip_prefix("http://").or_else(|| url.strip_prefix("https://"));
    match rest {
        Some(host) if !host.is_empty() && !host.starts_with('/') => Ok(()),
        Some(_) => bail!("{flag}: {} names no host", fmucal_shared::quote::quote_user_text(url)),
        None => bail!(
            "{flag}: {} is not an http:// or https:// URL of a coordinator",
            fmucal_shared::quote::quote_user_text(url)
        ),
    }
}

/// A connection to a coordinator, with the token attached to every call. Clones share the
/// connection, so one client can follow several jobs at once.
#[derive(Clone)]
pub struct Client {
    inner: CalibrationClient<InterceptedService<Channel, AttachToken>>,
    /// Every job this client and its clones submitted, for [`Client::cancel_submitted`].
    submitted: Arc<Mutex<Vec<String>>>,
    /// Model ids by file, for [`Client::upload`].
    uploaded: Arc<Mutex<HashMap<PathBuf, String>>>,
}

impl Client {
    /// Connects to the coordinator at `url` (TLS for `https://`), retrying for about five
    /// seconds.
    pub async fn connect(url: &str, token: Option<&str>, tls: Option<&ClientTls>) -> Result<Self> {
        let attach = AttachToken::new(token).map_err(anyhow::Error::msg)?;
        let endpoint = fmucal_proto::tls::endpoint(url, tls).map_err(anyhow::Error::msg)?;
        // A coordinator started a moment ago may not listen yet: retry for a few seconds.
        let mut attempt = 0;
        let channel = loop {
            match endpoint.connect().await {
                Ok(ch) => break ch,
                Err(e) if attempt >= 25 => {
                    return Err(anyhow::Error::new(e).context(format!("cannot reach the coordinator at {url}")));
                }
                Err(_) => {
                    attempt += 1;
                    tokio::time::sleep(Duration::from_millis(200)).await;
                }
            }
        };
        let inner = CalibrationClient::with_interceptor(channel, attach)
            .max_encoding_message_size(fmucal_proto::MAX_MESSAGE_BYTES)
            .max_decoding_message_size(fmucal_proto::MAX_MESSAGE_BYTES);
        Ok(Client { inner, submitted: Arc::default(), uploaded: Arc::default() })
    }

    /// Submits a calibration, shows its progress, and returns its result (without errors or
    /// identifiability, which are computed afterwards).
    pub async fn calibrate(
        &mut self,
        spec: &JobSpec,
        data: &[MeasurementTable],
        model: &Path,
    ) -> Result<CalibrationResult> {
        let bar = indicatif::ProgressBar::new_spinner();
        bar.set_style(
            indicatif::ProgressStyle::with_template("{spinner} {elapsed_precise} {msg}").expect("valid template"),
        );
        bar.enable_steady_tick(Duration::from_millis(200));
        let result = self
            .calibrate_with(spec, data, model, |ev| {
                bar.set_message(format!(
                    "iteration {}  evaluations {}  best f {:.6e}",
                    ev.iteration, ev.evaluations, ev.best_f
                ))
            })
            .await;
        bar.finish_and_clear();
        result
    }

    /// Submits a calibration, hands each progress event to `on_event`, and returns its result.
    pub async fn calibrate_with(
        &mut self,
        spec: &JobSpec,
        data: &[MeasurementTable],
        model: &Path,
        mut on_event: impl FnMut(&pb::WatchJobResponse),
    ) -> Result<CalibrationResult> {
        let job_id = self.submit(spec, data, model).await?;
        let mut history = vec![];
        let job = self
            .wait_for_end(&job_id, |ev| {
                on_event(ev);
                if ev.batch_wall_s > 0.0 {
                    history.push(HistoryPoint {
                        round: ev.rounds,
                        evaluations: ev.evaluations,
                        best_f: ev.best_f,
                        batch_wall_s: ev.batch_wall_s,
                        best_x: ev.best_x.clone(),
                    });
                }
            })
            .await?;
        if job.status == pb::JobStatus::Failed as i32 {
            bail!("the job failed: {}", job.error);
        }
        let r = job.result.context("the coordinator returned no result")?;
        Ok(result_from_proto(r, history))
    }

    /// Evaluates `points` of `spec` on the workers (one job that evaluates them), with their
    /// residual vectors, in the order given.
    pub async fn evaluate(
        &mut self,
        spec: &JobSpec,
        points: Vec<Vec<f64>>,
        data: &[MeasurementTable],
        model: &Path,
    ) -> Result<Vec<EvaluatedPoint>> {
        let job_id = self.submit(&spec.evaluating_points(points), data, model).await?;
        let r = self.wait_for_end(&job_id, |_| {}).await?;
        if r.status == pb::JobStatus::Failed as i32 {
            bail!("the job failed: {}", r.error);
        }
        Ok(r.result.map(|r| result_from_proto(r, vec![]).evaluated).unwrap_or_default())
    }

    /// Names `model` on the coordinator by `id`, without uploading it: for a model the
    /// coordinator was given otherwise (a local run's, registered in-process).
    pub fn registered(self, model: &Path, id: String) -> Self {
        self.uploaded.lock().expect("not poisoned").insert(model.to_owned(), id);
        self
    }

    /// The id of `model` on the coordinator: uploaded on first use by this client or a clone
    /// (the coordinator keeps uploads on disk), so a diagnosis's dozens of jobs send it once.
    async fn upload(&mut self, model: &Path) -> Result<String> {
        if let Some(id) = self.uploaded.lock().expect("not poisoned").get(model) {
            return Ok(id.clone());
        }
        let bytes = std::fs::read(model)?;
        let chunks: Vec<pb::UploadModelRequest> = bytes
            .chunks(fmucal_proto::MODEL_CHUNK_BYTES)
            .map(|c| pb::UploadModelRequest { chunk: c.to_vec() })
            .collect();
        let model_id = self
            .inner
            .upload_model(tokio_stream::iter(chunks))
            .await
            .context("uploading the model")?
            .into_inner()
            .model_id;
        self.uploaded.lock().expect("not poisoned").insert(model.to_owned(), model_id.clone());
        Ok(model_id)
    }

    /// Uploads the model (once, [`Client::upload`]) and submits the job.
    async fn submit(&mut self, spec: &JobSpec, data: &[MeasurementTable], model: &Path) -> Result<String> {
        let model_id = self.upload(model).await?;
        let job_id = self
            .inner
            .submit_job(pb::SubmitJobRequest { spec: Some(job_to_proto(spec, data, &model_id)) })
            .await
            .map_err(|s| anyhow::anyhow!("the coordinator rejected the job: {}", s.message()))?
            .into_inner()
            .job_id;
        self.submitted.lock().expect("not poisoned").push(job_id.clone());
        record_job(&job_id);
        Ok(job_id)
    }

    /// Stops the calibration this client (or a clone) submitted first, as Ctrl-C does: cancels
    /// every job it submitted and returns the calibration's best point so far (`None` if none
    /// was submitted yet), with termination `interrupted`.
    pub async fn interrupt(&mut self) -> Result<Option<CalibrationResult>> {
        let first = self.submitted.lock().expect("not poisoned").first().cloned();
        self.cancel_submitted().await;
        let Some(job_id) = first else { return Ok(None) };
        let r = self.inner.get_job(pb::GetJobRequest { job_id }).await?.into_inner();
        Ok(r.result.map(|r| CalibrationResult { termination: "interrupted".into(), ..result_from_proto(r, vec![]) }))
    }

    /// Cancels every job this client or a clone submitted that has not ended; returns how many
    /// it stopped. For a client that gives up (a diagnosis stopped midway), so its jobs do not
    /// keep the workers busy. Cancelling a job that has ended changes nothing and answers its
    /// final status.
    pub async fn cancel_submitted(&mut self) -> usize {
        let ids = std::mem::take(&mut *self.submitted.lock().expect("not poisoned"));
        let mut stopped = 0;
        for job_id in ids {
            let status = self.inner.cancel_job(pb::CancelJobRequest { job_id }).await.map(|r| r.into_inner().status);
            stopped += usize::from(status.is_ok_and(|s| s == pb::JobStatus::Cancelled as i32));
        }
        stopped
    }

    /// Follows a job's `WatchJob` stream (one event per completed batch, the first at once),
    /// handing each event to `on_event`, until the job has ended; then returns its final state.
    /// A coordinator that goes away meanwhile (restarted, say: it resumes its jobs from its
    /// store) is waited for, for [`RECONNECT_FOR`], and the job followed again from where it
    /// was; events of batches already seen are not handed on twice.
    async fn wait_for_end(
        &mut self,
        job_id: &str,
        mut on_event: impl FnMut(&pb::WatchJobResponse),
    ) -> Result<pb::GetJobResponse> {
        let ended = |status: i32| {
            [pb::JobStatus::Succeeded, pb::JobStatus::Failed, pb::JobStatus::Cancelled]
                .iter()
                .any(|s| *s as i32 == status)
        };
        let mut last_rounds = None;
        let mut lost_since: Option<tokio::time::Instant> = None;
        loop {
            let mut answered = false;
            let watched = self.watch_until_end(job_id, &mut last_rounds, &mut answered, &ended, &mut on_event).await;
            if answered {
                // The coordinator answered since it was last lost: a later loss starts anew.
                lost_since = None;
            }
            let status = match watched {
                Ok(()) => match self.inner.get_job(pb::GetJobRequest { job_id: job_id.to_owned() }).await {
                    Ok(job) => return Ok(job.into_inner()),
                    Err(status) => status,
                },
                Err(status) => status,
            };
            if !coordinator_unreachable(&status) {
                return Err(status.into());
            }
            let since = *lost_since.get_or_insert_with(tokio::time::Instant::now);
            if since.elapsed() > RECONNECT_FOR {
                return Err(anyhow::Error::new(status)
                    .context(format!("lost the coordinator for more than {} s", RECONNECT_FOR.as_secs())));
            }
            tracing::warn!(job_id, "lost the coordinator ({}); following the job again", status.message());
            tokio::time::sleep(Duration::from_millis(500)).await;
        }
    }

    /// One `WatchJob` stream, until the job ends (`Ok`) or the stream fails; `answered` is set
    /// once the coordinator has sent an event.
    async fn watch_until_end(
        &mut self,
        job_id: &str,
        last_rounds: &mut Option<u64>,
        answered: &mut bool,
        ended: &impl Fn(i32) -> bool,
        on_event: &mut impl FnMut(&pb::WatchJobResponse),
    ) -> Result<(), tonic::Status> {
        let mut stream = self.inner.watch_job(pb::WatchJobRequest { job_id: job_id.to_owned() }).await?.into_inner();
        // The stream also ends when the coordinator has sent the last event of a finished job.
        while let Some(ev) = stream.message().await? {
            *answered = true;
            let repeated = last_rounds.is_some_and(|r| ev.rounds <= r) && !ended(ev.status);
            if !repeated {
                on_event(&ev);
                *last_rounds = Some(ev.rounds);
            }
            if ended(ev.status) {
                break;
            }
        }
        Ok(())
    }
}

/// How long a client waits for a coordinator that went away while it followed a job.
const RECONNECT_FOR: Duration = Duration::from_secs(120);

/// Lists a submitted job in the file a coordinator running this process as a diagnosis named
/// ([`fmucal_coordinator::diagnoses::JOB_RECORD_VAR`]), so that a coordinator that restarts
/// after dying can cancel it.
fn record_job(job_id: &str) {
    use std::io::Write;
    let Some(path) = std::env::var_os(fmucal_coordinator::diagnoses::JOB_RECORD_VAR) else { return };
    let written = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(&path)
        .and_then(|mut f| writeln!(f, "{job_id}").and_then(|()| f.sync_data()));
    if let Err(e) = written {
        tracing::warn!("cannot list job {job_id} in {}: {e}", std::path::Path::new(&path).display());
    }
}

/// Whether a failed call means the coordinator is not there (restarting, or the connection
/// dropped), rather than an answer.
fn coordinator_unreachable(status: &tonic::Status) -> bool {
    matches!(status.code(), tonic::Code::Unavailable | tonic::Code::Unknown | tonic::Code::Cancelled)
}

/// A diagnosis's evaluator on a coordinator (a local cluster's or `--coordinator`'s): its
/// calibrations and points run as jobs on the workers.
#[derive(Clone)]
pub struct OnCoordinator(pub Client);

impl fmucal_diagnose::driver::Evaluate for OnCoordinator {
    async fn calibrate(
        &mut self,
        job: &JobSpec,
        data: &MeasurementTable,
        model: &Path,
        progress: &(dyn Fn(fmucal_diagnose::driver::Progress) + Send + Sync),
    ) -> Result<CalibrationResult, fmucal_diagnose::error::Error> {
        let events = |ev: &pb::WatchJobResponse| {
            progress(fmucal_diagnose::driver::Progress {
                iteration: ev.iteration,
                evaluations: ev.evaluations,
                best_f: ev.best_f,
            })
        };
        let data = std::slice::from_ref(data);
        self.0.calibrate_with(job, data, model, events).await.map_err(fmucal_diagnose::error::Error::evaluate)
    }
}
