//! The least-squares solver's iteration: what happens when a batch is complete (radius
//! updates, upkeep of the interpolation set, stopping rules) and how the next batch is formed.
//! The rules are summarised in the parent module's docs; the constants are DFO-LS's defaults
//! unless noted.

// `!(a > b)` is meant: it is true when a is NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use nalgebra::DVector;

use super::batch::{LsBatch, Told};
use super::model::{InterpolationSet, Sample};
use super::subproblem::{StepBox, geometry_step, trust_region_step};
use super::{LeastSquares, Phase, Role};
use crate::Termination;

/// Ratio below which a step is unsuccessful (η₁).
const ETA1: f64 = 0.1;
/// Ratio above which a step is very successful (η₂).
const ETA2: f64 = 0.7;
/// Radius factor after an unsuccessful step (γ_dec).
const GAMMA_DEC: f64 = 0.5;
/// Radius factor after a very successful step (γ_inc), and the factor on the step length
/// (γ̄_inc).
const GAMMA_INC: f64 = 2.0;
const GAMMA_INC_STEP: f64 = 4.0;
const DELTA_MAX: f64 = 1e10;
/// A step shorter than this fraction of ρ is a safety step (not worth a round of its own).
const SAFETY: f64 = 0.5;
/// A point farther than this many ρ from the centre needs a geometry step in a safety round.
const FAR_RHO: f64 = 10.0;
/// The smallest ρ when `x_tol` is not set.
const RHO_FLOOR: f64 = 1e-15;
/// Slow progress: log f falls by less than this per iteration, over `SLOW_HISTORY` iterations.
const SLOW_THRESHOLD: f64 = 1e-4;
const SLOW_HISTORY: usize = 5;
/// (fmucal) The further step along the Levenberg–Marquardt path is at most this many Δ.
const FURTHER: f64 = 4.0;
/// (fmucal) A round that would hold the trial step alone also asks this fraction of it.
const BACKTRACK: f64 = 0.5;
/// (fmucal) The set is renewed around a step when its farthest point is more than this many
/// step lengths from the centre.
const STALE_STEPS: f64 = 3.0;
/// (fmucal) When ρ goes down because the model's step is short, it goes down to at most this
/// many step lengths.
const RHO_STEPS: f64 = 2.0;

impl LeastSquares {
    /// Asks the initial design: x0 (unless this is a retry after every point failed) and a step
    /// of length Δ along each axis.
    pub(super) fn ask_initial(&mut self, retry: bool) {
        let n = self.space.dim();
        let z0 = self.x0.clone();
        let mut points = if retry { vec![] } else { vec![z0.clone()] };
        for i in 0..n {
            let mut z = z0.clone();
            z[i] = self.coordinate_step(&z0, i);
            points.push(z);
        }
        self.phase = Phase::Initial;
        self.start_batch(points);
    }

    /// z0ᵢ + Δ, else z0ᵢ − Δ, else the bound with more room.
    fn coordinate_step(&self, z0: &[f64], i: usize) -> f64 {
        let (lo, hi) = self.space.z_bounds(i);
        let (up, down) = (z0[i] + self.delta, z0[i] - self.delta);
        if up <= hi {
            up
        } else if down >= lo {
            down
        } else if hi - z0[i] >= z0[i] - lo {
            hi
        } else {
            lo
        }
    }

    /// Hands out the scaled points (projected onto the box) as the next batch, no more than
    /// `max_fevals` allows (the first points have priority); stops if none is allowed.
    fn start_batch(&mut self, mut points: Vec<Vec<f64>>) {
        // Never ask a non-finite point (the subproblems do not produce one; this is a guard).
        let finite: Vec<bool> = points.iter().map(|z| z.iter().all(|v| v.is_finite())).collect();
        if finite.contains(&false) {
            tracing::warn!("least squares: dropping a non-finite candidate");
            if let Phase::Round { roles } = &mut self.phase {
                let mut keep = finite.iter();
                roles.retain(|_| keep.next().copied().unwrap_or(false));
            }
            let mut keep = finite.iter();
            points.retain(|_| keep.next().copied().unwrap_or(false));
        }
        if let Some(max) = self.settings.stopping.max_fevals {
            let left = max.saturating_sub(self.evaluations);
            points.truncate(usize::try_from(left).unwrap_or(usize::MAX));
        }
        if points.is_empty() {
            self.stop(Termination::MaxFevals);
            return;
        }
        if let Phase::Round { roles } = &mut self.phase {
            roles.truncate(points.len());
        }
        for z in &mut points {
            self.space.project(z);
        }
        self.batch = LsBatch::new(points, &self.space, &mut self.next_id);
        self.rounds += 1;
    }

    fn stop(&mut self, t: Termination) {
        self.phase = Phase::Done(t);
        self.batch = LsBatch::default();
    }

    /// Consumes the completed batch: counts it, updates the set and radii, and asks the next
    /// batch or stops.
    pub(super) fn advance(&mut self) {
        let batch = std::mem::take(&mut self.batch);
        self.evaluations += batch.z.len() as u64;
        let samples: Vec<Option<Sample>> =
            batch.z.into_iter().zip(batch.results).map(|(z, told)| self.sample(z, told)).collect();
        match std::mem::replace(&mut self.phase, Phase::Round { roles: vec![] }) {
            Phase::Initial => {
                for s in samples.into_iter().flatten() {
                    self.set.insert(s, self.delta);
                }
                if self.set.points.is_empty() {
                    // Every point failed: try again closer to x0.
                    self.delta *= GAMMA_DEC;
                    self.rho = self.delta;
                    if self.delta < self.rho_end() {
                        self.stop(Termination::XTol);
                    } else {
                        self.ask_initial(true);
                    }
                    return;
                }
                self.f0 = Some(self.set.centre().f);
                self.plan();
            }
            Phase::Round { roles } => {
                self.iterations += 1;
                self.finish_round(&roles, samples);
                if !matches!(self.phase, Phase::Done(_)) {
                    self.plan();
                }
            }
            Phase::Done(t) => self.phase = Phase::Done(t),
        }
    }

    /// A told result as a sample, if it is usable: residuals, all finite, as many as before.
    fn sample(&mut self, z: Vec<f64>, told: Option<Told>) -> Option<Sample> {
        let Some(Told::Residuals(r)) = told else { return None };
        if r.is_empty() {
            return None;
        }
        match self.m {
            Some(m) if m != r.len() => {
                tracing::warn!(expected = m, got = r.len(), "residual vector of a different length; treated as failed");
                return None;
            }
            _ => self.m = Some(r.len()),
        }
        let f = r.iter().map(|v| v * v).sum();
        Some(Sample { z, r, f })
    }

    /// Applies a completed round: the ratio test and radius update for its trial steps, the
    /// upkeep of the set, the slow-progress count and, when nothing more can be learnt at this
    /// resolution, a lower ρ.
    fn finish_round(&mut self, roles: &[Role], mut samples: Vec<Option<Sample>>) {
        let f_k = self.set.centre().f;
        let delta_before = self.delta;
        // The trial step that decides the radius: the best one if it improves, else the first.
        let mut decisive: Option<(f64, f64, f64, f64)> = None; // (f, ratio, length, radius)
        for (role, sample) in roles.iter().zip(&samples) {
            if let Role::Trial { radius, norm, predicted, .. } = role {
                let f = sample.as_ref().map_or(f64::INFINITY, |s| s.f);
                if decisive.is_none_or(|(best, ..)| f < best && f < f_k) {
                    decisive = Some((f, (f_k - f) / predicted, *norm, *radius));
                }
            }
        }
        if let Some((f, ratio, norm, radius)) = decisive {
            self.delta = if f.is_finite() {
                updated_radius(radius, ratio, norm)
            } else {
                // Not evaluated: the model is unchanged, so only a shorter step differs.
                GAMMA_DEC * radius.min(norm)
            };
            if self.delta <= 1.5 * self.rho {
                self.delta = self.rho;
            }
        }
        self.update_set(roles, &mut samples);
        let mut fixed_geometry = false;
        let mut geometry_failed = false;
        for (role, sample) in roles.iter().zip(samples) {
            if let Role::Geometry { replaces } = role {
                let Some(y) = sample else {
                    geometry_failed = true;
                    continue;
                };
                let target = replaces.as_ref().and_then(|z| self.set.find(z)).filter(|&t| t != self.set.centre);
                match target {
                    Some(t) => {
                        self.set.replace(t, y);
                        fixed_geometry = true;
                    }
                    None => {
                        self.set.insert(y, self.delta);
                    }
                }
            }
        }
        let f_new = self.set.centre().f;
        if f_new < f_k {
            self.record_progress(f_new);
            self.stalled = 0;
        } else if roles.iter().any(|r| matches!(r, Role::Geometry { .. })) {
            self.stalled += 1;
        }
        if geometry_failed {
            // Try the geometry step again closer in; at the lowest radius, lower the resolution.
            self.delta = (GAMMA_DEC * self.delta).max(self.rho);
            if delta_before <= self.rho {
                self.reduce_rho(0.0);
            }
        } else if let Some((_, ratio, norm, _)) = decisive
            && !(ratio > 0.0)
            && !fixed_geometry
            && self.delta.max(norm) <= self.rho
        {
            // A failed step at the lowest radius with a good model: lower the resolution.
            self.reduce_rho(0.0);
        } else if self.stalled > self.space.dim() as u64 {
            // More geometry rounds than points without progress (they cannot move the points
            // any more, e.g. at the limit of floating point): lower the resolution.
            self.reduce_rho(0.0);
        }
    }

    /// Puts the round's trial and refresh points into the set. A complete refresh renews the
    /// whole set: the old centre, the trial point and the points next to it; otherwise each
    /// usable point is inserted (trial points best first; of a step and its half, the better).
    fn update_set(&mut self, roles: &[Role], samples: &mut [Option<Sample>]) {
        let refresh: Vec<usize> = (0..roles.len()).filter(|&i| matches!(roles[i], Role::Refresh)).collect();
        let trials: Vec<usize> = (0..roles.len()).filter(|&i| matches!(roles[i], Role::Trial { .. })).collect();
        if !refresh.is_empty() && trials.len() == 1 && trials.iter().chain(&refresh).all(|&i| samples[i].is_some()) {
            let mut points = vec![self.set.centre().clone()];
            points.extend(trials.iter().chain(&refresh).filter_map(|&i| samples[i].take()));
            let centre = (0..points.len()).min_by(|&a, &b| points[a].f.total_cmp(&points[b].f).then(a.cmp(&b)));
            self.set = InterpolationSet { points, centre: centre.unwrap_or(0) };
            return;
        }
        let mut order = trials;
        order.sort_by(|&a, &b| {
            let f = |i: usize| samples[i].as_ref().map_or(f64::INFINITY, |s| s.f);
            f(a).total_cmp(&f(b)).then(a.cmp(&b))
        });
        if roles.iter().any(|r| matches!(r, Role::Trial { backtrack: true, .. })) {
            // A step and its half: on one line with the centre, so only the better enters.
            order.truncate(1);
        }
        for i in order.into_iter().chain(refresh) {
            if let Some(y) = samples[i].take() {
                self.set.insert(y, self.delta);
            }
        }
    }

    fn record_progress(&mut self, f: f64) {
        let p = &mut self.progress;
        p.history.push(f);
        if p.history.len() > SLOW_HISTORY + 1 {
            p.history.remove(0);
        }
        if p.history.len() == SLOW_HISTORY + 1 {
            let (old, new) = (p.history[0], f);
            let slow = old > 0.0 && new > 0.0 && (old.ln() - new.ln()) / (SLOW_HISTORY as f64) < SLOW_THRESHOLD;
            p.slow = if slow { p.slow + 1 } else { 0 };
        }
    }

    fn rho_end(&self) -> f64 {
        self.settings.stopping.x_tol.unwrap_or(RHO_FLOOR)
    }

    /// Lowers ρ as DFO-LS does (to x_tol if within 16×, else to the geometric mean with x_tol
    /// if within 250×, else ×0.1), and no further than `RHO_STEPS` × `step` when the model's
    /// step length is known; Δ becomes max(ρ_old/2, ρ). Stops at x_tol.
    fn reduce_rho(&mut self, step: f64) {
        let end = self.rho_end();
        if self.rho <= end {
            self.stop(Termination::XTol);
            return;
        }
        let ratio = self.rho / end;
        let mut new = if ratio <= 16.0 {
            end
        } else if ratio <= 250.0 {
            (self.rho * end).sqrt()
        } else {
            0.1 * self.rho
        };
        if step > 0.0 {
            new = new.min(RHO_STEPS * step).max(end);
        }
        self.delta = (0.5 * self.rho).max(new);
        self.rho = new;
        self.stalled = 0;
    }

    /// The stopping rules other than x_tol, in the order f_tol, slow progress, max_iters,
    /// max_fevals.
    fn stop_rule(&self) -> Option<Termination> {
        let stopping = &self.settings.stopping;
        let f = self.set.centre().f;
        if let (Some(t), Some(f0)) = (stopping.f_tol, self.f0)
            && f <= t * f0
        {
            return Some(Termination::FTol);
        }
        if self.settings.max_slow_iterations.is_some_and(|m| self.progress.slow >= m) {
            return Some(Termination::FTol);
        }
        if stopping.max_iters.is_some_and(|m| self.iterations >= m) {
            return Some(Termination::MaxIters);
        }
        if stopping.max_fevals.is_some_and(|m| self.evaluations >= m) {
            return Some(Termination::MaxFevals);
        }
        None
    }

    /// The steps the box allows from the centre.
    fn step_box(&self) -> StepBox {
        let c = &self.set.centre().z;
        let (lo, hi) = (0..c.len())
            .map(|i| {
                let (l, u) = self.space.z_bounds(i);
                ((l - c[i]).min(0.0), (u - c[i]).max(0.0))
            })
            .unzip();
        StepBox { lo, hi }
    }

    fn at_centre(&self, d: &DVector<f64>) -> Vec<f64> {
        self.set.centre().z.iter().zip(d.iter()).map(|(a, b)| a + b).collect()
    }

    /// A geometry step on the farthest point of the set (DFO-LS: in a ball of radius
    /// max(min(dist/10, Δ), ρ), maximising the point's Lagrange polynomial).
    fn geometry_for_farthest(&self) -> Option<(Vec<f64>, Role)> {
        let (t, dist) = self.set.farthest()?;
        let radius = (0.1 * dist).min(self.delta).max(self.rho);
        let model = self.set.model();
        let k = model.others.iter().position(|&o| o == t)?;
        let c = model.lagrange.column(k).into_owned();
        let d = geometry_step(&c, &self.step_box(), radius);
        Some((self.at_centre(&d), Role::Geometry { replaces: Some(self.set.points[t].z.clone()) }))
    }

    /// The points next to the trial point `y` = centre + `step`, at the step's length along an
    /// orthonormal basis of the directions orthogonal to it (flipped where the box would cut
    /// them).
    fn refresh_points(&self, y: &[f64], step: &DVector<f64>) -> Vec<Vec<f64>> {
        let h = step.norm();
        orthogonal_complement(step)
            .into_iter()
            .map(|q| {
                let along = |sign: f64| -> Vec<f64> { y.iter().zip(q.iter()).map(|(a, b)| a + sign * h * b).collect() };
                let mut z = along(1.0);
                let before = z.clone();
                self.space.project(&mut z);
                if z != before {
                    z = along(-1.0);
                    self.space.project(&mut z);
                }
                z
            })
            .collect()
    }

    /// Forms the next round (or stops); see the parent module's docs.
    fn plan(&mut self) {
        loop {
            if let Some(t) = self.stop_rule() {
                self.stop(t);
                return;
            }
            let model = self.set.model();
            let bx = self.step_box();
            let f_k = self.set.centre().f;
            let predicted = |d: &DVector<f64>| f_k - (&model.r + &model.jacobian * d).norm_squared();
            if let Some(gain) = self.settings.min_predicted_gain
                && model.missing.is_empty()
                && self.set.farthest().is_none_or(|(_, d)| d <= FAR_RHO * self.rho)
                && predicted(&trust_region_step(&model.jacobian, &model.r, &bx, f64::INFINITY)) < gain
            {
                self.stop(Termination::FTol);
                return;
            }
            let step = trust_region_step(&model.jacobian, &model.r, &bx, self.delta);
            let (norm, pred) = (step.norm(), predicted(&step));
            let useful = norm >= SAFETY * self.rho && pred > 0.0;
            let mut points = vec![];
            let mut roles = vec![];
            if useful {
                points.push(self.at_centre(&step));
                roles.push(Role::Trial { radius: self.delta, norm, predicted: pred, backtrack: false });
            }
            if !model.missing.is_empty() {
                // An incomplete set (after failed evaluations): fill the missing directions.
                for q in &model.missing {
                    points.push(self.at_centre(&geometry_step(q, &bx, self.delta)));
                    roles.push(Role::Geometry { replaces: None });
                }
            } else if useful {
                let gauss_newton = trust_region_step(&model.jacobian, &model.r, &bx, f64::INFINITY).norm();
                let further = gauss_newton.min(FURTHER * self.delta);
                let far = self.set.farthest().map_or(0.0, |(_, d)| d);
                if gauss_newton > 1.5 * self.delta {
                    // The trust region cuts the Gauss–Newton step: also try further along the
                    // Levenberg–Marquardt path.
                    let step2 = trust_region_step(&model.jacobian, &model.r, &bx, further);
                    let (norm2, pred2) = (step2.norm(), predicted(&step2));
                    if pred2 > 0.0 && (norm2 - norm).abs() > 0.1 * norm {
                        points.push(self.at_centre(&step2));
                        roles.push(Role::Trial { radius: further, norm: norm2, predicted: pred2, backtrack: false });
                    }
                } else if step.len() > 1 && far > STALE_STEPS * norm.max(self.rho) {
                    // The model's points are far compared with the step: renew them around it.
                    for z in self.refresh_points(&points[0], &step) {
                        points.push(z);
                        roles.push(Role::Refresh);
                    }
                }
            } else if let Some((_, dist)) = self.set.farthest()
                && dist > FAR_RHO * self.rho
            {
                // A safety step: the model's step is short for this resolution, and a point is
                // far. Fix the geometry, and evaluate the short step with it.
                self.delta = (0.1 * self.delta).min(0.5 * dist).max(1.5 * self.rho);
                if let Some((z, role)) = self.geometry_for_farthest() {
                    if pred > 0.0 && norm > 0.0 {
                        points.push(self.at_centre(&step));
                        roles.push(Role::Trial { radius: norm.max(self.rho), norm, predicted: pred, backtrack: false });
                    }
                    points.push(z);
                    roles.push(role);
                }
            }
            if useful && points.len() == 1 && norm > self.rho {
                // The step alone: its half rides along (a backtracking step that costs no round
                // time), so that a step the model overshoots still makes progress this round.
                let half = &step * BACKTRACK;
                points.push(self.at_centre(&half));
                roles.push(Role::Trial {
                    radius: BACKTRACK * norm,
                    norm: BACKTRACK * norm,
                    predicted: predicted(&half),
                    backtrack: true,
                });
            }
            if points.is_empty() {
                // Nothing to learn at this resolution.
                self.reduce_rho(norm);
                if matches!(self.phase, Phase::Done(_)) {
                    return;
                }
                continue;
            }
            self.phase = Phase::Round { roles };
            self.start_batch(points);
            return;
        }
    }
}

/// DFO-LS's radius update after a step of length `norm` computed for radius `delta`, with
/// ratio `ratio`.
fn updated_radius(delta: f64, ratio: f64, norm: f64) -> f64 {
    if !(ratio >= ETA1) {
        (GAMMA_DEC * delta).min(norm)
    } else if ratio <= ETA2 {
        (GAMMA_DEC * delta).max(norm)
    } else {
        (GAMMA_INC * delta).max(GAMMA_INC_STEP * norm).min(DELTA_MAX)
    }
}

/// An orthonormal basis of the directions orthogonal to `v` (n − 1 vectors): columns 2…n of
/// the Householder reflection that maps v to a multiple of e₁ (the unit vectors e₂…eₙ if v is
/// zero).
fn orthogonal_complement(v: &DVector<f64>) -> Vec<DVector<f64>> {
    let n = v.len();
    let unit = |j: usize| DVector::from_fn(n, |i, _| if i == j { 1.0 } else { 0.0 });
    let norm = v.norm();
    if !(norm > 0.0) {
        return (1..n).map(unit).collect();
    }
    let mut u = v / norm;
    u[0] += if u[0] >= 0.0 { 1.0 } else { -1.0 };
    let uu = u.dot(&u);
    (1..n).map(|j| unit(j) - &u * (2.0 * u[j] / uu)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_orthogonal_complement_is_orthonormal_and_orthogonal_to_the_vector() {
        for v in [vec![3.0, -1.0, 2.0], vec![-1.0, 0.0, 0.0], vec![0.0, 0.0, 0.0], vec![1e-300, 5.0, 0.0]] {
            let v = DVector::from_vec(v);
            let q = orthogonal_complement(&v);
            assert_eq!(q.len(), 2);
            for (i, a) in q.iter().enumerate() {
                assert!(a.dot(&v).abs() <= 1e-12 * v.norm());
                for (j, b) in q.iter().enumerate() {
                    let expected = if i == j { 1.0 } else { 0.0 };
                    assert!((a.dot(b) - expected).abs() < 1e-12);
                }
            }
        }
    }

    #[test]
    fn the_radius_update_follows_the_ratio() {
        assert_eq!(updated_radius(1.0, -1.0, 0.3), 0.3);
        assert_eq!(updated_radius(1.0, f64::NAN, 0.8), 0.5);
        assert_eq!(updated_radius(1.0, 0.5, 0.8), 0.8);
        assert_eq!(updated_radius(1.0, 0.9, 1.0), 4.0);
        assert_eq!(updated_radius(1.0, 0.9, 0.1), 2.0);
    }
}
