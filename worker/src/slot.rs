//! One evaluation slot: a task that long-polls the coordinator (asking for up to 4 points and
//! returning their results with the next poll) and has them evaluated on its own thread of the
//! worker's warm-evaluator pool (thread 0 for an FMU that allows one instance per process),
//! waiting at most the evaluation deadline for each.

use std::sync::Arc;
use std::time::Duration;

use fmucal_proto::convert::point_result;
use fmucal_proto::v1 as pb;
use fmucal_shared::job::Evaluation;
use fmucal_shared::job::pool::{EvalRequest, EvaluatorPool};
use tokio::sync::{RwLock, oneshot, watch};

use crate::Client;
use crate::hung::Hung;
use crate::jobs::JobCache;

/// Points a slot asks for per poll; the coordinator grants at most a fair share.
const PREFETCH: u32 = 4;

/// How long a point may run before the slot hands back the points it fetched with it and has
/// not started (at most a tenth of the deadline): a slow or hung model of one job must not
/// hold back the points of other jobs, which the worker's other slots or other workers can
/// evaluate meanwhile.
const PATIENCE: Duration = Duration::from_secs(1);

pub struct SlotContext {
    /// The worker's evaluation threads; this slot's is `pool` thread `index`.
    pub pool: Arc<EvaluatorPool>,
    pub client: Client,
    pub worker_id: Arc<RwLock<String>>,
    pub jobs: Arc<JobCache>,
    pub stop: watch::Receiver<bool>,
    pub index: usize,
    /// How long an evaluation may take before it is abandoned (`None`: no limit).
    pub deadline: Option<Duration>,
    pub hung: Arc<Hung>,
    /// Turns true when the worker stops waiting for its evaluations.
    pub give_up: watch::Receiver<bool>,
    pub metrics: Option<crate::metrics::WorkerMetrics>,
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
                // Keep trying for about two minutes (the coordinator may be restarting), but
                // not past the grace period of a stop.
                failures += 1;
                if failures > 600 || *s.give_up.borrow() {
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
        let received = tokio::time::Instant::now();
        let mut waiting: std::collections::VecDeque<pb::Assignment> = resp.assignments.into();
        while let Some(a) = waiting.pop_front() {
            // Once the worker gives up on its evaluations (it needs a fresh process, or the
            // grace period of a stop has passed), the points not done go back; so do the
            // points after one that took a tenth of the deadline, which could otherwise reach
            // the coordinator past its evaluation timeout.
            let late = s.deadline.is_some_and(|d| received.elapsed() > d / 10);
            let evaluation = if late || s.hung.restart_reason().is_some() || *s.give_up.borrow() {
                None
            } else {
                let (mut client, worker_id) = (s.client.clone(), s.worker_id.clone());
                let patience = s.deadline.map_or(PATIENCE, |d| PATIENCE.min(d / 10));
                let evaluating = evaluate(&mut s, &a);
                tokio::pin!(evaluating);
                tokio::select! {
                    e = &mut evaluating => e,
                    () = tokio::time::sleep(patience), if !waiting.is_empty() => {
                        // Hand the points not started back now, while this one goes on.
                        let back: Vec<pb::PointResult> =
                            waiting.drain(..).map(|w| not_evaluated(&w, "the slot is busy with a slow point")).collect();
                        tracing::debug!(points = back.len(), "handing back points held behind a slow one");
                        let req = pb::PollWorkRequest {
                            worker_id: worker_id.read().await.clone(),
                            results: back.clone(),
                            max_points: 0,
                            wait_ms: 0,
                        };
                        if client.poll_work(req).await.is_err() {
                            pending.extend(back);
                        }
                        evaluating.await
                    }
                }
            };
            let point = match evaluation {
                Some(e) => {
                    if let Some(m) = &s.metrics {
                        m.evaluated(e.value.is_none(), e.wall);
                    }
                    let point = point_result(&a, e);
                    tracing::debug!(job = %point.job_id, point = point.point_id, status = point.status, "point evaluated");
                    point
                }
                None => {
                    tracing::debug!(job = %a.job_id, point = a.point_id, "point handed back unevaluated");
                    not_evaluated(&a, "the worker is stopping")
                }
            };
            pending.push(point);
        }
    }
}

/// Evaluates one assignment under the deadline; `None` if the worker gave up waiting.
async fn evaluate(s: &mut SlotContext, a: &pb::Assignment) -> Option<Evaluation> {
    let ctx = match s.jobs.get(&mut s.client, &a.job_id).await {
        Ok(ctx) => ctx,
        Err(e) => return Some(Evaluation::failed(e)),
    };
    let (reply, wait) = oneshot::channel();
    let (started_tx, started) = oneshot::channel();
    let thread = if ctx.exclusive { 0 } else { s.index };
    let request = EvalRequest {
        job_key: a.job_id.clone(),
        fmu: ctx.fmu.clone(),
        job: ctx.job.clone(),
        x: a.x.clone(),
        experiment: a.experiment as usize,
        want_residuals: a.want_residuals,
        started: Some(Box::new(move || {
            let _ = started_tx.send(());
        })),
    };
    tracing::debug!(job = %a.job_id, point = a.point_id, thread, "evaluating point");
    s.pool.submit(Some(thread), request, move |e| {
        let _ = reply.send(e);
    });
    let stopped = |_| Evaluation::failed("the evaluation thread stopped");
    // The deadline runs from when a thread starts on the point, not while it waits in the
    // queue (points of a once-per-process model share thread 0).
    let within_deadline = async {
        let Some(deadline) = s.deadline else { return wait.await.unwrap_or_else(stopped) };
        let mut wait = wait;
        tokio::select! {
            biased;
            evaluation = &mut wait => return evaluation.unwrap_or_else(stopped),
            _ = started => {}
        }
        match tokio::time::timeout(deadline, wait).await {
            Ok(evaluation) => evaluation.unwrap_or_else(stopped),
            Err(_) => {
                // A thread that held a once-per-process model must not be replaced while it lives.
                let exclusive = ctx.exclusive || (thread == 0 && s.jobs.has_exclusive().await);
                s.hung.abandon(&s.pool, thread, exclusive, deadline)
            }
        }
    };
    let mut give_up = s.give_up.clone();
    tokio::select! {
        e = within_deadline => Some(e),
        _ = give_up.wait_for(|g| *g) => None,
    }
}

/// Hands a point back unevaluated (saying `why`): the coordinator re-sends it, to this worker
/// or another.
fn not_evaluated(a: &pb::Assignment, why: &str) -> pb::PointResult {
    pb::PointResult {
        job_id: a.job_id.clone(),
        point_id: a.point_id,
        status: pb::PointStatus::NotEvaluated as i32,
        value: f64::NAN,
        message: format!("handed back unevaluated: {why}"),
        ..Default::default()
    }
}
