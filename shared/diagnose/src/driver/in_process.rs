//! An [`Evaluate`]r in this process, with no coordinator: each job runs on a warm-evaluator
//! pool of its own ([`fmucal_shared::job::local::calibrate`], the run the distributed one
//! reproduces point for point). For a program that embeds the diagnosis, and for the tests
//! that compare it with `fmucal diagnose`.

use std::path::Path;
use std::sync::Arc;

use fmucal_shared::fmu::Fmu;
use fmucal_shared::job::{CalibrationResult, JobSpec, MeasurementTable, PreparedJob};

use super::{Evaluate, Progress};
use crate::error::Error;

/// Runs every job on `threads` threads of this process, on `fmu` (the model path a job names
/// is not read again).
#[derive(Clone)]
pub struct InProcess {
    pub fmu: Arc<Fmu>,
    pub threads: usize,
}

impl Evaluate for InProcess {
    async fn calibrate(
        &mut self,
        job: &JobSpec,
        data: &MeasurementTable,
        _model: &Path,
        progress: &(dyn Fn(Progress) + Send + Sync),
    ) -> Result<CalibrationResult, Error> {
        let fmu = self.fmu.clone();
        let prepared =
            Arc::new(PreparedJob::new(job, &fmu.description, &fmu.interfaces(), std::slice::from_ref(data))?);
        let threads = self.threads;
        let (tx, mut rx) = tokio::sync::mpsc::unbounded_channel();
        let run = tokio::task::spawn_blocking(move || {
            fmucal_shared::job::local::calibrate(fmu, prepared, threads, |h| {
                let _ = tx.send(Progress { iteration: h.round, evaluations: h.evaluations, best_f: h.best_f });
            })
        });
        while let Some(p) = rx.recv().await {
            progress(p);
        }
        Ok(run.await.map_err(|e| Error::msg(format!("an in-process calibration panicked: {e}")))??)
    }
}
