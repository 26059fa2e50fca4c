//! Long-poll parking: a worker's poll that found no work waits here, up to its deadline, for
//! points to be queued. Whenever points are queued (a new batch, a point handed back, failed
//! or re-sent), the parked polls are offered them in the order they were parked; a poll past
//! its deadline, or whose caller went away, is answered with nothing.
//!
//! Pull keeps the coordinator from ever connecting to a worker, and parking keeps pull from
//! costing a round trip per idle interval. What a parked poll is answered with is a list of
//! [`Lease`]s; how it travels back (a gRPC reply) is the caller's [`PollReply`].

use std::collections::VecDeque;
use std::time::Duration;

// tokio's clock, so tests can pause and advance it.
use tokio::time::Instant;

use super::leases::Lease;

/// The longest a poll waits for work.
pub(super) const MAX_POLL_WAIT: Duration = Duration::from_secs(10);

/// How a poll is answered: once, with the points leased to it and whether its worker is still
/// registered.
pub(super) trait PollReply: Send {
    fn answer(self: Box<Self>, leases: Vec<Lease>, known: bool);
    /// Whether the caller went away (no one would read the answer).
    fn gone(&self) -> bool;
}

struct Parked {
    worker_id: String,
    max: usize,
    deadline: Instant,
    reply: Box<dyn PollReply>,
}

/// The parked polls, oldest first.
#[derive(Default)]
pub(super) struct Parking {
    parked: VecDeque<Parked>,
}

impl Parking {
    /// Parks worker `worker_id`'s poll for up to `max` points until `deadline`.
    pub(super) fn park(&mut self, worker_id: String, max: usize, deadline: Instant, reply: Box<dyn PollReply>) {
        self.parked.push_back(Parked { worker_id, max, deadline, reply });
    }

    /// How many polls are parked.
    #[cfg(test)]
    pub(super) fn len(&self) -> usize {
        self.parked.len()
    }

    /// Offers queued points to the parked polls, oldest first: `assign(worker, max)` leases
    /// them. A poll that got some is answered; one whose caller went away is dropped.
    pub(super) fn wake(&mut self, mut assign: impl FnMut(&str, usize) -> Vec<Lease>) {
        let mut still = VecDeque::new();
        while let Some(p) = self.parked.pop_front() {
            if p.reply.gone() {
                continue;
            }
            let a = assign(&p.worker_id, p.max);
            if a.is_empty() {
                still.push_back(p);
            } else {
                p.reply.answer(a, true);
            }
        }
        self.parked = still;
    }

    /// Answers, with nothing, the polls past their deadline at `now` or whose caller went away;
    /// `known(worker)` says whether their worker is still registered.
    pub(super) fn expire(&mut self, now: Instant, known: impl Fn(&str) -> bool) {
        let mut still = VecDeque::new();
        while let Some(p) = self.parked.pop_front() {
            if p.deadline <= now || p.reply.gone() {
                let known = known(&p.worker_id);
                p.reply.answer(vec![], known);
            } else {
                still.push_back(p);
            }
        }
        self.parked = still;
    }

    /// Answers every parked poll with nothing (the scheduler stops).
    pub(super) fn release_all(&mut self) {
        for p in self.parked.drain(..) {
            p.reply.answer(vec![], true);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scheduler::jobs::Batch;
    use crate::scheduler::leases::Leases;
    use fmucal_shared::job::run::WorkItem;
    use tokio::sync::oneshot;

    /// A poll's answer as the test reads it: the leased point ids and `known`.
    type Answer = (Vec<u64>, bool);

    impl PollReply for oneshot::Sender<Answer> {
        fn answer(self: Box<Self>, leases: Vec<Lease>, known: bool) {
            let _ = (*self).send((leases.iter().map(|l| l.point_id).collect(), known));
        }

        fn gone(&self) -> bool {
            self.is_closed()
        }
    }

    fn poll() -> (Box<dyn PollReply>, oneshot::Receiver<Answer>) {
        let (tx, rx) = oneshot::channel();
        (Box::new(tx), rx)
    }

    #[tokio::test(start_paused = true)]
    async fn a_parked_poll_is_woken_when_work_arrives() {
        let mut leases = Leases::default();
        let mut parking = Parking::default();
        let mut batch = Batch::new();
        let w = leases.register("a", 2);
        let (reply, mut rx) = poll();
        parking.park(w.clone(), 2, Instant::now() + MAX_POLL_WAIT, reply);
        let mut wake = |parking: &mut Parking, batch: &mut Batch| {
            parking.wake(|wid, max| {
                let open =
                    vec![crate::scheduler::jobs::OpenBatch { id: "job", batch: &mut *batch, want_residuals: false }];
                leases.assign(wid, max, open)
            });
        };
        // Nothing queued: the poll stays parked.
        wake(&mut parking, &mut batch);
        assert_eq!(parking.len(), 1);
        assert!(rx.try_recv().is_err());
        // A batch arrives: the poll is answered with its points, up to what it asked for.
        batch.add((0..3).map(|id| WorkItem { id, experiment: 0, x: vec![0.0] }).collect());
        wake(&mut parking, &mut batch);
        assert_eq!(parking.len(), 0);
        assert_eq!(rx.try_recv().unwrap(), (vec![0, 1], true));
        assert_eq!(batch.queue, [2]);
    }

    #[tokio::test(start_paused = true)]
    async fn a_parked_poll_is_answered_empty_at_its_deadline() {
        let mut parking = Parking::default();
        let (reply, mut rx) = poll();
        parking.park("w1".into(), 4, Instant::now() + Duration::from_millis(500), reply);
        parking.expire(Instant::now(), |_| true);
        assert_eq!(parking.len(), 1);
        tokio::time::advance(Duration::from_millis(500)).await;
        parking.expire(Instant::now(), |w| w != "w1");
        assert_eq!(parking.len(), 0);
        assert_eq!(rx.try_recv().unwrap(), (vec![], false));
    }

    #[tokio::test(start_paused = true)]
    async fn a_poll_whose_caller_left_is_dropped_unanswered() {
        let mut parking = Parking::default();
        let (reply, rx) = poll();
        parking.park("w1".into(), 4, Instant::now() + MAX_POLL_WAIT, reply);
        drop(rx);
        let mut asked = 0;
        parking.wake(|_, _| {
            asked += 1;
            vec![]
        });
        assert_eq!((asked, parking.len()), (0, 0));
    }
}
