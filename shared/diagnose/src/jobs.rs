//! The jobs a diagnosis builds from the base job: a candidate's calibration (the base with the
//! candidate added, starting where the screening points) and the base of a next round (the job
//! with every start at the fitted values), and the tolerances of a candidate's fit. Pure; the
//! driver submits them.

use std::collections::BTreeMap;

use super::candidates::Candidate;
use fmucal_shared::job::choices::Algorithm;
use fmucal_shared::job::identifiability::DifferencePlan;
use fmucal_shared::job::spec::{EffectSpec, JobSpec, OptimizerSpec, SetValue};

/// How far a candidate fit's ΔIC = n_eff·ln(SSR₁/SSR₀) + q·ln(n_eff) may be off because its
/// SSR is not fully converged: far below the differences the decision acts on (0 for the IC
/// test, 2 for equal support).
pub const IC_ACCURACY: f64 = 0.1;

/// The objective accuracy (a job's f_tol, absolute) at which a fit knows an SSR
/// near `ssr` well enough for the decision: an error δ in SSR₁ moves ΔIC by n_eff·δ/SSR₁, so
/// δ = [`IC_ACCURACY`]·SSR₁/n_eff, with `n_eff` the effective samples the decision uses.
pub fn decision_f_tol(ssr: f64, n_eff: f64) -> f64 {
    IC_ACCURACY * ssr.max(0.0) / n_eff.max(1.0)
}

/// The optimizer settings of a candidate's fit expected to end near `ssr`: the least-squares
/// solver (a fit starts where the screening's Gauss–Newton step points, and from there the
/// residual vector takes it to the optimum in a few rounds of parallel points, where
/// Nelder–Mead walks point by point), with the job's own x_tol and budgets, and f_tol
/// loosened to [`decision_f_tol`] where that is looser (a job's tolerance is meant for its
/// final fit, and the decision needs far less; the chosen candidate is polished to the job's
/// own tolerances afterwards). Returns the settings and the f_tol the decision uses.
pub fn decision_optimizer(own: &OptimizerSpec, ssr: f64, n_eff: f64) -> (OptimizerSpec, f64) {
    let mut o = own.clone();
    o.set_algorithm(Algorithm::LeastSquares);
    let needed = decision_f_tol(ssr, n_eff);
    let f_tol = match own.f_tol {
        // 0 disables the rule in the job; the decision still stops at what it needs.
        Some(t) if t > 0.0 => t.max(needed),
        _ => needed.max(fmucal_shared::optim::Stopping::default_for(1).f_tol.unwrap_or(0.0)),
    };
    if f_tol > 0.0 {
        o.f_tol = Some(f_tol);
    }
    (o, f_tol)
}

/// The SSR of the noise alone in a residual vector `r` (one output after another): m·σ², with
/// σ² from the median of the squared first differences, (r_{i+1} − r_i)² ≈ 2σ² for white noise
/// on a residual that varies slowly from sample to sample (the median ignores the jumps where
/// one output's residual ends and the next begins, and events). No fit can end much below it,
/// so a tolerance derived from it is tight enough for any candidate.
pub fn noise_ssr(r: &[f64]) -> f64 {
    r.len() as f64 * fmucal_shared::residuals::noise_sigma(r).powi(2)
}

/// A candidate fit whose Gauss–Newton step would still gain `decrease` stopped early (its
/// solver ended on a slope, not at an optimum) when that gain would move its ΔIC by more
/// than 10 × [`IC_ACCURACY`], half the [`EQUAL_SUPPORT`](super::decision::EQUAL_SUPPORT)
/// band: Gauss–Newton steps go on. `f_tol` is the tolerance it stopped at (a gain below it is noise).
pub fn stopped_early(decrease: f64, f_tol: f64, ssr: f64, n_eff: f64) -> bool {
    decrease > 10.0 * f_tol.max(decision_f_tol(ssr, n_eff))
}

/// The initial step (scaled; the least-squares solver's initial radius) for the polish of a fit
/// that has stopped near its optimum: 20 times the job's `x_tol`, at most the job's own initial
/// step. It shrinks to x_tol in a few reductions; a start that is further off is walked by
/// growing the radius.
pub fn polish_step(x_tol: Option<f64>, initial_step: Option<f64>) -> f64 {
    let default = initial_step.unwrap_or(0.05);
    let x_tol = x_tol.filter(|x| *x > 0.0).unwrap_or(1e-6);
    (20.0 * x_tol).min(default)
}

/// The Gauss–Newton step from the centre of an evaluated difference plan, kept inside
/// `lower`..`upper`, and what it is predicted to take off the SSR: x + s with J from the plan's
/// central differences and s the least-squares step, clamped into the bounds, and
/// ‖r₀‖² − ‖r₀ + J·s‖². `None` if the residuals do not match the plan.
pub fn gauss_newton(
    plan: &DifferencePlan,
    residuals: &[Vec<f64>],
    lower: &[f64],
    upper: &[f64],
) -> Option<(Vec<f64>, f64)> {
    let n = plan.pairs.len();
    let r0 = residuals.first()?;
    let m = r0.len();
    if residuals.len() != plan.points.len() || residuals.iter().any(|r| r.len() != m) || m == 0 || n == 0 {
        return None;
    }
    let x = &plan.points[0];
    let mut jac = nalgebra::DMatrix::<f64>::zeros(m, n);
    for (i, &(up, down, dist)) in plan.pairs.iter().enumerate() {
        if dist <= 0.0 {
            return None;
        }
        for k in 0..m {
            jac[(k, i)] = (residuals[up][k] - residuals[down][k]) / dist;
        }
    }
    let r = nalgebra::DVector::from_column_slice(r0);
    let svd = jac.clone().svd(true, true);
    let eps = 1e-12 * svd.singular_values.max();
    let step = svd.solve(&(-&r), eps).ok()?;
    let next: Vec<f64> = (0..n).map(|i| (x[i] + step[i]).clamp(lower[i].min(x[i]), upper[i].max(x[i]))).collect();
    let clamped = nalgebra::DVector::from_iterator(n, (0..n).map(|i| next[i] - x[i]));
    let after = &r + &jac * clamped;
    let gain = (r.norm_squared() - after.norm_squared()).max(0.0);
    gain.is_finite().then_some((next, gain))
}

/// The calibration of `candidate` added to `base`: the base's values start at `starts`, the
/// candidate's parameters at `effect_starts`; with `fix_base`, the base's `[[parameters]]` are
/// fixed at their starts (`[simulation] set`) and only the effects are fitted.
pub fn candidate_job(
    base: &JobSpec,
    starts: &BTreeMap<String, f64>,
    candidate: &Candidate,
    effect_starts: &[f64],
    fix_base: bool,
) -> JobSpec {
    let mut job = base.clone().with_starts(starts);
    job.diagnose = None;
    if fix_base {
        for p in std::mem::take(&mut job.parameters) {
            job.simulation.set.insert(p.name.clone(), SetValue::Number(p.start));
        }
    }
    job.effects.push(candidate.with_starts(effect_starts));
    job
}

/// Two effects of the same kind acting at the same place.
pub fn same_place(a: &EffectSpec, b: &EffectSpec) -> bool {
    a.kind == b.kind
        && a.state == b.state
        && a.port == b.port
        && a.signal == b.signal
        && a.output == b.output
        && a.input == b.input
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use super::*;
    use fmucal_shared::effects::guess::Guess;

    fn base() -> JobSpec {
        let text = concat!(
            include_str!("../../tests/data/minimal_job.toml"),
            r#"[[effects]]
kind = "sensor_offset"
output = "y"
parameters = { offset = { start = 0.0, lower = -1.0, upper = 1.0 } }
[diagnose]
top = 3
"#
        );
        JobSpec::from_toml(text, Path::new("/")).unwrap()
    }

    fn coulomb() -> Candidate {
        let mut effect = EffectSpec {
            kind: "coulomb_friction".into(),
            state: None,
            reaction: None,
            port: Some("p".into()),
            signal: Some("v".into()),
            output: None,
            input: None,
            parameters: Default::default(),
        };
        effect
            .parameters
            .insert("force".into(), fmucal_shared::job::spec::Bounds { start: 0.0, lower: 0.0, upper: 0.1 });
        Candidate {
            effect,
            guesses: vec![Guess { neutral: 0.0, step: Some(0.01), lower: 0.0, upper: 0.1 }],
            source: "diagnose.ports[0].velocities[0]".into(),
        }
    }

    #[test]
    fn a_candidate_job_starts_where_it_is_told_and_clamps_into_the_bounds() {
        let starts: BTreeMap<String, f64> = [("k".into(), 1.5), ("effects[0].offset".into(), 7.0)].into();
        let job = candidate_job(&base(), &starts, &coulomb(), &[0.03], false);
        assert_eq!(job.parameters[0].start, 1.5);
        assert_eq!(job.effects[0].parameters["offset"].start, 1.0, "clamped to the upper bound");
        assert_eq!(job.effects[1].kind, "coulomb_friction");
        assert_eq!(job.effects[1].parameters["force"].start, 0.03);
        assert_eq!(job.diagnose, None);
        job.validate().unwrap();
        let (names, ..) = job.parameter_vectors();
        assert_eq!(names, ["k", "effects[0].offset", "effects[1].force"]);
    }

    #[test]
    fn with_fix_base_the_base_parameters_are_set_and_only_effects_are_fitted() {
        let starts: BTreeMap<String, f64> = [("k".into(), 1.25)].into();
        let job = candidate_job(&base(), &starts, &coulomb(), &[0.03], true);
        assert!(job.parameters.is_empty());
        assert_eq!(job.simulation.set["k"], SetValue::Number(1.25));
        let (names, ..) = job.parameter_vectors();
        assert_eq!(names, ["effects[0].offset", "effects[1].force"]);
    }

    #[test]
    fn a_decision_tolerance_keeps_the_ic_error_within_its_accuracy() {
        // SSR 2000 over 1000 effective samples: an error of 0.2 moves ΔIC by 0.1.
        assert!((decision_f_tol(2000.0, 1000.0) - 0.2).abs() < 1e-12);
        let n_eff = 400.0;
        let ssr = 0.08;
        let d = decision_f_tol(ssr, n_eff);
        assert!((n_eff * ((ssr + d) / ssr).ln() - IC_ACCURACY).abs() < 1e-3 * IC_ACCURACY);
        assert_eq!(decision_f_tol(1.0, 0.0), IC_ACCURACY, "at least one sample");
    }

    #[test]
    fn the_decision_loosens_f_tol_but_never_tightens_it() {
        let own = OptimizerSpec { f_tol: Some(1e-10), x_tol: Some(1e-5), ..Default::default() };
        let (o, f_tol) = decision_optimizer(&own, 2000.0, 1000.0);
        assert_eq!((o.f_tol, f_tol), (Some(0.2), 0.2));
        assert_eq!(o.x_tol, Some(1e-5), "x_tol is the job's");
        assert_eq!(o.algorithm(), Algorithm::LeastSquares, "the fit uses the residual vector");
        let loose = OptimizerSpec { f_tol: Some(1.0), ..Default::default() };
        assert_eq!(decision_optimizer(&loose, 2000.0, 1000.0).0.f_tol, Some(1.0));
        let off = OptimizerSpec { f_tol: Some(0.0), ..Default::default() };
        assert_eq!(decision_optimizer(&off, 2000.0, 1000.0).0.f_tol, Some(0.2));
    }

    #[test]
    fn the_noise_ssr_of_white_noise_on_a_slow_residual_is_its_sum_of_squares() {
        // Deterministic pseudo-noise (SplitMix64, Box–Muller) with σ = 0.01 on a slow sine, two
        // outputs one after the other.
        let mut state = 7u64;
        let mut uniform = || {
            state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = state;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
        };
        let m = 4000;
        let r: Vec<f64> = (0..m)
            .map(|i| {
                let (u1, u2) = (uniform().max(1e-300), uniform());
                let noise = 0.01 * (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos();
                let offset = if i < m / 2 { 5.0 } else { -3.0 };
                offset + (i as f64 * 0.002).sin() + noise
            })
            .collect();
        let expected = m as f64 * 1e-4;
        let got = noise_ssr(&r);
        assert!((got / expected - 1.0).abs() < 0.1, "{got} vs {expected}");
        assert_eq!(noise_ssr(&[1.0]), 0.0);
    }

    #[test]
    fn a_fit_stopped_early_when_a_step_would_move_its_ic_by_more_than_one() {
        let (ssr, n_eff) = (0.08, 400.0);
        let f_tol = decision_f_tol(ssr, n_eff);
        assert!(!stopped_early(5.0 * f_tol, f_tol, ssr, n_eff));
        assert!(stopped_early(20.0 * f_tol, f_tol, ssr, n_eff));
        assert!(!stopped_early(f64::NAN, f_tol, ssr, n_eff), "unknown: not stopped early");
        // Ended far above the SSR its tolerance came from: judged by the SSR it reached.
        assert!(!stopped_early(20.0 * f_tol, f_tol, 10.0 * ssr, n_eff));
    }

    #[test]
    fn a_polish_starts_with_a_radius_of_twenty_x_tol() {
        assert!((polish_step(Some(1e-4), None) - 2e-3).abs() < 1e-15);
        assert_eq!(polish_step(Some(1e-2), Some(0.05)), 0.05, "at most the job's own step");
        assert!((polish_step(None, None) - 2e-5).abs() < 1e-18);
    }

    /// The plan and residuals of r(x) = A·x − b at `x` (exact differences: r is linear).
    fn linear(x: &[f64]) -> (DifferencePlan, Vec<Vec<f64>>) {
        let a = [[1.0, 0.0], [0.0, 2.0], [1.0, 1.0]];
        let b = [1.0, 2.0, 3.0];
        let r = |p: &[f64]| -> Vec<f64> { (0..3).map(|k| a[k][0] * p[0] + a[k][1] * p[1] - b[k]).collect() };
        let mut points = vec![x.to_vec()];
        let mut pairs = vec![];
        for i in 0..2 {
            for d in [0.01, -0.01] {
                let mut p = x.to_vec();
                p[i] += d;
                points.push(p);
            }
            pairs.push((points.len() - 2, points.len() - 1, 0.02));
        }
        let residuals = points.iter().map(|p| r(p)).collect();
        (DifferencePlan { points, pairs }, residuals)
    }

    /// What the [`gauss_newton`] step is predicted to take off the SSR (NaN without a step).
    fn predicted_decrease(plan: &DifferencePlan, residuals: &[Vec<f64>], lower: &[f64], upper: &[f64]) -> f64 {
        gauss_newton(plan, residuals, lower, upper).map_or(f64::NAN, |(_, gain)| gain)
    }

    #[test]
    fn the_predicted_decrease_is_what_the_optimum_is_below_a_point() {
        let ssr = |r: &[f64]| r.iter().map(|v| v * v).sum::<f64>();
        // The least-squares optimum of the linear problem: (AᵀA)⁻¹Aᵀb.
        let (ata, atb) = ([[2.0, 1.0], [1.0, 5.0]], [4.0, 7.0]);
        let det = ata[0][0] * ata[1][1] - ata[0][1] * ata[1][0];
        let opt = [(ata[1][1] * atb[0] - ata[0][1] * atb[1]) / det, (ata[0][0] * atb[1] - ata[1][0] * atb[0]) / det];
        let (plan, residuals) = linear(&opt);
        let (lo, hi) = ([-10.0, -10.0], [10.0, 10.0]);
        assert!(predicted_decrease(&plan, &residuals, &lo, &hi) < 1e-9);
        let (plan, residuals) = linear(&[0.0, 0.0]);
        let at_opt = ssr(&linear(&opt).1[0]);
        let d = predicted_decrease(&plan, &residuals, &lo, &hi);
        assert!((d - (ssr(&residuals[0]) - at_opt)).abs() < 1e-9, "{d}");
        let (next, _) = gauss_newton(&plan, &residuals, &lo, &hi).unwrap();
        assert!((next[0] - opt[0]).abs() < 1e-9 && (next[1] - opt[1]).abs() < 1e-9, "{next:?} vs {opt:?}");
        // A bound that holds the step back: only the part inside the box counts.
        let held = predicted_decrease(&plan, &residuals, &lo, &[10.0, 0.0]);
        assert!(held > 0.0 && held < d, "{held} vs {d}");
        assert!(predicted_decrease(&plan, &residuals[..2], &lo, &hi).is_nan());
    }

    #[test]
    fn the_same_kind_at_the_same_place_is_the_same_effect() {
        let a = coulomb().effect;
        let mut b = a.clone();
        b.parameters.clear();
        assert!(same_place(&a, &b));
        b.signal = Some("w".into());
        assert!(!same_place(&a, &b));
    }
}
