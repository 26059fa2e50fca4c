//! `fmucal diagnose JOB.toml`: calibrates the job, finds where the model and the measurements
//! disagree, screens the candidate effects at every place the model's structure offers (its
//! states in Model Exchange, its injection inputs) and the job's `[diagnose]` section allows, fits the most
//! promising ones concurrently on the workers, names the one that passes all three tests of
//! [`fmucal_diagnose::decision`] (or none), and writes to `--out` (default
//! `diagnosis/`): `report.json`, `job.toml` (the job with the named effects added, ready for
//! `fmucal calibrate`), `corrected.fmu` (that job's model as an FMU, when an effect is named,
//! as `fmucal export` writes it) and the residual plots. Locally (an in-process coordinator and worker
//! processes, as `calibrate` runs) or on `--coordinator URL`.
//!
//! The diagnosis itself is [`fmucal_diagnose::driver`]; this module is its command line: the
//! flags, the files it reads and writes, and the lines and bars it prints ([`Printer`]).
//!
//! - [`plots`]: residual plots before and after, and against the most correlated signal.

mod plots;

use std::path::PathBuf;
use std::sync::Arc;

use anyhow::{Context as _, Result, bail};
use fmucal_diagnose::driver::{self, Context, Event, Observe, checks};
use fmucal_diagnose::jobs::polish_step;
use fmucal_diagnose::spec::DiagnoseSpec;
use fmucal_shared::job::JobSpec;
use fmucal_shared::job::choices::Algorithm;

use super::client::{Client, OnCoordinator};

#[derive(clap::Args)]
pub struct Args {
    /// The job file (TOML), with an optional [diagnose] section.
    job: PathBuf,
    /// Workers (simulations at once) for a local run. Default: the job's [workers] count, else the number of cores.
    #[arg(long)]
    workers: Option<usize>,
    /// Output folder for report.json, job.toml and the plots.
    #[arg(long, default_value = "diagnosis")]
    out: PathBuf,
    /// Candidates fitted after screening (overrides [diagnose] top).
    #[arg(long)]
    top: Option<usize>,
    #[command(flatten)]
    remote: super::client::RemoteArgs,
    /// Stop (cancelling the jobs submitted) when standard input closes: how a coordinator
    /// running this diagnosis for a `Diagnose` request stops it.
    #[arg(long, hide = true)]
    stop_on_stdin_eof: bool,
}

/// Prints a diagnosis's progress on standard error: a line as each round's phases start, a
/// spinner over the base calibration and a bar over the candidate fits.
#[derive(Default)]
struct Printer(std::sync::Mutex<Option<indicatif::ProgressBar>>);

impl Printer {
    fn show(&self, bar: indicatif::ProgressBar, template: &str) {
        bar.set_style(indicatif::ProgressStyle::with_template(template).expect("valid template"));
        *self.0.lock().expect("not poisoned") = Some(bar);
    }

    fn clear(&self) {
        if let Some(bar) = self.0.lock().expect("not poisoned").take() {
            bar.finish_and_clear();
        }
    }
}

impl Observe for Printer {
    fn event(&self, event: Event) {
        match event {
            Event::Calibrating { round } => {
                eprintln!("round {}: calibrating the base model", round + 1);
                let bar = indicatif::ProgressBar::new_spinner();
                self.show(bar.clone(), "{spinner} {elapsed_precise} {msg}");
                bar.enable_steady_tick(std::time::Duration::from_millis(200));
            }
            Event::Progress(p) => {
                if let Some(bar) = &*self.0.lock().expect("not poisoned") {
                    bar.set_message(format!(
                        "iteration {}  evaluations {}  best f {:.6e}",
                        p.iteration, p.evaluations, p.best_f
                    ));
                }
            }
            Event::Calibrated | Event::AllFitted => self.clear(),
            Event::Screening { round } => eprintln!("round {}: screening the candidates", round + 1),
            Event::Fitting { round, top, candidates } => {
                eprintln!("round {}: fitting the {top} most promising of {candidates} candidates", round + 1);
                let bar = indicatif::ProgressBar::new(top as u64);
                self.show(bar, "{elapsed_precise} candidates fitted {pos}/{len} {msg}");
            }
            Event::Fitted => {
                if let Some(bar) = &*self.0.lock().expect("not poisoned") {
                    bar.inc(1);
                }
            }
        }
    }
}

/// One standard error of the widest parameter as a fraction of its range (the optimizers'
/// scaled step: of log(x) for a log-scaled parameter), within [1e-6, 0.05]; `None` unless
/// every calibrated value has one.
fn local_step(job: &JobSpec, standard_errors: &std::collections::BTreeMap<String, f64>) -> Option<f64> {
    let calibrated = job.calibrated();
    let steps: Option<Vec<f64>> = calibrated
        .iter()
        .map(|c| {
            let se = standard_errors.get(&c.name).copied().filter(|s| s.is_finite() && *s > 0.0)?;
            let b = c.bounds;
            let (se, range) = match c.scale {
                // d log x = dx / x.
                fmucal_shared::job::choices::Scale::Log => (se / b.start.abs(), (b.upper / b.lower).ln()),
                _ => (se, b.upper - b.lower),
            };
            (range > 0.0 && range.is_finite() && se.is_finite()).then(|| se / range)
        })
        .collect();
    let widest = steps?.into_iter().fold(0.0, f64::max);
    (widest > 0.0).then(|| widest.clamp(1e-6, 0.05))
}

/// Resolves on SIGTERM or Ctrl-C, or, with `stdin_eof`, when standard input closes; says which.
async fn stop_requested(stdin_eof: bool) -> &'static str {
    let closed = async {
        if !stdin_eof {
            return std::future::pending().await;
        }
        let (tx, rx) = tokio::sync::oneshot::channel();
        std::thread::spawn(move || {
            let _ = std::io::copy(&mut std::io::stdin(), &mut std::io::sink());
            let _ = tx.send(());
        });
        let _ = rx.await;
    };
    tokio::select! {
        () = super::servers::terminate_signal() => "interrupted",
        () = closed => "stopped by the coordinator that ran it",
    }
}

pub fn run(args: Args) -> Result<()> {
    let mut spec = JobSpec::from_toml_file(&args.job)?;
    spec.validate()?;
    let original = spec.clone();
    // The section is the diagnosis's own: read from the file's text so that a TOML error
    // quotes its line.
    spec.diagnose = None;
    let text = std::fs::read_to_string(&args.job).with_context(|| format!("cannot read {}", args.job.display()))?;
    let mut settings = DiagnoseSpec::from_job_text(&text)?;
    if let Some(top) = args.top {
        settings.top = top;
        settings.validate()?;
    }
    anyhow::ensure!(
        spec.experiments.is_empty(),
        "experiments: diagnose takes a job with one experiment; give it one of them as its own job"
    );
    let threads = super::local_cluster::worker_count(args.workers, &spec)?;
    args.remote.check()?;
    let model = super::calibrate::model_path(&spec)?;
    spec.model.path = Some(model.clone());
    let data = fmucal_shared::job::data::read_all(&spec)?.pop().context("data: the job has no data")?;
    let windows = checks::windows(&mut spec, &data, &settings)?;
    let fmu =
        Arc::new(super::known_archives::load(&model).with_context(|| format!("cannot load {}", model.display()))?);
    let ctx = Context::new(&spec, settings, windows, fmu, data, model)?;
    // Removed again if the run fails before writing anything into it.
    let _out = super::outputs::OutDir::create(&args.out)?;
    // `job.toml` in the output folder must not be the job being read (`diagnose diagnosis/job.toml`).
    let written = args.out.join("job.toml");
    if let (Ok(a), Ok(b)) = (written.canonicalize(), args.job.canonicalize())
        && a == b
    {
        bail!("--out {}: its job.toml would overwrite the job file; choose another folder", args.out.display());
    }

    let printer = Printer::default();
    let rt = tokio::runtime::Runtime::new()?;
    let outcome = rt.block_on(async {
        match args.remote.connect().await? {
            Some(client) => {
                // Stopped midway, the diagnosis cancels its jobs: they would keep the
                // coordinator's workers busy for nobody.
                tokio::select! {
                    outcome = driver::diagnose(OnCoordinator(client.clone()), &ctx, spec, &printer) => Ok(outcome?),
                    why = stop_requested(args.stop_on_stdin_eof) => {
                        let n = client.clone().cancel_submitted().await;
                        bail!("{why}; cancelled {n} running jobs")
                    }
                }
            }
            None => {
                let (outcome, stopping) =
                    super::local_cluster::run(threads, (&ctx.model, &ctx.fmu), async |client: Client| {
                        Ok(driver::diagnose(OnCoordinator(client), &ctx, spec, &printer).await?)
                    })
                    .await?;
                stopping.wait().await;
                Ok(outcome)
            }
        }
    })?;

    let report = &outcome.diagnosis;
    let json = serde_json::to_string_pretty(report)?;
    std::fs::write(args.out.join("report.json"), json + "\n")?;
    // The job that reproduces the diagnosis: the named effects added, every start at the
    // final fit, paths that hold from any folder, and a search that stays near the optimum.
    let mut kept = original.with_absolute_paths();
    kept.effects.extend(report.named.iter().map(|n| n.effect.clone()));
    let mut kept = kept.with_starts(&report.fitted);
    // A held-out window becomes the job's validation window, so that the job is judged where
    // the diagnosis was.
    if report.windows.holdout {
        kept.simulation.stop_time = Some(report.windows.calibration_stop);
        kept.simulation.validation_stop_time = Some(report.windows.validation_stop);
    }
    // A job that names no algorithm gets the one the diagnosis polished its fit with: least
    // squares from the polish's small trust radius, which confirms the optimum in a few
    // points where Nelder–Mead's simplex must shrink from its first edge down to x_tol. A job
    // that names its algorithm keeps it, with a first step of one standard error.
    if kept.optimizer.named_algorithm().is_none() {
        kept.optimizer.set_algorithm(Algorithm::LeastSquares);
        if kept.optimizer.initial_step().is_none() {
            kept.optimizer.set_initial_step(Some(polish_step(kept.optimizer.x_tol, None)));
        }
    }
    if kept.optimizer.initial_step().is_none() {
        kept.optimizer.set_initial_step(local_step(&kept, &report.standard_errors));
    }
    // The `[diagnose]` settings the diagnosis used (the job's section, and `--top`), every
    // setting spelled out (defaults included), so that the written job diagnoses alike under a
    // later version's defaults; none where the job had no section and the defaults ran.
    let section =
        (kept.diagnose.take().is_some() || ctx.settings != DiagnoseSpec::default()).then(|| ctx.settings.to_job_text());
    let mut toml = toml::to_string(&kept).context("cannot write the job with the effect")?;
    if let Some(section) = section {
        toml = format!("{toml}\n{section}");
    }
    let header = "# Written by `fmucal diagnose`: the job with the effects it named added.\n";
    std::fs::write(args.out.join("job.toml"), format!("{header}{toml}"))?;
    plots::draw(&args.out, &outcome)?;
    print!("{}", report.summary());
    eprintln!("wrote {} and {}", args.out.join("report.json").display(), args.out.join("job.toml").display());
    // The corrected model itself, whenever an effect was named: the written job at its fit.
    if !report.named.is_empty() {
        let fmu = args.out.join("corrected.fmu");
        match super::export::export(&kept, super::export::Values::Starts, None, &fmu) {
            Ok(line) => eprintln!("{line}"),
            Err(e) => eprintln!("no corrected.fmu: {e:#}"),
        }
    }
    Ok(())
}
