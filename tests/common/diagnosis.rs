//! The cases of the diagnosis benchmarks (`tests/diagnosis_grid.rs`,
//! `tests/diagnosis_exported.rs`) and of `bench/solver_choice.rs`, which fits their base jobs:
//! the models' inputs, outputs and base parameters, and noisy data simulated from a fixture.

use std::path::{Path, PathBuf};

use fmucal_shared::sim::{OutputTimes, SimResult, SimSpec, simulate};

/// SplitMix64 and Box–Muller: seeded uniform and Gaussian numbers without a dependency.
pub struct Rng(pub u64);

impl Rng {
    pub fn uniform(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }

    pub fn gaussian(&mut self) -> f64 {
        let (u1, u2) = (self.uniform().max(1e-300), self.uniform());
        (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    }
}

/// Input columns of a case: (data column, FMU input, samples).
pub type Inputs = Vec<(&'static str, &'static str, Vec<f64>)>;

/// `n + 1` times from 0, `dt` apart.
pub fn time_grid(n: usize, dt: f64) -> Vec<f64> {
    (0..=n).map(|k| k as f64 * dt).collect()
}

/// The Furuta pendulum's input profiles: 0 torque pulses in both directions then a free swing,
/// 1 a slow sine with a faster one on top, its amplitude growing threefold over the record (at
/// one amplitude, damping that grows with speed, quadratic drag, acts as a viscous friction
/// would, and only the change of amplitude tells them apart).
pub fn furuta_inputs(profile: usize) -> (Vec<f64>, Inputs) {
    let time = time_grid(1000, 0.01);
    let u = time
        .iter()
        .map(|t| match profile {
            0 if *t < 1.0 => 0.08,
            0 if *t < 2.0 => -0.08,
            0 if (4.0..4.5).contains(t) => 0.1,
            0 => 0.0,
            _ => (0.5 + 0.1 * t) * (0.05 * (1.3 * t).sin() + 0.02 * (4.1 * t).sin()),
        })
        .collect();
    (time, vec![("u", "u", u)])
}

/// The spring–mass's input profiles of `tests/diagnosis_grid.rs`: 0 a sine force, 1 two sines.
pub fn spring_mass_inputs(profile: usize) -> (Vec<f64>, Inputs) {
    let time = time_grid(1000, 0.02);
    let f = time
        .iter()
        .map(|t| match profile {
            0 => 3.0 * t.sin(),
            _ => 2.5 * (0.7 * t).sin() + 1.5 * (1.9 * t).sin(),
        })
        .collect();
    (time, vec![("F", "F", f)])
}

/// The exported spring–mass's inputs in `tests/diagnosis_exported.rs`: none (the mass rings
/// down from its start), or driven by a force of the order of the spring's pull at the start
/// position (k·x0 = 2 N), below the resonance (2 rad/s), with a slower one on top.
pub fn exported_spring_mass_inputs(driven: bool) -> (Vec<f64>, Inputs) {
    let time = time_grid(1000, 0.02);
    if !driven {
        return (time, vec![]);
    }
    let f = time.iter().map(|t| 0.8 * (1.3 * t).sin() + 0.4 * (0.5 * t).sin()).collect();
    (time, vec![("F", "F", f)])
}

/// The exhaust pipe's measured inputs up to 1800 s (`examples/exhaust/exhaust_data.csv`).
pub fn exhaust_inputs() -> (Vec<f64>, Inputs) {
    let data = super::exhaust_data();
    let rows = data.time.partition_point(|t| *t <= 1800.0);
    let columns =
        super::EXHAUST_INPUTS.map(|c| (c, c, data.column(c).expect("an exhaust input")[..rows].to_vec())).to_vec();
    (data.time[..rows].to_vec(), columns)
}

/// The base models of the diagnosis benchmarks.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Model {
    Furuta,
    SpringMass,
    Exhaust,
}

impl Model {
    /// Outputs (FMU variable, data column).
    pub fn outputs(self) -> &'static [(&'static str, &'static str)] {
        match self {
            Model::Furuta => &[("armJoint.phi", "phi"), ("pendulumJoint.phi", "theta")],
            Model::SpringMass => &[("mass.x", "x")],
            Model::Exhaust => &[("outlet.T", "outlet_T")],
        }
    }

    /// The base job's `[[parameters]]` tables (the spring–mass's is also the one
    /// `bench/fmpy_scipy_local.sh` fits).
    pub fn parameters(self) -> &'static str {
        match self {
            Model::Furuta => include_str!("../data/parameters/furuta.toml"),
            Model::SpringMass => include_str!("../data/parameters/spring_mass.toml"),
            Model::Exhaust => include_str!("../data/parameters/exhaust_pipe.toml"),
        }
    }
}

/// The exhaust pipe's `[simulation]` and `[optimizer]` tables: calibrated to 1200 s, held out
/// to 1800 s.
pub const EXHAUST_SETTINGS: &str = "[simulation]\nstop_time = 1200.0\nvalidation_stop_time = 1800.0\ntolerance = 1e-6\n\
                                    [optimizer]\nx_tol = 1e-4\nf_tol = 1e-6\n";

/// The `[simulation]` tables of the Furuta and spring–mass jobs: `tests/diagnosis_grid.rs`
/// fits the whole record (the diagnosis holds out its last quarter), `tests/diagnosis_exported.rs`
/// names its windows (the last quarter held out).
pub const GRID_SIMULATION: &str = "[simulation]\ntolerance = 1e-8\n";
pub const FURUTA_EXPORTED_SIMULATION: &str =
    "[simulation]\nstop_time = 7.5\nvalidation_stop_time = 10.0\ntolerance = 1e-8\n";
pub const SPRING_MASS_EXPORTED_SIMULATION: &str =
    "[simulation]\nstop_time = 15.0\nvalidation_stop_time = 20.0\ntolerance = 1e-8\n";

/// The tight `[optimizer]` table of the Furuta and spring–mass jobs.
pub const TIGHT_OPTIMIZER: &str = "[optimizer]\nx_tol = 1e-5\nf_tol = 1e-10\n";

/// The simulation of `outputs` on `inputs` (none: no input table), over `time` and at tolerance
/// 1e-10, that gives a case's noise-free data.
pub fn noise_free_spec(time: &[f64], inputs: &Inputs, outputs: &[(&str, &str)]) -> SimSpec {
    let table = (!inputs.is_empty())
        .then(|| super::table(time.to_vec(), inputs.iter().map(|(_, variable, v)| (*variable, v.clone())).collect()));
    SimSpec {
        start_time: Some(time[0]),
        stop_time: time.last().copied(),
        output_times: Some(OutputTimes::Times(time.to_vec())),
        inputs: table,
        outputs: outputs.iter().map(|(v, _)| (*v).to_owned()).collect(),
        tolerance: Some(1e-10),
        ..Default::default()
    }
}

/// The outputs of `fmu` at its default parameters (its files unpacked under `dir/cache`) on
/// `inputs` over `time`, without noise.
pub fn noise_free(fmu: &Path, time: &[f64], inputs: &Inputs, outputs: &[(&str, &str)], dir: &Path) -> SimResult {
    let fmu = super::load(fmu, &dir.join("cache"));
    simulate(&fmu, &noise_free_spec(time, inputs, outputs)).unwrap()
}

/// Noise standard deviation of each output: the fraction `noise` of its range.
pub fn noise_sigmas(clean: &SimResult, noise: f64) -> Vec<f64> {
    clean
        .columns
        .iter()
        .map(|c| {
            let (lo, hi) = c.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| (a.min(*v), b.max(*v)));
            noise * (hi - lo)
        })
        .collect()
}

/// The RMS error a perfect model has on data with these noise levels (all weights 1).
pub fn noise_floor(sigma: &[f64]) -> f64 {
    (sigma.iter().map(|s| s * s).sum::<f64>() / sigma.len() as f64).sqrt()
}

/// Writes `dir/data.csv`, the columns `time`, then `outputs` (`clean`'s columns plus seeded
/// Gaussian noise of standard deviation `sigma`, one per output), then the inputs as they are,
/// and `dir/job.toml`, the job on `model` with those outputs and inputs and then `body`; returns
/// the job file.
#[allow(clippy::too_many_arguments)]
pub fn write_noisy_case(
    dir: &Path,
    model: &Path,
    time: &[f64],
    inputs: &Inputs,
    outputs: &[(&str, &str)],
    clean: &SimResult,
    sigma: &[f64],
    seed: u64,
    body: &str,
) -> PathBuf {
    let mut noise = Rng(seed);
    let mut csv = String::from("time");
    for (_, column) in outputs {
        csv.push_str(&format!(",{column}"));
    }
    for (column, _, _) in inputs {
        csv.push_str(&format!(",{column}"));
    }
    csv.push('\n');
    for (i, t) in time.iter().enumerate() {
        csv.push_str(&format!("{t}"));
        for (c, s) in clean.columns.iter().zip(sigma) {
            csv.push_str(&format!(",{}", c[i] + s * noise.gaussian()));
        }
        for (_, _, v) in inputs {
            csv.push_str(&format!(",{}", v[i]));
        }
        csv.push('\n');
    }
    std::fs::write(dir.join("data.csv"), csv).unwrap();
    let mapped: Vec<(&str, &str)> = inputs.iter().map(|(column, variable, _)| (*column, *variable)).collect();
    let job = super::job_toml(model, Some(Path::new("data.csv")), outputs, &mapped, &[], body);
    let path = dir.join("job.toml");
    std::fs::write(&path, job).unwrap();
    path
}

/// Writes a case of `model` into `dir`: data simulated from `truth` ([`noise_free`]) on the
/// input columns over the times of `time_inputs`, with noise of the fraction `noise` of each
/// output's range ([`noise_sigmas`]) seeded with `seed`, and the job on `base` with `body`
/// ([`write_noisy_case`]). Returns the job file, the noise floor ([`noise_floor`]) and the
/// noise-free outputs.
#[allow(clippy::too_many_arguments)]
pub fn write_case(
    dir: &Path,
    truth: &Path,
    base: &Path,
    model: Model,
    (time, inputs): (Vec<f64>, Inputs),
    noise: f64,
    seed: u64,
    body: &str,
) -> (PathBuf, f64, SimResult) {
    let clean = noise_free(truth, &time, &inputs, model.outputs(), dir);
    let sigma = noise_sigmas(&clean, noise);
    let job = write_noisy_case(dir, base, &time, &inputs, model.outputs(), &clean, &sigma, seed, body);
    (job, noise_floor(&sigma), clean)
}

/// A scratch folder for a case: under `DIAGNOSIS_GRID_DIR` (kept, to look at) if set.
pub fn case_dir(name: &str) -> (Option<tempfile::TempDir>, PathBuf) {
    match std::env::var_os("DIAGNOSIS_GRID_DIR") {
        Some(root) => {
            let dir = Path::new(&root).join(name);
            std::fs::create_dir_all(&dir).unwrap();
            (None, dir)
        }
        None => {
            let t = tempfile::tempdir().unwrap();
            let p = t.path().to_owned();
            (Some(t), p)
        }
    }
}

/// The cases of `grid` to run, numbered as the kept folders are: those whose numbers
/// `DIAGNOSIS_GRID_CASES` lists (`3,4,10`), or all where it is not set.
pub fn selected<C>(grid: Vec<C>) -> Vec<(usize, C)> {
    let only: Option<Vec<usize>> = std::env::var("DIAGNOSIS_GRID_CASES").ok().map(|s| {
        s.split(',').filter(|x| !x.trim().is_empty()).map(|x| x.trim().parse().expect("case numbers")).collect()
    });
    grid.into_iter().enumerate().filter(|(k, _)| only.as_ref().is_none_or(|o| o.contains(k))).collect()
}

/// Prints the head of a Markdown table with these columns.
pub fn print_table_head(columns: &[&str]) {
    println!("| {} |", columns.join(" | "));
    println!("|{}", "---|".repeat(columns.len()));
}

/// Runs `fmucal diagnose --workers 2` on the job of `case` into `dir/diagnosis`, which must
/// succeed, and reads its report.
pub fn diagnose(case: &impl std::fmt::Debug, job: &Path, dir: &Path) -> fmucal_diagnose::report::Diagnosis {
    let out = dir.join("diagnosis");
    let run = fmucal("diagnose", job, &out);
    assert!(
        run.status.success(),
        "{case:?}: {}\n{}",
        String::from_utf8_lossy(&run.stdout),
        String::from_utf8_lossy(&run.stderr)
    );
    eprintln!("{case:?}\n{}", String::from_utf8_lossy(&run.stdout));
    serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap()
}

/// Runs `fmucal COMMAND --workers 2 --out OUT JOB`.
pub fn fmucal(command: &str, job: &Path, out: &Path) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_fmucal"))
        .args([command, "--workers", "2", "--out"])
        .arg(out)
        .arg(job)
        .output()
        .unwrap()
}
