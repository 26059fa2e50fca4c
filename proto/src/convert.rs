//! Conversions between protobuf messages and fmucal's job types: `TryFrom` with
//! [`ConvertError::Missing`] for absent required fields (never an `unwrap`), and the reverse
//! direction for clients.

use crate::v1 as pb;
use fmucal_shared::job::choices::{interface_name, parse_interface};
use fmucal_shared::job::experiments::ExperimentSpec;
use fmucal_shared::job::options::FlatOptions;
use fmucal_shared::job::spec::{
    AlgorithmOptions, Bounds, CmaEsOptions, DataRef, DifferentialEvolutionOptions, EffectSpec, GeneticOptions,
    InputMap, LeastSquaresOptions, ModelRef, NelderMeadOptions, OptimizerSpec, OutputMap, ParameterSpec, SetValue,
    SimulationSpec, WorkersSpec,
};
use fmucal_shared::job::{
    CalibrationResult, EvaluatedPoint, Evaluation, HistoryPoint, JobKind, JobSpec, JobStatus, MeasurementTable,
};

/// A message that cannot be converted.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ConvertError {
    #[error("{0} is required")]
    Missing(&'static str),
    /// A field holds a value outside its set (an unknown algorithm, interface, solver or kind).
    #[error("{field}: {message}")]
    Invalid { field: &'static str, message: String },
    /// A field whose name is built from the message (an index into a list).
    #[error("{field}: {message}")]
    InvalidAt { field: String, message: String },
}

/// Reads an optional text choice: empty or absent is `None`, else it must parse.
fn choice<T>(field: &'static str, text: Option<String>) -> Result<Option<T>, ConvertError>
where
    T: std::str::FromStr<Err = String>,
{
    text.filter(|t| !t.is_empty())
        .map(|t| t.parse().map_err(|message| ConvertError::Invalid { field, message }))
        .transpose()
}

impl From<JobStatus> for pb::JobStatus {
    fn from(s: JobStatus) -> Self {
        match s {
            JobStatus::Running => pb::JobStatus::Running,
            JobStatus::Succeeded => pb::JobStatus::Succeeded,
            JobStatus::Failed => pb::JobStatus::Failed,
            JobStatus::Cancelled => pb::JobStatus::Cancelled,
        }
    }
}

/// A job as submitted over gRPC: the spec and the data that travels with it, one table per
/// experiment of [`JobSpec::experiment_views`] (the job's shared table repeated for those that
/// have none of their own).
#[derive(Debug, Clone)]
pub struct SubmittedJob {
    pub spec: JobSpec,
    pub data: Vec<MeasurementTable>,
}

fn table(d: pb::MeasurementData) -> MeasurementTable {
    MeasurementTable { time: d.time, columns: d.columns.into_iter().map(|c| (c.name, c.values)).collect() }
}

fn data_to_proto(d: &MeasurementTable) -> pb::MeasurementData {
    pb::MeasurementData {
        time: d.time.clone(),
        columns: d.columns.iter().map(|(n, v)| pb::Column { name: n.clone(), values: v.clone() }).collect(),
    }
}

fn output_from(o: pb::OutputMap) -> OutputMap {
    OutputMap { variable: o.variable, column: o.column, weight: o.weight.unwrap_or(1.0) }
}

fn output_to(o: &OutputMap) -> pb::OutputMap {
    pb::OutputMap { variable: o.variable.clone(), column: o.column.clone(), weight: Some(o.weight) }
}

fn input_from(i: pb::InputMap) -> InputMap {
    InputMap { column: i.column, variable: i.variable }
}

fn input_to(i: &InputMap) -> pb::InputMap {
    pb::InputMap { column: i.column.clone(), variable: i.variable.clone() }
}

/// An experiment and its own data table, if it has one.
fn experiment_from(k: usize, e: pb::Experiment) -> Result<(ExperimentSpec, Option<MeasurementTable>), ConvertError> {
    let role = (!e.role.is_empty())
        .then(|| e.role.parse())
        .transpose()
        .map_err(|message| ConvertError::InvalidAt { field: format!("spec.experiments[{k}].role"), message })?
        .unwrap_or_default();
    let data = e.data.map(table);
    let spec = ExperimentSpec {
        name: e.name,
        role,
        data: data.as_ref().map(|_| DataRef::default()),
        outputs: e.outputs.map(|l| l.items.into_iter().map(output_from).collect()),
        inputs: e.inputs.map(|l| l.items.into_iter().map(input_from).collect()),
        set: e.set.into_iter().map(|(k, v)| (k, SetValue::from_text(v))).collect(),
        start_time: e.start_time,
        stop_time: e.stop_time,
        validation_stop_time: e.validation_stop_time,
        starts: e.starts.into_iter().collect(),
    };
    Ok((spec, data))
}

impl TryFrom<pb::JobSpec> for SubmittedJob {
    type Error = ConvertError;

    fn try_from(p: pb::JobSpec) -> Result<Self, ConvertError> {
        let mut experiments = vec![];
        let mut own_data = vec![];
        for (k, e) in p.experiments.into_iter().enumerate() {
            let (spec, data) = experiment_from(k, e)?;
            experiments.push(spec);
            own_data.push(data);
        }
        let shared = p.data.map(table);
        if shared.is_none() && (own_data.is_empty() || own_data.iter().any(Option::is_none)) {
            return Err(ConvertError::Missing("spec.data"));
        }
        if p.model_id.is_empty() {
            return Err(ConvertError::Missing("spec.model_id"));
        }
        let mut parameters = vec![];
        for (k, q) in p.parameters.into_iter().enumerate() {
            let scale = (!q.scale.is_empty())
                .then(|| q.scale.parse())
                .transpose()
                .map_err(|message| ConvertError::InvalidAt { field: format!("spec.parameters[{k}].scale"), message })?
                .unwrap_or_default();
            parameters.push(ParameterSpec {
                per_experiment: q.per_experiment,
                scale,
                ..ParameterSpec::new(q.name, q.start, q.lower, q.upper)
            });
        }
        let sim = p.simulation.unwrap_or_default();
        let o = p.optimizer.unwrap_or_default();
        let interface = (!p.interface.is_empty())
            .then(|| parse_interface(&p.interface))
            .transpose()
            .map_err(|message| ConvertError::Invalid { field: "spec.interface", message })?;
        let kind = match pb::JobKind::try_from(p.kind) {
            Ok(pb::JobKind::Calibration) if !p.points.is_empty() => {
                return Err(ConvertError::Invalid {
                    field: "spec.points",
                    message: format!(
                        "{} points given for a calibration job: only an evaluate-points job takes points",
                        p.points.len()
                    ),
                });
            }
            Ok(pb::JobKind::Calibration) => JobKind::Calibration,
            Ok(pb::JobKind::EvaluatePoints) => JobKind::EvaluatePoints(p.points.into_iter().map(|p| p.x).collect()),
            Err(_) => {
                return Err(ConvertError::Invalid { field: "spec.kind", message: format!("unknown kind {}", p.kind) });
            }
        };
        let spec = JobSpec {
            model: ModelRef { path: None, id: Some(p.model_id), interface },
            data: DataRef::default(),
            outputs: p.outputs.into_iter().map(output_from).collect(),
            inputs: p.inputs.into_iter().map(input_from).collect(),
            parameters,
            simulation: SimulationSpec {
                start_time: sim.start_time,
                stop_time: sim.stop_time,
                tolerance: sim.tolerance,
                // The guard runs in the client that reads the job file, before and after it
                // submits: a coordinator's job never runs it.
                tolerance_guard: None,
                solver: choice("spec.simulation.solver", sim.solver)?,
                set: sim.set.into_iter().map(|(k, v)| (k, SetValue::from_text(v))).collect(),
                set_from: None,
                validation_stop_time: sim.validation_stop_time,
                fixed_from_earlier_stage: vec![],
            },
            optimizer: optimizer_from(o)?,
            effects: p.effects.into_iter().map(EffectSpec::from).collect(),
            workers: WorkersSpec::default(),
            diagnose: None,
            experiments,
            kind,
        };
        let data = if own_data.is_empty() {
            shared.into_iter().collect()
        } else {
            own_data.into_iter().map(|own| own.or_else(|| shared.clone()).unwrap_or_default()).collect()
        };
        Ok(SubmittedJob { spec, data })
    }
}

/// The optimizer settings of a message: its `algorithm` with its options, or, when that is
/// unset, the `legacy_*` fields of protocol version 3 (a job stored by an older coordinator).
///
/// # Errors
/// [`ConvertError::Invalid`] naming `spec.optimizer.algorithm` for an unknown legacy name.
pub fn optimizer_from(o: pb::OptimizerSpec) -> Result<OptimizerSpec, ConvertError> {
    use pb::optimizer_spec::Algorithm as A;
    let options = match o.algorithm.clone() {
        Some(A::DefaultAlgorithm(m)) => AlgorithmOptions::Unnamed(nelder_mead_from(m)),
        Some(A::NelderMead(m)) => AlgorithmOptions::NelderMead(nelder_mead_from(m)),
        Some(A::DifferentialEvolution(m)) => AlgorithmOptions::DifferentialEvolution(DifferentialEvolutionOptions {
            population: m.population.map(|v| v as usize),
            weight: m.weight,
            crossover: m.crossover,
        }),
        Some(A::Genetic(m)) => AlgorithmOptions::Genetic(GeneticOptions {
            population: m.population.map(|v| v as usize),
            bits: m.bits,
            crossover_rate: m.crossover_rate,
            mutation_rate: m.mutation_rate,
            elitism: m.elitism.map(|v| v as usize),
        }),
        Some(A::CmaEs(m)) => AlgorithmOptions::CmaEs(CmaEsOptions {
            initial_step: m.initial_step,
            population: m.population.map(|v| v as usize),
            restarts: m.restarts,
        }),
        Some(A::LeastSquares(m)) => {
            AlgorithmOptions::LeastSquares(LeastSquaresOptions { initial_step: m.initial_step })
        }
        None => legacy_options(&o)?,
    };
    Ok(with_shared_settings(&o, options))
}

/// `options` with the settings every algorithm shares, as `o` carries them in either form.
fn with_shared_settings(o: &pb::OptimizerSpec, options: AlgorithmOptions) -> OptimizerSpec {
    fmucal_shared::with_shared_optimizer_settings!(OptimizerSpec { options } from o)
}

fn nelder_mead_from(m: pb::NelderMeadOptions) -> NelderMeadOptions {
    NelderMeadOptions { parallel: m.parallel.unwrap_or(true), initial_step: m.initial_step }
}

/// Protocol version 3's flat options: every algorithm's side by side, those of the other
/// algorithms dropped (they never applied).
#[allow(deprecated)]
fn legacy_options(o: &pb::OptimizerSpec) -> Result<AlgorithmOptions, ConvertError> {
    let algorithm = choice("spec.optimizer.algorithm", Some(o.legacy_algorithm.clone()))?;
    let flat = FlatOptions {
        parallel: o.legacy_parallel.unwrap_or(true),
        initial_step: o.legacy_initial_step,
        population: o.legacy_population.map(|v| v as usize),
        restarts: o.legacy_restarts,
        weight: o.legacy_weight,
        crossover: o.legacy_crossover,
        bits: o.legacy_bits,
        crossover_rate: o.legacy_crossover_rate,
        mutation_rate: o.legacy_mutation_rate,
        elitism: o.legacy_elitism.map(|v| v as usize),
    };
    Ok(AlgorithmOptions::from_flat_lenient(algorithm, flat))
}

/// The protobuf form of optimizer settings: the shared settings and the `algorithm` (the
/// legacy fields stay unset).
pub fn optimizer_to_proto(o: &OptimizerSpec) -> pb::OptimizerSpec {
    use pb::optimizer_spec::Algorithm as A;
    let nelder_mead =
        |m: &NelderMeadOptions| pb::NelderMeadOptions { parallel: Some(m.parallel), initial_step: m.initial_step };
    let algorithm = match &o.options {
        AlgorithmOptions::Unnamed(m) => A::DefaultAlgorithm(nelder_mead(m)),
        AlgorithmOptions::NelderMead(m) => A::NelderMead(nelder_mead(m)),
        AlgorithmOptions::DifferentialEvolution(m) => A::DifferentialEvolution(pb::DifferentialEvolutionOptions {
            population: m.population.map(|v| v as u64),
            weight: m.weight,
            crossover: m.crossover,
        }),
        AlgorithmOptions::Genetic(m) => A::Genetic(pb::GeneticOptions {
            population: m.population.map(|v| v as u64),
            bits: m.bits,
            crossover_rate: m.crossover_rate,
            mutation_rate: m.mutation_rate,
            elitism: m.elitism.map(|v| v as u64),
        }),
        AlgorithmOptions::CmaEs(m) => A::CmaEs(pb::CmaEsOptions {
            initial_step: m.initial_step,
            population: m.population.map(|v| v as u64),
            restarts: m.restarts,
        }),
        AlgorithmOptions::LeastSquares(m) => A::LeastSquares(pb::LeastSquaresOptions { initial_step: m.initial_step }),
    };
    fmucal_shared::with_shared_optimizer_settings!(pb::OptimizerSpec {
        algorithm: Some(algorithm),
        ..Default::default()
    } from o)
}

impl From<pb::EffectSpec> for EffectSpec {
    fn from(e: pb::EffectSpec) -> Self {
        EffectSpec {
            kind: e.kind,
            state: e.state,
            reaction: e.reaction,
            port: e.port,
            signal: e.signal,
            output: e.output,
            input: e.input,
            parameters: e
                .parameters
                .into_iter()
                .map(|(n, b)| (n, Bounds { start: b.start, lower: b.lower, upper: b.upper }))
                .collect(),
        }
    }
}

/// The protobuf form of an effect.
pub fn effect_to_proto(e: &EffectSpec) -> pb::EffectSpec {
    pb::EffectSpec {
        kind: e.kind.clone(),
        state: e.state.clone(),
        reaction: e.reaction.clone(),
        port: e.port.clone(),
        signal: e.signal.clone(),
        output: e.output.clone(),
        input: e.input.clone(),
        parameters: e
            .parameters
            .iter()
            .map(|(n, b)| (n.clone(), pb::Bounds { start: b.start, lower: b.lower, upper: b.upper }))
            .collect(),
    }
}

/// The protobuf form of a job, for clients (the model must already be uploaded as `model_id`):
/// `data[k]` is the table of experiment `k` of [`JobSpec::experiment_views`]. The job's shared
/// table travels once, as the data of the first experiment that has none of its own.
pub fn job_to_proto(spec: &JobSpec, data: &[MeasurementTable], model_id: &str) -> pb::JobSpec {
    let shared = if spec.experiments.is_empty() {
        data.first()
    } else {
        spec.experiments.iter().zip(data).find(|(e, _)| e.data.is_none()).map(|(_, d)| d)
    };
    let experiments = spec
        .experiments
        .iter()
        .zip(data)
        .map(|(e, d)| pb::Experiment {
            name: e.name.clone(),
            role: e.role.to_string(),
            data: e.data.as_ref().map(|_| data_to_proto(d)),
            outputs: e.outputs.as_ref().map(|l| pb::OutputList { items: l.iter().map(output_to).collect() }),
            inputs: e.inputs.as_ref().map(|l| pb::InputList { items: l.iter().map(input_to).collect() }),
            set: e.set.iter().map(|(k, v)| (k.clone(), v.to_string())).collect(),
            start_time: e.start_time,
            stop_time: e.stop_time,
            validation_stop_time: e.validation_stop_time,
            starts: e.starts.iter().map(|(k, v)| (k.clone(), *v)).collect(),
        })
        .collect();
    pb::JobSpec {
        model_id: model_id.to_owned(),
        interface: spec.model.interface.map(interface_name).unwrap_or_default().to_owned(),
        data: shared.map(data_to_proto),
        outputs: spec.outputs.iter().map(output_to).collect(),
        inputs: spec.inputs.iter().map(input_to).collect(),
        parameters: spec
            .parameters
            .iter()
            .map(|p| pb::ParameterSpec {
                name: p.name.clone(),
                start: p.start,
                lower: p.lower,
                upper: p.upper,
                per_experiment: p.per_experiment,
                scale: p.scale.to_string(),
            })
            .collect(),
        simulation: Some(pb::SimulationSpec {
            start_time: spec.simulation.start_time,
            stop_time: spec.simulation.stop_time,
            tolerance: spec.simulation.tolerance,
            solver: spec.simulation.solver.map(|s| s.to_string()),
            set: spec.simulation.set.iter().map(|(k, v)| (k.clone(), v.to_string())).collect(),
            validation_stop_time: spec.simulation.validation_stop_time,
        }),
        optimizer: Some(optimizer_to_proto(&spec.optimizer)),
        kind: match spec.kind {
            JobKind::Calibration => pb::JobKind::Calibration,
            JobKind::EvaluatePoints(_) => pb::JobKind::EvaluatePoints,
        } as i32,
        effects: spec.effects.iter().map(effect_to_proto).collect(),
        points: match &spec.kind {
            JobKind::Calibration => vec![],
            JobKind::EvaluatePoints(points) => points.iter().map(|x| pb::Point { x: x.clone() }).collect(),
        },
        experiments,
    }
}

/// What a worker reports for an assignment.
pub fn point_result(a: &pb::Assignment, e: Evaluation) -> pb::PointResult {
    pb::PointResult {
        job_id: a.job_id.clone(),
        point_id: a.point_id,
        status: if e.value.is_some() { pb::PointStatus::Ok } else { pb::PointStatus::SimulationFailed } as i32,
        value: e.value.unwrap_or(f64::NAN),
        message: e.error.unwrap_or_default(),
        wall_s: e.wall.as_secs_f64(),
        residuals: e.residuals.unwrap_or_default(),
    }
}

/// The evaluation a worker reported (a bad wall time reads as zero).
pub fn evaluation_from_proto(r: &pb::PointResult) -> Evaluation {
    let ok = r.status == pb::PointStatus::Ok as i32;
    Evaluation {
        value: ok.then_some(r.value),
        residuals: ok.then(|| r.residuals.clone()),
        error: (!ok).then(|| r.message.clone()),
        wall: std::time::Duration::try_from_secs_f64(r.wall_s).unwrap_or_default(),
    }
}

/// The protobuf form of a result.
pub fn result_to_proto(r: &CalibrationResult, names: &[String]) -> pb::JobResult {
    pb::JobResult {
        names: names.to_vec(),
        x_opt: names.iter().map(|n| r.x_opt.get(n).copied().unwrap_or(f64::NAN)).collect(),
        f_opt: r.f_opt,
        iterations: r.iterations,
        evaluations: r.evaluations,
        elapsed_s: r.elapsed_s,
        termination: r.termination.clone(),
        failed_evaluations: r.failed_evaluations,
        rounds: r.rounds,
        warnings: r.warnings.clone(),
        evaluated: r
            .evaluated
            .iter()
            .map(|e| pb::EvaluatedPoint {
                x: e.x.clone(),
                ok: e.value.is_some(),
                value: e.value.unwrap_or(f64::NAN),
                residuals: e.residuals.clone(),
                message: e.message.clone(),
            })
            .collect(),
    }
}

/// The result a coordinator returned, with the `history` its client saw stream by.
pub fn result_from_proto(r: pb::JobResult, history: Vec<HistoryPoint>) -> CalibrationResult {
    CalibrationResult {
        x_opt: r.names.into_iter().zip(r.x_opt).collect(),
        f_opt: r.f_opt,
        iterations: r.iterations,
        evaluations: r.evaluations,
        rounds: r.rounds,
        failed_evaluations: r.failed_evaluations,
        termination: r.termination,
        elapsed_s: r.elapsed_s,
        history,
        evaluated: r
            .evaluated
            .into_iter()
            .map(|e| EvaluatedPoint {
                x: e.x,
                value: e.ok.then_some(e.value),
                residuals: e.residuals,
                message: e.message,
            })
            .collect(),
        errors: None,
        identifiability: None,
        experiments: vec![],
        fmi_version: None,
        warnings: r.warnings,
        tolerance_guard: None,
        parameters: vec![],
        units: Default::default(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn missing_data_is_named_not_unwrapped() {
        let p = pb::JobSpec { model_id: "abc".into(), ..Default::default() };
        assert_eq!(SubmittedJob::try_from(p).unwrap_err(), ConvertError::Missing("spec.data"));
        let p = pb::JobSpec { data: Some(Default::default()), ..Default::default() };
        assert_eq!(SubmittedJob::try_from(p).unwrap_err(), ConvertError::Missing("spec.model_id"));
    }

    #[test]
    fn experiments_need_data_and_known_roles_and_scales() {
        let experiment = pb::Experiment { name: "a".into(), ..Default::default() };
        let p = pb::JobSpec { model_id: "m".into(), experiments: vec![experiment.clone()], ..Default::default() };
        assert_eq!(SubmittedJob::try_from(p).unwrap_err(), ConvertError::Missing("spec.data"));
        let own = pb::Experiment { data: Some(Default::default()), role: "check".into(), ..experiment };
        let p = pb::JobSpec { model_id: "m".into(), experiments: vec![own.clone()], ..Default::default() };
        let e = SubmittedJob::try_from(p).unwrap_err().to_string();
        assert_eq!(e, "spec.experiments[0].role: \"check\" is not fit or validation");
        let parameter = pb::ParameterSpec { name: "k".into(), scale: "ln".into(), ..Default::default() };
        let own = pb::Experiment { role: String::new(), ..own };
        let p = pb::JobSpec {
            model_id: "m".into(),
            experiments: vec![own],
            parameters: vec![parameter],
            ..Default::default()
        };
        let e = SubmittedJob::try_from(p).unwrap_err().to_string();
        assert_eq!(e, "spec.parameters[0].scale: \"ln\" is not linear or log");
    }

    /// A valid one-experiment job over the protocol, edited by `edit`, converted and validated.
    fn submitted(edit: impl FnOnce(&mut pb::JobSpec)) -> Result<SubmittedJob, String> {
        let spec = JobSpec::from_toml(
            "[model]\nid = \"m\"\n[data]\n[[outputs]]\nvariable = \"y\"\ncolumn = \"y\"\n[[parameters]]\nname = \"k\"\nstart = 1.0\nlower = 0.0\nupper = 2.0\n[simulation]\nstop_time = 1.0\n",
            std::path::Path::new("."),
        )
        .unwrap();
        let data = MeasurementTable { time: vec![0.0, 1.0, 2.0], columns: vec![("y".into(), vec![1.0, 2.0, 3.0])] };
        let mut p = job_to_proto(&spec, std::slice::from_ref(&data), "m");
        edit(&mut p);
        let job = SubmittedJob::try_from(p).map_err(|e| e.to_string())?;
        job.spec.validate().map_err(|e| e.to_string())?;
        for table in &job.data {
            table.validate_measurements(&["y"]).map_err(|e| e.to_string())?;
        }
        Ok(job)
    }

    #[test]
    fn careless_requests_are_refused_as_job_files_are() {
        submitted(|_| {}).unwrap();
        let e = submitted(|p| p.points = vec![pb::Point { x: vec![1.0] }]).unwrap_err();
        assert_eq!(e, "spec.points: 1 points given for a calibration job: only an evaluate-points job takes points");
        for (v, says) in [
            (f64::NAN, "simulation.validation_stop_time: NaN is not a finite time"),
            (0.5, "simulation.validation_stop_time: 0.5 is not a finite time after the calibration stop time 1"),
        ] {
            let e = submitted(|p| p.simulation.as_mut().unwrap().validation_stop_time = Some(v)).unwrap_err();
            assert!(e.starts_with(says), "{e}");
        }
        submitted(|p| p.simulation.as_mut().unwrap().validation_stop_time = Some(2.0)).unwrap();
        let e = submitted(|p| {
            let data = p.data.as_mut().unwrap();
            data.columns.push(pb::Column { name: "y".into(), values: vec![0.0; 3] });
        })
        .unwrap_err();
        assert_eq!(e, "data.columns: column \"y\" appears twice");
        let e =
            submitted(|p| p.inputs = vec![pb::InputMap { column: "y".into(), variable: "u".into() }; 2]).unwrap_err();
        assert!(e.starts_with("inputs[1].variable: \"u\" is already mapped by inputs[0]"), "{e}");
    }

    #[test]
    fn round_trip_keeps_the_job() {
        let spec = JobSpec::from_toml(
            "[model]\nid = \"m\"\n[data]\n[[outputs]]\nvariable = \"y\"\ncolumn = \"y\"\nweight = 2.0\n[[parameters]]\nname = \"k\"\nstart = 1.0\nlower = 0.0\nupper = 2.0\n[optimizer]\nx_tol = 1e-3\n",
            std::path::Path::new("."),
        )
        .unwrap();
        let data = MeasurementTable { time: vec![0.0, 1.0], columns: vec![("y".into(), vec![1.0, f64::NAN])] };
        let back = SubmittedJob::try_from(job_to_proto(&spec, std::slice::from_ref(&data), "m")).unwrap();
        assert_eq!(back.spec, spec);
        assert_eq!(back.data.len(), 1);
        assert_eq!(back.data[0].time, data.time);
    }
}
