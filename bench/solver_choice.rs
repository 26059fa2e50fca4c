//! Which solver should calibrations use by default? Run with `bash bench/solver_choice.sh`
//! (`cargo bench --bench solver_choice`): Nelder–Mead and least squares, each with the job's
//! own settings otherwise (tolerances, budget or the algorithm's default budget), on
//!
//! - every example under `examples/` that `fmucal calibrate` runs as it is (the exhaust's
//!   stage 2 reads stage 1's result and is left out; stage 1 and all four cover its model);
//! - the base jobs of the diagnosis benchmarks (`tests/diagnosis_grid.rs`,
//!   `tests/diagnosis_exported.rs`): the base model's parameters fitted to data from a fixture
//!   that hides an effect the base lacks (the model cannot fit it exactly), or from the base;
//! - the hybrid fixtures: the stick-slip oscillator (stiction and Coulomb friction with mode
//!   switches), the bouncing ball (state events) and a spring–mass with an injected dead-zone
//!   spring (the term's own event indicators);
//! - the Dymola-shaped (`*Exported`) fixtures, through the exported grid's base jobs.
//!
//! Generated cases simulate their data from the fixture at its defaults (tolerance 1e-10) and
//! add seeded Gaussian noise of 1 % of each output's range, as the diagnosis grids do; their
//! inputs and jobs are the grids' (`tests/common/diagnosis.rs`).
//!
//! Each case runs from the job's start and from `RANDOM_STARTS` seeded random starts, uniform
//! on the middle 90 % of each parameter's bounds (of its logarithm for `scale = "log"`). The
//! target of a case is 1 % above the best f any of its runs reached; a run's cost is the
//! simulations until its best f is within the target (read from its history, as `result.json`
//! holds it), a run that never gets there or stops with an error is a failure. A case's cost for
//! one solver is the median over its starts, a failure counting as infinite. Least squares
//! wins a case when its median is lower than Nelder–Mead's.
//!
//! Runs are in-process on 2 evaluation threads (`local::calibrate`, the ask/tell loop the
//! coordinator drives; the result does not depend on the number of threads). Prints a Markdown
//! table, the failures, and the decision rule's verdict: least squares becomes the default if
//! it wins at least 80 % of the cases and fails on no start where Nelder–Mead succeeds.
//! `--case TEXT` runs the cases whose name contains TEXT; `--f-tol VALUE` replaces every job's
//! `f_tol` (for both solvers), to tell a stopping rule from a solver that is stuck.

#[path = "../tests/common/mod.rs"]
mod common;
#[path = "solver_runs.rs"]
mod solver_runs;

use std::path::{Path, PathBuf};

use common::diagnosis::{
    EXHAUST_SETTINGS, FURUTA_EXPORTED_SIMULATION, GRID_SIMULATION, Inputs, Model, Rng, SPRING_MASS_EXPORTED_SIMULATION,
    TIGHT_OPTIMIZER, exhaust_inputs, exported_spring_mass_inputs, furuta_inputs, noise_free_spec, noise_sigmas,
    spring_mass_inputs, time_grid,
};
use fmucal_models::Fixture;
use fmucal_shared::job::{Algorithm, JobSpec};
use fmucal_shared::sim::{PortTerm, SimSpec, simulate};
use solver_runs::{Problem, Run, load, prepare, run};

const THREADS: usize = 2;
const RANDOM_STARTS: usize = 3;
const NOISE: f64 = 0.01;
const SOLVERS: [Algorithm; 2] = [Algorithm::NelderMead, Algorithm::LeastSquares];

/// A case whose data is simulated here.
#[derive(Default)]
struct Generated {
    /// The model the data comes from (a fixture that may hide an effect).
    data_fmu: PathBuf,
    /// Values set on `data_fmu` and effects injected into it for the data (none by default).
    set: Vec<(&'static str, f64)>,
    port_terms: Vec<PortTerm>,
    /// The job's model.
    job_fmu: PathBuf,
    time: Vec<f64>,
    inputs: Inputs,
    /// (FMU output, data column).
    outputs: &'static [(&'static str, &'static str)],
    /// The job's `[[parameters]]`, `[[effects]]`, `[simulation]` and `[optimizer]` tables.
    body: String,
    seed: u64,
}

enum Source {
    /// A job file under `examples/`.
    Example(&'static str),
    Generated(Generated),
}

struct Case {
    name: &'static str,
    source: Source,
}

fn cases() -> Vec<Case> {
    let example = |name, file| Case { name, source: Source::Example(file) };
    let generated = |name, g| Case { name, source: Source::Generated(g) };
    let furuta = || fmucal_models::example("furuta").expect("the furuta example");
    let exhaust = || fmucal_models::example("exhaust-pipe").expect("the exhaust example");
    let grid_furuta = |data_fmu, profile, seed| {
        base_job(Model::Furuta, data_fmu, furuta(), furuta_inputs(profile), GRID_SIMULATION, seed)
    };
    let grid_spring = |data_fmu, profile, seed| {
        base_job(
            Model::SpringMass,
            data_fmu,
            Fixture::SpringMass.path(),
            spring_mass_inputs(profile),
            GRID_SIMULATION,
            seed,
        )
    };
    let exported_furuta = |data_fmu, profile, seed| {
        let inputs = furuta_inputs(profile);
        base_job(Model::Furuta, data_fmu, Fixture::FurutaExported.path(), inputs, FURUTA_EXPORTED_SIMULATION, seed)
    };
    let exported_spring = |data_fmu, driven, seed| {
        let inputs = exported_spring_mass_inputs(driven);
        base_job(
            Model::SpringMass,
            data_fmu,
            Fixture::SpringMassExported.path(),
            inputs,
            SPRING_MASS_EXPORTED_SIMULATION,
            seed,
        )
    };
    let (exhaust_time, exhaust_in) = exhaust_inputs();
    let exhaust_case = |data_fmu, job_fmu, seed| Generated {
        data_fmu,
        job_fmu,
        time: exhaust_time.clone(),
        inputs: exhaust_in.clone(),
        outputs: Model::Exhaust.outputs(),
        body: format!("{}{EXHAUST_SETTINGS}", Model::Exhaust.parameters()),
        seed,
        ..Default::default()
    };
    vec![
        // The examples that are calibration jobs.
        example("example furuta", "examples/furuta/job.toml"),
        example("example furuta_experiments", "examples/furuta_experiments/job.toml"),
        example("example exhaust stage 1", "examples/exhaust/stage1_right.toml"),
        example("example exhaust all four", "examples/exhaust/all_four.toml"),
        example("example friction (base job)", "examples/friction/job.toml"),
        example("example diagnose (base job)", "examples/diagnose/job.toml"),
        // Base jobs of the diagnosis grid.
        generated("grid Furuta, pendulum Coulomb", grid_furuta(Fixture::FurutaHiddenCoulomb.path(), 0, 11)),
        generated("grid Furuta, arm sensor offset", grid_furuta(Fixture::FurutaHiddenSensorOffset.path(), 0, 12)),
        generated("grid Furuta, arm drag", grid_furuta(Fixture::FurutaHiddenArmDrag.path(), 1, 13)),
        generated("grid Furuta, nothing hidden", grid_furuta(furuta(), 1, 14)),
        generated("grid spring-mass, cubic spring", grid_spring(Fixture::SpringMassHiddenCubic.path(), 0, 15)),
        generated("grid exhaust, radiation", exhaust_case(Fixture::ExhaustPipeHiddenRadiation.path(), exhaust(), 16)),
        // Base jobs of the exported grid: Dymola-shaped descriptions.
        generated(
            "exported spring-mass, Coulomb, driven",
            exported_spring(Fixture::SpringMassExportedHiddenCoulomb.path(), true, 21),
        ),
        generated(
            "exported spring-mass, Stribeck, free",
            exported_spring(Fixture::SpringMassExportedHiddenStribeck.path(), false, 22),
        ),
        generated(
            "exported spring-mass, nothing hidden",
            exported_spring(Fixture::SpringMassExported.path(), true, 23),
        ),
        generated(
            "exported Furuta, pendulum Coulomb",
            exported_furuta(Fixture::FurutaExportedHiddenCoulomb.path(), 1, 24),
        ),
        generated(
            "exported exhaust, radiation",
            exhaust_case(Fixture::ExhaustPipeExportedHiddenRadiation.path(), Fixture::ExhaustPipeExported.path(), 25),
        ),
        // Hybrid models.
        generated("hybrid stick-slip", {
            // F = 2.2 sin(0.8 t): stick and slip phases in both directions. The model refuses
            // Fc > Fs, so the bounds keep Fc below Fs everywhere.
            let time = time_grid(400, 0.05);
            let f = time.iter().map(|t| 2.2 * (0.8 * t).sin()).collect();
            let parameters = include_str!("../tests/data/parameters/stick_slip.toml");
            own_data(Fixture::StickSlip.path(), time, vec![("F", "F", f)], &[("x", "x")], parameters, 31)
        }),
        generated("hybrid bouncing ball", {
            let ball = fmucal_models::example("bouncing-ball").expect("the bouncing-ball example");
            let parameters = include_str!("../tests/data/parameters/bouncing_ball.toml");
            own_data(ball, time_grid(300, 0.01), vec![], &[("h", "h")], parameters, 32)
        }),
        generated(
            "hybrid dead-zone spring",
            Generated {
                // A free spring–mass from x = 1 m with a dead-zone spring (k 12 N/m, width
                // 0.3 m) injected on its force port: the zone's edges are event indicators.
                data_fmu: Fixture::SpringMass.path(),
                set: vec![("mass.x", 1.0)],
                port_terms: vec![PortTerm {
                    kind: "dead_zone_spring".into(),
                    port: "mass.Fext".into(),
                    signal: "mass.x".into(),
                    parameters: vec![12.0, 0.3],
                }],
                job_fmu: Fixture::SpringMass.path(),
                time: time_grid(1000, 0.01),
                inputs: vec![],
                outputs: Model::SpringMass.outputs(),
                body: r#"
[[effects]]
kind = "dead_zone_spring"
port = "mass.Fext"
signal = "mass.x"
parameters = { k = { start = 6.0, lower = 1.0, upper = 30.0 }, width = { start = 0.15, lower = 0.0, upper = 0.6 } }
[simulation]
set = { "mass.x" = 1.0 }
tolerance = 1e-8
[optimizer]
x_tol = 1e-5
f_tol = 1e-10
"#
                .to_owned(),
                seed: 33,
            },
        ),
    ]
}

/// A diagnosis grid's base job of `model` (its outputs and parameters, `simulation` and the
/// tight optimizer table) on `job_fmu`, fitted to data from `data_fmu` on the input columns over
/// the times of `time_inputs`.
fn base_job(
    model: Model,
    data_fmu: PathBuf,
    job_fmu: PathBuf,
    (time, inputs): (Vec<f64>, Inputs),
    simulation: &str,
    seed: u64,
) -> Generated {
    let body = body(model.parameters(), simulation);
    Generated { data_fmu, job_fmu, time, inputs, outputs: model.outputs(), body, seed, ..Default::default() }
}

/// A case whose data come from the job's own model `fmu` at its defaults, on `inputs` over
/// `time`: the job fits `parameters` to `outputs` (with [`GRID_SIMULATION`]).
fn own_data(
    fmu: PathBuf,
    time: Vec<f64>,
    inputs: Inputs,
    outputs: &'static [(&'static str, &'static str)],
    parameters: &str,
    seed: u64,
) -> Generated {
    let body = body(parameters, GRID_SIMULATION);
    Generated { data_fmu: fmu.clone(), job_fmu: fmu, time, inputs, outputs, body, seed, ..Default::default() }
}

/// `parameters`, `simulation` and the grids' tight optimizer table, as one job body.
fn body(parameters: &str, simulation: &str) -> String {
    format!("{parameters}{simulation}{TIGHT_OPTIMIZER}")
}

/// Writes the case's noisy data and job into `dir` and prepares the job.
fn generate(g: &Generated, dir: &Path) -> Result<Problem, String> {
    let fmu = fmucal_shared::fmu::Fmu::load(&g.data_fmu).map_err(|e| e.to_string())?;
    let spec = SimSpec {
        parameters: g.set.iter().map(|(n, v)| ((*n).to_owned(), v.to_string())).collect(),
        port_terms: g.port_terms.clone(),
        ..noise_free_spec(&g.time, &g.inputs, g.outputs)
    };
    let clean = simulate(&fmu, &spec).map_err(|e| e.to_string())?;
    let sigma = noise_sigmas(&clean, NOISE);
    let job = common::diagnosis::write_noisy_case(
        dir, &g.job_fmu, &g.time, &g.inputs, g.outputs, &clean, &sigma, g.seed, &g.body,
    );
    let spec = JobSpec::from_toml_file(&job).map_err(|e| e.to_string())?;
    prepare(spec)
}

/// The job with its calibrated values started at `x` (in `calibrated()` order).
fn started_at(spec: &JobSpec, x: &[f64]) -> JobSpec {
    let mut spec = spec.clone();
    let mut k = 0;
    for p in 0..spec.parameters.len() {
        if spec.parameters[p].per_experiment && !spec.experiments.is_empty() {
            for e in spec.fitted_experiments() {
                let name = spec.parameters[p].name.clone();
                spec.experiments[e].starts.insert(name, x[k]);
                k += 1;
            }
        } else {
            spec.parameters[p].start = x[k];
            k += 1;
        }
    }
    for effect in 0..spec.effects.len() {
        let names: Vec<&str> =
            spec.effects[effect].ordered_parameters(effect).unwrap_or_default().iter().map(|(n, _)| *n).collect();
        for name in names {
            if let Some(b) = spec.effects[effect].parameters.get_mut(name) {
                b.start = x[k];
            }
            k += 1;
        }
    }
    spec
}

/// The job's start, then `RANDOM_STARTS` seeded starts inside the bounds.
fn starts(spec: &JobSpec, seed: u64) -> Vec<Vec<f64>> {
    let (_, x0, lower, upper) = spec.parameter_vectors();
    let log = spec.log_scaled();
    let mut rng = Rng(seed);
    let mut out = vec![x0.clone()];
    for _ in 0..RANDOM_STARTS {
        let x = (0..x0.len())
            .map(|i| {
                let u = 0.05 + 0.9 * rng.uniform();
                if !(lower[i].is_finite() && upper[i].is_finite()) {
                    x0[i]
                } else if log[i] {
                    (lower[i].ln() + u * (upper[i].ln() - lower[i].ln())).exp()
                } else {
                    lower[i] + u * (upper[i] - lower[i])
                }
            })
            .collect();
        out.push(x);
    }
    out
}

/// One solver's runs of a case, one per start (an error as text).
type Runs = Vec<Result<Run, String>>;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 { v[n / 2] } else { 0.5 * (v[n / 2 - 1] + v[n / 2]) }
}

fn cell(v: f64) -> String {
    if v.is_finite() { format!("{v:.0}") } else { "failed".into() }
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let only = args.iter().position(|a| a == "--case").and_then(|i| args.get(i + 1)).cloned();
    let f_tol: Option<f64> = args
        .iter()
        .position(|a| a == "--f-tol")
        .and_then(|i| args.get(i + 1))
        .map(|v| v.parse().expect("--f-tol takes a number"));
    let mut lines = vec![];
    let mut notes = vec![];
    let (mut cases_run, mut ls_wins, mut ls_only_failures) = (0, 0, 0);
    let mut ratios = vec![];
    println!(
        "| case | n | starts | NM simulations | LS simulations | LS ÷ NM | NM rounds | LS rounds | NM failures | LS failures |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|");
    for (index, case) in cases().into_iter().enumerate() {
        if only.as_deref().is_some_and(|o| !case.name.contains(o)) {
            continue;
        }
        let dir = tempfile::tempdir().expect("a scratch folder");
        let problem = match &case.source {
            Source::Example(file) => Ok(load(file)),
            Source::Generated(g) => generate(g, dir.path()),
        };
        let mut problem = match problem {
            Ok(p) => p,
            Err(e) => {
                notes.push(format!("{}: cannot set up: {e}", case.name));
                continue;
            }
        };
        if f_tol.is_some() {
            problem.spec.optimizer.f_tol = f_tol;
        }
        let per_evaluation = problem.spec.fitted_experiments().len() as u64;
        let n = problem.spec.parameter_vectors().0.len();
        let starts = starts(&problem.spec, 1000 + index as u64);
        let runs: Vec<Runs> = SOLVERS
            .iter()
            .map(|algorithm| {
                starts
                    .iter()
                    .map(|x| {
                        let p = Problem {
                            spec: started_at(&problem.spec, x),
                            fmu: problem.fmu.clone(),
                            data: problem.data.clone(),
                        };
                        run(&p, *algorithm, THREADS, None)
                    })
                    .collect()
            })
            .collect();
        let best = runs.iter().flatten().flatten().map(|r| r.f_opt).fold(f64::INFINITY, f64::min);
        let target = best * 1.01;
        // Per solver: simulations and rounds to the target per start (infinite: failed).
        let reached: Vec<Vec<(f64, f64)>> = runs
            .iter()
            .map(|runs| {
                runs.iter()
                    .map(|r| match r.as_ref().ok().and_then(|r| r.reach(target)) {
                        Some((evaluations, rounds, _)) => ((evaluations * per_evaluation) as f64, rounds as f64),
                        None => (f64::INFINITY, f64::INFINITY),
                    })
                    .collect()
            })
            .collect();
        for (s, algorithm) in SOLVERS.iter().enumerate() {
            for (k, r) in runs[s].iter().enumerate() {
                if reached[s][k].0.is_finite() {
                    continue;
                }
                let other = reached[1 - s][k].0.is_finite();
                if *algorithm == Algorithm::LeastSquares && other {
                    ls_only_failures += 1;
                }
                let what = match r {
                    Ok(r) => format!(
                        "ended at f = {:.6e} ({:.1} % above the best), {} simulations, {}",
                        r.f_opt,
                        100.0 * (r.f_opt / best - 1.0),
                        r.evaluations * per_evaluation,
                        r.termination
                    ),
                    Err(e) => format!("error: {e}"),
                };
                let start: Vec<String> = starts[k].iter().map(|v| format!("{v:.3e}")).collect();
                notes.push(format!(
                    "{}: {algorithm} from [{}] {what}{}",
                    case.name,
                    start.join(", "),
                    if other { "; the other solver reached the target from there" } else { "" }
                ));
            }
        }
        let med = |s: usize, col: usize| median(reached[s].iter().map(|r| if col == 0 { r.0 } else { r.1 }).collect());
        let (nm, ls) = (med(0, 0), med(1, 0));
        let fails = |s: usize| reached[s].iter().filter(|r| !r.0.is_finite()).count();
        let ratio = if nm.is_finite() && ls.is_finite() { format!("{:.2}", ls / nm) } else { "–".into() };
        if nm.is_finite() && ls.is_finite() {
            ratios.push(ls / nm);
        }
        cases_run += 1;
        if ls < nm {
            ls_wins += 1;
        }
        let line = format!(
            "| {} | {n} | {} | {} | {} | {ratio} | {} | {} | {} | {} |",
            case.name,
            starts.len(),
            cell(nm),
            cell(ls),
            cell(med(0, 1)),
            cell(med(1, 1)),
            fails(0),
            fails(1)
        );
        println!("{line}");
        lines.push(line);
    }
    println!();
    println!("Least squares wins {ls_wins} of {cases_run} cases; median LS ÷ NM {:.2}.", median(ratios.clone()));
    println!("Starts where least squares fails and Nelder–Mead reaches the target: {ls_only_failures}.");
    let holds = cases_run > 0 && ls_wins * 5 >= cases_run * 4 && ls_only_failures == 0;
    println!(
        "Decision rule (wins on >= 80 % of cases, no failure Nelder–Mead avoids): {}.",
        if holds { "holds" } else { "does not hold" }
    );
    for note in &notes {
        println!("- {note}");
    }
}
