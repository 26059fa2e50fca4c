//! Job persistence in redb under `<data-dir>/jobs.redb`: the submitted spec (protobuf bytes),
//! the job state after every completed batch (optimizer included, as JSON), the evaluation log
//! (one entry per told point), and the result. Submissions are written before they are
//! acknowledged; states and log entries go through a [`Writer`] thread that commits whatever
//! has queued up in one durable transaction, so the scheduler never waits for a disk flush. After a restart, running jobs resume from their
//! last completed batch and the logged points of the open batch are told again rather than
//! re-evaluated; finished results stay queryable.

use std::path::Path;
use std::sync::Arc;
use std::sync::mpsc;

use fmucal_shared::job::{CalibrationResult, Evaluation, JobRun, JobStatus};
use redb::{Database, ReadableDatabase, ReadableTable, TableDefinition};
use serde::{Deserialize, Serialize};

use crate::error::CoordinatorError;

const SPECS: TableDefinition<&str, &[u8]> = TableDefinition::new("job_specs");
const STATES: TableDefinition<&str, &str> = TableDefinition::new("job_states");
const EVALS: TableDefinition<(&str, u64), &str> = TableDefinition::new("evaluations");

/// Everything about a job except its spec.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct JobState {
    /// Submission order, for listing.
    pub seq: u64,
    pub status: JobStatus,
    /// The optimizer and the bookkeeping of its rounds.
    pub run: JobRun,
    /// Wall time spent before the current coordinator process.
    pub elapsed_s: f64,
    pub result: Option<CalibrationResult>,
    pub error: Option<String>,
}

pub struct Store {
    db: Database,
}

impl Store {
    pub fn open(data_dir: &Path) -> Result<Self, CoordinatorError> {
        std::fs::create_dir_all(data_dir)?;
        let db = Database::create(data_dir.join("jobs.redb"))?;
        let tx = db.begin_write()?;
        tx.open_table(SPECS)?;
        tx.open_table(STATES)?;
        tx.open_table(EVALS)?;
        tx.commit()?;
        Ok(Store { db })
    }

    /// Stores a new job durably.
    pub fn create(&self, id: &str, spec: &[u8], state: &JobState) -> Result<(), CoordinatorError> {
        let tx = self.db.begin_write()?;
        tx.open_table(SPECS)?.insert(id, spec)?;
        tx.open_table(STATES)?.insert(id, serde_json::to_string(state)?.as_str())?;
        tx.commit()?;
        Ok(())
    }

    /// The ids of every job ever stored, also those whose state cannot be read: new ids must
    /// not reuse them (their logs are still there).
    pub fn job_ids(&self) -> Result<Vec<String>, CoordinatorError> {
        let tx = self.db.begin_read()?;
        let specs = tx.open_table(SPECS)?;
        let mut ids = vec![];
        for entry in specs.iter()? {
            ids.push(entry?.0.value().to_owned());
        }
        Ok(ids)
    }

    /// Every job: (id, spec bytes, state). A state that cannot be read (written by another
    /// version of fmucal) is reported and left out, not fatal.
    pub fn load_all(&self) -> Result<Vec<(String, Vec<u8>, JobState)>, CoordinatorError> {
        let tx = self.db.begin_read()?;
        let specs = tx.open_table(SPECS)?;
        let states = tx.open_table(STATES)?;
        let mut out = vec![];
        for entry in states.iter()? {
            let (k, v) = entry?;
            let id = k.value().to_owned();
            let state: JobState = match serde_json::from_str(v.value()) {
                Ok(s) => s,
                Err(e) => {
                    tracing::error!(job = %id, "the stored job state cannot be read, leaving the job out: {e}");
                    continue;
                }
            };
            let spec = specs.get(id.as_str())?.map(|s| s.value().to_vec()).unwrap_or_default();
            out.push((id, spec, state));
        }
        Ok(out)
    }

    /// Logged evaluations of a job's points.
    pub fn evaluations(&self, id: &str) -> Result<Vec<(u64, Evaluation)>, CoordinatorError> {
        let tx = self.db.begin_read()?;
        let evals = tx.open_table(EVALS)?;
        let mut out = vec![];
        for entry in evals.range((id, 0)..=(id, u64::MAX))? {
            let (k, v) = entry?;
            out.push((k.value().1, serde_json::from_str(v.value())?));
        }
        Ok(out)
    }
}

/// A queued write.
pub enum Write {
    /// A job's state after a completed batch (JSON).
    State { id: String, json: String },
    /// Told points: (job, point, evaluation).
    Log(Vec<(String, u64, Evaluation)>),
}

/// The thread that commits queued writes in order.
pub struct Writer {
    tx: Option<mpsc::Sender<Write>>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl Writer {
    pub fn spawn(store: Arc<Store>) -> Self {
        let (tx, rx) = mpsc::channel::<Write>();
        let thread = std::thread::Builder::new()
            .name("fmucal-store".into())
            .spawn(move || {
                while let Ok(first) = rx.recv() {
                    let mut writes = vec![first];
                    writes.extend(rx.try_iter());
                    if let Err(e) = store.commit(writes) {
                        tracing::error!("cannot write job state: {e}");
                    }
                }
            })
            .ok();
        Writer { tx: Some(tx), thread }
    }

    pub fn send(&self, w: Write) {
        if let Some(tx) = &self.tx {
            let _ = tx.send(w);
        }
    }
}

impl Drop for Writer {
    /// Waits until everything queued is on disk.
    fn drop(&mut self) {
        self.tx.take();
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

impl Store {
    /// Commits a group of writes in one durable transaction (for a job's state, the last wins).
    fn commit(&self, writes: Vec<Write>) -> Result<(), CoordinatorError> {
        let tx = self.db.begin_write()?;
        {
            let mut states = tx.open_table(STATES)?;
            let mut evals = tx.open_table(EVALS)?;
            for w in &writes {
                match w {
                    Write::State { id, json } => {
                        states.insert(id.as_str(), json.as_str())?;
                    }
                    Write::Log(entries) => {
                        for (id, point, evaluation) in entries {
                            evals.insert((id.as_str(), *point), serde_json::to_string(evaluation)?.as_str())?;
                        }
                    }
                }
            }
        }
        tx.commit()?;
        Ok(())
    }
}
