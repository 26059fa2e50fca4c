//! The decision (step 5 of a diagnosis): which fitted candidate, if any, is named.
//!
//! A candidate is accepted only if all three hold:
//! 1. **It wins on data the fit did not see**: on the validation window (or the held-out end
//!    of the calibration window) the likelihood ratio n_v·ln(SSR_v₀/SSR_v₁), with n_v the
//!    effective samples of the base model's residual there, exceeds the χ²_q quantile at the
//!    rule's confidence (the drop is more than chance would give an effect with q strength
//!    parameters), and the RMS error falls by at least `min_validation_gain`.
//! 2. **Its information criterion improves** with the sample size corrected for the residual's
//!    autocorrelation: ΔIC = n_eff·ln(SSR₁/SSR₀) + q·ln(n_eff) < 0, with n_eff from the base
//!    fit's residual (a smooth, model-error residual has far fewer independent samples than
//!    rows, which is what keeps an extra parameter from "explaining" it for free).
//! 3. **Its parameters' confidence intervals exclude "no effect"**: for every strength
//!    parameter, |θ − neutral| > z·SE, where SE is the standard error at the candidate's optimum
//!    inflated by √(m/n_eff) of the candidate's own residual.
//!
//! Among accepted candidates the lowest ΔIC is named, unless another accepted candidate acting
//! at a different place of the model (another port, output or input) is within
//! [`EQUAL_SUPPORT`] of it: the data then show that something is missing but not where, and
//! none is named. Accepted candidates at the same place within [`EQUAL_SUPPORT`] (radiation and
//! convection on one wall) are reported as equally supported alongside the one named. If none
//! passes, none is named: naming the wrong effect is worse than naming none.

use serde::{Deserialize, Serialize};

use fmucal_shared::residuals::chi_squared_survival;

/// The evidence about one fitted candidate.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Evidence {
    /// Sum of squares on the calibration window, and the number of residuals.
    #[serde(with = "fmucal_shared::optim::serde_float")]
    pub ssr: f64,
    pub residuals: usize,
    /// Effective samples of this fit's residual.
    #[serde(with = "fmucal_shared::optim::serde_float")]
    pub n_eff: f64,
    /// RMS on the validation window (NaN: the simulation failed).
    #[serde(with = "fmucal_shared::optim::serde_float")]
    pub validation_rms: f64,
    /// The effect's parameters: value, neutral value, standard error (uncorrected; NaN when
    /// not available), and whether it is a strength parameter.
    pub parameters: Vec<ParameterEvidence>,
    /// Where the effect acts ([`place`]): candidates at different places that the data support
    /// equally well leave the diagnosis unable to say where the model is wrong.
    #[serde(default)]
    pub place: String,
}

/// Where an effect acts on the model: the derivative of its state or its port (whatever
/// signal it reads), or the output or input it changes: `der(mass.v)`, `port mass.Fext`,
/// `output mass.x`, `input u`.
pub fn place(effect: &fmucal_shared::job::spec::EffectSpec) -> String {
    match (&effect.state, &effect.port, &effect.output, &effect.input) {
        (Some(s), _, _, _) => format!("der({s})"),
        (_, Some(p), _, _) => format!("port {p}"),
        (_, _, Some(o), _) => format!("output {o}"),
        (_, _, _, Some(i)) => format!("input {i}"),
        _ => String::new(),
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ParameterEvidence {
    pub name: String,
    #[serde(with = "fmucal_shared::optim::serde_float")]
    pub value: f64,
    #[serde(with = "fmucal_shared::optim::serde_float")]
    pub neutral: f64,
    #[serde(with = "fmucal_shared::optim::serde_float")]
    pub standard_error: f64,
    pub strength: bool,
}

/// The base fit the candidates are compared with.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Baseline {
    #[serde(with = "fmucal_shared::optim::serde_float")]
    pub ssr: f64,
    #[serde(with = "fmucal_shared::optim::serde_float")]
    pub n_eff: f64,
    #[serde(with = "fmucal_shared::optim::serde_float")]
    pub validation_rms: f64,
    /// Effective samples of the base residual on the validation window.
    #[serde(with = "fmucal_shared::optim::serde_float")]
    pub validation_n_eff: f64,
}

/// The settings of the rule.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rule {
    pub min_validation_gain: f64,
    pub confidence: f64,
}

/// How one candidate fared.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Verdict {
    /// Relative fall of the validation RMS (negative: it rose).
    #[serde(with = "fmucal_shared::optim::serde_float")]
    pub validation_gain: f64,
    /// n_v·ln(SSR_v₀/SSR_v₁) and the χ²_q quantile it must exceed.
    #[serde(with = "fmucal_shared::optim::serde_float")]
    pub validation_statistic: f64,
    #[serde(with = "fmucal_shared::optim::serde_float")]
    pub validation_threshold: f64,
    #[serde(with = "fmucal_shared::optim::serde_float")]
    pub delta_ic: f64,
    /// Per parameter: the half-width z·SE·√(m/n_eff) of its confidence interval.
    #[serde(with = "fmucal_shared::optim::serde_float::vec")]
    pub half_widths: Vec<f64>,
    pub wins_on_validation: bool,
    pub improves_ic: bool,
    pub intervals_exclude_neutral: bool,
    /// Where the effect acts (the evidence's `place`).
    #[serde(default)]
    pub place: String,
}

impl Verdict {
    pub fn accepted(&self) -> bool {
        self.wins_on_validation && self.improves_ic && self.intervals_exclude_neutral
    }

    /// Why a candidate was turned down, in words (empty when accepted).
    pub fn reasons(&self) -> Vec<&'static str> {
        let mut out = vec![];
        if !self.wins_on_validation {
            out.push("does not win on held-out data");
        }
        if !self.improves_ic {
            out.push("information criterion does not improve");
        }
        if !self.intervals_exclude_neutral {
            out.push("confidence interval includes no effect");
        }
        out
    }
}

/// Judges one candidate against the baseline.
pub fn judge(base: &Baseline, fit: &Evidence, rule: &Rule) -> Verdict {
    let q = fit.parameters.len() as f64;
    let n_eff = base.n_eff.max(1.0);
    let delta_ic = if fit.ssr.is_finite() && base.ssr > 0.0 && fit.ssr > 0.0 {
        n_eff * (fit.ssr / base.ssr).ln() + q * n_eff.ln()
    } else {
        f64::NAN
    };
    let validation_gain = (base.validation_rms - fit.validation_rms) / base.validation_rms;
    let strengths = fit.parameters.iter().filter(|p| p.strength).count().max(1) as f64;
    let validation_statistic = base.validation_n_eff.max(1.0) * 2.0 * (base.validation_rms / fit.validation_rms).ln();
    let validation_threshold = chi_squared_quantile(rule.confidence, strengths);
    let z = normal_quantile(0.5 + rule.confidence / 2.0);
    let inflation = (fit.residuals as f64 / fit.n_eff.max(1.0)).max(1.0).sqrt();
    let half_widths: Vec<f64> = fit.parameters.iter().map(|p| z * p.standard_error * inflation).collect();
    let intervals_exclude_neutral = fit
        .parameters
        .iter()
        .zip(&half_widths)
        .filter(|(p, _)| p.strength)
        .all(|(p, w)| w.is_finite() && (p.value - p.neutral).abs() > *w)
        && fit.parameters.iter().any(|p| p.strength);
    Verdict {
        validation_gain,
        validation_statistic,
        validation_threshold,
        delta_ic,
        half_widths,
        wins_on_validation: validation_statistic > validation_threshold && validation_gain >= rule.min_validation_gain,
        improves_ic: delta_ic < 0.0,
        intervals_exclude_neutral,
        place: fit.place.clone(),
    }
}

/// The index of the accepted candidate with the lowest ΔIC, if any.
fn best(verdicts: &[Option<Verdict>]) -> Option<usize> {
    verdicts
        .iter()
        .enumerate()
        .filter_map(|(k, v)| v.as_ref().filter(|v| v.accepted()).map(|v| (k, v.delta_ic)))
        .min_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)))
        .map(|(k, _)| k)
}

/// The accepted candidate to name: the one with the lowest ΔIC, unless [`elsewhere`] finds
/// candidates at other places as well supported (then none).
pub fn choose(verdicts: &[Option<Verdict>]) -> Option<usize> {
    best(verdicts).filter(|_| elsewhere(verdicts).is_empty())
}

/// The accepted candidates within [`EQUAL_SUPPORT`] of the lowest ΔIC that act at another place
/// than the best one (a port, output or input): when there are any, the data cannot tell where
/// the model is wrong, and the best is not named (the best comes first in the list then).
pub fn elsewhere(verdicts: &[Option<Verdict>]) -> Vec<usize> {
    let Some(b) = best(verdicts) else { return vec![] };
    let place = verdicts[b].as_ref().map(|v| v.place.as_str()).unwrap_or_default();
    let others: Vec<usize> =
        within(verdicts, b).into_iter().filter(|k| verdicts[*k].as_ref().is_some_and(|v| v.place != place)).collect();
    if others.is_empty() { others } else { std::iter::once(b).chain(others).collect() }
}

/// The other accepted candidates within [`EQUAL_SUPPORT`] of candidate `of`.
fn within(verdicts: &[Option<Verdict>], of: usize) -> Vec<usize> {
    let Some(best) = verdicts.get(of).and_then(|v| v.as_ref()).map(|v| v.delta_ic) else { return vec![] };
    verdicts
        .iter()
        .enumerate()
        .filter(|(k, v)| *k != of && v.as_ref().is_some_and(|v| v.accepted() && v.delta_ic - best <= EQUAL_SUPPORT))
        .map(|(k, _)| k)
        .collect()
}

/// Information-criterion difference within which two accepted candidates are equally
/// supported by the data (Burnham and Anderson's rule of thumb).
pub const EQUAL_SUPPORT: f64 = 2.0;

/// The other accepted candidates whose ΔIC is within [`EQUAL_SUPPORT`] of the chosen one's: the
/// data cannot tell them from it (radiation and convection over a narrow temperature range; by
/// [`choose`] they act at the same place).
pub fn equally_supported(verdicts: &[Option<Verdict>], chosen: usize) -> Vec<usize> {
    within(verdicts, chosen)
}

/// Effective number of independent samples of a residual made of `series` (one per output, on
/// its time grid; NaN = missing): Σ n·(1 − ρ₁)/(1 + ρ₁) with ρ₁ the lag-1 autocorrelation
/// (the AR(1) variance-inflation correction), each term between 1 and n.
pub fn effective_samples(series: &[Vec<f64>]) -> f64 {
    series
        .iter()
        .map(|r| {
            let valid: Vec<f64> = r.iter().copied().filter(|v| !v.is_nan()).collect();
            let n = valid.len() as f64;
            if n < 3.0 {
                return n;
            }
            let mean = valid.iter().sum::<f64>() / n;
            let c0: f64 = valid.iter().map(|v| (v - mean).powi(2)).sum();
            let c1: f64 = valid.windows(2).map(|w| (w[0] - mean) * (w[1] - mean)).sum();
            let rho = if c0 > 0.0 { (c1 / c0).clamp(-0.99, 0.999_999) } else { 0.0 };
            (n * (1.0 - rho) / (1.0 + rho)).clamp(1.0, n)
        })
        .sum()
}

/// The χ² quantile with `k` degrees of freedom at probability `p`: the root of
/// P(χ²ₖ ≥ x) = 1 − p, found by bisection on [`chi_squared_survival`] to 1e-10 relative.
pub fn chi_squared_quantile(p: f64, k: f64) -> f64 {
    if !(p > 0.0 && p < 1.0 && k > 0.0) {
        return f64::NAN;
    }
    let (mut lo, mut hi) = (0.0, k.max(1.0));
    while chi_squared_survival(hi, k) > 1.0 - p {
        hi *= 2.0;
    }
    while hi - lo > 1e-10 * hi {
        let mid = 0.5 * (lo + hi);
        if chi_squared_survival(mid, k) > 1.0 - p { lo = mid } else { hi = mid }
    }
    0.5 * (lo + hi)
}

/// The standard normal quantile Φ⁻¹(p) for p in (0, 1) (Acklam's rational approximation,
/// relative error below 1.2e-9).
pub fn normal_quantile(p: f64) -> f64 {
    const A: [f64; 6] = [
        -3.969683028665376e1,
        2.209460984245205e2,
        -2.759285104469687e2,
        1.383577518672690e2,
        -3.066479806614716e1,
        2.506628277459239,
    ];
    const B: [f64; 5] =
        [-5.447609879822406e1, 1.615858368580409e2, -1.556989798598866e2, 6.680131188771972e1, -1.328068155288572e1];
    const C: [f64; 6] = [
        -7.784894002430293e-3,
        -3.223964580411365e-1,
        -2.400758277161838,
        -2.549732539343734,
        4.374664141464968,
        2.938163982698783,
    ];
    const D: [f64; 4] = [7.784695709041462e-3, 3.224671290700398e-1, 2.445134137142996, 3.754408661907416];
    if !(p > 0.0 && p < 1.0) {
        return f64::NAN;
    }
    let tail = |q: f64| {
        let q = (-2.0 * q.ln()).sqrt();
        (((((C[0] * q + C[1]) * q + C[2]) * q + C[3]) * q + C[4]) * q + C[5])
            / ((((D[0] * q + D[1]) * q + D[2]) * q + D[3]) * q + 1.0)
    };
    if p < 0.02425 {
        tail(p)
    } else if p > 1.0 - 0.02425 {
        -tail(1.0 - p)
    } else {
        let q = p - 0.5;
        let r = q * q;
        (((((A[0] * r + A[1]) * r + A[2]) * r + A[3]) * r + A[4]) * r + A[5]) * q
            / (((((B[0] * r + B[1]) * r + B[2]) * r + B[3]) * r + B[4]) * r + 1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normal_quantiles_match_the_tables() {
        for (p, z) in
            [(0.975, 1.959_963_984_540_054), (0.5, 0.0), (0.995, 2.575_829_303_548_901), (0.01, -2.326_347_874_040_841)]
        {
            assert!((normal_quantile(p) - z).abs() < 1e-8, "{p}: {}", normal_quantile(p));
        }
    }

    #[test]
    fn chi_squared_quantiles_match_the_tables() {
        for (p, k, x) in
            [(0.95, 1.0, 3.841_458_82), (0.95, 2.0, 5.991_464_55), (0.95, 3.0, 7.814_727_90), (0.99, 1.0, 6.634_896_60)]
        {
            let q = chi_squared_quantile(p, k);
            assert!((q - x).abs() < 1e-6 * x, "χ²({k}) at {p}: {q} vs {x}");
        }
        // k = 1 is the square of the two-sided normal quantile.
        assert!((chi_squared_quantile(0.95, 1.0) - normal_quantile(0.975).powi(2)).abs() < 1e-7);
    }

    #[test]
    fn white_noise_keeps_its_samples_and_a_smooth_residual_loses_most() {
        // A deterministic white-ish sequence (a linear congruential generator) and a sine.
        let mut s = 12345u64;
        let noise: Vec<f64> = (0..2000)
            .map(|_| {
                s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5
            })
            .collect();
        let smooth: Vec<f64> = (0..2000).map(|k| (k as f64 * 0.01).sin()).collect();
        let white = effective_samples(std::slice::from_ref(&noise));
        assert!(white > 1700.0 && white <= 2000.0, "{white}");
        assert!(effective_samples(&[smooth]) < 20.0);
    }

    fn evidence(ssr: f64, validation_rms: f64, value: f64, se: f64) -> Evidence {
        Evidence {
            ssr,
            residuals: 1000,
            n_eff: 1000.0,
            validation_rms,
            parameters: vec![ParameterEvidence {
                name: "force".into(),
                value,
                neutral: 0.0,
                standard_error: se,
                strength: true,
            }],
            place: "port a.tauExt".into(),
        }
    }

    #[test]
    fn equally_supported_candidates_at_other_places_leave_the_effect_unnamed() {
        let base = Baseline { ssr: 10.0, n_eff: 100.0, validation_rms: 1.0, validation_n_eff: 500.0 };
        let rule = Rule { min_validation_gain: 0.05, confidence: 0.95 };
        let at = |ssr: f64, place: &str| {
            let mut e = evidence(ssr, 0.5, 0.01, 0.001);
            e.place = place.into();
            Some(judge(&base, &e, &rule))
        };
        // ΔIC differs by 100·ln(2.05/2) ≈ 2.5 > 2: the best is named wherever the other acts.
        let clear = [at(2.05, "input u"), at(2.0, "port a.tauExt")];
        assert_eq!((choose(&clear), elsewhere(&clear)), (Some(1), vec![]));
        // Within 2 (ΔIC 1.0 apart) at the same place: named, the other equally supported.
        let same = [at(2.02, "port a.tauExt"), at(2.0, "port a.tauExt")];
        assert_eq!((choose(&same), equally_supported(&same, 1)), (Some(1), vec![0]));
        // Within 2 at another place: the data cannot say where, none is named.
        let apart = [at(2.02, "output y"), None, at(2.0, "port a.tauExt"), at(3.0, "input u")];
        assert_eq!((choose(&apart), elsewhere(&apart)), (None, vec![2, 0]));
        // A rejected candidate at another place does not count.
        let mut rejected = judge(&base, &evidence(2.02, 0.99, 0.01, 0.001), &rule);
        rejected.place = "output y".into();
        assert_eq!(choose(&[Some(rejected), at(2.0, "port a.tauExt")]), Some(1));
    }

    #[test]
    fn each_of_the_three_tests_can_turn_a_candidate_down() {
        let base = Baseline { ssr: 10.0, n_eff: 100.0, validation_rms: 1.0, validation_n_eff: 500.0 };
        let rule = Rule { min_validation_gain: 0.05, confidence: 0.95 };
        let good = judge(&base, &evidence(2.0, 0.5, 0.01, 0.001), &rule);
        assert!(good.accepted(), "{good:?}");
        // A 0.3 % drop over 500 effective held-out samples is within chance (statistic 3.0).
        let no_validation = judge(&base, &evidence(2.0, 0.997, 0.01, 0.001), &rule);
        assert_eq!(no_validation.reasons(), ["does not win on held-out data"]);
        // A 3 % drop is not (statistic 30), but falls short of a 5 % minimum gain.
        assert!(
            judge(&base, &evidence(2.0, 0.97, 0.01, 0.001), &Rule { min_validation_gain: 0.01, ..rule }).accepted()
        );
        assert!(!judge(&base, &evidence(2.0, 0.97, 0.01, 0.001), &rule).wins_on_validation);
        // A 1 % drop of SSR over 100 effective samples does not pay for one parameter (ln 100).
        let no_ic = judge(&base, &evidence(9.9, 0.5, 0.01, 0.001), &rule);
        assert_eq!(no_ic.reasons(), ["information criterion does not improve"]);
        let wide = judge(&base, &evidence(2.0, 0.5, 0.01, 0.006), &rule);
        assert_eq!(wide.reasons(), ["confidence interval includes no effect"]);
        assert_eq!(choose(&[Some(no_ic), None, Some(good.clone()), Some(wide)]), Some(2));
        assert_eq!(choose(&[None]), None);
        let mut close = good.clone();
        close.delta_ic += 1.5;
        let mut far = good.clone();
        far.delta_ic += 2.5;
        assert_eq!(equally_supported(&[Some(far), Some(good), None, Some(close)], 1), [3]);
    }

    #[test]
    fn a_correlated_residual_widens_the_interval() {
        let base = Baseline { ssr: 10.0, n_eff: 100.0, validation_rms: 1.0, validation_n_eff: 500.0 };
        let rule = Rule { min_validation_gain: 0.05, confidence: 0.95 };
        let mut e = evidence(2.0, 0.5, 0.01, 0.001);
        assert!(judge(&base, &e, &rule).accepted());
        e.n_eff = 10.0; // 1000 residuals worth 10: the standard error grows tenfold.
        let v = judge(&base, &e, &rule);
        assert!((v.half_widths[0] - 1.959_963_984_540_054 * 0.01).abs() < 1e-9, "{v:?}");
        assert!(!v.intervals_exclude_neutral);
    }
}
