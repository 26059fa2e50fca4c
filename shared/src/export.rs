//! The corrected model as an FMU (`fmucal export`): the original FMU, the calibrated values as
//! its new defaults and the job's effects as part of the model, packed as an FMI 2.0 FMU that
//! any FMI tool runs.
//!
//! The archive holds:
//! - `modelDescription.xml`: the original's variables (written as FMI 2.0 whatever version the
//!   original is, by [`crate::fmu::ModelDescription::to_fmi2_xml`]) with the calibrated values
//!   as start values, plus one tunable parameter `effects[K].NAME` per effect parameter (the
//!   job's `effects[K]` table, parameter `NAME`) and one output `effects[K].output` per sensor
//!   effect (the original output with the effect applied);
//! - `binaries/linux64/<model>_corrected.so`: the FMU runtime, the crate `fmucal-fmu` (the same
//!   effect library and integrator as `fmucal simulate`), which loads the original from
//!   `resources/fmucal/original/` and applies [`RuntimeConfig`] from
//!   `resources/fmucal/corrected.json`.
//!
//! A Model Exchange original exports Model Exchange (terms added inside `fmi2GetDerivatives`,
//! kinks as extra event indicators) and Co-Simulation (the original's Model Exchange integrated
//! by [`crate::sim::Stepper`]); a Co-Simulation-only original exports Co-Simulation with port
//! effects applied at communication points. What cannot be exported cleanly (a state effect on
//! a Co-Simulation-only original, the sensor lag and the delays, which need a memory of their
//! own) is refused in one line naming the effect.

use std::io::Write as _;
use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::effects::{self, Found, Scale};
use crate::fmu::schema::{
    Causality, Initial, InterfaceInfo, ScalarVariable, Unit, Unknown, Value, VarType, Variability,
};
use crate::fmu::{Fmu, ModelDescription};
use crate::job::PreparedJob;
use crate::quote::quote_user_text;
use crate::sim::plan::{Setting, setting};

/// Where the runtime finds its settings inside the exported FMU.
pub const CONFIG_PATH: &str = "resources/fmucal/corrected.json";
/// Where the original FMU lies, unpacked, inside the exported FMU.
pub const ORIGINAL_DIR: &str = "resources/fmucal/original";
/// The version of [`RuntimeConfig`] this build writes and reads.
pub const CONFIG_FORMAT: u32 = 1;

/// What the FMU runtime reads from [`CONFIG_PATH`].
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct RuntimeConfig {
    pub format: u32,
    /// Values set on the original right after it is instantiated (and after a reset): the
    /// calibrated parameters and the job's `[simulation] set` values, as text.
    pub settings: Vec<(String, String)>,
    pub effects: Vec<RuntimeEffect>,
    /// The integrator of the Co-Simulation interface over a Model Exchange original.
    pub solver: String,
    /// Its relative tolerance when `fmi2SetupExperiment` gives none; `None`: the original's
    /// default experiment's, else 1e-6.
    pub tolerance: Option<f64>,
}

/// One effect of the job, resolved against the original.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct RuntimeEffect {
    /// The job's index K (`effects[K]`).
    pub index: usize,
    pub kind: String,
    pub target: Target,
    /// One per parameter of the kind, in its order.
    pub parameters: Vec<RuntimeParameter>,
    /// A sensor effect's corrected output `effects[K].output`.
    pub output_value_reference: Option<u32>,
}

/// What an effect acts on (names of the original's variables).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(rename_all = "snake_case")]
pub enum Target {
    Port {
        port: String,
        signal: String,
    },
    State {
        state: String,
        signal: String,
        /// A second velocity state whose derivative gets the same term at the `reaction`
        /// parameter's strength (the effect's last parameter).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        reaction: Option<String>,
    },
    Sensor {
        output: String,
    },
    Actuator {
        input: String,
    },
}

/// An effect parameter as a variable of the exported FMU.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct RuntimeParameter {
    /// `effects[K].NAME`.
    pub name: String,
    pub value_reference: u32,
    pub start: f64,
}

/// Why an export is refused: one line naming the effect, variable or file.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct ExportError(pub String);

fn refuse(msg: impl Into<String>) -> ExportError {
    ExportError(msg.into())
}

/// What to export.
pub struct Request<'a> {
    pub fmu: &'a Fmu,
    pub job: &'a PreparedJob,
    /// The experiment whose settings become the defaults.
    pub experiment: usize,
    /// Every calibrated value, in the job's point order.
    pub x: &'a [f64],
    /// The bytes of the FMU runtime library (`libfmucal_fmu.so`).
    pub runtime: &'a [u8],
}

/// The model identifier of the exported FMU: the original's, with `_corrected`.
pub fn model_identifier(md: &ModelDescription) -> String {
    let base =
        md.model_exchange.as_ref().or(md.co_simulation.as_ref()).map_or("model", |i| i.model_identifier.as_str());
    format!("{base}_corrected")
}

/// The unit of what effect `target` adds to, and of the signal it reads.
fn target_units(md: &ModelDescription, target: &Target) -> (Option<String>, Option<String>) {
    let unit = |name: &str| {
        md.variable(name).and_then(|v| md.unit_of(v).or_else(|| md.unit_of(md.base_of(v)))).map(str::to_owned)
    };
    match target {
        Target::Port { port, signal } => (unit(port), unit(signal)),
        Target::State { state, signal, .. } => (crate::structure::derivative_unit(md, state), unit(signal)),
        Target::Sensor { output } => (unit(output), None),
        Target::Actuator { input } => (unit(input), None),
    }
}

fn describe(kind: &str, target: &Target) -> String {
    match target {
        Target::Port { port, signal } => format!("{kind} of {signal} on {port}"),
        Target::State { state, reaction: Some(r), .. } => format!("{kind} on der({state}) and der({r})"),
        Target::State { state, .. } => format!("{kind} on der({state})"),
        Target::Sensor { output } => format!("{kind} on output {output}"),
        Target::Actuator { input } => format!("{kind} on input {input}"),
    }
}

fn typed_start(s: &Setting) -> Option<(u32, VarType, Value)> {
    Some(match s {
        Setting::Real(vr, v) => (*vr, VarType::Real, Value::Real(*v)),
        Setting::Integer(vr, v) => (*vr, VarType::Integer, Value::Integer(i64::from(*v))),
        Setting::Boolean(vr, v) => (*vr, VarType::Boolean, Value::Boolean(*v)),
        Setting::String(vr, v) => (*vr, VarType::String, Value::String(v.clone())),
        Setting::Binary(..) => return None,
    })
}

/// The exported FMU's description and runtime settings.
///
/// # Errors
/// [`ExportError`] naming what cannot be exported.
pub fn describe_corrected(req: &Request) -> Result<(ModelDescription, RuntimeConfig), ExportError> {
    let original = &req.fmu.description;
    let experiment = req
        .job
        .experiments
        .get(req.experiment)
        .ok_or_else(|| refuse(format!("the job has no experiment {}", req.experiment)))?;
    let has_me = original.model_exchange.is_some();
    let spec = experiment.sim_spec(req.x);

    // FMI 1.0's negated aliases have no FMI 2.0 form: internal ones are left out.
    let drop: Vec<usize> = original
        .variables
        .iter()
        .enumerate()
        .filter(|(_, v)| {
            v.negated && !matches!(v.causality, Causality::Input | Causality::Output | Causality::Parameter)
        })
        .map(|(i, _)| i)
        .collect();
    let mut md = original.without_variables(&drop);

    // The calibrated values and the job's settings become the start values.
    for (name, text) in &spec.parameters {
        let s = setting(original, name, text).map_err(|e| refuse(format!("{}: {e}", quote_user_text(name))))?;
        let Some((vr, ty, value)) = typed_start(&s) else {
            return Err(refuse(format!("{}: FMI 2.0 has no Binary start value", quote_user_text(name))));
        };
        let ty =
            |v: &ScalarVariable| v.var_type == ty || (ty == VarType::Integer && v.var_type == VarType::Enumeration);
        for v in md.variables.iter_mut().filter(|v| v.value_reference == vr && ty(v) && !v.negated) {
            if v.start.is_some() || v.name == *name {
                v.start = Some(value.clone());
            }
        }
    }

    let mut next_vr = md.variables.iter().map(|v| v.value_reference).max().map_or(0, |m| m + 1);
    let mut effects_out = vec![];
    let mut kinks = 0;
    for (k, e) in experiment.effects.iter().enumerate() {
        let field = |f: &str| format!("effects[{k}].{f}");
        let found = effects::find(&e.spec.kind).map_err(|err| refuse(format!("{}: {err}", field("kind"))))?;
        let values = req.x.get(e.offset..e.offset + e.count).unwrap_or_default();
        let target = match (&e.spec.port, &e.spec.signal, &e.spec.state, &e.spec.output, &e.spec.input) {
            (Some(port), Some(signal), ..) => Target::Port { port: port.clone(), signal: signal.clone() },
            (_, _, Some(state), ..) => {
                if !has_me {
                    return Err(refuse(format!(
                        "{}: a state effect needs Model Exchange, and the original offers Co-Simulation only",
                        field("state")
                    )));
                }
                let signal = e.state_signal.clone().unwrap_or_else(|| state.clone());
                Target::State { state: state.clone(), signal, reaction: e.reaction.clone() }
            }
            (_, _, _, Some(output), _) => Target::Sensor { output: output.clone() },
            (_, _, _, _, Some(input)) => Target::Actuator { input: input.clone() },
            _ => return Err(refuse(format!("{}: the effect names no port, state, output or input", field("kind")))),
        };
        if let Found::Series(kind) = &found
            && !matches!(
                kind.name(),
                "sensor_offset" | "sensor_gain" | "actuator_offset" | "actuator_gain" | "actuator_saturation"
            )
        {
            return Err(refuse(format!(
                "{}: {} cannot be exported: it needs a memory of the signal's past inside the FMU; export the job without it",
                field("kind"),
                kind.name()
            )));
        }
        if let Found::Port(kind) = &found {
            // A reaction is a second term with the same kinks.
            kinks += kind.kinks(values).len() * if e.reaction.is_some() { 2 } else { 1 };
        }
        let (load_unit, signal_unit) = target_units(original, &target);
        let what = describe(&e.spec.kind, &target);
        let mut parameters = vec![];
        for (name, value) in e.spec.parameter_names().iter().zip(values) {
            let unit = match effects::parameter_scale(name) {
                // The reaction is the kind's first parameter on another derivative: that one's
                // unit where the first parameter is a load (a force), none where it is a
                // coefficient.
                _ if *name == effects::REACTION => {
                    let first = e.spec.parameter_names().first().map(|f| effects::parameter_scale(f));
                    e.reaction
                        .as_deref()
                        .filter(|_| first == Some(Scale::Load))
                        .and_then(|r| crate::structure::derivative_unit(original, r))
                }
                Scale::Load => load_unit.clone(),
                Scale::Signal => signal_unit.clone(),
                Scale::Other => None,
            };
            let full = format!("effects[{k}].{name}");
            if md.variable(&full).is_some() {
                return Err(refuse(format!("{full}: the original already has a variable of that name")));
            }
            md.variables.push(new_real(
                &full,
                next_vr,
                format!("{what}: {name} (fmucal effect parameter)"),
                (Causality::Parameter, Variability::Tunable, Some(Initial::Exact)),
                Some(*value),
                unit,
            ));
            parameters.push(RuntimeParameter { name: full, value_reference: next_vr, start: *value });
            next_vr += 1;
        }
        let mut output_value_reference = None;
        if let Target::Sensor { output } = &target {
            let name = format!("effects[{k}].output");
            md.variables.push(new_real(
                &name,
                next_vr,
                format!("{output} with {} (fmucal sensor effect)", e.spec.kind),
                (Causality::Output, Variability::Continuous, None),
                None,
                load_unit.clone(),
            ));
            let index = md.variables.len();
            md.model_structure.outputs.push(Unknown { index, dependencies: None });
            md.model_structure.initial_unknowns.push(Unknown { index, dependencies: None });
            output_value_reference = Some(next_vr);
            next_vr += 1;
        }
        effects_out.push(RuntimeEffect {
            index: k,
            kind: e.spec.kind.clone(),
            target,
            parameters,
            output_value_reference,
        });
    }
    // What an effect changes depends on its new parameters (and a state term on its signal):
    // the unknowns it reaches lose their dependency lists, which then mean "on everything".
    let index_of = |name: &str| md.variables.iter().position(|v| v.name == name).map(|i| i + 1);
    let mut via: Vec<usize> = vec![];
    let mut reached: Vec<usize> = vec![];
    for e in &effects_out {
        match &e.target {
            Target::Port { port, .. } => via.extend(index_of(port)),
            Target::Actuator { input } => via.extend(index_of(input)),
            Target::State { state, reaction, .. } => {
                for state in std::iter::once(state).chain(reaction) {
                    if let Some((_, der)) = original.states().into_iter().find(|(s, _)| s.name == *state) {
                        let vr = der.value_reference;
                        reached.extend(
                            md.variables
                                .iter()
                                .enumerate()
                                .filter(|(_, v)| v.value_reference == vr && v.var_type == VarType::Real)
                                .map(|(i, _)| i + 1),
                        );
                    }
                }
            }
            Target::Sensor { .. } => {}
        }
    }
    let ms = &mut md.model_structure;
    for u in ms.outputs.iter_mut().chain(ms.derivatives.iter_mut()).chain(ms.initial_unknowns.iter_mut()) {
        if reached.contains(&u.index) || u.dependencies.as_ref().is_some_and(|d| d.iter().any(|i| via.contains(i))) {
            u.dependencies = None;
        }
    }
    // Every unit a variable names is defined.
    let used: Vec<String> = md.variables.iter().filter_map(|v| v.unit.clone()).collect();
    for u in used {
        if !md.unit_definitions.iter().any(|d| d.name == u) {
            md.unit_definitions.push(Unit { name: u, base_unit: None, display_units: vec![] });
        }
    }

    let id = model_identifier(original);
    let once = |i: &Option<InterfaceInfo>| i.as_ref().is_some_and(|i| i.can_be_instantiated_only_once_per_process);
    md.fmi_version = "2.0".into();
    md.number_of_event_indicators += kinks;
    md.model_exchange = original.model_exchange.as_ref().map(|me| InterfaceInfo {
        model_identifier: id.clone(),
        can_be_instantiated_only_once_per_process: me.can_be_instantiated_only_once_per_process,
        completed_integrator_step_not_needed: me.completed_integrator_step_not_needed,
        ..InterfaceInfo::default()
    });
    md.co_simulation = Some(InterfaceInfo {
        model_identifier: id,
        can_be_instantiated_only_once_per_process: once(&original.model_exchange) || once(&original.co_simulation),
        can_handle_variable_communication_step_size: has_me
            || original.co_simulation.as_ref().is_some_and(|c| c.can_handle_variable_communication_step_size),
        ..InterfaceInfo::default()
    });
    md.generation_tool = Some(format!(
        "fmucal export {} (from {})",
        env!("CARGO_PKG_VERSION"),
        original.generation_tool.as_deref().unwrap_or("an unnamed tool")
    ));
    md.generation_date_and_time = None;
    let config = RuntimeConfig {
        format: CONFIG_FORMAT,
        settings: spec.parameters.clone(),
        effects: effects_out,
        solver: req.job.spec.simulation.solver.map(|s| s.to_string()).unwrap_or_else(|| "bdf".into()),
        tolerance: spec.tolerance,
    };
    let json = serde_json::to_string(&config).map_err(|e| refuse(e.to_string()))?;
    md.guid = format!("{{fmucal-{:016x}-{:016x}}}", fnv(original.guid.as_bytes()), fnv(json.as_bytes()));
    Ok((md, config))
}

/// A Real variable the export adds: `(causality, variability, initial)` as `kind`.
fn new_real(
    name: &str,
    value_reference: u32,
    description: String,
    kind: (Causality, Variability, Option<Initial>),
    start: Option<f64>,
    unit: Option<String>,
) -> ScalarVariable {
    ScalarVariable {
        name: name.to_owned(),
        value_reference,
        description: Some(description),
        causality: kind.0,
        variability: kind.1,
        initial: kind.2,
        var_type: VarType::Real,
        declared_type: None,
        start: start.map(Value::Real),
        min: None,
        max: None,
        nominal: None,
        unit,
        derivative: None,
        reinit: false,
        display_unit: None,
        alias_of: None,
        negated: false,
        fmi3: None,
    }
}

/// FNV-1a, for a GUID that changes with the original and the settings (stable across builds).
fn fnv(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, b| (h ^ u64::from(*b)).wrapping_mul(0x0100_0000_01b3))
}

/// The exported FMU's archive bytes.
///
/// # Errors
/// [`ExportError`] naming what cannot be exported, or the file that cannot be read.
pub fn corrected_fmu(req: &Request) -> Result<Vec<u8>, ExportError> {
    let (md, config) = describe_corrected(req)?;
    let xml = md.to_fmi2_xml().map_err(|e| refuse(e.to_string()))?;
    let json = serde_json::to_string_pretty(&config).map_err(|e| refuse(e.to_string()))?;
    let id = model_identifier(&req.fmu.description);
    let mut zip = zip::ZipWriter::new(std::io::Cursor::new(Vec::new()));
    let file = zip::write::SimpleFileOptions::default().compression_method(zip::CompressionMethod::Deflated);
    let zerr = |e: zip::result::ZipError| refuse(format!("cannot write the archive: {e}"));
    let ioerr = |e: std::io::Error| refuse(format!("cannot write the archive: {e}"));
    zip.start_file("modelDescription.xml", file).map_err(zerr)?;
    zip.write_all(xml.as_bytes()).map_err(ioerr)?;
    zip.start_file(format!("binaries/linux64/{id}.so"), file.unix_permissions(0o755)).map_err(zerr)?;
    zip.write_all(req.runtime).map_err(ioerr)?;
    zip.start_file(CONFIG_PATH, file).map_err(zerr)?;
    zip.write_all(json.as_bytes()).map_err(ioerr)?;
    add_tree(&mut zip, &req.fmu.dir, &req.fmu.dir, file)?;
    Ok(zip.finish().map_err(zerr)?.into_inner())
}

/// Adds every regular file under `dir` to the archive, under [`ORIGINAL_DIR`].
fn add_tree(
    zip: &mut zip::ZipWriter<std::io::Cursor<Vec<u8>>>,
    root: &Path,
    dir: &Path,
    options: zip::write::SimpleFileOptions,
) -> Result<(), ExportError> {
    let read = |p: &Path, e: std::io::Error| refuse(format!("cannot read {}: {e}", p.display()));
    let mut entries: Vec<_> =
        std::fs::read_dir(dir).map_err(|e| read(dir, e))?.collect::<Result<_, _>>().map_err(|e| read(dir, e))?;
    entries.sort_by_key(std::fs::DirEntry::file_name);
    for entry in entries {
        let path = entry.path();
        let kind = entry.file_type().map_err(|e| read(&path, e))?;
        if kind.is_dir() {
            add_tree(zip, root, &path, options)?;
        } else if kind.is_file() {
            let rel = path.strip_prefix(root).unwrap_or(&path);
            let name = format!("{ORIGINAL_DIR}/{}", rel.to_string_lossy().replace('\\', "/"));
            let bytes = std::fs::read(&path).map_err(|e| read(&path, e))?;
            zip.start_file(name, options.unix_permissions(0o755))
                .map_err(|e| refuse(format!("cannot write the archive: {e}")))?;
            zip.write_all(&bytes).map_err(|e| refuse(format!("cannot write the archive: {e}")))?;
        }
    }
    Ok(())
}
