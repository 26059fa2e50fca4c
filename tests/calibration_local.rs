//! Calibration in-process: recovers a known parameter from data the model itself generated,
//! gives the same result for any number of threads, and rejects inconsistent jobs with the
//! field named.

mod common;

use std::sync::Arc;

use fmucal_shared::job::pool::EvaluatorPool;
use fmucal_shared::job::{Evaluator, JobSpec, MeasurementTable, PreparedJob, identifiability, local};
use fmucal_shared::sim::{SimSpec, simulate};

/// Synthetic data from Decay with k = 1.7, every 0.05 s, with one duplicated time stamp and one
/// missing cell.
fn data(dir: &std::path::Path) -> std::path::PathBuf {
    let cache = dir.join("cache");
    let fmu = common::load_example("decay", &cache);
    let spec = SimSpec { parameters: vec![("k".into(), "1.7".into())], tolerance: Some(1e-10), ..Default::default() };
    let r = simulate(&fmu, &spec).unwrap();
    let mut text = String::from("time,x\n");
    for (i, (t, x)) in r.time.iter().zip(r.column("x").unwrap()).enumerate() {
        if i % 5 != 0 {
            continue;
        }
        if i == 50 {
            text.push_str(&format!("{t},\n"));
        } else {
            text.push_str(&format!("{t},{x}\n"));
        }
        if i == 100 {
            text.push_str(&format!("{t},{x}\n"));
        }
    }
    common::write_file(dir, "decay.csv", text)
}

fn job(dir: &std::path::Path, extra: &str) -> JobSpec {
    let toml = common::job_toml(
        &common::example("decay"),
        Some(&data(dir)),
        &[("x", "x")],
        &[],
        &[("k", 1.0, 0.1, 5.0)],
        &format!("[simulation]\ntolerance = 1e-10\n[optimizer]\nx_tol = 1e-8\nf_tol = 1e-14\n{extra}\n"),
    );
    JobSpec::from_toml(&toml, dir).unwrap()
}

fn prepare(
    spec: &JobSpec,
    dir: &std::path::Path,
) -> (Arc<fmucal_shared::fmu::Fmu>, Result<PreparedJob, fmucal_shared::job::JobError>) {
    let fmu = Arc::new(common::load_example("decay", &dir.join("cache")));
    let table = MeasurementTable::read(spec.data.path.as_ref().unwrap(), "time").unwrap();
    let prepared = PreparedJob::new(spec, &fmu.description, &fmu.interfaces(), std::slice::from_ref(&table));
    (fmu, prepared)
}

#[test]
fn recovers_the_rate_that_generated_the_data_with_any_thread_count() {
    let dir = tempfile::tempdir().unwrap();
    for algorithm in ["nelder-mead", "differential-evolution", "cma-es", "least-squares"] {
        let spec = job(dir.path(), &format!("algorithm = \"{algorithm}\"\nmax_iters = 200\nseed = 3"));
        let (fmu, prepared) = prepare(&spec, dir.path());
        let prepared = Arc::new(prepared.unwrap());
        let one = local::calibrate(fmu.clone(), prepared.clone(), 1, |_| {}).unwrap();
        let three = local::calibrate(fmu, prepared, 3, |_| {}).unwrap();
        assert_eq!(one.x_opt, three.x_opt, "{algorithm}: thread count changed the result");
        assert_eq!(one.evaluations, three.evaluations);
        let k = one.x_opt["k"];
        assert!((k - 1.7).abs() < 1e-4, "{algorithm}: recovered k = {k}");
        assert!(one.f_opt < 1e-8, "{algorithm}: f_opt = {}", one.f_opt);
        assert!(!one.history.is_empty() && one.history.windows(2).all(|w| w[1].best_f <= w[0].best_f));
        // One history point per completed round, numbered from 1, the last one the final count.
        let rounds: Vec<u64> = one.history.iter().map(|h| h.round).collect();
        assert_eq!(rounds, (1..=one.rounds).collect::<Vec<_>>(), "{algorithm}: history rounds");
        assert_eq!(one.history.last().map(|h| h.evaluations), Some(one.evaluations));
    }
}

#[test]
fn duplicate_stamps_are_averaged_and_missing_cells_skipped() {
    let dir = tempfile::tempdir().unwrap();
    let spec = job(dir.path(), "");
    let (_, prepared) = prepare(&spec, dir.path());
    let obj = prepared.unwrap().single().objective.clone();
    assert_eq!(obj.times.len(), 41, "41 unique time stamps");
    assert!(obj.targets[0].values[10].is_nan(), "the empty cell is missing");
    assert!(obj.times.windows(2).all(|w| w[0] < w[1]));
}

#[test]
fn inconsistent_jobs_name_the_field() {
    let dir = tempfile::tempdir().unwrap();
    let cases: [(&str, &str, &str); 6] = [
        ("name = \"k\"", "name = \"kk\"", "parameters[0].name: unknown variable \"kk\""),
        ("name = \"k\"", "name = \"resourceFactor\"", "parameters[0].name: resourceFactor may not be set"),
        ("name = \"k\"", "name = \"power\"", "only Real parameters"),
        ("upper = 5.0", "upper = 500.0", "parameters[0].upper: 500 is above k's maximum 100"),
        ("column = \"x\"", "column = \"y\"", "outputs[0].column: no column \"y\" in the data; the closest: \"x\""),
        ("variable = \"x\"", "variable = \"nope\"", "outputs[0].variable: unknown variable"),
    ];
    for (from, to, want) in cases {
        let spec = job(dir.path(), "");
        let text = toml::to_string(&spec).unwrap().replacen(from, to, 1);
        let spec = JobSpec::from_toml(&text, dir.path()).unwrap();
        let (_, prepared) = prepare(&spec, dir.path());
        let err = prepared.unwrap_err().to_string();
        assert!(err.contains(want), "{want:?} not in {err:?}");
    }
}

#[test]
fn in_process_identifiability_uses_each_difference_points_own_residuals() {
    let dir = tempfile::tempdir().unwrap();
    let spec = job(dir.path(), "");
    let (fmu, prepared) = prepare(&spec, dir.path());
    let prepared = prepared.unwrap();
    // Away from the optimum, so the residuals (and the standard error) are far from zero.
    let x = [1.5];
    let pool = EvaluatorPool::new(3, "test-eval").unwrap();
    let analysed = identifiability::analyze(fmu.clone(), &prepared, &x, &pool).unwrap();
    // The same statistics from the plan's points evaluated one by one on a plain evaluator.
    let plan = identifiability::difference_points(&prepared, &x);
    let mut ev = Evaluator::new(&fmu, Arc::new(prepared.clone())).unwrap();
    let residuals: Vec<Vec<f64>> = plan.points.iter().map(|p| ev.evaluate(p, 0, true).residuals.unwrap()).collect();
    let direct = identifiability::from_residuals(&prepared.parameter_names, &plan, &residuals).unwrap();
    assert_eq!(analysed, direct);
    assert!(analysed.standard_errors[0] > 0.0 && analysed.standard_errors[0].is_finite(), "{analysed:?}");
    assert_eq!(analysed.residuals, prepared.single().objective.times.len() - 1, "one measurement is missing");
}

/// A rate four decades below the start is found when the optimizer works on log(k): the data
/// are the closed form x(t) = e^(−0.1 t), the start k = 1e-5 and the bounds [1e-6, 100].
#[test]
fn a_log_scaled_parameter_is_recovered_four_decades_from_its_start() {
    let dir = tempfile::tempdir().unwrap();
    let mut text = String::from("time,x\n");
    for i in 0..=80 {
        let t = 0.5 * f64::from(i);
        text.push_str(&format!("{t},{}\n", (-0.1 * t).exp()));
    }
    let data = dir.path().join("decay.csv");
    std::fs::write(&data, text).unwrap();
    let toml = common::job_toml(
        &common::example("decay"),
        Some(&data),
        &[("x", "x")],
        &[],
        &[("k", 1e-5, 1e-6, 100.0)],
        "[simulation]\ntolerance = 1e-10\n[optimizer]\nx_tol = 1e-9\nf_tol = 1e-16\n",
    )
    .replace("upper = 100.0", "upper = 100.0\nscale = \"log\"");
    let spec = JobSpec::from_toml(&toml, dir.path()).unwrap();
    let (fmu, prepared) = prepare(&spec, dir.path());
    let result = local::calibrate(fmu, Arc::new(prepared.unwrap()), 2, |_| {}).unwrap();
    let k = result.x_opt["k"];
    assert!((k - 0.1).abs() < 1e-5, "recovered k = {k} ({})", result.termination);
    assert!(result.f_opt < 1e-9, "f_opt = {}", result.f_opt);
}
