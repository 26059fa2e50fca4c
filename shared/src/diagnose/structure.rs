//! TEMPORARY stand-in (replaced by the structure reader of branch h27struct).

use serde::Serialize;

use super::effects::Domain;
use crate::fmu::ModelDescription;

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Quantity {
    Translational,
    Rotational,
    Thermal,
    Other,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Role {
    Position,
    Velocity,
    Temperature,
    Other,
}

#[derive(Debug, Clone, Serialize)]
pub struct State {
    pub name: String,
    pub index: usize,
    pub derivative: String,
    pub unit: Option<String>,
    pub quantity: Quantity,
    pub role: Role,
    pub position: Option<String>,
    pub velocity: Option<String>,
    pub derivative_aliases: Vec<String>,
}

#[derive(Debug, Clone, Serialize)]
pub struct Port {
    pub name: String,
    pub unit: String,
    pub domain: Domain,
    pub velocities: Vec<String>,
    pub positions: Vec<String>,
    pub temperatures: Vec<String>,
}

#[derive(Debug, Clone, Default, Serialize)]
pub struct Structure {
    pub states: Vec<State>,
    pub ports: Vec<Port>,
}

impl Structure {
    pub fn read(md: &ModelDescription, _mapped_inputs: &[String]) -> Structure {
        let states = md.states();
        let mut out: Vec<State> = states
            .iter()
            .enumerate()
            .map(|(index, (s, d))| {
                let unit = md.unit_of(s).map(str::to_owned);
                let (quantity, role) = match unit.as_deref() {
                    Some("m") => (Quantity::Translational, Role::Other),
                    Some("m/s") => (Quantity::Translational, Role::Velocity),
                    Some("rad") => (Quantity::Rotational, Role::Other),
                    Some("rad/s") => (Quantity::Rotational, Role::Velocity),
                    Some("K") => (Quantity::Thermal, Role::Temperature),
                    _ => (Quantity::Other, Role::Other),
                };
                State {
                    name: s.name.clone(),
                    index,
                    derivative: d.name.clone(),
                    unit,
                    quantity,
                    role,
                    position: None,
                    velocity: None,
                    derivative_aliases: vec![],
                }
            })
            .collect();
        for i in 0..out.len() {
            let prefix = out[i].name.rsplit_once('.').map(|p| p.0.to_owned());
            if out[i].quantity == Quantity::Other || out[i].role == Role::Velocity {
                continue;
            }
            if let Some(j) = (0..out.len()).find(|&j| {
                out[j].role == Role::Velocity
                    && out[j].quantity == out[i].quantity
                    && out[j].name.rsplit_once('.').map(|p| p.0.to_owned()) == prefix
            }) {
                out[i].role = Role::Position;
                out[i].velocity = Some(out[j].name.clone());
                out[j].position = Some(out[i].name.clone());
            }
        }
        Structure { states: out, ports: vec![] }
    }

    pub fn state(&self, name: &str) -> Option<&State> {
        self.states.iter().find(|s| s.name == name)
    }
}
