//! The worker registry and the leases: which workers are alive (by heartbeat), how many slots
//! each has, which points each holds, and which it held and gave up. Leasing takes points from
//! the running jobs' open batches ([`super::jobs::OpenBatch`]), oldest job first, within a
//! worker's fair share; a worker's report on a point is accepted only while the point is
//! leased to it.
//!
//! A worker's id carries a random part from its registration, so it cannot be guessed and used
//! to answer another worker's points. A late result, for a point re-sent or taken back since,
//! is told apart from a forged one by the points the coordinator remembers the worker
//! answering or giving up ([`Released`]).
//!
//! Workers and reports are domain values here ([`Lease`], [`Report`]); their protobuf forms
//! are converted at the service edge ([`crate::edge`]).

use std::collections::{HashMap, HashSet, VecDeque};
use std::time::Duration;

// tokio's clock, so tests can pause and advance it.
use tokio::time::Instant;

use fmucal_shared::job::Evaluation;

use super::jobs::OpenBatch;

/// A point leased to a worker, as it is handed out.
#[derive(Debug, Clone, PartialEq)]
pub struct Lease {
    pub job_id: String,
    pub point_id: u64,
    /// The point, in the order of the job's calibrated parameters.
    pub x: Vec<f64>,
    /// Whether the job wants the weighted residuals with the value.
    pub want_residuals: bool,
    /// The experiment's index in the job.
    pub experiment: usize,
}

/// What a worker reports on a point it was leased.
#[derive(Debug, Clone, PartialEq)]
pub struct Report {
    pub job_id: String,
    pub point_id: u64,
    pub outcome: Outcome,
}

#[derive(Debug, Clone, PartialEq)]
pub enum Outcome {
    /// Handed back without evaluating it (the worker is stopping).
    NotEvaluated,
    /// Evaluated: a value, or the reason the simulation failed.
    Evaluated(Evaluation),
}

/// Whether a worker may answer a point ([`Leases::answer`]).
#[derive(Debug, PartialEq, Eq)]
pub(super) enum Answer {
    /// Leased to it: taken (the point is no longer leased to it).
    Leased,
    /// Leased to it once and answered or taken back since: late (or sent again), not forged.
    Late,
    /// Never leased to it (or forgotten, past [`MAX_RELEASED`]).
    NeverLeased,
    /// The worker is not registered.
    UnknownWorker,
}

pub(super) struct Worker {
    slots: usize,
    last_seen: Instant,
    /// The points leased to it: (job, point).
    pub(super) inflight: HashSet<(String, u64)>,
    /// Points leased to it and answered or taken back since (their job ended, or they timed
    /// out): a result for one of them is late (or sent again), not forged.
    released: Released,
}

/// The most answered or taken-back points a worker remembers; past it the oldest are
/// forgotten (a result for one of those is then logged as never leased).
const MAX_RELEASED: usize = 4096;

/// Points answered by a worker or taken back from it, the newest [`MAX_RELEASED`], as keyed
/// 64-bit fingerprints of (job, point) in a ring: at most 32 KiB a worker, whatever it has
/// answered. A hash set here would hold the job ids too and, churned by one insert and one
/// remove per result, doubled its table after about 40,000 results a worker (the capacity
/// benchmark's late RSS step). Only a result for a point no longer leased to the worker (late,
/// or forged) scans the ring, and the coordinator takes at most [`Leases::max_reports`]
/// results from one poll. A forged result whose fingerprint matches a remembered point's (odds
/// at most 2⁻⁵²) is logged as late; either way it is ignored.
struct Released {
    ring: VecDeque<u64>,
    keys: std::hash::RandomState,
}

impl Default for Released {
    fn default() -> Self {
        // Empty until the worker answers: it grows by doubling to MAX_RELEASED, then stays.
        Self { ring: VecDeque::new(), keys: std::hash::RandomState::new() }
    }
}

impl Released {
    fn fingerprint(&self, point: &(String, u64)) -> u64 {
        use std::hash::BuildHasher;
        self.keys.hash_one(point)
    }

    fn insert(&mut self, point: &(String, u64)) {
        if self.ring.len() == MAX_RELEASED {
            self.ring.pop_front();
        }
        let f = self.fingerprint(point);
        self.ring.push_back(f);
    }

    /// Whether `point` was answered or taken back (forgetting it).
    fn take(&mut self, point: &(String, u64)) -> bool {
        let f = self.fingerprint(point);
        match self.ring.iter().rposition(|&g| g == f) {
            Some(i) => {
                self.ring.remove(i);
                true
            }
            None => false,
        }
    }
}

/// The part of a worker's chosen name that goes into its id: at most
/// [`fmucal_proto::MAX_WORKER_NAME_CHARS`] letters, digits, `.`, `-` and `_` (any other
/// character becomes `_`).
fn worker_name(name: &str) -> String {
    let kept: String = name
        .chars()
        .take(fmucal_proto::MAX_WORKER_NAME_CHARS)
        .map(|c| if c.is_ascii_alphanumeric() || matches!(c, '.' | '-' | '_') { c } else { '_' })
        .collect();
    if kept.is_empty() { "worker".into() } else { kept }
}

/// 16 random hex digits from the operating system (a clock-derived fallback if it has none).
fn random_hex() -> String {
    use std::io::Read;
    let mut bytes = [0u8; 8];
    let read = std::fs::File::open("/dev/urandom").and_then(|mut f| f.read_exact(&mut bytes));
    if read.is_err() {
        let nanos = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_nanos());
        bytes = (nanos as u64).to_le_bytes();
    }
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// Why a worker's evaluation of a leased point cannot be true, if it cannot: the objective is a
/// sum of squares (never negative or NaN; +inf is an overflow, kept), and an evaluation carrying
/// residuals must carry as many as the experiment has measured values (`residuals`, if known).
pub(super) fn impossible_result(e: &Evaluation, residuals: Option<usize>) -> Option<String> {
    let value = e.value?;
    if value.is_nan() {
        return Some("value: NaN is not a sum of squares".into());
    }
    if value < 0.0 {
        return Some(format!("value: a sum of squares cannot be negative ({value:e})"));
    }
    let sent = e.residuals.as_deref().unwrap_or_default();
    match residuals {
        Some(n) if !sent.is_empty() && sent.len() != n => {
            Some(format!("residuals: {} values, but the experiment has {n} measured values", sent.len()))
        }
        _ => None,
    }
}

/// The registered workers and their leases.
#[derive(Default)]
pub(super) struct Leases {
    workers: HashMap<String, Worker>,
    next_worker: u64,
}

impl Leases {
    /// Registers a worker with `slots` slots under a fresh, unguessable id that carries its
    /// (bounded) `name`.
    pub(super) fn register(&mut self, name: &str, slots: usize) -> String {
        self.next_worker += 1;
        // A random part, so a worker id cannot be guessed and used to answer another
        // worker's points.
        let id = format!("w{}-{}-{}", self.next_worker, worker_name(name), random_hex());
        self.workers.insert(
            id.clone(),
            Worker { slots, last_seen: Instant::now(), inflight: HashSet::new(), released: Released::default() },
        );
        tracing::info!(worker = %id, slots, "worker registered");
        id
    }

    /// The worker is alive now; false if it is not registered (or expired).
    pub(super) fn heartbeat(&mut self, wid: &str) -> bool {
        match self.workers.get_mut(wid) {
            Some(w) => {
                w.last_seen = Instant::now();
                true
            }
            None => false,
        }
    }

    pub(super) fn contains(&self, wid: &str) -> bool {
        self.workers.contains_key(wid)
    }

    /// How many workers are registered.
    pub(super) fn len(&self) -> usize {
        self.workers.len()
    }

    /// Their slots in all.
    pub(super) fn slots(&self) -> usize {
        self.workers.values().map(|w| w.slots).sum()
    }

    /// The most results a poll from `wid` can carry that are not forged: one for each point
    /// leased to it and one for each it answered or gave up and is remembered (a late result).
    /// 0 if it is not registered.
    pub(super) fn max_reports(&self, wid: &str) -> usize {
        self.workers.get(wid).map_or(0, |w| w.inflight.len() + w.released.ring.len())
    }

    /// Whether `wid` may answer `point` (job, point id); if it is leased to it, the lease ends
    /// (the same answer sent again is then late, not forged).
    pub(super) fn answer(&mut self, wid: &str, point: (String, u64)) -> Answer {
        let Some(worker) = self.workers.get_mut(wid) else { return Answer::UnknownWorker };
        if !worker.inflight.remove(&point) {
            return if worker.released.take(&point) { Answer::Late } else { Answer::NeverLeased };
        }
        worker.released.insert(&point);
        Answer::Leased
    }

    /// Takes `point` back from `wid` (it timed out), if it was leased to it.
    pub(super) fn take_back(&mut self, wid: &str, point: (String, u64)) {
        if let Some(info) = self.workers.get_mut(wid)
            && info.inflight.remove(&point)
        {
            info.released.insert(&point);
        }
    }

    /// Takes back every point of job `id` (it ended) from every worker.
    pub(super) fn take_back_job(&mut self, id: &str) {
        for w in self.workers.values_mut() {
            let taken: Vec<(String, u64)> = w.inflight.iter().filter(|(j, _)| j == id).cloned().collect();
            for point in taken {
                w.inflight.remove(&point);
                w.released.insert(&point);
            }
        }
    }

    /// The workers silent for longer than `expiry` at `now`.
    pub(super) fn silent(&self, now: Instant, expiry: Duration) -> Vec<String> {
        self.workers
            .iter()
            .filter(|(_, w)| now.duration_since(w.last_seen) > expiry)
            .map(|(id, _)| id.clone())
            .collect()
    }

    /// Drops worker `wid`, returning the points it held.
    pub(super) fn remove(&mut self, wid: &str) -> Option<HashSet<(String, u64)>> {
        self.workers.remove(wid).map(|w| w.inflight)
    }

    /// Leases up to `max` queued points of `batches` (oldest job first) to worker `wid`,
    /// avoiding points that already failed on it while another worker is alive. A worker may
    /// ask for several points per poll (to amortise the round trip), but gets at most its fair
    /// share of the queue, so expensive batches still spread over the whole pool. A worker
    /// polls once for all its slots, asking [`fmucal_proto::POINTS_PER_SLOT`] per slot less
    /// the points it is evaluating, so a poll counts as a request for k = ⌈max / 4⌉ of its
    /// slots (at most the slots it has), and
    /// its share is ⌈queued × k / live slots⌉ (an older worker that polls per slot asks for 4:
    /// one slot's share).
    ///
    /// A point sent again after a worker died holding it beside others (a suspect: it may be
    /// the one that kills) goes only to an idle worker, alone, and that worker gets nothing
    /// else until it answers: if it dies again, the death is the point's own, and a healthy
    /// point is not charged for a neighbour's crash.
    pub(super) fn assign(&mut self, wid: &str, max: usize, batches: Vec<OpenBatch<'_>>) -> Vec<Lease> {
        let alone = self.workers.len() <= 1;
        let (idle, holds_suspect) = match self.workers.get(wid) {
            Some(w) => (
                w.inflight.is_empty(),
                w.inflight.iter().any(|(j, pid)| {
                    batches
                        .iter()
                        .find(|b| b.id == j)
                        .and_then(|b| b.batch.open.get(pid))
                        .is_some_and(|p| p.uncharged_retries > 0)
                }),
            ),
            None => (true, false),
        };
        if holds_suspect {
            return vec![];
        }
        let queued: usize = batches.iter().map(|b| b.batch.queue.len()).sum();
        let slots = self.slots().max(1);
        let own = self.workers.get(wid).map_or(1, |w| w.slots.max(1));
        let k = own.min(max.div_ceil(fmucal_proto::POINTS_PER_SLOT as usize)).max(1);
        let max = max.min((queued * k).div_ceil(slots).max(1));
        let mut out = vec![];
        let mut took_suspect = false;
        for OpenBatch { id, batch, want_residuals } in batches {
            let mut skipped = VecDeque::new();
            while out.len() < max && !took_suspect {
                let Some(pid) = batch.queue.pop_front() else { break };
                let Some(p) = batch.open.get_mut(&pid) else { continue };
                if !alone && p.failed_on.iter().any(|w| w == wid) {
                    skipped.push_back(pid);
                    continue;
                }
                let suspect = p.uncharged_retries > 0;
                if suspect && (!idle || !out.is_empty()) {
                    skipped.push_back(pid);
                    continue;
                }
                p.assigned = Some((wid.to_owned(), Instant::now()));
                out.push(Lease {
                    job_id: id.to_owned(),
                    point_id: pid,
                    x: p.x.clone(),
                    want_residuals,
                    experiment: p.experiment,
                });
                took_suspect = suspect;
            }
            skipped.extend(batch.queue.drain(..));
            batch.queue = skipped;
            if out.len() >= max || took_suspect {
                break;
            }
        }
        if let Some(w) = self.workers.get_mut(wid) {
            for a in &out {
                w.inflight.insert((a.job_id.clone(), a.point_id));
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scheduler::jobs::Batch;
    use fmucal_shared::job::run::WorkItem;

    fn batch(ids: &[u64]) -> Batch {
        let mut b = Batch::new();
        b.add(ids.iter().map(|&id| WorkItem { id, experiment: 0, x: vec![id as f64] }).collect());
        b
    }

    fn open<'a>(id: &'a str, batch: &'a mut Batch) -> Vec<OpenBatch<'a>> {
        vec![OpenBatch { id, batch, want_residuals: false }]
    }

    fn ids(leases: &[Lease]) -> Vec<u64> {
        leases.iter().map(|l| l.point_id).collect()
    }

    #[tokio::test]
    async fn a_point_handed_back_is_leased_again_first() {
        let mut leases = Leases::default();
        let mut b = batch(&[0, 1, 2]);
        let w = leases.register("a", 1);
        let got = leases.assign(&w, 2, open("job", &mut b));
        assert_eq!(ids(&got), [0, 1]);
        assert_eq!(b.leased(), 2);
        // The worker hands point 1 back unevaluated: its lease ends and it goes first in line.
        assert_eq!(leases.answer(&w, ("job".into(), 1)), Answer::Leased);
        assert!(b.hand_back(1));
        assert_eq!(b.queue, [1, 2]);
        assert_eq!(ids(&leases.assign(&w, 4, open("job", &mut b))), [1, 2]);
        // The same answer sent again is late, and one for a point never leased is not.
        assert_eq!(leases.answer(&w, ("job".into(), 0)), Answer::Leased);
        assert_eq!(leases.answer(&w, ("job".into(), 0)), Answer::Late);
        assert_eq!(leases.answer(&w, ("job".into(), 9)), Answer::NeverLeased);
        assert_eq!(leases.answer("nobody", ("job".into(), 2)), Answer::UnknownWorker);
    }

    #[test]
    fn a_worker_remembers_its_newest_released_points_in_fixed_memory() {
        let mut r = Released::default();
        let point = |i: u64| (format!("job-{}", i % 7), i);
        for i in 0..MAX_RELEASED as u64 {
            r.insert(&point(i));
        }
        let capacity = r.ring.capacity();
        for i in MAX_RELEASED as u64..100_000 {
            r.insert(&point(i));
        }
        // The newest MAX_RELEASED are remembered, the older forgotten, and the full ring never
        // grew.
        assert_eq!(r.ring.len(), MAX_RELEASED);
        assert_eq!(r.ring.capacity(), capacity);
        let oldest_kept = 100_000 - MAX_RELEASED as u64;
        assert!(!r.take(&point(oldest_kept - 1)));
        assert!(r.take(&point(oldest_kept)));
        assert!(r.take(&point(99_999)));
        // Taking a point forgets it; another job's point of the same number was never released.
        assert!(!r.take(&point(99_999)));
        assert!(!r.take(&("other".into(), 99_998)));
        assert!(r.take(&point(99_998)));
    }

    #[tokio::test]
    async fn a_worker_gets_its_fair_share_of_the_queue() {
        let mut leases = Leases::default();
        let mut b = batch(&[0, 1, 2, 3, 4, 5]);
        let a = leases.register("a", 1);
        let two = leases.register("b", 2);
        // 6 queued over 3 slots: 2 for each slot, however many are asked for.
        assert_eq!(ids(&leases.assign(&a, 4, open("job", &mut b))), [0, 1]);
        // Then 4 queued: a poll for both of a worker's slots gets ⌈4 × 2 / 3⌉.
        assert_eq!(ids(&leases.assign(&two, 8, open("job", &mut b))), [2, 3, 4]);
        // A poll for one slot (4 points asked, as a worker that polls per slot asks) gets one
        // slot's share, whatever slots its worker has.
        let mut leases = Leases::default();
        let mut b = batch(&[0, 1, 2, 3, 4, 5]);
        let _a = leases.register("a", 1);
        let two = leases.register("b", 2);
        assert_eq!(ids(&leases.assign(&two, 4, open("job", &mut b))), [0, 1]);
    }

    #[tokio::test]
    async fn a_point_is_not_sent_back_to_a_worker_it_failed_on_while_another_lives() {
        let mut leases = Leases::default();
        let mut b = batch(&[0, 1]);
        let a = leases.register("a", 1);
        let got = leases.assign(&a, 1, open("job", &mut b));
        assert_eq!(leases.answer(&a, ("job".into(), got[0].point_id)), Answer::Leased);
        b.attempt_failed(0, &a, "boom");
        assert_eq!(b.queue, [1, 0]);
        // Alone, it gets the point again; with another worker alive, it is skipped.
        let _other = leases.register("b", 1);
        assert_eq!(ids(&leases.assign(&a, 2, open("job", &mut b))), [1]);
        assert_eq!(b.queue, [0]);
    }

    #[tokio::test]
    async fn a_suspect_point_goes_alone_to_an_idle_worker() {
        let mut leases = Leases::default();
        let mut b = batch(&[0, 1, 2]);
        let a = leases.register("a", 1);
        assert_eq!(b.retry_uncharged(1), crate::scheduler::jobs::Retry::Queued);
        b.queue.retain(|&q| q != 1);
        b.queue.push_front(1);
        assert_eq!(ids(&leases.assign(&a, 4, open("job", &mut b))), [1]);
        // Holding a suspect, the worker gets nothing else until it answers.
        assert!(leases.assign(&a, 4, open("job", &mut b)).is_empty());
        leases.answer(&a, ("job".into(), 1));
        b.take(1);
        assert_eq!(ids(&leases.assign(&a, 4, open("job", &mut b))), [0, 2]);
    }

    #[tokio::test(start_paused = true)]
    async fn a_silent_worker_is_found_and_gives_its_points_back() {
        let mut leases = Leases::default();
        let mut b = batch(&[0, 1]);
        let a = leases.register("a", 1);
        assert_eq!(ids(&leases.assign(&a, 2, open("job", &mut b))), [0, 1]);
        let live = leases.register("b", 2);
        let expiry = Duration::from_secs(5);
        tokio::time::advance(Duration::from_secs(3)).await;
        assert!(leases.heartbeat(&live));
        tokio::time::advance(Duration::from_secs(3)).await;
        assert_eq!(leases.silent(Instant::now(), expiry), [a.clone()]);
        let held = leases.remove(&a).unwrap();
        assert_eq!(held, HashSet::from([("job".to_owned(), 0), ("job".to_owned(), 1)]));
        assert!(!leases.heartbeat(&a));
    }

    #[test]
    fn an_impossible_evaluation_is_named() {
        let e = |value: f64, residuals: Vec<f64>| Evaluation {
            value: Some(value),
            residuals: Some(residuals),
            error: None,
            wall: Duration::ZERO,
        };
        assert!(impossible_result(&e(f64::NAN, vec![]), None).unwrap().contains("NaN"));
        assert!(impossible_result(&e(-1.0, vec![]), None).unwrap().contains("negative"));
        assert!(impossible_result(&e(1.0, vec![0.0; 3]), Some(2)).unwrap().contains("3 values"));
        assert_eq!(impossible_result(&e(f64::INFINITY, vec![]), Some(2)), None);
        assert_eq!(impossible_result(&e(1.0, vec![0.0; 2]), Some(2)), None);
        assert_eq!(impossible_result(&Evaluation::failed("boom"), Some(2)), None);
    }

    #[test]
    fn a_worker_name_is_bounded_and_plain() {
        assert_eq!(worker_name("node-1.a_b"), "node-1.a_b");
        assert_eq!(worker_name("a b/c"), "a_b_c");
        assert_eq!(worker_name(""), "worker");
    }
}
