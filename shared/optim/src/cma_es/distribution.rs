//! The search distribution N(m, σ² C) of one local CMA-ES run and its update from a ranked
//! generation, following Hansen's tutorial (arXiv:1604.00772, section 4 and Table 1):
//! weighted recombination of the mean (c_m = 1), cumulative step-size adaptation (CSA) with the
//! path p_σ, and the covariance update from the path p_c (rank one, stalled by h_σ) and the
//! ranked steps (rank μ, with the active negative weights rescaled by k / ‖C^{−1/2} y‖²).
//!
//! C = B D² Bᵀ is decomposed lazily, every λ / ((c_1 + c_μ) k · 10) generations, with
//! nalgebra's `SymmetricEigen`; sampling and C^{−1/2} use the last decomposition. Matrices are
//! kept row-major in plain vectors, so the state serializes exactly (non-finite values too,
//! should an update degenerate).

use nalgebra::{DMatrix, SymmetricEigen};
use serde::{Deserialize, Serialize};

use super::super::random::Random;
use super::params::Params;

/// The distribution became unusable (non-finite, or C not positive definite): the local run
/// must end.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct Degenerate;

/// N(m, σ² C) and the evolution paths; see the module docs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(super) struct Distribution {
    #[serde(with = "super::super::serde_float::vec")]
    pub mean: Vec<f64>,
    #[serde(with = "super::super::serde_float")]
    pub sigma: f64,
    /// C, k × k, row-major.
    #[serde(with = "super::super::serde_float::vec")]
    pub cov: Vec<f64>,
    /// B, k × k, row-major; its columns are C's eigenvectors.
    #[serde(with = "super::super::serde_float::vec")]
    pub basis: Vec<f64>,
    /// D: the square roots of C's eigenvalues (the column order of B).
    #[serde(with = "super::super::serde_float::vec")]
    pub scales: Vec<f64>,
    #[serde(with = "super::super::serde_float::vec")]
    pub path_sigma: Vec<f64>,
    #[serde(with = "super::super::serde_float::vec")]
    pub path_c: Vec<f64>,
    /// Updates done in this local run.
    pub generation: u64,
    /// `generation` at the last eigendecomposition.
    pub eigen_generation: u64,
}

impl Distribution {
    /// N(mean, σ² I) with zero paths.
    pub fn new(mean: Vec<f64>, sigma: f64) -> Distribution {
        let k = mean.len();
        let identity: Vec<f64> = (0..k * k).map(|i| if i % (k + 1) == 0 { 1.0 } else { 0.0 }).collect();
        Distribution {
            mean,
            sigma,
            cov: identity.clone(),
            basis: identity,
            scales: vec![1.0; k],
            path_sigma: vec![0.0; k],
            path_c: vec![0.0; k],
            generation: 0,
            eigen_generation: 0,
        }
    }

    pub fn dim(&self) -> usize {
        self.mean.len()
    }

    /// A step y ~ N(0, C): B D z with z standard normal.
    pub fn sample(&self, rng: &mut Random) -> Vec<f64> {
        let k = self.dim();
        let dz: Vec<f64> = self.scales.iter().map(|d| d * rng.gaussian()).collect();
        (0..k).map(|i| (0..k).map(|j| self.basis[i * k + j] * dz[j]).sum()).collect()
    }

    /// The search point m + σ y of step `y`.
    pub fn point(&self, y: &[f64]) -> Vec<f64> {
        self.mean.iter().zip(y).map(|(m, v)| m + self.sigma * v).collect()
    }

    /// C^{−1/2} v = B D⁻¹ Bᵀ v.
    pub fn whiten(&self, v: &[f64]) -> Vec<f64> {
        let k = self.dim();
        let t: Vec<f64> =
            (0..k).map(|j| (0..k).map(|i| self.basis[i * k + j] * v[i]).sum::<f64>() / self.scales[j]).collect();
        (0..k).map(|i| (0..k).map(|j| self.basis[i * k + j] * t[j]).sum()).collect()
    }

    /// σ · max_i √C_ii: the largest standard deviation of a coordinate.
    pub fn max_std(&self) -> f64 {
        let k = self.dim();
        self.sigma * (0..k).map(|i| self.cov[i * k + i].sqrt()).fold(0.0, f64::max)
    }

    /// The condition number of C, (max D / min D)².
    pub fn condition(&self) -> f64 {
        let max = self.scales.iter().copied().fold(0.0, f64::max);
        let min = self.scales.iter().copied().fold(f64::INFINITY, f64::min);
        (max / min).powi(2)
    }

    /// One generation's update from its steps in rank order (best first, all λ of them);
    /// see the module docs. Decomposes C again when due.
    ///
    /// # Errors
    /// [`Degenerate`] if the new state is not finite or C is no longer positive definite.
    pub fn update(&mut self, ranked: &[&[f64]], p: &Params) -> Result<(), Degenerate> {
        let k = self.dim();
        let mu = p.mu();
        let mut y_w = vec![0.0; k];
        for (y, w) in ranked.iter().zip(&p.weights).take(mu) {
            for (a, v) in y_w.iter_mut().zip(y.iter()) {
                *a += w * v;
            }
        }
        for (m, v) in self.mean.iter_mut().zip(&y_w) {
            *m += self.sigma * v;
        }
        // Step-size path and the stall indicator h_σ.
        let white = self.whiten(&y_w);
        let rate_sigma = (p.c_sigma * (2.0 - p.c_sigma) * p.mu_eff).sqrt();
        for (ps, v) in self.path_sigma.iter_mut().zip(&white) {
            *ps = (1.0 - p.c_sigma) * *ps + rate_sigma * v;
        }
        self.generation += 1;
        let norm_sigma = norm(&self.path_sigma);
        let unbias = (1.0 - (1.0 - p.c_sigma).powf(2.0 * self.generation as f64)).sqrt();
        let h_sigma = norm_sigma / unbias < (1.4 + 2.0 / (k as f64 + 1.0)) * p.chi_n;
        let rate_c = if h_sigma { (p.c_c * (2.0 - p.c_c) * p.mu_eff).sqrt() } else { 0.0 };
        for (pc, v) in self.path_c.iter_mut().zip(&y_w) {
            *pc = (1.0 - p.c_c) * *pc + rate_c * v;
        }
        // Covariance: decay, rank one, rank μ (negative weights rescaled).
        let stall = if h_sigma { 0.0 } else { p.c_c * (2.0 - p.c_c) };
        let weight_sum: f64 = p.weights.iter().sum();
        let decay = 1.0 + p.c_1 * stall - p.c_1 - p.c_mu * weight_sum;
        let rank_mu: Vec<(f64, &[f64])> = ranked
            .iter()
            .zip(&p.weights)
            .filter(|(_, w)| **w != 0.0)
            .map(|(y, &w)| {
                if w > 0.0 {
                    return (w, *y);
                }
                let len2: f64 = self.whiten(y).iter().map(|v| v * v).sum();
                (if len2 > 0.0 { w * k as f64 / len2 } else { 0.0 }, *y)
            })
            .collect();
        for i in 0..k {
            for j in i..k {
                let mut c = decay * self.cov[i * k + j] + p.c_1 * self.path_c[i] * self.path_c[j];
                for (w, y) in &rank_mu {
                    c += p.c_mu * w * y[i] * y[j];
                }
                self.cov[i * k + j] = c;
                self.cov[j * k + i] = c;
            }
        }
        self.sigma *= ((p.c_sigma / p.d_sigma) * (norm_sigma / p.chi_n - 1.0)).exp();
        let finite = |v: &[f64]| v.iter().all(|x| x.is_finite());
        if !(self.sigma.is_finite() && self.sigma > 0.0 && finite(&self.mean) && finite(&self.cov)) {
            return Err(Degenerate);
        }
        if (self.generation - self.eigen_generation) as f64 >= p.eigen_interval {
            self.decompose()?;
        }
        Ok(())
    }

    /// Refreshes B and D from C.
    fn decompose(&mut self) -> Result<(), Degenerate> {
        let k = self.dim();
        let c = DMatrix::from_row_slice(k, k, &self.cov);
        let eig = SymmetricEigen::try_new(c, f64::EPSILON, 1000 + 100 * k).ok_or(Degenerate)?;
        if eig.eigenvalues.iter().any(|v| !(v.is_finite() && *v > 0.0)) {
            return Err(Degenerate);
        }
        for i in 0..k {
            for j in 0..k {
                self.basis[i * k + j] = eig.eigenvectors[(i, j)];
            }
        }
        self.scales = eig.eigenvalues.iter().map(|v| v.sqrt()).collect();
        self.eigen_generation = self.generation;
        Ok(())
    }
}

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn samples_follow_the_covariance_after_a_decomposition() {
        let mut d = Distribution::new(vec![0.0, 0.0], 1.0);
        d.cov = vec![4.0, 1.2, 1.2, 1.0];
        d.decompose().unwrap();
        let mut rng = Random::new(1);
        let n = 100_000;
        let mut s = [0.0; 3];
        for _ in 0..n {
            let y = d.sample(&mut rng);
            s[0] += y[0] * y[0];
            s[1] += y[0] * y[1];
            s[2] += y[1] * y[1];
        }
        let est: Vec<f64> = s.iter().map(|v| v / n as f64).collect();
        assert!((est[0] - 4.0).abs() < 0.08 && (est[1] - 1.2).abs() < 0.04 && (est[2] - 1.0).abs() < 0.02, "{est:?}");
        // C^{-1/2} whitens: ‖C^{-1/2} y‖² = yᵀ C⁻¹ y.
        let y = [1.0, -2.0];
        let w = d.whiten(&y);
        let det = 4.0 - 1.44;
        let quad = (1.0 * y[0] * y[0] - 2.0 * 1.2 * y[0] * y[1] + 4.0 * y[1] * y[1]) / det;
        assert!((w[0] * w[0] + w[1] * w[1] - quad).abs() < 1e-12);
    }

    #[test]
    fn the_covariance_learns_the_inverse_hessian_of_an_ellipsoid() {
        let p = Params::new(2, 6);
        let mut d = Distribution::new(vec![1.0, 1.0], 0.5);
        let mut rng = Random::new(4);
        let f = |x: &[f64]| x[0] * x[0] + 100.0 * x[1] * x[1];
        for _ in 0..150 {
            let mut ys: Vec<Vec<f64>> = (0..p.lambda).map(|_| d.sample(&mut rng)).collect();
            ys.sort_by(|a, b| f(&d.point(a)).total_cmp(&f(&d.point(b))));
            let ranked: Vec<&[f64]> = ys.iter().map(Vec::as_slice).collect();
            d.update(&ranked, &p).unwrap();
        }
        let ratio = d.cov[0] / d.cov[3];
        assert!((30.0..300.0).contains(&ratio), "C₀₀ / C₁₁ = {ratio}, want about 100");
        assert!(f(&d.mean) < 1e-6 && d.sigma < 1e-2, "m = {:?}, σ = {}", d.mean, d.sigma);
    }
}
