//! The localise step of a diagnosis: per output, the residual's RMS, its worst time windows,
//! its whiteness (Ljung–Box) and its correlation with every readable candidate signal and that
//! signal's sign, strongest first. Pure: it takes the residuals and signals on the calibration
//! window's time grid.

use serde::{Deserialize, Serialize};

use fmucal_shared::residuals::{LJUNG_BOX_LAGS, LjungBox, WindowRms, correlation, ljung_box, windows};

/// The correlation of an output's residual with one signal.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SignalCorrelation {
    pub signal: String,
    #[serde(with = "fmucal_shared::optim::serde_float")]
    pub correlation: f64,
    /// With sign(signal): what a Coulomb-like effect of that signal would leave.
    #[serde(with = "fmucal_shared::optim::serde_float")]
    pub sign_correlation: f64,
}

impl SignalCorrelation {
    /// The larger of the two in magnitude.
    pub fn strength(&self) -> f64 {
        self.correlation.abs().max(self.sign_correlation.abs())
    }
}

/// The residual analysis of one output.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct OutputResidual {
    pub variable: String,
    #[serde(with = "fmucal_shared::optim::serde_float")]
    pub rms: f64,
    /// Worst first.
    pub windows: Vec<WindowRms>,
    pub ljung_box: Option<LjungBox>,
    /// Strongest first.
    pub correlations: Vec<SignalCorrelation>,
}

/// The residual analysis of every output.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Localisation {
    pub outputs: Vec<OutputResidual>,
}

/// Analyses `residuals` (per output: variable and simulated − measured on `time`, NaN where
/// missing) against `signals` (name and values on `time`), in `window_count` windows.
pub fn localise(
    time: &[f64],
    residuals: &[(String, Vec<f64>)],
    signals: &[(String, Vec<f64>)],
    window_count: usize,
) -> Localisation {
    let outputs = residuals
        .iter()
        .map(|(variable, r)| {
            let valid: Vec<f64> = r.iter().copied().filter(|v| !v.is_nan()).collect();
            let rms = (valid.iter().map(|v| v * v).sum::<f64>() / valid.len().max(1) as f64).sqrt();
            let mut correlations: Vec<SignalCorrelation> = signals
                .iter()
                .map(|(name, s)| {
                    let sign: Vec<f64> = s.iter().map(|v| if v.is_nan() { f64::NAN } else { sign(*v) }).collect();
                    SignalCorrelation {
                        signal: name.clone(),
                        correlation: correlation(r, s),
                        sign_correlation: correlation(r, &sign),
                    }
                })
                .collect();
            correlations.sort_by(|a, b| b.strength().total_cmp(&a.strength()));
            OutputResidual {
                variable: variable.clone(),
                rms,
                windows: windows(time, r, window_count),
                ljung_box: ljung_box(r, LJUNG_BOX_LAGS),
                correlations,
            }
        })
        .collect();
    Localisation { outputs }
}

/// −1, 0 or 1 (0 at 0, unlike `f64::signum`).
fn sign(v: f64) -> f64 {
    if v > 0.0 {
        1.0
    } else if v < 0.0 {
        -1.0
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_residual_that_follows_the_sign_of_a_velocity_is_found_there() {
        let time: Vec<f64> = (0..1000).map(|k| k as f64 * 0.01).collect();
        let v: Vec<f64> = time.iter().map(|t| (1.3 * t).sin()).collect();
        let x: Vec<f64> = time.iter().map(|t| (0.4 * t).cos()).collect();
        // A Coulomb-like residual: a step with the velocity's sign, largest after t = 5.
        let r: Vec<f64> = time.iter().zip(&v).map(|(t, v)| if *t > 5.0 { 0.1 } else { 0.01 } * sign(*v)).collect();
        let l = localise(&time, &[("y".into(), r)], &[("x".into(), x), ("v".into(), v)], 10);
        let out = &l.outputs[0];
        assert_eq!(out.correlations[0].signal, "v");
        assert!(out.correlations[0].sign_correlation > out.correlations[0].correlation.abs());
        assert!(out.windows[0].start_time >= 5.0 - 1e-9, "{:?}", out.windows[0]);
        assert!(out.ljung_box.as_ref().unwrap().p_value < 1e-6);
    }
}
