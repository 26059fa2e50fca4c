//! The two subproblems of the least-squares solver, both over the intersection of the box and
//! the trust region {d : ‖d‖₂ ≤ Δ, lo ≤ d ≤ hi} (steps from the centre, in scaled variables;
//! lo ≤ 0 ≤ hi because the centre lies in the box).
//!
//! - [`trust_region_step`] minimises the Gauss–Newton model ‖r + J d‖² exactly. For a
//!   Levenberg–Marquardt damping μ ≥ 0 the damped problem min ‖r + J d‖² + μ‖d‖² over the box is
//!   a bounded-variable least-squares problem, solved by a primal active-set method
//!   ([`box_least_squares`]: each free subproblem by an SVD of the free columns of J). Its
//!   solution's length decreases with μ, so μ is found by bisection (in log μ) such that
//!   ‖d(μ)‖ ≤ Δ, with ‖d(μ)‖ ≥ 0.98 Δ unless μ = 0 already fits. By the KKT conditions that
//!   is the minimiser of the model over box ∩ ball.
//! - [`geometry_step`] maximises |cᵀd| (c: a Lagrange polynomial's gradient): the maximiser of
//!   the linear function cᵀd over box ∩ ball is d(t) = clamp(t c, lo, hi) for the largest t with
//!   ‖d(t)‖ ≤ Δ, found exactly from the sorted breakpoints where components reach their bounds.

use nalgebra::{DMatrix, DVector, SVD};

/// Steps d allowed by the bounds: lo ≤ d ≤ hi, with lo ≤ 0 ≤ hi (entries may be infinite).
#[derive(Debug, Clone, PartialEq)]
pub(super) struct StepBox {
    pub lo: Vec<f64>,
    pub hi: Vec<f64>,
}

impl StepBox {
    pub fn dim(&self) -> usize {
        self.lo.len()
    }
}

/// The SVD of `m`, or `None` when it is empty, holds a non-finite value or does not converge.
pub(super) fn svd(m: DMatrix<f64>) -> Option<SVD<f64, nalgebra::Dyn, nalgebra::Dyn>> {
    if m.is_empty() || m.iter().any(|v| !v.is_finite()) {
        return None;
    }
    SVD::try_new(m, true, true, f64::EPSILON * 5.0, 10_000)
}

/// The minimiser of ‖r + J d‖² over {‖d‖ ≤ Δ} ∩ box; see the module docs. Returns the zero step
/// when the model is degenerate (no finite SVD).
pub(super) fn trust_region_step(j: &DMatrix<f64>, r: &DVector<f64>, bx: &StepBox, delta: f64) -> DVector<f64> {
    let n = bx.dim();
    let zero = DVector::zeros(n);
    let g = j.transpose() * r;
    let g_norm = g.norm();
    if !(g_norm > 0.0 && g_norm.is_finite() && delta > 0.0) {
        return zero;
    }
    let d0 = box_least_squares(j, r, 0.0, bx);
    if !d0.norm().is_finite() {
        return zero;
    }
    if d0.norm() <= delta {
        return d0;
    }
    // ‖d(μ)‖ ≤ 2‖g‖/μ (compare the damped model at d(μ) with its value 0 at d = 0), so μ_hi
    // fits; μ = 0 does not.
    let (mut lo, mut hi) = (0.0, 2.0 * g_norm / delta);
    let mut best = box_least_squares(j, r, hi, bx);
    for _ in 0..100 {
        if best.norm() >= 0.98 * delta {
            break;
        }
        let mid = if lo == 0.0 { hi * 1e-3 } else { (lo * hi).sqrt() };
        if !(mid > lo && mid < hi) {
            break;
        }
        let d = box_least_squares(j, r, mid, bx);
        if d.norm() <= delta {
            hi = mid;
            best = d;
        } else {
            lo = mid;
        }
    }
    let norm = best.norm();
    if !norm.is_finite() {
        zero
    } else if norm <= delta {
        best
    } else {
        best * (delta / norm)
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Bound {
    Free,
    Lower,
    Upper,
}

/// min ‖r + J d‖² + μ‖d‖² subject to lo ≤ d ≤ hi, by a primal active-set method from d = 0:
/// solve on the free variables (the others held at their bounds); if that point is outside the
/// box, move toward it until a variable reaches a bound and fix it; else release the fixed
/// variable whose multiplier has the wrong sign, or stop when none has. Every iterate is
/// feasible and lowers the objective, so a (never expected) iteration cap still returns a
/// feasible descent step.
pub(super) fn box_least_squares(j: &DMatrix<f64>, r: &DVector<f64>, mu: f64, bx: &StepBox) -> DVector<f64> {
    let n = bx.dim();
    let mut d = DVector::zeros(n);
    let grad = |d: &DVector<f64>| j.transpose() * (r + j * d) + d * mu;
    let g0 = grad(&d);
    let mut state: Vec<Bound> = (0..n)
        .map(|i| {
            if bx.lo[i] >= 0.0 && (g0[i] > 0.0 || bx.hi[i] <= 0.0) {
                Bound::Lower
            } else if bx.hi[i] <= 0.0 && g0[i] < 0.0 {
                Bound::Upper
            } else {
                Bound::Free
            }
        })
        .collect();
    for _ in 0..(5 * n + 20) {
        let free: Vec<usize> = (0..n).filter(|&i| state[i] == Bound::Free).collect();
        let target = if free.is_empty() { Some(vec![]) } else { solve_free(j, r, mu, &d, &free) };
        let Some(target) = target else { return d };
        // Move from d toward the free solution as far as the box allows.
        let mut alpha = 1.0;
        let mut blocking = None;
        for (k, &i) in free.iter().enumerate() {
            let (from, to) = (d[i], target[k]);
            let ratio = if to < bx.lo[i] {
                (bx.lo[i] - from) / (to - from)
            } else if to > bx.hi[i] {
                (bx.hi[i] - from) / (to - from)
            } else {
                continue;
            };
            let ratio = if ratio.is_finite() { ratio.clamp(0.0, 1.0) } else { 0.0 };
            if ratio < alpha || blocking.is_none() {
                alpha = ratio.min(alpha);
                blocking = Some((i, to));
            }
        }
        for (k, &i) in free.iter().enumerate() {
            d[i] += alpha * (target[k] - d[i]);
            d[i] = d[i].clamp(bx.lo[i], bx.hi[i]);
        }
        if let Some((i, to)) = blocking {
            if to < bx.lo[i] {
                d[i] = bx.lo[i];
                state[i] = Bound::Lower;
            } else {
                d[i] = bx.hi[i];
                state[i] = Bound::Upper;
            }
            continue;
        }
        // The free subproblem is solved: check the multipliers of the fixed variables.
        let g = grad(&d);
        let wrong = (0..n)
            .filter_map(|i| match state[i] {
                Bound::Lower if g[i] < 0.0 && bx.hi[i] > bx.lo[i] => Some((i, -g[i])),
                Bound::Upper if g[i] > 0.0 && bx.hi[i] > bx.lo[i] => Some((i, g[i])),
                _ => None,
            })
            .max_by(|a, b| a.1.total_cmp(&b.1).then(b.0.cmp(&a.0)));
        match wrong {
            Some((i, _)) => state[i] = Bound::Free,
            None => return d,
        }
    }
    d
}

/// The free variables' values minimising ‖r + J d‖² + μ‖d‖² with the other variables held at
/// d: x = −V diag(σ / (σ² + μ)) Uᵀ r̃ with r̃ = r + J_fixed d_fixed, dropping singular values
/// that are negligible when μ = 0 (the minimum-norm solution). `None` if J is degenerate.
fn solve_free(j: &DMatrix<f64>, r: &DVector<f64>, mu: f64, d: &DVector<f64>, free: &[usize]) -> Option<Vec<f64>> {
    let mut fixed_d = d.clone();
    for &i in free {
        fixed_d[i] = 0.0;
    }
    let rt = r + j * fixed_d;
    let jf = j.select_columns(free);
    let svd = svd(jf)?;
    let (u, v_t) = (svd.u.as_ref()?, svd.v_t.as_ref()?);
    let s_max = svd.singular_values.max();
    let ur = u.transpose() * rt;
    let mut coef = DVector::zeros(svd.singular_values.len());
    for (k, &s) in svd.singular_values.iter().enumerate() {
        let denom = s * s + mu;
        if denom > 0.0 && (mu > 0.0 || s > 1e-13 * s_max) {
            coef[k] = -s / denom * ur[k];
        }
    }
    let x = v_t.transpose() * coef;
    x.iter().all(|v| v.is_finite()).then(|| x.iter().copied().collect())
}

/// The step in box ∩ ball that maximises |cᵀd|; see the module docs.
pub(super) fn geometry_step(c: &DVector<f64>, bx: &StepBox, delta: f64) -> DVector<f64> {
    let plus = farthest_along(c, bx, delta);
    let minus = farthest_along(&(-c), bx, delta);
    if c.dot(&minus).abs() > c.dot(&plus).abs() { minus } else { plus }
}

/// argmax cᵀd over box ∩ ball: clamp(t c) for the largest t ≥ 0 with ‖clamp(t c)‖ ≤ Δ.
/// Components of c below 1e-12 of the largest count as zero (they would otherwise reach
/// their bounds only at absurd t).
fn farthest_along(c: &DVector<f64>, bx: &StepBox, delta: f64) -> DVector<f64> {
    let n = bx.dim();
    let zero = DVector::zeros(n);
    let c_max = c.amax();
    if !(c_max > 0.0 && c_max.is_finite()) {
        return zero;
    }
    let c = c.map(|v| if v.abs() <= 1e-12 * c_max { 0.0 } else { v });
    let bound_of = |i: usize| if c[i] > 0.0 { bx.hi[i] } else { bx.lo[i] };
    // Where each component reaches its bound (∞ if never), in order.
    let mut hits: Vec<(f64, usize)> =
        (0..n).filter(|&i| c[i] != 0.0).map(|i| ((bound_of(i) / c[i]).max(0.0), i)).collect();
    hits.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    let mut fixed_sq = 0.0;
    let mut t = f64::INFINITY;
    for (k, &(ti, i)) in hits.iter().enumerate() {
        let free_sq: f64 = hits[k..].iter().map(|&(_, j)| c[j] * c[j]).sum();
        if fixed_sq + ti * ti * free_sq >= delta * delta {
            t = ((delta * delta - fixed_sq).max(0.0) / free_sq).sqrt();
            break;
        }
        fixed_sq += bound_of(i).powi(2);
    }
    // With t = ∞ every component has reached a (finite) bound: the box's corner.
    let d = DVector::from_fn(n, |i, _| {
        if c[i] == 0.0 {
            0.0
        } else if t.is_infinite() {
            bound_of(i)
        } else {
            (t * c[i]).clamp(bx.lo[i], bx.hi[i])
        }
    });
    let norm = d.norm();
    if !norm.is_finite() {
        zero
    } else if norm > delta {
        d * (delta / norm)
    } else {
        d
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unbounded(n: usize) -> StepBox {
        StepBox { lo: vec![f64::NEG_INFINITY; n], hi: vec![f64::INFINITY; n] }
    }

    #[test]
    fn gauss_newton_step_inside_the_region_solves_the_linear_system() {
        let j = DMatrix::from_row_slice(3, 2, &[1.0, 0.0, 0.0, 2.0, 1.0, 1.0]);
        let x = DVector::from_vec(vec![0.3, -0.2]);
        let r = -(&j * &x);
        let d = trust_region_step(&j, &r, &unbounded(2), 10.0);
        assert!((d - x).norm() < 1e-12);
    }

    #[test]
    fn step_on_the_sphere_matches_the_levenberg_marquardt_closed_form() {
        // Unconstrained: d(μ) = −(JᵀJ + μI)⁻¹ Jᵀr with ‖d‖ = Δ.
        let j = DMatrix::from_row_slice(2, 2, &[3.0, 1.0, 0.0, 0.5]);
        let r = DVector::from_vec(vec![4.0, -2.0]);
        let d = trust_region_step(&j, &r, &unbounded(2), 0.5);
        assert!((d.norm() - 0.5).abs() < 0.011, "{}", d.norm());
        // d is parallel to −(JᵀJ + μI)⁻¹Jᵀr for some μ ≥ 0: the gradient of the model at d is
        // −μ d.
        let g = j.transpose() * (&r + &j * &d);
        let mu = -g.dot(&d) / d.dot(&d);
        assert!(mu > 0.0 && (g + &d * mu).norm() < 1e-8 * mu, "μ = {mu}");
    }

    #[test]
    fn box_constrained_least_squares_meets_the_kkt_conditions() {
        let j = DMatrix::from_row_slice(4, 3, &[1.0, 2.0, 0.0, 0.0, 1.0, 1.0, 1.0, 0.0, 3.0, 2.0, 1.0, 1.0]);
        let r = DVector::from_vec(vec![3.0, -1.0, 2.0, 5.0]);
        let bx = StepBox { lo: vec![-0.5, 0.0, -1.0], hi: vec![0.5, 0.2, 0.0] };
        for mu in [0.0, 0.1, 10.0] {
            let d = box_least_squares(&j, &r, mu, &bx);
            let g = j.transpose() * (&r + &j * &d) + &d * mu;
            for i in 0..3 {
                assert!(d[i] >= bx.lo[i] && d[i] <= bx.hi[i]);
                let tol = 1e-9 * (1.0 + g.norm());
                if d[i] > bx.lo[i] && d[i] < bx.hi[i] {
                    assert!(g[i].abs() < tol, "μ {mu}: free {i} has gradient {}", g[i]);
                } else if d[i] == bx.lo[i] {
                    assert!(g[i] >= -tol, "μ {mu}: {i} at lower with gradient {}", g[i]);
                } else {
                    assert!(g[i] <= tol, "μ {mu}: {i} at upper with gradient {}", g[i]);
                }
            }
        }
    }

    #[test]
    fn geometry_step_maximises_the_linear_function_in_box_and_ball() {
        let c = DVector::from_vec(vec![1.0, 2.0]);
        let d = geometry_step(&c, &unbounded(2), 2.0);
        assert!((d.norm() - 2.0).abs() < 1e-12 && (d.dot(&c) - 2.0 * c.norm()).abs() < 1e-12);
        // The box stops the second component at 0.5: the rest of the radius goes to the first.
        let bx = StepBox { lo: vec![-1.0, -0.5], hi: vec![1.0, 0.5] };
        let d = geometry_step(&c, &bx, 1.0);
        assert!((d[1].abs() - 0.5).abs() < 1e-12 && (d[0].abs() - 0.75f64.sqrt()).abs() < 1e-12, "{d}");
        // Components far below the largest are ignored, even against infinite bounds.
        let tiny = DVector::from_vec(vec![1e-19, 1.0, -1e-18]);
        let bx = StepBox { lo: vec![-1.0, -0.9, f64::NEG_INFINITY], hi: vec![0.1, 0.0, 0.8] };
        let d = geometry_step(&tiny, &bx, 0.1);
        assert!(d.iter().all(|v| v.is_finite()) && (d[1] + 0.1).abs() < 1e-12, "{d}");
        // Only the negative direction has room.
        let bx = StepBox { lo: vec![-1.0, -1.0], hi: vec![0.0, 0.0] };
        let d = geometry_step(&c, &bx, 1.0);
        assert!(d[0] < 0.0 && d[1] < 0.0 && (d.norm() - 1.0).abs() < 1e-12);
    }
}
