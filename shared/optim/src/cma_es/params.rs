//! The strategy parameters of (μ/μ_w, λ)-CMA-ES for a dimension k and a population λ, as in
//! Hansen's tutorial (arXiv:1604.00772, Table 1 and equation 53): recombination weights (the
//! negative ones of active CMA included), the learning rates of the two evolution paths and of
//! the covariance matrix, the damping of the step size and E‖N(0, I)‖. They are a function of
//! (k, λ) only, so they are recomputed when needed instead of being kept in the state.

/// The parameters of one local run; see the module docs.
#[derive(Debug, Clone)]
pub(super) struct Params {
    /// Dimension k of the search (the free parameters).
    pub k: usize,
    /// Population λ.
    pub lambda: usize,
    /// Weights w_i in rank order (best first): μ positive ones summing to 1, then weights ≤ 0.
    pub weights: Vec<f64>,
    /// Variance-effective selection mass of the positive weights, μ_eff.
    pub mu_eff: f64,
    /// Learning rate of the step-size path, c_σ.
    pub c_sigma: f64,
    /// Damping of the step-size update, d_σ.
    pub d_sigma: f64,
    /// Learning rate of the covariance path, c_c.
    pub c_c: f64,
    /// Rank-one learning rate, c_1.
    pub c_1: f64,
    /// Rank-μ learning rate, c_μ.
    pub c_mu: f64,
    /// E‖N(0, I)‖ ≈ √k (1 − 1/(4k) + 1/(21k²)).
    pub chi_n: f64,
    /// Generations between two eigendecompositions of C: λ / ((c_1 + c_μ) k · 10).
    pub eigen_interval: f64,
}

impl Params {
    /// The default parameters for dimension `k` ≥ 1 and population `lambda` ≥ 2.
    pub fn new(k: usize, lambda: usize) -> Params {
        let n = k as f64;
        let mu = lambda / 2;
        let raw: Vec<f64> = (1..=lambda).map(|i| ((lambda as f64 + 1.0) / 2.0).ln() - (i as f64).ln()).collect();
        let pos: Vec<f64> = raw.iter().copied().filter(|w| *w > 0.0).collect();
        let neg: Vec<f64> = raw.iter().copied().filter(|w| *w < 0.0).collect();
        let mass = |w: &[f64]| {
            let s: f64 = w.iter().sum();
            s * s / w.iter().map(|v| v * v).sum::<f64>()
        };
        let mu_eff = mass(&pos);
        let c_sigma = (mu_eff + 2.0) / (n + mu_eff + 5.0);
        let d_sigma = 1.0 + 2.0 * (((mu_eff - 1.0) / (n + 1.0)).sqrt() - 1.0).max(0.0) + c_sigma;
        let c_c = (4.0 + mu_eff / n) / (n + 4.0 + 2.0 * mu_eff / n);
        let alpha_cov = 2.0;
        let c_1 = alpha_cov / ((n + 1.3).powi(2) + mu_eff);
        let c_mu = (1.0 - c_1)
            .min(alpha_cov * (mu_eff - 2.0 + 1.0 / mu_eff) / ((n + 2.0).powi(2) + alpha_cov * mu_eff / 2.0))
            .max(0.0);
        // Scale of the negative weights: the smallest of α_μ⁻, α_μeff⁻ and α_posdef⁻ (eq. 53).
        let neg_scale = if neg.is_empty() {
            0.0
        } else {
            let mu_eff_neg = mass(&neg);
            let alpha_mu = 1.0 + c_1 / c_mu;
            let alpha_mu_eff = 1.0 + 2.0 * mu_eff_neg / (mu_eff + 2.0);
            let alpha_posdef = (1.0 - c_1 - c_mu) / (n * c_mu);
            alpha_mu.min(alpha_mu_eff).min(alpha_posdef)
        };
        let (sum_pos, sum_neg): (f64, f64) = (pos.iter().sum(), -neg.iter().sum::<f64>());
        let weights = raw
            .iter()
            .map(|&w| if w >= 0.0 { w / sum_pos } else { neg_scale * w / sum_neg })
            .map(|w| if w.is_finite() { w } else { 0.0 })
            .collect();
        debug_assert!(mu >= 1 && pos.len() == mu);
        Params {
            k,
            lambda,
            weights,
            mu_eff,
            c_sigma,
            d_sigma,
            c_c,
            c_1,
            c_mu,
            chi_n: n.sqrt() * (1.0 - 1.0 / (4.0 * n) + 1.0 / (21.0 * n * n)),
            eigen_interval: lambda as f64 / ((c_1 + c_mu) * n * 10.0),
        }
    }

    /// The number μ of positive weights.
    pub fn mu(&self) -> usize {
        self.lambda / 2
    }
}

#[cfg(test)]
mod tests {
    use super::Params;

    /// Values of the tutorial's formulas for n = 10, λ = 10, worked out by hand.
    #[test]
    fn defaults_for_ten_dimensions_match_the_tutorial() {
        let p = Params::new(10, 10);
        assert_eq!(p.mu(), 5);
        let positive: f64 = p.weights[..5].iter().sum();
        assert!((positive - 1.0).abs() < 1e-15);
        assert!(p.weights.windows(2).all(|w| w[0] >= w[1]), "weights decrease with rank: {:?}", p.weights);
        assert!(p.weights[5..].iter().all(|w| *w <= 0.0));
        assert!((p.mu_eff - 3.1672).abs() < 1e-4, "μ_eff = {}", p.mu_eff);
        assert!((p.c_sigma - 5.1672 / 18.1672).abs() < 1e-4);
        assert!((p.c_1 - 2.0 / (11.3f64.powi(2) + p.mu_eff)).abs() < 1e-15);
        assert!((p.chi_n - 3.0847).abs() < 1e-4, "χ_n = {}", p.chi_n);
        // The negative weights sum to −min(α…) (eq. 53), and 1 − c_1 − c_μ Σw stays ≤ 1.
        let negative: f64 = p.weights[5..].iter().sum();
        assert!(negative < 0.0 && 1.0 - p.c_1 - p.c_mu * (positive + negative) <= 1.0);
    }

    #[test]
    fn parameters_are_finite_for_small_problems_and_large_populations() {
        for (k, lambda) in [(1, 4), (1, 5), (2, 6), (3, 2048), (40, 15)] {
            let p = Params::new(k, lambda);
            let all = [p.mu_eff, p.c_sigma, p.d_sigma, p.c_c, p.c_1, p.c_mu, p.chi_n, p.eigen_interval];
            assert!(all.iter().all(|v| v.is_finite() && *v > 0.0), "k {k}, λ {lambda}: {p:?}");
            assert!(p.weights.iter().all(|w| w.is_finite()) && p.c_1 + p.c_mu <= 1.0);
        }
    }
}
