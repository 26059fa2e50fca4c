//! Job persistence in redb under `<data-dir>/jobs.redb`: the submitted spec (protobuf bytes),
//! the job state after every completed batch (optimizer included, as JSON), the evaluation log
//! (one entry per told point), and the result. After a restart, running jobs resume from their
//! last completed batch and the logged points of the open batch are told again rather than
//! re-evaluated; finished results stay queryable.

use std::path::Path;

use fmucal_shared::job::{CalibrationResult, HistoryPoint};
use fmucal_shared::optim::{AnyOptimizer, Outcome};
use redb::{Database, Durability, ReadableDatabase, ReadableTable, TableDefinition};
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
    pub status: i32,
    pub optimizer: AnyOptimizer,
    pub history: Vec<HistoryPoint>,
    pub failed_evaluations: u64,
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

    /// Saves the state after a completed batch, durably.
    pub fn save_state(&self, id: &str, state: &JobState) -> Result<(), CoordinatorError> {
        let tx = self.db.begin_write()?;
        tx.open_table(STATES)?.insert(id, serde_json::to_string(state)?.as_str())?;
        tx.commit()?;
        Ok(())
    }

    /// Logs one told point. Not fsynced on its own: it becomes durable with the next batch.
    pub fn log_evaluation(&self, id: &str, point: u64, outcome: Outcome) -> Result<(), CoordinatorError> {
        let mut tx = self.db.begin_write()?;
        tx.set_durability(Durability::None).map_err(|e| CoordinatorError::Storage(e.to_string()))?;
        tx.open_table(EVALS)?.insert((id, point), serde_json::to_string(&outcome)?.as_str())?;
        tx.commit()?;
        Ok(())
    }

    /// Every job: (id, spec bytes, state).
    pub fn load_all(&self) -> Result<Vec<(String, Vec<u8>, JobState)>, CoordinatorError> {
        let tx = self.db.begin_read()?;
        let specs = tx.open_table(SPECS)?;
        let states = tx.open_table(STATES)?;
        let mut out = vec![];
        for entry in states.iter()? {
            let (k, v) = entry?;
            let id = k.value().to_owned();
            let state: JobState = serde_json::from_str(v.value())?;
            let spec = specs.get(id.as_str())?.map(|s| s.value().to_vec()).unwrap_or_default();
            out.push((id, spec, state));
        }
        Ok(out)
    }

    /// Logged outcomes of a job's points.
    pub fn evaluations(&self, id: &str) -> Result<Vec<(u64, Outcome)>, CoordinatorError> {
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
