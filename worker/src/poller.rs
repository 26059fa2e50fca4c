//! The worker's one conversation with the coordinator about points: a single task polls for
//! all the worker's slots, so a poll carries the results of several slots and brings points
//! for several (the coordinator's cost is per poll, not per point). The points wait in an
//! [`Inbox`] that the slots ([`crate::slot`]) take them from; their results wait there until
//! a poll carries them.
//!
//! When it polls:
//! - **for work**, once a slot is idle and no point waits for one: with every result held,
//!   asking for up to [`POINTS_PER_SLOT`] per slot less the points being evaluated. This poll
//!   waits at the coordinator (a long poll) until there is work, so idle slots get new points,
//!   of any job, as soon as they are queued. One such poll is out at a time.
//! - **to deliver results** (asking for nothing, waiting for nothing) while the poll for work
//!   waits, once the coordinator may be waiting for them: when the worker holds no other point
//!   of a result's job (a job's batch is told to its optimizer only when all its points are
//!   back, so a result is not needed while a point of the same job runs here). Other results
//!   wait for the next poll, so a poll carries several.
//! - **to hand points back**: a point that has waited a second for a slot (a tenth of the
//!   deadline, if that is less) goes back with the points behind it, since a slow model of one
//!   job must not hold back the points of other jobs, which other workers can evaluate
//!   meanwhile; and on a stop the points not started go back at once.
//!
//! After a stop the poller ends once the slots have finished their points and every result is
//! sent; a poll for work still out is awaited if it carried results (it ends within its wait)
//! and dropped if it did not.

use std::collections::VecDeque;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use fmucal_proto::POINTS_PER_SLOT;
use fmucal_proto::v1 as pb;
use tokio::sync::{Notify, RwLock, watch};
use tokio::time::Instant;

use crate::Client;
use crate::slot::not_evaluated;

/// How long a point may wait for a slot before it and the points behind it are handed back.
const PATIENCE: Duration = Duration::from_secs(1);

/// How long a poll for work waits at the coordinator when there is none, milliseconds.
const LONG_POLL_MS: u32 = 2000;

/// What the poller and the slots share: the points received and not started, how many are
/// being evaluated, and the results not yet sent.
#[derive(Default)]
pub struct Inbox {
    state: Mutex<State>,
    /// Wakes the slots: a point arrived, or the poller ended.
    points: Notify,
    /// Wakes the poller: a result is in, or a slot took the last point waiting.
    changed: Notify,
}

#[derive(Default)]
struct State {
    queued: VecDeque<(pb::Assignment, Instant)>,
    running: usize,
    /// The jobs of the points being evaluated, with how many each.
    running_jobs: std::collections::HashMap<String, usize>,
    results: Vec<pb::PointResult>,
    /// The poller has ended: the slots leave once no point is left.
    closed: bool,
}

/// A point a slot took from the [`Inbox`]: [`Taken::finish`] hands in its result. Dropped
/// unfinished (a slot that ended abruptly), it goes back to the coordinator unevaluated.
pub struct Taken {
    inbox: Arc<Inbox>,
    /// The point.
    pub point: pb::Assignment,
    /// When the worker received it.
    pub received: Instant,
    finished: bool,
}

impl Taken {
    /// Hands in the point's result, for the next poll.
    pub fn finish(mut self, result: pb::PointResult) {
        self.finished = true;
        self.inbox.done(result);
    }
}

impl Drop for Taken {
    fn drop(&mut self) {
        if !self.finished {
            self.inbox.done(not_evaluated(&self.point, "its slot ended"));
        }
    }
}

impl Inbox {
    fn lock(&self) -> std::sync::MutexGuard<'_, State> {
        self.state.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    /// The next point for a slot, waiting for one; `None` once the poller has ended and none
    /// is left.
    pub async fn next(self: &Arc<Self>) -> Option<Taken> {
        loop {
            let arrived = self.points.notified();
            tokio::pin!(arrived);
            arrived.as_mut().enable();
            {
                let mut st = self.lock();
                if let Some((point, received)) = st.queued.pop_front() {
                    st.running += 1;
                    *st.running_jobs.entry(point.job_id.clone()).or_default() += 1;
                    let last = st.queued.is_empty();
                    drop(st);
                    if last {
                        // Another slot may be idle now with nothing to take: time to ask.
                        self.changed.notify_one();
                    }
                    return Some(Taken { inbox: self.clone(), point, received, finished: false });
                }
                if st.closed {
                    return None;
                }
            }
            arrived.await;
        }
    }

    fn done(&self, result: pb::PointResult) {
        let mut st = self.lock();
        st.running = st.running.saturating_sub(1);
        if let Some(n) = st.running_jobs.get_mut(&result.job_id) {
            *n -= 1;
            if *n == 0 {
                st.running_jobs.remove(&result.job_id);
            }
        }
        st.results.push(result);
        drop(st);
        self.changed.notify_one();
    }

    /// Results a poll did not deliver, to be sent first with the next one.
    fn unsent(&self, results: Vec<pb::PointResult>) {
        let mut st = self.lock();
        let later = std::mem::replace(&mut st.results, results);
        st.results.extend(later);
    }

    /// Whether the coordinator may be waiting for a result held: one whose job has no other
    /// point here, running or waiting for a slot.
    fn urgent(st: &State) -> bool {
        let queued: std::collections::HashSet<&str> = st.queued.iter().map(|(a, _)| a.job_id.as_str()).collect();
        st.results.iter().any(|r| !st.running_jobs.contains_key(&r.job_id) && !queued.contains(r.job_id.as_str()))
    }

    fn close(&self) {
        self.lock().closed = true;
        self.points.notify_waiters();
    }
}

/// What one successful poll did, for an observer ([`PollerContext::observer`]).
pub struct PollObservation<'a> {
    /// The results it delivered.
    pub results: &'a [pb::PointResult],
    /// The points it brought.
    pub assignments: usize,
    /// From sending the poll to its answer.
    pub round_trip: Duration,
}

/// Called after every successful poll (the capacity benchmark counts polls with it).
pub type Observer = Arc<dyn Fn(&PollObservation<'_>) + Send + Sync>;

pub struct PollerContext {
    pub client: Client,
    pub worker_id: Arc<RwLock<String>>,
    pub slots: usize,
    pub stop: watch::Receiver<bool>,
    /// Turns true when the worker stops waiting for its evaluations.
    pub give_up: watch::Receiver<bool>,
    /// How long an evaluation may take before it is abandoned (`None`: no limit).
    pub deadline: Option<Duration>,
    pub observer: Option<Observer>,
}

/// A poll's answer and the results it carried.
type Answered = (Result<pb::PollWorkResponse, tonic::Status>, Vec<pb::PointResult>, Duration);

/// Polls for the worker's slots until a stop has been asked and every point is answered or
/// handed back (or the coordinator stops answering for good); then the slots leave.
pub async fn run(mut p: PollerContext, inbox: Arc<Inbox>) {
    poll_until_stopped(&mut p, &inbox).await;
    inbox.close();
}

async fn poll_until_stopped(p: &mut PollerContext, inbox: &Inbox) {
    let patience = p.deadline.map_or(PATIENCE, |d| PATIENCE.min(d / 10));
    let mut failures = 0;
    // The poll for work that is out, if one is.
    let mut asking: Option<tokio::task::JoinHandle<Answered>> = None;
    let mut asking_carries_results = false;
    loop {
        let stopping = *p.stop.borrow();
        let changed = inbox.changed.notified();
        tokio::pin!(changed);
        changed.as_mut().enable();
        if stopping
            && !asking_carries_results
            && let Some(task) = asking.take()
        {
            // A poll for work carrying nothing is dropped at once (the coordinator sees its
            // caller gone and leases it nothing).
            task.abort();
        }
        let (ask, deliver, waiting_since) = {
            let mut st = inbox.lock();
            let now = Instant::now();
            let why = if stopping {
                Some("the worker is stopping")
            } else if st.queued.front().is_some_and(|(_, at)| now.duration_since(*at) >= patience) {
                Some("the worker's slots are busy with slow points")
            } else {
                None
            };
            let handing_back = why.is_some() && !st.queued.is_empty();
            if let Some(why) = why.filter(|_| handing_back) {
                let back: Vec<pb::PointResult> = st.queued.drain(..).map(|(a, _)| not_evaluated(&a, why)).collect();
                tracing::debug!(points = back.len(), why, "handing back points not started");
                st.results.extend(back);
            }
            if stopping && asking.is_none() && st.results.is_empty() && st.running == 0 {
                return;
            }
            let idle = !stopping && st.running < p.slots && st.queued.is_empty();
            let ask = (idle && asking.is_none()).then(|| {
                let max_points = (p.slots * POINTS_PER_SLOT as usize).saturating_sub(st.running).max(1) as u32;
                (std::mem::take(&mut st.results), max_points)
            });
            // Results go at once when a poll for work is out (the coordinator has nothing for
            // this worker) and it may be waiting for one of them, when points are handed back,
            // and during a stop; otherwise they wait for the next poll for work.
            let due = (asking.is_some() && Inbox::urgent(&st)) || handing_back || stopping;
            let deliver = (ask.is_none() && !st.results.is_empty() && due).then(|| std::mem::take(&mut st.results));
            (ask, deliver, st.queued.front().map(|(_, at)| *at))
        };
        if let Some((results, max_points)) = ask {
            asking_carries_results = !results.is_empty();
            let req = request(p, &results, max_points, LONG_POLL_MS).await;
            let mut client = p.client.clone();
            asking = Some(tokio::spawn(async move {
                let started = Instant::now();
                let answer = client.poll_work(req).await.map(tonic::Response::into_inner);
                (answer, results, started.elapsed())
            }));
            continue;
        }
        if let Some(results) = deliver {
            let started = Instant::now();
            let req = request(p, &results, 0, 0).await;
            let answer = p.client.poll_work(req).await.map(tonic::Response::into_inner);
            if !answered(p, inbox, (answer, results, started.elapsed()), &mut failures).await {
                return;
            }
            continue;
        }
        // Nothing to send: wait for a result, the poll for work, the stop, or a point's
        // patience to run out.
        let patience_out = async {
            match waiting_since {
                Some(at) => tokio::time::sleep_until(at + patience).await,
                None => std::future::pending().await,
            }
        };
        let asked = async {
            match asking.as_mut() {
                Some(task) => task.await,
                None => std::future::pending().await,
            }
        };
        tokio::select! {
            () = &mut changed => {}
            _ = p.stop.changed(), if !stopping => {}
            () = patience_out => {}
            joined = asked => {
                asking = None;
                asking_carries_results = false;
                let Ok(answered_poll) = joined else { continue };
                if !answered(p, inbox, answered_poll, &mut failures).await {
                    return;
                }
            }
        }
    }
}

/// A poll carrying `results`, asking for `max_points` and waiting up to `wait_ms` for them.
async fn request(p: &PollerContext, results: &[pb::PointResult], max_points: u32, wait_ms: u32) -> pb::PollWorkRequest {
    pb::PollWorkRequest { worker_id: p.worker_id.read().await.clone(), results: results.to_vec(), max_points, wait_ms }
}

/// Takes a poll's answer: queues the points it brought (handed back at once during a stop),
/// or, when it failed, keeps its results for the next poll. `false` when the coordinator has
/// stopped answering for good.
async fn answered(
    p: &mut PollerContext,
    inbox: &Inbox,
    (answer, sent, round_trip): Answered,
    failures: &mut u32,
) -> bool {
    let resp = match answer {
        Ok(r) => {
            *failures = 0;
            r
        }
        Err(e) => {
            inbox.unsent(sent);
            // Keep trying for about two minutes (the coordinator may be restarting), but not
            // past the grace period of a stop.
            *failures += 1;
            if *failures > 600 || *p.give_up.borrow() {
                tracing::error!("the coordinator stopped answering: {e}");
                return false;
            }
            tokio::time::sleep(Duration::from_millis(200)).await;
            return true;
        }
    };
    if let Some(observe) = &p.observer {
        observe(&PollObservation { results: &sent, assignments: resp.assignments.len(), round_trip });
    }
    if !resp.known {
        // The heartbeat task registers again; the points this worker held were re-queued by
        // the coordinator, and its results are no longer taken.
        tokio::time::sleep(Duration::from_millis(100)).await;
        return true;
    }
    if !resp.assignments.is_empty() {
        let now = Instant::now();
        inbox.lock().queued.extend(resp.assignments.into_iter().map(|a| (a, now)));
        inbox.points.notify_waiters();
    }
    true
}

#[cfg(test)]
mod tests {
    use std::collections::VecDeque;
    use std::sync::{Arc, Mutex};
    use std::time::Duration;

    use fmucal_proto::auth::AttachToken;
    use fmucal_proto::v1 as pb;
    use fmucal_proto::v1::worker_pool_client::WorkerPoolClient;
    use fmucal_proto::v1::worker_pool_server::{WorkerPool, WorkerPoolServer};
    use tokio::sync::{RwLock, watch};
    use tonic::codegen::tokio_stream;
    use tonic::{Request, Response, Status};

    use super::{Inbox, PollerContext, run};

    /// A coordinator that hands out `points` on the first polls and records every poll.
    #[derive(Default)]
    struct Fake {
        points: Mutex<VecDeque<pb::Assignment>>,
        /// Per poll: results carried, max_points, wait_ms, points held by the worker before it.
        polls: Mutex<Vec<(usize, u32, u32, usize)>>,
        results: Mutex<Vec<pb::PointResult>>,
        /// When each result came in.
        arrived: Mutex<Vec<(u64, std::time::Instant)>>,
        handed: Mutex<usize>,
    }

    struct Coordinator(Arc<Fake>);

    #[tonic::async_trait]
    impl WorkerPool for Coordinator {
        async fn register(&self, _: Request<pb::RegisterRequest>) -> Result<Response<pb::RegisterResponse>, Status> {
            Err(Status::unimplemented("not used"))
        }
        async fn heartbeat(&self, _: Request<pb::HeartbeatRequest>) -> Result<Response<pb::HeartbeatResponse>, Status> {
            Err(Status::unimplemented("not used"))
        }
        type FetchModelStream = tokio_stream::Iter<std::vec::IntoIter<Result<pb::FetchModelResponse, Status>>>;
        async fn fetch_model(
            &self,
            _: Request<pb::FetchModelRequest>,
        ) -> Result<Response<Self::FetchModelStream>, Status> {
            Err(Status::unimplemented("not used"))
        }
        async fn fetch_job(&self, _: Request<pb::FetchJobRequest>) -> Result<Response<pb::FetchJobResponse>, Status> {
            Err(Status::unimplemented("not used"))
        }
        async fn poll_work(&self, req: Request<pb::PollWorkRequest>) -> Result<Response<pb::PollWorkResponse>, Status> {
            let req = req.into_inner();
            let fake = &self.0;
            let now = std::time::Instant::now();
            fake.arrived.lock().unwrap().extend(req.results.iter().map(|r| (r.point_id, now)));
            let take = |max: u32| -> Vec<pb::Assignment> {
                let mut points = fake.points.lock().unwrap();
                let n = points.len().min(max as usize);
                points.drain(..n).collect()
            };
            let mut assignments: Vec<pb::Assignment> = {
                let held = fake.handed.lock().unwrap().saturating_sub(fake.results.lock().unwrap().len());
                fake.polls.lock().unwrap().push((req.results.len(), req.max_points, req.wait_ms, held));
                fake.results.lock().unwrap().extend(req.results);
                take(req.max_points)
            };
            // No work: a parked poll, answered when points come or empty at its deadline.
            let deadline = now + Duration::from_millis(u64::from(req.wait_ms));
            while assignments.is_empty() && std::time::Instant::now() < deadline {
                tokio::time::sleep(Duration::from_millis(10)).await;
                assignments = take(req.max_points);
            }
            *fake.handed.lock().unwrap() += assignments.len();
            Ok(Response::new(pb::PollWorkResponse { assignments, known: true }))
        }
    }

    fn point(id: u64) -> pb::Assignment {
        pb::Assignment { job_id: "job".into(), point_id: id, x: vec![id as f64], ..Default::default() }
    }

    /// Runs a worker's poller against a fake coordinator holding `points`, with `slots` slots
    /// that take `work(point id)` per point, until `done` says so of the fake (stopping the worker
    /// after `stop_after` too, if given); then stops it and waits for the poller and the slots
    /// to end. Returns the fake and how long it took until `done`.
    async fn run_worker(
        slots: usize,
        points: u64,
        work: fn(u64) -> Duration,
        deadline: Option<Duration>,
        stop_after: Option<Duration>,
        done: impl Fn(&Fake) -> bool,
    ) -> (Arc<Fake>, Duration) {
        let fake = Arc::new(Fake { points: Mutex::new((0..points).map(point).collect()), ..Default::default() });
        let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
        let url = format!("http://{}", listener.local_addr().unwrap());
        let server = tonic::transport::Server::builder()
            .add_service(WorkerPoolServer::new(Coordinator(fake.clone())))
            .serve_with_incoming(tonic::transport::server::TcpIncoming::from(listener));
        tokio::spawn(server);
        let channel = tonic::transport::Endpoint::from_shared(url).unwrap().connect().await.unwrap();
        let client = WorkerPoolClient::with_interceptor(channel, AttachToken::new(None).unwrap());
        let (stop_tx, stop) = watch::channel(false);
        let (_give_up_tx, give_up) = watch::channel(false);
        let inbox = Arc::new(Inbox::default());
        let ctx = PollerContext {
            client,
            worker_id: Arc::new(RwLock::new("w".into())),
            slots,
            stop,
            give_up,
            deadline,
            observer: None,
        };
        let mut tasks = tokio::task::JoinSet::new();
        tasks.spawn(run(ctx, inbox.clone()));
        for _ in 0..slots {
            let inbox = inbox.clone();
            tasks.spawn(async move {
                while let Some(taken) = inbox.next().await {
                    tokio::time::sleep(work(taken.point.point_id)).await;
                    let a = &taken.point;
                    let result = pb::PointResult {
                        job_id: a.job_id.clone(),
                        point_id: a.point_id,
                        status: pb::PointStatus::Ok as i32,
                        value: a.x[0],
                        ..Default::default()
                    };
                    taken.finish(result);
                }
            });
        }
        let started = std::time::Instant::now();
        let waited = async {
            if let Some(after) = stop_after {
                tokio::time::sleep(after).await;
                let _ = stop_tx.send(true);
            }
            while !done(&fake) {
                tokio::time::sleep(Duration::from_millis(5)).await;
            }
            let took = started.elapsed();
            let _ = stop_tx.send(true);
            while tasks.join_next().await.is_some() {}
            took
        };
        let took =
            tokio::time::timeout(Duration::from_secs(30), waited).await.expect("the poller and its slots did not end");
        (fake, took)
    }

    /// Each point's status as the fake received it. A result may arrive twice, as from a real
    /// worker (which the coordinator answers as late): one sent with a long poll that the stop
    /// interrupted is sent again with the stop's poll.
    fn statuses(fake: &Fake) -> Vec<(u64, i32)> {
        let mut v: Vec<(u64, i32)> = fake.results.lock().unwrap().iter().map(|r| (r.point_id, r.status)).collect();
        v.sort_unstable();
        v.dedup();
        v
    }

    #[tokio::test]
    async fn one_poll_serves_all_the_slots_and_results_do_not_wait_for_work() {
        let (fake, took) =
            run_worker(4, 16, |_| Duration::from_millis(20), None, None, |f| statuses(f).len() == 16).await;
        let ok = pb::PointStatus::Ok as i32;
        assert_eq!(statuses(&fake), (0..16).map(|i| (i, ok)).collect::<Vec<_>>());
        // The polls before the stop (the stop's ask for nothing).
        let polls: Vec<_> = fake.polls.lock().unwrap().clone();
        // The first poll asks for 4 points for each slot and gets all 16; once none is left to
        // take, the results come back in at most one poll per slot (polling per slot, the
        // worker would have taken 4 polls to fetch the points).
        assert_eq!(polls[0], (0, 16, 2000, 0), "{polls:?}");
        assert!(polls[1].0 > 0, "{polls:?}");
        let last = polls.iter().rposition(|p| p.0 > 0).unwrap();
        assert!(last <= 4, "16 results of 4 slots took {} polls: {polls:?}", last + 1);
        // The poll for work waits at the coordinator (2 s here, as there is none), and the
        // results that come in meanwhile go at once, asking for nothing: 16 points of 20 ms on
        // 4 slots are all back long before that poll ends.
        assert!(polls[2..].iter().all(|p| p.1 == 0 && p.2 == 0), "{polls:?}");
        assert!(took < Duration::from_millis(1500), "the last results waited for the poll for work: {took:?}");
    }

    #[tokio::test]
    async fn a_point_that_waits_too_long_for_a_slot_goes_back() {
        // Deadline 2 s: a point may wait 0.2 s for a slot; the one slot is busy for 0.6 s.
        let deadline = Some(Duration::from_secs(2));
        let (fake, _) =
            run_worker(1, 3, |_| Duration::from_millis(600), deadline, None, |f| statuses(f).len() == 3).await;
        let (ok, back) = (pb::PointStatus::Ok as i32, pb::PointStatus::NotEvaluated as i32);
        assert_eq!(statuses(&fake), [(0, ok), (1, back), (2, back)]);
        let results = fake.results.lock().unwrap();
        assert_eq!(results[0].point_id, 1, "the points waiting go back before the slow one ends");
        assert!(results[1].message.contains("busy with slow points"), "{:?}", results[1].message);
    }

    #[tokio::test]
    async fn a_stop_hands_back_the_points_not_started_and_waits_for_the_others() {
        let stop = Some(Duration::from_millis(100));
        let (fake, _) = run_worker(1, 3, |_| Duration::from_millis(400), None, stop, |f| statuses(f).len() == 3).await;
        let (ok, back) = (pb::PointStatus::Ok as i32, pb::PointStatus::NotEvaluated as i32);
        assert_eq!(statuses(&fake), [(0, ok), (1, back), (2, back)]);
        // Nothing is asked for once the stop is given.
        let polls = fake.polls.lock().unwrap();
        assert!(polls.iter().skip(1).all(|p| p.1 == 0), "{polls:?}");
    }

    #[tokio::test]
    async fn an_idle_slot_waits_for_work_while_another_is_busy() {
        // 2 slots, 1 point of 1.5 s; 0.1 s in, another point, of 50 ms, is queued at the
        // coordinator. The idle slot's poll for work is out all the while, so that point starts
        // at once, not when the busy slot is done.
        let start = std::time::Instant::now();
        let added = std::sync::atomic::AtomicBool::new(false);
        let work = |id| Duration::from_millis(if id == 0 { 1500 } else { 50 });
        let (fake, _) = run_worker(2, 1, work, None, None, |f| {
            if start.elapsed() > Duration::from_millis(100) && !added.swap(true, std::sync::atomic::Ordering::SeqCst) {
                f.points.lock().unwrap().push_back(point(1));
            }
            statuses(f).len() == 2
        })
        .await;
        let arrived = fake.arrived.lock().unwrap().clone();
        let at = |id: u64| arrived.iter().find(|(p, _)| *p == id).unwrap().1 - start;
        assert!(at(0) >= Duration::from_millis(1500), "{arrived:?}");
        assert!(at(1) < Duration::from_millis(1300), "the second point waited for the busy slot: {:?}", at(1));
    }
}
