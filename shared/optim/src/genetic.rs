//! A genetic algorithm as Andersson et al. 2012 (section 4.2.2) describe it: individuals are
//! bit strings with `bits` bits per parameter, decoded uniformly over the box
//! (z = k / (2^bits − 1)); each generation selects parents with probability decreasing with
//! their objective value, recombines them by single-point crossover (rate ≈ 0.7), flips bits at
//! a low rate, and keeps the best `elitism` individuals unchanged. One generation is one batch
//! (the new children only; elites keep their cached values).
//!
//! - **Selection** is rank-based roulette: the k-th best of N is drawn with probability
//!   ∝ N − k. Ranks come from the total order of [`Fitness`], so failed evaluations simply rank
//!   last and infinite values need no special care.
//! - Needs finite bounds. x0 (if given) is encoded as the first member of the first population.
//! - Termination (first met): x_tol on the population's size (scaled), f_tol on the spread of
//!   its values, max_iters generations, max_fevals.
//!
//! Defaults: population 50, 16 bits per parameter, crossover rate 0.7, mutation rate 0.01 per
//! bit, elitism 2, seed 0, [`Stopping::default_for`].

use serde::{Deserialize, Serialize};

use super::fitness::Fitness;
use super::random::Random;
use super::run::{BatchOptimizer, PopulationPhase as Phase, RunState, Step, population_space};
use super::{OptimError, Stopping, Termination};

/// Genetic algorithm settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GaSettings {
    /// Population size (≥ 4). Default: 50.
    pub population: usize,
    /// Bits per parameter (1 to 52). Default: 16.
    pub bits: u32,
    /// Probability that a pair of parents is recombined. Default: 0.7.
    pub crossover_rate: f64,
    /// Probability that a bit flips. Default: 0.01.
    pub mutation_rate: f64,
    /// Best individuals carried over unchanged (< population). Default: 2.
    pub elitism: usize,
    /// Seed of the random generator. Default: 0.
    pub seed: u64,
    /// Stopping rules. Default: [`Stopping::default_for`] the dimension.
    pub stopping: Stopping,
}

impl GaSettings {
    /// Defaults for an `n`-dimensional problem.
    pub fn new(n: usize) -> Self {
        GaSettings {
            population: 50,
            bits: 16,
            crossover_rate: 0.7,
            mutation_rate: 0.01,
            elitism: 2,
            seed: 0,
            stopping: Stopping::default_for(n),
        }
    }
}

/// One individual: its genes (one integer per parameter) and value.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct Individual {
    genes: Vec<u64>,
    f: Fitness,
}

/// The genetic algorithm optimizer; see the module docs. Its `iterations` are the generations
/// completed.
pub type GeneticAlgorithm = BatchOptimizer<GeneticSteps>;

/// The algorithm part of [`GeneticAlgorithm`]: the population, the children being evaluated
/// and the generator.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct GeneticSteps {
    settings: GaSettings,
    population: Vec<Individual>,
    /// Genes of the children in the current batch.
    children: Vec<Vec<u64>>,
    phase: Phase,
    rng: Random,
}

impl GeneticAlgorithm {
    /// Starts the GA in `[lower, upper]` (finite), seeding the population with `x0` if given.
    ///
    /// # Errors
    /// [`OptimError::Setting`] naming the bad field: bounds (must be finite), `x0`,
    /// `population`, `bits`, `crossover_rate`, `mutation_rate`, `elitism` or a stopping rule.
    pub fn new(lower: &[f64], upper: &[f64], x0: Option<&[f64]>, settings: GaSettings) -> Result<Self, OptimError> {
        let space = population_space(lower, upper, x0, settings.population, "the genetic algorithm")?;
        if !(1..=52).contains(&settings.bits) {
            return Err(OptimError::setting("bits", format!("must be in 1..=52, got {}", settings.bits)));
        }
        for (field, v) in [("crossover_rate", settings.crossover_rate), ("mutation_rate", settings.mutation_rate)] {
            if !(0.0..=1.0).contains(&v) {
                return Err(OptimError::setting(field, format!("must be in [0, 1], got {v}")));
            }
        }
        if settings.elitism >= settings.population {
            return Err(OptimError::setting(
                "elitism",
                format!("must be below the population {}", settings.population),
            ));
        }
        settings.stopping.validate()?;
        let mut rng = Random::new(settings.seed);
        let max = (1u64 << settings.bits) - 1;
        let n = space.dim();
        let mut genomes: Vec<Vec<u64>> = vec![];
        if let Some(x0) = x0 {
            genomes.push(space.to_scaled(x0).iter().map(|z| (z.clamp(0.0, 1.0) * max as f64).round() as u64).collect());
        }
        while genomes.len() < settings.population {
            genomes.push((0..n).map(|_| random_bits(&mut rng, settings.bits)).collect());
        }
        let mut run = RunState::new(space);
        let mut algorithm = GeneticSteps { settings, population: vec![], children: vec![], phase: Phase::Initial, rng };
        algorithm.ask_children(&mut run, genomes, Phase::Initial);
        Ok(BatchOptimizer { run, algorithm })
    }
}

impl GeneticSteps {
    fn decode(&self, genes: &[u64]) -> Vec<f64> {
        let max = ((1u64 << self.settings.bits) - 1) as f64;
        genes.iter().map(|&g| g as f64 / max).collect()
    }

    fn ask_children(&mut self, run: &mut RunState, genomes: Vec<Vec<u64>>, phase: Phase) {
        let points = genomes.iter().map(|g| self.decode(g)).collect();
        run.start_batch(points);
        self.children = genomes;
        self.phase = phase;
    }

    /// Rank-based roulette: index k (0 = best) with probability ∝ N − k.
    fn select(&mut self) -> usize {
        let n = self.population.len();
        let total = n * (n + 1) / 2;
        let mut ticket = self.rng.below(total);
        for k in 0..n {
            let w = n - k;
            if ticket < w {
                return k;
            }
            ticket -= w;
        }
        n - 1
    }

    /// The children of the next generation, for `n` parameters.
    fn breed(&mut self, n: usize) -> Vec<Vec<u64>> {
        let bits = self.settings.bits as usize;
        let want = self.settings.population - self.settings.elitism;
        let mut out = Vec::with_capacity(want);
        while out.len() < want {
            let (a, b) = (self.select(), self.select());
            let mut c1 = self.population[a].genes.clone();
            let mut c2 = self.population[b].genes.clone();
            let total = bits * n;
            if total > 1 && self.rng.chance(self.settings.crossover_rate) {
                let point = 1 + self.rng.below(total - 1);
                for pos in point..total {
                    let (gene, bit) = (pos / bits, pos % bits);
                    let mask = 1u64 << bit;
                    let (x, y) = (c1[gene] & mask, c2[gene] & mask);
                    c1[gene] = (c1[gene] & !mask) | y;
                    c2[gene] = (c2[gene] & !mask) | x;
                }
            }
            for child in [&mut c1, &mut c2] {
                for g in child.iter_mut() {
                    for bit in 0..bits {
                        if self.rng.chance(self.settings.mutation_rate) {
                            *g ^= 1u64 << bit;
                        }
                    }
                }
            }
            out.push(c1);
            if out.len() < want {
                out.push(c2);
            }
        }
        out
    }

    fn check_and_continue(&mut self, run: &mut RunState) {
        self.population.sort_by(|a, b| a.f.cmp(&b.f));
        let decoded: Vec<Vec<f64>> = self.population.iter().map(|ind| self.decode(&ind.genes)).collect();
        let values = self.population.iter().map(|p| p.f);
        if let Some(t) = run.stop_if(&self.settings.stopping, &decoded[0], decoded.iter().map(Vec::as_slice), values) {
            self.phase = Phase::Done(t);
            return;
        }
        let children = self.breed(run.space.dim());
        self.ask_children(run, children, Phase::Generation);
    }
}

impl Step for GeneticSteps {
    fn done(&self) -> Option<Termination> {
        self.phase.done()
    }

    fn advance(&mut self, run: &mut RunState) {
        let values = run.absorb();
        let children: Vec<Individual> = std::mem::take(&mut self.children)
            .into_iter()
            .zip(values)
            .map(|(genes, f)| Individual { genes, f })
            .collect();
        if self.phase == Phase::Initial {
            self.population = children;
        } else {
            self.population.truncate(self.settings.elitism);
            self.population.extend(children);
            run.iterations += 1;
        }
        self.check_and_continue(run);
    }
}

fn random_bits(rng: &mut Random, bits: u32) -> u64 {
    (0..bits).fold(0u64, |acc, b| if rng.chance(0.5) { acc | (1 << b) } else { acc })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_problems::{self as tp, run};
    use crate::{Optimizer, Outcome, Status};

    #[test]
    fn rastrigin_2d_global_basin_for_a_fixed_seed() {
        let mut s = GaSettings::new(2);
        s.seed = 3;
        s.stopping.max_iters = Some(200);
        let mut ga = GeneticAlgorithm::new(&[-5.12, -5.12], &[5.12, 5.12], None, s).unwrap();
        run(&mut ga, &|x| Outcome::Value(tp::rastrigin(x)), 10_000);
        let (x, f) = ga.best().unwrap();
        assert!(x.iter().all(|v| v.abs() < 0.5), "f = {f} at {x:?}");
    }

    #[test]
    fn elites_are_not_evaluated_again() {
        let mut s = GaSettings::new(2);
        s.stopping = Stopping { x_tol: None, f_tol: None, max_iters: Some(10), max_fevals: None };
        let mut ga = GeneticAlgorithm::new(&[0.0, 0.0], &[1.0, 1.0], None, s).unwrap();
        run(&mut ga, &|x| Outcome::Value(tp::sphere(x)), 1000);
        assert_eq!(ga.evaluations(), 50 + 10 * 48);
        assert_eq!(ga.status(), Status::Done(Termination::MaxIters));
    }

    #[test]
    fn bad_settings_name_the_field() {
        let check = |s: GaSettings, field: &str| {
            tp::assert_names_setting(GeneticAlgorithm::new(&[0.0], &[1.0], None, s), field)
        };
        check(GaSettings { bits: 0, ..GaSettings::new(1) }, "bits");
        check(GaSettings { crossover_rate: 1.5, ..GaSettings::new(1) }, "crossover_rate");
        check(GaSettings { mutation_rate: -1.0, ..GaSettings::new(1) }, "mutation_rate");
        check(GaSettings { elitism: 50, ..GaSettings::new(1) }, "elitism");
        check(GaSettings { population: 2, ..GaSettings::new(1) }, "population");
    }
}
