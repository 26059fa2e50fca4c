//! The rounds of a diagnosis, over the coordinator's protocol so every simulation-heavy step
//! runs on the workers: calibrate the base job; localise its residual; size and screen the
//! candidates (one job that evaluates points); fit the top K as K calibration jobs submitted
//! concurrently, each followed by its identifiability points and judged as soon as it ends;
//! choose and polish; and, if one is named and `rounds = 2`, search again with it added.

use std::collections::BTreeMap;
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{Context as _, Result};
use fmucal_diagnose::candidates::{Candidate, Screening, Sizes, generate, ranking};
use fmucal_diagnose::decision::{Baseline, Evidence, ParameterEvidence, Rule, choose, equally_supported, judge};
use fmucal_diagnose::jobs::{
    candidate_job, decision_f_tol, decision_optimizer, gauss_newton, noise_ssr, polish_step, same_place, stopped_early,
};
use fmucal_diagnose::localise::localise;
use fmucal_diagnose::report::{
    CandidateFit, Conclusion, Diagnosis, NamedEffect, PhaseTime, RankedCandidate, Round, value_with_interval,
};
use fmucal_shared::effects;
use fmucal_shared::effects::guess::SignalStats;
use fmucal_shared::job::choices::Algorithm;
use fmucal_shared::job::identifiability::{self, Identifiability};
use fmucal_shared::job::{CalibrationResult, JobSpec, MeasurementTable, PreparedJob};
use fmucal_shared::structure::derivative_unit;

use super::Context;
use super::look::{Look, look, signals};
use super::probe::{Probed, scales};
use crate::cli::client::Client;

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

/// A fitted candidate as it comes back from the workers.
struct Fitted {
    job: JobSpec,
    result: Result<(CalibrationResult, Result<Identifiability>)>,
    elapsed: Duration,
    /// Simulations of the fit and of its identifiability points.
    simulations: u64,
}

pub async fn diagnose(mut client: Client, ctx: &Context, mut base: JobSpec) -> Result<Outcome> {
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
        eprintln!("round {}: calibrating the base model", round + 1);
        let t = Instant::now();
        let result = client
            .calibrate(&base, std::slice::from_ref(&*ctx.data), &ctx.model)
            .await
            .context("the base calibration")?;
        if round == 0 {
            base_calibration_s = t.elapsed().as_secs_f64();
            fitted = result.x_opt.clone();
            standard_errors = result
                .identifiability
                .as_ref()
                .map(|id| id.names.iter().cloned().zip(id.standard_errors.iter().copied()).collect())
                .unwrap_or_default();
        }
        phases.add("base", t, result.evaluations);
        let t = Instant::now();
        let prepared = Arc::new(prepare(ctx, &base)?);
        let x_base = result.x_opt_in(&prepared.parameter_names);
        let before = look(ctx, &prepared, &x_base)?;
        let baseline = Baseline {
            ssr: result.f_opt,
            n_eff: before.n_eff,
            validation_rms: before.rms.validation,
            validation_n_eff: before.validation_n_eff,
        };

        // Localise: the residual against every signal the diagnosis may read.
        let mut names: Vec<String> =
            ctx.places.ports.iter().flat_map(|p| p.spec.signals().map(|(_, s)| s.to_owned())).collect();
        names.extend(ctx.places.states.iter().flat_map(|s| std::iter::once(s.state.clone()).chain(s.position.clone())));
        names.extend(ctx.settings.signals.iter().cloned());
        names.extend(base.inputs.iter().map(|i| i.variable.clone()));
        names.extend(base.outputs.iter().map(|o| o.variable.clone()));
        let mut seen = std::collections::HashSet::new();
        names.retain(|n| seen.insert(n.clone()));
        let signal_values = signals(ctx, &prepared, &x_base, &names)?;
        let localisation = localise(&before.time, &before.residuals, &signal_values, ctx.settings.windows);
        phases.add("look", t, 2);

        // Size and screen every candidate.
        eprintln!("round {}: screening the candidates", round + 1);
        let t = Instant::now();
        let probed = scales(&mut client, ctx, &ctx.places, &base, &x_base).await?;
        phases.add("probe", t, probed.simulations);
        for note in &probed.notes {
            if !notes.contains(note) {
                notes.push(note.clone());
            }
        }
        let t = Instant::now();
        let sizes = sizes(ctx, &base, &before, &signal_values, &probed);
        let candidates: Vec<Candidate> = generate(&base, &ctx.settings, &ctx.places, &sizes)
            .into_iter()
            .filter(|c| !base.effects.iter().any(|e| same_place(e, &c.effect)))
            .collect();
        let screening = Screening::new(&base, &x_base, &candidates, ctx.settings.fix_base);
        let evaluated = client
            .evaluate(&screening.job, screening.points.clone(), std::slice::from_ref(&*ctx.data), &ctx.model)
            .await?;
        phases.add("screen", t, screening.points.len() as u64);
        let residuals: Vec<Option<Vec<f64>>> = evaluated.iter().map(|e| e.value.map(|_| e.residuals.clone())).collect();
        let screened = screening.statistics(&residuals, before.n_eff);
        // No candidate fit ends much below the noise: the fits' tolerances start from it.
        let noise = residuals.first().cloned().flatten().map_or(0.0, |r| noise_ssr(&r));
        let order = ranking(&screened);
        // Only candidates the screening predicts to improve the information criterion are
        // worth a fit; a failed screening ranks last and is not fitted.
        let top: Vec<usize> =
            order.iter().copied().filter(|&c| screened[c].predicted_delta_ic < 0.0).take(ctx.settings.top).collect();

        // Where each fit starts: the best of the base optimum and the full and half Gauss–Newton
        // steps (the linear prediction can overshoot when the effect trades off against a base
        // parameter), evaluated as one batch.
        let t = Instant::now();
        let steps: Vec<Vec<f64>> =
            top.iter().flat_map(|&c| [1.0, 0.5].map(|f| screening.along_step(c, &screened[c], f))).collect();
        let tried = if steps.is_empty() {
            vec![]
        } else {
            client.evaluate(&screening.job, steps.clone(), std::slice::from_ref(&*ctx.data), &ctx.model).await?
        };
        let starts: Vec<(f64, Vec<f64>, Vec<f64>)> = top
            .iter()
            .enumerate()
            .map(|(slot, &c)| {
                let neutral: Vec<f64> = candidates[c].guesses.iter().map(|g| g.neutral).collect();
                let mut best = (result.f_opt, x_base.clone(), neutral);
                for k in [2 * slot, 2 * slot + 1] {
                    if let Some(v) = tried.get(k).and_then(|e| e.value)
                        && v < best.0
                    {
                        let (b, e) = screening.split(c, &steps[k]);
                        best = (v, b, e);
                    }
                }
                best
            })
            .collect();
        phases.add("starts", t, steps.len() as u64);

        // Fit the top K concurrently on the workers.
        let t = Instant::now();
        eprintln!("round {}: fitting the {} most promising of {} candidates", round + 1, top.len(), candidates.len());
        let bar = indicatif::ProgressBar::new(top.len() as u64);
        bar.set_style(
            indicatif::ProgressStyle::with_template("{elapsed_precise} candidates fitted {pos}/{len} {msg}")
                .expect("valid template"),
        );
        let mut tasks = tokio::task::JoinSet::new();
        let shared = Arc::new(ctx.clone());
        // One judging at a time: each instantiates the FMU in this process, which some FMUs
        // allow only once at a time (canBeInstantiatedOnlyOncePerProcess).
        let one_at_a_time = Arc::new(tokio::sync::Semaphore::new(1));
        for (slot, &c) in top.iter().enumerate() {
            let narrowed = candidates[c].narrowed(&screened[c].estimate);
            let (start_ssr, from, effect_start) = &starts[slot];
            let (start_ssr, n_eff) = (start_ssr.min(noise.max(0.0)).max(f64::MIN_POSITIVE), baseline.n_eff);
            let starts: BTreeMap<String, f64> =
                prepared.parameter_names.iter().cloned().zip(from.iter().copied()).collect();
            let mut job = candidate_job(&base, &starts, &narrowed, effect_start, ctx.settings.fix_base);
            // A candidate that does not help can leave the optimizer wandering on a flat
            // objective: bound its work by the base fit's.
            job.optimizer.max_fevals = job.optimizer.max_fevals.or(Some((5 * result.evaluations).max(500)));
            let (mut client, data, model, fmu) = (client.clone(), ctx.data.clone(), ctx.model.clone(), ctx.fmu.clone());
            let (ctx, one_at_a_time) = (shared.clone(), one_at_a_time.clone());
            tasks.spawn(async move {
                let t = Instant::now();
                let prepared = PreparedJob::new(&job, &fmu.description, &fmu.interfaces(), std::slice::from_ref(&data));
                let mut simulations = 0;
                let result = match prepared {
                    Ok(prepared) => {
                        let fit = Fit { client: &mut client, job: &prepared, data: &data, model: &model };
                        fit.for_decision(start_ssr, n_eff, &mut simulations).await
                    }
                    Err(e) => Err(e.into()),
                };
                tracing::debug!("candidate {slot}: {:.3} s, {simulations} simulations", t.elapsed().as_secs_f64());
                let fitted = Fitted { job, result, elapsed: t.elapsed(), simulations };
                // Judged as soon as it is fitted (a local simulation), while the other fits
                // still run on the workers.
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
        let mut fits: BTreeMap<usize, (CandidateFit, JobSpec, Option<Look>)> = BTreeMap::new();
        let (mut simulations, mut judging) = (0, Duration::ZERO);
        while let Some(done) = tasks.join_next().await {
            let (slot, fit_simulations, judged, judge_time) = done.context("a candidate fit panicked")?;
            fits.insert(top[slot], judged.context("judging a candidate fit panicked")?);
            bar.inc(1);
            simulations += fit_simulations;
            judging += judge_time;
        }
        bar.finish_and_clear();
        // The judging (one local simulation per fit) overlaps the fits; its own sum is kept.
        tracing::debug!("candidates judged in {:.3} s in all, beside the fits", judging.as_secs_f64());
        phases.add("fits", t, simulations + fits.len() as u64);

        // The fits stopped once their SSR was known well enough to decide. The chosen one is
        // polished from its optimum to the job's own tolerances ([`polish`]), so that its
        // values (and the starts of `job.toml`) are as precise as a calibration's, and judged
        // again; should that change the choice, the new choice is polished too.
        let t = Instant::now();
        let mut polished = std::collections::BTreeSet::new();
        let mut polish_simulations = 0;
        let (verdicts, chosen) = loop {
            let verdicts: Vec<Option<_>> =
                order.iter().map(|c| fits.get(c).and_then(|f| f.0.verdict.clone())).collect();
            let chosen = choose(&verdicts);
            let Some(c) = chosen.map(|rank| order[rank]) else { break (verdicts, chosen) };
            if !polished.insert(c) {
                break (verdicts, chosen);
            }
            let (fit, job, _) = &fits[&c];
            match polish(&mut client, ctx, job, fit, baseline.n_eff).await {
                Ok(f) => {
                    polish_simulations += f.simulations;
                    let narrowed = candidates[c].narrowed(&screened[c].estimate);
                    let judged = judge_fit(ctx, &baseline, &rule, &narrowed, f);
                    if judged.0.verdict.is_some() {
                        fits.insert(c, judged);
                    }
                }
                Err(e) => tracing::warn!("polishing candidate {c}: {e:#}"),
            }
        };
        phases.add("polish", t, polish_simulations);
        let equally = chosen.map(|c| equally_supported(&verdicts, c)).unwrap_or_default();
        let ranked: Vec<RankedCandidate> = order
            .iter()
            .map(|&c| RankedCandidate {
                description: candidates[c].describe(),
                candidate: candidates[c].clone(),
                screening: screened[c].clone(),
                fit: fits.get(&c).map(|f| f.0.clone()),
            })
            .collect();
        rounds.push(Round {
            base_x_opt: result.x_opt.clone(),
            baseline,
            localisation,
            port_scales: probed.port_scales,
            state_scales: probed.state_scales,
            candidates: ranked,
            chosen,
            equally_supported: equally,
        });
        if first_look.is_none() {
            first_look = Some(before);
            first_signals = signal_values;
        } else {
            last_look = Some(before);
        }
        let Some(rank) = chosen else { break };
        let c = order[rank];
        let (fit, job, after) = fits.remove(&c).expect("the chosen candidate was fitted");
        let effect = name(ctx, &candidates[c], &fit, &job);
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

/// A calibration job on the workers, with what its identifiability points need.
struct Fit<'a> {
    client: &'a mut Client,
    job: &'a PreparedJob,
    data: &'a MeasurementTable,
    model: &'a std::path::Path,
}

impl Fit<'_> {
    /// The fit of a candidate to the accuracy the decision needs ([`decision_optimizer`] at
    /// `ssr`, the lower of the start's SSR and the noise's), then its identifiability from the
    /// difference points at its optimum. Those also say what a Gauss–Newton step would still
    /// gain ([`gauss_newton`]): more than [`stopped_early`] allows means the fit stopped on
    /// a slope, and Gauss–Newton steps go on ([`Fit::gauss_newton`]). The result counts the
    /// evaluations of the fit and `simulations` adds the difference points.
    async fn for_decision(
        mut self,
        ssr: f64,
        n_eff: f64,
        simulations: &mut u64,
    ) -> Result<(CalibrationResult, Result<Identifiability>)> {
        let (optimizer, f_tol) = decision_optimizer(&self.job.spec.optimizer, ssr, n_eff);
        let mut job = self.job.spec.clone();
        job.optimizer = optimizer;
        let mut result = self.client.calibrate_with(&job, std::slice::from_ref(self.data), self.model, |_| {}).await?;
        *simulations += result.evaluations;
        let x = result.x_opt_in(&self.job.parameter_names);
        let done = |ssr: f64, gain: f64| !stopped_early(gain, f_tol, ssr, n_eff);
        let (refined, id) = self.gauss_newton(x, done, simulations).await?;
        if let Some((ssr, x, _)) = refined.filter(|(ssr, ..)| *ssr < result.f_opt) {
            result.f_opt = ssr;
            result.x_opt = self.job.parameter_names.iter().cloned().zip(x).collect();
        }
        Ok((result, id))
    }

    /// Gauss–Newton from `x`: each iteration is one job that evaluates the difference points
    /// at the current point (2n + 1 simulations side by side on the workers), which give its
    /// SSR, its identifiability and the next step ([`gauss_newton`]). It stops when
    /// `done(ssr, predicted gain)`, when a step does not lower the SSR (the point before it is
    /// kept) or lowers it by less than a quarter of its predicted gain, or after
    /// [`GAUSS_NEWTON_ITERATIONS`]. Returns the last point kept, its SSR and
    /// what a step from it was predicted to gain (`None` if the points at `x` failed), and its
    /// identifiability.
    async fn gauss_newton(
        &mut self,
        mut x: Vec<f64>,
        done: impl Fn(f64, f64) -> bool,
        simulations: &mut u64,
    ) -> Result<(Option<(f64, Vec<f64>, f64)>, Result<Identifiability>)> {
        let (_, _, lower, upper) = self.job.spec.parameter_vectors();
        let mut best: Option<(f64, Vec<f64>, identifiability::DifferencePlan, Vec<Vec<f64>>, f64)> = None;
        let mut failed = None;
        for iteration in 0..GAUSS_NEWTON_ITERATIONS {
            let plan = identifiability::difference_points(self.job, &x);
            *simulations += plan.points.len() as u64;
            let evaluated = self
                .client
                .evaluate(&self.job.spec, plan.points.clone(), std::slice::from_ref(self.data), self.model)
                .await?;
            let residuals = match identifiability::residuals_of(&evaluated) {
                Ok(r) => r,
                Err(e) => {
                    failed = Some(anyhow::Error::from(e));
                    break;
                }
            };
            let ssr: f64 = residuals[0].iter().map(|r| r * r).sum();
            if best.as_ref().is_some_and(|b| ssr >= b.0) {
                break;
            }
            // A step that realised less than a quarter of its predicted gain: the linear model
            // does not hold here, and further steps would not either.
            let poor = best.as_ref().is_some_and(|b| b.0 - ssr < 0.25 * b.4);
            let next = gauss_newton(&plan, &residuals, &lower, &upper);
            tracing::debug!(
                "Gauss–Newton {iteration}: SSR {ssr:.6e}, a step would gain {:.2e}",
                next.as_ref().map_or(f64::NAN, |n| n.1)
            );
            best = Some((ssr, x.clone(), plan, residuals, next.as_ref().map_or(f64::NAN, |n| n.1)));
            match next {
                Some((next, gain)) if !poor && !done(ssr, gain) => x = next,
                _ => break,
            }
        }
        Ok(match best {
            Some((ssr, x, plan, residuals, gain)) => {
                let id = identifiability::from_residuals(&self.job.parameter_names, &plan, &residuals);
                (Some((ssr, x, gain)), id.map_err(anyhow::Error::from))
            }
            None => (None, Err(failed.unwrap_or_else(|| anyhow::anyhow!("no difference point was evaluated")))),
        })
    }
}

/// Gauss–Newton iterations after a fit, at most.
const GAUSS_NEWTON_ITERATIONS: usize = 4;

/// The chosen candidate's fit, polished from its optimum to the job's own tolerances, so that
/// its values (and the starts of `job.toml`) are as precise as a calibration's: Gauss–Newton
/// ([`Fit::gauss_newton`], each step 2n + 1 simulations side by side) until a step is predicted
/// to gain less than the job's f_tol. Where the model is too nonlinear for that (the last
/// step's predicted gain is still above the decision's accuracy, [`decision_f_tol`] at
/// `n_eff`), the least-squares solver goes on from there with the job's own x_tol, from a
/// small trust region ([`polish_step`]; its interpolation model follows the curvature the
/// difference steps miss). Evaluations and wall time include the decision's
/// fit; `simulations` only the polish's.
async fn polish(client: &mut Client, ctx: &Context, job: &JobSpec, fit: &CandidateFit, n_eff: f64) -> Result<Fitted> {
    let t = Instant::now();
    let prepared = prepare(ctx, job)?;
    let names = prepared.parameter_names.clone();
    let f_tol = job.optimizer.f_tol.filter(|t| *t > 0.0).unwrap_or(1e-8);
    let x: Vec<f64> = names.iter().map(|n| fit.x_opt.get(n).copied().unwrap_or(f64::NAN)).collect();
    let mut simulations = 0;
    let mut gn = Fit { client, job: &prepared, data: &ctx.data, model: &ctx.model };
    let (refined, mut id) = gn.gauss_newton(x, |_, gain| gain <= f_tol, &mut simulations).await?;
    let (mut ssr, mut x, gain) = refined.context("the polish's first point failed")?;
    let mut termination = "Gauss–Newton polish";
    if gain > decision_f_tol(ssr, n_eff) {
        let mut ls = job.clone().with_starts(&names.iter().cloned().zip(x.iter().copied()).collect());
        ls.optimizer.set_algorithm(Algorithm::LeastSquares);
        ls.optimizer.set_initial_step(Some(polish_step(ls.optimizer.x_tol, ls.optimizer.initial_step())));
        let r = gn.client.calibrate_with(&ls, std::slice::from_ref(&*ctx.data), &ctx.model, |_| {}).await?;
        simulations += r.evaluations;
        if r.f_opt < ssr {
            let (_, again) = gn.gauss_newton(r.x_opt_in(&names), |_, _| true, &mut simulations).await?;
            (ssr, x, id) = (r.f_opt, r.x_opt_in(&names), again);
            termination = "Gauss–Newton and least-squares polish";
        }
    }
    tracing::debug!(
        "polish ({termination}): {simulations} simulations, SSR {:.6e} → {ssr:.6e}",
        fit.evidence.as_ref().map_or(f64::NAN, |e| e.ssr)
    );
    let elapsed = t.elapsed() + Duration::from_secs_f64(fit.elapsed_s);
    let result = CalibrationResult {
        x_opt: names.iter().cloned().zip(x).collect(),
        f_opt: ssr,
        iterations: 0,
        evaluations: fit.evaluations + simulations,
        rounds: 0,
        failed_evaluations: 0,
        termination: termination.into(),
        elapsed_s: elapsed.as_secs_f64(),
        history: vec![],
        ..Default::default()
    };
    Ok(Fitted { job: job.clone(), result: Ok((result, id)), elapsed, simulations })
}

fn prepare(ctx: &Context, job: &JobSpec) -> Result<PreparedJob> {
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

/// The evidence about one fitted candidate and its verdict.
fn judge_fit(
    ctx: &Context,
    baseline: &Baseline,
    rule: &Rule,
    candidate: &Candidate,
    f: Fitted,
) -> (CandidateFit, JobSpec, Option<Look>) {
    let elapsed_s = f.elapsed.as_secs_f64();
    let failed = |x_opt: BTreeMap<String, f64>, e: String| CandidateFit {
        evaluations: 0,
        x_opt,
        standard_errors: BTreeMap::new(),
        calibration_rms: f64::NAN,
        evidence: None,
        verdict: None,
        error: Some(e),
        elapsed_s,
    };
    let (result, identified) = match f.result {
        Ok(r) => r,
        Err(e) => return (failed(BTreeMap::new(), format!("{e:#}")), f.job, None),
    };
    let evidence = (|| -> Result<(Evidence, Look)> {
        let prepared = Arc::new(prepare(ctx, &f.job)?);
        let x = result.x_opt_in(&prepared.parameter_names);
        let seen = look(ctx, &prepared, &x)?;
        let k = f.job.effects.len() - 1;
        let id = identified.as_ref().ok();
        let parameters = candidate
            .parameter_names()
            .iter()
            .zip(&candidate.guesses)
            .map(|(name, g)| {
                let full = format!("effects[{k}].{name}");
                let se = id
                    .and_then(|id| id.names.iter().position(|n| *n == full).map(|i| id.standard_errors[i]))
                    .unwrap_or(f64::NAN);
                ParameterEvidence {
                    name: (*name).to_owned(),
                    value: result.x_opt.get(&full).copied().unwrap_or(f64::NAN),
                    neutral: g.neutral,
                    standard_error: se,
                    strength: g.step.is_some(),
                }
            })
            .collect();
        let residuals = seen.residuals.iter().map(|(_, r)| r.iter().filter(|v| !v.is_nan()).count()).sum();
        let e = Evidence {
            ssr: result.f_opt,
            residuals,
            n_eff: seen.n_eff,
            validation_rms: seen.rms.validation,
            parameters,
            place: fmucal_diagnose::decision::place(&candidate.effect),
        };
        Ok((e, seen))
    })();
    match evidence {
        Ok((e, seen)) => {
            let verdict = judge(baseline, &e, rule);
            let standard_errors = identified
                .as_ref()
                .map(|id| id.names.iter().cloned().zip(id.standard_errors.iter().copied()).collect())
                .unwrap_or_default();
            let error = identified.err().map(|e| format!("no standard errors: {e:#}"));
            let fit = CandidateFit {
                standard_errors,
                evaluations: result.evaluations,
                x_opt: result.x_opt,
                calibration_rms: seen.rms.calibration,
                evidence: Some(e),
                verdict: Some(verdict),
                error,
                elapsed_s,
            };
            (fit, f.job, Some(seen))
        }
        Err(e) => (failed(result.x_opt, format!("{e:#}")), f.job, None),
    }
}

/// The accepted effect in words, and its `[[effects]]` entry with the fitted starts within the
/// candidate's full guessed bounds (not the narrowed ones its fit used), so a later calibration
/// is not held near this one's estimate.
fn name(ctx: &Context, candidate: &Candidate, fit: &CandidateFit, job: &JobSpec) -> NamedEffect {
    let k = job.effects.len() - 1;
    let md = &ctx.fmu.description;
    // A port's strength is in the port's unit; a state's in its derivative's (an acceleration
    // on a velocity), which is the state's unit per second when the derivative has none.
    let words = |u: Option<String>| u.map(|u| format!(" {u}")).unwrap_or_default();
    let unit = words(match (&candidate.effect.state, &candidate.effect.port) {
        (Some(state), _) => derivative_unit(md, state),
        (_, Some(port)) => md.variable(port).and_then(|v| md.unit_of(v)).map(str::to_owned),
        _ => None,
    });
    let names = candidate.parameter_names();
    // A reaction is the kind's first parameter on another derivative: in that one's unit where
    // the first parameter is a load (a force), none where it is a coefficient.
    let first_is_load = names.first().is_some_and(|f| effects::parameter_scale(f) == effects::Scale::Load);
    let reaction_unit =
        words(candidate.effect.reaction.as_deref().filter(|_| first_is_load).and_then(|r| derivative_unit(md, r)));
    let fitted: Vec<f64> =
        names.iter().map(|n| fit.x_opt.get(&format!("effects[{k}].{n}")).copied().unwrap_or(f64::NAN)).collect();
    let values: Vec<String> = names
        .iter()
        .zip(&fitted)
        .enumerate()
        .map(|(j, (n, v))| {
            let w = fit.verdict.as_ref().and_then(|v| v.half_widths.get(j).copied()).unwrap_or(f64::NAN);
            // Only the loads (a force, a strength): the port's or the derivative's unit.
            let load =
                effects::parameter_scale(n) == effects::Scale::Load && !matches!(*n, "offset" | "lower" | "upper");
            let u = if *n == effects::REACTION {
                reaction_unit.as_str()
            } else if load {
                unit.as_str()
            } else {
                ""
            };
            format!("{n} {}{u}", value_with_interval(*v, w))
        })
        .collect();
    NamedEffect {
        words: format!("{}, {}", candidate.describe(), values.join(", ")),
        effect: candidate.with_starts(&fitted),
    }
}
