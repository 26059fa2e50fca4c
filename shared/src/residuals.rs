//! The statistics of a fit's residual on a calibration window: where the simulation and the
//! measurements disagree, whether the disagreement is noise, and which readable signal it
//! follows. `fmucal calibrate` warns with them ([`Misfit`]) and a diagnosis localises with
//! them (`diagnose::localise`).
//!
//! - [`windows`]: RMS of the residual in equal time windows, worst first.
//! - [`ljung_box`]: the Ljung–Box statistic Q = n(n+2) Σₖ₌₁ʰ ρ̂ₖ²/(n−k) over the first h
//!   autocorrelations and its p-value under whiteness (χ² with h degrees of freedom). A small
//!   p-value says the residual is not white: some dynamics are missing.
//! - [`correlation`]: Pearson correlation of the residual with a candidate signal (a velocity,
//!   a temperature, an input, or its sign).
//! - [`noise_sigma`]: the noise level of a residual from its first differences.
//! - [`Misfit`]: whether a fit is far from its noise, the one definition of "far" (thresholds
//!   [`FAR_RMS_OVER_NOISE`], [`FAR_LJUNG_BOX_P`], [`FAR_VALIDATION_OVER_CALIBRATION`]) that
//!   tells "the model fits" from "the model misses something".
//!
//! Residuals are given on the objective's time grid; NaN marks a missing measurement and is
//! left out (a window or a lag with no pair of valid samples contributes nothing).

use serde::{Deserialize, Serialize};

/// Lags of the Ljung–Box test: 20, or fewer for short series.
pub const LJUNG_BOX_LAGS: usize = 20;

/// The RMS of the residual between two times.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct WindowRms {
    pub start_time: f64,
    pub stop_time: f64,
    pub rms: f64,
    /// Valid (non-NaN) residuals in the window.
    pub samples: usize,
}

/// RMS of `residual` over `count` windows of equal length spanning `time`, worst first
/// (windows without a valid sample are left out).
pub fn windows(time: &[f64], residual: &[f64], count: usize) -> Vec<WindowRms> {
    let (Some(&t0), Some(&t1)) = (time.first(), time.last()) else { return vec![] };
    let count = count.max(1);
    let width = (t1 - t0) / count as f64;
    let mut sums = vec![(0.0, 0usize); count];
    for (t, r) in time.iter().zip(residual) {
        if r.is_nan() {
            continue;
        }
        let k = if width > 0.0 { (((t - t0) / width) as usize).min(count - 1) } else { 0 };
        sums[k].0 += r * r;
        sums[k].1 += 1;
    }
    let mut out: Vec<WindowRms> = sums
        .into_iter()
        .enumerate()
        .filter(|(_, (_, n))| *n > 0)
        .map(|(k, (s, n))| WindowRms {
            start_time: t0 + k as f64 * width,
            stop_time: if k + 1 == count { t1 } else { t0 + (k + 1) as f64 * width },
            rms: (s / n as f64).sqrt(),
            samples: n,
        })
        .collect();
    out.sort_by(|a, b| b.rms.total_cmp(&a.rms));
    out
}

/// The Ljung–Box whiteness test of a residual.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LjungBox {
    /// Lags used (h).
    pub lags: usize,
    pub statistic: f64,
    /// P(χ²ₕ ≥ statistic): near 0 when the residual is not white.
    pub p_value: f64,
}

/// Sample autocorrelation of `x` at lags 1..=`lags`, NaN samples left out of every product.
fn autocorrelations(x: &[f64], lags: usize) -> Vec<f64> {
    let valid: Vec<f64> = x.iter().copied().filter(|v| !v.is_nan()).collect();
    let mean = valid.iter().sum::<f64>() / valid.len().max(1) as f64;
    let c0: f64 = valid.iter().map(|v| (v - mean).powi(2)).sum();
    (1..=lags)
        .map(|k| {
            let ck: f64 = x
                .iter()
                .zip(&x[k.min(x.len())..])
                .filter(|(a, b)| !a.is_nan() && !b.is_nan())
                .map(|(a, b)| (a - mean) * (b - mean))
                .sum();
            if c0 > 0.0 { ck / c0 } else { 0.0 }
        })
        .collect()
}

/// Ljung–Box over the first `lags` lags (at most n − 1); `None` with fewer than 3 valid samples.
pub fn ljung_box(residual: &[f64], lags: usize) -> Option<LjungBox> {
    let n = residual.iter().filter(|v| !v.is_nan()).count();
    if n < 3 {
        return None;
    }
    let lags = lags.clamp(1, n - 1);
    let rho = autocorrelations(residual, lags);
    let nf = n as f64;
    let statistic = nf * (nf + 2.0) * rho.iter().enumerate().map(|(i, r)| r * r / (nf - (i + 1) as f64)).sum::<f64>();
    Some(LjungBox { lags, statistic, p_value: chi_squared_survival(statistic, lags as f64) })
}

/// The standard deviation of the white noise in a residual that varies slowly from sample to
/// sample: (r_{i+1} − r_i)² ≈ 2σ² for white noise, and its median ignores the few jumps (where
/// one output's residual ends and the next begins, events). The median of χ²₁ is 0.4549…, so
/// σ² = median(d²)/(2·0.4549). 0 without two consecutive valid samples.
pub fn noise_sigma(r: &[f64]) -> f64 {
    let mut d2: Vec<f64> = r.windows(2).map(|w| (w[1] - w[0]).powi(2)).filter(|v| v.is_finite()).collect();
    if d2.is_empty() {
        return 0.0;
    }
    d2.sort_by(f64::total_cmp);
    let median = if d2.len() % 2 == 1 { d2[d2.len() / 2] } else { 0.5 * (d2[d2.len() / 2 - 1] + d2[d2.len() / 2]) };
    (median / (2.0 * 0.454_936_423_119_572_8)).sqrt()
}

/// A fit whose calibration RMS is more than this multiple of the noise estimate leaves more
/// than noise: at 1.3 the misfit itself is 0.83 times the noise, and white noise of 500
/// samples or more estimates its own level within a few percent.
pub const FAR_RMS_OVER_NOISE: f64 = 1.3;
/// A Ljung–Box p-value below this says the residual is strongly non-white.
pub const FAR_LJUNG_BOX_P: f64 = 1e-4;
/// A held-out RMS above this multiple of the calibration RMS says the fit does not carry over.
pub const FAR_VALIDATION_OVER_CALIBRATION: f64 = 1.5;
/// The smallest noise level assumed, as a fraction of the measured output's range: on
/// noise-free (synthetic) data the integrator's own smooth error must not read as a misfit.
pub const NOISE_FLOOR: f64 = 1e-6;

/// How far one output's fit is from its noise.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct OutputMisfit {
    pub variable: String,
    /// RMS of the residual on the calibration window, and on the validation window if any.
    #[serde(with = "crate::optim::serde_float")]
    pub rms: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub validation_rms: Option<f64>,
    /// The noise estimate ([`noise_sigma`]) of the calibration residual.
    #[serde(with = "crate::optim::serde_float")]
    pub noise: f64,
    pub ljung_box_p: Option<f64>,
}

impl OutputMisfit {
    /// The fit of `variable` from its residuals on the calibration and validation windows
    /// (NaN where missing); `range` is the measured output's range (for [`NOISE_FLOOR`]).
    pub fn new(variable: &str, calibration: &[f64], validation: &[f64], range: f64) -> OutputMisfit {
        let rms = |r: &[f64]| {
            let valid: Vec<f64> = r.iter().copied().filter(|v| v.is_finite()).collect();
            (!valid.is_empty()).then(|| (valid.iter().map(|v| v * v).sum::<f64>() / valid.len() as f64).sqrt())
        };
        OutputMisfit {
            variable: variable.to_owned(),
            rms: rms(calibration).unwrap_or(0.0),
            validation_rms: rms(validation),
            noise: noise_sigma(calibration).max(NOISE_FLOOR * range.abs()),
            ljung_box_p: ljung_box(calibration, LJUNG_BOX_LAGS).map(|l| l.p_value),
        }
    }

    /// The calibration RMS over the noise estimate (infinite on a noise-free residual that is
    /// not zero).
    pub fn rms_over_noise(&self) -> f64 {
        if self.noise > 0.0 {
            self.rms / self.noise
        } else if self.rms > 0.0 {
            f64::INFINITY
        } else {
            1.0
        }
    }

    /// Far from the noise: an RMS above [`FAR_RMS_OVER_NOISE`] × the noise, and a residual
    /// that is strongly non-white or a held-out error well above the calibration error.
    pub fn far(&self) -> bool {
        let non_white = self.ljung_box_p.is_some_and(|p| p < FAR_LJUNG_BOX_P);
        let not_carried = self.validation_rms.is_some_and(|v| v > FAR_VALIDATION_OVER_CALIBRATION * self.rms);
        self.rms_over_noise() > FAR_RMS_OVER_NOISE && (non_white || not_carried)
    }

    /// The evidence in words: "mass.x: RMS 8.100 × the noise estimate 1.2e-2, Ljung–Box p =
    /// 3.0e-205, held-out RMS 2.30 × the calibration RMS".
    pub fn evidence(&self) -> String {
        let mut parts = vec![format!("RMS {:.3} × the noise estimate {:.3e}", self.rms_over_noise(), self.noise)];
        if let Some(p) = self.ljung_box_p {
            parts.push(format!("Ljung–Box p = {p:.1e}"));
        }
        if let Some(v) = self.validation_rms.filter(|_| self.rms > 0.0) {
            parts.push(format!("held-out RMS {:.2} × the calibration RMS", v / self.rms));
        }
        format!("{}: {}", self.variable, parts.join(", "))
    }
}

/// How far a fit is from its noise, output by output.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Misfit {
    pub outputs: Vec<OutputMisfit>,
}

impl Misfit {
    /// Whether any output is far from its noise ([`OutputMisfit::far`]).
    pub fn far(&self) -> bool {
        self.outputs.iter().any(OutputMisfit::far)
    }

    /// The evidence of every output, the far ones first.
    pub fn evidence(&self) -> String {
        let mut o: Vec<&OutputMisfit> = self.outputs.iter().collect();
        o.sort_by_key(|m| !m.far());
        o.iter().map(|m| m.evidence()).collect::<Vec<_>>().join("; ")
    }
}

/// Pearson correlation of `a` and `b` over the samples where both are valid; 0 when either is
/// constant there or fewer than 2 pairs remain.
pub fn correlation(a: &[f64], b: &[f64]) -> f64 {
    let pairs: Vec<(f64, f64)> =
        a.iter().zip(b).filter(|(x, y)| !x.is_nan() && !y.is_nan()).map(|(x, y)| (*x, *y)).collect();
    if pairs.len() < 2 {
        return 0.0;
    }
    let n = pairs.len() as f64;
    let (ma, mb) = (pairs.iter().map(|p| p.0).sum::<f64>() / n, pairs.iter().map(|p| p.1).sum::<f64>() / n);
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for (x, y) in &pairs {
        sab += (x - ma) * (y - mb);
        saa += (x - ma).powi(2);
        sbb += (y - mb).powi(2);
    }
    if saa > 0.0 && sbb > 0.0 { sab / (saa * sbb).sqrt() } else { 0.0 }
}

/// P(X ≥ x) for X ~ χ² with `k` degrees of freedom: the regularized upper incomplete gamma
/// Q(k/2, x/2), by its series below a + 1 and its continued fraction above (Lentz).
pub fn chi_squared_survival(x: f64, k: f64) -> f64 {
    if x.is_nan() || k <= 0.0 {
        return f64::NAN;
    }
    if x <= 0.0 {
        return 1.0;
    }
    let (a, x) = (k / 2.0, x / 2.0);
    let log_prefactor = a * x.ln() - x - ln_gamma(a);
    if x < a + 1.0 {
        // P(a, x) = e^{-x} x^a / Γ(a) Σ xⁿ / (a (a+1) … (a+n))
        let (mut term, mut sum, mut ap) = (1.0 / a, 1.0 / a, a);
        for _ in 0..10_000 {
            ap += 1.0;
            term *= x / ap;
            sum += term;
            if term.abs() < sum.abs() * 1e-16 {
                break;
            }
        }
        (1.0 - sum * log_prefactor.exp()).max(0.0)
    } else {
        let tiny = 1e-300;
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / tiny;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..10_000 {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < tiny {
                d = tiny;
            }
            c = b + an / c;
            if c.abs() < tiny {
                c = tiny;
            }
            d = 1.0 / d;
            let delta = d * c;
            h *= delta;
            if (delta - 1.0).abs() < 1e-16 {
                break;
            }
        }
        (log_prefactor.exp() * h).clamp(0.0, 1.0)
    }
}

/// ln Γ(x) for x > 0 (Lanczos, g = 7, n = 9; relative error below 1e-15).
fn ln_gamma(x: f64) -> f64 {
    const G: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        // Reflection: Γ(x) Γ(1 − x) = π / sin(πx).
        return (std::f64::consts::PI / (std::f64::consts::PI * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let t = x + 7.5;
    let sum = G[0] + G.iter().enumerate().skip(1).map(|(i, g)| g / (x + i as f64)).sum::<f64>();
    0.5 * (2.0 * std::f64::consts::PI).ln() + (x + 0.5) * t.ln() - t + sum.ln()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A deterministic standard normal sequence (Box–Muller on a linear congruential generator).
    fn gaussian(n: usize, seed: u64) -> Vec<f64> {
        let mut state = seed;
        let mut uniform = || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
        };
        (0..n).map(|_| (-2.0 * uniform().ln()).sqrt() * (std::f64::consts::TAU * uniform()).cos()).collect()
    }

    #[test]
    fn far_needs_more_than_noise_and_a_pattern() {
        let m = |rms: f64, validation: f64, p: f64| OutputMisfit {
            variable: "y".into(),
            rms,
            validation_rms: Some(validation),
            noise: 1.0,
            ljung_box_p: Some(p),
        };
        assert!(m(1.4, 1.4, 1e-9).far(), "above the noise and not white");
        assert!(m(1.4, 2.2, 0.5).far(), "above the noise and not carried over");
        assert!(!m(1.2, 3.0, 1e-9).far(), "within the noise");
        assert!(!m(3.0, 3.1, 0.2).far(), "large but white and carried over: the noise estimate is off");
    }

    #[test]
    fn white_noise_is_near_its_noise_and_a_slow_misfit_is_far() {
        let n = 2000;
        let noise: Vec<f64> = gaussian(n, 7).iter().map(|e| 0.01 * e).collect();
        // The noise estimate recovers σ within a few percent.
        assert!((noise_sigma(&noise) / 0.01 - 1.0).abs() < 0.06, "{}", noise_sigma(&noise));
        let fits = OutputMisfit::new("y", &noise[..1500], &noise[1500..], 1.0);
        assert!(!fits.far() && fits.rms_over_noise() < 1.2, "{fits:?}");
        // A slow misfit of 5 σ on top: the noise estimate barely moves, the RMS does.
        let misfit: Vec<f64> = noise.iter().enumerate().map(|(i, e)| e + 0.05 * (i as f64 * 0.01).sin()).collect();
        let m = OutputMisfit::new("y", &misfit[..1500], &misfit[1500..], 1.0);
        // Noise-free data: a smooth error of the integrator's size is not a misfit.
        let smooth: Vec<f64> = (0..2000).map(|i| 1e-9 * (i as f64 * 0.01).sin()).collect();
        assert!(!OutputMisfit::new("y", &smooth[..1500], &smooth[1500..], 1.0).far());
        assert!(m.far(), "{m:?}");
        assert!(m.evidence().starts_with("y: RMS "), "{}", m.evidence());
        let all = Misfit { outputs: vec![fits, m] };
        assert!(all.far() && all.evidence().starts_with("y: RMS 3"), "{}", all.evidence());
    }

    #[test]
    fn chi_squared_survival_matches_closed_forms() {
        // k = 2: P(X ≥ x) = e^{-x/2}; k = 1: erfc(√(x/2)), here at x = 3.841458820694124
        // (the 95 % quantile) it is 0.05.
        for x in [0.1, 1.0, 2.5, 10.0, 40.0] {
            let want = (-x / 2.0f64).exp();
            assert!((chi_squared_survival(x, 2.0) - want).abs() < 1e-14 * want.max(1e-300) + 1e-16, "{x}");
        }
        assert!((chi_squared_survival(3.841_458_820_694_124, 1.0) - 0.05).abs() < 1e-13);
        // k = 4: e^{-x/2} (1 + x/2).
        for x in [0.5, 3.0, 20.0] {
            let want = (-x / 2.0f64).exp() * (1.0 + x / 2.0);
            assert!((chi_squared_survival(x, 4.0) - want).abs() < 1e-13, "{x}");
        }
        assert_eq!(chi_squared_survival(0.0, 3.0), 1.0);
    }

    #[test]
    fn ljung_box_by_hand_on_a_short_series() {
        // x = [1, -1, 1, -1]: mean 0, c0 = 4, c1 = -3, c2 = 2; n = 4, h = 2:
        // Q = 4·6·((−3/4)²/3 + (2/4)²/2) = 24·(0.1875 + 0.125) = 7.5.
        let lb = ljung_box(&[1.0, -1.0, 1.0, -1.0], 2).unwrap();
        assert!((lb.statistic - 7.5).abs() < 1e-12, "{lb:?}");
        assert!((lb.p_value - (-7.5f64 / 2.0).exp()).abs() < 1e-14);
        assert!(ljung_box(&[1.0, f64::NAN], 5).is_none());
    }

    #[test]
    fn structure_in_the_residual_gives_a_small_p_value_and_noise_does_not() {
        let drift: Vec<f64> = (0..200).map(|i| (i as f64 / 30.0).sin()).collect();
        assert!(ljung_box(&drift, 10).unwrap().p_value < 1e-10);
        // Uniform noise from a fixed xorshift64* sequence.
        let mut state = 0x9E37_79B9_7F4A_7C15u64;
        let noise: Vec<f64> = (0..500)
            .map(|_| {
                state ^= state >> 12;
                state ^= state << 25;
                state ^= state >> 27;
                (state.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 / (1u64 << 53) as f64 - 0.5
            })
            .collect();
        let lb = ljung_box(&noise, 10).unwrap();
        assert!(lb.p_value > 0.05, "{lb:?}");
    }

    #[test]
    fn windows_rank_the_worst_span_first_and_skip_missing_samples() {
        let time: Vec<f64> = (0..=10).map(f64::from).collect();
        let mut r = vec![0.1; 11];
        r[7] = 2.0;
        r[8] = f64::NAN;
        let w = windows(&time, &r, 5);
        assert_eq!(w.len(), 5);
        assert_eq!((w[0].start_time, w[0].stop_time), (6.0, 8.0));
        // Window [6, 8) holds t = 6 and 7; t = 8 (missing) would belong to [8, 10].
        assert_eq!(w[0].samples, 2);
        assert!((w[0].rms - ((0.01 + 4.0) / 2.0f64).sqrt()).abs() < 1e-15);
        let last = w.iter().find(|w| w.start_time == 8.0).unwrap();
        assert_eq!((last.stop_time, last.samples), (10.0, 2));
    }

    #[test]
    fn correlation_finds_the_signal_a_residual_follows() {
        let v: Vec<f64> = (0..100).map(|i| (i as f64 / 7.0).sin()).collect();
        let r: Vec<f64> = v.iter().map(|v| -0.3 * v + 0.01).collect();
        assert!((correlation(&r, &v) + 1.0).abs() < 1e-12);
        let sign: Vec<f64> = v.iter().map(|v| v.signum()).collect();
        assert!(correlation(&r, &sign) < -0.8);
        assert_eq!(correlation(&r, &vec![1.0; 100]), 0.0);
    }
}
