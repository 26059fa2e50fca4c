//! What the solver benchmarks (`bench/solvers.rs`, `bench/solver_choice.rs`) share: loading a
//! job with its model and data, running it in-process with one algorithm, and reading from a
//! run's history when it first came within reach of a target. Each benchmark uses a part of it.
#![allow(dead_code)]

use std::path::Path;
use std::sync::Arc;
use std::time::Instant;

use fmucal_shared::fmu::Fmu;
use fmucal_shared::job::data::read_all;
use fmucal_shared::job::{Algorithm, HistoryPoint, JobSpec, MeasurementTable, PreparedJob, local};

/// One optimizer's run on one problem.
pub struct Run {
    pub history: Vec<HistoryPoint>,
    pub f_opt: f64,
    pub evaluations: u64,
    pub rounds: u64,
    pub wall_s: f64,
    pub termination: String,
}

impl Run {
    /// Objective evaluations, rounds and wall time to reach `target` (none if never).
    pub fn reach(&self, target: f64) -> Option<(u64, u64, f64)> {
        let mut wall = 0.0;
        for h in &self.history {
            wall += h.batch_wall_s;
            if h.best_f <= target {
                return Some((h.evaluations, h.round, wall));
            }
        }
        None
    }
}

/// A job ready to run: its spec (model path resolved), model and data.
pub struct Problem {
    pub spec: JobSpec,
    pub fmu: Arc<Fmu>,
    pub data: Vec<MeasurementTable>,
}

/// Loads `spec`'s model (an `example:NAME` from the build tree) and data.
///
/// # Errors
/// The model or the data cannot be read.
pub fn prepare(mut spec: JobSpec) -> Result<Problem, String> {
    let model = spec.model.path.clone().ok_or("the job names no model path")?;
    let name = model.to_string_lossy().strip_prefix("example:").map(str::to_owned);
    let path = match name {
        Some(name) => fmucal_models::example(&name).ok_or(format!("no built-in example {name}"))?,
        None => model,
    };
    spec.model.path = Some(path.clone());
    let data = read_all(&spec).map_err(|e| e.to_string())?;
    let fmu = Arc::new(Fmu::load(&path).map_err(|e| e.to_string())?);
    Ok(Problem { spec, fmu, data })
}

/// Reads the job file `file` (relative to the repository) and prepares it.
pub fn load(file: &str) -> Problem {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let spec = JobSpec::from_toml_file(&root.join(file)).expect("the example job reads");
    prepare(spec).expect("the example's model and data load")
}

/// Runs `problem` with `algorithm` on `threads` evaluation threads; `max_fevals`, if given,
/// replaces the job's budget. The job's other settings stay.
///
/// # Errors
/// The job does not prepare, or the calibration fails.
pub fn run(problem: &Problem, algorithm: Algorithm, threads: usize, max_fevals: Option<u64>) -> Result<Run, String> {
    let mut spec = problem.spec.clone();
    spec.optimizer.set_algorithm(algorithm);
    if max_fevals.is_some() {
        spec.optimizer.max_fevals = max_fevals;
    }
    let fmu = &problem.fmu;
    let job = PreparedJob::new(&spec, &fmu.description, &fmu.interfaces(), &problem.data).map_err(|e| e.to_string())?;
    let started = Instant::now();
    let result = local::calibrate(fmu.clone(), Arc::new(job), threads, |_| {}).map_err(|e| e.to_string())?;
    Ok(Run {
        history: result.history,
        f_opt: result.f_opt,
        evaluations: result.evaluations,
        rounds: result.rounds,
        wall_s: started.elapsed().as_secs_f64(),
        termination: result.termination,
    })
}
