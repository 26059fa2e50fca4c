//! What a diagnosis found, as `diagnosis/report.json` holds it, and its readable summary.

use std::collections::BTreeMap;
use std::fmt::Write;

use serde::{Deserialize, Serialize};

use super::candidates::{Candidate, Screened};
use super::decision::{Baseline, Evidence, Verdict, elsewhere};
use super::localise::Localisation;
use fmucal_shared::job::spec::EffectSpec;
use fmucal_shared::residuals::Misfit;

/// What a diagnosis concludes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Conclusion {
    /// An effect of the library was named.
    Named,
    /// None was, and the base model's residual is far from its noise
    /// ([`fmucal_shared::residuals::Misfit::far`]), or the best candidate left it far: the model
    /// misses something none of the tried effects explains.
    MissesSomething,
    /// None was, and the residual is consistent with noise: the model fits.
    Fits,
}

impl Conclusion {
    /// The conclusion from whether an effect was named, whether one explained only part of the
    /// misfit, and the base model's misfit.
    pub fn of(named: bool, partial: bool, base: &Misfit) -> Conclusion {
        if named {
            Conclusion::Named
        } else if partial || base.far() {
            Conclusion::MissesSomething
        } else {
            Conclusion::Fits
        }
    }
}

/// The whole diagnosis.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Diagnosis {
    pub conclusion: Conclusion,
    /// How far the base model's fit, and the fit with the named effects, are from the noise.
    pub misfit_before: Misfit,
    pub misfit_after: Misfit,
    /// Every calibrated value of the model the diagnosis ends with (the base, or the base with
    /// the named effects, `effects[K].NAME`), and their standard errors where known.
    #[serde(default)]
    pub fitted: BTreeMap<String, f64>,
    #[serde(default)]
    pub standard_errors: BTreeMap<String, f64>,
    /// The windows every fit and comparison used.
    pub windows: Windows,
    pub rounds: Vec<Round>,
    /// The effects named, in the order found (empty: "no effect found").
    pub named: Vec<NamedEffect>,
    /// The candidate that passed every test but left the residual far from its noise: it
    /// explains part of what is missing, and is not named.
    #[serde(default)]
    pub partial: Vec<NamedEffect>,
    /// How far the model with the partial effect is from the noise.
    #[serde(default)]
    pub misfit_partial: Option<Misfit>,
    /// RMS errors of the base model and of the model with the named effects.
    pub before: RmsPair,
    pub after: RmsPair,
    /// Wall time of the first base calibration and of the whole diagnosis [s].
    pub base_calibration_s: f64,
    pub elapsed_s: f64,
    /// Where the time went, summed over the rounds: each phase's wall time and simulations.
    #[serde(default)]
    pub phases: BTreeMap<String, PhaseTime>,
    /// What could not be tried, and why ("Co-Simulation only: no state effects").
    #[serde(default)]
    pub notes: Vec<String>,
}

/// One phase of a diagnosis: wall time [s] and the simulations it ran (on the workers, or in
/// this process for the local looks).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct PhaseTime {
    pub seconds: f64,
    pub simulations: u64,
}

#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Windows {
    pub start_time: f64,
    /// Fits use [start_time, calibration_stop]; decisions and the after/before comparison use
    /// (calibration_stop, validation_stop].
    pub calibration_stop: f64,
    pub validation_stop: f64,
    /// True when the validation window was held out of the job's own calibration window.
    pub holdout: bool,
}

#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RmsPair {
    #[serde(with = "fmucal_shared::optim::serde_float")]
    pub calibration: f64,
    #[serde(with = "fmucal_shared::optim::serde_float")]
    pub validation: f64,
}

/// One search for an effect.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Round {
    /// The base calibration of this round (the job plus the effects named before it).
    pub base_x_opt: BTreeMap<String, f64>,
    pub baseline: Baseline,
    pub localisation: Localisation,
    /// Load scale of each port: given, or probed (the constant load that moves the outputs as
    /// much as the residual does).
    pub port_scales: BTreeMap<String, f64>,
    /// Derivative scale of each state: the constant rate on its derivative that moves the
    /// outputs as much as the residual does (in the derivative's units).
    #[serde(default)]
    pub state_scales: BTreeMap<String, f64>,
    /// Every candidate in ranking order.
    pub candidates: Vec<RankedCandidate>,
    /// Index into `candidates` of the one named, if any.
    pub chosen: Option<usize>,
    /// Other accepted candidates the data supports as well as the chosen one (ΔIC within 2).
    #[serde(default)]
    pub equally_supported: Vec<usize>,
}

impl Round {
    /// The accepted candidates equally supported at different places ([`elsewhere`]): the best
    /// first, then the others within ΔIC 2 of it; empty when the data say where.
    pub fn elsewhere(&self) -> Vec<usize> {
        let verdicts: Vec<Option<Verdict>> =
            self.candidates.iter().map(|c| c.fit.as_ref().and_then(|f| f.verdict.clone())).collect();
        elsewhere(&verdicts)
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RankedCandidate {
    pub description: String,
    pub candidate: Candidate,
    pub screening: Screened,
    /// Present for the top K, which were fitted.
    pub fit: Option<CandidateFit>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CandidateFit {
    /// The fitted values of every calibrated parameter, effect parameters last.
    pub x_opt: BTreeMap<String, f64>,
    /// Their standard errors (absent where the identifiability analysis failed).
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub standard_errors: BTreeMap<String, f64>,
    #[serde(with = "fmucal_shared::optim::serde_float")]
    pub calibration_rms: f64,
    pub evidence: Option<Evidence>,
    pub verdict: Option<Verdict>,
    /// Why the fit or its analysis failed (a failed fit has no verdict and is never named).
    pub error: Option<String>,
    /// Simulations of the fit, and its wall time.
    pub evaluations: u64,
    pub elapsed_s: f64,
}

/// An accepted effect.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NamedEffect {
    /// In words, e.g. "coulomb_friction on pendulumJoint.w through pendulumJoint.tauExt,
    /// force 0.0123 ± 0.0004 N.m".
    pub words: String,
    /// The `[[effects]]` entry, its starts at the fitted values.
    pub effect: EffectSpec,
}

/// "0.0123 ± 0.0004" with as many digits as the half-width warrants.
pub fn value_with_interval(value: f64, half_width: f64) -> String {
    if !(half_width.is_finite() && half_width > 0.0) {
        return format!("{value:.4e}");
    }
    let digits = (-half_width.log10().floor() + 1.0).clamp(0.0, 12.0) as usize;
    if value.abs() >= 1e-3 && value.abs() < 1e5 {
        format!("{value:.digits$} ± {half_width:.digits$}")
    } else {
        format!("{value:.3e} ± {half_width:.1e}")
    }
}

impl Diagnosis {
    /// The readable summary printed on stdout.
    pub fn summary(&self) -> String {
        let mut s = String::new();
        let w = &self.windows;
        let _ = writeln!(
            s,
            "fitted on [{}, {}] s, judged on ({}, {}] s{}",
            w.start_time,
            w.calibration_stop,
            w.calibration_stop,
            w.validation_stop,
            if w.holdout { " (held out of the job's window)" } else { "" }
        );
        for (k, round) in self.rounds.iter().enumerate() {
            // What was tried where: "der(mass.v) 8, output mass.x 4".
            let mut places: Vec<(String, usize)> = vec![];
            for c in &round.candidates {
                let place = c.candidate.place();
                match places.iter_mut().find(|(p, _)| *p == place) {
                    Some((_, n)) => *n += 1,
                    None => places.push((place, 1)),
                }
            }
            let tried: Vec<String> = places.iter().map(|(p, n)| format!("{p} {n}")).collect();
            let _ = writeln!(s, "round {}: tried {}", k + 1, tried.join(", "));
            let fitted = round.candidates.iter().filter(|c| c.fit.is_some()).count();
            let _ = writeln!(s, "round {}: {}", k + 1, screened_and_fitted(round.candidates.len(), fitted));
            for (rank, c) in round.candidates.iter().enumerate().filter(|(_, c)| c.fit.is_some()) {
                let fit = c.fit.as_ref().expect("filtered");
                let verdict = match (&fit.verdict, &fit.error) {
                    (Some(v), _) if v.accepted() => "accepted".to_owned(),
                    (Some(v), _) => v.reasons().join("; "),
                    (None, Some(e)) => format!("failed: {e}"),
                    (None, None) => "not judged".to_owned(),
                };
                let stats = fit
                    .verdict
                    .as_ref()
                    .map(|v| format!("validation {:+.1} %, ΔIC {:.1}", -100.0 * v.validation_gain, v.delta_ic))
                    .unwrap_or_default();
                let mark = if round.chosen == Some(rank) { "*" } else { " " };
                let _ = writeln!(s, " {mark}{:>2}. {:<62} {stats:<32} {verdict}", rank + 1, c.description);
            }
        }
        for round in &self.rounds {
            if !round.equally_supported.is_empty() {
                let names: Vec<&str> =
                    round.equally_supported.iter().map(|k| round.candidates[*k].description.as_str()).collect();
                let _ = writeln!(s, "the data supports these as well (ΔIC within 2): {}", names.join("; "));
            }
        }
        for note in &self.notes {
            let _ = writeln!(s, "not tried: {note}");
        }
        if self.named.is_empty() {
            let first = self.rounds.first();
            let fitted = first.is_some_and(|r| r.candidates.iter().any(|c| c.fit.is_some()));
            let apart = first.map(Round::elsewhere).unwrap_or_default();
            let why = if !apart.is_empty() {
                let round = first.expect("verdicts come from the first round");
                let names: Vec<&str> = apart.iter().map(|k| round.candidates[*k].description.as_str()).collect();
                format!(
                    "candidates at different places are equally supported (ΔIC within 2), so the data do not say where the model is wrong: {}",
                    names.join("; ")
                )
            } else if fitted {
                "no candidate passed all three tests".to_owned()
            } else {
                "the screening predicts no candidate to improve the fit enough to pay for its parameters".to_owned()
            };
            let tried = first.map_or(0, |r| r.candidates.len());
            match self.conclusion {
                Conclusion::MissesSomething if !self.partial.is_empty() => {
                    let words: Vec<&str> = self.partial.iter().map(|p| p.words.as_str()).collect();
                    let _ = writeln!(
                        s,
                        "the model misses something that {}: the best, {}, passes every test but leaves the residual far from its noise ({})",
                        none_of_tried(tried),
                        words.join("; "),
                        self.misfit_partial.as_ref().map_or_else(String::new, Misfit::evidence)
                    );
                }
                // Effects at different places explain it equally: something is missing, but
                // the data do not say where.
                Conclusion::MissesSomething if !apart.is_empty() => {
                    let _ = writeln!(
                        s,
                        "the model misses something: {why}; the evidence: {}",
                        self.misfit_before.evidence()
                    );
                }
                Conclusion::MissesSomething => {
                    let _ = writeln!(
                        s,
                        "the model misses something that {} ({why}); the evidence: {}",
                        none_of_tried(tried),
                        self.misfit_before.evidence()
                    );
                }
                _ => {
                    let _ = writeln!(
                        s,
                        "no effect found: the residual is consistent with noise ({}); {why}",
                        self.misfit_before.evidence()
                    );
                }
            }
        }
        for e in &self.named {
            let _ = writeln!(s, "found: {}", e.words);
        }
        if !self.named.is_empty() {
            for p in &self.partial {
                let _ = writeln!(
                    s,
                    "the next round's best, {}, passes every test but leaves the residual far from its noise ({}): not named",
                    p.words,
                    self.misfit_partial.as_ref().map_or_else(String::new, Misfit::evidence)
                );
            }
        }
        if !self.named.is_empty() && self.partial.is_empty() && self.misfit_after.far() {
            let _ = writeln!(
                s,
                "the named effects explain part of the misfit; the model still misses something: {}",
                self.misfit_after.evidence()
            );
        }
        if !self.fitted.is_empty() {
            let _ = writeln!(s, "fitted values (± standard error):");
            let width = self.fitted.keys().map(|k| k.chars().count()).max().unwrap_or(0);
            for (name, v) in &self.fitted {
                let se = self.standard_errors.get(name).copied().unwrap_or(f64::NAN);
                let _ = writeln!(s, "  {name:<width$}  {}", value_with_interval(*v, se));
            }
        }
        let _ = writeln!(
            s,
            "RMS error before → after: calibration {:.4e} → {:.4e}, validation {:.4e} → {:.4e} ({:+.1} %)",
            self.before.calibration,
            self.after.calibration,
            self.before.validation,
            self.after.validation,
            100.0 * (self.after.validation / self.before.validation - 1.0)
        );
        let _ =
            writeln!(s, "diagnosis took {:.1} s (base calibration {:.1} s)", self.elapsed_s, self.base_calibration_s);
        s
    }
}

/// "12 candidates" or "1 candidate".
fn candidates(n: usize) -> String {
    if n == 1 { "1 candidate".to_owned() } else { format!("{n} candidates") }
}

/// A round's screening in words: how many candidates it screened, and how many of them it
/// predicts to help and so were fitted, e.g. "screened 12 candidates; fitted the 4 predicted to
/// help:" (the fitted ones are listed after the colon).
fn screened_and_fitted(screened: usize, fitted: usize) -> String {
    let fitted = match fitted {
        0 => "none is predicted to help, so none was fitted".to_owned(),
        1 if screened == 1 => "it is predicted to help and was fitted:".to_owned(),
        1 => "fitted the one predicted to help:".to_owned(),
        n if n == screened => format!("all {n} are predicted to help and were fitted:"),
        n => format!("fitted the {n} predicted to help:"),
    };
    format!("screened {}; {fitted}", candidates(screened))
}

/// That no tried effect explains the misfit: "none of the 8 tried effects explains", "the one
/// tried effect does not explain".
fn none_of_tried(tried: usize) -> String {
    match tried {
        0 => "no tried effect explains".to_owned(),
        1 => "the one tried effect does not explain".to_owned(),
        n => format!("none of the {n} tried effects explains"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_are_printed_to_the_digits_their_interval_warrants() {
        assert_eq!(value_with_interval(0.012347, 0.00041), "0.01235 ± 0.00041");
        assert_eq!(value_with_interval(1.5, f64::NAN), "1.5000e0");
        assert_eq!(value_with_interval(2.5e-6, 1e-7), "2.500e-6 ± 1.0e-7");
    }

    #[test]
    fn the_screening_sentence_reads_well_for_any_count() {
        assert_eq!(screened_and_fitted(12, 4), "screened 12 candidates; fitted the 4 predicted to help:");
        assert_eq!(screened_and_fitted(12, 1), "screened 12 candidates; fitted the one predicted to help:");
        assert_eq!(screened_and_fitted(1, 1), "screened 1 candidate; it is predicted to help and was fitted:");
        assert_eq!(screened_and_fitted(3, 3), "screened 3 candidates; all 3 are predicted to help and were fitted:");
        assert_eq!(screened_and_fitted(5, 0), "screened 5 candidates; none is predicted to help, so none was fitted");
        assert_eq!(none_of_tried(8), "none of the 8 tried effects explains");
        assert_eq!(none_of_tried(1), "the one tried effect does not explain");
    }
}
