//! Protocol messages built by the hardening tests (`tests/hardening.rs`) and by the gRPC probe
//! (`bench/probe_grpc.rs`, which includes this file).

use fmucal_proto::v1 as pb;

/// `base` with its optimizer set to `algorithm` (`genetic`, else differential evolution) with a
/// population of `population`.
pub fn with_population(base: &pb::JobSpec, algorithm: &str, population: u64) -> pb::JobSpec {
    let mut j = base.clone();
    let o = j.optimizer.get_or_insert_with(Default::default);
    o.algorithm = Some(match algorithm {
        "genetic" => pb::optimizer_spec::Algorithm::Genetic(pb::GeneticOptions {
            population: Some(population),
            ..Default::default()
        }),
        _ => pb::optimizer_spec::Algorithm::DifferentialEvolution(pb::DifferentialEvolutionOptions {
            population: Some(population),
            ..Default::default()
        }),
    });
    j
}
