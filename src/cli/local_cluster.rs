//! A cluster for one local run (`fmucal calibrate` without `--coordinator`): an in-process
//! coordinator on 127.0.0.1 (a free port) with freshly generated client and worker tokens and
//! its state in a run folder ([`super::run_dir`]: a killed run's folder is removed by the next
//! run), and `fmucal worker` processes of this executable, replaced when they die (an FMU may
//! crash one) and dying with this process. [`run`] hands a connected [`Client`] to the work
//! and stops everything when the work ends.
//!
//! N workers are one process of N slots: it starts once, and one poll serves all its slots
//! (measured: 55 against 64 ms for the cheap model of `bench/fmpy_scipy_local.sh`, median of
//! 30 interleaved runs). A model that may be instantiated only once per process gets N
//! processes of one slot instead, so that its points still run N at a time; so does a run
//! whose worker process died, from then on, so that a crash takes only its own point.
//!
//! The run's model is the archive this process has already unpacked into the user's FMU
//! cache and checked: it is registered with the coordinator in-process
//! ([`fmucal_coordinator::run_with_local_models`]) and handed to each worker process on its
//! command line as `SHA256=FOLDER`, so it is neither uploaded, fetched nor unpacked again.

use std::time::Duration;

use anyhow::{Context, Result, bail};
use fmucal_shared::fmu::Interface;
use fmucal_shared::job::limits::MAX_WORKERS;

use super::client::Client;

/// Worker slots of a local run: `--workers`, else the job's `[workers] count` (checked
/// with the job), else the number of cores (at most the cap).
///
/// # Errors
/// `--workers` of 0 or above [`MAX_WORKERS`], in one line naming the flag.
pub fn worker_count(flag: Option<usize>, spec: &fmucal_shared::job::JobSpec) -> Result<usize> {
    if let Some(n) = flag
        && !(1..=MAX_WORKERS).contains(&n)
    {
        bail!("--workers: {n} is not in 1..={MAX_WORKERS} (the cap on local workers)");
    }
    let cores = || std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1).min(MAX_WORKERS);
    Ok(flag.or(spec.workers.count).unwrap_or_else(cores).max(1))
}

/// Starts the coordinator and `workers` worker slots, runs `work` on a client connected to
/// them while supervising the workers, then stops them all and returns the work's result with
/// the cluster [`Stopping`] (which the caller waits for once its own outputs are written).
/// `model` is the run's model, loaded from the archive the work names: the client names it
/// by its SHA-256 with no upload.
pub async fn run<T>(
    workers: usize,
    model: (&std::path::Path, &fmucal_shared::fmu::Fmu),
    work: impl AsyncFnOnce(Client) -> Result<T>,
) -> Result<(T, Stopping)> {
    let (archive, fmu) = model;
    let local = fmucal_coordinator::models::LocalModel {
        archive: archive.to_owned(),
        dir: fmu.dir.clone(),
        sha256: fmu.sha256.clone(),
    };
    let unpacked = format!("{}={}", local.sha256, local.dir.display());
    let (token, worker_token) = (super::token::generate()?, super::token::generate()?);
    let state = super::run_dir::RunDir::create()?;
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await?;
    let url = format!("http://{}", listener.local_addr()?);
    let (stop_tx, stop_rx) = tokio::sync::oneshot::channel::<()>();
    // The run's jobs end with it: their state stays in memory (no store file to open).
    let config = fmucal_coordinator::Config {
        token: Some(token.clone()),
        worker_token: Some(worker_token.clone()),
        in_memory_store: true,
        ..fmucal_coordinator::Config::new(state.path().join("coordinator"))
    };
    let local_models = [local.clone()];
    let server = tokio::spawn(async move {
        fmucal_coordinator::run_with_local_models(config, &local_models, listener, async {
            let _ = stop_rx.await;
        })
        .await
    });
    let exe = std::env::current_exe()?;
    let cache = state.path().join("worker-cache");
    // One process of N slots, or N of one: for a model that may be instantiated only once per
    // process, and after a worker process has died (crash isolation from then on).
    let mut isolated = [Interface::ModelExchange, Interface::CoSimulation].into_iter().any(|i| fmu.once_per_process(i));
    let spawn = |k: usize, slots: usize| {
        let mut cmd = tokio::process::Command::new(&exe);
        cmd.args(["worker", "--coordinator", &url, "--slots", &slots.to_string(), "--cache-dir"])
            .arg(&cache)
            .arg(super::servers::UNPACKED_MODEL_FLAG)
            .arg(&unpacked)
            .env("FMUCAL_WORKER_TOKEN", &worker_token)
            .env_remove("FMUCAL_TOKEN")
            .env("HOSTNAME", format!("local{k}"))
            .stdin(std::process::Stdio::null())
            .stdout(std::process::Stdio::null())
            .kill_on_drop(true);
        // Workers die with this process, also when it is killed with SIGKILL.
        super::run_dir::die_with_parent(&mut cmd);
        cmd.spawn()
    };
    let start = |isolated: bool| {
        let (processes, slots) = if isolated { (workers, 1) } else { (1, workers) };
        (0..processes).map(|k| spawn(k, slots)).collect::<std::io::Result<Vec<_>>>()
    };
    let mut children = start(isolated).context("cannot start worker processes")?;
    let client = Client::connect(&url, Some(&token), None).await?.registered(archive, local.sha256.clone());
    let work = work(client);
    tokio::pin!(work);
    // Supervise: a worker that dies (an FMU may crash it) is replaced. The first death of the
    // process of N slots replaces it with N processes of one slot: the points it held come
    // back one by one (each may be the one that crashed it), and they then run N at a time,
    // and a later crash takes only its own point.
    let mut restarts = 0;
    let result = loop {
        tokio::select! {
            r = &mut work => break r,
            _ = tokio::time::sleep(Duration::from_millis(200)) => {
                for k in 0..children.len() {
                    let Ok(Some(status)) = children[k].try_wait() else { continue };
                    restarts += 1;
                    if restarts > 1000 {
                        bail!("workers keep dying ({status}); giving up");
                    }
                    if !isolated {
                        isolated = true;
                        tracing::warn!(%status, "the worker process exited; going on with {workers} single-slot worker processes");
                        children = start(true)?;
                        break;
                    }
                    tracing::warn!(worker = k, %status, "worker exited; starting another");
                    children[k] = spawn(k, 1)?;
                }
            }
        }
    };
    for c in &mut children {
        let _ = c.start_kill();
    }
    let _ = stop_tx.send(());
    // The coordinator closes its store and the run's folder goes while the caller writes its
    // outputs; [`Stopping::wait`] waits for both.
    let stopping = Stopping(tokio::spawn(async move {
        let _ = server.await;
        for mut c in children {
            let _ = c.wait().await;
        }
        drop(state);
        tracing::debug!("local cluster: stopped, its folder removed");
    }));
    match result {
        Ok(r) => Ok((r, stopping)),
        Err(e) => {
            stopping.wait().await;
            Err(e)
        }
    }
}

/// A local cluster whose work has ended, stopping: its workers killed, its coordinator
/// closing its store, its folder about to be removed.
#[must_use = "wait for the cluster to stop before the process ends"]
pub struct Stopping(tokio::task::JoinHandle<()>);

impl Stopping {
    /// Waits until the coordinator has stopped, the workers have exited and the run's
    /// folder is removed.
    pub async fn wait(self) {
        let _ = self.0.await;
    }
}
