//! When a local CMA-ES run ends: the user's x_tol and f_tol, and the internal criteria with
//! pycma's default thresholds (written from pycma's option descriptions). Each criterion is
//! reported as [`Termination::XTol`] (the distribution collapsed or degenerated) or
//! [`Termination::FTol`] (the values stopped improving); while restarts remain, any of them
//! starts the next IPOP run instead of stopping.
//!
//! With k free dimensions, population λ, g generations in the local run and H = 10 + ⌈30k/λ⌉:
//!
//! | criterion | holds when | reported as |
//! |---|---|---|
//! | `x_tol` (user) | σ · maxᵢ √Cᵢᵢ ≤ x_tol | XTol |
//! | `f_tol` (user) | the range of this generation's values and of the best values of the last H generations ≤ f_tol | FTol |
//! | TolX | σ · maxᵢ max(\|p_c,i\|, √Cᵢᵢ) < 1e-11 | XTol |
//! | TolFacUpX | σ · maxᵢ √Cᵢᵢ > 1e3 · σ₀ (σ₀ far too small) | XTol |
//! | TolUpSigma | σ / σ₀ > 1e20 · max D | XTol |
//! | ConditionCov | cond(C) > 1e14 | XTol |
//! | NoEffectAxis | adding 0.1 σ dⱼ bⱼ (j = g mod k) leaves the mean unchanged | XTol |
//! | NoEffectCoord | adding 0.2 σ √Cᵢᵢ leaves mᵢ unchanged, for some i | XTol |
//! | numerical failure | the state is not finite or C not positive definite | XTol |
//! | TolFun | the `f_tol` range above < 1e-11 | FTol |
//! | TolFunHist | the best values of the last H generations (H recorded) span < 1e-12 | FTol |
//! | FlatFitness | the best and the median value of the generation are equal | FTol |
//! | TolStagnation | after T = ⌊100 + 100 k^1.5 / λ⌋ generations, the median of the last T/2 generations' best values is no better than that of the T/2 before, and likewise for their medians | FTol |
//!
//! Spaces are scaled (the box is [0, 1] per dimension). A failed or infinite value in a
//! generation makes its range infinite, so the value rules never hold on failures alone.

use serde::{Deserialize, Serialize};

use super::super::fitness::{self, Fitness};
use super::super::{Stopping, Termination};
use super::distribution::Distribution;
use super::params::Params;

const TOL_X: f64 = 1e-11;
const TOL_FAC_UP_X: f64 = 1e3;
const TOL_UP_SIGMA: f64 = 1e20;
const MAX_CONDITION: f64 = 1e14;
const TOL_FUN: f64 = 1e-11;
const TOL_FUN_HIST: f64 = 1e-12;

/// The per-generation best and median values of the local run (most recent last), as many as
/// the criteria look at. Failed values are kept as +∞.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub(super) struct History {
    #[serde(with = "super::super::serde_float::vec")]
    best: Vec<f64>,
    #[serde(with = "super::super::serde_float::vec")]
    median: Vec<f64>,
}

impl History {
    /// Records a generation's values, given in rank order.
    pub fn push(&mut self, ranked: &[Fitness], p: &Params) {
        let value = |f: &Fitness| match f {
            Fitness::Value(v) => *v,
            Fitness::Failed => f64::INFINITY,
        };
        self.best.push(ranked.first().map_or(f64::INFINITY, value));
        self.median.push(ranked.get(ranked.len() / 2).map_or(f64::INFINITY, value));
        let keep = fun_window(p).max(stagnation_window(p));
        for h in [&mut self.best, &mut self.median] {
            if h.len() > keep {
                h.drain(..h.len() - keep);
            }
        }
    }
}

/// H = 10 + ⌈30k/λ⌉, the generations the value ranges look back on.
fn fun_window(p: &Params) -> usize {
    10 + (30 * p.k).div_ceil(p.lambda)
}

/// T = ⌊100 + 100 k^1.5 / λ⌋, rounded up to even.
fn stagnation_window(p: &Params) -> usize {
    let t = (100.0 + 100.0 * (p.k as f64).powf(1.5) / p.lambda as f64) as usize;
    t + t % 2
}

/// The first criterion of the module docs' table that holds after a generation (its values in
/// rank order, the distribution already updated), or `None`.
pub(super) fn local_stop(
    d: &Distribution,
    p: &Params,
    history: &History,
    ranked: &[Fitness],
    stopping: &Stopping,
    sigma0: f64,
) -> Option<Termination> {
    let recent = &history.best[history.best.len().saturating_sub(fun_window(p))..];
    let f_range = fitness::spread(ranked.iter().copied().chain(recent.iter().map(|v| Fitness::Value(*v))));
    let user = Stopping { max_iters: None, max_fevals: None, ..*stopping };
    if let Some(t) = user.check(d.max_std(), f_range, 0, 0) {
        return Some(t);
    }
    if x_criterion(d, sigma0) {
        return Some(Termination::XTol);
    }
    let hist_full = history.best.len() >= fun_window(p);
    let flat = matches!((ranked.first(), ranked.get(ranked.len() / 2)),
        (Some(Fitness::Value(a)), Some(Fitness::Value(b))) if a.is_finite() && a == b);
    if f_range < TOL_FUN
        || (hist_full && fitness::spread(recent.iter().map(|v| Fitness::Value(*v))) < TOL_FUN_HIST)
        || flat
        || stagnated(history, p)
    {
        return Some(Termination::FTol);
    }
    None
}

/// TolX, TolFacUpX, TolUpSigma, ConditionCov, NoEffectAxis and NoEffectCoord.
fn x_criterion(d: &Distribution, sigma0: f64) -> bool {
    let k = d.dim();
    let sigma = d.sigma;
    let diag = |i: usize| d.cov[i * k + i].sqrt();
    let tol_x = (0..k).all(|i| sigma * d.path_c[i].abs().max(diag(i)) < TOL_X);
    let max_d = d.scales.iter().copied().fold(0.0, f64::max);
    let axis = (d.generation % k as u64) as usize;
    let no_effect_axis = (0..k).all(|i| d.mean[i] + 0.1 * sigma * d.scales[axis] * d.basis[i * k + axis] == d.mean[i]);
    let no_effect_coord = (0..k).any(|i| d.mean[i] + 0.2 * sigma * diag(i) == d.mean[i]);
    tol_x
        || d.max_std() > TOL_FAC_UP_X * sigma0
        || sigma / sigma0 > TOL_UP_SIGMA * max_d
        || d.condition() > MAX_CONDITION
        || no_effect_axis
        || no_effect_coord
}

/// TolStagnation; see the module docs.
fn stagnated(history: &History, p: &Params) -> bool {
    let t = stagnation_window(p);
    let no_better = |h: &[f64]| {
        if h.len() < t {
            return false;
        }
        let window = &h[h.len() - t..];
        let (old, new) = window.split_at(t / 2);
        median(new) >= median(old)
    };
    no_better(&history.best) && no_better(&history.median)
}

fn median(v: &[f64]) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let n = s.len();
    if n % 2 == 1 { s[n / 2] } else { 0.5 * (s[n / 2 - 1] + s[n / 2]) }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn values(v: &[f64]) -> Vec<Fitness> {
        v.iter().map(|x| Fitness::Value(*x)).collect()
    }

    #[test]
    fn value_rules_look_at_the_generation_and_its_recent_history() {
        let p = Params::new(2, 6);
        let d = Distribution::new(vec![0.5, 0.5], 0.3);
        let none = Stopping { x_tol: None, f_tol: None, max_iters: None, max_fevals: None };
        let f_tol = Stopping { f_tol: Some(1e-3), ..none };
        let mut h = History::default();
        let close = values(&[1.0, 1.0001, 1.0002, 1.0003, 1.0004, 1.0005]);
        h.push(&values(&[2.0, 3.0, 4.0, 5.0, 6.0, 7.0]), &p);
        assert_eq!(local_stop(&d, &p, &h, &close, &f_tol, 0.3), None, "an earlier best is far");
        let mut h = History::default();
        h.push(&close, &p);
        assert_eq!(local_stop(&d, &p, &h, &close, &f_tol, 0.3), Some(Termination::FTol));
        assert_eq!(local_stop(&d, &p, &h, &close, &none, 0.3), None);
        let failed = [close[..5].to_vec(), vec![Fitness::Failed]].concat();
        assert_eq!(local_stop(&d, &p, &h, &failed, &f_tol, 0.3), None, "a failure makes the range infinite");
        let flat = values(&[1.0, 1.0, 1.0, 1.0, 2.0, 3.0]);
        assert_eq!(local_stop(&d, &p, &History::default(), &flat, &none, 0.3), Some(Termination::FTol));
    }

    #[test]
    fn distribution_rules_report_x_tol() {
        let p = Params::new(2, 6);
        let none = Stopping { x_tol: None, f_tol: None, max_iters: None, max_fevals: None };
        let spread = values(&[1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
        let h = History::default();
        let mut d = Distribution::new(vec![0.5, 0.5], 0.3);
        assert_eq!(local_stop(&d, &p, &h, &spread, &none, 0.3), None);
        assert_eq!(
            local_stop(&d, &p, &h, &spread, &Stopping { x_tol: Some(0.5), ..none }, 0.3),
            Some(Termination::XTol)
        );
        d.sigma = 1e-12;
        assert_eq!(local_stop(&d, &p, &h, &spread, &none, 0.3), Some(Termination::XTol), "TolX");
        let mut d = Distribution::new(vec![0.5, 0.5], 0.3);
        d.scales = vec![1.0, 1e-8];
        assert_eq!(local_stop(&d, &p, &h, &spread, &none, 0.3), Some(Termination::XTol), "ConditionCov");
    }

    #[test]
    fn stagnation_needs_both_histories_to_stall() {
        let p = Params::new(1, 4);
        let t = stagnation_window(&p);
        let mut h = History::default();
        for g in 0..t {
            // The best stalls, the median keeps improving.
            let a = 1.0 / (g as f64 + 1.0);
            h.push(&values(&[1.0, 1.0 + a, 1.0 + a, 9.0]), &p);
        }
        assert!(!stagnated(&h, &p));
        let mut h = History::default();
        for g in 0..t {
            h.push(&values(&[1.0 + (g % 3) as f64, 7.0, 8.0, 9.0]), &p);
        }
        assert!(stagnated(&h, &p));
        assert!(h.best.len() <= t.max(fun_window(&p)));
    }
}
