//! What the worker does about evaluations that do not return: a point past its deadline fails
//! and its slot's thread is abandoned and replaced ([`Hung::abandon`]); when that is not safe
//! or twice as many threads as slots are stuck, the worker stops and asks for a fresh process. At shutdown, [`join_within_grace`] bounds how long the slots may take.

use std::sync::{Arc, Mutex};
use std::time::Duration;

use fmucal_shared::job::Evaluation;
use fmucal_shared::job::pool::EvaluatorPool;
use tokio::sync::watch;
use tokio::task::JoinSet;

/// How long the slots may take to finish their points once a stop is asked.
pub const DEFAULT_STOP_GRACE: Duration = Duration::from_secs(20);

/// The worker's limit on stuck evaluation threads and its restart request.
pub struct Hung {
    /// Threads still stuck the worker tolerates before it asks for a fresh process: twice its
    /// slots (a thread stuck in a busy loop takes a core). One that comes back no longer counts.
    limit: usize,
    restart: Mutex<Option<String>>,
    stop: Arc<watch::Sender<bool>>,
}

impl Hung {
    /// For a worker with `slots` slots; `stop` stops the slots.
    pub fn new(slots: usize, stop: Arc<watch::Sender<bool>>) -> Self {
        Hung { limit: 2 * slots.max(1), restart: Mutex::new(None), stop }
    }

    /// The point evaluated on pool thread `thread` did not return within `deadline`: gives up
    /// on that thread and returns the point's failed evaluation. The thread is replaced, unless
    /// the model may be instantiated only once per process (`exclusive`: a second instance is
    /// not allowed while the stuck one lives) or the limit of stuck threads is reached; then
    /// the worker stops and [`Hung::restart_reason`] says why.
    pub fn abandon(&self, pool: &EvaluatorPool, thread: usize, exclusive: bool, deadline: Duration) -> Evaluation {
        let why = format!(
            "the model did not return within the worker's evaluation deadline of {:.1} s; its instance was abandoned",
            deadline.as_secs_f64()
        );
        // Threads given up on before that are still stuck, and this one.
        let stuck = pool.stuck_threads() + 1;
        tracing::error!(thread, stuck, "{why}");
        let restart = if exclusive {
            Some("a model that may be instantiated only once per process did not return".to_owned())
        } else if stuck >= self.limit as u64 {
            Some(format!("{stuck} evaluation threads are stuck in models that did not return"))
        } else {
            pool.replace_thread(thread).err().map(|e| format!("cannot start a thread to replace a stuck one: {e}"))
        };
        match restart {
            Some(reason) => {
                pool.abandon_thread(thread);
                self.request_restart(reason);
            }
            None => tracing::warn!(thread, "a fresh evaluation thread replaces the stuck one"),
        }
        Evaluation::failed(why)
    }

    fn request_restart(&self, reason: String) {
        tracing::error!("the worker stops to be restarted: {reason}");
        self.restart.lock().unwrap_or_else(|p| p.into_inner()).get_or_insert(reason);
        let _ = self.stop.send(true);
    }

    /// Why the worker asked for a fresh process, if it did.
    pub fn restart_reason(&self) -> Option<String> {
        self.restart.lock().unwrap_or_else(|p| p.into_inner()).clone()
    }
}

/// Waits for the slots to end; once `stop` turns true, waits at most `grace` more. Then the
/// slots give up on the evaluations still running (`give_up`) and hand their points back, and
/// every pool thread is abandoned so that dropping the pool does not wait for a model that does
/// not return; a poller that cannot reach the coordinator within 5 s more is aborted, with the
/// slots (the coordinator re-sends their points when this worker's registration expires).
pub async fn join_within_grace(
    slots: &mut JoinSet<()>,
    mut stop: watch::Receiver<bool>,
    grace: Duration,
    give_up: &watch::Sender<bool>,
    pool: &EvaluatorPool,
) {
    tokio::select! {
        () = join_all(slots) => return,
        _ = stop.wait_for(|stopping| *stopping) => {}
    }
    if tokio::time::timeout(grace, join_all(slots)).await.is_ok() {
        return;
    }
    tracing::warn!(
        "points still being evaluated {:.1} s after the stop was asked are handed back unevaluated",
        grace.as_secs_f64()
    );
    let _ = give_up.send(true);
    for k in 0..pool.len() {
        pool.abandon_thread(k);
    }
    if tokio::time::timeout(Duration::from_secs(5), join_all(slots)).await.is_err() {
        slots.abort_all();
    }
}

async fn join_all(slots: &mut JoinSet<()>) {
    while slots.join_next().await.is_some() {}
}
