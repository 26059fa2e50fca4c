//! The warm-evaluator pool: OS threads that each own the FMU instances of the jobs they have
//! evaluated (an [`Evaluator`] per job, for up to 4 jobs, reset between points,
//! re-instantiated after a failure), fed from one queue. A request may name the thread that
//! must run it (a worker keeps one thread per slot, and sends every point of an FMU that may
//! be instantiated only once per process to thread 0) or leave it to whichever thread is
//! free. Every path that evaluates points uses it: the in-process executor, the
//! identifiability analysis and the workers. A panic while evaluating (a bug, or an FMU
//! calling back into a panicking logger) fails that point only: the thread drops the job's
//! instance and goes on, so no request is left without an answer.
//!
//! A thread stuck in an FMU that never returns cannot be stopped from outside; its owner (a
//! worker slot with a deadline) may [`EvaluatorPool::replace_thread`] it: a fresh thread takes
//! over its index and its queue, and the stuck one, if it ever returns, drops what it holds and
//! ends without taking more work. Dropping the pool joins the live threads only.

use std::collections::{HashMap, VecDeque};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::Duration;

use super::JobError;
use super::evaluator::{Evaluation, Evaluator};
use super::prepared::PreparedJob;
use super::run::WorkItem;
use crate::fmu::{Fmu, FmuError};
use crate::sim::SimError;

/// Jobs whose instances a thread keeps warm; a long-lived worker sees many jobs.
const WARM_JOBS_PER_THREAD: usize = 4;

/// One point to evaluate.
pub struct EvalRequest {
    /// Identifies the job: requests with the same key share a thread's warm instance.
    pub job_key: String,
    pub fmu: Arc<Fmu>,
    pub job: Arc<PreparedJob>,
    /// The point, in parameter order.
    pub x: Vec<f64>,
    /// The experiment to simulate (its index in the job).
    pub experiment: usize,
    pub want_residuals: bool,
    /// Called when a thread starts evaluating the point (after any wait in the queue).
    pub started: Option<Box<dyn FnOnce() + Send>>,
}

type Reply = Box<dyn FnOnce(Evaluation) + Send>;

struct Queued {
    thread: Option<usize>,
    request: EvalRequest,
    reply: Reply,
}

#[derive(Default)]
struct Queue {
    tasks: VecDeque<Queued>,
    closed: bool,
}

struct Shared {
    queue: Mutex<Queue>,
    ready: Condvar,
    /// Per thread index, the generation of the thread that serves it; a thread whose
    /// generation is older has been replaced.
    generations: Vec<AtomicU64>,
    /// Replaced or abandoned threads that have not ended yet (stuck in a model).
    stuck: AtomicU64,
}

impl Shared {
    fn lock(&self) -> MutexGuard<'_, Queue> {
        self.queue.lock().unwrap_or_else(|p| p.into_inner())
    }

    fn is_current(&self, index: usize, generation: u64) -> bool {
        self.generations[index].load(Ordering::SeqCst) == generation
    }
}

/// Threads with warm evaluators; dropping the pool lets queued work finish, then joins the live
/// threads (not the replaced or abandoned ones).
pub struct EvaluatorPool {
    shared: Arc<Shared>,
    name: String,
    /// The live thread of each index (`None` once abandoned).
    threads: Mutex<Vec<Option<JoinHandle<()>>>>,
}

impl EvaluatorPool {
    /// Starts `threads` (at least one) evaluation threads named `<name>-<k>`.
    ///
    /// # Errors
    /// The OS error if a thread cannot be started.
    pub fn new(threads: usize, name: &str) -> std::io::Result<Self> {
        let n = threads.max(1);
        let shared = Arc::new(Shared {
            queue: Mutex::new(Queue::default()),
            ready: Condvar::new(),
            generations: (0..n).map(|_| AtomicU64::new(0)).collect(),
            stuck: AtomicU64::new(0),
        });
        let threads = (0..n).map(|k| spawn(&shared, name, k, 0).map(Some)).collect::<std::io::Result<Vec<_>>>()?;
        Ok(EvaluatorPool { shared, name: name.to_owned(), threads: Mutex::new(threads) })
    }

    /// The number of thread indices.
    pub fn len(&self) -> usize {
        self.shared.generations.len()
    }

    /// Always false: a pool has at least one thread.
    pub fn is_empty(&self) -> bool {
        false
    }

    /// Gives up on the thread serving `index` (stuck in a model that does not return) and
    /// starts a fresh one in its place, which takes over the requests queued for `index`. The
    /// stuck thread is never joined; if it returns, it ends without taking more work, and the
    /// reply of the request it held goes nowhere.
    ///
    /// # Errors
    /// The OS error if the new thread cannot be started (then `index` has no thread until a
    /// later call succeeds).
    pub fn replace_thread(&self, index: usize) -> std::io::Result<()> {
        let index = index % self.len();
        self.abandon_thread(index);
        let generation = self.shared.generations[index].load(Ordering::SeqCst);
        let handle = spawn(&self.shared, &self.name, index, generation)?;
        self.lock_threads()[index] = Some(handle);
        Ok(())
    }

    /// Gives up on the thread serving `index` without replacing it (at shutdown, for a thread
    /// still busy after the grace period): dropping the pool will not wait for it.
    pub fn abandon_thread(&self, index: usize) {
        let index = index % self.len();
        self.shared.generations[index].fetch_add(1, Ordering::SeqCst);
        if self.lock_threads()[index].take().is_some() {
            self.shared.stuck.fetch_add(1, Ordering::SeqCst);
        }
        self.shared.ready.notify_all();
    }

    /// Threads given up on (replaced or abandoned) that have not ended yet.
    pub fn stuck_threads(&self) -> u64 {
        self.shared.stuck.load(Ordering::SeqCst)
    }

    fn lock_threads(&self) -> MutexGuard<'_, Vec<Option<JoinHandle<()>>>> {
        self.threads.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Queues `request` for thread `thread` (taken modulo the number of threads) or, with
    /// `None`, for the first free thread; `reply` receives the evaluation on that thread.
    pub fn submit(&self, thread: Option<usize>, request: EvalRequest, reply: impl FnOnce(Evaluation) + Send + 'static) {
        let thread = thread.map(|t| t % self.len());
        self.shared.lock().tasks.push_back(Queued { thread, request, reply: Box::new(reply) });
        self.shared.ready.notify_all();
    }

    /// Evaluates work `items` of one job, spread over the threads (all on thread 0 for an FMU
    /// that can be instantiated only once per process); the evaluations come back in the order
    /// of `items`.
    pub fn evaluate_items(
        &self,
        job_key: &str,
        fmu: &Arc<Fmu>,
        job: &Arc<PreparedJob>,
        items: &[WorkItem],
        want_residuals: bool,
    ) -> Vec<Evaluation> {
        let (tx, rx) = std::sync::mpsc::channel();
        let thread = fmu.once_per_process(job.interface).then_some(0);
        for (i, item) in items.iter().enumerate() {
            let tx = tx.clone();
            let request = EvalRequest {
                job_key: job_key.to_owned(),
                fmu: fmu.clone(),
                job: job.clone(),
                x: item.x.clone(),
                experiment: item.experiment,
                want_residuals,
                started: None,
            };
            self.submit(thread, request, move |e| {
                let _ = tx.send((i, e));
            });
        }
        drop(tx);
        let mut out: Vec<Option<Evaluation>> = vec![None; items.len()];
        for (i, e) in rx {
            out[i] = Some(e);
        }
        out.into_iter().map(|e| e.unwrap_or_else(|| Evaluation::failed("the evaluation thread stopped"))).collect()
    }
}

impl Drop for EvaluatorPool {
    fn drop(&mut self) {
        self.shared.lock().closed = true;
        self.shared.ready.notify_all();
        let threads = std::mem::take(&mut *self.lock_threads());
        for t in threads.into_iter().flatten() {
            let _ = t.join();
        }
    }
}

fn spawn(shared: &Arc<Shared>, name: &str, index: usize, generation: u64) -> std::io::Result<JoinHandle<()>> {
    let shared = shared.clone();
    std::thread::Builder::new().name(format!("{name}-{index}")).spawn(move || serve(&shared, index, generation))
}

/// Thread `me` of `generation`: takes the first task meant for it or for any thread, until the
/// pool closes and nothing is left for it, or until it has been replaced.
fn serve(shared: &Shared, me: usize, generation: u64) {
    let mut warm: HashMap<String, Evaluator> = HashMap::new();
    serve_until_replaced(shared, me, generation, &mut warm);
    if !shared.is_current(me, generation) {
        // A thread given up on has come back: its instances go, and so does it.
        drop(warm);
        shared.stuck.fetch_sub(1, Ordering::SeqCst);
    }
}

fn serve_until_replaced(shared: &Shared, me: usize, generation: u64, warm: &mut HashMap<String, Evaluator>) {
    loop {
        let task = {
            let mut q = shared.lock();
            loop {
                if !shared.is_current(me, generation) {
                    break None;
                }
                if let Some(i) = q.tasks.iter().position(|t| t.thread.is_none_or(|t| t == me)) {
                    break q.tasks.remove(i);
                }
                if q.closed {
                    break None;
                }
                q = shared.ready.wait_timeout(q, Duration::from_secs(1)).unwrap_or_else(|p| p.into_inner()).0;
            }
        };
        let Some(Queued { mut request, reply, .. }) = task else { return };
        if let Some(started) = request.started.take() {
            started();
        }
        let key = request.job_key.clone();
        let evaluation = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| evaluate(warm, request)))
            .unwrap_or_else(|panic| {
                // The instance may be in any state now: never reuse it.
                warm.remove(&key);
                let why = panic
                    .downcast_ref::<&str>()
                    .map(|s| (*s).to_owned())
                    .or_else(|| panic.downcast_ref::<String>().cloned())
                    .unwrap_or_default();
                Evaluation::failed(format!("the evaluation panicked: {why}"))
            });
        reply(evaluation);
    }
}

/// Evaluates `r` on its job's warm instance, instantiating it first if needed. A model that
/// may be instantiated only once per process can still be warm here for an earlier job (the
/// points of such models share one thread): those instances are let go and the new one is
/// tried again.
fn evaluate(warm: &mut HashMap<String, Evaluator>, r: EvalRequest) -> Evaluation {
    if !warm.contains_key(&r.job_key) {
        if warm.len() >= WARM_JOBS_PER_THREAD {
            warm.clear();
        }
        let mut fresh = Evaluator::new(&r.fmu, r.job.clone());
        if fresh.as_ref().is_err_and(held_by_another_instance) && !warm.is_empty() {
            warm.clear();
            fresh = Evaluator::new(&r.fmu, r.job.clone());
        }
        match fresh {
            Ok(ev) => {
                warm.insert(r.job_key.clone(), ev);
            }
            Err(e) => return Evaluation::failed(e.to_string()),
        }
    }
    let ev = warm.get_mut(&r.job_key).expect("warm or inserted above");
    ev.evaluate(&r.x, r.experiment, r.want_residuals)
}

/// Whether instantiating failed because the model may be instantiated only once per process
/// and an instance is live.
fn held_by_another_instance(e: &JobError) -> bool {
    matches!(
        e,
        JobError::Fmu(FmuError::OnlyOncePerProcess { .. })
            | JobError::Sim(SimError::Fmu(FmuError::OnlyOncePerProcess { .. }))
    )
}
