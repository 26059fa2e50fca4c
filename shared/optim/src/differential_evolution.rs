//! Differential evolution, rand/1/bin (Storn & Price 1997; Andersson et al. 2012, section
//! 4.2.1). Each generation is one batch: for every target xᵢ a mutant v = x_r1 + F (x_r2 − x_r3)
//! with r1, r2, r3 distinct and ≠ i, binomial crossover with probability CR (at least one
//! component from the mutant), and selection of the trial if it is no worse than the target.
//!
//! - Needs finite bounds; works in the unit box of scaled variables.
//! - **Bound rule**: a trial component outside [0, 1] is replaced by a uniform draw between the
//!   target's component and the violated bound, so trials stay feasible without piling up on
//!   the faces.
//! - The initial population is uniform in the box, with x0 (if given) as its first member.
//! - Termination (first met): x_tol on the population's size (largest ∞-norm distance from the
//!   best member, scaled), f_tol on the spread of its values, max_iters generations, max_fevals.
//!
//! Defaults: population 10·n (at least 10), F = 0.8, CR = 0.9, seed 0, [`Stopping::default_for`].

use serde::{Deserialize, Serialize};

use super::fitness::Fitness;
use super::random::Random;
use super::run::{BatchOptimizer, PopulationPhase as Phase, RunState, Step, population_space};
use super::space::Space;
use super::{OptimError, Stopping, Termination};

/// Differential evolution settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DeSettings {
    /// Population size N (≥ 4). Default: 10·n, at least 10.
    pub population: usize,
    /// Differential weight F in [0, 2]. Default: 0.8.
    pub weight: f64,
    /// Crossover probability CR in [0, 1]. Default: 0.9.
    pub crossover: f64,
    /// Seed of the random generator. Default: 0.
    pub seed: u64,
    /// Stopping rules. Default: [`Stopping::default_for`] the dimension.
    pub stopping: Stopping,
}

impl DeSettings {
    /// Defaults for an `n`-dimensional problem.
    pub fn new(n: usize) -> Self {
        DeSettings {
            population: (10 * n).max(10),
            weight: 0.8,
            crossover: 0.9,
            seed: 0,
            stopping: Stopping::default_for(n),
        }
    }
}

/// The differential evolution optimizer; see the module docs. Its `iterations` are the
/// generations completed.
pub type DifferentialEvolution = BatchOptimizer<DifferentialEvolutionSteps>;

/// The algorithm part of [`DifferentialEvolution`]: the population and the generator.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct DifferentialEvolutionSteps {
    settings: DeSettings,
    population: Vec<(Vec<f64>, Fitness)>,
    phase: Phase,
    rng: Random,
}

impl DifferentialEvolution {
    /// Starts DE in `[lower, upper]` (finite), seeding the population with `x0` if given.
    ///
    /// # Errors
    /// [`OptimError::Setting`] naming the bad field: bounds (must be finite), `x0`,
    /// `population`, `weight`, `crossover` or a stopping rule.
    pub fn new(lower: &[f64], upper: &[f64], x0: Option<&[f64]>, settings: DeSettings) -> Result<Self, OptimError> {
        let space = population_space(lower, upper, x0, settings.population, "differential evolution")?;
        if !(0.0..=2.0).contains(&settings.weight) {
            return Err(OptimError::setting("weight", format!("F must be in [0, 2], got {}", settings.weight)));
        }
        if !(0.0..=1.0).contains(&settings.crossover) {
            return Err(OptimError::setting("crossover", format!("CR must be in [0, 1], got {}", settings.crossover)));
        }
        settings.stopping.validate()?;
        let mut rng = Random::new(settings.seed);
        let n = space.dim();
        let mut points: Vec<Vec<f64>> = Vec::with_capacity(settings.population);
        if let Some(x0) = x0 {
            points.push(space.to_scaled(x0));
        }
        while points.len() < settings.population {
            points.push((0..n).map(|i| uniform_in(&space, i, &mut rng)).collect());
        }
        let mut run = RunState::new(space);
        run.start_batch(points);
        let algorithm = DifferentialEvolutionSteps { settings, population: vec![], phase: Phase::Initial, rng };
        Ok(BatchOptimizer { run, algorithm })
    }
}

impl DifferentialEvolutionSteps {
    fn trial(&mut self, space: &Space, i: usize) -> Vec<f64> {
        let np = self.population.len();
        let pick = |exclude: &[usize], rng: &mut Random| loop {
            let r = rng.below(np);
            if !exclude.contains(&r) {
                return r;
            }
        };
        let r1 = pick(&[i], &mut self.rng);
        let r2 = pick(&[i, r1], &mut self.rng);
        let r3 = pick(&[i, r1, r2], &mut self.rng);
        let n = space.dim();
        let forced = self.rng.below(n);
        let target = &self.population[i].0;
        let mut u = target.clone();
        for j in 0..n {
            if j == forced || self.rng.chance(self.settings.crossover) {
                let v = self.population[r1].0[j]
                    + self.settings.weight * (self.population[r2].0[j] - self.population[r3].0[j]);
                let (lo, hi) = space.z_bounds(j);
                u[j] = if v < lo {
                    target[j] + self.rng.uniform() * (lo - target[j])
                } else if v > hi {
                    target[j] + self.rng.uniform() * (hi - target[j])
                } else {
                    v
                };
            }
        }
        u
    }

    fn check_and_continue(&mut self, run: &mut RunState) {
        let pop = &self.population;
        let best = pop.iter().min_by(|a, b| a.1.cmp(&b.1)).map(|p| p.0.as_slice()).unwrap_or_default();
        let points = pop.iter().map(|p| p.0.as_slice());
        if let Some(t) = run.stop_if(&self.settings.stopping, best, points, pop.iter().map(|p| p.1)) {
            self.phase = Phase::Done(t);
            return;
        }
        let trials = (0..self.population.len()).map(|i| self.trial(&run.space, i)).collect();
        run.start_batch(trials);
        self.phase = Phase::Generation;
    }
}

impl Step for DifferentialEvolutionSteps {
    fn done(&self) -> Option<Termination> {
        self.phase.done()
    }

    fn advance(&mut self, run: &mut RunState) {
        let values = run.absorb();
        if self.phase == Phase::Initial {
            self.population = run.batch.z.iter().cloned().zip(values).collect();
        } else {
            for (i, (z, f)) in run.batch.z.iter().zip(values).enumerate() {
                if !self.population[i].1.lt(&f) {
                    self.population[i] = (z.clone(), f);
                }
            }
            run.iterations += 1;
        }
        self.check_and_continue(run);
    }
}

fn uniform_in(space: &Space, i: usize, rng: &mut Random) -> f64 {
    let (lo, hi) = space.z_bounds(i);
    lo + rng.uniform() * (hi - lo)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_problems::{self as tp, run};
    use crate::{Optimizer, Outcome};

    #[test]
    fn rastrigin_2d_global_basin_for_a_fixed_seed() {
        let mut s = DeSettings::new(2);
        s.seed = 7;
        s.population = 30;
        s.stopping.max_iters = Some(300);
        let mut de = DifferentialEvolution::new(&[-5.12, -5.12], &[5.12, 5.12], Some(&[3.3, -4.1]), s).unwrap();
        run(&mut de, &|x| Outcome::Value(tp::rastrigin(x)), 10_000);
        let (x, f) = de.best().unwrap();
        assert!(x.iter().all(|v| v.abs() < 0.5) && f < 1e-6, "f = {f} at {x:?}");
    }

    #[test]
    fn sphere_and_bound_optimum() {
        let mut de = DifferentialEvolution::new(&[2.0, -1.0], &[5.0, 3.0], None, DeSettings::new(2)).unwrap();
        run(&mut de, &|x| Outcome::Value(tp::shifted_sphere(x)), 10_000);
        let (x, _) = de.best().unwrap();
        assert!((x[0] - 2.0).abs() < 1e-4 && (x[1] + 1.0).abs() < 1e-4, "{x:?}");
    }

    #[test]
    fn bad_settings_name_the_field() {
        let check = |s: DeSettings, lower: f64, field: &str| {
            tp::assert_names_setting(DifferentialEvolution::new(&[lower, 0.0], &[1.0, 1.0], None, s), field)
        };
        check(DeSettings { weight: 2.5, ..DeSettings::new(2) }, 0.0, "weight");
        check(DeSettings { crossover: -0.1, ..DeSettings::new(2) }, 0.0, "crossover");
        check(DeSettings { population: 3, ..DeSettings::new(2) }, 0.0, "population");
        check(DeSettings::new(2), f64::NEG_INFINITY, "lower");
        check(DeSettings::new(2), 2.0, "lower");
    }
}
