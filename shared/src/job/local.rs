//! In-process calibration: the job's run ([`JobRun`]) executed on `threads` threads of a
//! warm-evaluator pool. Results are told in candidate order once a round is complete, so the
//! run is the same for any number of threads. This is the reference that the distributed run
//! (coordinator and workers) reproduces.

use std::sync::Arc;
use std::time::Instant;

use super::JobError;
use super::executor::{PoolBackend, execute};
use super::pool::EvaluatorPool;
use super::prepared::PreparedJob;
use super::result::{CalibrationResult, HistoryPoint};
use super::run::JobRun;
use crate::fmu::Fmu;

/// Calibrates `job` on `threads` threads; `on_round` sees each completed round.
///
/// # Errors
/// [`JobError::Optim`] if the optimizer settings are invalid, [`JobError::Invalid`] if the
/// evaluation threads cannot be started.
pub fn calibrate(
    fmu: Arc<Fmu>,
    job: Arc<PreparedJob>,
    threads: usize,
    on_round: impl FnMut(&HistoryPoint),
) -> Result<CalibrationResult, JobError> {
    let started = Instant::now();
    let mut run = JobRun::new(&job)?;
    let pool = EvaluatorPool::new(threads, "fmucal-eval")
        .map_err(|e| JobError::invalid("workers", format!("cannot start evaluation threads: {e}")))?;
    let mut backend = PoolBackend { pool: &pool, fmu, job: job.clone(), job_key: "calibration".into() };
    execute(&mut run, &mut backend, on_round)?;
    Ok(run.take_result(&job.spec, started.elapsed().as_secs_f64(), None))
}
