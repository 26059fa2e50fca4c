//! Where a diagnosis may add effects, from the job's `[diagnose]` section and the model's own
//! structure ([`super::structure`]): the injection ports listed by hand, then every injection
//! input the model has that the job does not feed from data, then (Model Exchange) every
//! continuous state, narrowed by `states` and `exclude`. What cannot be tried, and why, is kept
//! as notes for the summary.

use super::effects::Domain;
use super::spec::{DiagnoseSpec, PortDomain, PortSpec};
use super::structure::{Role, Structure};
use crate::job::JobSpec;

/// A port a diagnosis may add terms to, with the job field (or model input) it comes from.
#[derive(Debug, Clone, PartialEq)]
pub struct PortPlace {
    pub spec: PortSpec,
    /// `diagnose.ports[1]`, or `model input pendulumJoint.tauExt` for one found in the model.
    pub source: String,
    /// Listed by hand: a probe that cannot size it is an error, not a note.
    pub by_hand: bool,
    /// Listed by hand, or paired with the states of its own component (not with all of them
    /// for want of a shared prefix).
    pub by_prefix: bool,
}

/// A continuous state whose derivative a diagnosis may add terms to.
#[derive(Debug, Clone, PartialEq)]
pub struct StatePlace {
    pub state: String,
    pub role: Role,
    /// For a velocity: the position whose derivative it is (what springs read).
    pub position: Option<String>,
}

/// Every place of one diagnosis.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Places {
    pub ports: Vec<PortPlace>,
    pub states: Vec<StatePlace>,
    /// What could not be tried, and why, in words.
    pub notes: Vec<String>,
}

impl Places {
    /// The places of `job` on a model of `structure` (read with the job's mapped inputs left
    /// out). `model_exchange`: the job simulates in Model Exchange, where fmucal integrates the
    /// states; otherwise `why_not` says why state effects are out.
    pub fn new(job: &JobSpec, diagnose: &DiagnoseSpec, structure: &Structure, model_exchange: Result<(), String>) -> Places {
        let excluded = |name: &str| diagnose.exclude.iter().any(|e| e == name);
        let mut ports: Vec<PortPlace> = diagnose
            .ports
            .iter()
            .enumerate()
            .map(|(k, p)| PortPlace {
                spec: p.clone(),
                source: format!("diagnose.ports[{k}]"),
                by_hand: true,
                by_prefix: true,
            })
            .collect();
        let mapped: Vec<&str> = job.inputs.iter().map(|i| i.variable.as_str()).collect();
        for p in &structure.ports {
            if excluded(&p.name) || mapped.contains(&p.name.as_str()) || ports.iter().any(|q| q.spec.port == p.name) {
                continue;
            }
            let keep = |list: &[String]| -> Vec<String> { list.iter().filter(|s| !excluded(s)).cloned().collect() };
            let domain = match p.domain {
                Domain::Thermal => PortDomain::Thermal,
                _ => PortDomain::Mechanical,
            };
            let spec = PortSpec {
                port: p.name.clone(),
                domain,
                velocities: keep(&p.velocities),
                positions: keep(&p.positions),
                temperatures: keep(&p.temperatures),
                scale: None,
                ambient: None,
            };
            if spec.signals().next().is_none() {
                continue;
            }
            ports.push(PortPlace { spec, source: format!("model input {}", p.name), by_hand: false, by_prefix: p.by_prefix });
        }
        let mut notes = vec![];
        // One physical place, one set of candidates. A port paired with its own component's
        // states is the place where their terms enter, so those states get no state effects of
        // the port's domain; a port paired with every state only for want of a shared prefix is
        // left to the state effects, which say where (Model Exchange).
        if model_exchange.is_ok() && !structure.states.is_empty() {
            ports.retain(|p| {
                let keep = p.by_hand || p.by_prefix;
                if !keep {
                    notes.push(format!(
                        "port effects on input {}: it is not tied to one component, so its effects are tried on the states' derivatives instead",
                        p.spec.port
                    ));
                }
                keep
            });
        }
        let covered: Vec<&str> = ports
            .iter()
            .filter(|p| p.by_prefix)
            .flat_map(|p| p.spec.velocities.iter().chain(&p.spec.temperatures).map(String::as_str))
            .collect();
        if ports.is_empty() && notes.is_empty() {
            notes.push("no injection input (a force, torque or heat-flow input not fed from data): no port effects".to_owned());
        }
        let states = match model_exchange {
            Err(why) => {
                notes.push(format!("{why}: no state effects"));
                vec![]
            }
            Ok(()) => structure
                .states
                .iter()
                .filter(|s| !excluded(&s.name))
                .filter(|s| diagnose.states.as_ref().is_none_or(|only| only.contains(&s.name)))
                // A position gets its terms through its velocity's derivative.
                .filter(|s| s.role != Role::Position)
                .filter(|s| !covered.contains(&s.name.as_str()))
                .map(|s| StatePlace { state: s.name.clone(), role: s.role, position: s.position.clone() })
                .collect(),
        };
        Places { ports, states, notes }
    }
}
