//! fmucal's coordinator: runs each job's ask/tell optimizer and hands its batches of points to
//! workers over gRPC (package `fmucal.v1`). [`run`] serves the client-facing `Calibration` and
//! the worker-facing `WorkerPool` services on a listener until `shutdown` resolves, so tests can
//! start it on `127.0.0.1:0`. Job state persists in redb under the data directory. A
//! `Diagnose` request runs `fmucal diagnose` as a child process against this coordinator
//! ([`diagnoses`]).

pub mod diagnoses;
pub mod error;
pub mod models;
pub mod scheduler;
pub mod services;
pub mod store;

use std::future::Future;
use std::net::SocketAddr;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use fmucal_proto::v1 as pb;
use tokio::net::TcpListener;
use tonic::service::interceptor::InterceptedService;
use tonic::transport::server::TcpIncoming;

pub use error::CoordinatorError;
pub use scheduler::Timing;

/// Coordinator settings.
#[derive(Debug, Clone)]
pub struct Config {
    /// Where models and job state are kept.
    pub data_dir: PathBuf,
    /// Shared token every RPC must carry; required unless listening on loopback only.
    pub token: Option<String>,
    pub timing: Timing,
    /// The fmucal binary a `Diagnose` request runs as a child process ([`diagnoses`]);
    /// `None` refuses diagnoses.
    pub diagnose_program: Option<PathBuf>,
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

/// Refuses a non-loopback address without a token.
///
/// # Errors
/// [`CoordinatorError::Config`] with the reason.
pub fn check_exposure(addr: SocketAddr, token: Option<&str>) -> Result<(), CoordinatorError> {
    if !addr.ip().is_loopback() && token.is_none_or(str::is_empty) {
        return Err(CoordinatorError::Config(format!(
            "refusing to listen on {addr} without a token: workers run native code from the FMUs they are sent; \
             set FMUCAL_TOKEN (or --token-file), or listen on 127.0.0.1"
        )));
    }
    Ok(())
}

/// Serves until `shutdown` resolves.
///
/// # Errors
/// [`CoordinatorError`] if the store cannot be opened, the address is exposed without a token,
/// or the server fails.
pub async fn run(
    config: Config,
    listener: TcpListener,
    shutdown: impl Future<Output = ()> + Send + 'static,
) -> Result<(), CoordinatorError> {
    let addr = listener.local_addr()?;
    check_exposure(addr, config.token.as_deref())?;
    let models = Arc::new(Mutex::new(models::ModelStore::open(&config.data_dir)?));
    let data_dir = config.data_dir.clone();
    let (store, models2, timing) =
        (tokio::task::spawn_blocking(move || store::Store::open(&data_dir)), models.clone(), config.timing.clone());
    let store = store.await.map_err(|e| CoordinatorError::Storage(e.to_string()))??;
    let sched = tokio::task::spawn_blocking(move || scheduler::Scheduler::new(store, models2, timing))
        .await
        .map_err(|e| CoordinatorError::Storage(e.to_string()))??;
    let (tx, rx) = tokio::sync::mpsc::channel(1024);
    let scheduler_task = tokio::spawn(sched.run(rx));
    let diagnoses =
        diagnoses::Diagnoses::new(config.diagnose_program.clone(), addr, config.token.clone(), &config.data_dir)?;
    let handlers = services::Handlers { commands: tx, models, diagnoses: Arc::new(diagnoses) };
    let auth = fmucal_proto::auth::BearerAuth::new(config.token.as_deref());
    let (a1, a2) = (auth.clone(), auth);
    let (health_reporter, health_service) = tonic_health::server::health_reporter();
    health_reporter.set_serving::<pb::calibration_server::CalibrationServer<services::Handlers>>().await;
    tracing::info!(%addr, "coordinator listening");
    tonic::transport::Server::builder()
        .add_service(health_service)
        .add_service(InterceptedService::new(
            pb::calibration_server::CalibrationServer::new(handlers.clone())
                .max_decoding_message_size(fmucal_proto::MAX_MESSAGE_BYTES),
            move |r| a1.check(r),
        ))
        .add_service(InterceptedService::new(
            pb::worker_pool_server::WorkerPoolServer::new(handlers)
                .max_decoding_message_size(fmucal_proto::MAX_MESSAGE_BYTES),
            move |r| a2.check(r),
        ))
        .serve_with_incoming_shutdown(TcpIncoming::from(listener).with_nodelay(Some(true)), shutdown)
        .await?;
    scheduler_task.abort();
    Ok(())
}
