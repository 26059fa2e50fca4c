//! `fmucal coordinator --salvage`: keeps every readable job of a damaged job store. The damaged
//! file is kept aside (`jobs.redb.damaged-<unix seconds>`), never changed; its jobs are read
//! from copies of it, each opened a different way, and those of the copy that yields the most
//! are written to a fresh `jobs.redb`:
//!
//! 1. the file as it is;
//! 2. with redb's magic number restored and its "recovery required" flag set, so that redb
//!    rebuilds its allocator state from the trees instead of trusting the stored one (a
//!    damaged allocator state makes redb panic or refuse);
//! 3. as 2, on the other of redb's two commit slots (the commit before the last).
//!
//! A job is kept when its spec and state read back (its journal as far as it reads);
//! each read is on its own, so a damaged page loses the jobs on it, not those after it. Jobs are
//! looked up by id, `job-000000` up to past the highest id seen, so a damaged branch page of the
//! id index does not hide the jobs below it.

use std::path::{Path, PathBuf};

use redb::{AccessGuard, Database, ReadTransaction, ReadableDatabase, ReadableTable, TableDefinition, Value};

use crate::error::CoordinatorError;
use crate::store::{EVALS, JOURNAL, META, SPECS, STATES, Store};

/// redb's file magic number (its format's first 9 bytes) and the flags byte after it.
const MAGIC: [u8; 9] = [b'r', b'e', b'd', b'b', 0x1A, 0x0A, 0xA9, 0x0D, 0x0A];
const FLAGS_OFFSET: usize = MAGIC.len();
const PRIMARY_SLOT: u8 = 1;
const RECOVERY_REQUIRED: u8 = 2;
/// Ids probed past the highest one seen.
const PROBE_PAST: u64 = 10_000;

/// What a salvage kept and lost.
#[derive(Debug, Clone, Default)]
pub struct SalvageReport {
    /// Where the damaged file now is.
    pub damaged: PathBuf,
    /// Which way of opening it was used (see the module doc).
    pub method: &'static str,
    pub kept: Vec<String>,
    /// Ids with a spec or state found but not readable.
    pub lost: Vec<String>,
    /// Told points kept in the kept jobs' logs (the former JSON log's and the journal's).
    pub evaluations: u64,
}

/// One job as read: spec bytes, state JSON, the former log's entries, the journal's blocks.
struct Readable {
    id: String,
    spec: Vec<u8>,
    state: String,
    evaluations: Vec<(u64, String)>,
    journal: Vec<(u64, Vec<u8>)>,
}

/// Salvages `<data_dir>/jobs.redb` (the coordinator must be stopped).
///
/// # Errors
/// If there is no store, it cannot be copied, or no way of opening it works.
pub fn salvage(data_dir: &Path) -> Result<SalvageReport, CoordinatorError> {
    let path = data_dir.join("jobs.redb");
    let in_use = std::panic::catch_unwind(|| {
        matches!(redb::ReadOnlyDatabase::open(&path), Err(redb::DatabaseError::DatabaseAlreadyOpen))
    });
    if in_use.unwrap_or(false) {
        return Err(CoordinatorError::Storage(format!(
            "{} is open in a running coordinator: stop it first",
            path.display()
        )));
    }
    let original =
        std::fs::read(&path).map_err(|e| CoordinatorError::Storage(format!("cannot read {}: {e}", path.display())))?;
    let stamp = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_secs());
    let damaged = data_dir.join(format!("jobs.redb.damaged-{stamp}"));
    let work = data_dir.join(".salvage");
    let _ = std::fs::remove_dir_all(&work);
    std::fs::create_dir_all(&work)?;
    let mut best: Option<(&'static str, Vec<Readable>, Vec<String>)> = None;
    let mut why = vec![];
    for (attempt, (method, patch)) in [
        ("as it is", None),
        ("rebuilding redb's allocator state", Some(false)),
        ("rebuilding redb's allocator state, from the commit before the last", Some(true)),
    ]
    .into_iter()
    .enumerate()
    {
        let mut bytes = original.clone();
        if let Some(other_slot) = patch {
            if bytes.len() <= FLAGS_OFFSET {
                continue;
            }
            bytes[..MAGIC.len()].copy_from_slice(&MAGIC);
            bytes[FLAGS_OFFSET] |= RECOVERY_REQUIRED;
            if other_slot {
                bytes[FLAGS_OFFSET] ^= PRIMARY_SLOT;
            }
        }
        let copy = work.join(format!("attempt-{attempt}.redb"));
        std::fs::write(&copy, &bytes)?;
        match read_jobs(&copy) {
            Ok((jobs, lost)) => {
                tracing::info!(method, jobs = jobs.len(), "salvage attempt");
                if best.as_ref().is_none_or(|(_, b, _)| jobs.len() > b.len()) {
                    best = Some((method, jobs, lost));
                }
            }
            Err(e) => why.push(format!("{method}: {e}")),
        }
    }
    let best = best.filter(|(_, jobs, _)| !jobs.is_empty());
    if best.is_none() && why.is_empty() {
        why.push("no job reads back".into());
    }
    let Some((method, jobs, mut lost)) = best else {
        let _ = std::fs::remove_dir_all(&work);
        return Err(CoordinatorError::Storage(format!(
            "{} cannot be read in any way ({}); restore a backup",
            path.display(),
            why.join("; ")
        )));
    };
    // The fresh store, written beside the damaged one, then put in its place.
    let fresh_dir = work.join("fresh");
    std::fs::create_dir_all(&fresh_dir)?;
    let fresh = Store::open(&fresh_dir)?;
    let mut report = SalvageReport { damaged: damaged.clone(), method, ..Default::default() };
    for job in jobs {
        fresh.restore_job(&job.id, &job.spec, &job.state, &job.evaluations, &job.journal)?;
        let journaled: usize = job.journal.iter().map(|(_, b)| crate::journal::decode(b).map_or(0, |p| p.len())).sum();
        report.evaluations += (job.evaluations.len() + journaled) as u64;
        report.kept.push(job.id);
    }
    drop(fresh);
    std::fs::rename(&path, &damaged)?;
    std::fs::rename(fresh_dir.join("jobs.redb"), &path)?;
    let _ = std::fs::remove_dir_all(&work);
    lost.retain(|id| !report.kept.contains(id));
    report.lost = lost;
    Ok(report)
}

/// Opens the copy at `path` (a panic in redb counts as a failure) and reads every job it can.
fn read_jobs(path: &Path) -> Result<(Vec<Readable>, Vec<String>), String> {
    let path = path.to_owned();
    std::panic::catch_unwind(move || -> Result<(Vec<Readable>, Vec<String>), String> {
        let db = Database::builder().create(&path).map_err(|e| e.to_string())?;
        Ok(read_open(&db))
    })
    .unwrap_or_else(|_| Err("redb panicked opening it".into()))
}

fn read_open(db: &Database) -> (Vec<Readable>, Vec<String>) {
    let guarded =
        |f: &dyn Fn() -> Option<u64>| std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)).ok().flatten();
    // The highest id: from the index as far as it reads, and the id counter.
    let listed = guarded(&|| {
        let tx = db.begin_read().ok()?;
        let specs = tx.open_table(SPECS).ok()?;
        let mut highest = None;
        for entry in specs.iter().ok()? {
            let Ok((k, _)) = entry else { break };
            highest = highest.max(k.value().strip_prefix("job-").and_then(|n| n.parse::<u64>().ok()));
        }
        highest
    });
    let counted = guarded(&|| db.begin_read().ok()?.open_table(META).ok()?.get("next_seq").ok()?.map(|v| v.value()));
    let last = listed.unwrap_or(0).max(counted.unwrap_or(0));
    let mut jobs = vec![];
    let mut lost = vec![];
    for seq in 0..=last.saturating_add(PROBE_PAST) {
        let id = format!("job-{seq:06}");
        match std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| read_job(db, &id))) {
            Ok(Ok(Some(job))) => jobs.push(job),
            Ok(Ok(None)) => {}
            Ok(Err(())) | Err(_) => lost.push(id),
        }
    }
    (jobs, lost)
}

/// Job `id`: `None` if it is not there, `Err` if it is but does not read back.
fn read_job(db: &Database, id: &str) -> Result<Option<Readable>, ()> {
    let tx = db.begin_read().map_err(|_| ())?;
    let spec = tx.open_table(SPECS).map_err(|_| ())?.get(id).map_err(|_| ())?.map(|v| v.value().to_vec());
    let state = tx.open_table(STATES).map_err(|_| ())?.get(id).map_err(|_| ())?.map(|v| v.value().to_owned());
    let (spec, state) = match (spec, state) {
        (None, None) => return Ok(None),
        (Some(spec), Some(state)) => (spec, state),
        _ => return Err(()),
    };
    // A damaged value may still read: the state must at least be JSON (whether this version
    // of fmucal can use it is decided at start, as for any stored state).
    if serde_json::from_str::<serde_json::Value>(&state).is_err() {
        return Err(());
    }
    let evaluations = point_rows(&tx, EVALS, id, |v| v.value().to_owned());
    let journal = point_rows(&tx, JOURNAL, id, |v| v.value().to_vec());
    Ok(Some(Readable { id: id.to_owned(), spec, state, evaluations, journal }))
}

/// Job `id`'s rows of a `table` keyed by (job id, point), as far as they read (none if the
/// table does not open), each value made owned by `owned`.
fn point_rows<V: Value + 'static, T>(
    tx: &ReadTransaction,
    table: TableDefinition<'_, (&'static str, u64), V>,
    id: &str,
    owned: impl Fn(&AccessGuard<'static, V>) -> T,
) -> Vec<(u64, T)> {
    let mut rows = vec![];
    if let Ok(table) = tx.open_table(table)
        && let Ok(range) = table.range((id, 0)..=(id, u64::MAX))
    {
        for entry in range {
            let Ok((k, v)) = entry else { break };
            rows.push((k.value().1, owned(&v)));
        }
    }
    rows
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A store of `n` jobs, each with a padded state, 5 evaluations in the former JSON log and
    /// 3 more in a journal block, like a real one (resumed from a store of the former version).
    fn store_with_jobs(dir: &Path, n: u64) {
        let store = Store::open(dir).unwrap();
        for seq in 0..n {
            let id = format!("job-{seq:06}");
            let state = format!(
                "{{\"seq\":{seq},\"status\":\"Succeeded\",\"run\":null,\"elapsed_s\":1.0,\"result\":null,\"error\":\"{}\"}}",
                "e".repeat(3000)
            );
            let evals: Vec<(u64, String)> = (0..5)
                .map(|p| {
                    (
                        p,
                        format!(
                            "{{\"value\":{p}.5,\"residuals\":null,\"error\":null,\"wall\":{{\"secs\":0,\"nanos\":1}}}}"
                        ),
                    )
                })
                .collect();
            let e = fmucal_shared::job::Evaluation::failed("x");
            let block = crate::journal::encode((5..8).map(|p| (p, [0.5, 1.5].as_slice(), &e)));
            store.restore_job(&id, b"spec bytes", &state, &evals, &[(5, block)]).unwrap();
        }
    }

    fn readable_normally(dir: &Path) -> usize {
        std::panic::catch_unwind(|| Store::open(dir).ok().and_then(|s| s.job_ids().ok()).map_or(0, |ids| ids.len()))
            .unwrap_or(0)
    }

    /// One flipped byte that leaves the store unreadable as it is (redb refuses it or panics):
    /// found by flipping bytes across the file, the first such.
    fn damaged_copy(original: &[u8], dir: &Path) -> usize {
        for k in 0..400 {
            let offset = k * original.len() / 400 + k % 7;
            let mut bytes = original.to_vec();
            bytes[offset] ^= 0x5a;
            std::fs::write(dir.join("jobs.redb"), &bytes).unwrap();
            if readable_normally(dir) == 0 {
                return offset;
            }
        }
        panic!("no single flipped byte made the store unreadable");
    }

    /// A store that one flipped byte made unreadable gives back all its jobs, with their logs;
    /// the salvaged store opens as usual, keeps the id counter, and the damaged file is kept
    /// aside unchanged.
    #[test]
    fn a_store_one_flipped_byte_made_unreadable_gives_back_every_job() {
        let base = tempfile::tempdir().unwrap();
        store_with_jobs(base.path(), 40);
        let original = std::fs::read(base.path().join("jobs.redb")).unwrap();
        let dir = tempfile::tempdir().unwrap();
        let offset = damaged_copy(&original, dir.path());
        let damaged = std::fs::read(dir.path().join("jobs.redb")).unwrap();
        let report = salvage(dir.path()).unwrap();
        assert_eq!(report.kept.len(), 40, "flipped byte {offset}: {report:?}");
        assert_eq!(report.evaluations, 320);
        assert!(report.lost.is_empty(), "{report:?}");
        assert_eq!(std::fs::read(&report.damaged).unwrap(), damaged, "the damaged file was changed");
        let store = Store::open(dir.path()).unwrap();
        assert_eq!(store.job_ids().unwrap().len(), 40);
        let logged = store.evaluations("job-000039").unwrap();
        assert_eq!(logged.iter().map(|l| l.point).collect::<Vec<_>>(), (0..8).collect::<Vec<_>>());
        assert_eq!(logged[7].x.as_deref(), Some([0.5, 1.5].as_slice()));
        assert_eq!(store.next_seq().unwrap(), 40);
        assert!(!dir.path().join(".salvage").exists(), "the work folder was left behind");
    }

    /// A store in use is refused; an intact store comes back whole; a file that is not a store
    /// at all is refused, left where it is.
    #[test]
    fn an_intact_store_comes_back_whole_and_garbage_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        store_with_jobs(dir.path(), 3);
        let open = Store::open(dir.path()).unwrap();
        let err = salvage(dir.path()).unwrap_err().to_string();
        assert!(err.contains("stop it first"), "{err}");
        drop(open);
        let report = salvage(dir.path()).unwrap();
        assert_eq!((report.method, report.kept.len()), ("as it is", 3));
        let garbage = tempfile::tempdir().unwrap();
        std::fs::write(garbage.path().join("jobs.redb"), vec![7u8; 10_000]).unwrap();
        let err = salvage(garbage.path()).unwrap_err().to_string();
        assert!(err.contains("cannot be read in any way") && err.contains("restore a backup"), "{err}");
        assert_eq!(std::fs::read(garbage.path().join("jobs.redb")).unwrap(), vec![7u8; 10_000]);
    }
}
