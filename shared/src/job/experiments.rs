//! Several experiments in one calibration: the `[[experiments]]` of a job file, each with its own
//! data, mapping, fixed values and time windows, and how a job's calibrated values are laid out
//! when some parameters take one value per experiment.
//!
//! ```toml
//! [[parameters]]
//! name = "phi0"              # an initial state that differs between experiments:
//! per_experiment = true      # calibrated once per fitted experiment, as "phi0@step"
//! start = 0.0
//! lower = -0.5
//! upper = 0.5
//!
//! [[experiments]]
//! name = "step"              # unique; letters, digits, '_' and '-' (names a results folder)
//! data = { path = "step.csv" }     # default: the job's [data]
//! inputs = [{ column = "u", variable = "u" }]   # default: the job's [[inputs]]
//! # outputs = [...]          # default: the job's [[outputs]] (their weights too)
//! set = { g = 9.81 }         # over the job's [simulation] set
//! stop_time = 10.0           # start_time, stop_time, validation_stop_time: default the job's
//! starts = { phi0 = 0.1 }    # this experiment's start of a per-experiment parameter
//!
//! [[experiments]]
//! name = "held-out"
//! role = "validation"        # simulated with the optimum and reported, never fitted
//! data = { path = "held_out.csv" }
//! ```
//!
//! A job without `[[experiments]]` is one experiment made of its top-level fields. With them,
//! each experiment is a complete single-experiment job ([`ExperimentView`]) built from the
//! top-level fields and its own. The calibrated values ([`Calibrated`]) are the `[[parameters]]`
//! in order — a per-experiment one expanded into `NAME@EXPERIMENT` for each fitted experiment —
//! then the effects' parameters. In a validation experiment a per-experiment parameter is fixed
//! at its start (the experiment's `starts` entry, else the parameter's `start`).

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use super::JobError;
use super::choices::{ExperimentRole, Scale, text};
use super::spec::{Bounds, DataRef, InputMap, JobSpec, OutputMap, SetValue};
use crate::quote::quote_user_text;

/// One `[[experiments]]` entry; unset fields take the job's.
#[serde_with::skip_serializing_none]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExperimentSpec {
    pub name: String,
    /// `fit` (default) or `validation`.
    #[serde(default, with = "text", skip_serializing_if = "is_fit")]
    pub role: ExperimentRole,
    pub data: Option<DataRef>,
    pub outputs: Option<Vec<OutputMap>>,
    pub inputs: Option<Vec<InputMap>>,
    /// Fixed values, over the job's `[simulation] set`.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub set: BTreeMap<String, SetValue>,
    pub start_time: Option<f64>,
    pub stop_time: Option<f64>,
    pub validation_stop_time: Option<f64>,
    /// Starts of per-experiment parameters in this experiment, by name.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub starts: BTreeMap<String, f64>,
}

fn is_fit(role: &ExperimentRole) -> bool {
    *role == ExperimentRole::Fit
}

impl ExperimentSpec {
    /// An experiment named `name` that takes everything from the job.
    pub fn named(name: impl Into<String>) -> Self {
        ExperimentSpec {
            name: name.into(),
            role: ExperimentRole::Fit,
            data: None,
            outputs: None,
            inputs: None,
            set: BTreeMap::new(),
            start_time: None,
            stop_time: None,
            validation_stop_time: None,
            starts: BTreeMap::new(),
        }
    }
}

/// One experiment as a complete single-experiment job.
#[derive(Debug, Clone, PartialEq)]
pub struct ExperimentView {
    /// Empty for a job without `[[experiments]]`.
    pub name: String,
    pub role: ExperimentRole,
    /// Prefix of the fields its errors name: empty, or `experiments[K].`.
    pub field_prefix: String,
    /// Its data, mapping, windows and fixed values. Its `parameters` are the FMU parameters it
    /// calibrates (per-experiment ones at its start); a validation experiment's per-experiment
    /// parameters are in `simulation.set` instead.
    pub spec: JobSpec,
}

/// Where a calibrated value is used.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Slot {
    /// `[[parameters]]` entry `index`: shared by every experiment (`experiment: None`) or the
    /// value of one experiment (the index of its view).
    Parameter { index: usize, experiment: Option<usize> },
    /// Parameter `name` of effect `effect`.
    Effect { effect: usize, name: &'static str },
}

/// One calibrated value: its name in results, start and bounds, scale and use.
#[derive(Debug, Clone, PartialEq)]
pub struct Calibrated {
    pub name: String,
    pub bounds: Bounds,
    pub scale: Scale,
    pub slot: Slot,
}

/// The index in `calibrated` ([`JobSpec::calibrated`]) of the value experiment `experiment`
/// uses for `[[parameters]]` entry `index`.
pub fn position_for(calibrated: &[Calibrated], index: usize, experiment: usize) -> Option<usize> {
    calibrated.iter().position(|c| match c.slot {
        Slot::Parameter { index: i, experiment: e } => i == index && e.is_none_or(|e| e == experiment),
        Slot::Effect { .. } => false,
    })
}

/// Checks an experiment name: it names a folder of the CLI's output.
fn valid_name(name: &str) -> bool {
    !name.is_empty() && name.len() <= 64 && name.chars().all(|c| c.is_ascii_alphanumeric() || matches!(c, '_' | '-'))
}

impl JobSpec {
    /// The experiments as complete single-experiment jobs, in order; one (named "") for a job
    /// without `[[experiments]]`.
    pub fn experiment_views(&self) -> Vec<ExperimentView> {
        let mut base = self.clone();
        base.experiments = vec![];
        if self.experiments.is_empty() {
            return vec![ExperimentView {
                name: String::new(),
                role: ExperimentRole::Fit,
                field_prefix: String::new(),
                spec: base,
            }];
        }
        self.experiments
            .iter()
            .enumerate()
            .map(|(k, e)| {
                let mut s = base.clone();
                if let Some(d) = &e.data {
                    s.data = d.clone();
                }
                if let Some(o) = &e.outputs {
                    s.outputs = o.clone();
                }
                if let Some(i) = &e.inputs {
                    s.inputs = i.clone();
                }
                s.simulation.set.extend(e.set.iter().map(|(k, v)| (k.clone(), v.clone())));
                for (field, value) in [
                    (&mut s.simulation.start_time, e.start_time),
                    (&mut s.simulation.stop_time, e.stop_time),
                    (&mut s.simulation.validation_stop_time, e.validation_stop_time),
                ] {
                    if value.is_some() {
                        *field = value;
                    }
                }
                let mut parameters = vec![];
                for mut p in s.parameters {
                    if p.per_experiment {
                        p.start = e.starts.get(&p.name).copied().unwrap_or(p.start);
                        if e.role == ExperimentRole::Validation {
                            s.simulation.set.insert(p.name.clone(), SetValue::Number(p.start));
                            continue;
                        }
                    }
                    parameters.push(p);
                }
                s.parameters = parameters;
                ExperimentView {
                    name: e.name.clone(),
                    role: e.role,
                    field_prefix: format!("experiments[{k}]."),
                    spec: s,
                }
            })
            .collect()
    }

    /// Indices of the fitted experiments among [`Self::experiment_views`].
    pub fn fitted_experiments(&self) -> Vec<usize> {
        if self.experiments.is_empty() {
            return vec![0];
        }
        (0..self.experiments.len()).filter(|&k| self.experiments[k].role == ExperimentRole::Fit).collect()
    }

    /// Every calibrated value in order: the `[[parameters]]` (a per-experiment one once per
    /// fitted experiment, as `NAME@EXPERIMENT`), then the effects' parameters
    /// (`effects[K].NAME`). An invalid effect contributes nothing (see [`Self::validate`]).
    pub fn calibrated(&self) -> Vec<Calibrated> {
        let fitted = self.fitted_experiments();
        let mut out = vec![];
        for (index, p) in self.parameters.iter().enumerate() {
            let bounds = Bounds { start: p.start, lower: p.lower, upper: p.upper };
            if p.per_experiment && !self.experiments.is_empty() {
                for &e in &fitted {
                    let x = &self.experiments[e];
                    let start = x.starts.get(&p.name).copied().unwrap_or(p.start);
                    out.push(Calibrated {
                        name: format!("{}@{}", p.name, x.name),
                        bounds: Bounds { start, ..bounds },
                        scale: p.scale,
                        slot: Slot::Parameter { index, experiment: Some(e) },
                    });
                }
            } else {
                out.push(Calibrated {
                    name: p.name.clone(),
                    bounds,
                    scale: p.scale,
                    slot: Slot::Parameter { index, experiment: None },
                });
            }
        }
        for (k, e) in self.effects.iter().enumerate() {
            for (name, bounds) in e.ordered_parameters(k).unwrap_or_default() {
                out.push(Calibrated {
                    name: format!("effects[{k}].{name}"),
                    bounds,
                    scale: Scale::Linear,
                    slot: Slot::Effect { effect: k, name },
                });
            }
        }
        out
    }

    /// The index in [`Self::calibrated`] of the value experiment `experiment` uses for
    /// `[[parameters]]` entry `index`.
    pub fn calibrated_index(&self, index: usize, experiment: usize) -> Option<usize> {
        position_for(&self.calibrated(), index, experiment)
    }

    /// Checks the `[[experiments]]` and the per-experiment and log-scaled parameters.
    ///
    /// # Errors
    /// [`JobError::Invalid`] naming the field.
    pub(super) fn validate_experiments(&self) -> Result<(), JobError> {
        for (k, p) in self.parameters.iter().enumerate() {
            if p.per_experiment && self.experiments.is_empty() {
                return Err(JobError::invalid(
                    format!("parameters[{k}].per_experiment"),
                    format!("{}: a per-experiment parameter needs [[experiments]]", quote_user_text(&p.name)),
                ));
            }
            if p.scale == Scale::Log && !(p.lower > 0.0) {
                return Err(JobError::invalid(
                    format!("parameters[{k}].lower"),
                    format!(
                        "{}: scale = \"log\" needs a positive lower bound, got {}",
                        quote_user_text(&p.name),
                        p.lower
                    ),
                ));
            }
            if p.scale == Scale::Log && p.upper == f64::INFINITY {
                return Err(JobError::invalid(
                    format!("parameters[{k}].upper"),
                    format!("{}: scale = \"log\" needs a finite upper bound", quote_user_text(&p.name)),
                ));
            }
        }
        if self.experiments.is_empty() {
            return Ok(());
        }
        if self.fitted_experiments().is_empty() {
            return Err(JobError::invalid("experiments", "at least one experiment must have role = \"fit\""));
        }
        for (k, e) in self.experiments.iter().enumerate() {
            let field = |f: &str| format!("experiments[{k}].{f}");
            if !valid_name(&e.name) {
                return Err(JobError::invalid(
                    field("name"),
                    format!(
                        "{}: use 1 to 64 letters, digits, '_' or '-' (it names a folder of the results)",
                        quote_user_text(&e.name)
                    ),
                ));
            }
            if self.experiments[..k].iter().any(|o| o.name == e.name) {
                return Err(JobError::invalid(field("name"), format!("{} appears twice", quote_user_text(&e.name))));
            }
            for (name, start) in &e.starts {
                let Some(p) = self.parameters.iter().find(|p| &p.name == name && p.per_experiment) else {
                    return Err(JobError::invalid(
                        field(&format!("starts.{name}")),
                        "is not a parameter with per_experiment = true",
                    ));
                };
                if !(start.is_finite() && *start >= p.lower && *start <= p.upper) {
                    return Err(JobError::invalid(
                        field(&format!("starts.{name}")),
                        format!("{start} is outside [{}, {}]", p.lower, p.upper),
                    ));
                }
            }
            if let Some(outputs) = &e.outputs
                && outputs.is_empty()
            {
                return Err(JobError::invalid(field("outputs"), "at least one output is needed"));
            }
        }
        for view in self.experiment_views() {
            view.spec.validate_mapping().map_err(|e| prefixed(&view.field_prefix, e))?;
            view.spec.simulation.check_times().map_err(|e| prefixed(&view.field_prefix, e))?;
        }
        Ok(())
    }
}

/// `e` with its field named inside an experiment.
pub fn prefixed(prefix: &str, e: JobError) -> JobError {
    match e {
        JobError::Invalid { field, message } if !prefix.is_empty() => {
            JobError::Invalid { field: format!("{prefix}{field}"), message }
        }
        other => other,
    }
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use super::*;

    /// The minimal job with a per-experiment parameter and three experiments.
    static JOB: std::sync::LazyLock<String> = std::sync::LazyLock::new(|| {
        crate::job::spec::tests::JOB.to_owned()
            + r#"[[parameters]]
name = "y0"
per_experiment = true
start = 0.0
lower = -1.0
upper = 1.0
[[experiments]]
name = "a"
starts = { y0 = 0.5 }
[[experiments]]
name = "b"
data = { path = "b.csv" }
stop_time = 3.0
set = { g = 1.0 }
[[experiments]]
name = "c"
role = "validation"
starts = { y0 = -0.25 }
"#
    });

    #[test]
    fn per_experiment_parameters_expand_for_fitted_experiments_only() {
        let spec = JobSpec::from_toml(&JOB, Path::new("/jobs")).unwrap();
        spec.validate().unwrap();
        let names: Vec<String> = spec.calibrated().into_iter().map(|c| c.name).collect();
        assert_eq!(names, ["k", "y0@a", "y0@b"]);
        let (_, x0, ..) = spec.parameter_vectors();
        assert_eq!(x0, [1.0, 0.5, 0.0]);
        assert_eq!(spec.fitted_experiments(), [0, 1]);
        assert_eq!(spec.calibrated_index(1, 1), Some(2));
        assert_eq!(spec.calibrated_index(0, 1), Some(0));
        assert_eq!(spec.calibrated_index(1, 2), None, "validation experiments calibrate nothing of their own");
    }

    #[test]
    fn views_inherit_the_job_and_override_their_own_fields() {
        let spec = JobSpec::from_toml(&JOB, Path::new("/jobs")).unwrap();
        let views = spec.experiment_views();
        assert_eq!(views.len(), 3);
        assert_eq!(views[0].spec.data.path.as_deref(), Some(Path::new("/jobs/d.csv")));
        assert_eq!(views[1].spec.data.path.as_deref(), Some(Path::new("/jobs/b.csv")), "resolved against the file");
        assert_eq!(views[1].spec.simulation.stop_time, Some(3.0));
        assert_eq!(views[1].spec.simulation.set["g"], SetValue::Number(1.0));
        assert_eq!(views[0].spec.parameters[1].start, 0.5);
        assert_eq!(views[2].spec.parameters.len(), 1, "the validation experiment fixes y0");
        assert_eq!(views[2].spec.simulation.set["y0"], SetValue::Number(-0.25));
        assert!(views.iter().all(|v| v.spec.experiments.is_empty()));
        let plain = JobSpec::from_toml(&JOB[..JOB.find("[[parameters]]\nname = \"y0\"").unwrap()], Path::new("."));
        let views = plain.unwrap().experiment_views();
        assert_eq!((views.len(), views[0].name.as_str(), views[0].field_prefix.as_str()), (1, "", ""));
    }

    #[test]
    fn bad_experiments_name_the_field() {
        for (from, to, field) in [
            ("name = \"b\"", "name = \"a\"", "experiments[1].name"),
            ("name = \"b\"", "name = \"../b\"", "experiments[1].name"),
            ("starts = { y0 = 0.5 }", "starts = { k = 0.5 }", "experiments[0].starts.k"),
            ("starts = { y0 = 0.5 }", "starts = { y0 = 5.0 }", "experiments[0].starts.y0"),
            ("path = \"b.csv\" }", "path = \"b.csv\", bogus = 1 }", "toml"),
        ] {
            let e = JobSpec::from_toml(&JOB.replace(from, to), Path::new(".")).and_then(|s| s.validate());
            let e = e.unwrap_err().to_string();
            assert!(e.starts_with(field), "{e}");
        }
        let all_validation = JOB
            .replace("role = \"validation\"\n", "")
            .replace("[[experiments]]\nname", "[[experiments]]\nrole = \"validation\"\nname");
        let e = JobSpec::from_toml(&all_validation, Path::new(".")).unwrap().validate().unwrap_err();
        assert!(e.to_string().starts_with("experiments: at least one"), "{e}");
        let e = JobSpec::from_toml(&JOB.replace("role = \"validation\"", "role = \"check\""), Path::new("."));
        assert!(e.unwrap_err().to_string().contains("\"check\" is not fit or validation"));
        let alone = &JOB[..JOB.find("[[experiments]]").unwrap()];
        let e = JobSpec::from_toml(alone, Path::new(".")).unwrap().validate().unwrap_err();
        assert!(e.to_string().starts_with("parameters[1].per_experiment"), "{e}");
    }

    #[test]
    fn log_scale_needs_positive_finite_bounds() {
        let job = &JOB[..JOB.find("[[parameters]]\nname = \"y0\"").unwrap()];
        let log = job.replace("upper = 2.0", "upper = 2.0\nscale = \"log\"");
        let e = JobSpec::from_toml(&log, Path::new(".")).unwrap().validate().unwrap_err();
        assert!(e.to_string().starts_with("parameters[0].lower") && e.to_string().contains("positive"), "{e}");
        let ok = log.replace("lower = 0.0", "lower = 1e-3");
        JobSpec::from_toml(&ok, Path::new(".")).unwrap().validate().unwrap();
    }
}
