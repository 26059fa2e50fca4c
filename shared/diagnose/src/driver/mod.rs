//! The rounds of a diagnosis, one function per phase: calibrate the base job ([`base_fit`]);
//! localise its residual ([`localise_residual`]); size the places ([`probe::scales`]) and
//! screen the candidates in one job of points ([`screen`]); find where each of the top K
//! starts ([`starts`]); fit them concurrently, each followed by its identifiability points
//! and judged as soon as it ends ([`fit_top`]); choose and polish ([`choose_and_polish`]);
//! and, if one is named and `rounds = 2`, search again with it added.
//!
//! Every simulation-heavy step goes through an [`Evaluate`]r: the command line's gRPC client
//! (a local cluster or `--coordinator`), so that it runs on the workers. The driver's own
//! simulations (a fit's residuals, the signals: one or two each) run in this process
//! ([`look`]). Progress goes to an [`Observe`]r as [`Event`]s, as argmin's executor reports
//! to its observers; the driver prints nothing.
//!
//! - [`checks`]: everything checked before any model code runs;
//! - [`look`]: the local simulations (residuals, signals, evidence);
//! - [`probe`]: the scale of each place (a port's load, a state's rate) not given;
//! - [`in_process`]: an evaluator in this process, with no coordinator;
//! - [`fit`]: a candidate's fit to the accuracy the decision needs, Gauss–Newton and the polish;
//! - [`judge`]: the evidence about a fit, its verdict, and the named effect in words.

pub mod checks;
pub mod fit;
pub mod in_process;
pub mod judge;
pub mod look;
pub mod probe;

use std::collections::BTreeMap;
use std::future::Future;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

use fmucal_shared::fmu::Fmu;
use fmucal_shared::job::{CalibrationResult, EvaluatedPoint, JobSpec, MeasurementTable, PreparedJob};

use self::fit::{Fit, Fitted, polish};
use self::judge::{Judged, judge_fit, name};
use self::look::{Look, look, signals};
use self::probe::Probed;
use crate::candidates::{Candidate, Screened, Screening, Sizes, generate, ranking};
use crate::decision::{Baseline, Rule, choose, equally_supported};
use crate::error::{Context as _, Error};
use crate::jobs::{candidate_job, noise_ssr, same_place};
use crate::localise::{Localisation, localise};
use crate::places::Places;
use crate::report::{Conclusion, Diagnosis, PhaseTime, RankedCandidate, Round, Windows};
use crate::spec::DiagnoseSpec;
use fmucal_shared::effects::guess::SignalStats;

/// What every phase shares (cheap to clone: the model and data are shared).
#[derive(Clone)]
pub struct Context {
    /// The model, loaded in this process for the driver's own simulations.
    pub fmu: Arc<Fmu>,
    pub data: Arc<MeasurementTable>,
    /// The model's archive, as the evaluator is given it.
    pub model: PathBuf,
    pub settings: DiagnoseSpec,
    pub windows: Windows,
    /// Where candidates go: ports by hand and from the model, states in Model Exchange
    /// ([`checks::job_and_candidates`]).
    pub places: Places,
}

impl Context {
    /// The context of a diagnosis of `spec`, whose windows [`checks::windows`] has set:
    /// every candidate is checked against the model and the data first
    /// ([`checks::job_and_candidates`]).
    ///
    /// # Errors
    /// The job's own error, or one naming the `[diagnose]` field a bad candidate comes from.
    pub fn new(
        spec: &JobSpec,
        settings: DiagnoseSpec,
        windows: Windows,
        fmu: Arc<Fmu>,
        data: MeasurementTable,
        model: PathBuf,
    ) -> Result<Context, Error> {
        let places = checks::job_and_candidates(spec, &settings, &fmu, &data)?;
        Ok(Context { fmu, data: Arc::new(data), model, settings, windows, places })
    }
}

/// How far a calibration has come, after each of its rounds.
#[derive(Debug, Clone, Copy)]
pub struct Progress {
    pub iteration: u64,
    pub evaluations: u64,
    pub best_f: f64,
}

/// What runs the diagnosis's jobs: a calibration, and a job that evaluates given points.
/// Clones share one connection or pool, so that the fits run side by side.
pub trait Evaluate: Clone + Send + Sync + 'static {
    /// Calibrates `job` on `data` with the model at `model`; `progress` sees each round.
    fn calibrate(
        &mut self,
        job: &JobSpec,
        data: &MeasurementTable,
        model: &Path,
        progress: &(dyn Fn(Progress) + Send + Sync),
    ) -> impl Future<Output = Result<CalibrationResult, Error>> + Send;

    /// Evaluates `points` of `job` (in its parameter order), with their residual vectors, in
    /// the order given: a job that evaluates them ([`JobSpec::evaluating_points`]).
    fn evaluate(
        &mut self,
        job: &JobSpec,
        points: Vec<Vec<f64>>,
        data: &MeasurementTable,
        model: &Path,
    ) -> impl Future<Output = Result<Vec<EvaluatedPoint>, Error>> + Send {
        let job = job.evaluating_points(points);
        async move { Ok(self.calibrate(&job, data, model, &|_| {}).await?.evaluated) }
    }
}

/// What a diagnosis reports while it runs (rounds count from 0).
#[derive(Debug, Clone, Copy)]
pub enum Event {
    /// The round's base calibration starts.
    Calibrating { round: usize },
    /// A round of the base calibration ended.
    Progress(Progress),
    /// The base calibration ended.
    Calibrated,
    /// The candidates are sized and screened.
    Screening { round: usize },
    /// The `top` most promising of `candidates` are fitted.
    Fitting { round: usize, top: usize, candidates: usize },
    /// One of them is fitted and judged.
    Fitted,
    /// All of them are.
    AllFitted,
}

/// Sees a diagnosis's [`Event`]s.
pub trait Observe: Sync {
    fn event(&self, event: Event);
}

/// Sees nothing.
impl Observe for () {
    fn event(&self, _: Event) {}
}

/// What the plots need besides the report: the residuals before and after.
pub struct Outcome {
    pub diagnosis: Diagnosis,
    pub before: Look,
    pub after: Look,
    /// The signals of the first round, on its calibration window.
    pub signals: Vec<(String, Vec<f64>)>,
}

/// Wall time and simulations per phase, summed over the rounds.
#[derive(Default)]
struct Phases(BTreeMap<String, PhaseTime>);

impl Phases {
    /// Adds the time since `since` and `simulations` to `phase`.
    fn add(&mut self, phase: &str, since: Instant, simulations: u64) {
        let seconds = since.elapsed().as_secs_f64();
        tracing::debug!("diagnose phase {phase}: {seconds:.3} s, {simulations} simulations");
        let p = self.0.entry(phase.to_owned()).or_default();
        p.seconds += seconds;
        p.simulations += simulations;
    }
}

/// The base of a round: its calibration, and its fit at the optimum.
pub struct Base {
    pub result: CalibrationResult,
    pub prepared: Arc<PreparedJob>,
    /// The optimum in the job's parameter order.
    pub x: Vec<f64>,
    pub look: Look,
    pub baseline: Baseline,
}

/// The candidates of a round, screened at the base optimum.
pub struct Screen {
    pub candidates: Vec<Candidate>,
    pub screening: Screening,
    pub screened: Vec<Screened>,
    /// The candidates from best to worst.
    pub order: Vec<usize>,
    /// Those worth a fit, at most `top`: the ones predicted to improve the information
    /// criterion (a failed screening ranks last and is not fitted).
    pub top: Vec<usize>,
    /// The SSR of the noise alone: no candidate fit ends much below it.
    pub noise: f64,
}

/// Where a candidate's fit starts.
pub struct Start {
    pub ssr: f64,
    /// The base's values.
    pub base: Vec<f64>,
    /// The effect's values.
    pub effect: Vec<f64>,
}

/// Diagnoses `base` on `eval`'s workers; `observer` sees its progress.
///
/// # Errors
/// The first step that fails: the base calibration, a probe, the screening (a candidate fit
/// that fails is reported as such instead).
pub async fn diagnose(
    eval: impl Evaluate,
    ctx: &Context,
    mut base: JobSpec,
    observer: &dyn Observe,
) -> Result<Outcome, Error> {
    let mut eval = eval;
    let started = Instant::now();
    let rule = Rule { min_validation_gain: ctx.settings.min_validation_gain, confidence: ctx.settings.confidence };
    let mut rounds = vec![];
    let mut named = vec![];
    let mut base_calibration_s = 0.0;
    let mut first_look: Option<Look> = None;
    let mut last_look: Option<Look> = None;
    let mut first_signals = vec![];
    let mut phases = Phases::default();
    let mut notes = ctx.places.notes.clone();
    let mut partial = vec![];
    let mut partial_look: Option<Look> = None;
    // The values of the model the diagnosis ends with (the base, or the base with the named
    // effects), with their standard errors.
    let (mut fitted, mut standard_errors) = (BTreeMap::new(), BTreeMap::new());
    for round in 0..ctx.settings.rounds {
        observer.event(Event::Calibrating { round });
        let t = Instant::now();
        let fit = base_fit(&mut eval, ctx, &base, observer).await?;
        if round == 0 {
            base_calibration_s = t.elapsed().as_secs_f64();
            fitted = fit.result.x_opt.clone();
            standard_errors = fit
                .result
                .identifiability
                .as_ref()
                .map(|id| id.names.iter().cloned().zip(id.standard_errors.iter().copied()).collect())
                .unwrap_or_default();
        }
        phases.add("base", t, fit.result.evaluations);
        let t = Instant::now();
        let (localisation, signal_values) = localise_residual(ctx, &base, &fit)?;
        phases.add("look", t, 2);

        observer.event(Event::Screening { round });
        let t = Instant::now();
        let probed = probe::scales(&mut eval, ctx, &ctx.places, &base, &fit.x).await?;
        phases.add("probe", t, probed.simulations);
        for note in &probed.notes {
            if !notes.contains(note) {
                notes.push(note.clone());
            }
        }
        let t = Instant::now();
        let screen = screen(&mut eval, ctx, &base, &fit, &signal_values, &probed).await?;
        phases.add("screen", t, screen.screening.points.len() as u64);

        let t = Instant::now();
        let (starts, simulations) = starts(&mut eval, ctx, &screen, &fit).await?;
        phases.add("starts", t, simulations);

        let t = Instant::now();
        observer.event(Event::Fitting { round, top: screen.top.len(), candidates: screen.candidates.len() });
        let (mut fits, simulations) = fit_top(&eval, ctx, &base, &screen, &starts, &fit, &rule, observer).await?;
        observer.event(Event::AllFitted);
        phases.add("fits", t, simulations + fits.len() as u64);

        let t = Instant::now();
        let (chosen, equally, simulations) =
            choose_and_polish(&mut eval, ctx, &screen, &mut fits, &fit.baseline, &rule).await;
        phases.add("polish", t, simulations);
        let ranked: Vec<RankedCandidate> = screen
            .order
            .iter()
            .map(|&c| RankedCandidate {
                description: screen.candidates[c].describe(),
                candidate: screen.candidates[c].clone(),
                screening: screen.screened[c].clone(),
                fit: fits.get(&c).map(|f| f.fit.clone()),
            })
            .collect();
        rounds.push(Round {
            base_x_opt: fit.result.x_opt.clone(),
            baseline: fit.baseline,
            localisation,
            port_scales: probed.port_scales,
            state_scales: probed.state_scales,
            candidates: ranked,
            chosen,
            equally_supported: equally,
        });
        if first_look.is_none() {
            first_look = Some(fit.look);
            first_signals = signal_values;
        } else {
            last_look = Some(fit.look);
        }
        let Some(rank) = chosen else { break };
        let c = screen.order[rank];
        let Judged { fit, job, look: after } = fits.remove(&c).expect("the chosen candidate was fitted");
        let effect = name(ctx, &screen.candidates[c], &fit, &job);
        // In the last round, an effect that leaves the model far from its noise is not the
        // missing effect, only a part of what is missing: it is reported as such and not
        // named. (An earlier round keeps it and looks for the rest.)
        let last_round = round + 1 == ctx.settings.rounds;
        if last_round && after.as_ref().is_none_or(|a| a.misfit(ctx.windows.calibration_stop).far()) {
            partial.push(effect);
            partial_look = after;
            break;
        }
        // With fix_base the fit holds only the effect's values: the base's stay.
        fitted.extend(fit.x_opt.clone());
        standard_errors.extend(fit.standard_errors.clone());
        last_look = after;
        // The next round's base: this round's job (its own optimizer settings and parameters)
        // with the named effect, every start at the fitted value.
        base.effects.push(effect.effect.clone());
        base = base.with_starts(&fit.x_opt);
        named.push(effect);
    }
    let before = first_look.context("no round ran")?;
    let after = last_look.unwrap_or_else(|| before.clone());
    let stop = ctx.windows.calibration_stop;
    let misfit_before = before.misfit(stop);
    let misfit_after = after.misfit(stop);
    let misfit_partial = partial_look.as_ref().map(|l| l.misfit(stop));
    let conclusion = Conclusion::of(!named.is_empty(), !partial.is_empty(), &misfit_before);
    let diagnosis = Diagnosis {
        partial,
        misfit_partial,
        fitted,
        standard_errors,
        conclusion,
        misfit_before,
        misfit_after,
        windows: ctx.windows,
        rounds,
        named,
        before: before.rms,
        after: after.rms,
        base_calibration_s,
        elapsed_s: started.elapsed().as_secs_f64(),
        phases: phases.0,
        notes,
    };
    Ok(Outcome { diagnosis, before, after, signals: first_signals })
}

/// The round's base calibration on the workers, and its fit at the optimum in this process.
pub async fn base_fit(
    eval: &mut impl Evaluate,
    ctx: &Context,
    base: &JobSpec,
    observer: &dyn Observe,
) -> Result<Base, Error> {
    let progress = |p: Progress| observer.event(Event::Progress(p));
    let result = eval.calibrate(base, &ctx.data, &ctx.model, &progress).await;
    observer.event(Event::Calibrated);
    let result = result.context("the base calibration")?;
    let prepared = Arc::new(prepare(ctx, base)?);
    let x = result.x_opt_in(&prepared.parameter_names);
    let look = look(ctx, &prepared, &x)?;
    let baseline = Baseline {
        ssr: result.f_opt,
        n_eff: look.n_eff,
        validation_rms: look.rms.validation,
        validation_n_eff: look.validation_n_eff,
    };
    Ok(Base { result, prepared, x, look, baseline })
}

/// The base's residual against every signal the diagnosis may read, and those signals.
pub fn localise_residual(
    ctx: &Context,
    base: &JobSpec,
    fit: &Base,
) -> Result<(Localisation, Vec<(String, Vec<f64>)>), Error> {
    let mut names: Vec<String> =
        ctx.places.ports.iter().flat_map(|p| p.spec.signals().map(|(_, s)| s.to_owned())).collect();
    names.extend(ctx.places.states.iter().flat_map(|s| std::iter::once(s.state.clone()).chain(s.position.clone())));
    names.extend(ctx.settings.signals.iter().cloned());
    names.extend(base.inputs.iter().map(|i| i.variable.clone()));
    names.extend(base.outputs.iter().map(|o| o.variable.clone()));
    let mut seen = std::collections::HashSet::new();
    names.retain(|n| seen.insert(n.clone()));
    let signal_values = signals(ctx, &fit.prepared, &fit.x, &names)?;
    let localisation = localise(&fit.look.time, &fit.look.residuals, &signal_values, ctx.settings.windows);
    Ok((localisation, signal_values))
}

/// Every candidate at the places, sized by the probe and the signals, screened in one job of
/// points at the base optimum.
pub async fn screen(
    eval: &mut impl Evaluate,
    ctx: &Context,
    base: &JobSpec,
    fit: &Base,
    signal_values: &[(String, Vec<f64>)],
    probed: &Probed,
) -> Result<Screen, Error> {
    let sizes = sizes(ctx, base, &fit.look, signal_values, probed);
    let candidates: Vec<Candidate> = generate(base, &ctx.settings, &ctx.places, &sizes)
        .into_iter()
        .filter(|c| !base.effects.iter().any(|e| same_place(e, &c.effect)))
        .collect();
    let screening = Screening::new(base, &fit.x, &candidates, ctx.settings.fix_base);
    let evaluated = eval.evaluate(&screening.job, screening.points.clone(), &ctx.data, &ctx.model).await?;
    let residuals: Vec<Option<Vec<f64>>> = evaluated.iter().map(|e| e.value.map(|_| e.residuals.clone())).collect();
    let screened = screening.statistics(&residuals, fit.look.n_eff);
    let noise = residuals.first().cloned().flatten().map_or(0.0, |r| noise_ssr(&r));
    let order = ranking(&screened);
    let top: Vec<usize> =
        order.iter().copied().filter(|&c| screened[c].predicted_delta_ic < 0.0).take(ctx.settings.top).collect();
    Ok(Screen { candidates, screening, screened, order, top, noise })
}

/// Where each fit of the top K starts: the best of the base optimum and the full and half
/// Gauss–Newton steps of the screening (the linear prediction can overshoot when the effect
/// trades off against a base parameter), evaluated as one batch. Also returns the simulations.
pub async fn starts(
    eval: &mut impl Evaluate,
    ctx: &Context,
    screen: &Screen,
    fit: &Base,
) -> Result<(Vec<Start>, u64), Error> {
    let Screen { screening, screened, top, candidates, .. } = screen;
    let steps: Vec<Vec<f64>> =
        top.iter().flat_map(|&c| [1.0, 0.5].map(|f| screening.along_step(c, &screened[c], f))).collect();
    let tried = if steps.is_empty() {
        vec![]
    } else {
        eval.evaluate(&screening.job, steps.clone(), &ctx.data, &ctx.model).await?
    };
    let starts = top
        .iter()
        .enumerate()
        .map(|(slot, &c)| {
            let neutral: Vec<f64> = candidates[c].guesses.iter().map(|g| g.neutral).collect();
            let mut best = Start { ssr: fit.result.f_opt, base: fit.x.clone(), effect: neutral };
            for k in [2 * slot, 2 * slot + 1] {
                if let Some(v) = tried.get(k).and_then(|e| e.value)
                    && v < best.ssr
                {
                    let (b, e) = screening.split(c, &steps[k]);
                    best = Start { ssr: v, base: b, effect: e };
                }
            }
            best
        })
        .collect();
    Ok((starts, steps.len() as u64))
}

/// Fits the top K concurrently on the workers, each judged as soon as it is fitted (a local
/// simulation) while the others still run; returns the judged fits by candidate, and the
/// simulations of the fits.
#[allow(clippy::too_many_arguments)]
pub async fn fit_top(
    eval: &impl Evaluate,
    ctx: &Context,
    base: &JobSpec,
    screen: &Screen,
    starts: &[Start],
    fit: &Base,
    rule: &Rule,
    observer: &dyn Observe,
) -> Result<(BTreeMap<usize, Judged>, u64), Error> {
    let mut tasks = tokio::task::JoinSet::new();
    let shared = Arc::new(ctx.clone());
    // One judging at a time: each instantiates the FMU in this process, which some FMUs
    // allow only once at a time (canBeInstantiatedOnlyOncePerProcess).
    let one_at_a_time = Arc::new(tokio::sync::Semaphore::new(1));
    let (baseline, rule) = (fit.baseline, *rule);
    for (slot, &c) in screen.top.iter().enumerate() {
        let narrowed = screen.candidates[c].narrowed(&screen.screened[c].estimate);
        let start = &starts[slot];
        let (start_ssr, n_eff) = (start.ssr.min(screen.noise.max(0.0)).max(f64::MIN_POSITIVE), baseline.n_eff);
        let from: BTreeMap<String, f64> =
            fit.prepared.parameter_names.iter().cloned().zip(start.base.iter().copied()).collect();
        let mut job = candidate_job(base, &from, &narrowed, &start.effect, ctx.settings.fix_base);
        // A candidate that does not help can leave the optimizer wandering on a flat
        // objective: bound its work by the base fit's.
        job.optimizer.max_fevals = job.optimizer.max_fevals.or(Some((5 * fit.result.evaluations).max(500)));
        let (mut eval, ctx, one_at_a_time) = (eval.clone(), shared.clone(), one_at_a_time.clone());
        tasks.spawn(async move {
            let t = Instant::now();
            let prepared =
                PreparedJob::new(&job, &ctx.fmu.description, &ctx.fmu.interfaces(), std::slice::from_ref(&ctx.data));
            let mut simulations = 0;
            let result = match prepared {
                Ok(prepared) => {
                    let fit = Fit { eval: &mut eval, job: &prepared, data: &ctx.data, model: &ctx.model };
                    fit.for_decision(start_ssr, n_eff, &mut simulations).await
                }
                Err(e) => Err(e.into()),
            };
            tracing::debug!("candidate {slot}: {:.3} s, {simulations} simulations", t.elapsed().as_secs_f64());
            let fitted = Fitted { job, result, elapsed: t.elapsed(), simulations };
            let judge_started = Instant::now();
            let turn = one_at_a_time.acquire_owned().await.expect("the semaphore is never closed");
            let judged = tokio::task::spawn_blocking(move || {
                let _turn = turn;
                judge_fit(&ctx, &baseline, &rule, &narrowed, fitted)
            })
            .await;
            (slot, simulations, judged, judge_started.elapsed())
        });
    }
    let mut fits = BTreeMap::new();
    let (mut simulations, mut judging) = (0, Duration::ZERO);
    while let Some(done) = tasks.join_next().await {
        let (slot, fit_simulations, judged, judge_time) =
            done.map_err(|e| Error::msg(format!("a candidate fit panicked: {e}")))?;
        fits.insert(
            screen.top[slot],
            judged.map_err(|e| Error::msg(format!("judging a candidate fit panicked: {e}")))?,
        );
        observer.event(Event::Fitted);
        simulations += fit_simulations;
        judging += judge_time;
    }
    // The judging (one local simulation per fit) overlaps the fits; its own sum is kept.
    tracing::debug!("candidates judged in {:.3} s in all, beside the fits", judging.as_secs_f64());
    Ok((fits, simulations))
}

/// The fits stopped once their SSR was known well enough to decide. The chosen one is
/// polished from its optimum to the job's own tolerances ([`polish`]), so that its values
/// (and the starts of `job.toml`) are as precise as a calibration's, and judged again; should
/// that change the choice, the new choice is polished too. Returns the choice (a rank in the
/// screening's order), the ranks equally supported, and the polish's simulations.
pub async fn choose_and_polish(
    eval: &mut impl Evaluate,
    ctx: &Context,
    screen: &Screen,
    fits: &mut BTreeMap<usize, Judged>,
    baseline: &Baseline,
    rule: &Rule,
) -> (Option<usize>, Vec<usize>, u64) {
    let mut polished = std::collections::BTreeSet::new();
    let mut simulations = 0;
    let (verdicts, chosen) = loop {
        let verdicts: Vec<Option<_>> =
            screen.order.iter().map(|c| fits.get(c).and_then(|f| f.fit.verdict.clone())).collect();
        let chosen = choose(&verdicts);
        let Some(c) = chosen.map(|rank| screen.order[rank]) else { break (verdicts, chosen) };
        if !polished.insert(c) {
            break (verdicts, chosen);
        }
        let judged = &fits[&c];
        match polish(eval, ctx, &judged.job, &judged.fit, baseline.n_eff).await {
            Ok(f) => {
                simulations += f.simulations;
                let narrowed = screen.candidates[c].narrowed(&screen.screened[c].estimate);
                let judged = judge_fit(ctx, baseline, rule, &narrowed, f);
                if judged.fit.verdict.is_some() {
                    fits.insert(c, judged);
                }
            }
            Err(e) => tracing::warn!("polishing candidate {c}: {}", e.one_line()),
        }
    };
    let equally = chosen.map(|c| equally_supported(&verdicts, c)).unwrap_or_default();
    (chosen, equally, simulations)
}

pub(crate) fn prepare(ctx: &Context, job: &JobSpec) -> Result<PreparedJob, Error> {
    Ok(PreparedJob::new(job, &ctx.fmu.description, &ctx.fmu.interfaces(), std::slice::from_ref(&ctx.data))?)
}

/// The sizes the candidates are guessed from: the ports' scales, the simulated signals, and the
/// measured outputs and inputs on the calibration window.
fn sizes(ctx: &Context, base: &JobSpec, before: &Look, signal_values: &[(String, Vec<f64>)], probed: &Probed) -> Sizes {
    let signals = signal_values.iter().map(|(n, v)| (n.clone(), SignalStats::of(v))).collect();
    let rows = before.time.len();
    let mut series: BTreeMap<String, SignalStats> =
        before.fit.outputs.iter().map(|o| (o.variable.clone(), SignalStats::of(&o.measured[..rows]))).collect();
    let (t0, t1) = (ctx.windows.start_time, ctx.windows.calibration_stop);
    for i in &base.inputs {
        if let Some(column) = ctx.data.column(&i.column) {
            let v: Vec<f64> =
                ctx.data.time.iter().zip(column).filter(|(t, _)| **t >= t0 && **t <= t1).map(|(_, v)| *v).collect();
            series.insert(i.variable.clone(), SignalStats::of(&v));
        }
    }
    let duration = t1 - t0;
    let sample = if rows > 1 { duration / (rows - 1) as f64 } else { duration };
    Sizes {
        port_scales: probed.port_scales.clone(),
        state_scales: probed.state_scales.clone(),
        signals,
        series,
        duration,
        sample,
    }
}
