//! A job stored by a coordinator of protocol version 3 still reads the same: that version
//! carried every algorithm's options side by side in a flat `OptimizerSpec`, and the
//! coordinator's store keeps the `JobSpec` bytes of its jobs. [`V3OptimizerSpec`] is that
//! message as version 3 declared it (its field numbers and types), filled as version 3's
//! `job_to_proto` filled it: every option, `parallel` always present.

use std::path::Path;

use fmucal_proto::convert::{SubmittedJob, job_to_proto};
use fmucal_proto::v1 as pb;
use fmucal_shared::job::spec::OptimizerSpec;
use fmucal_shared::job::{JobSpec, MeasurementTable};
use prost::Message;

/// `OptimizerSpec` of protocol version 3.
#[derive(Clone, PartialEq, prost::Message)]
struct V3OptimizerSpec {
    #[prost(string, tag = "1")]
    algorithm: String,
    #[prost(bool, optional, tag = "2")]
    parallel: Option<bool>,
    #[prost(double, optional, tag = "3")]
    x_tol: Option<f64>,
    #[prost(double, optional, tag = "4")]
    f_tol: Option<f64>,
    #[prost(uint64, optional, tag = "5")]
    max_iters: Option<u64>,
    #[prost(uint64, optional, tag = "6")]
    max_fevals: Option<u64>,
    #[prost(uint64, tag = "7")]
    seed: u64,
    #[prost(double, optional, tag = "8")]
    initial_step: Option<f64>,
    #[prost(uint64, optional, tag = "9")]
    population: Option<u64>,
    #[prost(double, optional, tag = "10")]
    weight: Option<f64>,
    #[prost(double, optional, tag = "11")]
    crossover: Option<f64>,
    #[prost(uint32, optional, tag = "12")]
    bits: Option<u32>,
    #[prost(double, optional, tag = "13")]
    crossover_rate: Option<f64>,
    #[prost(double, optional, tag = "14")]
    mutation_rate: Option<f64>,
    #[prost(uint64, optional, tag = "15")]
    elitism: Option<u64>,
    #[prost(uint32, optional, tag = "17")]
    restarts: Option<u32>,
    #[prost(double, optional, tag = "18")]
    max_time: Option<f64>,
}

/// The job with `optimizer` as its `[optimizer]` table.
fn job(optimizer: &str) -> JobSpec {
    let text = format!(
        "[model]\nid = \"m\"\n[data]\n[[outputs]]\nvariable = \"y\"\ncolumn = \"y\"\n\
         [[parameters]]\nname = \"k\"\nstart = 1.0\nlower = 0.0\nupper = 2.0\n[optimizer]\n{optimizer}\n"
    );
    JobSpec::from_toml(&text, Path::new(".")).unwrap_or_else(|e| panic!("{optimizer}: {e}"))
}

/// The flat message version 3 wrote for `optimizer`'s table, with every option of `table`.
fn v3_message(table: &toml::Table) -> V3OptimizerSpec {
    let f = |k: &str| table.get(k).and_then(|v| v.as_float().or_else(|| v.as_integer().map(|i| i as f64)));
    let u = |k: &str| table.get(k).and_then(toml::Value::as_integer).map(|i| i as u64);
    V3OptimizerSpec {
        algorithm: table.get("algorithm").and_then(|v| v.as_str()).unwrap_or_default().to_owned(),
        parallel: Some(table.get("parallel").and_then(toml::Value::as_bool).unwrap_or(true)),
        x_tol: f("x_tol"),
        f_tol: f("f_tol"),
        max_iters: u("max_iters"),
        max_fevals: u("max_fevals"),
        seed: u("seed").unwrap_or(0),
        initial_step: f("initial_step"),
        population: u("population"),
        weight: f("weight"),
        crossover: f("crossover"),
        bits: u("bits").map(|b| b as u32),
        crossover_rate: f("crossover_rate"),
        mutation_rate: f("mutation_rate"),
        elitism: u("elitism"),
        restarts: u("restarts").map(|r| r as u32),
        max_time: f("max_time"),
    }
}

/// The `JobSpec` bytes a version 3 coordinator stored for `spec`, with `optimizer` in place of
/// today's optimizer message.
fn stored_by_v3(spec: &JobSpec, optimizer: &V3OptimizerSpec) -> Vec<u8> {
    let data = MeasurementTable { time: vec![0.0, 1.0], columns: vec![("y".into(), vec![1.0, 2.0])] };
    let mut message = job_to_proto(spec, &[data], "m");
    message.optimizer = None;
    let mut bytes = message.encode_to_vec();
    prost::encoding::message::encode(8, optimizer, &mut bytes);
    bytes
}

#[test]
fn a_job_stored_before_protocol_version_4_keeps_its_optimizer() {
    for table in [
        "",
        "x_tol = 1e-3\nf_tol = 0\nmax_iters = 40\nmax_fevals = 900\nmax_time = 60.5\nseed = 7",
        "parallel = false\ninitial_step = 0.2",
        "algorithm = \"nelder-mead\"\ninitial_step = 0.02\nx_tol = 1e-4",
        "algorithm = \"differential-evolution\"\npopulation = 20\nweight = 0.7\ncrossover = 0.9\nseed = 3",
        "algorithm = \"genetic\"\npopulation = 30\nbits = 16\ncrossover_rate = 0.8\nmutation_rate = 0.02\nelitism = 2",
        "algorithm = \"cma-es\"\ninitial_step = 0.3\npopulation = 8\nrestarts = 2\nseed = 11",
        "algorithm = \"least-squares\"\ninitial_step = 0.1\nmax_fevals = 300",
    ] {
        let spec = job(table);
        let v3 = v3_message(&table.parse().unwrap());
        let back = SubmittedJob::try_from(pb::JobSpec::decode(&*stored_by_v3(&spec, &v3)).unwrap()).unwrap();
        assert_eq!(back.spec.optimizer, spec.optimizer, "{table}");
        assert_eq!(back.spec, spec, "{table}");
    }
}

#[test]
fn options_a_version_3_job_carried_for_other_algorithms_are_dropped() {
    // Version 3 read these and never used them: the job runs as it did.
    let spec = job("algorithm = \"differential-evolution\"\npopulation = 20");
    let table =
        "algorithm = \"differential-evolution\"\npopulation = 20\ninitial_step = 0.3\nparallel = false\nbits = 9";
    let v3 = v3_message(&table.parse().unwrap());
    let back = SubmittedJob::try_from(pb::JobSpec::decode(&*stored_by_v3(&spec, &v3)).unwrap()).unwrap();
    assert_eq!(back.spec.optimizer, spec.optimizer);
    let written: OptimizerSpec = toml::from_str(&toml::to_string(&back.spec.optimizer).unwrap()).unwrap();
    assert_eq!(written, spec.optimizer);
}
