//! One evaluation slot: a task that long-polls the coordinator (asking for up to 4 points and
//! returning their results with the next poll) and an OS thread that owns the
//! slot's FMU instances (one per job, reset between points, replaced after a failure).

use std::collections::HashMap;
use std::sync::Arc;
use std::sync::mpsc;

use fmucal_proto::v1 as pb;
use fmucal_shared::job::Evaluator;
use tokio::sync::{RwLock, oneshot, watch};

use crate::Client;
use crate::jobs::{JobCache, JobContext};

/// Points a slot asks for per poll; the coordinator grants at most a fair share.
const PREFETCH: u32 = 4;

pub struct SlotContext {
    /// Task queues of every slot's evaluation thread (this slot's is `threads[index]`).
    pub threads: Arc<Vec<mpsc::Sender<Task>>>,
    pub client: Client,
    pub worker_id: Arc<RwLock<String>>,
    pub jobs: Arc<JobCache>,
    pub stop: watch::Receiver<bool>,
    pub index: usize,
}

pub struct Task {
    job_id: String,
    ctx: Arc<JobContext>,
    assignment: pb::Assignment,
    reply: oneshot::Sender<pb::PointResult>,
}

/// Starts an evaluation thread and returns its task queue.
pub fn spawn_thread(index: usize) -> std::io::Result<mpsc::Sender<Task>> {
    let (tx, rx) = mpsc::channel::<Task>();
    std::thread::Builder::new().name(format!("fmucal-slot-{index}")).spawn(move || evaluator_thread(rx))?;
    Ok(tx)
}

/// A slot's evaluation thread.
fn evaluator_thread(rx: mpsc::Receiver<Task>) {
    let mut evaluators: HashMap<String, Evaluator> = HashMap::new();
    while let Ok(task) = rx.recv() {
        // Keep instances of a few recent jobs only: a long-lived worker sees many jobs.
        if !evaluators.contains_key(&task.job_id) && evaluators.len() >= 4 {
            evaluators.clear();
        }
        let a = &task.assignment;
        let result = match evaluators.entry(task.job_id.clone()) {
            std::collections::hash_map::Entry::Occupied(e) => Ok(e.into_mut()),
            std::collections::hash_map::Entry::Vacant(v) => {
                Evaluator::new(&task.ctx.fmu, task.ctx.job.clone()).map(|ev| v.insert(ev))
            }
        };
        let point = match result {
            Ok(ev) => {
                let e = ev.evaluate(&a.x, a.want_residuals);
                pb::PointResult {
                    job_id: a.job_id.clone(),
                    point_id: a.point_id,
                    status: if e.value.is_some() { pb::PointStatus::Ok } else { pb::PointStatus::SimulationFailed }
                        as i32,
                    value: e.value.unwrap_or(f64::NAN),
                    message: e.error.unwrap_or_default(),
                    wall_s: e.wall.as_secs_f64(),
                    residuals: e.residuals.unwrap_or_default(),
                }
            }
            Err(err) => failed(a, err.to_string()),
        };
        tracing::debug!(job = %point.job_id, point = point.point_id, status = point.status, "point evaluated");
        let _ = task.reply.send(point);
    }
}

fn failed(a: &pb::Assignment, message: String) -> pb::PointResult {
    pb::PointResult {
        job_id: a.job_id.clone(),
        point_id: a.point_id,
        status: pb::PointStatus::SimulationFailed as i32,
        value: f64::NAN,
        message,
        wall_s: 0.0,
        residuals: vec![],
    }
}

pub async fn run(mut s: SlotContext) {
    let mut pending: Vec<pb::PointResult> = vec![];
    let mut failures = 0;
    loop {
        let stopping = *s.stop.borrow();
        let req = pb::PollWorkRequest {
            worker_id: s.worker_id.read().await.clone(),
            results: std::mem::take(&mut pending),
            max_points: if stopping { 0 } else { PREFETCH },
            wait_ms: if stopping { 0 } else { 2000 },
        };
        let sent = req.results.clone();
        let resp = tokio::select! {
            r = s.client.poll_work(req) => r,
            _ = s.stop.changed(), if !stopping => {
                // Stop asked while waiting: hand back what we hold and leave.
                pending = sent;
                continue;
            }
        };
        let resp = match resp {
            Ok(r) => {
                failures = 0;
                r.into_inner()
            }
            Err(e) => {
                pending = sent;
                // Keep trying for about two minutes: the coordinator may be restarting.
                failures += 1;
                if failures > 600 {
                    tracing::error!("the coordinator stopped answering: {e}");
                    return;
                }
                tokio::time::sleep(std::time::Duration::from_millis(200)).await;
                continue;
            }
        };
        if stopping {
            return;
        }
        if !resp.known {
            // The heartbeat task registers again; points in hand were re-queued by the coordinator.
            tokio::time::sleep(std::time::Duration::from_millis(100)).await;
            continue;
        }
        for a in resp.assignments {
            let result = match s.jobs.get(&mut s.client, &a.job_id).await {
                Ok(ctx) => {
                    let (reply, wait) = oneshot::channel();
                    let thread = if ctx.exclusive { 0 } else { s.index };
                    let task = Task { job_id: a.job_id.clone(), ctx, assignment: a.clone(), reply };
                    if s.threads[thread].send(task).is_err() {
                        return;
                    }
                    wait.await.unwrap_or_else(|_| failed(&a, "the evaluation thread stopped".into()))
                }
                Err(e) => failed(&a, e),
            };
            pending.push(result);
        }
    }
}
