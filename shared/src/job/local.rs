//! In-process calibration: the job's optimizer asks batches, and `threads` evaluator threads
//! (each with its own warm FMU instance) evaluate them. Results are told in candidate order
//! once a batch is complete, so the run is the same for any number of threads. This is the
//! reference that the distributed run (coordinator and workers) reproduces.

use std::collections::BTreeMap;
use std::sync::mpsc;
use std::sync::{Arc, Mutex};
use std::time::Instant;

use super::evaluator::{Evaluation, Evaluator};
use super::objective::PreparedJob;
use super::result::{CalibrationResult, HistoryPoint};
use super::{JobError, optimizer};
use crate::fmu::Fmu;
use crate::optim::{Optimizer, Outcome, Status};

/// Outcome of an evaluation for the optimizer.
pub fn outcome(e: &Evaluation) -> Outcome {
    e.value.map(Outcome::Value).unwrap_or(Outcome::Failed)
}

/// Calibrates `job` on `threads` threads; `on_round` sees each completed round.
///
/// # Errors
/// [`JobError::Optim`] if the optimizer settings are invalid.
pub fn calibrate(
    fmu: Arc<Fmu>,
    job: Arc<PreparedJob>,
    threads: usize,
    mut on_round: impl FnMut(&HistoryPoint),
) -> Result<CalibrationResult, JobError> {
    let started = Instant::now();
    let mut opt = optimizer::build(&job.spec)?;
    let (work_tx, work_rx) = mpsc::channel::<(usize, Vec<f64>)>();
    let work_rx = Arc::new(Mutex::new(work_rx));
    let (done_tx, done_rx) = mpsc::channel::<(usize, Evaluation)>();
    let mut history = vec![];
    let mut failed = 0;
    std::thread::scope(|scope| {
        for _ in 0..threads.max(1) {
            let (rx, tx, fmu, job) = (work_rx.clone(), done_tx.clone(), fmu.clone(), job.clone());
            scope.spawn(move || {
                let mut evaluator = Evaluator::new(&fmu, job);
                loop {
                    let next = rx.lock().unwrap_or_else(|p| p.into_inner()).recv();
                    let Ok((i, x)) = next else { break };
                    let e = match evaluator.as_mut() {
                        Ok(ev) => ev.evaluate(&x, false),
                        Err(err) => Evaluation {
                            value: None,
                            residuals: None,
                            error: Some(err.to_string()),
                            wall: Default::default(),
                        },
                    };
                    if tx.send((i, e)).is_err() {
                        break;
                    }
                }
            });
        }
        drop(done_tx);
        loop {
            let batch = opt.ask();
            if batch.is_empty() {
                break;
            }
            let t0 = Instant::now();
            for (i, c) in batch.iter().enumerate() {
                work_tx.send((i, c.x.clone())).expect("evaluator threads are alive");
            }
            let mut results: Vec<Option<Evaluation>> = vec![None; batch.len()];
            for _ in 0..batch.len() {
                let (i, e) = done_rx.recv().expect("evaluator threads are alive");
                results[i] = Some(e);
            }
            for (c, e) in batch.iter().zip(results) {
                let e = e.expect("every candidate answered");
                if e.value.is_none() {
                    failed += 1;
                    tracing::debug!(x = ?c.x, error = ?e.error, "evaluation failed");
                }
                opt.tell(c.id, outcome(&e)).expect("candidate from this batch");
            }
            let point = HistoryPoint {
                round: opt.rounds(),
                evaluations: opt.evaluations(),
                best_f: opt.best().map(|b| b.1).unwrap_or(f64::INFINITY),
                batch_wall_s: t0.elapsed().as_secs_f64(),
            };
            on_round(&point);
            history.push(point);
        }
        drop(work_tx);
    });
    Ok(finish(&opt, &job, failed, started.elapsed().as_secs_f64(), history))
}

/// Assembles the result of a finished optimizer.
pub fn finish(
    opt: &dyn Optimizer,
    job: &PreparedJob,
    failed: u64,
    elapsed_s: f64,
    history: Vec<HistoryPoint>,
) -> CalibrationResult {
    let (x, f) = opt.best().unwrap_or_else(|| (job.spec.parameter_vectors().1, f64::INFINITY));
    CalibrationResult {
        x_opt: job.parameter_names.iter().cloned().zip(x).collect::<BTreeMap<_, _>>(),
        f_opt: f,
        iterations: opt.iterations(),
        evaluations: opt.evaluations(),
        rounds: opt.rounds(),
        failed_evaluations: failed,
        termination: match opt.status() {
            Status::Done(t) => t.to_string(),
            Status::Running => "stopped".into(),
        },
        elapsed_s,
        history,
        errors: None,
        identifiability: None,
    }
}
