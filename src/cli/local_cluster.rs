//! A cluster for one local run (`fmucal calibrate` without `--coordinator`): an in-process
//! coordinator on 127.0.0.1 (a free port) with freshly generated client and worker tokens and its state in a
//! temporary folder, and N `fmucal worker` processes of this executable, each replaced when it
//! dies (an FMU may crash it). [`run`] hands a connected [`Client`] to the work and stops
//! everything when the work ends.

use std::time::Duration;

use anyhow::{Context, Result, bail};

use super::client::Client;

/// Worker processes of a local run: `--workers`, else the job's `[workers] count`, else the
/// number of cores; at least 1.
pub fn worker_count(flag: Option<usize>, spec: &fmucal_shared::job::JobSpec) -> usize {
    flag.or(spec.workers.count)
        .unwrap_or_else(|| std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1))
        .max(1)
}

/// Starts the coordinator and `workers` worker processes, runs `work` on a client connected to
/// them while supervising the workers, then stops them all and returns the work's result.
pub async fn run<T>(workers: usize, work: impl AsyncFnOnce(Client) -> Result<T>) -> Result<T> {
    let (token, worker_token) = (super::token::generate()?, super::token::generate()?);
    let state = tempfile::tempdir()?;
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await?;
    let url = format!("http://{}", listener.local_addr()?);
    let (stop_tx, stop_rx) = tokio::sync::oneshot::channel::<()>();
    let config = fmucal_coordinator::Config {
        data_dir: state.path().join("coordinator"),
        token: Some(token.clone()),
        worker_token: Some(worker_token.clone()),
        timing: Default::default(),
        max_store_bytes: fmucal_coordinator::models::DEFAULT_MAX_STORE_BYTES,
        connections: Default::default(),
        keep_finished_jobs: None,
        tls: None,
        diagnose_program: None,
        metrics: None,
    };
    let server = tokio::spawn(fmucal_coordinator::run(config, listener, async {
        let _ = stop_rx.await;
    }));
    let exe = std::env::current_exe()?;
    let cache = state.path().join("worker-cache");
    let spawn = |k: usize| {
        tokio::process::Command::new(&exe)
            .args(["worker", "--coordinator", &url, "--cache-dir"])
            .arg(&cache)
            .env("FMUCAL_WORKER_TOKEN", &worker_token)
            .env_remove("FMUCAL_TOKEN")
            .env("HOSTNAME", format!("local{k}"))
            .stdin(std::process::Stdio::null())
            .stdout(std::process::Stdio::null())
            .kill_on_drop(true)
            .spawn()
    };
    let mut children =
        (0..workers).map(&spawn).collect::<std::io::Result<Vec<_>>>().context("cannot start worker processes")?;
    let client = Client::connect(&url, Some(&token), None).await?;
    let work = work(client);
    tokio::pin!(work);
    // Supervise: a worker that dies (an FMU may crash it) is replaced.
    let mut restarts = 0;
    let result = loop {
        tokio::select! {
            r = &mut work => break r,
            _ = tokio::time::sleep(Duration::from_millis(200)) => {
                for (k, c) in children.iter_mut().enumerate() {
                    if let Ok(Some(status)) = c.try_wait() {
                        restarts += 1;
                        if restarts > 1000 {
                            bail!("workers keep dying ({status}); giving up");
                        }
                        tracing::warn!(worker = k, %status, "worker exited; starting another");
                        *c = spawn(k)?;
                    }
                }
            }
        }
    };
    for c in &mut children {
        let _ = c.start_kill();
    }
    let _ = stop_tx.send(());
    let _ = server.await;
    result
}
