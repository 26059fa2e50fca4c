//! fmucal's coordinator: runs each job's ask/tell optimizer and hands its batches of points to
//! workers over gRPC (package `fmucal.v1`). [`run`] serves the client-facing `Calibration` and
//! the worker-facing `WorkerPool` services on a listener until `shutdown` resolves, so tests can
//! start it on `127.0.0.1:0`. Job state persists in redb under the data directory. A
//! `Diagnose` request runs `fmucal diagnose` as a child process against this coordinator
//! ([`diagnoses`]).

pub mod connections;
pub mod diagnoses;
pub mod edge;
pub mod error;
pub mod fillable_disk;
pub mod journal;
pub mod metrics;
pub mod models;
pub mod salvage;
pub mod scheduler;
pub mod services;
pub mod store;

use std::future::Future;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use fmucal_proto::v1 as pb;
use tokio::net::TcpListener;
use tonic::service::interceptor::InterceptedService;

pub use error::CoordinatorError;
pub use scheduler::Timing;

/// Coordinator settings.
#[derive(Debug, Clone)]
pub struct Config {
    /// Where models and job state are kept.
    pub data_dir: PathBuf,
    /// The token clients (the `Calibration` service) must carry. Required: without one,
    /// [`run`] refuses to start.
    pub token: Option<String>,
    /// The token workers (the `WorkerPool` service) must carry; `None` accepts the client
    /// token there too (one token for both, as for a local run).
    pub worker_token: Option<String>,
    pub timing: Timing,
    /// Cap on the model store (archives and unpacked files), bytes.
    pub max_store_bytes: u64,
    /// Cap on open connections and their idle timeout.
    pub connections: connections::ConnectionLimits,
    /// Keep at most this many finished jobs, deleting the oldest; `None` keeps every one.
    pub keep_finished_jobs: Option<usize>,
    /// Serve TLS (every listener); `None`: plaintext, which the CLI allows off loopback only
    /// with `--insecure`.
    pub tls: Option<fmucal_proto::tls::ServerTls>,
    /// The fmucal binary a `Diagnose` request runs as a child process ([`diagnoses`]);
    /// `None` refuses diagnoses.
    pub diagnose_program: Option<PathBuf>,
    /// Metrics the scheduler keeps up to date ([`metrics`]); whoever registered them serves
    /// them. `None`: none kept.
    pub metrics: Option<metrics::CoordinatorMetrics>,
    /// Keep the job state in memory only ([`store::Store::in_memory`]), for a coordinator
    /// whose jobs end with its process (a local run's in-process one): no `jobs.redb` to open
    /// or write, nothing to resume after a restart.
    pub in_memory_store: bool,
}

impl Config {
    /// A coordinator keeping its state in `data_dir`, with every other setting at its default:
    /// no token (set one: [`run`] refuses to start without), the default [`Timing`], store cap
    /// ([`models::DEFAULT_MAX_STORE_BYTES`]) and connection limits, every finished job kept,
    /// plaintext, no diagnoses, no metrics, the job state on disk.
    pub fn new(data_dir: impl Into<PathBuf>) -> Config {
        Config {
            data_dir: data_dir.into(),
            token: None,
            worker_token: None,
            timing: Timing::default(),
            max_store_bytes: models::DEFAULT_MAX_STORE_BYTES,
            connections: connections::ConnectionLimits::default(),
            keep_finished_jobs: None,
            tls: None,
            diagnose_program: None,
            metrics: None,
            in_memory_store: false,
        }
    }
}

impl Default for Timing {
    fn default() -> Self {
        Timing {
            heartbeat_interval: Duration::from_secs(1),
            worker_expiry: Duration::from_secs(5),
            evaluation_timeout: Duration::from_secs(600),
        }
    }
}

impl Timing {
    /// Refuses timings that make no sense: a zero heartbeat interval or evaluation timeout, and
    /// a worker expiry shorter than two heartbeat intervals (a live worker would expire between
    /// two heartbeats, and no job would progress).
    ///
    /// # Errors
    /// [`CoordinatorError::Config`] naming the setting.
    pub fn check(&self) -> Result<(), CoordinatorError> {
        if self.heartbeat_interval.is_zero() {
            return Err(CoordinatorError::Config("heartbeat_interval must be positive".into()));
        }
        if self.worker_expiry < 2 * self.heartbeat_interval {
            return Err(CoordinatorError::Config(format!(
                "worker_expiry must be at least twice the heartbeat interval of {:.3} s, not {:.3} s",
                self.heartbeat_interval.as_secs_f64(),
                self.worker_expiry.as_secs_f64()
            )));
        }
        if self.evaluation_timeout.is_zero() {
            return Err(CoordinatorError::Config("evaluation_timeout must be positive".into()));
        }
        Ok(())
    }
}

/// Makes the data folder if it is missing and checks that it is one, naming it in the error.
///
/// # Errors
/// [`CoordinatorError::Config`] naming the path.
pub fn check_data_dir(data_dir: &std::path::Path) -> Result<(), CoordinatorError> {
    let named = |why: String| CoordinatorError::Config(format!("data dir {}: {why}", data_dir.display()));
    if data_dir.exists() && !data_dir.is_dir() {
        return Err(named("not a directory".into()));
    }
    std::fs::create_dir_all(data_dir).map_err(|e| named(format!("cannot create it: {e}")))?;
    Ok(())
}

/// Refuses to serve without a client token, and a worker token equal to the client token
/// (which would let every client act as a worker). Workers run native code from the FMUs they
/// are sent, so even a loopback listener needs a token: any local user can reach it.
///
/// # Errors
/// [`CoordinatorError::Config`] with the reason.
pub fn check_tokens(token: Option<&str>, worker_token: Option<&str>) -> Result<(), CoordinatorError> {
    if token.is_none_or(|t| t.trim().is_empty()) {
        return Err(CoordinatorError::Config(
            "refusing to serve without a token: workers run native code from the FMUs they are sent; \
             set FMUCAL_TOKEN (or --token-file)"
                .into(),
        ));
    }
    match worker_token {
        Some(w) if w.trim().is_empty() => Err(CoordinatorError::Config("the worker token is empty".into())),
        Some(w) if Some(w) == token => Err(CoordinatorError::Config(
            "the worker token must differ from the client token (or leave it unset to use one token)".into(),
        )),
        _ => Ok(()),
    }
}

/// Waits for the scheduler task to end. It ends by itself only once the server has dropped
/// its handlers, or is aborted after the server stopped: neither is a failure. If it panicked,
/// the coordinator can no longer answer any job request, so health goes NOT_SERVING and the
/// reason is returned, for [`run`] to stop the server and fail (a supervisor restarts the
/// process; the store makes that safe).
async fn supervise_scheduler(
    task: tokio::task::JoinHandle<()>,
    health: &tonic_health::server::HealthReporter,
) -> Option<String> {
    let why = match task.await {
        Ok(()) => return None,
        Err(e) if e.is_cancelled() => return None,
        Err(e) => match e.try_into_panic() {
            Ok(panic) => {
                let text = panic
                    .downcast_ref::<&str>()
                    .map(|s| (*s).to_owned())
                    .or_else(|| panic.downcast_ref::<String>().cloned())
                    .unwrap_or_else(|| "no message".into());
                format!("the scheduler panicked: {text}")
            }
            Err(e) => format!("the scheduler failed: {e}"),
        },
    };
    tracing::error!("{why}; the coordinator stops");
    health.set_not_serving::<pb::calibration_server::CalibrationServer<services::Handlers>>().await;
    health.set_service_status("", tonic_health::ServingStatus::NotServing).await;
    Some(why)
}

/// How long open calls may go on once the coordinator is told to stop.
const SHUTDOWN_GRACE: Duration = Duration::from_secs(2);

/// Serves until `shutdown` resolves (open calls then have [`SHUTDOWN_GRACE`] to end).
///
/// # Errors
/// [`CoordinatorError`] if the store cannot be opened, there is no token, the TLS settings are
/// refused, the server fails, or the scheduler task panicked ([`CoordinatorError::Fatal`]).
pub async fn run(
    config: Config,
    listener: TcpListener,
    shutdown: impl Future<Output = ()> + Send + 'static,
) -> Result<(), CoordinatorError> {
    run_with_ready(config, listener, shutdown, |_| {}).await
}

/// [`run`], calling `ready` with the address once the store is open and the server is about
/// to serve (the `fmucal` binary then says it is listening: not before a store another
/// coordinator holds has been refused).
///
/// # Errors
/// As [`run`].
pub async fn run_with_ready(
    config: Config,
    listener: TcpListener,
    shutdown: impl Future<Output = ()> + Send + 'static,
    ready: impl FnOnce(std::net::SocketAddr),
) -> Result<(), CoordinatorError> {
    serve(config, &[], listener, shutdown, ready).await
}

/// [`run`] for a local run, with `local` models registered in the model store first
/// ([`models::ModelStore::register_local`]): models the calling process has unpacked and
/// checked, which clients then name by their SHA-256 without uploading them. Only this call
/// registers them; no request can.
///
/// # Errors
/// As [`run`], and INVALID_ARGUMENT if a local model does not describe.
pub async fn run_with_local_models(
    config: Config,
    local: &[models::LocalModel],
    listener: TcpListener,
    shutdown: impl Future<Output = ()> + Send + 'static,
) -> Result<(), CoordinatorError> {
    serve(config, local, listener, shutdown, |_| {}).await
}

async fn serve(
    config: Config,
    local: &[models::LocalModel],
    listener: TcpListener,
    shutdown: impl Future<Output = ()> + Send + 'static,
    ready: impl FnOnce(std::net::SocketAddr),
) -> Result<(), CoordinatorError> {
    let addr = listener.local_addr()?;
    check_tokens(config.token.as_deref(), config.worker_token.as_deref())?;
    config.timing.check()?;
    check_data_dir(&config.data_dir)?;
    let in_data_dir = |e: CoordinatorError| match e {
        CoordinatorError::Io(e) => CoordinatorError::Config(format!("data dir {}: {e}", config.data_dir.display())),
        CoordinatorError::Storage(m) if m.contains("already open") => CoordinatorError::Config(format!(
            "data dir {}: its job store is in use by another coordinator ({m})",
            config.data_dir.display()
        )),
        other => other,
    };
    let mut model_store = models::ModelStore::open(&config.data_dir, config.max_store_bytes).map_err(in_data_dir)?;
    for model in local {
        model_store.register_local(model)?;
    }
    let models = Arc::new(Mutex::new(model_store));
    let (data_dir, in_memory) = (config.data_dir.clone(), config.in_memory_store);
    let open = move || if in_memory { store::Store::in_memory() } else { store::Store::open(&data_dir) };
    let (store, models2, timing) = (tokio::task::spawn_blocking(open), models.clone(), config.timing.clone());
    let store = store.await.map_err(|e| CoordinatorError::Storage(e.to_string()))?.map_err(in_data_dir).map_err(|e| {
        // A store that exists but does not open is damaged: say what gives its jobs back.
        match e {
            CoordinatorError::Storage(m) if config.data_dir.join("jobs.redb").exists() => {
                CoordinatorError::Storage(format!(
                    "{}: {m}; if the file is damaged, `fmucal coordinator --data-dir {} --salvage` keeps every job that still reads",
                    config.data_dir.join("jobs.redb").display(),
                    config.data_dir.display()
                ))
            }
            other => other,
        }
    })?;
    let (keep, metrics) = (config.keep_finished_jobs, config.metrics.clone());
    // The jobs of diagnoses that died with the previous coordinator: nothing follows them now.
    let orphans = diagnoses::orphaned_jobs(&config.data_dir);
    let sched = tokio::task::spawn_blocking(move || {
        scheduler::Scheduler::new(store, models2, timing)
            .map(|s| s.with_orphans_cancelled(&orphans).with_retention(keep).with_metrics(metrics))
    })
    .await
    .map_err(|e| CoordinatorError::Storage(e.to_string()))??;
    let (tx, rx) = tokio::sync::mpsc::channel(1024);
    let scheduler_task = tokio::spawn(sched.run(rx));
    let diagnoses = diagnoses::Diagnoses::new(
        config.diagnose_program.clone(),
        addr,
        config.token.clone(),
        config.tls.clone(),
        &config.data_dir,
    )?;
    let models_dir = models.lock().map_err(|_| CoordinatorError::Storage("model store poisoned".into()))?.models_dir();
    let handlers = services::Handlers { commands: tx, models, models_dir, diagnoses: Arc::new(diagnoses) };
    let client_token = config.token.as_deref().unwrap_or_default();
    let client_auth = fmucal_proto::auth::BearerAuth::new(&[client_token]);
    let worker_auth = fmucal_proto::auth::BearerAuth::new(&[config.worker_token.as_deref().unwrap_or(client_token)]);
    let (health_reporter, health_service) = tonic_health::server::health_reporter();
    health_reporter.set_serving::<pb::calibration_server::CalibrationServer<services::Handlers>>().await;
    let fatal = Arc::new(Mutex::new(None));
    let (fatal_tx, fatal_rx) = tokio::sync::oneshot::channel::<()>();
    let (fatal2, reporter) = (fatal.clone(), health_reporter.clone());
    let abort_scheduler = scheduler_task.abort_handle();
    let supervisor = tokio::spawn(async move {
        if let Some(why) = supervise_scheduler(scheduler_task, &reporter).await {
            *fatal2.lock().unwrap_or_else(std::sync::PoisonError::into_inner) = Some(why);
            let _ = fatal_tx.send(());
        }
    });
    let (stopping_tx, stopping_rx) = tokio::sync::oneshot::channel::<()>();
    let stopping_reporter = health_reporter.clone();
    let stop = async move {
        tokio::select! {
            () = shutdown => {}
            _ = fatal_rx => {}
        }
        // Probes see the coordinator going away before its connections are cut.
        stopping_reporter.set_service_status("", tonic_health::ServingStatus::NotServing).await;
        stopping_reporter.set_not_serving::<pb::calibration_server::CalibrationServer<services::Handlers>>().await;
        let _ = stopping_tx.send(());
    };
    tracing::info!(%addr, tls = config.tls.is_some(), "coordinator listening");
    ready(addr);
    let keepalive = config.connections.keepalive_interval();
    let mut server = tonic::transport::Server::builder()
        .http2_keepalive_interval(Some(keepalive))
        .http2_keepalive_timeout(Some(keepalive));
    if let Some(tls) = &config.tls {
        let mut settings = tonic::transport::ServerTlsConfig::new()
            .identity(tonic::transport::Identity::from_pem(&tls.cert_pem, &tls.key_pem))
            .timeout(Duration::from_secs(10));
        if let Some(ca) = &tls.client_ca_pem {
            settings = settings.client_ca_root(tonic::transport::Certificate::from_pem(ca));
        }
        server = server
            .tls_config(settings)
            .map_err(|e| CoordinatorError::Config(format!("TLS: {}", fmucal_proto::tls::error_chain(&e))))?;
    }
    let served = server
        .add_service(health_service)
        .add_service(InterceptedService::new(
            pb::calibration_server::CalibrationServer::new(handlers.clone())
                .max_decoding_message_size(fmucal_proto::MAX_MESSAGE_BYTES),
            move |r| vouched(client_auth.check(r)),
        ))
        .add_service(InterceptedService::new(
            pb::worker_pool_server::WorkerPoolServer::new(handlers)
                .max_decoding_message_size(fmucal_proto::MAX_MESSAGE_BYTES),
            move |r| vouched(worker_auth.check(r)),
        ))
        .serve_with_incoming_shutdown(connections::incoming(listener, &config.connections), stop);
    // A graceful stop waits for every open call, and a client's WatchJob stream or a worker's
    // long poll may stay open for good: past SHUTDOWN_GRACE `run` stops waiting and returns once
    // the store is closed. tonic runs each connection as its own task, so in the `fmucal`
    // binary it is the process's exit that closes them (their clients and workers reconnect to
    // the next coordinator; the store holds every batch).
    let grace_over = async move {
        if stopping_rx.await.is_err() {
            std::future::pending::<()>().await;
        }
        tokio::time::sleep(SHUTDOWN_GRACE).await;
    };
    let served = tokio::select! {
        served = served => served,
        () = grace_over => {
            tracing::info!("closing the connections still open {} s after the stop", SHUTDOWN_GRACE.as_secs());
            Ok(())
        }
    };
    abort_scheduler.abort();
    // Once the scheduler has ended, its store is closed: a new coordinator may open it.
    let _ = supervisor.await;
    if let Some(why) = fatal.lock().unwrap_or_else(std::sync::PoisonError::into_inner).take() {
        return Err(CoordinatorError::Fatal(why));
    }
    served?;
    Ok(())
}

/// A request that passed its token check vouches for its connection
/// ([`connections::vouch`]).
fn vouched<T>(checked: Result<tonic::Request<T>, tonic::Status>) -> Result<tonic::Request<T>, tonic::Status> {
    if let Ok(req) = &checked {
        connections::vouch(req);
    }
    checked
}

#[cfg(test)]
mod tests {
    use super::*;
    use tonic_health::pb::health_server::Health;

    #[test]
    fn a_coordinator_needs_a_token_and_a_distinct_worker_token() {
        assert!(check_tokens(None, None).unwrap_err().to_string().contains("without a token"));
        assert!(check_tokens(Some(" "), None).is_err());
        check_tokens(Some("client"), None).unwrap();
        check_tokens(Some("client"), Some("worker")).unwrap();
        assert!(check_tokens(Some("client"), Some("client")).unwrap_err().to_string().contains("must differ"));
    }

    #[tokio::test]
    async fn a_panicking_scheduler_turns_health_to_not_serving() {
        let (reporter, _) = tonic_health::server::health_reporter();
        reporter.set_serving::<pb::calibration_server::CalibrationServer<services::Handlers>>().await;
        let health = tonic_health::server::HealthService::from_health_reporter(reporter.clone());
        let status = async |service: &str| {
            let req = tonic::Request::new(tonic_health::pb::HealthCheckRequest { service: service.into() });
            health.check(req).await.unwrap().into_inner().status
        };
        let name = "fmucal.v1.Calibration";
        assert_eq!(status(name).await, tonic_health::pb::health_check_response::ServingStatus::Serving as i32);
        let task = tokio::spawn(async { panic!("capacity overflow") });
        let why = supervise_scheduler(task, &reporter).await.unwrap();
        assert_eq!(why, "the scheduler panicked: capacity overflow");
        for service in [name, ""] {
            let s = status(service).await;
            assert_eq!(s, tonic_health::pb::health_check_response::ServingStatus::NotServing as i32, "{service:?}");
        }
        // An abort at shutdown, or an end once the handlers are gone, is not a failure.
        let task = tokio::spawn(std::future::pending::<()>());
        task.abort();
        assert!(supervise_scheduler(task, &reporter).await.is_none());
        assert!(supervise_scheduler(tokio::spawn(async {}), &reporter).await.is_none());
    }
}
