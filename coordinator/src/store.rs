//! Job persistence in redb under `<data-dir>/jobs.redb`: the submitted spec (protobuf bytes),
//! the job state after every completed batch (optimizer included, as JSON), the journal of a
//! running job (the points told since its last saved state, in the binary blocks of
//! [`crate::journal`]: each saved state removes the journal before it), and the result. Stores
//! written before the journal kept one JSON entry per told point instead (table
//! `evaluations`): they are still read, and resume as exactly.
//!
//! Submissions are written before they are acknowledged; states and journal blocks go through
//! a [`Writer`] thread that commits whatever has queued up in one durable transaction, so the
//! scheduler never waits for a disk flush. After a restart, running jobs resume from their
//! last completed batch and the journaled points of the open batch are told again rather than
//! re-evaluated; finished results stay queryable.
//!
//! A write that fails (a full disk) is reported to the scheduler ([`Writer::failures`]), which
//! fails the jobs it concerned; redb refuses every later write until the database is opened
//! again, so the writer reopens it and keeps the failed job states to write again, until the
//! disk has room.

use std::collections::BTreeMap;
use std::path::Path;
use std::sync::mpsc;
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Duration;

use fmucal_shared::job::{CalibrationResult, Evaluation, JobRun, JobStatus};
use redb::{Database, ReadableDatabase, ReadableTable, TableDefinition};
use serde::{Deserialize, Serialize};

use crate::error::CoordinatorError;
use crate::journal::{self, Logged};

pub(crate) const SPECS: TableDefinition<&str, &[u8]> = TableDefinition::new("job_specs");
pub(crate) const STATES: TableDefinition<&str, &str> = TableDefinition::new("job_states");
/// The former evaluation log: (job, point) → the point's [`Evaluation`] as JSON. Read, and
/// emptied with its job, but no longer written.
pub(crate) const EVALS: TableDefinition<(&str, u64), &str> = TableDefinition::new("evaluations");
/// The journal: (job, lowest point id of the block) → a block of told points ([`journal`]).
pub(crate) const JOURNAL: TableDefinition<(&str, u64), &[u8]> = TableDefinition::new("journal");
/// `next_seq`: past every job ever stored, deleted ones included, so ids are never reused.
pub(crate) const META: TableDefinition<&str, u64> = TableDefinition::new("meta");

/// The layout of a stored [`JobState`]. A state without the field (0) was written before it
/// existed, in the layout of 1; a state of a later layout is left out, not misread.
pub const STATE_FORMAT: u32 = 1;

/// Everything about a job except its spec.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct JobState {
    /// [`STATE_FORMAT`] when written.
    #[serde(default)]
    pub format: u32,
    /// Submission order, for listing.
    pub seq: u64,
    pub status: JobStatus,
    /// The optimizer and the bookkeeping of its rounds.
    pub run: JobRun,
    /// Wall time spent before the current coordinator process.
    pub elapsed_s: f64,
    pub result: Option<CalibrationResult>,
    pub error: Option<String>,
    /// In which order the job finished (retention deletes those that finished first); `None`
    /// while running, and for jobs finished before fmucal recorded it.
    #[serde(default)]
    pub finished_seq: Option<u64>,
}

/// redb's page cache (its default, 1 GiB, kept a coordinator that had run 300 jobs at 700 MB).
const CACHE_BYTES: usize = 64 << 20;

/// Opens the database (again, after an I/O error).
type Opener = Box<dyn Fn() -> Result<Database, redb::DatabaseError> + Send + Sync>;

pub struct Store {
    db: Mutex<Option<Database>>,
    open: Opener,
}

impl Store {
    pub fn open(data_dir: &Path) -> Result<Self, CoordinatorError> {
        std::fs::create_dir_all(data_dir)?;
        let path = data_dir.join("jobs.redb");
        Self::with_opener(Box::new(move || Database::builder().set_cache_size(CACHE_BYTES).create(&path)))
    }

    /// A store in memory only, for a coordinator whose jobs end with its process (a local
    /// run's): no file, nothing to resume.
    pub fn in_memory() -> Result<Self, CoordinatorError> {
        Self::with_opener(Box::new(|| Database::builder().create_with_backend(redb::backends::InMemoryBackend::new())))
    }

    /// A store on the database `open` returns, called again to reopen it after an I/O error
    /// (tests use a redb backend that can fail its writes).
    pub fn with_opener(open: Opener) -> Result<Self, CoordinatorError> {
        let db = open()?;
        let tx = db.begin_write()?;
        tx.open_table(SPECS)?;
        tx.open_table(STATES)?;
        tx.open_table(EVALS)?;
        tx.open_table(JOURNAL)?;
        tx.open_table(META)?;
        tx.commit()?;
        Ok(Store { db: Mutex::new(Some(db)), open })
    }

    /// The open database. Closed after a write error, it is opened again only on the writer
    /// thread (`reopen`: opening may repair the file, which takes a while); elsewhere that is
    /// an error, so the scheduler never waits for it.
    fn db(&self, reopen: bool) -> Result<MutexGuard<'_, Option<Database>>, CoordinatorError> {
        let mut guard = self.db.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        if guard.is_none() {
            if !reopen {
                return Err(CoordinatorError::Storage(
                    "the job store is being reopened after a write error (is the disk full?)".into(),
                ));
            }
            *guard = Some((self.open)()?);
            tracing::info!("the job store is open again");
        }
        Ok(guard)
    }

    /// Closes the database after an I/O error; the next use opens it again.
    fn reopen_later(&self) {
        let mut guard = self.db.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        guard.take();
    }

    /// The sequence number past every job ever stored, deleted ones included.
    pub fn next_seq(&self) -> Result<u64, CoordinatorError> {
        let db = self.db(false)?;
        let tx = db.as_ref().expect("opened").begin_read()?;
        let meta = tx.open_table(META)?;
        Ok(meta.get("next_seq")?.map_or(0, |v| v.value()))
    }

    /// Stores a new job durably.
    pub fn create(&self, id: &str, spec: &[u8], state: &JobState) -> Result<(), CoordinatorError> {
        self.insert_job(id, spec, state.seq, &serde_json::to_string(state)?)
    }

    fn insert_job(&self, id: &str, spec: &[u8], seq: u64, state_json: &str) -> Result<(), CoordinatorError> {
        let db = self.db(false)?;
        let written = (|| -> Result<(), CoordinatorError> {
            let tx = db.as_ref().expect("opened").begin_write()?;
            tx.open_table(SPECS)?.insert(id, spec)?;
            tx.open_table(STATES)?.insert(id, state_json)?;
            let mut meta = tx.open_table(META)?;
            let next = meta.get("next_seq")?.map_or(0, |v| v.value()).max(seq + 1);
            meta.insert("next_seq", next)?;
            drop(meta);
            tx.commit()?;
            Ok(())
        })();
        drop(db);
        if written.is_err() {
            self.reopen_later();
        }
        written
    }

    /// Writes a job as salvaged from a damaged store: spec, state JSON, the former JSON log's
    /// entries and the journal's blocks, as they were stored.
    pub(crate) fn restore_job(
        &self,
        id: &str,
        spec: &[u8],
        state_json: &str,
        evaluations: &[(u64, String)],
        journal: &[(u64, Vec<u8>)],
    ) -> Result<(), CoordinatorError> {
        let seq = id.strip_prefix("job-").and_then(|n| n.parse::<u64>().ok()).unwrap_or(0);
        self.insert_job(id, spec, seq, state_json)?;
        let db = self.db(false)?;
        let tx = db.as_ref().expect("opened").begin_write()?;
        {
            let mut evals = tx.open_table(EVALS)?;
            for (point, json) in evaluations {
                evals.insert((id, *point), json.as_str())?;
            }
            let mut blocks = tx.open_table(JOURNAL)?;
            for (first, block) in journal {
                blocks.insert((id, *first), block.as_slice())?;
            }
        }
        tx.commit()?;
        Ok(())
    }

    /// The ids of every job ever stored, also those whose state cannot be read: new ids must
    /// not reuse them (their logs are still there).
    pub fn job_ids(&self) -> Result<Vec<String>, CoordinatorError> {
        let db = self.db(false)?;
        let tx = db.as_ref().expect("opened").begin_read()?;
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
        let db = self.db(false)?;
        let tx = db.as_ref().expect("opened").begin_read()?;
        let specs = tx.open_table(SPECS)?;
        let states = tx.open_table(STATES)?;
        let mut out = vec![];
        for entry in states.iter()? {
            let (k, v) = entry?;
            let id = k.value().to_owned();
            let state: JobState = match serde_json::from_str::<JobState>(v.value()) {
                Ok(s) if s.format > STATE_FORMAT => {
                    let why = format!("format {} is newer than this version reads ({STATE_FORMAT})", s.format);
                    tracing::error!(job = %id, "the stored job state cannot be read, leaving the job out: {why}");
                    continue;
                }
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

    /// The told points a job's journal keeps: those of the former JSON log first (without
    /// their x), then the journal's blocks in key order; a point told twice is listed twice,
    /// the later telling last. A block that does not decode is reported and left out (its
    /// points are evaluated again).
    pub fn evaluations(&self, id: &str) -> Result<Vec<Logged>, CoordinatorError> {
        let db = self.db(false)?;
        let tx = db.as_ref().expect("opened").begin_read()?;
        let evals = tx.open_table(EVALS)?;
        let mut out = vec![];
        for entry in evals.range((id, 0)..=(id, u64::MAX))? {
            let (k, v) = entry?;
            out.push(Logged { point: k.value().1, x: None, evaluation: serde_json::from_str(v.value())? });
        }
        let blocks = tx.open_table(JOURNAL)?;
        for entry in blocks.range((id, 0)..=(id, u64::MAX))? {
            let (k, v) = entry?;
            match journal::decode(v.value()) {
                Ok(points) => out.extend(points),
                Err(e) => tracing::error!(job = %id, block = k.value().1, "{e}: its points are evaluated again"),
            }
        }
        Ok(out)
    }
}

/// A queued write.
pub enum Write {
    /// A job's state (JSON), after a completed batch or at its end. It removes the job's
    /// journal written before it: the state holds every point told by then (and a finished
    /// job's result its evaluated points), so the journal only ever holds the points told
    /// since the last saved state, those of the open batch.
    State { id: String, json: String },
    /// Told points, in the order they were told.
    Log(Vec<Told>),
    /// Removes a job: its spec, state and journal.
    Delete { id: String },
}

/// A point told to its job's optimizer, for the journal.
#[derive(Debug, Clone)]
pub struct Told {
    pub job: String,
    pub point: u64,
    /// The point as handed out.
    pub x: Vec<f64>,
    pub evaluation: Evaluation,
}

/// A group of writes that could not be committed: the jobs it concerned and why.
#[derive(Debug, Clone)]
pub struct WriteFailure {
    pub jobs: Vec<String>,
    pub error: String,
}

/// How often the writer tries again to write the job states a failed commit left unwritten.
const RETRY_EVERY: Duration = Duration::from_secs(1);

/// The thread that commits queued writes in order.
pub struct Writer {
    tx: Option<mpsc::Sender<Write>>,
    failures: mpsc::Receiver<WriteFailure>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl Writer {
    pub fn spawn(store: Arc<Store>) -> Self {
        let (tx, rx) = mpsc::channel::<Write>();
        let (failed_tx, failures) = mpsc::channel::<WriteFailure>();
        let thread = std::thread::Builder::new()
            .name("fmucal-store".into())
            .spawn(move || write_until_closed(&store, &rx, &failed_tx))
            .ok();
        Writer { tx: Some(tx), failures, thread }
    }

    pub fn send(&self, w: Write) {
        if let Some(tx) = &self.tx {
            let _ = tx.send(w);
        }
    }

    /// The failed commits reported since the last call.
    pub fn failures(&self) -> Vec<WriteFailure> {
        self.failures.try_iter().collect()
    }
}

/// The writer thread: commits what has queued up in one transaction. After a failure it
/// reports the jobs concerned, has the database reopened, and keeps their latest states
/// and deletions (later writes of the same job replace them) to commit with the next group, or
/// alone every [`RETRY_EVERY`], until they are written. Evaluation logs of a failed group are
/// dropped: the jobs they belong to are failed.
fn write_until_closed(store: &Store, rx: &mpsc::Receiver<Write>, failed: &mpsc::Sender<WriteFailure>) {
    let mut unwritten: BTreeMap<String, Write> = BTreeMap::new();
    loop {
        let first = if unwritten.is_empty() {
            match rx.recv() {
                Ok(w) => Some(w),
                Err(_) => return,
            }
        } else {
            match rx.recv_timeout(RETRY_EVERY) {
                Ok(w) => Some(w),
                Err(mpsc::RecvTimeoutError::Timeout) => None,
                Err(mpsc::RecvTimeoutError::Disconnected) => {
                    // Closing: one last try for what is left.
                    let _ = commit_group(store, retried(&mut unwritten), &mut unwritten, failed);
                    return;
                }
            }
        };
        let mut writes = retried(&mut unwritten);
        writes.extend(first);
        writes.extend(rx.try_iter());
        let _ = commit_group(store, writes, &mut unwritten, failed);
    }
}

/// The states and deletions left unwritten (they go first: a later write of a job replaces its).
fn retried(unwritten: &mut BTreeMap<String, Write>) -> Vec<Write> {
    std::mem::take(unwritten).into_values().collect()
}

fn commit_group(
    store: &Store,
    writes: Vec<Write>,
    unwritten: &mut BTreeMap<String, Write>,
    failed: &mpsc::Sender<WriteFailure>,
) -> Result<(), ()> {
    if writes.is_empty() {
        return Ok(());
    }
    let Err(e) = store.commit(&writes) else { return Ok(()) };
    let error = e.to_string();
    tracing::error!("cannot write job state: {error}");
    store.reopen_later();
    let mut jobs = vec![];
    for w in writes {
        match w {
            Write::State { ref id, .. } => {
                jobs.push(id.clone());
                unwritten.insert(id.clone(), w);
            }
            Write::Log(entries) => jobs.extend(entries.into_iter().map(|t| t.job)),
            Write::Delete { ref id } => {
                unwritten.insert(id.clone(), w);
            }
        }
    }
    jobs.sort_unstable();
    jobs.dedup();
    let _ = failed.send(WriteFailure { jobs, error });
    Err(())
}

impl Drop for Writer {
    /// Waits until everything queued is on disk (one last try for states a failed write left).
    fn drop(&mut self) {
        self.tx.take();
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

impl Store {
    /// Commits a group of writes in one durable transaction, in order (for a job's state, the
    /// last wins).
    fn commit(&self, writes: &[Write]) -> Result<(), CoordinatorError> {
        let db = self.db(true)?;
        let tx = db.as_ref().expect("opened").begin_write()?;
        {
            let mut specs = tx.open_table(SPECS)?;
            let mut states = tx.open_table(STATES)?;
            let mut evals = tx.open_table(EVALS)?;
            let mut blocks = tx.open_table(JOURNAL)?;
            let mut meta = tx.open_table(META)?;
            for w in writes {
                match w {
                    Write::State { id, json } => {
                        // A state written after its job was deleted stays deleted.
                        if specs.get(id.as_str())?.is_some() {
                            states.insert(id.as_str(), json.as_str())?;
                        }
                        evals.retain_in((id.as_str(), 0)..=(id.as_str(), u64::MAX), |_, _| false)?;
                        blocks.retain_in((id.as_str(), 0)..=(id.as_str(), u64::MAX), |_, _| false)?;
                    }
                    Write::Log(entries) => {
                        // One block per job, keyed by its lowest point: the blocks of a job hold
                        // disjoint points, unless a point is told again after a resume found its
                        // logged x changed; then the new records go after the block's.
                        let mut by_job: BTreeMap<&str, Vec<&Told>> = BTreeMap::new();
                        for t in entries {
                            by_job.entry(t.job.as_str()).or_default().push(t);
                        }
                        for (id, told) in by_job {
                            let first = told.iter().map(|t| t.point).min().expect("a job listed has points");
                            let mut block =
                                journal::encode(told.iter().map(|t| (t.point, t.x.as_slice(), &t.evaluation)));
                            if let Some(old) = blocks.get((id, first))? {
                                let mut joined = old.value().to_vec();
                                joined.extend_from_slice(&block[1..]);
                                block = joined;
                            }
                            blocks.insert((id, first), block.as_slice())?;
                        }
                    }
                    Write::Delete { id } => {
                        // Its number stays taken (also in a store from before `next_seq`).
                        if let Some(seq) = id.strip_prefix("job-").and_then(|n| n.parse::<u64>().ok()) {
                            let next = meta.get("next_seq")?.map_or(0, |v| v.value()).max(seq.saturating_add(1));
                            meta.insert("next_seq", next)?;
                        }
                        specs.remove(id.as_str())?;
                        states.remove(id.as_str())?;
                        evals.retain_in((id.as_str(), 0)..=(id.as_str(), u64::MAX), |_, _| false)?;
                        blocks.retain_in((id.as_str(), 0)..=(id.as_str(), u64::MAX), |_, _| false)?;
                    }
                }
            }
        }
        tx.commit()?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use fmucal_shared::job::JobStatus;

    use super::*;
    use crate::fillable_disk::FillableDisk;

    fn store_on(disk: &FillableDisk) -> Store {
        let disk = disk.clone();
        Store::with_opener(Box::new(move || disk.open())).unwrap()
    }

    fn state(seq: u64, status: JobStatus, error: Option<&str>) -> String {
        let mut json: serde_json::Value = serde_json::json!({ "seq": seq });
        json["status"] = serde_json::to_value(status).unwrap();
        json["error"] = serde_json::to_value(error).unwrap();
        json.to_string()
    }

    /// A store on a fresh disk holding the running jobs `(id, seq)`.
    fn store_with_running<S: AsRef<str>>(jobs: impl IntoIterator<Item = (S, u64)>) -> (FillableDisk, Arc<Store>) {
        let disk = FillableDisk::default();
        let store = Arc::new(store_on(&disk));
        for (id, seq) in jobs {
            store.insert_job(id.as_ref(), b"spec", seq, &state(seq, JobStatus::Running, None)).unwrap();
        }
        (disk, store)
    }

    fn told(job: &str, point: u64) -> Told {
        Told { job: job.into(), point, x: vec![1.0], evaluation: Evaluation::failed("x") }
    }

    fn stored_state(store: &Store, id: &str) -> Option<String> {
        // Closed while the writer reopens it: nothing to read yet.
        let db = store.db(false).ok()?;
        let tx = db.as_ref()?.begin_read().unwrap();
        tx.open_table(STATES).unwrap().get(id).unwrap().map(|v| v.value().to_owned())
    }

    fn wait_for(mut ok: impl FnMut() -> bool) {
        let end = std::time::Instant::now() + Duration::from_secs(30);
        while !ok() {
            assert!(std::time::Instant::now() < end, "timed out");
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    /// A full disk fails the writes of the jobs concerned, reported to the scheduler; once the
    /// disk has room again the store writes again, the last state of each such job first,
    /// without a restart.
    #[test]
    fn a_full_disk_is_reported_and_the_store_recovers_once_it_has_room() {
        let (disk, store) = store_with_running([("job-0", 0)]);
        let writer = Writer::spawn(store.clone());
        disk.set_full(true);
        writer.send(Write::State { id: "job-0".into(), json: state(0, JobStatus::Succeeded, None) });
        let mut failures = vec![];
        wait_for(|| {
            failures.extend(writer.failures());
            !failures.is_empty()
        });
        assert_eq!(failures[0].jobs, ["job-0"]);
        assert!(failures[0].error.contains("No space left on device"), "{:?}", failures[0].error);
        // The scheduler fails the job; that state cannot be written either, for now.
        let failed = state(0, JobStatus::Failed, Some("the job's state could not be saved"));
        writer.send(Write::State { id: "job-0".into(), json: failed.clone() });
        std::thread::sleep(Duration::from_millis(300));
        let second = state(1, JobStatus::Running, None);
        assert!(store.insert_job("job-1", b"spec", 1, &second).is_err(), "a write went through on a full disk");
        // Room again: the failed state is written without any new write, and new jobs are stored.
        disk.set_full(false);
        wait_for(|| stored_state(&store, "job-0").as_deref() == Some(failed.as_str()));
        store.insert_job("job-1", b"spec", 1, &second).unwrap();
        assert_eq!(store.next_seq().unwrap(), 2);
        // A deletion keeps the number taken in a store written before `next_seq` was kept.
        writer.send(Write::Delete { id: "job-9".into() });
        drop(writer);
        assert_eq!(store.next_seq().unwrap(), 10);
        // What a restart reads: the failed state, and both jobs.
        drop(store);
        let store = store_on(&disk);
        assert_eq!(stored_state(&store, "job-0").as_deref(), Some(failed.as_str()));
        assert_eq!(store.job_ids().unwrap(), ["job-0", "job-1"]);
    }

    /// A deleted job is gone with its log, a state queued after its deletion does not bring it
    /// back, and its sequence number stays taken.
    #[test]
    fn a_deleted_job_is_gone_with_its_log_and_its_number_stays_taken() {
        let (_disk, store) = store_with_running([("job-7", 7)]);
        let writer = Writer::spawn(store.clone());
        writer.send(Write::Log(vec![told("job-7", 0)]));
        writer.send(Write::Delete { id: "job-7".into() });
        writer.send(Write::State { id: "job-7".into(), json: state(7, JobStatus::Failed, None) });
        drop(writer);
        assert!(store.job_ids().unwrap().is_empty());
        assert!(stored_state(&store, "job-7").is_none());
        assert!(store.evaluations("job-7").unwrap().is_empty());
        assert_eq!(store.next_seq().unwrap(), 8);
    }

    /// A saved state removes its job's journal written before it (the state holds those
    /// points), and no other job's; what is told after it stays, in the former log's table
    /// too, until the next state; an ended job keeps none.
    #[test]
    fn a_saved_state_removes_the_journal_before_it_and_only_its_jobs() {
        let (_disk, store) = store_with_running([("job-1", 1), ("job-2", 2)]);
        let points = |id: &str| store.evaluations(id).unwrap().into_iter().map(|l| l.point).collect::<Vec<_>>();
        let writer = Writer::spawn(store.clone());
        let logged = |id: &str, from: u64| (from..from + 3).map(|p| told(id, p)).collect::<Vec<_>>();
        writer.send(Write::Log([logged("job-1", 0), logged("job-2", 0)].concat()));
        writer.send(Write::State { id: "job-1".into(), json: state(1, JobStatus::Running, None) });
        writer.send(Write::Log(logged("job-1", 3)));
        drop(writer);
        assert_eq!(points("job-1"), [3, 4, 5]);
        assert_eq!(points("job-2"), [0, 1, 2]);
        // An entry of the former JSON log goes the same way.
        restore_former_entry(&store, "job-1", 6);
        assert_eq!(points("job-1"), [6, 3, 4, 5]);
        let writer = Writer::spawn(store.clone());
        writer.send(Write::State { id: "job-1".into(), json: state(1, JobStatus::Succeeded, None) });
        drop(writer);
        assert!(points("job-1").is_empty());
        assert_eq!(points("job-2"), [0, 1, 2]);
        assert_eq!(stored_state(&store, "job-1"), Some(state(1, JobStatus::Succeeded, None)));
    }

    /// The journal's size in redb's pages (stored bytes, metadata and fragmentation) per point,
    /// with `jobs` running jobs of `dims` parameters whose told points are flushed in blocks
    /// of `per_block` (as the scheduler flushes a job's points every tick and at batch ends).
    fn journal_bytes_per_point(jobs: u64, dims: usize, per_block: u64, blocks_per_job: u64) -> f64 {
        use redb::ReadableTableMetadata;
        let (_disk, store) = store_with_running((0..jobs).map(|seq| (format!("job-{seq:06}"), seq)));
        let writer = Writer::spawn(store.clone());
        let x: Vec<f64> = (0..dims).map(|i| 0.1 + i as f64 / 3.0).collect();
        for b in 0..blocks_per_job {
            // Every job's block of this flush, as one scheduler tick sends them.
            let mut flush = vec![];
            for seq in 0..jobs {
                for p in b * per_block..(b + 1) * per_block {
                    let evaluation = Evaluation {
                        value: Some(1.0 / (p + seq + 1) as f64),
                        residuals: Some(vec![]),
                        error: None,
                        wall: Duration::from_millis(50),
                    };
                    flush.push(Told { job: format!("job-{seq:06}"), point: p, x: x.clone(), evaluation });
                }
            }
            writer.send(Write::Log(flush));
        }
        drop(writer);
        let db = store.db(false).unwrap();
        let tx = db.as_ref().unwrap().begin_read().unwrap();
        let table = tx.open_table(JOURNAL).unwrap();
        let s = table.stats().unwrap();
        let points = jobs * per_block * blocks_per_job;
        (s.stored_bytes() + s.metadata_bytes() + s.fragmented_bytes()) as f64 / points as f64
    }

    /// With up to 4 parameters the journal takes at most 100 bytes per told point on disk, for
    /// the blocks Nelder–Mead (1 to 4 points per batch, each flushed apart: the worst case) and
    /// DE or CMA-ES (a population's share per tick) give, over many running jobs.
    #[test]
    fn the_journal_takes_at_most_100_bytes_per_point_with_four_parameters() {
        for (what, per_block, blocks) in [("one point per block", 1, 4), ("4 per block", 4, 2), ("10 per block", 10, 2)]
        {
            let bytes = journal_bytes_per_point(300, 4, per_block, blocks);
            assert!(bytes <= 100.0, "{what}: {bytes:.1} bytes per point");
        }
    }

    /// Writes point `point` of `id` in the former JSON log, as coordinators before the journal did.
    fn restore_former_entry(store: &Store, id: &str, point: u64) {
        let db = store.db(false).unwrap();
        let tx = db.as_ref().unwrap().begin_write().unwrap();
        let json = serde_json::to_string(&Evaluation::failed("x")).unwrap();
        tx.open_table(EVALS).unwrap().insert((id, point), json.as_str()).unwrap();
        tx.commit().unwrap();
    }
}
