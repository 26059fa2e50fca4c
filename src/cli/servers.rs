//! `fmucal coordinator` and `fmucal worker`: start the servers and stop them cleanly on
//! SIGTERM or Ctrl-C (a worker finishes or hands back the points it holds).

use std::net::SocketAddr;
use std::path::PathBuf;

use anyhow::{Context, Result};

#[derive(clap::Args)]
pub struct CoordinatorArgs {
    /// Address to listen on.
    #[arg(long, default_value = "127.0.0.1:7070")]
    listen: SocketAddr,
    /// Where models and job state are kept (created if missing).
    #[arg(long)]
    data_dir: PathBuf,
    /// File holding the client token (else FMUCAL_TOKEN). Required.
    #[arg(long)]
    token_file: Option<PathBuf>,
    /// File holding the token workers must present (else FMUCAL_WORKER_TOKEN); unset, workers
    /// present the client token.
    #[arg(long)]
    worker_token_file: Option<PathBuf>,
    /// Drop a worker after this many seconds without a heartbeat: at least 2 (workers
    /// heartbeat every second), at most a day.
    #[arg(long, default_value_t = 5.0)]
    worker_expiry: f64,
    /// Re-send a point after this many seconds without a result: at least 1, at most a week.
    #[arg(long, default_value_t = 600.0)]
    evaluation_timeout: f64,
    /// Cap on the stored models (archives and their unpacked files), bytes; an upload past it
    /// is refused with RESOURCE_EXHAUSTED.
    #[arg(long, default_value_t = fmucal_coordinator::models::DEFAULT_MAX_STORE_BYTES)]
    max_store_bytes: u64,
    /// Cap on open connections; past it, new ones wait until one closes.
    #[arg(long, default_value_t = fmucal_coordinator::connections::DEFAULT_MAX_CONNECTIONS)]
    max_connections: usize,
    /// Close a connection nothing was read from for this many seconds, at least 1 (live
    /// clients answer the coordinator's keep-alive pings, sent three times per period).
    #[arg(long, default_value_t = fmucal_coordinator::connections::DEFAULT_IDLE_TIMEOUT.as_secs_f64())]
    idle_timeout: f64,
    /// Close a connection that has carried no request with a valid token this many seconds
    /// after it opened, at least 1 (a peer without a token cannot hold a connection open).
    #[arg(long, default_value_t = fmucal_coordinator::connections::DEFAULT_AUTH_TIMEOUT.as_secs_f64())]
    auth_timeout: f64,
    /// Keep at most this many finished jobs (at least 1), deleting those that finished first
    /// (with their results and logs) once they have been finished for a minute. Default: keep
    /// every job (delete them with DeleteJob).
    #[arg(long, value_parser = clap::value_parser!(u64).range(1..))]
    keep_finished_jobs: Option<u64>,
    /// Do not serve: rewrite a damaged job store under --data-dir with every job that still
    /// reads (the damaged file is kept aside), print what was kept, and exit. Stop the
    /// coordinator first.
    #[arg(long)]
    salvage: bool,
    /// Serve Prometheus metrics at http://ADDR/metrics (plain HTTP, no token: bind it where
    /// only the scraper reaches it). Default: not served.
    #[arg(long)]
    metrics_listen: Option<SocketAddr>,
    #[command(flatten)]
    tls: super::tls::ServerArgs,
}

#[derive(clap::Args)]
pub struct WorkerArgs {
    /// Coordinator URL, e.g. http://127.0.0.1:7070.
    #[arg(long)]
    coordinator: String,
    /// Concurrent evaluations (FMU instances on their own threads), 1 to 256.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=i64::from(fmucal_proto::MAX_SLOTS)))]
    slots: u32,
    /// File holding the token to present (else FMUCAL_WORKER_TOKEN, else FMUCAL_TOKEN).
    #[arg(long)]
    token_file: Option<PathBuf>,
    /// Serve gRPC health here (NOT_SERVING until registered).
    #[arg(long)]
    health_listen: Option<SocketAddr>,
    /// Where fetched models are kept. Default: the FMU cache.
    #[arg(long)]
    cache_dir: Option<PathBuf>,
    /// Fail a point whose model has not returned after this many seconds and abandon its
    /// instance. Default: 90 % of the coordinator's --evaluation-timeout.
    #[arg(long)]
    evaluation_deadline: Option<f64>,
    /// On SIGTERM or Ctrl-C, wait at most this many seconds for the points being evaluated.
    #[arg(long, default_value_t = fmucal_worker::DEFAULT_STOP_GRACE.as_secs_f64())]
    stop_grace: f64,
    /// Serve Prometheus metrics at http://ADDR/metrics (plain HTTP, no token). Default: not
    /// served.
    #[arg(long)]
    metrics_listen: Option<SocketAddr>,
    /// `SHA256=DIR`: the model whose archive has this SHA-256 is already unpacked in DIR; use
    /// it there instead of fetching and unpacking it. A local run passes its model so.
    #[arg(long, hide = true, value_name = "SHA256=DIR")]
    unpacked_model: Vec<String>,
    #[command(flatten)]
    tls: super::tls::ClientArgs,
}

/// The flag that hands a worker a model already unpacked ([`unpacked_models`]).
pub const UNPACKED_MODEL_FLAG: &str = "--unpacked-model";

/// The `--unpacked-model SHA256=DIR` values as a map.
///
/// # Errors
/// In one line naming the flag: no `=`, a SHA-256 that is not 64 hex digits, or a folder
/// without `modelDescription.xml`.
fn unpacked_models(values: &[String]) -> Result<std::collections::HashMap<String, PathBuf>> {
    let mut map = std::collections::HashMap::new();
    for v in values {
        let quoted = || fmucal_shared::quote::quote_user_text(v);
        let (sha, dir) =
            v.split_once('=').with_context(|| format!("{UNPACKED_MODEL_FLAG}: {} is not SHA256=DIR", quoted()))?;
        if sha.len() != 64 || !sha.bytes().all(|b| b.is_ascii_hexdigit()) {
            anyhow::bail!("{UNPACKED_MODEL_FLAG}: {} does not start with 64 hex digits", quoted());
        }
        let dir = PathBuf::from(dir);
        if !dir.join("modelDescription.xml").is_file() {
            anyhow::bail!("{UNPACKED_MODEL_FLAG}: {} holds no modelDescription.xml", dir.display());
        }
        map.insert(sha.to_ascii_lowercase(), dir);
    }
    Ok(map)
}

pub async fn terminate_signal() {
    let term = async {
        match tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate()) {
            Ok(mut s) => {
                s.recv().await;
            }
            Err(_) => std::future::pending::<()>().await,
        }
    };
    tokio::select! {
        _ = term => {}
        _ = tokio::signal::ctrl_c() => {}
    }
}

pub fn coordinator(args: CoordinatorArgs) -> Result<()> {
    if args.salvage {
        return salvage(&args.data_dir);
    }
    let timing = fmucal_coordinator::Timing {
        worker_expiry: seconds_within("--worker-expiry", args.worker_expiry, 2.0, DAY)?,
        evaluation_timeout: seconds_within("--evaluation-timeout", args.evaluation_timeout, 1.0, 7.0 * DAY)?,
        ..Default::default()
    };
    timing.check()?;
    let idle_timeout = seconds_within("--idle-timeout", args.idle_timeout, 1.0, DAY)?;
    let auth_timeout = seconds_within("--auth-timeout", args.auth_timeout, 1.0, DAY)?;
    anyhow::ensure!(args.max_connections >= 1, "--max-connections must be at least 1, not 0");
    let token = super::token::load(args.token_file.as_deref())?;
    let worker_token = super::token::load_worker_token(args.worker_token_file.as_deref())?;
    fmucal_coordinator::check_tokens(token.as_deref(), worker_token.as_deref())?;
    let tls = args.tls.load(args.listen)?;
    fmucal_coordinator::check_data_dir(&args.data_dir)?;
    let rt = tokio::runtime::Runtime::new()?;
    rt.block_on(async move {
        let listener = tokio::net::TcpListener::bind(args.listen)
            .await
            .with_context(|| format!("cannot listen on {}", args.listen))?;
        // A Diagnose request runs this binary as `fmucal diagnose --coordinator <here>`.
        let diagnose_program = std::env::current_exe().ok();
        let mut registry = prometheus_client::registry::Registry::default();
        let metrics = fmucal_coordinator::metrics::CoordinatorMetrics::register(&mut registry);
        let metrics = match args.metrics_listen {
            Some(addr) => {
                let bound = super::metrics_http::spawn(addr, registry).await?;
                super::status(&format!("metrics on http://{bound}/metrics"));
                Some(metrics)
            }
            None => None,
        };
        let config = fmucal_coordinator::Config {
            data_dir: args.data_dir,
            token,
            worker_token,
            timing,
            max_store_bytes: args.max_store_bytes,
            connections: fmucal_coordinator::connections::ConnectionLimits {
                max_connections: args.max_connections,
                idle_timeout,
                auth_timeout,
            },
            keep_finished_jobs: args.keep_finished_jobs.map(|n| usize::try_from(n).unwrap_or(usize::MAX)),
            tls,
            diagnose_program,
            metrics,
            in_memory_store: false,
        };
        // Said once the store is open: a data dir another coordinator holds fails first.
        let ready = |addr| super::status(&format!("coordinator listening on {addr}"));
        fmucal_coordinator::run_with_ready(config, listener, terminate_signal(), ready).await?;
        Ok(())
    })
}

pub fn worker(args: WorkerArgs) -> Result<()> {
    super::client::check_url("--coordinator", &args.coordinator)?;
    let ca = args.tls.ca_path();
    let url = args.coordinator.clone();
    worker_with(args).map_err(|e| {
        if matches!(
            e.downcast_ref::<fmucal_worker::WorkerError>(),
            Some(fmucal_worker::WorkerError::Connect { .. } | fmucal_worker::WorkerError::Registration(_))
        ) && fmucal_proto::tls::http_url_serves_tls(&url)
        {
            return e.context(format!("{url} serves TLS: use an https:// URL with --tls-ca"));
        }
        // A refused certificate: name the file that should have vouched for it.
        let text = format!("{e:#}");
        match ca {
            Some(ca) if text.contains("certificate") || text.contains("UnknownIssuer") => e.context(format!(
                "the coordinator's certificate was refused: is {} the CA that signed it?",
                ca.display()
            )),
            _ => e,
        }
    })
}

fn worker_with(args: WorkerArgs) -> Result<()> {
    super::run_dir::die_with_parent_if_asked()?;
    let token = super::token::load_for_worker(args.token_file.as_deref())?;
    let cache_dir = args.cache_dir.unwrap_or_else(fmucal_shared::fmu::archive::default_cache_dir);
    let name = format!("{}-{}", std::env::var("HOSTNAME").unwrap_or_else(|_| "worker".into()), std::process::id());
    let mut registry = prometheus_client::registry::Registry::default();
    let metrics = args.metrics_listen.map(|_| fmucal_worker::metrics::WorkerMetrics::register(&mut registry));
    let config = fmucal_worker::Config {
        coordinator: args.coordinator,
        token,
        slots: args.slots as usize,
        name,
        cache_dir,
        unpacked_models: unpacked_models(&args.unpacked_model)?,
        health_listen: args.health_listen,
        tls: args.tls.load()?,
        evaluation_deadline: args.evaluation_deadline.map(|s| seconds("--evaluation-deadline", s)).transpose()?,
        stop_grace: seconds("--stop-grace", args.stop_grace)?,
        metrics,
    };
    // Evaluations run on the slots' own threads; the runtime only does I/O, and one thread is
    // enough (a pool of many workers on few cores then switches less).
    let rt = tokio::runtime::Builder::new_current_thread().enable_all().build()?;
    let outcome = rt.block_on(async {
        if let Some(addr) = args.metrics_listen {
            let bound = super::metrics_http::spawn(addr, registry).await?;
            super::status(&format!("metrics on http://{bound}/metrics"));
        }
        anyhow::Ok(fmucal_worker::run(config, terminate_signal()).await)
    })?;
    // A model being loaded (a blocking task) must not hold the exit.
    rt.shutdown_timeout(std::time::Duration::from_secs(1));
    match outcome {
        Err(fmucal_worker::WorkerError::Restart(why)) => restart_worker(&why),
        other => Ok(other?),
    }
}

fn salvage(data_dir: &std::path::Path) -> Result<()> {
    // redb may panic on a damaged file; each such attempt is caught and reported below.
    std::panic::set_hook(Box::new(|_| {}));
    let report = fmucal_coordinator::salvage::salvage(data_dir)?;
    let _ = std::panic::take_hook();
    println!(
        "kept {} jobs ({} logged evaluations), read {}; the damaged store is now {}",
        report.kept.len(),
        report.evaluations,
        report.method,
        report.damaged.display()
    );
    if !report.lost.is_empty() {
        println!("lost {} jobs: {}", report.lost.len(), report.lost.join(", "));
    }
    Ok(())
}

/// A day, in seconds.
const DAY: f64 = 86_400.0;

/// A duration given in seconds on the command line, between `min` and `max` seconds.
fn seconds_within(flag: &str, s: f64, min: f64, max: f64) -> Result<std::time::Duration> {
    anyhow::ensure!(
        s.is_finite() && (min..=max).contains(&s),
        "{flag} must be a number of seconds from {min} to {max}, not {s}"
    );
    seconds(flag, s)
}

/// A duration given in seconds on the command line.
fn seconds(flag: &str, s: f64) -> Result<std::time::Duration> {
    std::time::Duration::try_from_secs_f64(s)
        .ok()
        .filter(|d| !d.is_zero())
        .with_context(|| format!("{flag} must be a positive number of seconds, not {s}"))
}

/// Replaces this worker process by a fresh one with the same arguments (and pid), leaving
/// behind the threads stuck in models that did not return.
fn restart_worker(why: &str) -> Result<()> {
    use std::os::unix::process::CommandExt;
    tracing::warn!("restarting the worker: {why}");
    let exe = std::env::current_exe().context("cannot find this program to restart the worker")?;
    let err = std::process::Command::new(exe).args(std::env::args_os().skip(1)).exec();
    Err(err).context("cannot restart the worker")
}
