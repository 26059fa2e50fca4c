//! The job file's `[diagnose]` section: which injection ports a diagnosis may add effects to,
//! with their physical domain and the signals the user allows, and the settings of the
//! screening and the decision. `fmucal calibrate` ignores it.
//!
//! ```toml
//! [diagnose]
//! top = 8                      # candidates fitted after screening (K)
//! fix_base = false             # true: candidates fit only their own parameters
//! holdout = 0.25               # without [simulation] validation_stop_time: the last quarter
//!                              # of the window is held out of every fit and used to decide
//! min_validation_gain = 0.02   # an effect must cut the held-out RMS by at least 2 %, and by
//!                              # more than chance (see crate::decision)
//! confidence = 0.95            # of that test and of the parameters' intervals, which must
//!                              # exclude "no effect"
//! windows = 10                 # time windows of the residual report
//! rounds = 1                   # 2: after naming one effect, look for a second
//! series = true                # also try sensor effects on every output and actuator
//!                              # effects on every input
//! signals = ["armJoint.w"]     # more signals to correlate the residual with
//! states = ["mass.v"]          # Model Exchange: only these states get state effects
//!                              # (default: every continuous state of the model)
//! exclude = ["mass.x", "F"]    # states, ports, outputs and inputs that get no candidate
//!
//! [[diagnose.ports]]
//! port = "pendulumJoint.tauExt"
//! domain = "mechanical"        # mechanical: velocities and positions; thermal: temperatures
//! velocities = ["pendulumJoint.w"]
//! positions = ["pendulumJoint.phi"]
//! scale = 0.01                 # optional: typical size of what the port adds (else probed)
//! # ambient = 293.15           # thermal: ambient temperature guess (default 293.15)
//! ```

use serde::{Deserialize, Serialize};

use fmucal_shared::job::JobError;
use fmucal_shared::job::spec::toml_error;
use fmucal_shared::quote::quote_user_text;

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DiagnoseSpec {
    #[serde(default)]
    pub ports: Vec<PortSpec>,
    /// Signals to correlate the residual with besides the ports' signals and the job's inputs
    /// and outputs.
    #[serde(default)]
    pub signals: Vec<String>,
    #[serde(default = "default_top")]
    pub top: usize,
    #[serde(default)]
    pub fix_base: bool,
    pub holdout: Option<f64>,
    #[serde(default = "default_min_gain")]
    pub min_validation_gain: f64,
    #[serde(default = "default_confidence")]
    pub confidence: f64,
    #[serde(default = "default_windows")]
    pub windows: usize,
    #[serde(default = "default_rounds")]
    pub rounds: usize,
    #[serde(default = "default_true")]
    pub series: bool,
    /// Only these continuous states get state effects; `None`: every state.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub states: Option<Vec<String>>,
    /// States, ports, outputs and inputs that get no candidate.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub exclude: Vec<String>,
}

impl Default for DiagnoseSpec {
    fn default() -> Self {
        toml::from_str("").expect("an empty [diagnose] table is valid")
    }
}

fn default_top() -> usize {
    8
}
fn default_min_gain() -> f64 {
    0.02
}
fn default_confidence() -> f64 {
    0.95
}
fn default_windows() -> usize {
    10
}
fn default_rounds() -> usize {
    1
}
fn default_true() -> bool {
    true
}

/// Holdout fraction when the job has no validation window and `holdout` is not given.
pub const DEFAULT_HOLDOUT: f64 = 0.25;

/// The physical domain of an injection port.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum PortDomain {
    Mechanical,
    Thermal,
}

#[serde_with::skip_serializing_none]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PortSpec {
    pub port: String,
    pub domain: PortDomain,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub velocities: Vec<String>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub positions: Vec<String>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub temperatures: Vec<String>,
    /// Typical size of the load the port adds; probed from the model when absent.
    pub scale: Option<f64>,
    /// Ambient temperature guess of thermal effects. Default 293.15.
    pub ambient: Option<f64>,
}

impl PortSpec {
    /// Every signal of the port, with the field that names it.
    pub fn signals(&self) -> impl Iterator<Item = (String, &str)> {
        [("velocities", &self.velocities), ("positions", &self.positions), ("temperatures", &self.temperatures)]
            .into_iter()
            .flat_map(|(field, list)| list.iter().enumerate().map(move |(k, s)| (format!("{field}[{k}]"), s.as_str())))
    }
}

impl DiagnoseSpec {
    /// The `[diagnose]` section of a job file's text, checked ([`DiagnoseSpec::validate`]);
    /// the defaults where the job has none. The job itself is read by
    /// [`JobSpec::from_toml`](fmucal_shared::job::JobSpec::from_toml), which keeps the section as
    /// written.
    ///
    /// # Errors
    /// [`JobError::Invalid`]: field `toml` with the parser's message in its layout (the line at
    /// fault quoted) for an unknown key or a wrong type, else as [`DiagnoseSpec::validate`].
    pub fn from_job_text(text: &str) -> Result<DiagnoseSpec, JobError> {
        #[derive(Deserialize)]
        struct Job {
            diagnose: Option<DiagnoseSpec>,
        }
        let job: Job = toml::from_str(text).map_err(|e| JobError::invalid("toml", toml_error(&e, text)))?;
        let spec = job.diagnose.unwrap_or_default();
        spec.validate()?;
        Ok(spec)
    }

    /// The section a job carries ([`JobSpec::diagnose`](fmucal_shared::job::JobSpec::diagnose)),
    /// checked; the defaults for none.
    ///
    /// # Errors
    /// [`JobError::Invalid`] naming the field.
    pub fn from_table(table: Option<&toml::Table>) -> Result<DiagnoseSpec, JobError> {
        let Some(table) = table else { return Ok(DiagnoseSpec::default()) };
        let spec: DiagnoseSpec = toml::Value::Table(table.clone())
            .try_into()
            .map_err(|e: toml::de::Error| JobError::invalid("diagnose", e.message().to_string()))?;
        spec.validate()?;
        Ok(spec)
    }

    /// The `[diagnose]` section as a job file's text, every setting spelled out (defaults
    /// included) in the settings' order, for a written job.
    pub fn to_job_text(&self) -> String {
        #[derive(Serialize)]
        struct Section<'a> {
            diagnose: &'a DiagnoseSpec,
        }
        toml::to_string(&Section { diagnose: self }).expect("a [diagnose] section is a TOML table")
    }

    /// The section as a job carries it.
    pub fn to_table(&self) -> toml::Table {
        toml::Table::try_from(self).expect("a [diagnose] section is a TOML table")
    }

    /// Checks what can be checked without the model: settings in range, each port with signals
    /// of its domain. The model checks (a real input, readable signals, no algebraic loop) come
    /// when the candidates are prepared.
    ///
    /// # Errors
    /// [`JobError::Invalid`] naming the field (`diagnose.ports[1].temperatures`, ...).
    pub fn validate(&self) -> Result<(), JobError> {
        let bad = |field: &str, message: String| Err(JobError::invalid(format!("diagnose.{field}"), message));
        if self.top == 0 {
            return bad("top", "must be at least 1".into());
        }
        if let Some(h) = self.holdout
            && !(h > 0.0 && h <= 0.75)
        {
            return bad("holdout", format!("{h} is not a fraction in (0, 0.75]"));
        }
        if !(0.0..1.0).contains(&self.min_validation_gain) {
            return bad("min_validation_gain", format!("{} is not in [0, 1)", self.min_validation_gain));
        }
        if !(self.confidence > 0.5 && self.confidence < 1.0) {
            return bad("confidence", format!("{} is not in (0.5, 1)", self.confidence));
        }
        if !(1..=1000).contains(&self.windows) {
            return bad("windows", format!("{} is not in 1..=1000", self.windows));
        }
        if !(1..=2).contains(&self.rounds) {
            return bad("rounds", format!("{} is not 1 or 2", self.rounds));
        }
        for (field, list) in [("states", self.states.as_deref().unwrap_or_default()), ("exclude", &self.exclude)] {
            if list.len() > 10_000 {
                return bad(field, format!("lists {} names; at most 10000", list.len()));
            }
            if let Some(k) = list.iter().position(|n| n.trim().is_empty()) {
                return bad(&format!("{field}[{k}]"), "is empty".into());
            }
        }
        for (k, p) in self.ports.iter().enumerate() {
            let field = |f: &str| format!("ports[{k}].{f}");
            if p.port.trim().is_empty() {
                return bad(&field("port"), "is empty".into());
            }
            if self.ports[..k].iter().any(|q| q.port == p.port) {
                return bad(&field("port"), format!("{} is listed twice", quote_user_text(&p.port)));
            }
            let (wrong, needed): (&[(&str, &Vec<String>)], &str) = match p.domain {
                PortDomain::Mechanical => (&[("temperatures", &p.temperatures)], "velocities or positions"),
                PortDomain::Thermal => (&[("velocities", &p.velocities), ("positions", &p.positions)], "temperatures"),
            };
            if let Some((name, _)) = wrong.iter().find(|(_, list)| !list.is_empty()) {
                return bad(&field(name), format!("a {:?} port takes no {name}", p.domain).to_lowercase());
            }
            if p.signals().next().is_none() {
                return bad(&field("domain"), format!("port {} lists no {needed}", quote_user_text(&p.port)));
            }
            if let Some((f, _)) = p.signals().find(|(_, s)| s.trim().is_empty()) {
                return bad(&field(&f), "is empty".into());
            }
            if let Some((f, _)) = p.signals().find(|(_, s)| *s == p.port) {
                return bad(
                    &field(&f),
                    format!(
                        "{} is the port itself: an effect on a port depends on another signal",
                        quote_user_text(&p.port)
                    ),
                );
            }
            if p.domain == PortDomain::Mechanical && p.ambient.is_some() {
                return bad(&field("ambient"), "a mechanical port takes no ambient temperature".into());
            }
            if let Some(s) = p.scale
                && !(s > 0.0 && s.is_finite())
            {
                return bad(&field("scale"), format!("{s} is not a positive number"));
            }
            if let Some(a) = p.ambient
                && !a.is_finite()
            {
                return bad(&field("ambient"), format!("{a} is not a number"));
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec(text: &str) -> Result<DiagnoseSpec, String> {
        let s: DiagnoseSpec = toml::from_str(text).map_err(|e| e.to_string())?;
        s.validate().map_err(|e| e.to_string())?;
        Ok(s)
    }

    #[test]
    fn the_section_reads_from_a_job_and_from_the_table_a_job_carries() {
        let job = "[model]\npath = \"m.fmu\"\n\n[diagnose]\ntop = 3\nexclude = [\"x\"]\n";
        let s = DiagnoseSpec::from_job_text(job).unwrap();
        assert_eq!((s.top, s.exclude.clone()), (3, vec!["x".to_string()]));
        assert_eq!(DiagnoseSpec::from_table(Some(&s.to_table())).unwrap(), s);
        // A written job spells out every setting, defaults included, and reads back the same.
        let written = s.to_job_text();
        assert!(written.starts_with("[diagnose]\n") && written.contains("confidence = 0.95"), "{written}");
        assert_eq!(DiagnoseSpec::from_job_text(&format!("[model]\n{written}")).unwrap(), s);
        assert_eq!(DiagnoseSpec::from_table(None).unwrap(), DiagnoseSpec::default());
        assert_eq!(DiagnoseSpec::from_job_text("[model]\n").unwrap(), DiagnoseSpec::default());
        let e = DiagnoseSpec::from_job_text("[diagnose]\ntopp = 3\n").unwrap_err().to_string();
        assert!(e.contains("line 2") && e.contains("unknown field `topp`"), "{e}");
        let mut t = toml::Table::new();
        t.insert("top".into(), toml::Value::Integer(0));
        let e = DiagnoseSpec::from_table(Some(&t)).unwrap_err().to_string();
        assert!(e.starts_with("diagnose.top: must be at least 1"), "{e}");
    }

    #[test]
    fn an_empty_section_gets_the_documented_defaults() {
        let s = spec("").unwrap();
        assert_eq!((s.top, s.fix_base, s.holdout, s.windows, s.rounds, s.series), (8, false, None, 10, 1, true));
        assert_eq!((s.min_validation_gain, s.confidence), (0.02, 0.95));
    }

    #[test]
    fn bad_settings_name_the_field() {
        let port = "[[ports]]\nport = \"p\"\ndomain = \"mechanical\"\n";
        for (text, want) in [
            ("top = 0", "diagnose.top: must be at least 1"),
            ("holdout = 0.9", "diagnose.holdout: 0.9 is not a fraction"),
            ("rounds = 3", "diagnose.rounds: 3 is not 1 or 2"),
            ("confidence = 1.0", "diagnose.confidence"),
            ("exclude = [\"a\", \" \"]", "diagnose.exclude[1]: is empty"),
            (
                &format!("{port}velocities = [\"v\"]\ntemperatures = [\"T\"]"),
                "diagnose.ports[0].temperatures: a mechanical port takes no temperatures",
            ),
            (port, "diagnose.ports[0].domain: port \"p\" lists no velocities or positions"),
            (&format!("{port}velocities = [\"v\", \"\"]"), "diagnose.ports[0].velocities[1]: is empty"),
            (
                &format!("{port}velocities = [\"v\"]\nscale = -1.0"),
                "diagnose.ports[0].scale: -1 is not a positive number",
            ),
            (
                &format!("{port}velocities = [\"v\"]\n{port}positions = [\"x\"]"),
                "diagnose.ports[1].port: \"p\" is listed twice",
            ),
            (
                &format!("{port}velocities = [\"v\", \"p\"]"),
                "diagnose.ports[0].velocities[1]: \"p\" is the port itself",
            ),
            (&format!("{port}positions = [\"p\"]"), "diagnose.ports[0].positions[0]: \"p\" is the port itself"),
            (
                &format!("{port}velocities = [\"v\"]\nambient = 300.0"),
                "diagnose.ports[0].ambient: a mechanical port takes no ambient temperature",
            ),
        ] {
            let e = spec(text).unwrap_err();
            assert!(e.starts_with(want), "{want:?} is not the start of {e:?}");
        }
        let e = spec("[[ports]]\nport = \"p\"\ndomain = \"electrical\"\nvelocities = [\"v\"]").unwrap_err();
        assert!(e.contains("unknown variant `electrical`"), "{e}");
    }
}
