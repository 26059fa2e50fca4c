//! What the scheduler writes to the store, and when: a submitted job durably before it is
//! acknowledged; the points told since the last saved state (the journal, in the binary blocks
//! of [`crate::journal`]) on every tick and before each state; a job's state after every
//! completed batch and at its end; a deletion after the writes queued before it. Reading the
//! store back, to resume, is here too.
//!
//! Writes go through the store's [`Writer`] thread, so the scheduler never waits for a disk
//! flush; a write that failed comes back as a [`WriteFailure`] for the scheduler to fail the
//! jobs it concerned. The order of the writes is what makes a resume exact: a state removes
//! the journal written before it, so the journal is flushed first.

use std::collections::HashMap;
use std::sync::Arc;

use crate::error::CoordinatorError;
use crate::journal::Logged;
use crate::store::{JobState, Store, Told, Write, WriteFailure, Writer};

/// The write of a job's `state`; the journal written before it goes with it ([`Write::State`]).
pub(super) fn state_write(id: &str, state: &JobState) -> Result<Write, serde_json::Error> {
    Ok(Write::State { id: id.to_owned(), json: serde_json::to_string(state)? })
}

/// A job as stored: its id, the job as it was sent (encoded), and its state.
pub(super) type StoredJob = (String, Vec<u8>, JobState);

/// The store, its writer, and the told points not yet sent to it.
pub(super) struct Persistence {
    store: Arc<Store>,
    writer: Writer,
    /// Told points not yet sent to the writer (sent every tick and at batch ends).
    unlogged: Vec<Told>,
}

impl Persistence {
    /// Starts the writer on `store`.
    pub(super) fn new(store: Store) -> Self {
        let store = Arc::new(store);
        let writer = Writer::spawn(store.clone());
        Persistence { store, writer, unlogged: vec![] }
    }

    /// The sequence number past every job ever stored, also those whose state this version
    /// cannot read, or deleted.
    pub(super) fn next_seq(&self) -> Result<u64, CoordinatorError> {
        let mut next = self.store.next_seq()?;
        for id in self.store.job_ids()? {
            if let Some(seq) = id.strip_prefix("job-").and_then(|n| n.parse::<u64>().ok()) {
                next = next.max(seq.saturating_add(1));
            }
        }
        Ok(next)
    }

    /// Every job whose state reads.
    pub(super) fn stored_jobs(&self) -> Result<Vec<StoredJob>, CoordinatorError> {
        self.store.load_all()
    }

    /// The points journaled for job `id` since its saved state, by point id.
    pub(super) fn journaled(&self, id: &str) -> Result<HashMap<u64, Logged>, CoordinatorError> {
        Ok(self.store.evaluations(id)?.into_iter().map(|l| (l.point, l)).collect())
    }

    /// Stores a new job durably: `sent` is the job as it was sent.
    pub(super) fn create(&self, id: &str, sent: &[u8], state: &JobState) -> Result<(), CoordinatorError> {
        self.store.create(id, sent, state)
    }

    /// Journals a told point (sent to the writer with the next flush).
    pub(super) fn log(&mut self, told: Told) {
        self.unlogged.push(told);
    }

    /// Sends the told points not yet sent to the writer.
    pub(super) fn flush_log(&mut self) {
        if !self.unlogged.is_empty() {
            self.writer.send(Write::Log(std::mem::take(&mut self.unlogged)));
        }
    }

    /// Saves job `id`'s `state` (an error is logged: the job goes on unsaved).
    pub(super) fn save(&self, id: &str, state: &JobState) {
        match state_write(id, state) {
            Ok(write) => self.writer.send(write),
            Err(e) => tracing::error!(job = %id, "cannot save the job state: {e}"),
        }
    }

    /// Saves a running job's `state` after a completed batch, with the journal before it.
    pub(super) fn checkpoint(&mut self, id: &str, state: &JobState) {
        match state_write(id, state) {
            Ok(write) => {
                self.flush_log();
                self.writer.send(write);
            }
            Err(e) => tracing::error!(job = %id, "cannot save the job state: {e}"),
        }
    }

    /// Writes job `id`'s end, `write` (its final state). The ended state removes the job's
    /// journal, so its unwritten entries need not be written.
    pub(super) fn finished(&mut self, id: &str, write: Write) {
        self.unlogged.retain(|t| t.job != id);
        self.flush_log();
        self.writer.send(write);
    }

    /// Deletes job `id` from the store, after the writes queued before.
    pub(super) fn delete(&mut self, id: &str) {
        self.flush_log();
        self.writer.send(Write::Delete { id: id.to_owned() });
    }

    /// The writes that failed since last asked.
    pub(super) fn failures(&self) -> Vec<WriteFailure> {
        self.writer.failures()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fmucal_shared::job::Evaluation;

    fn told(job: &str, point: u64) -> Told {
        Told { job: job.into(), point, x: vec![point as f64], evaluation: Evaluation::failed("test") }
    }

    #[test]
    fn the_journal_of_an_ended_job_is_not_written() {
        let dir = tempfile::tempdir().unwrap();
        let mut p = Persistence::new(Store::open(dir.path()).unwrap());
        p.log(told("job-000000", 0));
        p.log(told("job-000001", 0));
        p.finished("job-000000", Write::Delete { id: "job-000000".into() });
        assert!(p.unlogged.is_empty());
        p.log(told("job-000001", 1));
        p.flush_log();
        assert!(p.unlogged.is_empty());
        assert!(p.failures().is_empty());
    }
}
