//! Practical identifiability at the optimum: the Jacobian J of the weighted residuals by
//! central differences (one batch of 2n+1 points, one-sided at a bound) with a step of 1e-3
//! relative — large enough that the integrator's own error does not swamp the difference — the covariance s²(JᵀJ)⁻¹ with
//! s² = Σr²/(m − n), the parameters' standard errors and their correlation matrix. Correlations
//! near ±1 mean the data cannot tell the parameters apart (the paper's over-parameterization
//! remark about fitting both exhaust volumes at once).

use std::sync::Arc;

use serde::{Deserialize, Serialize};

use super::JobError;
use super::pool::EvaluatorPool;
use super::prepared::PreparedJob;
use super::result::EvaluatedPoint;
use crate::fmu::Fmu;

/// Standard errors and correlations of the calibrated parameters.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Identifiability {
    pub names: Vec<String>,
    /// Standard error of each parameter (user units).
    pub standard_errors: Vec<f64>,
    /// Correlation matrix, rows and columns in `names` order.
    pub correlation: Vec<Vec<f64>>,
    /// Residuals used (m) and the finite-difference distances (x₊ − x₋) per parameter.
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

/// The points of the finite-difference Jacobian: x first, then for each parameter a pair
/// x ± hᵢeᵢ, kept inside the bounds (one-sided at a bound).
#[derive(Debug, Clone, PartialEq)]
pub struct DifferencePlan {
    pub points: Vec<Vec<f64>>,
    /// Per parameter: (index of the upper point, index of the lower point, their distance).
    pub pairs: Vec<(usize, usize, f64)>,
}

/// The finite-difference step of a parameter at `x` within [lower, upper]: 1e-3 relative (of
/// |x|, or of the range for x near 0), large enough that the integrator's error does not swamp
/// the difference.
pub fn relative_step(x: f64, lower: f64, upper: f64) -> f64 {
    1e-3 * x.abs().max(1e-3 * (upper - lower).abs().min(1.0)).max(1e-12)
}

/// The points to evaluate at the optimum `x` of `job`.
pub fn difference_points(job: &PreparedJob, x: &[f64]) -> DifferencePlan {
    let (_, _, lower, upper) = job.spec.parameter_vectors();
    let mut points = vec![x.to_vec()];
    let mut pairs = vec![];
    for i in 0..x.len() {
        let h = relative_step(x[i], lower[i], upper[i]);
        let hi = (x[i] + h).min(upper[i]);
        let lo = (x[i] - h).max(lower[i]);
        for v in [hi, lo] {
            let mut p = x.to_vec();
            p[i] = v;
            points.push(p);
        }
        pairs.push((points.len() - 2, points.len() - 1, hi - lo));
    }
    DifferencePlan { points, pairs }
}

/// The linearised least-squares problem at the optimum: the Jacobian J of the residuals by
/// differences, (JᵀJ)⁻¹ and s² = Σr²/(m − n).
struct Linearised {
    jac: nalgebra::DMatrix<f64>,
    inv: nalgebra::DMatrix<f64>,
    s2: f64,
}

impl Linearised {
    fn new(names: &[String], plan: &DifferencePlan, residuals: &[Vec<f64>]) -> Result<Self, JobError> {
        let n = plan.pairs.len();
        if residuals.len() != plan.points.len() || residuals.iter().any(|r| r.len() != residuals[0].len()) {
            return Err(JobError::invalid("identifiability", "the residual vectors do not match the points"));
        }
        let r0 = &residuals[0];
        let m = r0.len();
        if m <= n {
            return Err(JobError::invalid("identifiability", format!("{m} residuals cannot determine {n} parameters")));
        }
        let mut jac = nalgebra::DMatrix::<f64>::zeros(m, n);
        for (i, &(up, down, dist)) in plan.pairs.iter().enumerate() {
            if dist <= 0.0 {
                return Err(JobError::invalid(
                    "identifiability",
                    format!("parameter {} has no room for a difference step", names[i]),
                ));
            }
            for k in 0..m {
                jac[(k, i)] = (residuals[up][k] - residuals[down][k]) / dist;
            }
        }
        let s2 = r0.iter().map(|v| v * v).sum::<f64>() / (m - n) as f64;
        let inv = (jac.transpose() * &jac).try_inverse().ok_or_else(|| {
            JobError::invalid("identifiability", "JᵀJ is singular: the parameters are not identifiable")
        })?;
        Ok(Linearised { jac, inv, s2 })
    }

    fn standard_errors(&self) -> Vec<f64> {
        (0..self.inv.ncols()).map(|i| (self.inv[(i, i)] * self.s2).max(0.0).sqrt()).collect()
    }
}

/// Standard errors and correlations from the residual vectors of `plan.points`.
///
/// # Errors
/// [`JobError::Invalid`] if the residual vectors do not match or JᵀJ is singular.
pub fn from_residuals(
    names: &[String],
    plan: &DifferencePlan,
    residuals: &[Vec<f64>],
) -> Result<Identifiability, JobError> {
    let lin = Linearised::new(names, plan, residuals)?;
    let n = plan.pairs.len();
    let cov = &lin.inv * lin.s2;
    let se = lin.standard_errors();
    let correlation = (0..n).map(|i| (0..n).map(|j| cov[(i, j)] / (se[i] * se[j])).collect()).collect();
    Ok(Identifiability {
        names: names.to_vec(),
        standard_errors: se,
        correlation,
        residuals: residuals[0].len(),
        steps: plan.pairs.iter().map(|p| p.2).collect(),
    })
}

/// How each estimate moves, to first order, when the residuals at the optimum change by
/// `change` (same length and order as the plan's residual vectors): the Gauss–Newton step
/// δ = −(JᵀJ)⁻¹Jᵀ·change in user units, with each parameter's standard error. The tolerance
/// guard's ‖e‖/σ bounds |δᵢ|/SEᵢ (Cauchy–Schwarz); this is its value.
///
/// # Errors
/// As [`from_residuals`], or if `change` has another length.
pub fn linearised_step(
    names: &[String],
    plan: &DifferencePlan,
    residuals: &[Vec<f64>],
    change: &[f64],
) -> Result<(Vec<f64>, Vec<f64>), JobError> {
    let lin = Linearised::new(names, plan, residuals)?;
    if change.len() != lin.jac.nrows() {
        return Err(JobError::invalid("identifiability", "the residual change does not match the residuals"));
    }
    let e = nalgebra::DVector::from_column_slice(change);
    let step = -(&lin.inv * (lin.jac.transpose() * e));
    Ok((step.iter().copied().collect(), lin.standard_errors()))
}

/// The residual vectors of an evaluated difference plan, in the order of its points.
///
/// # Errors
/// [`JobError::Invalid`] naming the first point whose simulation failed.
pub fn residuals_of(evaluated: &[EvaluatedPoint]) -> Result<Vec<Vec<f64>>, JobError> {
    evaluated
        .iter()
        .map(|e| match e.value {
            Some(_) => Ok(e.residuals.clone()),
            None => Err(JobError::invalid("identifiability", format!("a difference point failed: {}", e.message))),
        })
        .collect()
}

/// The whole analysis in this process, on `pool` (the CLI runs the points on the workers
/// instead, through an [`EvaluatePoints`](super::JobKind::EvaluatePoints) job).
///
/// # Errors
/// [`JobError::Invalid`] if an evaluation fails or JᵀJ is singular.
pub fn analyze(fmu: Arc<Fmu>, job: &PreparedJob, x: &[f64], pool: &EvaluatorPool) -> Result<Identifiability, JobError> {
    let plan = difference_points(job, x);
    let residuals = residuals_of(&super::local::evaluate(fmu, job, plan.points.clone(), pool)?)?;
    from_residuals(&job.parameter_names, &plan, &residuals)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_change_along_a_parameter_moves_it_by_that_much() {
        // r(a) = a·t − y for t = 1..m: J = t, SE(a) = s/‖t‖. A change c·t in the residuals is a
        // change −c in a, closed form.
        let m = 50;
        let t: Vec<f64> = (1..=m).map(f64::from).collect();
        let y: Vec<f64> = t.iter().enumerate().map(|(i, t)| 2.0 * t + if i % 2 == 0 { 0.1 } else { -0.1 }).collect();
        let r = |a: f64| -> Vec<f64> { t.iter().zip(&y).map(|(t, y)| a * t - y).collect() };
        let (a, h) = (2.0, 1e-3);
        let plan = DifferencePlan { points: vec![vec![a], vec![a + h], vec![a - h]], pairs: vec![(1, 2, 2.0 * h)] };
        let residuals = vec![r(a), r(a + h), r(a - h)];
        let names = vec!["a".to_owned()];
        let se = from_residuals(&names, &plan, &residuals).unwrap().standard_errors[0];
        let c = 3e-4;
        let change: Vec<f64> = t.iter().map(|t| c * t).collect();
        let (step, errors) = linearised_step(&names, &plan, &residuals, &change).unwrap();
        assert!((step[0] + c).abs() < 1e-6 * c, "{} vs {}", step[0], -c);
        assert_eq!(errors, vec![se]);
        assert!(linearised_step(&names, &plan, &residuals, &change[1..]).is_err());
    }
}
