//! One evaluation slot: a task that long-polls the coordinator (asking for up to 4 points and
//! returning their results with the next poll) and has them evaluated on its own thread of the
//! worker's warm-evaluator pool (thread 0 for an FMU that allows one instance per process).

use std::sync::Arc;

use fmucal_proto::convert::point_result;
use fmucal_proto::v1 as pb;
use fmucal_shared::job::Evaluation;
use fmucal_shared::job::pool::{EvalRequest, EvaluatorPool};
use tokio::sync::{RwLock, oneshot, watch};

use crate::Client;
use crate::jobs::JobCache;

/// Points a slot asks for per poll; the coordinator grants at most a fair share.
const PREFETCH: u32 = 4;

pub struct SlotContext {
    /// The worker's evaluation threads; this slot's is `pool` thread `index`.
    pub pool: Arc<EvaluatorPool>,
    pub client: Client,
    pub worker_id: Arc<RwLock<String>>,
    pub jobs: Arc<JobCache>,
    pub stop: watch::Receiver<bool>,
    pub index: usize,
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
            let evaluation = match s.jobs.get(&mut s.client, &a.job_id).await {
                Ok(ctx) => {
                    let (reply, wait) = oneshot::channel();
                    let thread = if ctx.exclusive { 0 } else { s.index };
                    let request = EvalRequest {
                        job_key: a.job_id.clone(),
                        fmu: ctx.fmu.clone(),
                        job: ctx.job.clone(),
                        x: a.x.clone(),
                        experiment: a.experiment as usize,
                        want_residuals: a.want_residuals,
                    };
                    s.pool.submit(Some(thread), request, move |e| {
                        let _ = reply.send(e);
                    });
                    wait.await.unwrap_or_else(|_| Evaluation::failed("the evaluation thread stopped"))
                }
                Err(e) => Evaluation::failed(e),
            };
            let point = point_result(&a, evaluation);
            tracing::debug!(job = %point.job_id, point = point.point_id, status = point.status, "point evaluated");
            pending.push(point);
        }
    }
}
