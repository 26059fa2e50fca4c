//! The `Diagnose` RPC. A diagnosis runs as a child process of fmucal's own binary,
//! `fmucal diagnose JOB --coordinator <this coordinator>`. So its driver is the CLI's, and every
//! simulation-heavy step is a job on this coordinator's workers. The few simulations the
//! driver runs itself (a fit's residuals, the signals it correlates them with) load the model's
//! native code in the child, never in the coordinator.
//!
//! This module owns those children:
//! - it writes the request's job and data to a scratch folder under `<data-dir>/diagnoses/`,
//!   which is removed when the diagnosis ends and emptied at start;
//! - it streams the child's progress lines, then its report;
//! - it stops the child when the client goes away: it closes the child's stdin, so the child
//!   cancels the jobs it submitted and exits, and kills it if it has not after a grace period;
//! - it runs at most [`MAX_RUNNING`] children at once;
//! - each child lists the jobs it submits in its scratch folder ([`JOB_RECORD_VAR`]), so that a
//!   coordinator started after one that died with its diagnoses (a SIGKILL, a crash) cancels
//!   those jobs ([`orphaned_jobs`]) instead of leaving them running with no one to follow them.

use std::net::{IpAddr, Ipv4Addr, Ipv6Addr, SocketAddr};
use std::path::{Path, PathBuf};
use std::process::Stdio;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

use fmucal_diagnose::report::Diagnosis;
use fmucal_diagnose::spec::DiagnoseSpec;
use fmucal_proto::convert::effect_to_proto;
use fmucal_proto::tls::ServerTls;
use fmucal_proto::v1 as pb;
use fmucal_shared::job::{JobSpec, MeasurementTable};
use tokio::io::{AsyncBufReadExt, AsyncReadExt, BufReader};
use tokio::sync::{OwnedSemaphorePermit, Semaphore, mpsc};
use tonic::Status;

use crate::error::CoordinatorError;

/// Diagnoses that may run at once; a request beyond them is refused (RESOURCE_EXHAUSTED).
pub const MAX_RUNNING: usize = 4;

/// How long a child asked to stop may take to cancel its jobs before it is killed.
const STOP_GRACE: std::time::Duration = std::time::Duration::from_secs(10);

/// The environment variable that tells a child where to list the ids of the jobs it submits,
/// one a line.
pub const JOB_RECORD_VAR: &str = "FMUCAL_JOB_RECORD";

/// The file in a scratch folder where its child lists its jobs.
const JOB_RECORD: &str = "jobs";

/// The jobs the diagnoses of an earlier coordinator on `data_dir` submitted: call it before
/// [`Diagnoses::new`] empties their folders. A diagnosis never outlives the coordinator that
/// ran it, so every one of them that is still running is an orphan.
pub fn orphaned_jobs(data_dir: &Path) -> Vec<String> {
    let Ok(entries) = std::fs::read_dir(data_dir.join("diagnoses")) else { return vec![] };
    let mut ids = vec![];
    for entry in entries.flatten() {
        if let Ok(text) = std::fs::read_to_string(entry.path().join(JOB_RECORD)) {
            ids.extend(text.lines().map(str::trim).filter(|l| !l.is_empty()).map(str::to_owned));
        }
    }
    ids
}

/// The name of the time column in the data file written for the child.
const TIME_COLUMN: &str = "time";

pub type Events = mpsc::Receiver<Result<pb::DiagnoseResponse, Status>>;

/// Starts diagnoses as child processes.
pub struct Diagnoses {
    /// The fmucal binary; `None`: this coordinator does not run diagnoses.
    program: Option<PathBuf>,
    /// Where the child reaches this coordinator.
    url: String,
    token: Option<String>,
    /// The coordinator's TLS: the child trusts its CA and, under mutual TLS, presents the
    /// coordinator's own certificate (see [`Diagnoses::new`]).
    tls: Option<ServerTls>,
    dir: PathBuf,
    running: Arc<Semaphore>,
    next: AtomicU64,
}

/// The URL a child on this host reaches a server listening on `addr` at (`localhost` under
/// TLS, the name a certificate of this host carries).
fn loopback_url(addr: SocketAddr, tls: bool) -> String {
    if tls {
        return format!("https://localhost:{}", addr.port());
    }
    let ip = match addr.ip() {
        IpAddr::V4(ip) if ip.is_unspecified() => IpAddr::V4(Ipv4Addr::LOCALHOST),
        IpAddr::V6(ip) if ip.is_unspecified() => IpAddr::V6(Ipv6Addr::LOCALHOST),
        ip => ip,
    };
    format!("http://{}", SocketAddr::new(ip, addr.port()))
}

impl Diagnoses {
    /// Empties `<data_dir>/diagnoses` (no diagnosis outlives the coordinator that ran it).
    /// Under TLS the child reaches the coordinator at `https://localhost:PORT`, trusting
    /// `tls.ca_pem`; under mutual TLS it presents the coordinator's own certificate, which
    /// must then also be valid for client authentication (as `fmucal certs` makes it).
    ///
    /// # Errors
    /// If the folder cannot be emptied or made.
    pub fn new(
        program: Option<PathBuf>,
        addr: SocketAddr,
        token: Option<String>,
        tls: Option<ServerTls>,
        data_dir: &Path,
    ) -> Result<Self, CoordinatorError> {
        let dir = data_dir.join("diagnoses");
        if dir.exists() {
            std::fs::remove_dir_all(&dir)?;
        }
        std::fs::create_dir_all(&dir)?;
        Ok(Diagnoses {
            program,
            url: loopback_url(addr, tls.is_some()),
            token,
            tls,
            dir,
            running: Arc::new(Semaphore::new(MAX_RUNNING)),
            next: AtomicU64::new(1),
        })
    }

    /// Starts the diagnosis of `job` (its model stored at `model`) and returns its events.
    ///
    /// # Errors
    /// FAILED_PRECONDITION if this coordinator runs no diagnoses, RESOURCE_EXHAUSTED if
    /// [`MAX_RUNNING`] are running, INVALID_ARGUMENT for data that cannot be written, or an I/O
    /// error starting the child.
    pub fn start(
        &self,
        mut job: JobSpec,
        data: &MeasurementTable,
        settings: DiagnoseSpec,
        model: PathBuf,
    ) -> Result<Events, Status> {
        let Some(program) = &self.program else {
            return Err(Status::failed_precondition("this coordinator was started without diagnoses"));
        };
        if self.tls.as_ref().is_some_and(|t| t.ca_pem.is_none()) {
            return Err(Status::failed_precondition(
                "this coordinator serves TLS without --tls-ca, so its diagnosis process could not trust it",
            ));
        }
        let permit = self.running.clone().try_acquire_owned().map_err(|_| {
            Status::resource_exhausted(format!("{MAX_RUNNING} diagnoses are running; try again when one ends"))
        })?;
        let scratch = self.dir.join(self.next.fetch_add(1, Ordering::Relaxed).to_string());
        let io = |e: std::io::Error| Status::internal(format!("cannot prepare the diagnosis: {e}"));
        std::fs::create_dir_all(&scratch).map_err(io)?;
        let prepared = (|| {
            let data_path = scratch.join("data.csv");
            fmucal_shared::series::write_csv(data, &data_path, TIME_COLUMN)
                .map_err(|e| Status::invalid_argument(format!("spec.data: {}", e.message)))?;
            job.model.path = Some(model);
            job.model.id = None;
            job.data.path = Some(data_path);
            job.data.time_column = TIME_COLUMN.into();
            job.diagnose = Some(settings.to_table());
            let text = toml::to_string(&job).map_err(|e| Status::internal(format!("cannot write the job: {e}")))?;
            let job_path = scratch.join("job.toml");
            std::fs::write(&job_path, text).map_err(io)?;
            let mut command = tokio::process::Command::new(program);
            command
                .arg("diagnose")
                .arg(&job_path)
                .arg("--coordinator")
                .arg(&self.url)
                .arg("--out")
                .arg(scratch.join("out"))
                .arg("--stop-on-stdin-eof")
                .env("FMUCAL_CACHE_DIR", self.dir.join("cache"))
                .env(JOB_RECORD_VAR, scratch.join(JOB_RECORD))
                .stdin(Stdio::piped())
                .stdout(Stdio::piped())
                .stderr(Stdio::piped())
                .kill_on_drop(true);
            match &self.token {
                Some(t) => command.env("FMUCAL_TOKEN", t),
                None => command.env_remove("FMUCAL_TOKEN"),
            };
            if let Some(tls) = &self.tls {
                let ca = scratch.join("tls-ca.pem");
                std::fs::write(&ca, tls.ca_pem.as_deref().unwrap_or_default()).map_err(io)?;
                command.env("FMUCAL_TLS_CA", ca);
                if tls.client_ca_pem.is_some() {
                    let (cert, key) = (scratch.join("tls-cert.pem"), scratch.join("tls-key.pem"));
                    std::fs::write(&cert, &tls.cert_pem).map_err(io)?;
                    write_private(&key, &tls.key_pem).map_err(io)?;
                    command.env("FMUCAL_TLS_CERT", cert).env("FMUCAL_TLS_KEY", key);
                }
            }
            command.spawn().map_err(|e| Status::internal(format!("cannot start {}: {e}", program.display())))
        })();
        let child = match prepared {
            Ok(child) => child,
            Err(status) => {
                let _ = std::fs::remove_dir_all(&scratch);
                return Err(status);
            }
        };
        let (tx, rx) = mpsc::channel(64);
        tokio::spawn(supervise(child, tx, scratch, permit));
        Ok(rx)
    }
}

fn progress(line: String) -> pb::DiagnoseResponse {
    pb::DiagnoseResponse { event: Some(pb::diagnose_response::Event::Progress(line)) }
}

/// Forwards the child's progress lines until it ends, then its report or its error; kills it
/// if the client goes away. Removes the scratch folder in every case.
async fn supervise(
    mut child: tokio::process::Child,
    tx: mpsc::Sender<Result<pb::DiagnoseResponse, Status>>,
    scratch: PathBuf,
    _permit: OwnedSemaphorePermit,
) {
    // Closing the child's stdin asks it to stop and cancel its jobs.
    let stdin = child.stdin.take();
    let mut stdout = child.stdout.take().expect("stdout is piped");
    let stderr = child.stderr.take().expect("stderr is piped");
    let summary = tokio::spawn(async move {
        let mut s = String::new();
        let _ = stdout.read_to_string(&mut s).await;
        s
    });
    let mut lines = BufReader::new(stderr).lines();
    let mut last = String::new();
    let mut started = false;
    let outcome = loop {
        tokio::select! {
            line = lines.next_line() => match line {
                Ok(Some(line)) => {
                    let line = line.trim().to_owned();
                    // The child's last line names files in the scratch folder, which the client
                    // never sees: the report travels in the result instead.
                    if line.is_empty() || line.starts_with("wrote ") {
                        continue;
                    }
                    started |= line.starts_with("round ");
                    last.clone_from(&line);
                    if tx.send(Ok(progress(line))).await.is_err() {
                        break None;
                    }
                }
                _ => break Some(child.wait().await),
            },
            () = tx.closed() => break None,
        }
    };
    let reply = match outcome {
        None => {
            tracing::info!("a diagnosis is stopped: its client went away");
            drop(stdin);
            if tokio::time::timeout(STOP_GRACE, child.wait()).await.is_err() {
                let _ = child.kill().await;
            }
            None
        }
        Some(Ok(status)) if status.success() => Some(
            result(&scratch.join("out"), summary.await.unwrap_or_default())
                .map(|r| pb::DiagnoseResponse { event: Some(pb::diagnose_response::Event::Result(r)) }),
        ),
        Some(Ok(_)) => {
            let message = last.strip_prefix("error: ").unwrap_or(&last).to_owned();
            // Before the first round, the child only checked the job: the request is at fault.
            Some(Err(if started {
                Status::aborted(format!("the diagnosis stopped: {message}"))
            } else {
                Status::invalid_argument(message)
            }))
        }
        Some(Err(e)) => Some(Err(Status::internal(format!("the diagnosis process: {e}")))),
    };
    if let Some(reply) = reply {
        let _ = tx.send(reply).await;
    }
    if let Err(e) = std::fs::remove_dir_all(&scratch) {
        tracing::warn!(scratch = %scratch.display(), "cannot remove a diagnosis folder: {e}");
    }
}

/// The result message from the child's output folder and its stdout.
fn result(out: &Path, summary: String) -> Result<pb::DiagnoseResult, Status> {
    let report_json = std::fs::read_to_string(out.join("report.json"))
        .map_err(|e| Status::internal(format!("the diagnosis wrote no report: {e}")))?;
    let report: Diagnosis = serde_json::from_str(&report_json)
        .map_err(|e| Status::internal(format!("the diagnosis wrote an unreadable report: {e}")))?;
    Ok(pb::DiagnoseResult {
        summary,
        named: report.named.iter().map(|n| n.words.clone()).collect(),
        effects: report.named.iter().map(|n| effect_to_proto(&n.effect)).collect(),
        report_json,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_child_reaches_a_wildcard_listener_on_loopback() {
        assert_eq!(loopback_url("0.0.0.0:7070".parse().unwrap(), false), "http://127.0.0.1:7070");
        assert_eq!(loopback_url("[::]:7070".parse().unwrap(), false), "http://[::1]:7070");
        assert_eq!(loopback_url("10.1.2.3:80".parse().unwrap(), false), "http://10.1.2.3:80");
        assert_eq!(loopback_url("0.0.0.0:7070".parse().unwrap(), true), "https://localhost:7070");
    }
}

/// Writes a file only its owner may read (a private key).
fn write_private(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    use std::io::Write;
    use std::os::unix::fs::OpenOptionsExt;
    std::fs::OpenOptions::new().write(true).create_new(true).mode(0o600).open(path)?.write_all(bytes)
}
