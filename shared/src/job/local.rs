//! In-process calibration: the job's run ([`JobRun`]) executed on `threads` threads of a
//! warm-evaluator pool; and [`evaluate`], a job's given points on such a pool. Results are told
//! in candidate order once a round is complete, so the run is the same for any number of
//! threads. This is the reference that the distributed run (coordinator and workers)
//! reproduces.

use std::sync::Arc;
use std::time::Instant;

use super::JobError;
use super::executor::{PoolBackend, execute};
use super::pool::EvaluatorPool;
use super::prepared::PreparedJob;
use super::result::{CalibrationResult, EvaluatedPoint, HistoryPoint};
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

/// Evaluates `points` of `job` on `pool` (each point on every fitted experiment), as a job
/// that evaluates points does on the workers: the same evaluations, so the same values and
/// residuals.
///
/// # Errors
/// [`JobError`] if the points do not fit the job (their length, the caps on a job's points) or
/// the run cannot complete.
pub fn evaluate(
    fmu: Arc<Fmu>,
    job: &PreparedJob,
    points: Vec<Vec<f64>>,
    pool: &EvaluatorPool,
) -> Result<Vec<EvaluatedPoint>, JobError> {
    // A key of its own per call: a pool thread keeps its evaluator warm by key, and another
    // call may bring another job (another tolerance) to the same pool.
    static CALLS: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    let key = format!("points-{}", CALLS.fetch_add(1, std::sync::atomic::Ordering::Relaxed));
    let job = Arc::new(job.evaluating_points(points));
    let mut run = JobRun::new(&job)?;
    let mut backend = PoolBackend { pool, fmu, job: job.clone(), job_key: key };
    execute(&mut run, &mut backend, |_| {})?;
    Ok(run.take_result(&job.spec, 0.0, None).evaluated)
}
