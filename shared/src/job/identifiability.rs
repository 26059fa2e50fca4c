//! Practical identifiability at the optimum: the Jacobian J of the weighted residuals by
//! central differences (one batch of 2n+1 evaluations) with a step of 1e-3 relative — large
//! enough that the integrator's own error (relative tolerance) does not swamp the difference — the covariance s²(JᵀJ)⁻¹ with
//! s² = Σr²/(m − n), the parameters' standard errors and their correlation matrix. Correlations
//! near ±1 mean the data cannot tell the parameters apart (the paper's over-parameterization
//! remark about fitting both exhaust volumes at once).

use std::sync::Arc;

use serde::{Deserialize, Serialize};

use super::JobError;
use super::evaluator::Evaluator;
use super::objective::PreparedJob;
use crate::fmu::Fmu;

/// Standard errors and correlations of the calibrated parameters.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Identifiability {
    pub names: Vec<String>,
    /// Standard error of each parameter (user units).
    pub standard_errors: Vec<f64>,
    /// Correlation matrix, rows and columns in `names` order.
    pub correlation: Vec<Vec<f64>>,
    /// Residuals used (m) and the finite-difference steps taken.
    pub residuals: usize,
    pub steps: Vec<f64>,
}

impl Identifiability {
    /// The largest |correlation| between two different parameters.
    pub fn max_abs_correlation(&self) -> f64 {
        let n = self.names.len();
        (0..n)
            .flat_map(|i| (0..n).filter(move |&j| j != i).map(move |j| (i, j)))
            .map(|(i, j)| self.correlation[i][j].abs())
            .fold(0.0, f64::max)
    }
}

/// Evaluates the residuals at `x` and at x + hᵢeᵢ (one batch, on `threads` threads) and derives
/// standard errors and correlations.
///
/// # Errors
/// [`JobError::Invalid`] if an evaluation fails or JᵀJ is singular.
pub fn analyze(fmu: Arc<Fmu>, job: Arc<PreparedJob>, x: &[f64], threads: usize) -> Result<Identifiability, JobError> {
    let (_, _, lower, upper) = job.spec.parameter_vectors();
    let n = x.len();
    // A relative step (bounds are not enforced here: the model is smooth just past them).
    let steps: Vec<f64> =
        (0..n).map(|i| 1e-3 * x[i].abs().max(1e-3 * (upper[i] - lower[i]).abs().min(1.0)).max(1e-12)).collect();
    let mut points = vec![x.to_vec()];
    for i in 0..n {
        for sign in [1.0, -1.0] {
            let mut p = x.to_vec();
            p[i] += sign * steps[i];
            points.push(p);
        }
    }
    let results = evaluate_batch(&fmu, &job, &points, threads)?;
    let r0 = &results[0];
    let m = r0.len();
    if m <= n {
        return Err(JobError::invalid("identifiability", format!("{m} residuals cannot determine {n} parameters")));
    }
    let mut jac = nalgebra::DMatrix::<f64>::zeros(m, n);
    for i in 0..n {
        for k in 0..m {
            jac[(k, i)] = (results[1 + 2 * i][k] - results[2 + 2 * i][k]) / (2.0 * steps[i]);
        }
    }
    let s2 = r0.iter().map(|v| v * v).sum::<f64>() / (m - n) as f64;
    let jtj = jac.transpose() * &jac;
    let inv = jtj
        .try_inverse()
        .ok_or_else(|| JobError::invalid("identifiability", "JᵀJ is singular: the parameters are not identifiable"))?;
    let cov = inv * s2;
    let se: Vec<f64> = (0..n).map(|i| cov[(i, i)].max(0.0).sqrt()).collect();
    let correlation = (0..n).map(|i| (0..n).map(|j| cov[(i, j)] / (se[i] * se[j])).collect()).collect();
    Ok(Identifiability { names: job.parameter_names.clone(), standard_errors: se, correlation, residuals: m, steps })
}

/// Residual vectors of `points`, evaluated on `threads` threads with one warm instance each.
fn evaluate_batch(
    fmu: &Arc<Fmu>,
    job: &Arc<PreparedJob>,
    points: &[Vec<f64>],
    threads: usize,
) -> Result<Vec<Vec<f64>>, JobError> {
    let chunks: Vec<Vec<(usize, Vec<f64>)>> = {
        let mut c = vec![vec![]; threads.max(1).min(points.len())];
        for (i, p) in points.iter().enumerate() {
            let k = i % c.len();
            c[k].push((i, p.clone()));
        }
        c
    };
    let mut out: Vec<Option<Result<Vec<f64>, String>>> = vec![None; points.len()];
    std::thread::scope(|scope| {
        let handles: Vec<_> = chunks
            .into_iter()
            .map(|chunk| {
                let (fmu, job) = (fmu.clone(), job.clone());
                scope.spawn(move || {
                    let mut ev = Evaluator::new(&fmu, job).map_err(|e| e.to_string());
                    chunk
                        .into_iter()
                        .map(|(i, p)| {
                            let r = match ev.as_mut() {
                                Ok(ev) => {
                                    let e = ev.evaluate(&p, true);
                                    e.residuals.ok_or(e.error.unwrap_or_else(|| "no residuals".into()))
                                }
                                Err(e) => Err(e.clone()),
                            };
                            (i, r)
                        })
                        .collect::<Vec<_>>()
                })
            })
            .collect();
        for h in handles {
            for (i, r) in h.join().unwrap_or_default() {
                out[i] = Some(r);
            }
        }
    });
    out.into_iter()
        .map(|r| match r {
            Some(Ok(v)) => Ok(v),
            Some(Err(e)) => Err(JobError::invalid("identifiability", format!("an evaluation failed: {e}"))),
            None => Err(JobError::invalid("identifiability", "an evaluation thread stopped")),
        })
        .collect()
}
