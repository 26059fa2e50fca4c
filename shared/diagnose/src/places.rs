//! Where a diagnosis may add effects, from the job's `[diagnose]` section and the model's own
//! structure ([`fmucal_shared::structure`]). With no port listed by hand (no `[diagnose]` section at
//! all, say), every injection input the model has that the job does not feed from data, and
//! (Model Exchange) every continuous state, narrowed by `states` and `exclude`. Ports listed by
//! hand say where to look: then only they, and the states `states` names. What cannot be
//! tried, and why, is kept as notes for the summary.

use super::spec::{DiagnoseSpec, PortDomain, PortSpec};
use fmucal_shared::effects::Domain;
use fmucal_shared::job::JobSpec;
use fmucal_shared::structure::{Role, Structure};

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
    /// For a velocity: the velocities coupled with it ([`fmucal_shared::structure::State::coupled`])
    /// that are places of this diagnosis too (so sized, and not excluded), where its friction's
    /// reaction may act.
    pub coupled: Vec<String>,
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
    /// out). `model_exchange` is `Ok` when the job simulates in Model Exchange, where fmucal
    /// integrates the states, else why state effects are out. Names in `states` and `exclude`
    /// may be a state's aliases.
    pub fn new(
        job: &JobSpec,
        diagnose: &DiagnoseSpec,
        structure: &Structure,
        model_exchange: Result<(), String>,
    ) -> Places {
        // A state named by an alias stands for the state.
        let canonical = |name: &str| structure.state(name).map_or_else(|| name.to_owned(), |s| s.name.clone());
        let exclude: Vec<String> = diagnose.exclude.iter().map(|n| canonical(n)).collect();
        let only: Option<Vec<String>> = diagnose.states.as_ref().map(|l| l.iter().map(|n| canonical(n)).collect());
        let excluded = |name: &str| exclude.iter().any(|e| e == name) || diagnose.exclude.iter().any(|e| e == name);
        let mut ports: Vec<PortPlace> = diagnose
            .ports
            .iter()
            .enumerate()
            .filter(|(_, p)| !excluded(&p.port))
            .map(|(k, p)| PortPlace {
                spec: p.clone(),
                source: format!("diagnose.ports[{k}]"),
                by_hand: true,
                by_prefix: true,
            })
            .collect();
        let mapped: Vec<&str> = job.inputs.iter().map(|i| i.variable.as_str()).collect();
        let by_hand = !diagnose.ports.is_empty();
        let mut notes = vec![];
        if by_hand && only.is_none() {
            notes.push(
                "the model's other injection inputs and states: diagnose.ports says where to look (name states in diagnose.states to add them)"
                    .to_owned(),
            );
        }
        for p in structure.ports.iter().filter(|_| !by_hand) {
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
            ports.push(PortPlace {
                spec,
                source: format!("model input {}", p.name),
                by_hand: false,
                by_prefix: p.by_prefix,
            });
        }
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
            notes.push(
                "no injection input (a force, torque or heat-flow input not fed from data): no port effects".to_owned(),
            );
        }
        let mut states = match model_exchange {
            Err(why) => {
                notes.push(format!("{why}: no state effects"));
                vec![]
            }
            Ok(()) => structure
                .states
                .iter()
                .filter(|s| !excluded(&s.name))
                .filter(|s| match &only {
                    Some(only) => only.contains(&s.name),
                    None => !by_hand,
                })
                // A position gets its terms through its velocity's derivative.
                .filter(|s| s.role != Role::Position)
                .filter(|s| !covered.contains(&s.name.as_str()))
                .map(|s| StatePlace {
                    state: s.name.clone(),
                    role: s.role,
                    position: s.position.clone(),
                    coupled: s.coupled.clone(),
                })
                .collect(),
        };
        // A reaction acts only on a velocity that is a place itself (sized by the probe).
        let names: Vec<String> = states.iter().map(|s| s.state.clone()).collect();
        for s in &mut states {
            s.coupled.retain(|c| names.contains(c));
        }
        // A state `states` names that is no place says why.
        for name in only.iter().flatten() {
            if states.iter().any(|s: &StatePlace| &s.state == name) || excluded(name) {
                continue;
            }
            match structure.state(name) {
                Some(s) if s.role == Role::Position => notes
                    .push(format!("diagnose.states: {name} is a position; its terms go on its velocity's derivative")),
                Some(_) if covered.contains(&name.as_str()) => {
                    notes.push(format!("diagnose.states: {name} is left to the port of its component"))
                }
                _ => {}
            }
        }
        Places { ports, states, notes }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fmucal_shared::effects::Domain;
    use fmucal_shared::structure::{Port, Quantity, State};

    fn state(name: &str, role: Role, position: Option<&str>) -> State {
        State {
            name: name.into(),
            index: 0,
            derivative: format!("der({name})"),
            unit: None,
            quantity: Quantity::Translational,
            role,
            position: position.map(str::to_owned),
            velocity: None,
            paired_by: None,
            derivative_aliases: vec![],
            aliases: vec![format!("{name}_alias")],
            coupled: vec![],
        }
    }

    fn port(name: &str, velocities: &[&str], by_prefix: bool) -> Port {
        Port {
            name: name.into(),
            unit: "N".into(),
            domain: Domain::Mechanical,
            quantity: Quantity::Translational,
            velocities: velocities.iter().map(|s| s.to_string()).collect(),
            positions: vec![],
            temperatures: vec![],
            by_prefix,
        }
    }

    fn job(inputs: &str) -> JobSpec {
        let text = format!(
            "[model]\npath = \"m.fmu\"\n[data]\npath = \"d.csv\"\n[[outputs]]\nvariable = \"x\"\ncolumn = \"x\"\n{inputs}"
        );
        JobSpec::from_toml(&text, std::path::Path::new("/")).unwrap()
    }

    #[test]
    fn a_port_of_its_own_component_takes_its_states_and_one_of_no_component_leaves_them_to_state_effects() {
        let structure = Structure {
            states: vec![
                state("a.x", Role::Position, None),
                state("a.v", Role::Velocity, Some("a.x")),
                state("b.v", Role::Velocity, None),
                state("c", Role::Other, None),
            ],
            ports: vec![port("a.f", &["a.v"], true), port("F", &["a.v", "b.v"], false)],
        };
        let p = Places::new(&job(""), &DiagnoseSpec::default(), &structure, Ok(()));
        let ports: Vec<&str> = p.ports.iter().map(|p| p.spec.port.as_str()).collect();
        let states: Vec<&str> = p.states.iter().map(|s| s.state.as_str()).collect();
        assert_eq!((ports, states), (vec!["a.f"], vec!["b.v", "c"]));
        assert_eq!(p.notes.len(), 1);
        assert!(p.notes[0].starts_with("port effects on input F: it is not tied to one component"), "{:?}", p.notes);

        // Co-Simulation: no state effects, so the port of no component stays.
        let p = Places::new(&job(""), &DiagnoseSpec::default(), &structure, Err("Co-Simulation only".into()));
        assert_eq!(p.ports.len(), 2);
        assert!(p.states.is_empty());
        assert_eq!(p.notes, ["Co-Simulation only: no state effects"]);

        // A mapped input is no port; `states` and `exclude` narrow, by a state's alias too.
        let mapped = job("[[inputs]]\ncolumn = \"a\"\nvariable = \"a.f\"\n");
        let settings = DiagnoseSpec {
            states: Some(vec!["a.v_alias".into(), "c".into()]),
            exclude: vec!["c_alias".into()],
            ..DiagnoseSpec::default()
        };
        let p = Places::new(&mapped, &settings, &structure, Ok(()));
        let states: Vec<&str> = p.states.iter().map(|s| s.state.as_str()).collect();
        assert_eq!(states, ["a.v"]);
        assert!(p.ports.is_empty());

        // Ports listed by hand say where to look: no other place, unless `states` names one.
        let hand: DiagnoseSpec =
            toml::from_str("[[ports]]\nport = \"F\"\ndomain = \"mechanical\"\nvelocities = [\"b.v\"]\n").unwrap();
        let p = Places::new(&job(""), &hand, &structure, Ok(()));
        assert_eq!((p.ports.len(), p.states.len()), (1, 0));
        assert!(p.notes[0].contains("diagnose.ports says where to look"), "{:?}", p.notes);
        let with_states = DiagnoseSpec { states: Some(vec!["c".into()]), ..hand };
        let p = Places::new(&job(""), &with_states, &structure, Ok(()));
        let states: Vec<&str> = p.states.iter().map(|s| s.state.as_str()).collect();
        assert_eq!(states, ["c"]);
    }

    #[test]
    fn a_model_without_injection_inputs_says_so() {
        let structure = Structure { states: vec![state("v", Role::Velocity, None)], ports: vec![] };
        let p = Places::new(&job(""), &DiagnoseSpec::default(), &structure, Ok(()));
        assert_eq!(p.notes.len(), 1);
        assert!(p.notes[0].starts_with("no injection input"), "{:?}", p.notes);
    }
}
