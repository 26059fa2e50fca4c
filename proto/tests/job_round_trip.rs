//! Property: any valid job survives TOML → protocol → job unchanged. A job crosses
//! the protocol on every run, local ones too, so a default slipped in at the join (an output
//! weight of 0 became 1) changes results. Fields the protocol does not carry by design (file
//! paths, `set_from`, the local worker count) are left at their
//! defaults by the generator; the model is named by its upload id.

use std::collections::BTreeMap;
use std::path::Path;

use fmucal_proto::convert::{SubmittedJob, job_to_proto};
use fmucal_shared::effects;
use fmucal_shared::fmu::Interface;
use fmucal_shared::job::choices::{ExperimentRole, Scale};
use fmucal_shared::job::experiments::ExperimentSpec;
use fmucal_shared::job::options::FlatOptions;
use fmucal_shared::job::spec::{
    AlgorithmOptions, Bounds, DataRef, EffectSpec, InputMap, ModelRef, OptimizerSpec, OutputMap, ParameterSpec,
    SetValue, SimulationSpec, WorkersSpec,
};
use fmucal_shared::job::{Algorithm, JobKind, JobSpec, MeasurementTable};
use fmucal_shared::sim::Solver;
use proptest::prelude::*;

fn name() -> impl Strategy<Value = String> {
    "[a-z][a-zA-Z0-9_]{0,6}(\\.[a-z][a-z0-9]{0,4})?"
}

/// Inputs with distinct variables (an FMU input takes one column: a job that maps one twice
/// is invalid, and is not what this property is about).
fn inputs(count: std::ops::Range<usize>) -> impl Strategy<Value = Vec<InputMap>> {
    prop::collection::btree_map(name(), name(), count)
        .prop_map(|m| m.into_iter().map(|(variable, column)| InputMap { column, variable }).collect())
}

fn finite() -> impl Strategy<Value = f64> {
    prop_oneof![Just(0.0), Just(1.0), -1e6..1e6f64, 1e-12..1e-3f64]
}

fn output() -> impl Strategy<Value = OutputMap> {
    (name(), name(), prop_oneof![Just(0.0), Just(1.0), 0.0..1e3f64]).prop_map(|(variable, column, weight)| OutputMap {
        variable,
        column,
        weight,
    })
}

fn parameters() -> impl Strategy<Value = Vec<ParameterSpec>> {
    prop::collection::btree_map(name(), (finite(), 0.0..1.0f64, 1e-9..1e3f64), 1..5)
        .prop_map(|m| {
            m.into_iter()
                .map(|(name, (lower, at, width))| ParameterSpec::new(name, lower + at * width, lower, lower + width))
                .filter(|p| p.start >= p.lower && p.start <= p.upper)
                .collect::<Vec<_>>()
        })
        .prop_filter("at least one parameter", |v| !v.is_empty())
}

/// Marks some parameters per-experiment (when there are experiments) and some log-scaled (when
/// their bounds are positive); per-experiment ones get a start in some experiments.
fn with_experiments(
    mut parameters: Vec<ParameterSpec>,
    mut experiments: Vec<ExperimentSpec>,
    flags: Vec<(bool, bool, f64)>,
) -> (Vec<ParameterSpec>, Vec<ExperimentSpec>) {
    for (p, (per_experiment, log, at)) in parameters.iter_mut().zip(flags) {
        if log && p.lower > 0.0 {
            p.scale = Scale::Log;
        }
        if per_experiment && !experiments.is_empty() {
            p.per_experiment = true;
            let k = (at * 7.0) as usize % experiments.len();
            let e = &mut experiments[k];
            e.starts.insert(p.name.clone(), p.lower + at * (p.upper - p.lower));
        }
    }
    (parameters, experiments)
}

/// Zero to three experiments, the first fitted, each with or without its own data, outputs,
/// inputs, fixed values and times.
fn experiments() -> impl Strategy<Value = Vec<ExperimentSpec>> {
    let one = (
        any::<bool>(),
        any::<bool>(),
        prop::option::of(prop::collection::vec(output(), 1..3)),
        prop::option::of(inputs(0..2)),
        prop::collection::btree_map(name(), set_value(), 0..2),
        (prop::option::of(0.0..10.0f64), prop::option::of(10.0..100.0f64), prop::option::of(100.0..200.0f64)),
    );
    prop::collection::vec(one, 0..4).prop_map(|list| {
        list.into_iter()
            .enumerate()
            .map(|(k, (validation, own_data, outputs, inputs, set, (start_time, stop_time, validation_stop_time)))| {
                ExperimentSpec {
                    name: format!("e{k}"),
                    role: if validation && k > 0 { ExperimentRole::Validation } else { ExperimentRole::Fit },
                    data: own_data.then(DataRef::default),
                    outputs,
                    inputs,
                    set,
                    start_time,
                    stop_time,
                    validation_stop_time,
                    starts: BTreeMap::new(),
                }
            })
            .collect()
    })
}

fn set_value() -> impl Strategy<Value = SetValue> {
    prop_oneof![
        finite().prop_map(SetValue::Number),
        any::<bool>().prop_map(SetValue::Bool),
        // Text that reads as a number or a boolean is that number or boolean (canonical form).
        "[a-z][a-z_]{0,8}".prop_filter_map("text", |t| match SetValue::from_text(t) {
            SetValue::Text(t) => Some(SetValue::Text(t)),
            _ => None,
        }),
    ]
}

fn simulation() -> impl Strategy<Value = SimulationSpec> {
    (
        prop::option::of(0.0..10.0f64),
        prop::option::of(10.0..100.0f64),
        prop::option::of(1e-10..1e-2f64),
        prop::option::of(prop_oneof![
            Just(Solver::Bdf),
            Just(Solver::Esdirk34),
            Just(Solver::TrBdf2),
            Just(Solver::Tsit45)
        ]),
        prop::collection::btree_map(name(), set_value(), 0..4),
        prop::option::of(100.0..200.0f64),
    )
        .prop_map(|(start_time, stop_time, tolerance, solver, set, validation_stop_time)| SimulationSpec {
            start_time,
            stop_time,
            tolerance,
            solver,
            set: set.into_iter().collect::<BTreeMap<_, _>>(),
            validation_stop_time,
            ..Default::default()
        })
}

/// A port effect of a few kinds, every parameter with finite, ordered bounds around its start.
fn effect() -> impl Strategy<Value = EffectSpec> {
    let kind = prop_oneof![Just("viscous_damping"), Just("linear_spring"), Just("stribeck_friction")];
    // An effect on a port reads another signal (a job is refused otherwise).
    let places = (name(), name()).prop_filter("the signal is not the port", |(port, signal)| port != signal);
    (kind, places, finite(), 0.0..1e3f64).prop_map(|(kind, (port, signal), start, width)| {
        let names = match effects::find(kind) {
            Ok(found) => found.kind().parameters(),
            Err(e) => panic!("{e}"),
        };
        EffectSpec {
            kind: kind.into(),
            state: None,
            reaction: None,
            port: Some(port),
            signal: Some(signal),
            output: None,
            input: None,
            parameters: names
                .iter()
                .map(|n| (n.to_string(), Bounds { start, lower: start - width, upper: start + width }))
                .collect(),
        }
    })
}

/// A friction on a state's derivative, with or without a reaction on another state.
fn state_effect() -> impl Strategy<Value = EffectSpec> {
    let places = (name(), prop::option::of(name()))
        .prop_filter("the reaction is another state", |(state, reaction)| reaction.as_ref() != Some(state));
    (places, finite(), 0.0..1e3f64).prop_map(|((state, reaction), start, width)| {
        let bounds = Bounds { start, lower: start - width, upper: start + width };
        let mut parameters: BTreeMap<String, Bounds> = [("force".to_owned(), bounds)].into();
        if reaction.is_some() {
            parameters.insert("reaction".to_owned(), bounds);
        }
        EffectSpec {
            kind: "coulomb_friction".into(),
            state: Some(state),
            reaction,
            parameters,
            ..EffectSpec::default()
        }
    })
}

fn optimizer() -> impl Strategy<Value = OptimizerSpec> {
    // None: the job names no algorithm, and none crosses the wire.
    let algorithm = prop::option::of(prop_oneof![
        Just(Algorithm::NelderMead),
        Just(Algorithm::DifferentialEvolution),
        Just(Algorithm::Genetic),
        Just(Algorithm::CmaEs),
        Just(Algorithm::LeastSquares)
    ]);
    let opt_f = || prop::option::of(1e-9..1.0f64);
    (
        (algorithm, any::<bool>(), opt_f(), opt_f(), prop::option::of(1..10_000u64), prop::option::of(1..10_000u64)),
        // TOML integers are signed 64-bit.
        (0..=i64::MAX as u64, opt_f(), prop::option::of(4..200usize), opt_f(), opt_f(), prop::option::of(4..32u32)),
        (opt_f(), opt_f(), prop::option::of(0..4usize), prop::option::of(0..8u32)),
    )
        .prop_map(
            |(
                (algorithm, parallel, x_tol, f_tol, max_iters, max_fevals),
                (seed, initial_step, population, weight, crossover, bits),
                (crossover_rate, mutation_rate, elitism, restarts),
            )| OptimizerSpec {
                x_tol,
                f_tol,
                max_iters,
                max_fevals,
                seed,
                max_time: Some(12.5),
                // Only the options the algorithm takes, as a job file holds them.
                options: AlgorithmOptions::from_flat_lenient(
                    algorithm,
                    FlatOptions {
                        parallel,
                        initial_step,
                        population,
                        restarts,
                        weight,
                        crossover,
                        bits,
                        crossover_rate,
                        mutation_rate,
                        elitism,
                    },
                ),
            },
        )
}

fn job() -> impl Strategy<Value = JobSpec> {
    (
        "[0-9a-f]{8}",
        prop::option::of(prop_oneof![Just(Interface::ModelExchange), Just(Interface::CoSimulation)]),
        prop::collection::vec(output(), 1..4),
        inputs(0..3),
        parameters(),
        simulation(),
        prop::collection::vec(prop_oneof![effect(), state_effect()], 0..3),
        experiments(),
        prop::collection::vec((any::<bool>(), any::<bool>(), 0.0..1.0f64), 5),
    )
        .prop_flat_map(|(id, interface, outputs, inputs, parameters, simulation, effects, experiments, flags)| {
            let (parameters, experiments) = with_experiments(parameters, experiments, flags);
            optimizer().prop_map(move |optimizer| JobSpec {
                model: ModelRef { path: None, id: Some(id.clone()), interface },
                data: DataRef { path: None, time_column: "time".into() },
                outputs: outputs.clone(),
                inputs: inputs.clone(),
                parameters: parameters.clone(),
                effects: effects.clone(),
                simulation: simulation.clone(),
                optimizer,
                workers: WorkersSpec::default(),
                diagnose: None,
                experiments: experiments.clone(),
                kind: JobKind::Calibration,
            })
        })
}

/// A job that evaluates given points: its kind is not part of the TOML file (the CLI asks it
/// of the coordinator), so it round-trips through the protocol only.
fn points_job() -> impl Strategy<Value = JobSpec> {
    job().prop_flat_map(|spec| {
        let n = spec.parameter_vectors().0.len();
        prop::collection::vec(prop::collection::vec(finite(), n), 1..4)
            .prop_map(move |points| spec.evaluating_points(points))
    })
}

fn data() -> MeasurementTable {
    MeasurementTable { time: vec![0.0, 1.0], columns: vec![("y".into(), vec![1.0, f64::NAN])] }
}

/// One table per experiment of `spec`, each telling which experiment it is.
fn tables(spec: &JobSpec) -> Vec<MeasurementTable> {
    (0..spec.experiment_views().len()).map(|k| MeasurementTable { time: vec![0.0, 1.0 + k as f64], ..data() }).collect()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    #[test]
    fn any_valid_job_survives_toml_protocol_and_back(spec in job()) {
        let text = toml::to_string(&spec).expect("a job serializes to TOML");
        let parsed = JobSpec::from_toml(&text, Path::new(".")).expect("its TOML parses");
        prop_assert!(parsed.validate().is_ok(), "{:?}", parsed.validate());
        prop_assert_eq!(&parsed, &spec);
        let id = spec.model.id.clone().unwrap();
        let tables = tables(&parsed);
        let back = SubmittedJob::try_from(job_to_proto(&parsed, &tables, &id)).expect("converts back");
        prop_assert_eq!(&back.spec, &parsed);
        // Every experiment gets its own table back, or the job's shared one (the first
        // experiment's that has no data of its own).
        let views = parsed.experiment_views();
        let shared = parsed.experiments.iter().position(|e| e.data.is_none()).unwrap_or(0);
        prop_assert_eq!(back.data.len(), views.len());
        for (k, table) in back.data.iter().enumerate() {
            let own = parsed.experiments.get(k).is_none_or(|e| e.data.is_some());
            prop_assert_eq!(&table.time, &tables[if own { k } else { shared }].time);
        }
    }

    #[test]
    fn any_points_job_survives_the_protocol(spec in points_job()) {
        let id = spec.model.id.clone().unwrap();
        let back = SubmittedJob::try_from(job_to_proto(&spec, &tables(&spec), &id)).expect("converts back");
        prop_assert_eq!(back.spec, spec);
    }
}

/// A one-output, one-parameter job whose output has `weight`.
fn small_job(weight: f64) -> JobSpec {
    let toml = format!(
        "[model]\nid = \"m\"\n[data]\n[[outputs]]\nvariable = \"y\"\ncolumn = \"y\"\nweight = {weight:?}\n\
         [[parameters]]\nname = \"k\"\nstart = 1.0\nlower = 0.0\nupper = 2.0\n"
    );
    JobSpec::from_toml(&toml, Path::new(".")).unwrap()
}

#[test]
fn unknown_choices_in_a_message_name_their_field() {
    let spec = small_job(1.0);
    let good = job_to_proto(&spec, &[data()], "m");
    let mut m = good.clone();
    // A message of protocol version 3, which named the algorithm as text.
    let o = m.optimizer.as_mut().unwrap();
    o.algorithm = None;
    #[allow(deprecated)]
    {
        o.legacy_algorithm = "points".into();
    }
    let e = SubmittedJob::try_from(m).unwrap_err().to_string();
    assert!(e.starts_with("spec.optimizer.algorithm: \"points\" is not nelder-mead"), "{e}");
    let mut m = good.clone();
    m.interface = "xx".into();
    assert_eq!(SubmittedJob::try_from(m).unwrap_err().to_string(), "spec.interface: \"xx\" is not me or cs");
    let mut m = good.clone();
    m.simulation.as_mut().unwrap().solver = Some("rk4".into());
    assert!(SubmittedJob::try_from(m).unwrap_err().to_string().starts_with("spec.simulation.solver: unknown solver"));
    let mut m = good;
    m.kind = 7;
    assert_eq!(SubmittedJob::try_from(m).unwrap_err().to_string(), "spec.kind: unknown kind 7");
}

#[test]
fn an_output_weight_of_zero_stays_zero() {
    let spec = small_job(0.0);
    let data = MeasurementTable { time: vec![0.0], columns: vec![("y".into(), vec![1.0])] };
    let back = SubmittedJob::try_from(job_to_proto(&spec, std::slice::from_ref(&data), "m")).unwrap();
    assert_eq!(back.spec.outputs[0].weight, 0.0);
    // A message without a weight (an older or minimal client) means 1.
    let mut message = job_to_proto(&spec, std::slice::from_ref(&data), "m");
    message.outputs[0].weight = None;
    assert_eq!(SubmittedJob::try_from(message).unwrap().spec.outputs[0].weight, 1.0);
}

#[test]
fn effects_survive_toml_and_the_protocol() {
    let mut text = toml::to_string(&small_job(1.0)).unwrap();
    text.push_str(
        "[[effects]]\nkind = \"coulomb_friction\"\nport = \"p\"\nsignal = \"s\"\n\
         parameters = { force = { start = 0.01, lower = 0.0, upper = 0.05 } }\n\
         [[effects]]\nkind = \"sensor_offset\"\noutput = \"y\"\n\
         parameters = { offset = { start = 0.0, lower = -1.0, upper = 1.0 } }\n",
    );
    let spec = JobSpec::from_toml(&text, Path::new(".")).unwrap();
    spec.validate().unwrap();
    assert_eq!(spec.effects.len(), 2);
    assert_eq!(spec.parameter_vectors().0, ["k", "effects[0].force", "effects[1].offset"]);
    let back = SubmittedJob::try_from(job_to_proto(&spec, &[data()], "m")).unwrap();
    assert_eq!(back.spec, spec);
}
