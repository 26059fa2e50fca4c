//! The objective of the paper's equation (1), over several outputs with weights:
//! f(x) = Σ_j w_j Σ_i (y_sim,j(t_i, x) − y_meas,j(t_i))², with y_sim taken at exactly the
//! measurement times. Missing measurements (NaN or empty cells) are skipped; rows with the same
//! time stamp (before and after an event) are averaged per column, as the 2012 `quad_err` did.
//! Measurements outside the simulated span [start, stop] are left out, so one data file can
//! serve a calibration window and a validation window.
//!
//! [`super::prepared::PreparedJob`] checks a job against its model and data once, and holds what
//! every evaluation needs: per experiment, the simulation template and these targets.

use serde::{Deserialize, Serialize};

use crate::sim::SimResult;

/// One output's targets at the unique measurement times (NaN = missing).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Target {
    pub variable: String,
    pub weight: f64,
    pub values: Vec<f64>,
}

/// The measurement side of the objective.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Objective {
    /// Unique measurement times inside the simulated span, increasing.
    pub times: Vec<f64>,
    pub targets: Vec<Target>,
}

impl Objective {
    /// Weighted residuals √w_j (y_sim − y_meas), output by output, skipping missing values.
    /// `None` if the simulation lacks an output, ended before the stop time (its last row may
    /// then be off the measurement times) or produced a non-finite value.
    pub fn residuals(&self, sim: &SimResult) -> Option<Vec<f64>> {
        if sim.terminated_early {
            return None;
        }
        let mut r = Vec::with_capacity(self.times.len() * self.targets.len());
        for t in &self.targets {
            let y = sim.column(&t.variable)?;
            if y.len() != t.values.len() {
                return None;
            }
            let s = t.weight.sqrt();
            for (ys, ym) in y.iter().zip(&t.values) {
                if ym.is_nan() {
                    continue;
                }
                let d = s * (ys - ym);
                if !d.is_finite() {
                    return None;
                }
                r.push(d);
            }
        }
        Some(r)
    }

    /// How many residuals [`Self::residuals`] gives: the measured (not missing) values.
    pub fn residual_count(&self) -> usize {
        self.targets.iter().map(|t| t.values.iter().filter(|v| !v.is_nan()).count()).sum()
    }

    /// Σ r².
    pub fn value(residuals: &[f64]) -> f64 {
        residuals.iter().map(|r| r * r).sum()
    }
}
