//! A fitted candidate judged: its evidence (a local simulation of its fit), its verdict by
//! [`crate::decision::judge`] ([`judge_fit`]), and, for the one named, the effect in words
//! with each value in its unit ([`name`]).

use std::collections::BTreeMap;
use std::sync::Arc;

use fmucal_shared::effects;
use fmucal_shared::job::JobSpec;
use fmucal_shared::structure::derivative_unit;

use super::fit::Fitted;
use super::look::{Look, look};
use super::{Context, prepare};
use crate::candidates::Candidate;
use crate::decision::{Baseline, Evidence, ParameterEvidence, Rule, judge};
use crate::error::Error;
use crate::report::{CandidateFit, NamedEffect, value_with_interval};

/// A candidate's fit with its verdict, the job it was fitted in, and its residuals (`None`
/// where the fit or its simulation failed).
pub struct Judged {
    pub fit: CandidateFit,
    pub job: JobSpec,
    pub look: Option<Look>,
}

/// The evidence about one fitted candidate and its verdict.
pub fn judge_fit(ctx: &Context, baseline: &Baseline, rule: &Rule, candidate: &Candidate, f: Fitted) -> Judged {
    let elapsed_s = f.elapsed.as_secs_f64();
    let failed = |x_opt: BTreeMap<String, f64>, e: &Error| CandidateFit {
        evaluations: 0,
        x_opt,
        standard_errors: BTreeMap::new(),
        calibration_rms: f64::NAN,
        evidence: None,
        verdict: None,
        error: Some(e.one_line()),
        elapsed_s,
    };
    let (result, identified) = match f.result {
        Ok(r) => r,
        Err(e) => return Judged { fit: failed(BTreeMap::new(), &e), job: f.job, look: None },
    };
    let evidence = (|| -> Result<(Evidence, Look), Error> {
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
            place: crate::decision::place(&candidate.effect),
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
            let error = identified.err().map(|e| format!("no standard errors: {}", e.one_line()));
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
            Judged { fit, job: f.job, look: Some(seen) }
        }
        Err(e) => Judged { fit: failed(result.x_opt, &e), job: f.job, look: None },
    }
}

/// The accepted effect in words, and its `[[effects]]` entry with the fitted starts within the
/// candidate's full guessed bounds (not the narrowed ones its fit used), so a later calibration
/// is not held near this one's estimate.
pub fn name(ctx: &Context, candidate: &Candidate, fit: &CandidateFit, job: &JobSpec) -> NamedEffect {
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
            let u = if *n == effects::REACTION {
                reaction_unit.as_str()
            } else if effects::is_load(n) {
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
