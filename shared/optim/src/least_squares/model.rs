//! The interpolation set of the least-squares solver and the linear model it defines
//! (Cartis & Roberts 2019, section 2): n + 1 evaluated points y₀…yₙ, one of them the centre
//! x_k (the best), give the Jacobian J of the model r(x_k + d) ≈ r(x_k) + J d by interpolation,
//! (y_t − x_k)ᵀ Jᵀ = r(y_t) − r(x_k) for every other point t.
//!
//! The linear Lagrange polynomials of the set are ℓ_t(x_k + d) = c_tᵀd for t ≠ centre (and
//! 1 − Σ c_tᵀd for the centre), where the c_t are the columns of W⁻¹ and W's rows are the
//! displacements y_t − x_k. They drive the set's upkeep:
//! - a new point y replaces the point t maximising |ℓ_t(y)| · max(1, ‖y_t − x‖/Δ)⁴ (x: the
//!   centre after y is added): the largest growth of |det W|, preferring far points; the
//!   centre is kept unless y is better;
//! - a geometry step replaces the point farthest from the centre by the point of a ball around
//!   the centre that maximises its |ℓ_t| ([`super::subproblem::geometry_step`]).
//!
//! A set with fewer than n + 1 points (after failed evaluations) gives the minimum-norm model
//! (W's pseudo-inverse); the directions it lacks are reported so that they can be filled.

// `!(a > b)` is meant: it is true when a is NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

use super::subproblem::svd;

/// An evaluated point: scaled position, residual vector and f = Σ r².
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(super) struct Sample {
    pub z: Vec<f64>,
    pub r: Vec<f64>,
    pub f: f64,
}

/// The interpolation set: at most n + 1 samples with equally long residual vectors, and the
/// index of the best one (the trust region's centre).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub(super) struct InterpolationSet {
    pub points: Vec<Sample>,
    pub centre: usize,
}

/// The linear model of the residuals around the centre, and the set's Lagrange polynomials.
#[derive(Debug, Clone)]
pub(super) struct Model {
    /// J, m × n.
    pub jacobian: DMatrix<f64>,
    /// r(x_k).
    pub r: DVector<f64>,
    /// The indices t ≠ centre, in order.
    pub others: Vec<usize>,
    /// Column k is c_t for t = others[k] (n × others.len()).
    pub lagrange: DMatrix<f64>,
    /// Unit directions orthogonal to every displacement: what an incomplete or degenerate set
    /// lacks.
    pub missing: Vec<DVector<f64>>,
}

/// Singular values below this fraction of the largest count as zero.
const RANK_TOL: f64 = 1e-13;

impl InterpolationSet {
    pub fn centre(&self) -> &Sample {
        &self.points[self.centre]
    }

    pub fn dim(&self) -> usize {
        self.centre().z.len()
    }

    /// y_t − x_k.
    fn displacement(&self, t: usize) -> DVector<f64> {
        let (y, x) = (&self.points[t].z, &self.centre().z);
        DVector::from_iterator(y.len(), y.iter().zip(x).map(|(a, b)| a - b))
    }

    /// The model at the centre; see the module docs.
    pub fn model(&self) -> Model {
        let n = self.dim();
        let centre = self.centre();
        let m = centre.r.len();
        let r = DVector::from_column_slice(&centre.r);
        let others: Vec<usize> = (0..self.points.len()).filter(|&t| t != self.centre).collect();
        let p = others.len();
        let identity = || (0..n).map(|i| DVector::from_fn(n, |k, _| if k == i { 1.0 } else { 0.0 })).collect();
        let empty = |others: Vec<usize>| Model {
            jacobian: DMatrix::zeros(m, n),
            r: r.clone(),
            lagrange: DMatrix::zeros(n, others.len()),
            others,
            missing: identity(),
        };
        if p == 0 {
            return empty(others);
        }
        // W padded with zero rows to at least n rows, so that V spans all of ℝⁿ.
        let rows = p.max(n);
        let mut w = DMatrix::zeros(rows, n);
        let mut dr = DMatrix::zeros(rows, m);
        for (k, &t) in others.iter().enumerate() {
            w.set_row(k, &self.displacement(t).transpose());
            for (i, (a, b)) in self.points[t].r.iter().zip(&centre.r).enumerate() {
                dr[(k, i)] = a - b;
            }
        }
        let Some(svd) = svd(w) else { return empty(others) };
        let (Some(u), Some(v_t)) = (svd.u.as_ref(), svd.v_t.as_ref()) else { return empty(others) };
        let s = &svd.singular_values;
        let s_max = s.max();
        // W⁺ = V Σ⁺ Uᵀ (n × rows).
        let mut sigma_inv = DMatrix::zeros(s.len(), s.len());
        let mut missing = vec![];
        for (k, &sk) in s.iter().enumerate() {
            if sk > RANK_TOL * s_max && sk > 0.0 {
                sigma_inv[(k, k)] = 1.0 / sk;
            } else {
                missing.push(v_t.row(k).transpose().normalize());
            }
        }
        let w_pinv = v_t.transpose() * sigma_inv * u.transpose();
        let jacobian = (&w_pinv * dr).transpose();
        if jacobian.iter().any(|v| !v.is_finite()) {
            return empty(others);
        }
        let lagrange = w_pinv.columns(0, p).into_owned();
        Model { jacobian, r, others, lagrange, missing }
    }

    /// The point farthest from the centre (not the centre) and its distance.
    pub fn farthest(&self) -> Option<(usize, f64)> {
        (0..self.points.len())
            .filter(|&t| t != self.centre)
            .map(|t| (t, self.displacement(t).norm()))
            .max_by(|a, b| a.1.total_cmp(&b.1).then(b.0.cmp(&a.0)))
    }

    /// The index of the point at `z`, if it is in the set.
    pub fn find(&self, z: &[f64]) -> Option<usize> {
        self.points.iter().position(|p| p.z == z)
    }

    /// Puts `y` in place of point t (a geometry step); it becomes the centre if better.
    pub fn replace(&mut self, t: usize, y: Sample) {
        let better = y.f < self.centre().f;
        self.points[t] = y;
        if better {
            self.centre = t;
        }
    }

    /// Adds an evaluated point (see the module docs): appended while the set is incomplete and
    /// y adds a direction, else it replaces the point that keeps the set best poised. Returns
    /// false (and leaves the set as it was) if y would make the set degenerate.
    pub fn insert(&mut self, y: Sample, delta: f64) -> bool {
        if self.points.is_empty() {
            self.points.push(y);
            self.centre = 0;
            return true;
        }
        let n = self.dim();
        let better = y.f < self.centre().f;
        let d = DVector::from_iterator(n, y.z.iter().zip(&self.centre().z).map(|(a, b)| a - b));
        let d_norm = d.norm();
        if !(d_norm > 0.0) {
            // The centre itself (or no displacement): keep the better of the two.
            if better {
                self.points[self.centre] = y;
            }
            return better;
        }
        let model = self.model();
        let outside: f64 = model.missing.iter().map(|q| q.dot(&d).powi(2)).sum::<f64>().sqrt();
        if self.points.len() < n + 1 && outside >= 1e-3 * d_norm {
            self.points.push(y);
            if better {
                self.centre = self.points.len() - 1;
            }
            return true;
        }
        // ℓ_t(y) for the others, and for the centre 1 − Σ ℓ_t(y).
        let ell_others = model.lagrange.transpose() * &d;
        let new_centre = if better { y.z.clone() } else { self.centre().z.clone() };
        let weight = |t: usize| {
            let dist: f64 = self.points[t].z.iter().zip(&new_centre).map(|(a, b)| (a - b).powi(2)).sum::<f64>().sqrt();
            (dist / delta).max(1.0).powi(4)
        };
        let mut candidates: Vec<(f64, usize)> =
            model.others.iter().enumerate().map(|(k, &t)| (ell_others[k].abs() * weight(t), t)).collect();
        if better {
            let ell_centre = 1.0 - ell_others.sum();
            candidates.push((ell_centre.abs() * weight(self.centre), self.centre));
        }
        let Some((score, t)) =
            candidates.into_iter().filter(|c| c.0.is_finite()).max_by(|a, b| a.0.total_cmp(&b.0).then(b.1.cmp(&a.1)))
        else {
            return false;
        };
        if !(score > 1e-10) {
            return false;
        }
        self.points[t] = y;
        if better {
            self.centre = t;
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(z: &[f64], r: impl Fn(&[f64]) -> Vec<f64>) -> Sample {
        let r = r(z);
        let f = r.iter().map(|v| v * v).sum();
        Sample { z: z.to_vec(), r, f }
    }

    fn linear(z: &[f64]) -> Vec<f64> {
        vec![1.0 + 2.0 * z[0] - z[1], 3.0 * z[1], z[0] + z[1] - 0.5]
    }

    #[test]
    fn the_model_of_linear_residuals_is_exact() {
        let mut set = InterpolationSet::default();
        for z in [[0.5, 0.5], [0.6, 0.5], [0.5, 0.7]] {
            set.insert(sample(&z, linear), 0.1);
        }
        let m = set.model();
        let expected = DMatrix::from_row_slice(3, 2, &[2.0, -1.0, 0.0, 3.0, 1.0, 1.0]);
        assert!((m.jacobian - expected).norm() < 1e-12);
        assert!(m.missing.is_empty());
        // ℓ_t(y_s) = δ_ts.
        for (k, &t) in m.others.iter().enumerate() {
            for (k2, &t2) in m.others.iter().enumerate() {
                let d = set.displacement(t2);
                let v = m.lagrange.column(k).dot(&d);
                assert!((v - if k == k2 { 1.0 } else { 0.0 }).abs() < 1e-12, "ℓ_{t}(y_{t2}) = {v}");
            }
        }
    }

    #[test]
    fn an_incomplete_set_reports_the_missing_directions() {
        let mut set = InterpolationSet::default();
        set.insert(sample(&[0.0, 0.0, 0.0], linear_3), 1.0);
        set.insert(sample(&[0.0, 1.0, 0.0], linear_3), 1.0);
        let m = set.model();
        assert_eq!(m.missing.len(), 2);
        for q in &m.missing {
            assert!(q[1].abs() < 1e-12);
        }
        // A point along the same direction cannot complete it.
        assert_eq!(set.points.len(), 2);
        set.insert(sample(&[0.0, 0.0, 1.0], linear_3), 1.0);
        assert_eq!((set.points.len(), set.model().missing.len()), (3, 1));
    }

    fn linear_3(z: &[f64]) -> Vec<f64> {
        vec![z[0] + 1.0, z[1] - z[2], 2.0 * z[2]]
    }

    #[test]
    fn a_better_point_becomes_the_centre_and_the_farthest_point_is_found() {
        let mut set = InterpolationSet::default();
        for z in [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]] {
            set.insert(sample(&z, |z| vec![z[0] - 0.1, z[1] - 0.1]), 1.0);
        }
        assert_eq!(set.centre().z, vec![0.0, 0.0]);
        set.insert(sample(&[0.1, 0.1], |z| vec![z[0] - 0.1, z[1] - 0.1]), 0.1);
        assert_eq!(set.centre().z, vec![0.1, 0.1]);
        assert_eq!(set.points.len(), 3);
        let (t, dist) = set.farthest().unwrap();
        assert_ne!(t, set.centre);
        assert!(dist > 0.9, "{dist}");
    }
}
