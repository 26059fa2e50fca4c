//! The driver's local simulations, in this process on the FMU its caller loaded (one or two
//! simulations each, against the many the workers run): a calibrated model's fit and residuals
//! on both windows ([`look`]), and the signals a diagnosis correlates the residual with and
//! sizes its candidates by ([`signals`]).

use std::sync::Arc;

use fmucal_shared::job::{FitTable, PreparedJob, report};
use fmucal_shared::residuals::Misfit;
use fmucal_shared::sim::simulate;

use super::Context;
use crate::decision::effective_samples;
use crate::error::{Context as _, Error};
use crate::report::RmsPair;

/// A calibrated model against the measurements (the optimized model only: the diagnosis
/// never looks at the nominal one).
#[derive(Clone)]
pub struct Look {
    /// Measured, nominal and optimized outputs up to the validation stop.
    pub fit: FitTable,
    /// The calibration window's times and, per output, simulated − measured there (NaN where
    /// the measurement is missing or the simulation failed).
    pub time: Vec<f64>,
    pub residuals: Vec<(String, Vec<f64>)>,
    /// Effective samples of those residuals, and of the residuals on the validation window.
    pub n_eff: f64,
    pub validation_n_eff: f64,
    /// Weighted RMS of the optimized model on both windows.
    pub rms: RmsPair,
}

impl Look {
    /// How far this fit is from its noise, per output, on the calibration and validation windows.
    pub fn misfit(&self, calibration_stop: f64) -> Misfit {
        self.fit.misfit(calibration_stop)
    }
}

/// The fit of `job` at `x` (its parameter order).
pub fn look(ctx: &Context, job: &Arc<PreparedJob>, x: &[f64]) -> Result<Look, Error> {
    let (fit, errors) = report::compare(&ctx.fmu, job, 0, &ctx.data, x, report::Models::Optimized)?;
    let stop = ctx.windows.calibration_stop;
    let rows = fit.time.partition_point(|t| *t <= stop);
    let time = fit.time[..rows].to_vec();
    let residuals: Vec<(String, Vec<f64>)> = fit
        .outputs
        .iter()
        .map(|o| {
            let r = (0..rows).map(|i| o.optimized[i].map_or(f64::NAN, |s| s - o.measured[i])).collect();
            (o.variable.clone(), r)
        })
        .collect();
    let series: Vec<Vec<f64>> = residuals.iter().map(|(_, r)| r.clone()).collect();
    let validation: Vec<Vec<f64>> = fit
        .outputs
        .iter()
        .map(|o| (rows..fit.time.len()).map(|i| o.optimized[i].map_or(f64::NAN, |s| s - o.measured[i])).collect())
        .collect();
    let rms = RmsPair {
        calibration: errors.calibration.rms_optimized,
        validation: errors.validation.as_ref().map_or(f64::NAN, |v| v.rms_optimized),
    };
    Ok(Look {
        n_eff: effective_samples(&series),
        validation_n_eff: effective_samples(&validation),
        fit,
        time,
        residuals,
        rms,
    })
}

/// The values of the variables `names` on the calibration window's measurement times, for the
/// model of `job` at `x`.
pub fn signals(
    ctx: &Context,
    job: &PreparedJob,
    x: &[f64],
    names: &[String],
) -> Result<Vec<(String, Vec<f64>)>, Error> {
    if names.is_empty() {
        return Ok(vec![]);
    }
    let mut spec = job.single().sim_spec(x);
    spec.outputs = names.to_vec();
    let sim = simulate(&ctx.fmu, &spec).context("simulating the signals of the candidates")?;
    Ok(names.iter().zip(sim.columns).map(|(n, c)| (n.clone(), c)).collect())
}
