//! The job specification, read from TOML by the CLI and converted from protobuf by the
//! coordinator. Relative paths in a TOML file are resolved against the file's folder.
//!
//! ```toml
//! [model]
//! path = "furuta.fmu"        # or "example:furuta", or: id = "<sha256 of an uploaded FMU>"
//! interface = "me"           # me | cs (default: me if offered)
//!
//! [data]
//! path = "FurutaData.mat"    # CSV with a time column, or MATLAB v5 .mat
//! time_column = "time"       # default "time"
//!
//! [[outputs]]
//! variable = "armJoint.phi"  # FMU variable
//! column = "phi"             # data column
//! weight = 1.0               # default 1
//!
//! [[inputs]]                 # data column -> FMU input
//! column = "u"
//! variable = "u"
//!
//! [[parameters]]
//! name = "armFriction"
//! start = 0.012
//! lower = 0.0
//! upper = 0.022
//! scale = "linear"           # or "log" (positive bounds): the optimizer works on log(x)
//! per_experiment = false     # true: one value per fitted experiment (see super::experiments)
//!
//! [simulation]               # all optional; default: the data's time span, FMU defaults
//! start_time = 0.0
//! stop_time = 40.0
//! tolerance = 1e-6
//! tolerance_guard = true     # calibrate: tighten the tolerance until its error is < 0.1 × noise
//! solver = "bdf"
//! set = { g = 9.81 }         # fixed values of other variables
//! set_from = "stage1/result.json"  # fix the x_opt of an earlier calibration (two-stage fits)
//! validation_stop_time = 1800.0    # report errors on (stop_time, 1800] too (CLI)
//!
//! [optimizer]
//! algorithm = "nelder-mead"  # nelder-mead | differential-evolution | genetic | cma-es | least-squares
//! parallel = true
//! x_tol = 1e-3
//! f_tol = 1e-2
//! max_iters = 1000
//! max_fevals = 5000
//! seed = 0
//!
//! [workers]
//! count = 2                  # local runs, 1 to 256; default: number of cores
//!
//! [diagnose]                 # what `fmucal diagnose` may try: see the fmucal-diagnose crate
//!
//! [[experiments]]            # several data sets, one parameter set: see super::experiments
//! ```

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::JobError;
use super::choices::{JobKind, Scale, optional_interface, optional_text, text};
use super::experiments::ExperimentSpec;
pub use super::options::{
    AlgorithmOptions, CmaEsOptions, DifferentialEvolutionOptions, GeneticOptions, LeastSquaresOptions,
    NelderMeadOptions, OptimizerSpec,
};
use crate::effects::{self, Domain};
use crate::fmu::Interface;
use crate::quote::quote_user_text;
use crate::sim::Solver;

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JobSpec {
    pub model: ModelRef,
    /// The measurements; with `[[experiments]]`, the default of those that name none.
    #[serde(default)]
    pub data: DataRef,
    pub outputs: Vec<OutputMap>,
    #[serde(default)]
    pub inputs: Vec<InputMap>,
    #[serde(default)]
    pub parameters: Vec<ParameterSpec>,
    /// Effects the model lacks, added by fmucal; their parameters are calibrated too.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub effects: Vec<EffectSpec>,
    #[serde(default)]
    pub simulation: SimulationSpec,
    #[serde(default)]
    pub optimizer: OptimizerSpec,
    #[serde(default)]
    pub workers: WorkersSpec,
    /// The `[diagnose]` section as written: what `fmucal diagnose` may try. The diagnosis
    /// owns its keys and reads them (`fmucal_diagnose::spec`); `calibrate` accepts the
    /// section and ignores it, and it is not sent to a coordinator.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub diagnose: Option<toml::Table>,
    /// Several experiments fitted with one parameter set ([`super::experiments`]); none: the
    /// job is one experiment.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub experiments: Vec<ExperimentSpec>,
    /// Calibrate (every job file) or evaluate given points (internal, over the protocol).
    #[serde(skip)]
    pub kind: JobKind,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModelRef {
    /// Path of the `.fmu` (CLI), or
    pub path: Option<PathBuf>,
    /// SHA-256 of an FMU uploaded to the coordinator.
    pub id: Option<String>,
    /// `me` or `cs`. Default: Model Exchange if offered.
    #[serde(default, with = "optional_interface")]
    pub interface: Option<Interface>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DataRef {
    /// CSV or MATLAB v5 `.mat` file (CLI); over gRPC the data travels with the job.
    pub path: Option<PathBuf>,
    /// Name of the time column or variable. Default: `time`.
    #[serde(default = "default_time_column")]
    pub time_column: String,
}

fn default_time_column() -> String {
    "time".into()
}

impl Default for DataRef {
    fn default() -> Self {
        DataRef { path: None, time_column: default_time_column() }
    }
}

fn one() -> f64 {
    1.0
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OutputMap {
    pub variable: String,
    pub column: String,
    #[serde(default = "one")]
    pub weight: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InputMap {
    pub column: String,
    pub variable: String,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ParameterSpec {
    pub name: String,
    pub start: f64,
    pub lower: f64,
    pub upper: f64,
    /// One value per fitted experiment (an initial state, say), named `NAME@EXPERIMENT`.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub per_experiment: bool,
    /// `linear` (default) or `log`: the optimizer works on log(x); the bounds must be positive.
    #[serde(default, with = "text", skip_serializing_if = "is_linear")]
    pub scale: Scale,
}

fn is_linear(scale: &Scale) -> bool {
    *scale == Scale::Linear
}

impl ParameterSpec {
    /// A shared, linearly scaled parameter.
    pub fn new(name: impl Into<String>, start: f64, lower: f64, upper: f64) -> Self {
        ParameterSpec { name: name.into(), start, lower, upper, per_experiment: false, scale: Scale::Linear }
    }
}

/// An effect of the library ([`crate::effects`]) added to the model:
///
/// ```toml
/// [[effects]]
/// kind = "coulomb_friction"          # a port effect: a term added to an FMU input
/// port = "pendulumJoint.tauExt"      # the input (summed with any data column mapped to it)
/// signal = "pendulumJoint.w"         # what the term depends on
/// parameters = { force = { start = 0.0, lower = 0.0, upper = 0.05 } }
///
/// [[effects]]
/// kind = "sensor_offset"             # a sensor effect, on a mapped output
/// output = "armJoint.phi"
/// parameters = { offset = { start = 0.0, lower = -0.1, upper = 0.1 } }
/// ```
///
/// Actuator effects name a mapped `input`. A state effect (Model Exchange) names a continuous
/// `state` instead of a port: its term is added to der(state), in the derivative's units (an
/// acceleration on a velocity), and reads the state itself (friction, damping, drag, thermal
/// and generic kinds) or the position whose derivative it is (springs); `signal` may name
/// another state. A mechanical state effect may name a `reaction`, another velocity state whose
/// derivative gets the same term at the strength of parameter `reaction` (a joint torque that
/// the mass matrix passes to a coupled joint; see [`crate::effects`]). Each parameter is
/// calibrated as `effects[K].NAME`, after the `[[parameters]]`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EffectSpec {
    pub kind: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub state: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reaction: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub port: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub signal: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub output: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub input: Option<String>,
    pub parameters: std::collections::BTreeMap<String, Bounds>,
}

/// Start value and bounds of a calibrated value.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Bounds {
    pub start: f64,
    pub lower: f64,
    pub upper: f64,
}

impl EffectSpec {
    /// The kind's parameters in its order, with their bounds.
    ///
    /// # Errors
    /// [`JobError::Invalid`] for an unknown kind or a misspelled or missing parameter.
    pub fn ordered_parameters(&self, k: usize) -> Result<Vec<(&'static str, Bounds)>, JobError> {
        let found =
            effects::find(&self.kind).map_err(|e| JobError::invalid(format!("effects[{k}].kind"), e.to_string()))?;
        let kind = found.kind();
        let field = format!("effects[{k}].parameters");
        let given: Vec<(String, f64)> = self
            .parameters
            .keys()
            .filter(|n| self.reaction.is_none() || n.as_str() != effects::REACTION)
            .map(|n| (n.clone(), 0.0))
            .collect();
        if self.reaction.is_none() && self.parameters.contains_key(effects::REACTION) {
            return Err(JobError::invalid(
                field,
                format!(
                    "{} has a parameter \"reaction\" only with a reaction state (effects[{k}].reaction)",
                    self.kind
                ),
            ));
        }
        effects::parameter_values(kind, &given).map_err(|e| JobError::invalid(field.clone(), e.to_string()))?;
        if self.reaction.is_some() && !self.parameters.contains_key(effects::REACTION) {
            return Err(JobError::invalid(
                field,
                format!("{} with a reaction state needs parameter \"reaction\"", self.kind),
            ));
        }
        Ok(self.parameter_names().into_iter().map(|n| (n, self.parameters[n])).collect())
    }

    /// The effect's parameter names in order: its kind's, then `reaction` when it has a
    /// reaction state. Empty for an unknown kind.
    pub fn parameter_names(&self) -> Vec<&'static str> {
        let mut names = effects::find(&self.kind).map(|f| f.kind().parameters().to_vec()).unwrap_or_default();
        if self.reaction.is_some() {
            names.push(effects::REACTION);
        }
        names
    }

    /// What the effect acts on.
    pub fn domain(&self) -> Option<Domain> {
        effects::find(&self.kind).ok().map(|f| f.kind().domain())
    }
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SimulationSpec {
    /// Default: the first measurement time.
    pub start_time: Option<f64>,
    /// Default: the last measurement time.
    pub stop_time: Option<f64>,
    /// Default: the FMU's DefaultExperiment tolerance, else 1e-6.
    pub tolerance: Option<f64>,
    /// `fmucal calibrate` checks that the integration error is small against the noise, at
    /// the start point and at the optimum, and tightens the tolerance (and refits) where it is
    /// not ([`super::tolerance`]). Default: true.
    pub tolerance_guard: Option<bool>,
    /// bdf (default), esdirk34, tr-bdf2 or tsit45.
    #[serde(default, with = "optional_text")]
    pub solver: Option<Solver>,
    /// Fixed values for other model variables, e.g. `{ crashMode = "abort", g = 9.81 }`.
    #[serde(default)]
    pub set: std::collections::BTreeMap<String, SetValue>,
    /// A `result.json` of an earlier calibration whose `x_opt` values are fixed here (the
    /// paper's two-stage fit). Read when the TOML file is loaded; `set` entries win.
    pub set_from: Option<PathBuf>,
    /// After calibrating up to `stop_time`, also simulate up to here and report the errors on
    /// the validation window (stop_time, validation_stop_time]: reports and diagnoses judge on it,
    /// calibrations never fit it.
    pub validation_stop_time: Option<f64>,
    /// Names `set_from` fixed (not part of the file format): the start model of the error
    /// report leaves them at the model's own values.
    #[serde(skip)]
    pub fixed_from_earlier_stage: Vec<String>,
}

impl SimulationSpec {
    /// The window times given: numbers, and a validation window that ends after the
    /// calibration window when both ends are given ([`Self::check_validation_stop`] checks it
    /// again once the data give the default stop time).
    ///
    /// # Errors
    /// [`JobError::Invalid`] naming `simulation.start_time`, `simulation.stop_time` or
    /// `simulation.validation_stop_time`.
    pub fn check_times(&self) -> Result<(), JobError> {
        for (field, value) in [
            ("simulation.start_time", self.start_time),
            ("simulation.stop_time", self.stop_time),
            ("simulation.validation_stop_time", self.validation_stop_time),
        ] {
            if let Some(v) = value
                && !v.is_finite()
            {
                return Err(JobError::invalid(field, format!("{v} is not a finite time")));
            }
        }
        match self.stop_time {
            Some(stop) => self.check_validation_stop(stop),
            None => Ok(()),
        }
    }

    /// The one check of the validation window, for every command and the protocol alike: it
    /// ends at a finite time after `stop`, the end of the calibration window (the job's
    /// `stop_time`, else its data's last time).
    ///
    /// # Errors
    /// [`JobError::Invalid`] naming `simulation.validation_stop_time`.
    pub fn check_validation_stop(&self, stop: f64) -> Result<(), JobError> {
        match self.validation_stop_time {
            Some(v) if !(v.is_finite() && v > stop) => Err(JobError::invalid(
                "simulation.validation_stop_time",
                format!("{v} is not a finite time after the calibration stop time {stop}"),
            )),
            _ => Ok(()),
        }
    }
}

/// A fixed value in `[simulation] set`: a number, a boolean or text (enumeration item names).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum SetValue {
    Number(f64),
    Bool(bool),
    Text(String),
}

impl SetValue {
    /// The canonical value of a text: a number or a boolean when the text is exactly how that
    /// value prints, else text. The protocol carries set values as text and a TOML file may
    /// quote a number; both read back through here, so one setting has one form in the job
    /// model, and what the FMU is given (`Display`) is the same text either way.
    pub fn from_text(text: String) -> SetValue {
        match text.as_str() {
            "true" => SetValue::Bool(true),
            "false" => SetValue::Bool(false),
            _ => match text.parse::<f64>() {
                Ok(v) if v.to_string() == text => SetValue::Number(v),
                _ => SetValue::Text(text),
            },
        }
    }
}

impl std::fmt::Display for SetValue {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            SetValue::Number(v) => write!(f, "{v}"),
            SetValue::Bool(b) => write!(f, "{b}"),
            SetValue::Text(t) => f.write_str(t),
        }
    }
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WorkersSpec {
    /// Worker processes for local runs, 1 to [`super::limits::MAX_WORKERS`]. Default: the
    /// number of cores.
    pub count: Option<usize>,
}

/// Characters of the quoted line a TOML error shows around the column at fault.
const TOML_QUOTE_CHARS: usize = 80;

/// A TOML parse error in the parser's layout, bounded: where, the one line at fault (escaped,
/// cut to [`TOML_QUOTE_CHARS`] characters around the column) with a caret under the column,
/// and what is wrong (itself one line, bounded).
///
/// ```text
/// TOML parse error at line 3, column 9
///   |
/// 3 | bogus = "yyy
///   |         ^
/// invalid basic string
/// ```
pub fn toml_error(e: &toml::de::Error, text: &str) -> String {
    use crate::quote::{MAX_QUOTED_CHARS, escape_user_text};
    let message = escape_user_text(e.message().trim(), MAX_QUOTED_CHARS);
    let Some(span) = e.span() else { return format!("TOML parse error\n{message}") };
    let at = span.start.min(text.len());
    let at = (0..=at).rev().find(|&i| text.is_char_boundary(i)).unwrap_or(0);
    let line_start = text[..at].rfind('\n').map_or(0, |i| i + 1);
    let line_end = text[at..].find('\n').map_or(text.len(), |i| at + i);
    let line_number = text[..line_start].matches('\n').count() + 1;
    let line = text[line_start..line_end].trim_end_matches('\r');
    let column = text[line_start..at].chars().count();
    // A window of the line around the column, escaped piece by piece so the caret stays under it.
    let chars: Vec<char> = line.chars().collect();
    let from = column.saturating_sub(TOML_QUOTE_CHARS / 2).min(chars.len());
    let to = (from + TOML_QUOTE_CHARS).min(chars.len());
    let piece = |a: usize, b: usize| {
        let s: String = chars[a.min(b)..b].iter().collect();
        escape_user_text(&s, TOML_QUOTE_CHARS * 10)
    };
    let lead = if from > 0 { "…" } else { "" };
    let tail = if to < chars.len() { "…" } else { "" };
    let before = format!("{lead}{}", piece(from, column.min(to)));
    let quoted = format!("{before}{}{tail}", piece(column.min(to), to));
    let gutter = " ".repeat(line_number.to_string().len());
    let caret = " ".repeat(before.chars().count());
    format!(
        "TOML parse error at line {line_number}, column {}\n{gutter} |\n{line_number} | {quoted}\n{gutter} | {caret}^\n{message}",
        column + 1
    )
}

impl JobSpec {
    /// This job with the start of every calibrated value named in `values` (`[[parameters]]`
    /// by name, effect parameters as `effects[K].NAME`) set to that value, clamped into its
    /// bounds: a job that starts at an earlier fit.
    #[must_use]
    pub fn with_starts(mut self, values: &std::collections::BTreeMap<String, f64>) -> JobSpec {
        for p in &mut self.parameters {
            if let Some(v) = values.get(&p.name).filter(|v| v.is_finite()) {
                p.start = v.clamp(p.lower, p.upper);
            }
        }
        for (k, e) in self.effects.iter_mut().enumerate() {
            for (name, b) in e.parameters.iter_mut() {
                if let Some(v) = values.get(&format!("effects[{k}].{name}")).filter(|v| v.is_finite()) {
                    b.start = v.clamp(b.lower, b.upper);
                }
            }
        }
        self
    }

    /// Parses TOML text; relative paths are resolved against `base_dir`.
    ///
    /// ```
    /// use std::path::Path;
    /// use fmucal_shared::job::JobSpec;
    ///
    /// let text = r#"
    ///     [model]
    ///     path = "example:decay"
    ///     [data]
    ///     path = "data.csv"
    ///     [[outputs]]
    ///     variable = "x"
    ///     column = "x"
    ///     [[parameters]]
    ///     name = "k"
    ///     start = 1.0
    ///     lower = 0.1
    ///     upper = 10.0
    /// "#;
    /// let job = JobSpec::from_toml(text, Path::new("/bench")).unwrap();
    /// job.validate().unwrap();
    /// assert_eq!(job.data.path.as_deref(), Some(Path::new("/bench/data.csv")));
    /// assert_eq!(job.calibrated()[0].name, "k");
    /// // A misspelled key is refused, naming it.
    /// let e = JobSpec::from_toml(&text.replace("lower", "lowr"), Path::new(".")).unwrap_err();
    /// assert!(e.to_string().contains("unknown field `lowr`"));
    /// ```
    ///
    /// # Errors
    /// [`JobError::Invalid`] with field `toml` and the parser's message in its layout
    /// ([`toml_error`]): several lines, quoting one line of `text` at most.
    pub fn from_toml(text: &str, base_dir: &Path) -> Result<JobSpec, JobError> {
        let mut spec: JobSpec = toml::from_str(text).map_err(|e| {
            super::options::option_error(text, &e).unwrap_or_else(|| JobError::invalid("toml", toml_error(&e, text)))
        })?;
        for value in spec.simulation.set.values_mut() {
            if let SetValue::Text(t) = value {
                *value = SetValue::from_text(std::mem::take(t));
            }
        }
        for value in spec.experiments.iter_mut().flat_map(|e| e.set.values_mut()) {
            if let SetValue::Text(t) = value {
                *value = SetValue::from_text(std::mem::take(t));
            }
        }
        let experiment_data = spec.experiments.iter_mut().filter_map(|e| e.data.as_mut());
        let data_paths = std::iter::once(&mut spec.data).chain(experiment_data).map(|d| &mut d.path);
        for p in std::iter::once(&mut spec.model.path).chain(data_paths).flatten() {
            // `example:NAME` names a built-in example FMU and is left as written.
            if p.is_relative() && !p.to_string_lossy().starts_with("example:") {
                *p = base_dir.join(&*p);
            }
        }
        Ok(spec)
    }

    /// The same job with its model and data paths absolute (against the current directory),
    /// so that the job written elsewhere (`fmucal diagnose`'s `job.toml`) runs from any
    /// working directory. `example:NAME` stays as it is.
    pub fn with_absolute_paths(mut self) -> JobSpec {
        let experiment_data = self.experiments.iter_mut().filter_map(|e| e.data.as_mut());
        let data_paths = std::iter::once(&mut self.data).chain(experiment_data).map(|d| &mut d.path);
        for p in std::iter::once(&mut self.model.path).chain(data_paths).flatten() {
            if p.is_relative()
                && !p.to_string_lossy().starts_with("example:")
                && let Ok(a) = std::path::absolute(&*p)
            {
                *p = a;
            }
        }
        self
    }

    /// Reads a TOML job file.
    ///
    /// # Errors
    /// [`JobError::Invalid`] naming `job file` or `simulation.set_from` for a path that is not
    /// a regular file or is over [`super::limits::MAX_JOB_FILE_BYTES`], [`JobError::Read`] if
    /// the file cannot be read, else as [`JobSpec::from_toml`].
    pub fn from_toml_file(path: &Path) -> Result<JobSpec, JobError> {
        super::limits::check_regular_file("job file", path, super::limits::MAX_JOB_FILE_BYTES)?;
        let text = std::fs::read_to_string(path)
            .map_err(|e| JobError::Read { path: path.display().to_string(), message: e.to_string() })?;
        let base = path.parent().unwrap_or(Path::new("."));
        let mut spec = JobSpec::from_toml(&text, base)?;
        if let Some(from) = spec.simulation.set_from.take() {
            let from = if from.is_relative() { base.join(from) } else { from };
            let read = |m: String| JobError::Read { path: from.display().to_string(), message: m };
            super::limits::check_regular_file("simulation.set_from", &from, super::limits::MAX_JOB_FILE_BYTES)?;
            let text = std::fs::read_to_string(&from).map_err(|e| read(e.to_string()))?;
            let result: super::CalibrationResult = serde_json::from_str(&text).map_err(|e| read(e.to_string()))?;
            for (name, v) in result.x_opt {
                if !spec.simulation.set.contains_key(&name) {
                    spec.simulation.fixed_from_earlier_stage.push(name.clone());
                    spec.simulation.set.insert(name, SetValue::Number(v));
                }
            }
        }
        Ok(spec)
    }

    /// Checks what can be checked without the model or data: names present, bounds ordered,
    /// starts within bounds, weights non-negative.
    ///
    /// # Errors
    /// [`JobError::Invalid`] naming the field.
    pub fn validate(&self) -> Result<(), JobError> {
        if self.model.path.is_none() && self.model.id.is_none() {
            return Err(JobError::invalid("model", "give a path or an id"));
        }
        if self.parameters.is_empty() && self.effects.is_empty() {
            return Err(JobError::invalid("parameters", "at least one parameter (or effect) is needed"));
        }
        super::limits::check_spec(self)?;
        let mut names = std::collections::HashSet::with_capacity(self.parameters.len());
        for (k, p) in self.parameters.iter().enumerate() {
            let f = |name: &str| format!("parameters[{k}].{name}");
            if p.name.trim().is_empty() {
                return Err(JobError::invalid(f("name"), "is empty"));
            }
            if !names.insert(p.name.as_str()) {
                return Err(JobError::invalid(f("name"), format!("{} appears twice", quote_user_text(&p.name))));
            }
            check_bounds(p.lower, p.upper)
                .map_err(|m| JobError::invalid(f("lower"), format!("{}: {m}", quote_user_text(&p.name))))?;
            if !(p.start.is_finite() && p.start >= p.lower && p.start <= p.upper) {
                return Err(JobError::invalid(
                    f("start"),
                    format!("{}: start {} is outside [{}, {}]", quote_user_text(&p.name), p.start, p.lower, p.upper),
                ));
            }
        }
        for (k, e) in self.effects.iter().enumerate() {
            self.validate_effect(k, e)?;
        }
        if let Some(t) = self.optimizer.max_time
            && !(t > 0.0 && t.is_finite())
        {
            return Err(JobError::invalid(
                "optimizer.max_time",
                format!("must be a positive number of seconds, got {t}"),
            ));
        }
        self.validate_simulation()?;
        self.validate_experiments()?;
        if self.experiments.is_empty() {
            self.validate_mapping()?;
        }
        Ok(())
    }

    /// The simulation's own settings: a tolerance an integrator can meet, finite window times
    /// (a validation window after the calibration window), and a local worker count within
    /// [`super::limits::MAX_WORKERS`].
    ///
    /// # Errors
    /// [`JobError::Invalid`] naming the field.
    fn validate_simulation(&self) -> Result<(), JobError> {
        if let Some(t) = self.simulation.tolerance
            && !(MIN_TOLERANCE..1.0).contains(&t)
        {
            return Err(JobError::invalid(
                "simulation.tolerance",
                format!(
                    "{t:e} is not in [{MIN_TOLERANCE:e}, 1): no integrator meets a relative tolerance below double precision"
                ),
            ));
        }
        if self.experiments.is_empty() {
            self.simulation.check_times()?;
        }
        if let Some(n) = self.workers.count
            && !(1..=super::limits::MAX_WORKERS).contains(&n)
        {
            return Err(JobError::invalid(
                "workers.count",
                format!(
                    "{n} is not in 1..={}: give at least one worker, and no more than the cap",
                    super::limits::MAX_WORKERS
                ),
            ));
        }
        Ok(())
    }

    /// One experiment's mapping: outputs present with valid weights and none given twice, each
    /// FMU input fed by one column, and the outputs and inputs the sensor and actuator effects
    /// name among them.
    ///
    /// # Errors
    /// [`JobError::Invalid`] naming the field.
    pub(super) fn validate_mapping(&self) -> Result<(), JobError> {
        if self.outputs.is_empty() {
            return Err(JobError::invalid("outputs", "at least one output is needed"));
        }
        let mut outputs = std::collections::HashMap::with_capacity(self.outputs.len());
        for (k, o) in self.outputs.iter().enumerate() {
            if !(o.weight >= 0.0 && o.weight.is_finite()) {
                return Err(JobError::invalid(
                    format!("outputs[{k}].weight"),
                    format!("{} must be a non-negative number", o.weight),
                ));
            }
            if let Some(j) = outputs.insert((o.variable.as_str(), o.column.as_str()), k) {
                return Err(JobError::invalid(
                    format!("outputs[{k}]"),
                    format!(
                        "{} against column {} is the same as outputs[{j}]: it would count twice",
                        quote_user_text(&o.variable),
                        quote_user_text(&o.column)
                    ),
                ));
            }
        }
        let mut inputs = std::collections::HashMap::with_capacity(self.inputs.len());
        for (k, i) in self.inputs.iter().enumerate() {
            if let Some(j) = inputs.insert(i.variable.as_str(), k) {
                return Err(JobError::invalid(
                    format!("inputs[{k}].variable"),
                    format!(
                        "{} is already mapped by inputs[{j}]: an FMU input takes one column",
                        quote_user_text(&i.variable)
                    ),
                ));
            }
        }
        for (k, e) in self.effects.iter().enumerate() {
            let field = |f: &str| format!("effects[{k}].{f}");
            if let Some(out) = &e.output
                && !self.outputs.iter().any(|o| &o.variable == out)
            {
                return Err(JobError::invalid(
                    field("output"),
                    format!("{} is not one of the job's [[outputs]]", quote_user_text(out)),
                ));
            }
            if let Some(input) = &e.input
                && !self.inputs.iter().any(|i| &i.variable == input)
            {
                return Err(JobError::invalid(
                    field("input"),
                    format!("{} is not one of the job's [[inputs]]", quote_user_text(input)),
                ));
            }
        }
        Ok(())
    }

    /// An effect names a known kind with exactly its parameters, in bounds, and what it acts
    /// on: a port and a signal, a mapped output (sensor) or a mapped input (actuator).
    fn validate_effect(&self, k: usize, e: &EffectSpec) -> Result<(), JobError> {
        // What the reaction needs first: its parameter is checked with the others below.
        if let Some(reaction) = &e.reaction
            && effects::find(&e.kind).is_ok()
        {
            let proportional = matches!(effects::find(&e.kind), Ok(effects::Found::Port(p)) if p.proportional());
            let why = if e.state.is_none() {
                Some("a reaction is a second state's derivative: give the effect a state first".to_owned())
            } else if e.domain() != Some(Domain::Mechanical) {
                Some(format!("{} is not mechanical: a reaction passes a force or torque to a coupled velocity", e.kind))
            } else if !proportional {
                Some(format!("{} has two strengths: a reaction needs a kind with one (coulomb_friction, say)", e.kind))
            } else if e.state.as_ref() == Some(reaction) {
                Some(format!("{} is the effect's own state: a reaction acts on another one", quote_user_text(reaction)))
            } else {
                None
            };
            if let Some(why) = why {
                return Err(JobError::invalid(format!("effects[{k}].reaction"), why));
            }
        }
        for (name, b) in e.ordered_parameters(k)? {
            check_bounds(b.lower, b.upper)
                .map_err(|m| JobError::invalid(format!("effects[{k}].parameters.{name}.lower"), m))?;
            if !(b.start.is_finite() && b.start >= b.lower && b.start <= b.upper) {
                return Err(JobError::invalid(
                    format!("effects[{k}].parameters.{name}.start"),
                    format!("start {} is outside [{}, {}]", b.start, b.lower, b.upper),
                ));
            }
        }
        let field = |f: &str| format!("effects[{k}].{f}");
        let domain = e.domain();
        if e.state.is_some() && e.port.is_some() {
            return Err(JobError::invalid(
                field("state"),
                "give a port or a state, not both: a state effect is added to der(state), a port effect to the port"
                    .to_owned(),
            ));
        }
        let on_state = e.state.is_some() || domain == Some(Domain::Generic);
        let (needed, unused): (&[(&str, &Option<String>)], [(&str, &Option<String>); 5]) = (
            match domain {
                Some(Domain::Mechanical | Domain::Thermal | Domain::Generic) if on_state => &[("state", &e.state)],
                Some(Domain::Mechanical | Domain::Thermal) => &[("port", &e.port), ("signal", &e.signal)],
                Some(Domain::Sensor) => &[("output", &e.output)],
                _ => &[("input", &e.input)],
            },
            [("state", &e.state), ("port", &e.port), ("signal", &e.signal), ("output", &e.output), ("input", &e.input)],
        );
        for (name, value) in needed {
            if value.as_deref().is_none_or(str::is_empty) {
                return Err(JobError::invalid(field(name), format!("{} needs a {name}", e.kind)));
            }
        }
        for (name, value) in unused {
            // A state effect may name its signal; without one it reads the state (or its position).
            let optional = on_state && name == "signal";
            if value.is_some() && !optional && !needed.iter().any(|(n, _)| *n == name) {
                return Err(JobError::invalid(field(name), format!("{} takes no {name}", e.kind)));
            }
        }
        if let (Some(port), Some(signal)) = (&e.port, &e.signal)
            && port == signal
        {
            return Err(JobError::invalid(
                field("signal"),
                format!(
                    "{} is the port itself: an effect on a port depends on another signal",
                    quote_user_text(signal)
                ),
            ));
        }
        Ok(())
    }

    /// The same model, data and mapping, asked to evaluate `points` instead of calibrating.
    pub fn evaluating_points(&self, points: Vec<Vec<f64>>) -> JobSpec {
        JobSpec { kind: JobKind::EvaluatePoints(points), optimizer: OptimizerSpec::default(), ..self.clone() }
    }

    /// Names, starts and bounds of every calibrated value ([`Self::calibrated`]): the
    /// `[[parameters]]`, then the effects' parameters.
    pub fn parameter_vectors(&self) -> (Vec<String>, Vec<f64>, Vec<f64>, Vec<f64>) {
        let all = self.calibrated();
        (
            all.iter().map(|p| p.name.clone()).collect(),
            all.iter().map(|p| p.bounds.start).collect(),
            all.iter().map(|p| p.bounds.lower).collect(),
            all.iter().map(|p| p.bounds.upper).collect(),
        )
    }

    /// Which calibrated values the optimizer sees as their logarithm.
    pub fn log_scaled(&self) -> Vec<bool> {
        self.calibrated().iter().map(|p| p.scale == Scale::Log).collect()
    }
}

/// The smallest `[simulation] tolerance` accepted: a few units of double precision.
pub const MIN_TOLERANCE: f64 = 1e-14;

/// Bounds the optimizers can work in: ordered, and (when both are finite) a finite width apart;
/// an infinite bound leaves that side open.
fn check_bounds(lower: f64, upper: f64) -> Result<(), String> {
    if lower.is_nan() || upper.is_nan() || lower > upper {
        return Err(format!("lower {lower} is above upper {upper}"));
    }
    if lower.is_finite() && upper.is_finite() && !(upper - lower).is_finite() {
        return Err(format!(
            "the bounds [{lower:e}, {upper:e}] are too far apart (their width overflows): scale the parameter, or use scale = \"log\""
        ));
    }
    Ok(())
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::job::choices::Algorithm;

    /// A minimal valid job: one output, one parameter `k` in [0, 2] from 1 (the Python
    /// client's tests and fmucal-diagnose's read the same file).
    pub(crate) const JOB: &str = include_str!("../../tests/data/minimal_job.toml");

    #[test]
    fn minimal_toml_gets_defaults_and_resolved_paths() {
        let spec = JobSpec::from_toml(JOB, Path::new("/jobs")).unwrap();
        assert_eq!(spec.model.path.as_deref(), Some(Path::new("/jobs/m.fmu")));
        assert_eq!(spec.data.time_column, "time");
        assert_eq!(spec.outputs[0].weight, 1.0);
        assert_eq!(spec.optimizer.algorithm(), Algorithm::NelderMead);
        assert_eq!(spec.kind, JobKind::Calibration);
        assert!(spec.optimizer.parallel());
        spec.validate().unwrap();
    }

    #[test]
    fn inconsistent_parameters_name_the_field() {
        let bad = JOB.replace("lower = 0.0", "lower = 3.0");
        let e = JobSpec::from_toml(&bad, Path::new(".")).unwrap().validate().unwrap_err();
        assert!(e.to_string().starts_with("parameters[0].lower"), "{e}");
        let bad = JOB.replace("start = 1.0", "start = 5.0");
        let e = JobSpec::from_toml(&bad, Path::new(".")).unwrap().validate().unwrap_err();
        assert!(e.to_string().starts_with("parameters[0].start"), "{e}");
        let e = JobSpec::from_toml(&JOB.replace("[data]", "[data]\nbogus = 1"), Path::new(".")).unwrap_err();
        assert!(e.to_string().contains("bogus"), "{e}");
    }

    #[test]
    fn values_no_run_can_use_are_refused_at_validation() {
        let check = |from: &str, to: &str| {
            JobSpec::from_toml(&JOB.replace(from, to), Path::new(".")).unwrap().validate().map_err(|e| e.to_string())
        };
        let e = check("lower = 0.0\nupper = 2.0", "lower = -1e308\nupper = 1e308").unwrap_err();
        assert!(e.starts_with("parameters[0].lower: \"k\": the bounds [-1e308, 1e308] are too far apart"), "{e}");
        check("lower = 0.0\nupper = 2.0", "lower = -inf\nupper = inf").unwrap();
        let e = check("[data]", "[simulation]\ntolerance = 1e-300\n[data]").unwrap_err();
        assert!(e.starts_with("simulation.tolerance: 1e-300 is not in [1e-14, 1)"), "{e}");
        check("[data]", "[simulation]\ntolerance = 1e-10\n[data]").unwrap();
        let twice = format!("{JOB}[[parameters]]\nname = \"k\"\nstart = 1.0\nlower = 0.0\nupper = 2.0\n");
        let e = JobSpec::from_toml(&twice, Path::new(".")).unwrap().validate().unwrap_err().to_string();
        assert_eq!(e, "parameters[1].name: \"k\" appears twice");
    }

    #[test]
    fn careless_mappings_windows_and_worker_counts_name_the_field() {
        let check = |extra: &str| {
            JobSpec::from_toml(&format!("{JOB}{extra}"), Path::new(".")).unwrap().validate().map_err(|e| e.to_string())
        };
        let input = "[[inputs]]\ncolumn = \"u\"\nvariable = \"u\"\n";
        check(input).unwrap();
        let e = check(&format!("{input}[[inputs]]\ncolumn = \"v\"\nvariable = \"u\"\n")).unwrap_err();
        assert_eq!(e, "inputs[1].variable: \"u\" is already mapped by inputs[0]: an FMU input takes one column");
        let e = check("[[outputs]]\nvariable = \"y\"\ncolumn = \"y\"\nweight = 2.0\n").unwrap_err();
        assert!(e.starts_with("outputs[1]: \"y\" against column \"y\" is the same as outputs[0]"), "{e}");
        check("[[outputs]]\nvariable = \"y\"\ncolumn = \"y2\"\n").unwrap();
        for (count, ok) in [("0", false), ("1", true), ("256", true), ("257", false), ("1000000", false)] {
            let r = check(&format!("[workers]\ncount = {count}\n"));
            assert_eq!(r.is_ok(), ok, "{count}: {r:?}");
            if let Err(e) = r {
                assert!(e.starts_with(&format!("workers.count: {count} is not in 1..=256")), "{e}");
            }
        }
        for (window, says) in [
            (
                "stop_time = 5.0\nvalidation_stop_time = 4.0",
                "simulation.validation_stop_time: 4 is not a finite time after",
            ),
            ("stop_time = 5.0\nvalidation_stop_time = 5.0", "simulation.validation_stop_time: 5 is not"),
            ("validation_stop_time = nan", "simulation.validation_stop_time: NaN is not a finite time"),
            ("start_time = nan", "simulation.start_time: NaN is not a finite time"),
            ("stop_time = inf", "simulation.stop_time: inf is not a finite time"),
        ] {
            let e = check(&format!("[simulation]\n{window}\n")).unwrap_err();
            assert!(e.starts_with(says), "{e}");
        }
        check("[simulation]\nstop_time = 5.0\nvalidation_stop_time = 6.0\n").unwrap();
        let spec = JobSpec::from_toml(&format!("{JOB}[simulation]\nvalidation_stop_time = 3.0\n"), Path::new("."));
        let sim = spec.unwrap().simulation;
        sim.check_validation_stop(2.0).unwrap();
        let e = sim.check_validation_stop(3.0).unwrap_err().to_string();
        assert_eq!(e, "simulation.validation_stop_time: 3 is not a finite time after the calibration stop time 3");
        let effect = "[[effects]]\nkind = \"viscous_damping\"\nport = \"tau\"\nsignal = \"tau\"\nparameters = { c = { start = 0.0, lower = 0.0, upper = 1.0 } }\n";
        let e = check(effect).unwrap_err();
        assert!(e.starts_with("effects[0].signal: \"tau\" is the port itself"), "{e}");
    }

    #[test]
    fn choices_are_read_as_enums_and_bad_names_are_refused_with_the_line() {
        let spec = JobSpec::from_toml(
            &JOB.replace("path = \"m.fmu\"", "path = \"m.fmu\"\ninterface = \"cs\"")
                .replace("[data]", "[simulation]\nsolver = \"tsit45\"\n[optimizer]\nalgorithm = \"genetic\"\n[data]"),
            Path::new("."),
        )
        .unwrap();
        assert_eq!(spec.model.interface, Some(Interface::CoSimulation));
        assert_eq!(spec.simulation.solver, Some(Solver::Tsit45));
        assert_eq!(spec.optimizer.named_algorithm(), Some(Algorithm::Genetic));
        for (from, to, says) in [
            ("path = \"m.fmu\"", "path = \"m.fmu\"\ninterface = \"xx\"", "\"xx\" is not me or cs"),
            ("[data]", "[optimizer]\nalgorithm = \"points\"\n[data]", "\"points\" is not nelder-mead"),
            ("[data]", "[simulation]\nsolver = \"rk4\"\n[data]", "unknown solver \"rk4\""),
        ] {
            let e = JobSpec::from_toml(&JOB.replace(from, to), Path::new(".")).unwrap_err().to_string();
            assert!(e.starts_with("toml: ") && e.contains("line") && e.contains(says), "{e}");
        }
    }

    #[test]
    fn toml_errors_keep_the_parsers_layout_quoting_one_bounded_line() {
        let e = JobSpec::from_toml("[model]\npath = \"m.fmu\"\nbogus = = 1\n", Path::new(".")).unwrap_err().to_string();
        let lines: Vec<&str> = e.lines().collect();
        assert_eq!(
            lines[..4],
            ["toml: TOML parse error at line 3, column 9", "  |", "3 | bogus = = 1", "  |         ^"],
            "{e}"
        );
        assert_eq!(lines.len(), 5, "{e}");
        let long = format!("x = 1\ny = \"{}\u{202e}\" = 1\n", "y".repeat(10_000));
        let e = JobSpec::from_toml(&long, Path::new(".")).unwrap_err().to_string();
        let lines: Vec<&str> = e.lines().collect();
        assert!(lines.len() == 5 && e.len() < 500 && !e.contains('\u{202e}'), "{e}");
        let caret = lines[3].chars().position(|c| c == '^').unwrap();
        assert_eq!(lines[2].chars().nth(caret), Some('='), "{e}");
        assert!(lines[2].starts_with("2 | …yyy") && lines[2].contains("\\u{202e}"), "{e}");
    }
}
