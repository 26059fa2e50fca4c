//! fmucal's worker: registers with a coordinator (announcing the protocol version), heartbeats,
//! and runs `slots` evaluation slots. One task long-polls the coordinator for all the slots
//! ([`poller`]: a poll returns the results of several slots and brings points for several),
//! and each slot evaluates the points it takes on its own thread of the warm-evaluator pool, which
//! keeps a warm FMU instance for each of its last 4 jobs (FMU instances are not `Send`). Points
//! of an FMU that may be instantiated only once per process all go to thread 0. Models and job data are fetched
//! once per job and cached; unpacked models are cached by hash, and a model the worker was
//! started with already unpacked ([`Config::unpacked_models`]) is opened where it is. On shutdown the slots finish
//! their current point and hand its result back before the worker exits, within a grace period
//! after which the worker leaves whatever is still running (the coordinator re-sends it).
//!
//! Every evaluation runs under a deadline (by default 90 % of the coordinator's evaluation
//! timeout): a model that has not returned by then fails its point, and the slot's thread is
//! abandoned and replaced. When twice as many threads are abandoned as there are slots, or the model
//! may be instantiated only once per process, the worker stops and [`run`] returns
//! [`WorkerError::Restart`]: `fmucal worker` then replaces its process with a fresh one.

mod hung;
mod jobs;
pub mod metrics;
pub mod poller;
mod slot;

use std::future::Future;
use std::net::SocketAddr;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;

pub use hung::DEFAULT_STOP_GRACE;

use fmucal_proto::auth::AttachToken;
use fmucal_proto::v1 as pb;
use fmucal_proto::v1::worker_pool_client::WorkerPoolClient;
use fmucal_shared::job::pool::EvaluatorPool;
use tokio::sync::watch;
use tonic::service::interceptor::InterceptedService;
use tonic::transport::Channel;
use tonic_health::ServingStatus;

/// The client type the worker uses.
pub type Client = WorkerPoolClient<InterceptedService<Channel, AttachToken>>;

/// Worker settings.
#[derive(Debug, Clone)]
pub struct Config {
    /// Coordinator URL, e.g. `http://127.0.0.1:7070`.
    pub coordinator: String,
    pub token: Option<String>,
    /// Concurrent evaluations (FMU instances), 1 to [`fmucal_proto::MAX_SLOTS`]. Default: 1.
    pub slots: usize,
    /// Name shown by the coordinator.
    pub name: String,
    /// Where fetched models are stored and unpacked.
    pub cache_dir: PathBuf,
    /// Models already unpacked on this machine, by the SHA-256 of their archive: the folder
    /// each was unpacked into, used as it is (neither fetched nor unpacked again). A local
    /// run passes its own model here; the coordinator names models only by their SHA-256, so
    /// it can never make the worker open any other folder. Default: none.
    pub unpacked_models: std::collections::HashMap<String, PathBuf>,
    /// Serve gRPC health (NOT_SERVING until registered) on this address.
    pub health_listen: Option<SocketAddr>,
    /// How to reach an `https://` coordinator.
    pub tls: Option<fmucal_proto::tls::ClientTls>,
    /// Abandon an evaluation that has not returned after this long. Default (`None`): 90 % of
    /// the coordinator's evaluation timeout, so the point fails here before it is re-sent.
    pub evaluation_deadline: Option<Duration>,
    /// After a stop is asked, how long the slots may take to finish their points.
    pub stop_grace: Duration,
    /// Metrics the slots keep up to date ([`metrics`]); whoever registered them serves them.
    /// `None`: none kept.
    pub metrics: Option<metrics::WorkerMetrics>,
}

#[derive(Debug, thiserror::Error)]
pub enum WorkerError {
    #[error("cannot reach the coordinator at {url}: {message}")]
    Connect { url: String, message: String },
    #[error("registration refused: {0}")]
    Registration(String),
    #[error("{0}")]
    Config(String),
    /// Evaluations did not return and their threads could not all be replaced: the process
    /// must be replaced (its points were handed back or failed).
    #[error("the worker needs a fresh process: {0}")]
    Restart(String),
}

/// Runs until `shutdown` resolves (then finishes the points in hand) or the coordinator stops
/// answering for good.
///
/// # Errors
/// [`WorkerError`] if the coordinator cannot be reached or refuses the registration.
pub async fn run(config: Config, shutdown: impl Future<Output = ()> + Send + 'static) -> Result<(), WorkerError> {
    let max = fmucal_proto::MAX_SLOTS as usize;
    if !(1..=max).contains(&config.slots) {
        return Err(WorkerError::Config(format!("slots: a worker has 1 to {max} slots, not {}", config.slots)));
    }
    let attach = AttachToken::new(config.token.as_deref()).map_err(WorkerError::Config)?;
    let channel = connect(&config.coordinator, config.tls.as_ref()).await?;
    let mut client: Client = WorkerPoolClient::with_interceptor(channel, attach)
        .max_decoding_message_size(fmucal_proto::MAX_MESSAGE_BYTES)
        .max_encoding_message_size(fmucal_proto::MAX_MESSAGE_BYTES);

    // Health is reported under the name of the service the worker takes part in, though it
    // serves only the health check itself.
    let (health_reporter, health_service) = tonic_health::server::health_reporter();
    set_health(&health_reporter, ServingStatus::NotServing).await;
    if let Some(addr) = config.health_listen {
        tokio::spawn(async move {
            if let Err(e) = tonic::transport::Server::builder().add_service(health_service).serve(addr).await {
                tracing::error!("health endpoint failed: {e}");
            }
        });
    }

    let reg = register(&mut client, &config).await?;
    let worker_id = Arc::new(tokio::sync::RwLock::new(reg.worker_id));
    set_health(&health_reporter, ServingStatus::Serving).await;
    let (stop_tx, stop_rx) = watch::channel(false);
    let stop_tx = Arc::new(stop_tx);
    // Whether the stop came from `shutdown` (then the worker exits, even if it also wanted a
    // fresh process).
    let terminated = Arc::new(std::sync::atomic::AtomicBool::new(false));
    {
        let (stop_tx, terminated) = (stop_tx.clone(), terminated.clone());
        tokio::spawn(async move {
            shutdown.await;
            terminated.store(true, std::sync::atomic::Ordering::SeqCst);
            let _ = stop_tx.send(true);
        });
    }
    let deadline = config.evaluation_deadline.or_else(|| {
        (reg.evaluation_timeout_ms > 0).then(|| Duration::from_millis(reg.evaluation_timeout_ms).mul_f64(0.9))
    });

    // Heartbeats, until the slots have ended (while they finish or hand back their points the
    // coordinator must not expire this worker); a coordinator that forgot us gets a new
    // registration.
    let (slots_done_tx, slots_done_rx) = watch::channel(false);
    {
        let (mut client, id, config, mut stop) = (client.clone(), worker_id.clone(), config.clone(), slots_done_rx);
        let every = Duration::from_millis(reg.heartbeat_interval_ms.max(50));
        tokio::spawn(async move {
            loop {
                tokio::select! {
                    _ = tokio::time::sleep(every) => {}
                    _ = stop.changed() => return,
                }
                let current = id.read().await.clone();
                match client.heartbeat(pb::HeartbeatRequest { worker_id: current }).await {
                    Ok(r) if !r.get_ref().known => {
                        if let Ok(r) = register(&mut client, &config).await {
                            *id.write().await = r.worker_id;
                        }
                    }
                    Ok(_) => {}
                    Err(e) => tracing::warn!("heartbeat failed: {e}"),
                }
            }
        });
    }

    let jobs = Arc::new(jobs::JobCache::new(config.cache_dir.clone(), config.unpacked_models.clone()));
    let pool = EvaluatorPool::new(config.slots.max(1), "fmucal-slot")
        .map_err(|e| WorkerError::Config(format!("cannot start evaluation threads: {e}")))?;
    let pool = Arc::new(pool);
    let hung = Arc::new(hung::Hung::new(config.slots.max(1), stop_tx.clone()));
    let (give_up_tx, give_up_rx) = watch::channel(false);
    let inbox = Arc::new(poller::Inbox::default());
    let mut slots = tokio::task::JoinSet::new();
    slots.spawn(poller::run(
        poller::PollerContext {
            client: client.clone(),
            worker_id: worker_id.clone(),
            slots: config.slots.max(1),
            stop: stop_rx.clone(),
            give_up: give_up_rx.clone(),
            deadline,
            observer: None,
        },
        inbox.clone(),
    ));
    for k in 0..config.slots.max(1) {
        let ctx = slot::SlotContext {
            pool: pool.clone(),
            client: client.clone(),
            jobs: jobs.clone(),
            index: k,
            deadline,
            hung: hung.clone(),
            give_up: give_up_rx.clone(),
            metrics: config.metrics.clone(),
        };
        slots.spawn(slot::run(ctx, inbox.clone()));
    }
    hung::join_within_grace(&mut slots, stop_rx.clone(), config.stop_grace, &give_up_tx, &pool).await;
    let _ = slots_done_tx.send(true);
    set_health(&health_reporter, ServingStatus::NotServing).await;
    if let Some(why) = hung.restart_reason()
        && !terminated.load(std::sync::atomic::Ordering::SeqCst)
    {
        return Err(WorkerError::Restart(why));
    }
    tracing::info!("worker stopped");
    Ok(())
}

/// Sets the worker's health, under the name of the service it takes part in and for the server
/// as a whole (the empty name, what `fmucal health URL` and most probes ask about).
async fn set_health(reporter: &tonic_health::server::HealthReporter, status: ServingStatus) {
    reporter.set_service_status(pb::worker_pool_server::SERVICE_NAME, status).await;
    reporter.set_service_status("", status).await;
}

async fn connect(url: &str, tls: Option<&fmucal_proto::tls::ClientTls>) -> Result<Channel, WorkerError> {
    let endpoint =
        fmucal_proto::tls::endpoint(url, tls).map_err(|message| WorkerError::Connect { url: url.into(), message })?;
    let mut last = String::new();
    for _ in 0..50 {
        match endpoint.connect().await {
            Ok(ch) => return Ok(ch),
            Err(e) => last = fmucal_proto::tls::error_chain(&e),
        }
        tokio::time::sleep(Duration::from_millis(200)).await;
    }
    Err(WorkerError::Connect { url: url.into(), message: last })
}

async fn register(client: &mut Client, config: &Config) -> Result<pb::RegisterResponse, WorkerError> {
    let req = pb::RegisterRequest {
        protocol_version: fmucal_proto::PROTOCOL_VERSION,
        slots: config.slots.max(1) as u32,
        name: config.name.clone(),
    };
    client.register(req).await.map(|r| r.into_inner()).map_err(|s| {
        // A connection that failed (a certificate refused, say) says why only in its source.
        let why = match std::error::Error::source(&s) {
            Some(source)
                if s.message().is_empty()
                    || s.code() == tonic::Code::Unknown
                    || s.code() == tonic::Code::Unavailable =>
            {
                let chain = fmucal_proto::tls::error_chain(source);
                if chain.starts_with(s.message()) { chain } else { format!("{}: {chain}", s.message()) }
            }
            _ => s.message().to_owned(),
        };
        WorkerError::Registration(why)
    })
}
