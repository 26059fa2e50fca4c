//! Solver benchmark, run with `cargo bench --bench solvers` (or `bash
//! bench/solvers.sh`): on the Furuta job, exhaust stage 1 and exhaust all-four
//! (`examples/`), how many simulations, batch rounds and how much wall time each optimizer needs
//! to come within 1 % of the objective Nelder–Mead ends at with the example's own settings.
//!
//! Every run is in-process on a warm-evaluator pool of 4 threads (`local::calibrate`, the same
//! ask/tell loop the coordinator drives), so the figures compare the solvers and not the
//! network. Each solver keeps the example's `x_tol` and `f_tol` and gets a budget of 3000
//! simulations. The wall time to the target is the sum of the batch wall times up to the
//! round that reached it. Prints a Markdown table, and JSON with `--json FILE`; `--problem
//! NAME` runs one problem only, and `--history` prints each round's best f after the table.

use std::path::Path;
use std::sync::Arc;
use std::time::Instant;

use fmucal_shared::fmu::Fmu;
use fmucal_shared::job::data::read_all;
use fmucal_shared::job::{HistoryPoint, JobSpec, PreparedJob, local};

const THREADS: usize = 4;
const BUDGET: u64 = 3000;

const PROBLEMS: [(&str, &str); 3] = [
    ("Furuta", "examples/furuta/job.toml"),
    ("exhaust stage 1", "examples/exhaust/stage1_right.toml"),
    ("exhaust all four", "examples/exhaust/all_four.toml"),
];

const ALGORITHMS: [&str; 3] = ["nelder-mead", "least-squares", "cma-es"];

/// One optimizer's run on one problem.
struct Run {
    history: Vec<HistoryPoint>,
    f_opt: f64,
    evaluations: u64,
    rounds: u64,
    wall_s: f64,
    termination: String,
}

impl Run {
    /// Simulations, rounds and wall time to reach `target` (none if never).
    fn reach(&self, target: f64) -> Option<(u64, u64, f64)> {
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

fn load(file: &str) -> (JobSpec, Arc<Fmu>, Vec<fmucal_shared::job::MeasurementTable>) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut spec = JobSpec::from_toml_file(&root.join(file)).expect("the example job reads");
    let model = spec.model.path.clone().expect("a model path");
    let name = model.to_string_lossy().strip_prefix("example:").map(str::to_owned);
    let path = match name {
        Some(name) => fmucal_models::example(&name).expect("a built-in example"),
        None => model,
    };
    spec.model.path = Some(path.clone());
    let data = read_all(&spec).expect("the example data read");
    let fmu = Arc::new(Fmu::load(&path).expect("the example FMU loads"));
    (spec, fmu, data)
}

fn run(spec: &JobSpec, fmu: &Arc<Fmu>, data: &[fmucal_shared::job::MeasurementTable], algorithm: &str) -> Run {
    let mut spec = spec.clone();
    spec.optimizer.algorithm = Some(algorithm.parse().expect("a known algorithm"));
    spec.optimizer.max_fevals = Some(BUDGET);
    let job = Arc::new(PreparedJob::new(&spec, &fmu.description, &fmu.interfaces(), data).expect("the job prepares"));
    let started = Instant::now();
    let result = local::calibrate(fmu.clone(), job, THREADS, |_| {}).expect("the calibration runs");
    Run {
        history: result.history,
        f_opt: result.f_opt,
        evaluations: result.evaluations,
        rounds: result.rounds,
        wall_s: started.elapsed().as_secs_f64(),
        termination: result.termination,
    }
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let json_path = args.iter().position(|a| a == "--json").and_then(|i| args.get(i + 1)).cloned();
    let only = args.iter().position(|a| a == "--problem").and_then(|i| args.get(i + 1)).cloned();
    let history = args.iter().any(|a| a == "--history");
    let mut rows = vec![];
    let mut trace = vec![];
    println!(
        "| problem | solver | simulations to NM's f + 1 % | rounds | wall (s) | final f | simulations in all | stop |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    for (problem, file) in PROBLEMS.into_iter().filter(|(p, _)| only.as_deref().is_none_or(|o| o == *p)) {
        let (spec, fmu, data) = load(file);
        let runs: Vec<(&str, Run)> = ALGORITHMS.iter().map(|a| (*a, run(&spec, &fmu, &data, a))).collect();
        let target = 1.01 * runs[0].1.f_opt;
        for (algorithm, r) in &runs {
            let reached = r.reach(target);
            if history {
                for h in &r.history {
                    trace.push(format!(
                        "{problem} {algorithm}: round {} simulations {} best f {:.6e}",
                        h.round, h.evaluations, h.best_f
                    ));
                }
            }
            let cell = |v: Option<String>| v.unwrap_or_else(|| "not reached".into());
            println!(
                "| {problem} | {algorithm} | {} | {} | {} | {:.6e} | {} | {} |",
                cell(reached.map(|x| x.0.to_string())),
                cell(reached.map(|x| x.1.to_string())),
                cell(reached.map(|x| format!("{:.2}", x.2))),
                r.f_opt,
                r.evaluations,
                r.termination
            );
            rows.push(serde_json::json!({
                "problem": problem, "solver": algorithm, "target": target,
                "simulations_to_target": reached.map(|x| x.0), "rounds_to_target": reached.map(|x| x.1),
                "wall_to_target_s": reached.map(|x| x.2), "f_opt": r.f_opt, "simulations": r.evaluations,
                "rounds": r.rounds, "wall_s": r.wall_s, "termination": r.termination,
            }));
        }
    }
    if !trace.is_empty() {
        println!("\n{}", trace.join("\n"));
    }
    if let Some(path) = json_path {
        std::fs::write(&path, serde_json::to_string_pretty(&rows).expect("JSON")).expect("write the JSON");
    }
}
