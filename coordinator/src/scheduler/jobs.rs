//! The job table: every job this coordinator knows, running or finished, with its open batch
//! (the work items asked of its run and not yet told), its watchers, its clocks, and the
//! retention of finished jobs.
//!
//! A job is held in domain types: the [`JobSpec`] as read and the stored [`JobState`]. The job
//! as it was sent is kept only as opaque bytes (its protobuf encoding, made at the service edge),
//! for the store and for the workers that fetch it. The table knows neither workers (their
//! leases are [`super::leases`]'s, though a point records who holds it) nor the store
//! ([`super::persist`]), so each change of a job's life is a plain method here that the
//! scheduler composes with the other parts.

use std::collections::{BTreeMap, HashSet, VecDeque};
use std::time::Duration;

// tokio's clock, so tests can pause and advance it.
use tokio::time::Instant;

use fmucal_shared::job::run::WorkItem;
use fmucal_shared::job::{JobSpec, JobStatus};
use fmucal_shared::optim::Optimizer;

use crate::store::JobState;

/// Times a point held by a dying worker beside other points is sent again before the death
/// counts against it.
pub(super) const MAX_UNCHARGED_RETRIES: u32 = 3;

/// How long a finished job stays at least, whatever the retention cap.
pub(super) const RETENTION_GRACE: Duration = Duration::from_secs(60);

/// How often the retention cap is applied besides when a job finishes.
pub(super) const RETENTION_EVERY: Duration = Duration::from_secs(1);

pub(super) fn is_running(status: JobStatus) -> bool {
    status == JobStatus::Running
}

/// A work item of a job: a point on one experiment.
pub(super) struct Point {
    pub(super) x: Vec<f64>,
    pub(super) experiment: usize,
    pub(super) failed_on: Vec<String>,
    /// Times the point was sent again, uncharged, because a worker that held it beside other
    /// points died: any of them may have killed it ([`MAX_UNCHARGED_RETRIES`]).
    pub(super) uncharged_retries: u32,
    /// Why the last attempt failed.
    pub(super) last_error: String,
    /// The worker it is leased to, and since when.
    pub(super) assigned: Option<(String, Instant)>,
}

/// A job's open batch: the points asked and not yet told, and the order in which those not
/// leased are handed out.
pub(super) struct Batch {
    pub(super) open: BTreeMap<u64, Point>,
    pub(super) queue: VecDeque<u64>,
    /// When the batch was asked.
    pub(super) started: Instant,
}

/// What became of a point sent again uncharged ([`Batch::retry_uncharged`]).
#[derive(Debug, PartialEq, Eq)]
pub(super) enum Retry {
    /// It is no longer open: nothing to do.
    Gone,
    /// It was sent again so [`MAX_UNCHARGED_RETRIES`] times already: the death counts.
    Exhausted,
    /// Queued again.
    Queued,
}

/// What a failed attempt leaves of a point ([`Batch::attempt_failed`]).
#[derive(Debug, PartialEq, Eq)]
pub(super) enum Attempt {
    /// Queued again for another try.
    Queued,
    /// Failed on two different workers or three times in all: it is told as failed, for the
    /// last attempt's reason.
    GiveUp(String),
}

impl Batch {
    /// An empty batch; its clock starts now.
    pub(super) fn new() -> Self {
        Batch { open: BTreeMap::new(), queue: VecDeque::new(), started: Instant::now() }
    }

    /// Opens and queues the `items` not already open (a resumed batch is asked again); the
    /// batch's clock starts again.
    pub(super) fn add(&mut self, items: Vec<WorkItem>) {
        self.started = Instant::now();
        for c in items {
            if !self.open.contains_key(&c.id) {
                let point = Point {
                    x: c.x,
                    experiment: c.experiment,
                    failed_on: vec![],
                    uncharged_retries: 0,
                    last_error: String::new(),
                    assigned: None,
                };
                self.open.insert(c.id, point);
                self.queue.push_back(c.id);
            }
        }
    }

    /// Closes `point` to tell it: no longer open nor queued.
    pub(super) fn take(&mut self, point: u64) -> Option<Point> {
        let p = self.open.remove(&point)?;
        self.queue.retain(|q| *q != point);
        Some(p)
    }

    /// A worker handed `point` back unevaluated: it is queued again, first in line, without
    /// counting as an attempt. Says whether it was open.
    pub(super) fn hand_back(&mut self, point: u64) -> bool {
        let Some(p) = self.open.get_mut(&point) else { return false };
        p.assigned = None;
        self.queue.push_front(point);
        true
    }

    /// Sends `point` again without counting an attempt against it, unless it was already sent
    /// again so [`MAX_UNCHARGED_RETRIES`] times.
    pub(super) fn retry_uncharged(&mut self, point: u64) -> Retry {
        let Some(p) = self.open.get_mut(&point) else { return Retry::Gone };
        if p.uncharged_retries >= MAX_UNCHARGED_RETRIES {
            return Retry::Exhausted;
        }
        p.uncharged_retries += 1;
        p.assigned = None;
        self.queue.push_back(point);
        Retry::Queued
    }

    /// Records a failed attempt of `point` on `worker`: the point is given up after two
    /// different workers (or three attempts), else queued again. `None`: it is not open.
    pub(super) fn attempt_failed(&mut self, point: u64, worker: &str, why: &str) -> Option<Attempt> {
        let p = self.open.get_mut(&point)?;
        p.failed_on.push(worker.to_owned());
        p.last_error = why.to_owned();
        p.assigned = None;
        let distinct: HashSet<&String> = p.failed_on.iter().collect();
        if distinct.len() >= 2 || p.failed_on.len() >= 3 {
            Some(Attempt::GiveUp(std::mem::take(&mut p.last_error)))
        } else {
            self.queue.push_back(point);
            Some(Attempt::Queued)
        }
    }

    /// The leased points whose lease began more than `timeout` before `now`, with their holder.
    pub(super) fn overdue(&self, now: Instant, timeout: Duration) -> Vec<(u64, String)> {
        let mut late = vec![];
        for (pid, p) in &self.open {
            if let Some((w, at)) = &p.assigned
                && now.duration_since(*at) > timeout
            {
                late.push((*pid, w.clone()));
            }
        }
        late
    }

    /// How many of its points are leased.
    pub(super) fn leased(&self) -> usize {
        self.open.values().filter(|p| p.assigned.is_some()).count()
    }

    fn clear(&mut self) {
        self.open.clear();
        self.queue.clear();
    }
}

/// A job's progress, as its watchers are told it.
#[derive(Debug, Clone, PartialEq)]
pub struct Progress {
    pub iteration: u64,
    pub evaluations: u64,
    /// +inf before any point is told.
    pub best_f: f64,
    /// Empty before any point is told.
    pub best_x: Vec<f64>,
    /// Wall time of the round just completed (0 outside a round's end).
    pub batch_wall_s: f64,
    pub status: JobStatus,
    pub rounds: u64,
}

/// Where a job's progress goes (a client's watch stream). Sends never wait: a watcher too slow
/// to take an event misses it.
pub trait Watcher: Send {
    /// Offers `progress`; false if it was not taken (the watcher is full or gone).
    fn offer(&self, progress: &Progress) -> bool;
    /// Whether the watcher has gone away.
    fn gone(&self) -> bool;
}

pub(super) struct Job {
    /// The job as it was sent, encoded (opaque here): stored, and handed to fetching workers.
    pub(super) sent: Vec<u8>,
    /// The job as submitted: its parameter names and start, readable without the model.
    pub(super) job: JobSpec,
    pub(super) state: JobState,
    pub(super) batch: Batch,
    pub(super) watchers: Vec<Box<dyn Watcher>>,
    pub(super) started: Instant,
    /// When it finished in this process (`None`: running, or finished before it started).
    pub(super) finished_at: Option<Instant>,
}

impl Job {
    /// A job with nothing queued yet; its clocks start now.
    pub(super) fn new(sent: Vec<u8>, job: JobSpec, state: JobState) -> Self {
        Job { sent, job, state, batch: Batch::new(), watchers: vec![], started: Instant::now(), finished_at: None }
    }

    pub(super) fn is_running(&self) -> bool {
        is_running(self.state.status)
    }

    /// Its progress now; `batch_wall_s` is the wall time of the round just completed.
    pub(super) fn progress(&self, batch_wall_s: f64) -> Progress {
        let o = self.state.run.optimizer();
        let best = self.state.run.best();
        Progress {
            iteration: o.iterations(),
            evaluations: o.evaluations(),
            best_f: best.as_ref().map_or(f64::INFINITY, |b| b.1),
            best_x: best.map(|b| b.0).unwrap_or_default(),
            batch_wall_s,
            status: self.state.status,
            rounds: self.state.run.completed_rounds(),
        }
    }

    /// Tells every watcher `progress` and keeps those still there (a full one stays).
    pub(super) fn notify(&mut self, progress: &Progress) {
        self.watchers.retain(|w| w.offer(progress) || !w.gone());
    }
}

/// A running job's open batch, as leasing sees it ([`Jobs::open_batches`]).
pub(super) struct OpenBatch<'a> {
    pub(super) id: &'a str,
    pub(super) batch: &'a mut Batch,
    pub(super) want_residuals: bool,
}

/// Every job, by id, and the numbering of submissions and of ends.
pub(super) struct Jobs {
    table: BTreeMap<String, Job>,
    next_seq: u64,
    /// The next job to finish gets this [`JobState::finished_seq`].
    next_finish: u64,
    /// Finished jobs kept (the oldest past it are deleted); `None`: every one.
    keep_finished: Option<usize>,
    last_retention: Instant,
}

impl Jobs {
    pub(super) fn new() -> Self {
        Jobs {
            table: BTreeMap::new(),
            next_seq: 0,
            next_finish: 0,
            keep_finished: None,
            last_retention: Instant::now(),
        }
    }

    pub(super) fn get(&self, id: &str) -> Option<&Job> {
        self.table.get(id)
    }

    pub(super) fn get_mut(&mut self, id: &str) -> Option<&mut Job> {
        self.table.get_mut(id)
    }

    pub(super) fn iter(&self) -> impl Iterator<Item = (&String, &Job)> {
        self.table.iter()
    }

    pub(super) fn values(&self) -> impl Iterator<Item = &Job> {
        self.table.values()
    }

    pub(super) fn insert(&mut self, id: String, job: Job) {
        self.table.insert(id, job);
    }

    pub(super) fn remove(&mut self, id: &str) -> Option<Job> {
        self.table.remove(id)
    }

    /// Numbers new jobs from `seq` on at least (past a job stored, or deleted, before).
    pub(super) fn skip_past(&mut self, seq: u64) {
        self.next_seq = self.next_seq.max(seq);
    }

    /// Numbers new ends past `finished_seq`, a stored job's.
    pub(super) fn ended_before(&mut self, finished_seq: Option<u64>) {
        self.next_finish = self.next_finish.max(finished_seq.map_or(0, |f| f + 1));
    }

    /// The sequence number and id of a new job.
    pub(super) fn next_id(&mut self) -> (u64, String) {
        let seq = self.next_seq;
        self.next_seq += 1;
        (seq, format!("job-{seq:06}"))
    }

    /// Ends job `id` with `status` (its error `why` if it failed): its elapsed time and result
    /// are set and its batch closed. Returns it, or `None` if there is no such job.
    pub(super) fn finish(&mut self, id: &str, status: JobStatus, why: Option<&str>) -> Option<&mut Job> {
        let job = self.table.get_mut(id)?;
        let elapsed = job.state.elapsed_s + job.started.elapsed().as_secs_f64();
        job.state.status = status;
        job.state.finished_seq = Some(self.next_finish);
        self.next_finish += 1;
        job.finished_at = Some(Instant::now());
        job.state.elapsed_s = elapsed;
        if status == JobStatus::Failed {
            job.state.error = why.map(str::to_owned);
        }
        job.state.result = Some(job.state.run.take_result(&job.job, elapsed, why));
        job.batch.clear();
        Some(job)
    }

    /// The running jobs' open batches, oldest submission first.
    pub(super) fn open_batches(&mut self) -> Vec<OpenBatch<'_>> {
        let mut order: Vec<(u64, OpenBatch<'_>)> = self
            .table
            .iter_mut()
            .filter(|(_, j)| j.is_running())
            .map(|(id, j)| {
                let want_residuals = j.state.run.wants_residuals();
                (j.state.seq, OpenBatch { id, batch: &mut j.batch, want_residuals })
            })
            .collect();
        order.sort_by_key(|(seq, _)| *seq);
        order.into_iter().map(|(_, b)| b).collect()
    }

    /// The leased points of every job past `timeout` at `now`: (job, point, worker).
    pub(super) fn overdue(&self, now: Instant, timeout: Duration) -> Vec<(String, u64, String)> {
        let mut late = vec![];
        for (id, job) in &self.table {
            for (pid, w) in job.batch.overdue(now, timeout) {
                late.push((id.clone(), pid, w));
            }
        }
        late
    }

    /// Keeps at most `keep` finished jobs from now on; `None` keeps every job.
    pub(super) fn set_retention(&mut self, keep: Option<usize>) {
        self.keep_finished = keep;
    }

    /// Whether the retention cap is due to be applied again.
    pub(super) fn retention_due(&self) -> bool {
        self.last_retention.elapsed() >= RETENTION_EVERY
    }

    /// The finished jobs past the retention cap, those that finished first, once they have
    /// been finished for [`RETENTION_GRACE`] (so the client that waited for one can read its
    /// result): the ones to delete now.
    pub(super) fn expired(&mut self) -> Vec<String> {
        self.last_retention = Instant::now();
        let Some(keep) = self.keep_finished else { return vec![] };
        let mut finished: Vec<((u64, u64), &String, &Job)> = self
            .table
            .iter()
            .filter(|(_, j)| !j.is_running())
            .map(|(id, j)| ((j.state.finished_seq.unwrap_or(0), j.state.seq), id, j))
            .collect();
        if finished.len() <= keep {
            return vec![];
        }
        finished.sort_unstable_by_key(|(order, _, _)| *order);
        let excess = finished.len() - keep;
        finished
            .into_iter()
            .take(excess)
            .filter(|(_, _, j)| j.finished_at.is_none_or(|t| t.elapsed() >= RETENTION_GRACE))
            .map(|(_, id, _)| id.clone())
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn item(id: u64) -> WorkItem {
        WorkItem { id, experiment: 0, x: vec![id as f64] }
    }

    #[test]
    fn a_batch_queues_each_item_once_in_order() {
        let mut b = Batch::new();
        b.add(vec![item(0), item(1)]);
        b.add(vec![item(1), item(2)]);
        assert_eq!(b.queue, [0, 1, 2]);
        assert_eq!(b.take(1).unwrap().x, [1.0]);
        assert_eq!(b.queue, [0, 2]);
        assert!(b.take(1).is_none());
    }

    #[test]
    fn a_point_is_given_up_after_two_workers_or_three_attempts() {
        let mut b = Batch::new();
        b.add(vec![item(0), item(1)]);
        b.queue.clear();
        assert_eq!(b.attempt_failed(0, "a", "boom"), Some(Attempt::Queued));
        assert_eq!(b.attempt_failed(0, "b", "bang"), Some(Attempt::GiveUp("bang".into())));
        assert_eq!(b.attempt_failed(1, "a", "1"), Some(Attempt::Queued));
        assert_eq!(b.attempt_failed(1, "a", "2"), Some(Attempt::Queued));
        assert_eq!(b.attempt_failed(1, "a", "3"), Some(Attempt::GiveUp("3".into())));
        assert_eq!(b.attempt_failed(7, "a", "not open"), None);
    }

    #[test]
    fn an_uncharged_retry_is_granted_a_bounded_number_of_times() {
        let mut b = Batch::new();
        b.add(vec![item(4)]);
        for _ in 0..MAX_UNCHARGED_RETRIES {
            assert_eq!(b.retry_uncharged(4), Retry::Queued);
        }
        assert_eq!(b.retry_uncharged(4), Retry::Exhausted);
        assert_eq!(b.retry_uncharged(5), Retry::Gone);
        assert_eq!(b.open[&4].uncharged_retries, MAX_UNCHARGED_RETRIES);
    }

    #[tokio::test(start_paused = true)]
    async fn a_lease_is_overdue_only_past_the_timeout() {
        let mut b = Batch::new();
        b.add(vec![item(0), item(1)]);
        b.open.get_mut(&0).unwrap().assigned = Some(("w".into(), Instant::now()));
        let timeout = Duration::from_secs(30);
        tokio::time::advance(timeout).await;
        assert!(b.overdue(Instant::now(), timeout).is_empty());
        tokio::time::advance(Duration::from_millis(1)).await;
        assert_eq!(b.overdue(Instant::now(), timeout), [(0, "w".to_owned())]);
        assert_eq!(b.leased(), 1);
    }
}
