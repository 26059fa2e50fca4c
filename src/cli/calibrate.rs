//! `fmucal calibrate JOB.toml`: checks the job locally, then either calibrates on a local
//! cluster ([`super::local_cluster`]: an in-process coordinator and a worker process of N slots) or
//! submits to `--coordinator URL` ([`super::client`]). Then compares the start and optimized
//! models with the measurements, prints a summary (the optimum, the weighted RMS errors per
//! window, and a table of each output's RMS error in its unit with its fit %), and writes
//! `result.json`, `convergence.csv` and `fit.csv`
//! ([`super::outputs`]) and the plots (`fit`, `error`, `convergence`, as SVG and PNG) to `--out`.
//! A job with `[[experiments]]` gets one folder `--out/NAME` per experiment for its `fit.csv`
//! and plots, and its RMS errors per experiment in `result.json`. Ctrl-C (or SIGTERM) cancels
//! the job, writes its best point so far to `result.json` with termination `interrupted`, and
//! exits with code 130. With `FMUCAL_PROGRESS=json` the progress bar gives way to one JSON
//! object per completed batch on stderr (for a program running the CLI: the Python package's
//! progress bar). A local run evaluates its few follow-up points (the tolerance guard's
//! first-order move, the identifiability analysis) in this process ([`FollowUp`]).

use std::path::PathBuf;
use std::sync::Arc;

use anyhow::{Context, Result};
use fmucal_shared::job::{ExperimentErrors, JobSpec, ParameterRange, PreparedJob, identifiability, report, tolerance};
use fmucal_shared::quote::quote_user_text;

use super::client::Client;

#[derive(clap::Args)]
pub struct Args {
    /// The job file (TOML).
    job: PathBuf,
    /// Workers (simulations at once) for a local run. Default: the job's [workers] count, else the number of cores.
    #[arg(long)]
    workers: Option<usize>,
    /// Output folder for result.json, convergence.csv and fit.csv.
    #[arg(long, default_value = "calibration")]
    out: PathBuf,
    #[command(flatten)]
    remote: super::client::RemoteArgs,
    /// Any warning (a parameter at a bound, a run ended by its budget, ...) ends the run with
    /// exit code 3, after the results are written.
    #[arg(long)]
    strict: bool,
}

/// The optimizer's initial step (a fraction of each parameter's range) of a refit at a tighter
/// tolerance, unless the job sets one: it starts at the first optimum, so the search stays
/// local.
const REFIT_STEP: f64 = 0.01;

/// The environment variable that turns the progress bar into JSON lines on stderr.
const PROGRESS_ENV: &str = "FMUCAL_PROGRESS";

/// Whether `FMUCAL_PROGRESS` asks for JSON progress lines; any value but `json` (or none) is
/// refused, naming the variable.
fn json_progress() -> Result<bool> {
    match std::env::var(PROGRESS_ENV) {
        Err(std::env::VarError::NotPresent) => Ok(false),
        Ok(v) if v.is_empty() => Ok(false),
        Ok(v) if v == "json" => Ok(true),
        Ok(v) => anyhow::bail!("{PROGRESS_ENV}: {} is not `json` (or unset)", quote_user_text(&v)),
        Err(std::env::VarError::NotUnicode(_)) => anyhow::bail!("{PROGRESS_ENV}: not UTF-8"),
    }
}

/// One progress line: `{"progress":{"round":..,"iteration":..,"evaluations":..,"best_f":..}}`
/// (`best_f` is `null` until a point succeeded).
fn progress_line(ev: &fmucal_proto::v1::WatchJobResponse) -> String {
    let best_f = if ev.best_f.is_finite() { serde_json::json!(ev.best_f) } else { serde_json::Value::Null };
    serde_json::json!({ "progress": {
        "round": ev.rounds, "iteration": ev.iteration, "evaluations": ev.evaluations, "best_f": best_f,
    }})
    .to_string()
}

/// Runs one calibration on `client`: with the progress bar, or with JSON progress lines.
async fn run_calibration(
    client: &mut Client,
    json: bool,
    spec: &JobSpec,
    data: &[fmucal_shared::job::MeasurementTable],
    model: &std::path::Path,
) -> Result<fmucal_shared::job::CalibrationResult> {
    if json {
        client.calibrate_with(spec, data, model, |ev| eprintln!("{}", progress_line(ev))).await
    } else {
        client.calibrate(spec, data, model).await
    }
}

/// A run whose checks warned, under `--strict` (exit code 3).
#[derive(Debug, thiserror::Error)]
#[error("{0} warning(s) under --strict")]
pub(crate) struct Warned(pub usize);

/// Resolves `example:NAME` and checks the file is a regular file.
pub(super) fn model_path(spec: &JobSpec) -> Result<PathBuf> {
    let p = spec.model.path.as_ref().context("model.path: the job's [model] needs a path for the CLI")?;
    let text = p.to_string_lossy();
    if let Some(name) = text.strip_prefix("example:") {
        return super::model_arg::example(name)?
            .with_context(|| format!("model.path: no built-in example {}", quote_user_text(name)));
    }
    let limits = fmucal_shared::fmu::archive::ArchiveLimits::from_env();
    fmucal_shared::job::limits::check_regular_file("model.path", p, limits.max_archive_bytes)?;
    Ok(p.clone())
}

/// Where a calibration's follow-up points run (the guard's first-order move, the
/// identifiability analysis): in this process for a local run, which has the model loaded for
/// the guard's checks (on the workers the points would be a job of their own, whose round trips
/// cost more than the points of a cheap model); on the coordinator's workers for a run on
/// `--coordinator`. The values are the same either way: the same evaluations of the same job.
enum FollowUp {
    Here { fmu: Arc<fmucal_shared::fmu::Fmu>, threads: usize },
    Workers,
}

impl FollowUp {
    /// `points` of `job` ([`fmucal_shared::job::local::evaluate`], or a job of points on the
    /// workers through `client`).
    async fn evaluate(
        &self,
        client: &mut Client,
        job: &Arc<PreparedJob>,
        points: Vec<Vec<f64>>,
        data: &[fmucal_shared::job::MeasurementTable],
        model: &std::path::Path,
    ) -> Result<Vec<fmucal_shared::job::EvaluatedPoint>> {
        match self {
            FollowUp::Workers => client.evaluate(&job.spec, points, data, model).await,
            FollowUp::Here { fmu, threads } => {
                let (fmu, job, threads) = (fmu.clone(), job.clone(), (*threads).clamp(1, points.len().max(1)));
                // A thread of its own, not the runtime's blocking pool: on Ctrl-C the command
                // writes its result and ends without waiting for the points.
                let (tx, rx) = tokio::sync::oneshot::channel();
                std::thread::Builder::new()
                    .name("fmucal-points".into())
                    .spawn(move || {
                        let evaluated = fmucal_shared::job::pool::EvaluatorPool::new(threads, "fmucal-points")
                            .context("cannot start evaluation threads")
                            .and_then(|pool| Ok(fmucal_shared::job::local::evaluate(fmu, &job, points, &pool)?));
                        let _ = tx.send(evaluated);
                    })
                    .context("cannot start an evaluation thread")?;
                rx.await.unwrap_or_else(|_| Err(anyhow::anyhow!("the evaluation thread stopped")))
            }
        }
    }

    /// The standard errors and correlations at `result`'s optimum from the 2n + 1 difference
    /// points.
    async fn identify(
        &self,
        client: &mut Client,
        job: &Arc<PreparedJob>,
        result: &fmucal_shared::job::CalibrationResult,
        data: &[fmucal_shared::job::MeasurementTable],
        model: &std::path::Path,
    ) -> Result<identifiability::Identifiability> {
        let plan = identifiability::difference_points(job, &result.x_opt_in(&job.parameter_names));
        let evaluated = self.evaluate(client, job, plan.points.clone(), data, model).await?;
        let residuals = identifiability::residuals_of(&evaluated)?;
        Ok(identifiability::from_residuals(&job.parameter_names, &plan, &residuals)?)
    }
}

/// The first-order move of the estimates at `result`'s optimum when `job`'s tolerance tightens
/// to `tight`'s ([`tolerance::LinearisedMove`]), with the standard errors at the tighter
/// tolerance that come with it. Two batches: the difference points at the tighter tolerance,
/// and the optimum at the first.
async fn first_order_move(
    follow_up: &FollowUp,
    client: &mut Client,
    job: &Arc<PreparedJob>,
    tight: &tolerance::Tightened,
    result: &fmucal_shared::job::CalibrationResult,
    data: &[fmucal_shared::job::MeasurementTable],
    model: &std::path::Path,
) -> Result<(tolerance::LinearisedMove, identifiability::Identifiability)> {
    let started = std::time::Instant::now();
    let names = &tight.job.parameter_names;
    let x = result.x_opt_in(names);
    let plan = identifiability::difference_points(&tight.job, &x);
    let fine = identifiability::residuals_of(
        &follow_up.evaluate(client, &tight.job, plan.points.clone(), data, model).await?,
    )?;
    let coarse = identifiability::residuals_of(&follow_up.evaluate(client, job, vec![x.clone()], data, model).await?)?;
    let change: Vec<f64> = fine[0].iter().zip(&coarse[0]).map(|(f, c)| f - c).collect();
    let (step, errors) = identifiability::linearised_step(names, &plan, &fine, &change)?;
    let (_, _, lower, upper) = tight.spec.parameter_vectors();
    let x_tol = fmucal_shared::job::optimizer::stopping(&tight.spec, names.len()).x_tol;
    let tolerance = tight.spec.simulation.tolerance.context("the tightened job has a tolerance")?;
    let bounds = (&lower[..], &upper[..], &tight.spec.log_scaled()[..]);
    let moved = tolerance::LinearisedMove {
        simulations: (plan.points.len() as u64 + 1) * job.fitted.len() as u64,
        seconds: started.elapsed().as_secs_f64(),
        ..tolerance::LinearisedMove::new(tolerance, names, &x, &step, &errors, bounds, x_tol)
    };
    Ok((moved, identifiability::from_residuals(names, &plan, &fine)?))
}

/// Logs (at debug level, with the log's timestamp) that a step of the run has ended, and the
/// milliseconds since the command started: `FMUCAL_LOG=fmucal=debug` shows where a run's time
/// goes.
fn step(since: std::time::Instant, step: &str) {
    tracing::debug!(step, ms = format_args!("{:.1}", since.elapsed().as_secs_f64() * 1e3), "calibrate");
}

pub fn run(args: Args) -> Result<()> {
    let t0 = std::time::Instant::now();
    let json = json_progress()?;
    let mut spec = JobSpec::from_toml_file(&args.job)?;
    spec.validate()?;
    let threads = super::local_cluster::worker_count(args.workers, &spec)?;
    args.remote.check()?;
    let model = model_path(&spec)?;
    spec.model.path = Some(model.clone());
    let data = fmucal_shared::job::data::read_all(&spec)?;
    // Check everything locally first: bad jobs fail before any process starts.
    let fmu =
        Arc::new(super::known_archives::load(&model).with_context(|| format!("cannot load {}", model.display()))?);
    let prepared = Arc::new(PreparedJob::new(&spec, &fmu.description, &fmu.interfaces(), &data)?);
    fmucal_shared::job::optimizer::build(&spec)?;
    step(t0, "job checked against the model and data");
    // Removed again if the run fails before writing anything into it.
    let _out = super::outputs::OutDir::create(&args.out)?;

    // The tolerance guard, before the calibration: tighten until the start point's integration
    // error is small against the noise.
    let guarded = spec.simulation.tolerance_guard.unwrap_or(true);
    // A start point that does not simulate is the calibration's to report, as it always has.
    let (prepared, start_checks) = if guarded {
        let (_, x0, _, _) = prepared.spec.parameter_vectors();
        match tolerance::tighten(&fmu, prepared.clone(), &data, &x0, "start") {
            Ok(t) => (t.job, t.checks),
            Err(e) => {
                tracing::debug!("no tolerance check at the start point: {e}");
                (prepared, vec![])
            }
        }
    } else {
        (prepared, vec![])
    };
    step(t0, "tolerance guard at the start point");

    // One runtime thread: the client runs on this thread (`block_on`) and the runtime's thread
    // only runs a local run's coordinator and the connections' tasks (the simulations run in
    // the worker process and on threads of their own); a second runtime thread costs
    // wake-ups across cores in the round trips with the workers, about 3 ms of a 55 ms local
    // run of a cheap model (`bash bench/fmpy_scipy_local.sh`).
    let rt = tokio::runtime::Builder::new_multi_thread().worker_threads(1).enable_all().build()?;
    let started = std::time::Instant::now();
    // Ctrl-C or SIGTERM cancels the job and keeps its best point so far; a local cluster's
    // workers and temporary folder go with it.
    let max_time = spec.optimizer.max_time;
    let follow_up = match args.remote.coordinator {
        None => FollowUp::Here { fmu: fmu.clone(), threads },
        Some(_) => FollowUp::Workers,
    };
    let work = async |mut client: Client| {
        let mut stopper = client.clone();
        // `optimizer.max_time` stops the calibration (not the analysis after it) with its best
        // point so far, as Ctrl-C does, but as a result like any other.
        let deadline = async {
            match max_time {
                Some(t) => tokio::time::sleep(std::time::Duration::from_secs_f64(t)).await,
                None => std::future::pending().await,
            }
        };
        let mut result = tokio::select! {
            r = run_calibration(&mut client, json, &prepared.spec, &data, &model) => r?,
            () = deadline => {
                let mut r = stopper.interrupt().await?.with_context(|| {
                    format!("optimizer.max_time: {} s passed before the run had a result", max_time.unwrap_or(0.0))
                })?;
                r.termination = "max_time reached".into();
                r
            }
            () = super::servers::terminate_signal() => return Ok(Err(stopper.interrupt().await?)),
        };
        step(t0, "calibrated");
        // The guard at the optimum: if the integration error there is not small against the
        // noise, refit from the optimum at the tolerance that makes it so.
        let mut job = prepared.clone();
        let mut checks = vec![];
        let mut refit = None;
        let mut linearised_move = None;
        // The standard errors, when the guard's first-order move already computed them.
        let mut identified = None;
        if guarded && result.termination != "max_time reached" {
            let x = result.x_opt_in(&job.parameter_names);
            let t = tokio::task::block_in_place(|| tolerance::tighten(&fmu, job.clone(), &data, &x, "optimum"))
                .map_err(|e| tracing::warn!("no tolerance check at the optimum: {e}"))
                .ok();
            if let Some(t) = &t {
                checks = t.checks.clone();
            }
            if let Some(t) = t.filter(|t| t.tightened(&job.spec)) {
                // How far the estimates move at the tighter tolerance, to first order: the
                // check's bound is often loose, and a refit costs a local search.
                let moved = tokio::select! {
                    m = first_order_move(&follow_up, &mut client, &job, &t, &result, &data, &model) => m,
                    () = super::servers::terminate_signal() => return Ok(Err(stopper.interrupt().await?)),
                };
                let moved = moved.map_err(|e| tracing::warn!("no first-order move at the optimum: {e:#}")).ok();
                if let Some((m, id)) = moved.as_ref().filter(|(m, _)| !m.refit_needed) {
                    linearised_move = Some(m.clone());
                    identified = Some(id.clone());
                    job = t.job;
                } else {
                    linearised_move = moved.map(|(m, _)| m);
                    // From the optimum, a local search; the report still compares with the
                    // job's own starts (`t.job`).
                    let mut from_optimum = t.spec.clone().with_starts(&result.x_opt);
                    if let Some(step) = from_optimum.optimizer.initial_step_mut() {
                        step.get_or_insert(REFIT_STEP);
                    }
                    let refit_started = std::time::Instant::now();
                    let second = tokio::select! {
                        r = run_calibration(&mut client, json, &from_optimum, &data, &model) => r?,
                        () = super::servers::terminate_signal() => return Ok(Err(stopper.interrupt().await?)),
                    };
                    refit = Some(tolerance::Refit {
                        from_tolerance: tolerance::effective_tolerance(&job.spec, &fmu),
                        evaluations: second.evaluations,
                        seconds: refit_started.elapsed().as_secs_f64(),
                    });
                    result = result.followed_by(second);
                    job = t.job;
                }
            }
        }
        step(t0, "tolerance guard at the optimum");
        let guard = guarded.then(|| {
            let mut all = start_checks.clone();
            all.extend(checks);
            let tolerance = tolerance::effective_tolerance(&job.spec, &fmu);
            tolerance::Guard { tolerance, checks: all, linearised_move, refit }
        });
        if let Some(identified) = identified {
            return Ok(Ok((result, Ok(identified), job, guard)));
        }
        let identified = tokio::select! {
            r = follow_up.identify(&mut client, &job, &result, &data, &model) => r,
            () = super::servers::terminate_signal() => return Ok(Err(stopper.interrupt().await?)),
        };
        step(t0, "identifiability points evaluated");
        Ok(Ok((result, identified, job, guard)))
    };
    let (outcome, stopping) = rt.block_on(async {
        match args.remote.connect().await? {
            Some(client) => Ok((work(client).await?, None)),
            None => super::local_cluster::run(threads, (&model, &fmu), work).await.map(|(o, s)| (o, Some(s))),
        }
    })?;
    // A local cluster stops while the outputs are written; it is waited for before the command
    // returns, on every path.
    let cluster = WaitOnDrop(&rt, stopping);
    // The wall time as the user saw it (a coordinator's result may not carry its own).
    let wall_s = started.elapsed().as_secs_f64();
    let (mut result, identified, prepared, guard) = match outcome {
        Ok(done) => done,
        Err(partial) => {
            if let Some(result) = partial {
                super::outputs::write_result(&args.out, &result)?;
                eprintln!(
                    "interrupted: wrote the best point so far (f = {:.6e} after {} evaluations) to {}",
                    result.f_opt,
                    result.evaluations,
                    args.out.join("result.json").display()
                );
            }
            return Err(super::Interrupted.into());
        }
    };
    result.tolerance_guard = guard;
    match identified {
        Ok(id) => result.identifiability = Some(id),
        Err(e) => tracing::warn!("no identifiability analysis: {e:#}"),
    }

    result.fmi_version = Some(fmu.description.fmi_version.clone());
    let x_opt = result.x_opt_in(&prepared.parameter_names);
    let mut fits = vec![];
    for (k, table) in data.iter().enumerate() {
        fits.push(report::compare(&fmu, &prepared, k, table, &x_opt, report::Models::StartAndOptimized)?);
    }
    step(t0, "start and optimum compared with the data");
    // What `fmucal plot` needs to label a redrawn plot: the order and bounds of each history
    // point's best x, and the outputs' units.
    let (names, _, lower, upper) = spec.parameter_vectors();
    result.parameters = (names.into_iter().zip(lower).zip(upper))
        .map(|((name, lower), upper)| ParameterRange { name, lower, upper })
        .collect();
    let outputs = fits.iter().flat_map(|(fit, _)| &fit.outputs);
    result.units = outputs.filter_map(|o| Some((o.variable.clone(), o.unit.clone()?))).collect();
    let model_start = fmu.description.default_experiment.as_ref().and_then(|d| d.start_time).unwrap_or(0.0);
    let data_start = data.first().and_then(|d| d.time.first().copied());
    if !(result.elapsed_s > 0.0) {
        result.elapsed_s = wall_s;
    }
    // The misfit check needs the fit's series; the others only the result.
    let mut misfit_warning = None;
    if spec.experiments.is_empty() {
        let (fit, errors) = fits.pop().context("one experiment")?;
        // The same test of "far from the noise" as a diagnosis's conclusion.
        let stop = spec.simulation.stop_time.or_else(|| data.first().and_then(|d| d.time.last().copied()));
        let misfit = fit.misfit(stop.unwrap_or(f64::INFINITY));
        if misfit.far() {
            misfit_warning = Some(format!(
                "the fit leaves more than noise ({}): the model may miss something; `fmucal diagnose` looks for what",
                misfit.evidence()
            ));
        }
        result.errors = Some(errors);
        result.warnings = fmucal_shared::job::warnings::check(&spec, &result, model_start, data_start);
        result.warnings.extend(misfit_warning);
        step(t0, "warnings checked");
        // The files and the plots are independent: written side by side.
        let (written, drawn) = std::thread::scope(|s| {
            let written = s.spawn(|| super::outputs::write(&args.out, &result, &fit));
            let drawn =
                crate::report::draw_all(&args.out, &fit, &result.history, &result.parameters, result.errors.as_ref());
            (written.join().unwrap_or_else(|_| Err(anyhow::anyhow!("writing the results panicked"))), drawn)
        });
        written?;
        drawn?;
        step(t0, "result.json, CSVs and plots written");
    } else {
        for (e, (fit, errors)) in prepared.experiments.iter().zip(&fits) {
            let dir = args.out.join(&e.name);
            std::fs::create_dir_all(&dir).with_context(|| format!("cannot create {}", dir.display()))?;
            super::outputs::write_fit(&dir, fit)?;
            crate::report::draw_all(&dir, fit, &result.history, &result.parameters, Some(errors))?;
            result.experiments.push(ExperimentErrors {
                name: e.name.clone(),
                role: e.role.to_string(),
                errors: errors.clone(),
            });
        }
        result.warnings = fmucal_shared::job::warnings::check(&spec, &result, model_start, data_start);
        super::outputs::write_result(&args.out, &result)?;
    }
    drop(cluster);
    step(t0, "workers and coordinator stopped");
    let budget = if fmucal_shared::job::warnings::ended_on_budget(&result.termination) {
        " (a budget, not convergence, ended the run)"
    } else {
        ""
    };
    println!(
        "termination: {}{budget}; f_opt = {:.6e} after {} evaluations in {:.2} s",
        result.termination, result.f_opt, result.evaluations, wall_s
    );
    let (names, _, lower, upper) = spec.parameter_vectors();
    for (name, v) in &result.x_opt {
        let bound = names
            .iter()
            .position(|n| n == name)
            .and_then(|i| fmucal_shared::job::warnings::at_bound(*v, lower[i], upper[i]));
        let se = match bound {
            Some(side) => Some(format!("  (at {side} bound)")),
            None => result.identifiability.as_ref().and_then(|id| {
                let k = id.names.iter().position(|n| n == name)?;
                Some(format!("  (standard error {:.2e})", id.standard_errors[k]))
            }),
        };
        println!("  {name} = {v:.6e}{}", se.unwrap_or_default());
    }
    if let Some(e) = &result.errors {
        let v = e.validation.as_ref().map(|v| format!(", validation {}", ratio(v))).unwrap_or_default();
        println!("scaled RMS error (optimized / start): calibration {}{v}", ratio(&e.calibration));
        if !e.outputs.is_empty() {
            println!("{OUTPUT_TABLE_TITLE}:");
        }
        print!("{}", output_table(&e.outputs, "calibration"));
    }
    if result.experiments.iter().any(|x| !x.errors.outputs.is_empty()) {
        println!("{OUTPUT_TABLE_TITLE}, per experiment:");
    }
    for x in &result.experiments {
        let e = &x.errors;
        let v = e.validation.as_ref().map(|v| format!(", validation window {}", ratio(v))).unwrap_or_default();
        let window = if x.role == "fit" { "calibration window" } else { "whole span (not fitted)" };
        println!(
            "experiment {} ({}): scaled RMS error (optimized / start): {window} {}{v}",
            x.name,
            x.role,
            ratio(&e.calibration)
        );
        print!("{}", output_table(&e.outputs, if x.role == "fit" { "calibration" } else { "whole span" }));
    }
    if let Some(g) = &result.tolerance_guard {
        println!("{}", g.summary());
    }
    if let Some(id) = &result.identifiability
        && let Some((a, b, c)) = largest_correlation(id)
    {
        println!("largest parameter correlation: {c:+.3} ({a}, {b})");
    }
    for w in &result.warnings {
        eprintln!("warning: {w}");
    }
    eprintln!("wrote {}", args.out.join("result.json").display());
    if args.strict && !result.warnings.is_empty() {
        return Err(Warned(result.warnings.len()).into());
    }
    Ok(())
}

/// A stopping local cluster ([`super::local_cluster::Stopping`]), waited for when dropped.
struct WaitOnDrop<'a>(&'a tokio::runtime::Runtime, Option<super::local_cluster::Stopping>);

impl Drop for WaitOnDrop<'_> {
    fn drop(&mut self) {
        if let Some(s) = self.1.take() {
            self.0.block_on(s.wait());
        }
    }
}

/// The pair of different parameters with the largest |correlation|, and that correlation with
/// its sign.
fn largest_correlation(id: &identifiability::Identifiability) -> Option<(&str, &str, f64)> {
    let n = id.names.len();
    let mut best: Option<(&str, &str, f64)> = None;
    for i in 0..n {
        for j in i + 1..n {
            let c = id.correlation[i][j];
            if best.is_none_or(|b| c.abs() > b.2.abs() || b.2.is_nan()) {
                best = Some((&id.names[i], &id.names[j], c));
            }
        }
    }
    best
}

/// A window's scaled RMS error for the summary, or why there is none: it is optimized / start
/// (the job's start values, `rms_start` in `result.json`), which has no value when the start
/// error is zero or not a number (every weight 0, a start point that fits exactly, or errors
/// that overflow).
fn ratio(w: &fmucal_shared::job::result::WindowError) -> String {
    if w.scaled_rms.is_finite() {
        format!("{:.3}", w.scaled_rms)
    } else if w.rms_start == 0.0 {
        "n/a (the start error is 0: every weight is 0, or the start point fits exactly)".into()
    } else {
        "n/a (an RMS error is not a finite number)".into()
    }
}

/// What [`output_table`]'s columns hold.
const OUTPUT_TABLE_TITLE: &str = "per output (RMS error in the output's unit; fit % = 100·(1 − ‖y − ŷ‖/‖y − ȳ‖))";

/// Each output's errors as a table, one row per output and window (the first called `first`,
/// then `validation`): the RMS error of the start and the optimized model in the output's
/// unit, and their fit %; empty without outputs.
fn output_table(outputs: &[fmucal_shared::job::result::OutputErrors], first: &str) -> String {
    use std::fmt::Write;
    if outputs.is_empty() {
        return String::new();
    }
    let name_w = outputs.iter().map(|o| o.variable.chars().count()).chain([6]).max().unwrap_or(6);
    let unit = |o: &fmucal_shared::job::result::OutputErrors| o.unit.clone().unwrap_or_else(|| "-".into());
    let unit_w = outputs.iter().map(|o| unit(o).chars().count()).chain([4]).max().unwrap_or(4);
    let rms = |v: f64| if v.is_finite() { format!("{v:.3e}") } else { "n/a".into() };
    let fit = |v: f64| if v.is_finite() { format!("{v:.1}") } else { "n/a".into() };
    let mut s = String::new();
    let _ = writeln!(
        s,
        "  {:<name_w$}  {:<unit_w$}  {:<11}  {:>10}  {:>13}  {:>11}  {:>15}",
        "output", "unit", "window", "RMS start", "RMS optimized", "fit % start", "fit % optimized"
    );
    for o in outputs {
        let windows = [(first, Some(o.calibration)), ("validation", o.validation)];
        for (window, e) in windows.iter().filter_map(|(w, e)| e.map(|e| (w, e))) {
            let _ = writeln!(
                s,
                "  {:<name_w$}  {:<unit_w$}  {window:<11}  {:>10}  {:>13}  {:>11}  {:>15}",
                o.variable,
                unit(o),
                rms(e.rms_start),
                rms(e.rms_optimized),
                fit(e.fit_percent_start),
                fit(e.fit_percent_optimized)
            );
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn progress_lines_are_one_json_object_with_null_for_no_point_yet() {
        let mut ev = fmucal_proto::v1::WatchJobResponse {
            iteration: 4,
            evaluations: 17,
            best_f: f64::INFINITY,
            rounds: 5,
            ..Default::default()
        };
        let line = progress_line(&ev);
        assert!(!line.contains('\n'));
        let v: serde_json::Value = serde_json::from_str(&line).unwrap();
        assert_eq!(v, serde_json::json!({"progress": {"round": 5, "iteration": 4, "evaluations": 17, "best_f": null}}));
        ev.best_f = 0.1 + 0.2;
        let v: serde_json::Value = serde_json::from_str(&progress_line(&ev)).unwrap();
        assert_eq!(v["progress"]["best_f"].as_f64().unwrap().to_bits(), (0.1f64 + 0.2).to_bits());
    }
}
