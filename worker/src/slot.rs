//! One evaluation slot: a task that takes the points the worker's poller ([`crate::poller`])
//! received, one at a time, and has each evaluated on its own thread of the worker's
//! warm-evaluator pool (thread 0 for an FMU that allows one instance per process), waiting at
//! most the evaluation deadline for each; the result goes back to the poller, which returns it
//! with its next poll.

use std::sync::Arc;
use std::time::Duration;

use fmucal_proto::convert::point_result;
use fmucal_proto::v1 as pb;
use fmucal_shared::job::Evaluation;
use fmucal_shared::job::pool::{EvalRequest, EvaluatorPool};
use tokio::sync::{oneshot, watch};

use crate::Client;
use crate::hung::Hung;
use crate::jobs::JobCache;
use crate::poller::Inbox;

pub struct SlotContext {
    /// The worker's evaluation threads; this slot's is `pool` thread `index`.
    pub pool: Arc<EvaluatorPool>,
    /// For fetching a job's spec and model the first time one of its points comes.
    pub client: Client,
    pub jobs: Arc<JobCache>,
    pub index: usize,
    /// How long an evaluation may take before it is abandoned (`None`: no limit).
    pub deadline: Option<Duration>,
    pub hung: Arc<Hung>,
    /// Turns true when the worker stops waiting for its evaluations.
    pub give_up: watch::Receiver<bool>,
    pub metrics: Option<crate::metrics::WorkerMetrics>,
}

/// Takes points from `inbox` until the poller has ended and none are left.
pub async fn run(mut s: SlotContext, inbox: Arc<Inbox>) {
    while let Some(taken) = inbox.next().await {
        let a = &taken.point;
        // Once the worker gives up on its evaluations (it needs a fresh process, or the grace
        // period of a stop has passed), the points not done go back; so does a point that
        // waited a tenth of the deadline, which could otherwise reach the coordinator past its
        // evaluation timeout.
        let late = s.deadline.is_some_and(|d| taken.received.elapsed() > d / 10);
        let why = if late {
            Some("it waited for a slot longer than a tenth of the evaluation deadline")
        } else if s.hung.restart_reason().is_some() {
            Some("the worker is restarting")
        } else if *s.give_up.borrow() {
            Some("the worker is stopping")
        } else {
            None
        };
        let evaluation = match why {
            Some(why) => Err(why),
            None => evaluate(&mut s, a).await.ok_or("the worker is stopping"),
        };
        let point = match evaluation {
            Ok(e) => {
                if let Some(m) = &s.metrics {
                    m.evaluated(e.value.is_none(), e.wall);
                }
                let point = point_result(a, e);
                tracing::debug!(job = %point.job_id, point = point.point_id, status = point.status, "point evaluated");
                point
            }
            Err(why) => {
                tracing::debug!(job = %a.job_id, point = a.point_id, why, "point handed back unevaluated");
                not_evaluated(a, why)
            }
        };
        taken.finish(point);
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
pub fn not_evaluated(a: &pb::Assignment, why: &str) -> pb::PointResult {
    pb::PointResult {
        job_id: a.job_id.clone(),
        point_id: a.point_id,
        status: pb::PointStatus::NotEvaluated as i32,
        value: f64::NAN,
        message: format!("handed back unevaluated: {why}"),
        ..Default::default()
    }
}
