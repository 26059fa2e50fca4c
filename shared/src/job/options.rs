//! The `[optimizer]` section of a job: [`OptimizerSpec`], the settings every algorithm shares,
//! with [`AlgorithmOptions`], one options type per algorithm. An option exists only for the
//! algorithms that use it, so the protocol (a `oneof`), the optimizer's build
//! ([`super::optimizer::build`], which merges each type with its optimizer's defaults) and
//! the clients carry each setting once.
//!
//! The TOML table stays flat (`algorithm = "genetic"`, `mutation_rate = 0.02`, ...): it is read
//! through the private [`OptimizerTable`] and converted here, in one place, and written back
//! as the same text. A field the chosen algorithm does not take is refused, naming it:
//! `optimizer.mutation_rate: applies to genetic, not nelder-mead`. The flat form
//! ([`FlatOptions`]) is also how protocol version 3 carried the options; its reader
//! ([`AlgorithmOptions::from_flat_lenient`]) drops those that never applied, so a job stored
//! by an older coordinator still resumes.

use serde::{Deserialize, Serialize};

use super::JobError;
use super::choices::{Algorithm, optional_text};

/// The optimizer settings of a job: the stopping rules and seed every algorithm shares, and
/// the algorithm with its own options.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "OptimizerTable", into = "OptimizerTable")]
pub struct OptimizerSpec {
    /// Simplex/population size rule (scaled); 0 disables it. Default: 1e-6.
    pub x_tol: Option<f64>,
    /// Spread of objective values rule; 0 disables it. Default: 1e-8. Least squares does not
    /// use it: it stops on x_tol (its trust radius), slow progress, max_iters and max_fevals.
    pub f_tol: Option<f64>,
    /// Iterations (NM, least squares) or generations (DE, GA, CMA-ES). With `max_fevals`
    /// unset too, the algorithm's default budget ([`super::optimizer::default_budget`]):
    /// Nelder–Mead 200·n iterations, least squares 100·n evaluations, DE, GA and CMA-ES 1000·n
    /// generations, for n parameters.
    pub max_iters: Option<u64>,
    /// Objective evaluations (see `max_iters` for the default).
    pub max_fevals: Option<u64>,
    /// Wall time in seconds after which the run stops with its best point so far (termination
    /// `max_time reached`). Enforced by `fmucal calibrate`, local or with `--coordinator`.
    pub max_time: Option<f64>,
    /// Seed of DE, GA and CMA-ES. Default: 0.
    pub seed: u64,
    /// The algorithm and its options.
    pub options: AlgorithmOptions,
}

/// `$form { x_tol: from.x_tol, ..., seed: from.seed, $($rest)* }`: a form of the optimizer
/// settings ([`OptimizerSpec`](crate::job::options::OptimizerSpec), the TOML table, the
/// protocol's message) with the settings every algorithm shares copied from `$from`, another
/// form, and its other fields as `$rest` gives them. Every conversion between the forms lists
/// the shared settings here, once.
#[macro_export]
macro_rules! with_shared_optimizer_settings {
    ($form:path { $($rest:tt)* } from $from:expr) => {{
        let from = &$from;
        $form {
            x_tol: from.x_tol,
            f_tol: from.f_tol,
            max_iters: from.max_iters,
            max_fevals: from.max_fevals,
            max_time: from.max_time,
            seed: from.seed,
            $($rest)*
        }
    }};
}

/// The algorithm of a job with its own options; unset options take the optimizer's defaults
/// ([`super::optimizer::build`]).
#[derive(Debug, Clone, PartialEq)]
pub enum AlgorithmOptions {
    /// No algorithm named: the default, Nelder–Mead, with these options. Kept apart from
    /// [`AlgorithmOptions::NelderMead`] so that a job written back says only what its author
    /// chose.
    Unnamed(NelderMeadOptions),
    NelderMead(NelderMeadOptions),
    DifferentialEvolution(DifferentialEvolutionOptions),
    Genetic(GeneticOptions),
    CmaEs(CmaEsOptions),
    LeastSquares(LeastSquaresOptions),
}

impl Default for AlgorithmOptions {
    fn default() -> Self {
        AlgorithmOptions::Unnamed(NelderMeadOptions::default())
    }
}

/// Nelder–Mead's options.
#[derive(Debug, Clone, PartialEq)]
pub struct NelderMeadOptions {
    /// Evaluate the four trial points as one batch. Default: true.
    pub parallel: bool,
    /// Initial simplex edge (scaled). Default: 0.05.
    pub initial_step: Option<f64>,
}

impl Default for NelderMeadOptions {
    fn default() -> Self {
        NelderMeadOptions { parallel: true, initial_step: None }
    }
}

/// Differential evolution's options.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct DifferentialEvolutionOptions {
    pub population: Option<usize>,
    /// Weight F.
    pub weight: Option<f64>,
    /// Crossover probability CR.
    pub crossover: Option<f64>,
}

/// The genetic algorithm's options.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct GeneticOptions {
    pub population: Option<usize>,
    /// Bits per parameter.
    pub bits: Option<u32>,
    pub crossover_rate: Option<f64>,
    pub mutation_rate: Option<f64>,
    pub elitism: Option<usize>,
}

/// CMA-ES's options.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct CmaEsOptions {
    /// Initial step size σ₀ (scaled). Default: 0.3.
    pub initial_step: Option<f64>,
    /// Population of its first run.
    pub population: Option<usize>,
    /// IPOP restarts, each with twice the population, after a run meets x_tol or f_tol.
    /// Default: 0.
    pub restarts: Option<u32>,
}

/// The least-squares solver's options.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct LeastSquaresOptions {
    /// Initial trust radius (scaled). Default: 0.1.
    pub initial_step: Option<f64>,
}

/// Every algorithm's options side by side, as the TOML table holds them and as protocol
/// version 3 carried them. `parallel` is true unless set false.
#[derive(Debug, Clone, PartialEq)]
pub struct FlatOptions {
    pub parallel: bool,
    pub initial_step: Option<f64>,
    pub population: Option<usize>,
    pub restarts: Option<u32>,
    pub weight: Option<f64>,
    pub crossover: Option<f64>,
    pub bits: Option<u32>,
    pub crossover_rate: Option<f64>,
    pub mutation_rate: Option<f64>,
    pub elitism: Option<usize>,
}

impl Default for FlatOptions {
    fn default() -> Self {
        FlatOptions {
            parallel: true,
            initial_step: None,
            population: None,
            restarts: None,
            weight: None,
            crossover: None,
            bits: None,
            crossover_rate: None,
            mutation_rate: None,
            elitism: None,
        }
    }
}

/// An option given for an algorithm that does not take it.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("optimizer.{field}: {message}")]
pub struct OptionError {
    /// The option's name in the `[optimizer]` table.
    pub field: &'static str,
    pub message: String,
}

impl From<OptionError> for JobError {
    fn from(e: OptionError) -> Self {
        JobError::invalid(format!("optimizer.{}", e.field), e.message)
    }
}

use Algorithm::{CmaEs, DifferentialEvolution, Genetic, LeastSquares, NelderMead};

/// Which algorithms take each flat option, in the table's order.
const TAKEN_BY: [(&str, &[Algorithm]); 10] = [
    ("parallel", &[NelderMead]),
    ("initial_step", &[NelderMead, CmaEs, LeastSquares]),
    ("population", &[DifferentialEvolution, Genetic, CmaEs]),
    ("restarts", &[CmaEs]),
    ("weight", &[DifferentialEvolution]),
    ("crossover", &[DifferentialEvolution]),
    ("bits", &[Genetic]),
    ("crossover_rate", &[Genetic]),
    ("mutation_rate", &[Genetic]),
    ("elitism", &[Genetic]),
];

impl FlatOptions {
    /// The names of the options set, in the table's order (`parallel` when false).
    fn set_fields(&self) -> Vec<&'static str> {
        let set = [
            !self.parallel,
            self.initial_step.is_some(),
            self.population.is_some(),
            self.restarts.is_some(),
            self.weight.is_some(),
            self.crossover.is_some(),
            self.bits.is_some(),
            self.crossover_rate.is_some(),
            self.mutation_rate.is_some(),
            self.elitism.is_some(),
        ];
        TAKEN_BY.iter().zip(set).filter(|(_, s)| *s).map(|((name, _), _)| *name).collect()
    }
}

impl AlgorithmOptions {
    /// The named `algorithm` (none: [`AlgorithmOptions::Unnamed`]) with every option unset.
    pub fn new(algorithm: Option<Algorithm>) -> Self {
        Self::from_flat_lenient(algorithm, FlatOptions::default())
    }

    /// The options of `algorithm` (none: the default, unnamed) from the flat table.
    ///
    /// # Errors
    /// [`OptionError`] naming the first option set that `algorithm` does not take
    /// (`parallel` only when false: every job written back says `parallel = true`).
    pub fn from_flat(algorithm: Option<Algorithm>, flat: FlatOptions) -> Result<Self, OptionError> {
        let runs = algorithm.unwrap_or_default();
        for field in flat.set_fields() {
            let takers = TAKEN_BY.iter().find(|(n, _)| *n == field).map_or(&[][..], |(_, t)| *t);
            if !takers.contains(&runs) {
                let names: Vec<String> = takers.iter().map(ToString::to_string).collect();
                let listed = match names.split_last() {
                    Some((last, [])) => last.clone(),
                    Some((last, rest)) => format!("{} or {last}", rest.join(", ")),
                    None => String::new(),
                };
                let default = if algorithm.is_none() { " (the default algorithm)" } else { "" };
                return Err(OptionError { field, message: format!("applies to {listed}, not {runs}{default}") });
            }
        }
        Ok(Self::from_flat_lenient(algorithm, flat))
    }

    /// The options of `algorithm` from the flat table, dropping those it does not take: how a
    /// job of protocol version 3 is read, whose clients sent every option (those never
    /// applied to the other algorithms).
    pub fn from_flat_lenient(algorithm: Option<Algorithm>, f: FlatOptions) -> Self {
        let nelder_mead = NelderMeadOptions { parallel: f.parallel, initial_step: f.initial_step };
        match algorithm {
            None => AlgorithmOptions::Unnamed(nelder_mead),
            Some(NelderMead) => AlgorithmOptions::NelderMead(nelder_mead),
            Some(DifferentialEvolution) => AlgorithmOptions::DifferentialEvolution(DifferentialEvolutionOptions {
                population: f.population,
                weight: f.weight,
                crossover: f.crossover,
            }),
            Some(Genetic) => AlgorithmOptions::Genetic(GeneticOptions {
                population: f.population,
                bits: f.bits,
                crossover_rate: f.crossover_rate,
                mutation_rate: f.mutation_rate,
                elitism: f.elitism,
            }),
            Some(CmaEs) => AlgorithmOptions::CmaEs(CmaEsOptions {
                initial_step: f.initial_step,
                population: f.population,
                restarts: f.restarts,
            }),
            Some(LeastSquares) => AlgorithmOptions::LeastSquares(LeastSquaresOptions { initial_step: f.initial_step }),
        }
    }

    /// The flat table of these options (the others unset, `parallel` true).
    pub fn to_flat(&self) -> FlatOptions {
        let d = FlatOptions::default();
        match self {
            AlgorithmOptions::Unnamed(o) | AlgorithmOptions::NelderMead(o) => {
                FlatOptions { parallel: o.parallel, initial_step: o.initial_step, ..d }
            }
            AlgorithmOptions::DifferentialEvolution(o) => {
                FlatOptions { population: o.population, weight: o.weight, crossover: o.crossover, ..d }
            }
            AlgorithmOptions::Genetic(o) => FlatOptions {
                population: o.population,
                bits: o.bits,
                crossover_rate: o.crossover_rate,
                mutation_rate: o.mutation_rate,
                elitism: o.elitism,
                ..d
            },
            AlgorithmOptions::CmaEs(o) => {
                FlatOptions { initial_step: o.initial_step, population: o.population, restarts: o.restarts, ..d }
            }
            AlgorithmOptions::LeastSquares(o) => FlatOptions { initial_step: o.initial_step, ..d },
        }
    }

    /// The algorithm that runs: the one named, else the default.
    pub fn algorithm(&self) -> Algorithm {
        self.named_algorithm().unwrap_or_default()
    }

    /// The algorithm the job names, if it names one.
    pub fn named_algorithm(&self) -> Option<Algorithm> {
        match self {
            AlgorithmOptions::Unnamed(_) => None,
            AlgorithmOptions::NelderMead(_) => Some(NelderMead),
            AlgorithmOptions::DifferentialEvolution(_) => Some(DifferentialEvolution),
            AlgorithmOptions::Genetic(_) => Some(Genetic),
            AlgorithmOptions::CmaEs(_) => Some(CmaEs),
            AlgorithmOptions::LeastSquares(_) => Some(LeastSquares),
        }
    }
}

impl OptimizerSpec {
    /// The algorithm that runs: the one the job names, else the default.
    pub fn algorithm(&self) -> Algorithm {
        self.options.algorithm()
    }

    /// The algorithm the job names, if it names one.
    pub fn named_algorithm(&self) -> Option<Algorithm> {
        self.options.named_algorithm()
    }

    /// Names `algorithm`, keeping the options it shares with the current one (the initial
    /// step, the population, Nelder–Mead's `parallel`); the others take their defaults.
    pub fn set_algorithm(&mut self, algorithm: Algorithm) {
        if self.named_algorithm() != Some(algorithm) {
            let flat = self.options.to_flat();
            self.options = AlgorithmOptions::from_flat_lenient(Some(algorithm), flat);
        }
    }

    /// Nelder–Mead: evaluate the trial points as one batch; true for the other algorithms.
    pub fn parallel(&self) -> bool {
        self.options.to_flat().parallel
    }

    /// The initial step (Nelder–Mead's simplex edge, CMA-ES's σ₀, least squares' trust
    /// radius), if set.
    pub fn initial_step(&self) -> Option<f64> {
        self.options.to_flat().initial_step
    }

    /// The initial step of an algorithm that takes one (Nelder–Mead, CMA-ES, least squares),
    /// to set; `None` for the others.
    pub fn initial_step_mut(&mut self) -> Option<&mut Option<f64>> {
        match &mut self.options {
            AlgorithmOptions::Unnamed(o) | AlgorithmOptions::NelderMead(o) => Some(&mut o.initial_step),
            AlgorithmOptions::CmaEs(o) => Some(&mut o.initial_step),
            AlgorithmOptions::LeastSquares(o) => Some(&mut o.initial_step),
            AlgorithmOptions::DifferentialEvolution(_) | AlgorithmOptions::Genetic(_) => None,
        }
    }

    /// Sets the initial step where the algorithm takes one ([`Self::initial_step_mut`]).
    pub fn set_initial_step(&mut self, step: Option<f64>) {
        if let Some(s) = self.initial_step_mut() {
            *s = step;
        }
    }

    /// The population (DE, GA, CMA-ES's first run), if set.
    pub fn population(&self) -> Option<usize> {
        self.options.to_flat().population
    }

    /// CMA-ES's IPOP restarts, if set.
    pub fn restarts(&self) -> Option<u32> {
        self.options.to_flat().restarts
    }
}

/// The `[optimizer]` table as written: every algorithm's options side by side. Its fields and
/// their order are the job file's format.
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct OptimizerTable {
    #[serde(default, with = "optional_text", skip_serializing_if = "Option::is_none")]
    algorithm: Option<Algorithm>,
    #[serde(default = "default_true")]
    parallel: bool,
    x_tol: Option<f64>,
    f_tol: Option<f64>,
    max_iters: Option<u64>,
    max_fevals: Option<u64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    max_time: Option<f64>,
    #[serde(default)]
    seed: u64,
    initial_step: Option<f64>,
    population: Option<usize>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    restarts: Option<u32>,
    weight: Option<f64>,
    crossover: Option<f64>,
    bits: Option<u32>,
    crossover_rate: Option<f64>,
    mutation_rate: Option<f64>,
    elitism: Option<usize>,
}

fn default_true() -> bool {
    true
}

impl TryFrom<OptimizerTable> for OptimizerSpec {
    type Error = OptionError;

    fn try_from(t: OptimizerTable) -> Result<Self, OptionError> {
        let flat = FlatOptions {
            parallel: t.parallel,
            initial_step: t.initial_step,
            population: t.population,
            restarts: t.restarts,
            weight: t.weight,
            crossover: t.crossover,
            bits: t.bits,
            crossover_rate: t.crossover_rate,
            mutation_rate: t.mutation_rate,
            elitism: t.elitism,
        };
        let options = AlgorithmOptions::from_flat(t.algorithm, flat)?;
        Ok(with_shared_optimizer_settings!(OptimizerSpec { options } from t))
    }
}

impl From<OptimizerSpec> for OptimizerTable {
    fn from(o: OptimizerSpec) -> Self {
        let f = o.options.to_flat();
        with_shared_optimizer_settings!(OptimizerTable {
            algorithm: o.options.named_algorithm(),
            parallel: f.parallel,
            initial_step: f.initial_step,
            population: f.population,
            restarts: f.restarts,
            weight: f.weight,
            crossover: f.crossover,
            bits: f.bits,
            crossover_rate: f.crossover_rate,
            mutation_rate: f.mutation_rate,
            elitism: f.elitism,
        } from o)
    }
}

/// The one-line error of an `[optimizer]` option its algorithm does not take, when that is
/// what the TOML parser's error `e` of `text` reports; `None` for any other error (it keeps
/// the parser's layout).
pub(super) fn option_error(text: &str, e: &toml::de::Error) -> Option<JobError> {
    let document: toml::Table = text.parse().ok()?;
    let table: OptimizerTable = document.get("optimizer")?.clone().try_into().ok()?;
    let error = OptimizerSpec::try_from(table).err()?;
    (e.message().trim() == error.to_string()).then(|| error.into())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::job::JobSpec;
    use crate::job::spec::tests::JOB;
    use std::path::Path;

    fn read(optimizer: &str) -> Result<OptimizerSpec, String> {
        JobSpec::from_toml(&format!("{JOB}[optimizer]\n{optimizer}\n"), Path::new("."))
            .map(|s| s.optimizer)
            .map_err(|e| e.to_string())
    }

    #[test]
    fn an_option_of_another_algorithm_is_one_line_naming_it() {
        let e = read("mutation_rate = 0.02").unwrap_err();
        assert_eq!(e, "optimizer.mutation_rate: applies to genetic, not nelder-mead (the default algorithm)");
        let e = read("algorithm = \"nelder-mead\"\nmutation_rate = 0.02").unwrap_err();
        assert_eq!(e, "optimizer.mutation_rate: applies to genetic, not nelder-mead");
        let e = read("algorithm = \"least-squares\"\npopulation = 4").unwrap_err();
        assert_eq!(e, "optimizer.population: applies to differential-evolution, genetic or cma-es, not least-squares");
        let e = read("algorithm = \"genetic\"\nparallel = false").unwrap_err();
        assert_eq!(e, "optimizer.parallel: applies to nelder-mead, not genetic");
        // Every job written back says `parallel = true`.
        read("algorithm = \"genetic\"\nparallel = true").unwrap();
        // Another error keeps the parser's layout.
        let e = read("algorithm = \"genetic\"\nmutation_rate = \"x\"").unwrap_err();
        assert!(e.starts_with("toml: TOML parse error"), "{e}");
    }

    #[test]
    fn each_algorithm_reads_its_options_and_writes_back_the_same_table() {
        for (table, options) in [
            ("", AlgorithmOptions::Unnamed(NelderMeadOptions::default())),
            (
                "parallel = false\ninitial_step = 0.2",
                AlgorithmOptions::Unnamed(NelderMeadOptions { parallel: false, initial_step: Some(0.2) }),
            ),
            (
                "algorithm = \"nelder-mead\"\ninitial_step = 0.2",
                AlgorithmOptions::NelderMead(NelderMeadOptions { parallel: true, initial_step: Some(0.2) }),
            ),
            (
                "algorithm = \"differential-evolution\"\npopulation = 20\nweight = 0.7\ncrossover = 0.9",
                AlgorithmOptions::DifferentialEvolution(DifferentialEvolutionOptions {
                    population: Some(20),
                    weight: Some(0.7),
                    crossover: Some(0.9),
                }),
            ),
            (
                "algorithm = \"genetic\"\npopulation = 30\nbits = 16\ncrossover_rate = 0.8\nmutation_rate = 0.02\nelitism = 2",
                AlgorithmOptions::Genetic(GeneticOptions {
                    population: Some(30),
                    bits: Some(16),
                    crossover_rate: Some(0.8),
                    mutation_rate: Some(0.02),
                    elitism: Some(2),
                }),
            ),
            (
                "algorithm = \"cma-es\"\ninitial_step = 0.3\npopulation = 8\nrestarts = 2",
                AlgorithmOptions::CmaEs(CmaEsOptions {
                    initial_step: Some(0.3),
                    population: Some(8),
                    restarts: Some(2),
                }),
            ),
            (
                "algorithm = \"least-squares\"\ninitial_step = 0.1",
                AlgorithmOptions::LeastSquares(LeastSquaresOptions { initial_step: Some(0.1) }),
            ),
        ] {
            let spec = read(&format!("{table}\nseed = 3\nx_tol = 0.001")).unwrap();
            assert_eq!(spec.options, options, "{table}");
            assert_eq!((spec.seed, spec.x_tol), (3, Some(1e-3)));
            let written = toml::to_string(&spec).unwrap();
            let back: OptimizerSpec = toml::from_str(&written).unwrap();
            assert_eq!(back, spec, "{written}");
            assert_eq!(written.contains("algorithm"), options.named_algorithm().is_some(), "{written}");
        }
    }

    #[test]
    fn a_job_is_written_back_as_the_flat_table_it_was() {
        let spec = read("algorithm = \"genetic\"\nmutation_rate = 0.02\nmax_time = 5.0").unwrap();
        let text = toml::to_string(&spec).unwrap();
        assert_eq!(text, "algorithm = \"genetic\"\nparallel = true\nmax_time = 5.0\nseed = 0\nmutation_rate = 0.02\n");
        let spec = read("parallel = false\ninitial_step = 0.2").unwrap();
        assert_eq!(toml::to_string(&spec).unwrap(), "parallel = false\nseed = 0\ninitial_step = 0.2\n");
    }

    #[test]
    fn switching_the_algorithm_keeps_the_options_both_take() {
        let mut o = read("initial_step = 0.2\nparallel = false").unwrap();
        o.set_algorithm(Algorithm::LeastSquares);
        assert_eq!(o.options, AlgorithmOptions::LeastSquares(LeastSquaresOptions { initial_step: Some(0.2) }));
        let mut o = read("algorithm = \"genetic\"\npopulation = 30\nbits = 8").unwrap();
        o.set_algorithm(Algorithm::CmaEs);
        assert_eq!(o.population(), Some(30));
        assert_eq!(o.initial_step(), None);
        o.set_initial_step(Some(0.5));
        assert_eq!(o.initial_step(), Some(0.5));
        o.set_algorithm(Algorithm::DifferentialEvolution);
        o.set_initial_step(Some(0.5));
        assert_eq!((o.initial_step(), o.population()), (None, Some(30)));
    }
}
