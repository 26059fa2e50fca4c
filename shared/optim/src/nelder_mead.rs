//! Nelder–Mead simplex search with box bounds, as in Andersson et al. 2012, section 4.1: trial
//! points x = x_c + δ (x_c − x_worst) with δ = 1 (reflection), 2 (expansion), 1/2 (outside
//! contraction) and −1/2 (inside contraction), and a shrink toward the best vertex by 1/2.
//!
//! - **Parallel mode** (default): the initial simplex's n+1 points form one batch; each
//!   iteration asks reflection, expansion and both contractions together (a batch of 4) and
//!   then applies the classic decision rules to the four values; a shrink asks its n points as
//!   one batch. The simplex path is the same as in sequential mode, in fewer rounds.
//! - **Sequential mode** asks one point at a time, like classic NM, and needs fewer evaluations.
//! - Vertex values are cached: a vertex is never evaluated twice.
//! - **Bounds**: every trial point is projected onto the box (componentwise clamp in scaled
//!   variables). Projection can flatten the simplex against a face; when an iteration that
//!   projected a point leaves the simplex's normalised volume |det E| / Π‖eᵢ‖ below 1e-10, the
//!   simplex is rebuilt around its best vertex with edges of the current simplex size (at least
//!   10·x_tol, at most the initial step), costing one extra batch of n points.
//! - The initial simplex is x0 plus `initial_step` along each scaled axis, away from zero
//!   (the other way where that leaves the box). With the default scaling of unbounded
//!   parameters this is SciPy's initial simplex.
//! - **Termination** (first rule met, see [`Stopping`]): x_tol on the largest ∞-norm distance of
//!   a vertex from the best one in scaled variables, f_tol on the spread of vertex values,
//!   max_iters, max_fevals (checked between iterations).
//!
//! Defaults: parallel, initial_step 0.05, [`Stopping::default_for`].

use serde::{Deserialize, Serialize};

use super::fitness::Fitness;
use super::run::{BatchOptimizer, RunState, Step, local_space};
use super::space::Space;
use super::{OptimError, Stopping, Termination};

/// Nelder–Mead settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NmSettings {
    /// Ask reflection, expansion and both contractions as one batch. Default: true.
    pub parallel: bool,
    /// Edge of the initial simplex in scaled variables (a fraction of the range where both
    /// bounds are finite). Default: 0.05.
    pub initial_step: f64,
    /// Stopping rules. Default: [`Stopping::default_for`] the dimension.
    pub stopping: Stopping,
    /// Scale of parameters without two finite bounds. Default: |x0| (0.005 where x0 is 0).
    pub nominal: Option<Vec<f64>>,
}

impl NmSettings {
    /// Defaults for an `n`-dimensional problem.
    pub fn new(n: usize) -> Self {
        NmSettings { parallel: true, initial_step: 0.05, stopping: Stopping::default_for(n), nominal: None }
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct Vertex {
    z: Vec<f64>,
    f: Fitness,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
enum Phase {
    /// The batch holds the n+1 initial vertices.
    Initial,
    /// The batch holds reflection, expansion, outside and inside contraction (parallel mode).
    Trial,
    /// The batch holds the reflection (sequential mode).
    Reflect,
    /// The batch holds the expansion; the reflection is known.
    Expand {
        reflection: Vertex,
    },
    /// The batch holds a contraction; the reflection is known.
    Contract {
        reflection: Vertex,
        outside: bool,
    },
    /// The batch holds the n shrunken vertices.
    Shrink,
    /// The batch holds n vertices of a simplex rebuilt around the best one.
    Rebuild,
    Done(Termination),
}

/// The Nelder–Mead optimizer; see the module docs.
pub type NelderMead = BatchOptimizer<NelderMeadSteps>;

/// The algorithm part of [`NelderMead`]: the simplex and where the iteration stands.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct NelderMeadSteps {
    settings: NmSettings,
    /// Sorted best first once evaluated.
    simplex: Vec<Vertex>,
    phase: Phase,
    /// Whether the current iteration projected a trial point onto the box.
    projected: bool,
}

impl NelderMead {
    /// Starts a search from `x0` within `[lower, upper]` (infinite bounds allowed).
    ///
    /// # Errors
    /// [`OptimError::Setting`] naming the bad field: bounds, `x0`, `nominal`, `initial_step` or a
    /// stopping rule.
    pub fn new(lower: &[f64], upper: &[f64], x0: &[f64], settings: NmSettings) -> Result<Self, OptimError> {
        let step = ("initial_step", settings.initial_step);
        let space = local_space(lower, upper, x0, settings.nominal.as_deref(), &settings.stopping, step)?;
        if let Some(i) = (0..space.dim()).find(|&i| lower[i] == upper[i]) {
            return Err(OptimError::setting(
                "upper",
                format!("parameter {i} has lower == upper; Nelder–Mead needs a range"),
            ));
        }
        let z0 = space.to_scaled(x0);
        let mut points = vec![z0.clone()];
        for i in 0..space.dim() {
            let mut z = z0.clone();
            z[i] = step_along(&space, &z0, i, settings.initial_step);
            points.push(z);
        }
        let mut run = RunState::new(space);
        run.start_batch(points);
        let algorithm = NelderMeadSteps { settings, simplex: vec![], phase: Phase::Initial, projected: false };
        Ok(BatchOptimizer { run, algorithm })
    }
}

impl NelderMeadSteps {
    fn new_batch(&mut self, run: &mut RunState, points: Vec<Vec<f64>>, phase: Phase) {
        run.start_batch(points);
        self.phase = phase;
    }

    /// Largest ∞-norm distance of a vertex from the best one.
    fn size(&self) -> f64 {
        super::extent(&self.simplex[0].z, self.simplex.iter().map(|v| v.z.as_slice()))
    }

    /// Sorts the simplex and either stops or asks the next trial points.
    fn start_iteration(&mut self, run: &mut RunState) {
        self.simplex.sort_by(|a, b| a.f.cmp(&b.f));
        let simplex = &self.simplex;
        let points = simplex.iter().map(|v| v.z.as_slice());
        if let Some(t) = run.stop_if(&self.settings.stopping, &simplex[0].z, points, simplex.iter().map(|v| v.f)) {
            self.phase = Phase::Done(t);
            return;
        }
        self.projected = false;
        if self.settings.parallel {
            let pts = [1.0, 2.0, 0.5, -0.5].iter().map(|&d| self.trial(&run.space, d)).collect();
            self.new_batch(run, pts, Phase::Trial);
        } else {
            let r = self.trial(&run.space, 1.0);
            self.new_batch(run, vec![r], Phase::Reflect);
        }
    }

    /// x_c + δ (x_c − x_worst), projected onto the box.
    fn trial(&mut self, space: &Space, delta: f64) -> Vec<f64> {
        let n = space.dim();
        let mut c = vec![0.0; n];
        for v in &self.simplex[..n] {
            for (ci, zi) in c.iter_mut().zip(&v.z) {
                *ci += zi / n as f64;
            }
        }
        let w = &self.simplex[n].z;
        let mut z: Vec<f64> = c.iter().zip(w).map(|(ci, wi)| ci + delta * (ci - wi)).collect();
        let before = z.clone();
        space.project(&mut z);
        if z != before {
            self.projected = true;
        }
        z
    }

    /// Replaces the worst vertex and goes on.
    fn accept(&mut self, run: &mut RunState, v: Vertex) {
        let n = run.space.dim();
        self.simplex[n] = v;
        run.iterations += 1;
        self.after_update(run);
    }

    fn shrink(&mut self, run: &mut RunState) {
        let best = self.simplex[0].z.clone();
        let pts = self.simplex[1..]
            .iter()
            .map(|v| v.z.iter().zip(&best).map(|(zi, bi)| bi + 0.5 * (zi - bi)).collect())
            .collect();
        self.new_batch(run, pts, Phase::Shrink);
    }

    /// Rebuilds the simplex if projection flattened it, else starts the next iteration.
    fn after_update(&mut self, run: &mut RunState) {
        if self.projected && normalized_volume(&self.simplex) < 1e-10 {
            self.simplex.sort_by(|a, b| a.f.cmp(&b.f));
            let floor = 10.0 * self.settings.stopping.x_tol.unwrap_or(1e-8);
            let step = self.size().max(floor).min(self.settings.initial_step);
            let z0 = self.simplex[0].z.clone();
            let pts = (0..run.space.dim())
                .map(|i| {
                    let mut z = z0.clone();
                    z[i] = step_along(&run.space, &z0, i, step);
                    z
                })
                .collect();
            tracing::debug!(step, "Nelder–Mead simplex flattened by projection; rebuilding");
            self.new_batch(run, pts, Phase::Rebuild);
        } else {
            self.start_iteration(run);
        }
    }

    /// The classic decision rules; asks for a missing point in sequential mode.
    fn decide(&mut self, run: &mut RunState, r: Vertex, e: Option<Vertex>, oc: Option<Vertex>, ic: Option<Vertex>) {
        let n = run.space.dim();
        let (f1, fn_, fw) = (self.simplex[0].f, self.simplex[n - 1].f, self.simplex[n].f);
        if r.f.lt(&f1) {
            match e {
                Some(e) => self.accept(run, if e.f.lt(&r.f) { e } else { r }),
                None => {
                    let z = self.trial(&run.space, 2.0);
                    self.new_batch(run, vec![z], Phase::Expand { reflection: r });
                }
            }
        } else if r.f.lt(&fn_) {
            self.accept(run, r);
        } else if r.f.lt(&fw) {
            match oc {
                Some(oc) if !r.f.lt(&oc.f) => self.accept(run, oc),
                Some(_) => self.shrink(run),
                None => {
                    let z = self.trial(&run.space, 0.5);
                    self.new_batch(run, vec![z], Phase::Contract { reflection: r, outside: true });
                }
            }
        } else {
            match ic {
                Some(ic) if ic.f.lt(&fw) => self.accept(run, ic),
                Some(_) => self.shrink(run),
                None => {
                    let z = self.trial(&run.space, -0.5);
                    self.new_batch(run, vec![z], Phase::Contract { reflection: r, outside: false });
                }
            }
        }
    }
}

/// Vertex `i` of `run`'s completed batch, with its value from `values`.
fn vertex(run: &RunState, i: usize, values: &[Fitness]) -> Vertex {
    Vertex { z: run.batch.z[i].clone(), f: values[i] }
}

impl Step for NelderMeadSteps {
    fn done(&self) -> Option<Termination> {
        match self.phase {
            Phase::Done(t) => Some(t),
            _ => None,
        }
    }

    /// Applies the batch that just completed.
    fn advance(&mut self, run: &mut RunState) {
        let values = run.absorb();
        let n = run.space.dim();
        match std::mem::replace(&mut self.phase, Phase::Initial) {
            Phase::Initial => {
                self.simplex = (0..=n).map(|i| vertex(run, i, &values)).collect();
                self.start_iteration(run);
            }
            Phase::Trial => {
                let [r, e, oc, ic] = [0, 1, 2, 3].map(|i| vertex(run, i, &values));
                self.decide(run, r, Some(e), Some(oc), Some(ic));
            }
            Phase::Reflect => {
                let r = vertex(run, 0, &values);
                self.decide(run, r, None, None, None);
            }
            Phase::Expand { reflection } => {
                let e = vertex(run, 0, &values);
                self.decide(run, reflection, Some(e), None, None);
            }
            Phase::Contract { reflection, outside } => {
                let c = vertex(run, 0, &values);
                if outside {
                    self.decide(run, reflection, None, Some(c), None);
                } else {
                    self.decide(run, reflection, None, None, Some(c));
                }
            }
            phase @ (Phase::Shrink | Phase::Rebuild) => {
                for i in 0..n {
                    self.simplex[i + 1] = vertex(run, i, &values);
                }
                if phase == Phase::Shrink {
                    run.iterations += 1;
                } else {
                    self.projected = false;
                }
                self.after_update(run);
            }
            Phase::Done(t) => self.phase = Phase::Done(t),
        }
    }
}

/// z0 moved by `step` along axis i, away from zero (so x0ᵢ·1.05 for the default scaling of
/// unbounded parameters, as SciPy does), or the other way where that leaves the box.
fn step_along(space: &Space, z0: &[f64], i: usize, step: f64) -> f64 {
    let (lo, hi) = space.z_bounds(i);
    let step = if z0[i] < 0.0 { -step } else { step };
    if (lo..=hi).contains(&(z0[i] + step)) {
        z0[i] + step
    } else if (lo..=hi).contains(&(z0[i] - step)) {
        z0[i] - step
    } else if hi - z0[i] >= z0[i] - lo {
        hi
    } else {
        lo
    }
}

/// |det E| / Π‖eᵢ‖ for the edges eᵢ = zᵢ − z₀: 1 for orthogonal edges, 0 when flat.
fn normalized_volume(simplex: &[Vertex]) -> f64 {
    let n = simplex.len() - 1;
    let mut m: Vec<Vec<f64>> =
        simplex[1..].iter().map(|v| v.z.iter().zip(&simplex[0].z).map(|(a, b)| a - b).collect()).collect();
    let norms: f64 = m.iter().map(|e| e.iter().map(|x| x * x).sum::<f64>().sqrt()).product();
    if norms == 0.0 {
        return 0.0;
    }
    let mut det = 1.0;
    for col in 0..n {
        let piv = (col..n).max_by(|&a, &b| m[a][col].abs().total_cmp(&m[b][col].abs())).unwrap_or(col);
        if m[piv][col] == 0.0 {
            return 0.0;
        }
        if piv != col {
            m.swap(piv, col);
            det = -det;
        }
        det *= m[col][col];
        for r in col + 1..n {
            let f = m[r][col] / m[col][col];
            for k in col..n {
                m[r][k] -= f * m[col][k];
            }
        }
    }
    det.abs() / norms
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_problems::{self as tp, run};
    use crate::{Optimizer, Outcome, Status};

    fn minimize(f: fn(&[f64]) -> f64, lower: &[f64], upper: &[f64], x0: &[f64], settings: NmSettings) -> NelderMead {
        let mut nm = NelderMead::new(lower, upper, x0, settings).unwrap();
        run(&mut nm, &|x| Outcome::Value(f(x)), 1_000_000);
        nm
    }

    fn tight(n: usize, parallel: bool) -> NmSettings {
        let mut s = NmSettings::new(n);
        s.parallel = parallel;
        s.stopping = Stopping { x_tol: Some(1e-10), f_tol: Some(1e-16), max_iters: Some(20_000), max_fevals: None };
        s
    }

    #[test]
    fn rosenbrock_2d_from_the_standard_start_reaches_1e_8() {
        let inf = f64::INFINITY;
        for parallel in [true, false] {
            let nm = minimize(tp::rosenbrock, &[-inf, -inf], &[inf, inf], &[-1.2, 1.0], tight(2, parallel));
            let (x, f) = nm.best().unwrap();
            assert!(f < 1e-8, "parallel={parallel}: f = {f:e} at {x:?}");
            assert!(matches!(nm.status(), Status::Done(_)));
        }
    }

    #[test]
    fn sphere_rosenbrock_4d_and_beale_converge() {
        let inf = f64::INFINITY;
        let cases: [(fn(&[f64]) -> f64, &[f64], &[f64], f64); 3] = [
            (tp::sphere, &[3.0, -2.0, 1.0], &[0.0; 3], 1e-12),
            (tp::rosenbrock, &[-1.2, 1.0, -1.2, 1.0], &[1.0; 4], 1e-6),
            (tp::beale, &[1.0, 1.0], &[3.0, 0.5], 1e-6),
        ];
        for (f, x0, x_star, tol) in cases {
            let n = x0.len();
            let nm = minimize(f, &vec![-inf; n], &vec![inf; n], x0, tight(n, true));
            let (x, _) = nm.best().unwrap();
            for (a, b) in x.iter().zip(x_star) {
                assert!((a - b).abs() < tol.sqrt(), "{x:?} vs {x_star:?}");
            }
        }
    }

    #[test]
    fn optimum_on_a_bound_is_found_and_no_point_leaves_the_box() {
        let (lower, upper) = ([2.0, -1.0], [5.0, 3.0]);
        let mut nm = NelderMead::new(&lower, &upper, &[4.0, 2.0], tight(2, true)).unwrap();
        let mut rounds = 0;
        while let batch = nm.ask()
            && !batch.is_empty()
            && rounds < 100_000
        {
            rounds += 1;
            for c in batch {
                assert!(c.x.iter().zip(&lower).zip(&upper).all(|((x, l), u)| l <= x && x <= u), "{:?}", c.x);
                nm.tell(c.id, Outcome::Value(tp::shifted_sphere(&c.x))).unwrap();
            }
        }
        let (x, f) = nm.best().unwrap();
        assert!((x[0] - 2.0).abs() < 1e-6 && (x[1] + 1.0).abs() < 1e-6, "{x:?}");
        assert!((f - 2.0).abs() < 1e-9);
    }

    #[test]
    fn sequential_and_parallel_follow_the_same_simplex_path() {
        let inf = f64::INFINITY;
        let seq = minimize(tp::rosenbrock, &[-inf, -inf], &[inf, inf], &[-1.2, 1.0], tight(2, false));
        let par = minimize(tp::rosenbrock, &[-inf, -inf], &[inf, inf], &[-1.2, 1.0], tight(2, true));
        assert_eq!(seq.algorithm.simplex, par.algorithm.simplex);
        assert_eq!(seq.iterations(), par.iterations());
        assert!(par.rounds() < seq.evaluations(), "{} rounds vs {} evaluations", par.rounds(), seq.evaluations());
        assert!(seq.evaluations() < par.evaluations(), "sequential mode should need fewer evaluations");
    }

    #[test]
    fn termination_reports_the_rule_that_fired() {
        let inf = f64::INFINITY;
        let mut s = NmSettings::new(2);
        s.stopping = Stopping { x_tol: None, f_tol: None, max_iters: Some(7), max_fevals: None };
        let nm = minimize(tp::rosenbrock, &[-inf, -inf], &[inf, inf], &[-1.2, 1.0], s.clone());
        assert_eq!((nm.status(), nm.iterations()), (Status::Done(Termination::MaxIters), 7));
        s.stopping = Stopping { x_tol: None, f_tol: None, max_iters: None, max_fevals: Some(30) };
        let nm = minimize(tp::rosenbrock, &[-inf, -inf], &[inf, inf], &[-1.2, 1.0], s.clone());
        assert_eq!(nm.status(), Status::Done(Termination::MaxFevals));
        s.stopping = Stopping { x_tol: Some(1e-3), f_tol: None, max_iters: None, max_fevals: None };
        let nm = minimize(tp::sphere, &[-inf, -inf], &[inf, inf], &[1.0, 1.0], s.clone());
        assert_eq!(nm.status(), Status::Done(Termination::XTol));
        assert!(nm.algorithm.size() <= 1e-3);
        s.stopping = Stopping { x_tol: None, f_tol: Some(1e-3), max_iters: None, max_fevals: None };
        let nm = minimize(tp::sphere, &[-inf, -inf], &[inf, inf], &[1.0, 1.0], s);
        assert_eq!(nm.status(), Status::Done(Termination::FTol));
    }

    #[test]
    fn bad_settings_name_the_field() {
        let mut s = NmSettings::new(2);
        s.stopping.x_tol = Some(0.0);
        tp::assert_names_setting(NelderMead::new(&[0.0, 0.0], &[1.0, 1.0], &[0.5, 0.5], s), "x_tol");
        let mut s = NmSettings::new(2);
        s.initial_step = -1.0;
        tp::assert_names_setting(NelderMead::new(&[0.0, 0.0], &[1.0, 1.0], &[0.5, 0.5], s), "initial_step");
        tp::assert_names_setting(NelderMead::new(&[0.0, 0.0], &[1.0, 1.0], &[0.5, 1.5], NmSettings::new(2)), "x0");
    }

    #[test]
    fn failed_points_rank_worst_and_the_search_goes_on() {
        let inf = f64::INFINITY;
        let mut nm = NelderMead::new(&[-inf, -inf], &[inf, inf], &[-1.2, 1.0], tight(2, true)).unwrap();
        // Everything with x0 > 1.5 "crashes": the optimum (1, 1) stays reachable.
        run(&mut nm, &|x| if x[0] > 1.5 { Outcome::Failed } else { Outcome::Value(tp::rosenbrock(x)) }, 100_000);
        assert!(nm.best().unwrap().1 < 1e-8);
    }
}
