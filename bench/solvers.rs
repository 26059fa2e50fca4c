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

#[path = "solver_runs.rs"]
mod solver_runs;

use solver_runs::{Run, load, run};

const THREADS: usize = 4;
const BUDGET: u64 = 3000;

const PROBLEMS: [(&str, &str); 3] = [
    ("Furuta", "examples/furuta/job.toml"),
    ("exhaust stage 1", "examples/exhaust/stage1_right.toml"),
    ("exhaust all four", "examples/exhaust/all_four.toml"),
];

const ALGORITHMS: [&str; 3] = ["nelder-mead", "least-squares", "cma-es"];

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
        let loaded = load(file);
        let runs: Vec<(&str, Run)> = ALGORITHMS
            .iter()
            .map(|a| {
                let algorithm = a.parse().expect("a known algorithm");
                (*a, run(&loaded, algorithm, THREADS, Some(BUDGET)).expect("the calibration runs"))
            })
            .collect();
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
