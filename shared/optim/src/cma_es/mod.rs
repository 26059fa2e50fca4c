//! CMA-ES, the covariance matrix adaptation evolution strategy (μ/μ_w, λ), with box bounds and
//! IPOP restarts, as in Hansen's tutorial (arXiv:1604.00772) and Auger & Hansen 2005
//! (IPOP-CMA-ES).
//!
//! - **Method**: each generation samples λ steps yᵢ ~ N(0, C) around the mean m with step size
//!   σ; the ranked steps move m (weighted recombination of the best μ = ⌊λ/2⌋), adapt σ by
//!   cumulative step-size adaptation and C by the rank-one (evolution path) and rank-μ updates,
//!   with the tutorial's default active (negative) weights; C is eigendecomposed lazily
//!   (`distribution.rs`). Parameters follow the tutorial's Table 1 (`params.rs`). One generation
//!   is one batch of λ points, so a generation is evaluated in parallel.
//! - **Scaled variables**: the search runs in the unit box of the scaled variables of
//!   [`Space`](super::Space), so σ₀ is a fraction of each parameter's range. It needs finite
//!   bounds; parameters with lower = upper are held fixed and not searched.
//! - **Bounds** (`boundary.rs`): every point is asked at T(m + σ y), with T a periodic, C¹ map of
//!   each coordinate onto its interval that is the identity away from the bounds. No asked
//!   point leaves the box, and optima on a bound are reached (the objective stays smooth in the
//!   search variables there).
//! - **Start**: the first run's mean is x0 (a uniform random point if none is given), σ = σ₀,
//!   C = I.
//! - **Failures**: failed and NaN results rank after every value (then by their order in the
//!   batch), so they get the smallest (negative) weights; nothing panics on ±∞, NaN or failures.
//! - **Termination and restarts**: after each generation the local run's criteria are checked
//!   (`stop.rs`: the user's `x_tol` on σ·maxᵢ√Cᵢᵢ and `f_tol` on the range of the generation's
//!   values and the recent generations' best values, then pycma's default internal criteria TolX,
//!   TolFacUpX, TolUpSigma, ConditionCov, NoEffectAxis, NoEffectCoord, TolFun, TolFunHist,
//!   FlatFitness and TolStagnation). When one holds and restarts remain, the next run starts
//!   (IPOP): population doubled, mean uniform at random in the box, σ = σ₀, C = I. When none
//!   remain, the optimizer stops with that criterion as [`Termination::XTol`] or
//!   [`Termination::FTol`]. `max_iters` (generations, counted across restarts) and
//!   `max_fevals` end the whole run; `max_fevals` is never exceeded: the last batch is cut to the
//!   evaluations left (that partial generation is not used for an update or counted as one).
//! - `best()` is the best point of all runs. The state (generator included) serializes, and the
//!   same seed gives the same asks whatever the order of tells.
//!
//! Defaults: population 4 + ⌊3 ln n⌋, σ₀ 0.3, 9 restarts, seed 0, [`Stopping::default_for`].

mod boundary;
mod distribution;
mod params;
mod stop;

use serde::{Deserialize, Serialize};

use super::batch::Batch;
use super::fitness::Fitness;
use super::random::Random;
use super::run::{BatchOptimizer, RunState, Step, population_space};
use super::{OptimError, Stopping, Termination};
use boundary::BoxMap;
use distribution::Distribution;
use params::Params;
use stop::History;

/// The largest population a restart may reach: `population · 2^restarts` must not exceed it.
pub const MAX_POPULATION: usize = 1 << 20;

/// CMA-ES settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CmaSettings {
    /// Population λ of the first run (≥ 4); each restart doubles it. Default: 4 + ⌊3 ln n⌋.
    pub population: usize,
    /// Initial step size σ₀ in scaled variables, i.e. as a fraction of each parameter's range
    /// (> 0). Default: 0.3.
    pub sigma0: f64,
    /// Most IPOP restarts after the first run (0: a single run); `population · 2^restarts`
    /// must be at most [`MAX_POPULATION`]. Default: 9.
    pub restarts: u32,
    /// Seed of the random generator. Default: 0.
    pub seed: u64,
    /// Stopping rules: `x_tol` and `f_tol` end a local run (then restart), `max_iters`
    /// (generations over all runs) and `max_fevals` end the optimization. Default:
    /// [`Stopping::default_for`] the dimension.
    pub stopping: Stopping,
}

impl CmaSettings {
    /// Defaults for an `n`-dimensional problem.
    pub fn new(n: usize) -> Self {
        CmaSettings {
            population: 4 + (3.0 * (n.max(1) as f64).ln()).floor() as usize,
            sigma0: 0.3,
            restarts: 9,
            seed: 0,
            stopping: Stopping::default_for(n),
        }
    }
}

/// The CMA-ES optimizer; see the module docs. Its `iterations` are the generations completed,
/// over all restarts.
pub type CmaEs = BatchOptimizer<CmaEsSteps>;

/// The algorithm part of [`CmaEs`]: the current run's distribution, the steps of the batch
/// being evaluated, the value history and the generator.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct CmaEsSteps {
    settings: CmaSettings,
    /// Restarts done so far (0 in the first run).
    restart: u32,
    distribution: Distribution,
    history: History,
    /// The steps y of the current batch, in its order.
    steps: Vec<Vec<f64>>,
    rng: Random,
    done: Option<Termination>,
}

impl CmaEs {
    /// Starts CMA-ES in `[lower, upper]` (finite) with mean `x0` (a uniform random point if
    /// `None`).
    ///
    /// # Errors
    /// [`OptimError::Setting`] naming the bad field: bounds (must be finite), `x0`,
    /// `population`, `sigma0`, `restarts` or a stopping rule.
    pub fn new(lower: &[f64], upper: &[f64], x0: Option<&[f64]>, settings: CmaSettings) -> Result<Self, OptimError> {
        let space = population_space(lower, upper, x0, settings.population, "CMA-ES")?;
        if !(settings.sigma0 > 0.0 && settings.sigma0.is_finite()) {
            return Err(OptimError::setting("sigma0", format!("must be a positive number, got {}", settings.sigma0)));
        }
        let largest = 1usize.checked_shl(settings.restarts).and_then(|f| f.checked_mul(settings.population));
        if largest.is_none_or(|l| l > MAX_POPULATION) {
            return Err(OptimError::setting(
                "restarts",
                format!(
                    "population {} doubled {} times exceeds {MAX_POPULATION}",
                    settings.population, settings.restarts
                ),
            ));
        }
        settings.stopping.validate()?;
        let map = BoxMap::new(&space);
        let mut rng = Random::new(settings.seed);
        let mean = match x0 {
            Some(x0) => map.preimage(&space.to_scaled(x0)),
            None => map.random_point(&mut rng),
        };
        let mut algorithm = CmaEsSteps {
            distribution: Distribution::new(mean, settings.sigma0),
            settings,
            restart: 0,
            history: History::default(),
            steps: vec![],
            rng,
            done: None,
        };
        let mut run = RunState::new(space);
        algorithm.ask_generation(&mut run, &map);
        Ok(BatchOptimizer { run, algorithm })
    }
}

impl CmaEsSteps {
    /// λ of the current run.
    fn population(&self) -> usize {
        self.settings.population << self.restart
    }

    /// Samples the next generation (cut to the evaluations left) and hands it out.
    fn ask_generation(&mut self, run: &mut RunState, map: &BoxMap) {
        let left = self.settings.stopping.max_fevals.map_or(u64::MAX, |m| m.saturating_sub(run.evaluations));
        let count = (self.population() as u64).min(left) as usize;
        self.steps = (0..count).map(|_| self.distribution.sample(&mut self.rng)).collect();
        let points = self.steps.iter().map(|y| map.to_box(&self.distribution.point(y))).collect();
        run.start_batch(points);
    }

    /// Updates the distribution from a complete generation; returns the local run's end, if
    /// reached.
    fn update(&mut self, values: &[Fitness], map: &BoxMap) -> Option<Termination> {
        if map.dim() == 0 {
            return Some(Termination::XTol);
        }
        let p = Params::new(map.dim(), self.population());
        let mut order: Vec<usize> = (0..values.len()).collect();
        order.sort_by(|&a, &b| values[a].cmp(&values[b]).then(a.cmp(&b)));
        let ranked_steps: Vec<&[f64]> = order.iter().map(|&i| self.steps[i].as_slice()).collect();
        let ranked: Vec<Fitness> = order.iter().map(|&i| values[i]).collect();
        let updated = self.distribution.update(&ranked_steps, &p);
        map.wrap(&mut self.distribution.mean);
        self.history.push(&ranked, &p);
        if updated.is_err() {
            return Some(Termination::XTol);
        }
        stop::local_stop(&self.distribution, &p, &self.history, &ranked, &self.settings.stopping, self.settings.sigma0)
    }

    /// Starts the next IPOP run.
    fn restart(&mut self, map: &BoxMap) {
        self.restart += 1;
        let mean = map.random_point(&mut self.rng);
        self.distribution = Distribution::new(mean, self.settings.sigma0);
        self.history = History::default();
    }
}

impl Step for CmaEsSteps {
    fn done(&self) -> Option<Termination> {
        self.done
    }

    fn advance(&mut self, run: &mut RunState) {
        let map = BoxMap::new(&run.space);
        let values = run.absorb();
        let mut local = None;
        if values.len() == self.population() && values.len() == self.steps.len() {
            local = self.update(&values, &map);
            run.iterations += 1;
        }
        let whole = Stopping { x_tol: None, f_tol: None, ..self.settings.stopping };
        let global = whole.check(f64::INFINITY, f64::INFINITY, run.iterations, run.evaluations);
        let last_run = self.restart >= self.settings.restarts || map.dim() == 0;
        let stop = match (local, global) {
            (Some(t), _) if last_run => Some(t),
            (_, Some(t)) => Some(t),
            (Some(_), None) => {
                self.restart(&map);
                None
            }
            (None, None) => None,
        };
        match stop {
            Some(t) => {
                self.done = Some(t);
                self.steps.clear();
                run.batch = Batch::default();
            }
            None => self.ask_generation(run, &map),
        }
    }
}

#[cfg(test)]
mod tests;
