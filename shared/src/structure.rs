//! A model's physical structure as its description states it: which continuous
//! states are positions, velocities or temperatures, which velocity is the derivative of
//! which position, which other variables *are* a state's derivative (an acceleration output
//! such as Dymola's `mass.a`), and which continuous Real inputs are injection ports (a force,
//! torque or heat flow the diagnosis may add an effect to), each paired with the states an
//! effect on it would be driven by. This module owns those rules, and [`port_domain`], the one
//! test of whether an input's unit makes it a mechanical or thermal port.
//!
//! It reads the [`ModelDescription`] only (FMI 1.0, 2.0 and 3.0 alike: FMI 1.0's states are
//! those the reader infers from `der(x)` names) and never fails: what the description does not
//! say is left [`Quantity::Other`] / [`Role::Other`] or unpaired.
//!
//! A position `x` and a velocity `v` (both states) are paired by the first rule that holds:
//!
//! 1. `der(x)` *is* `v`: the same variable after aliases (same type and value reference in
//!    FMI 2.0, `alias_of` in FMI 1.0 and 3.0), or a variable sharing `v`'s value carries a
//!    `derivative` attribute naming `x` (or an alias of `x`) — [`Pairing::Alias`];
//! 2. `der(x)`'s only dependency in `ModelStructure/Derivatives` is `v`, and their units (where
//!    both are known) are not at odds — [`Pairing::Dependency`];
//! 3. `x` and `v` (or aliases of them) share a component prefix (the text before the last
//!    `.`), `v`'s unit is `x`'s unit per second (`m` → `m/s`, `rad` → `rad/s`, or by SI base
//!    units), and no other state of that prefix qualifies — [`Pairing::PrefixAndUnit`].
//!
//! A state's [`Quantity`] comes from its unit (own or declared type's; by name, else by SI base
//! units), or without a unit from its declared type's `quantity`; a paired state of unknown
//! quantity takes its partner's. Its [`Role`]: a position has a velocity, a velocity a position
//! (or, unpaired, a unit in m/s or rad/s), a temperature is in K; anything else is
//! [`Role::Other`].
//!
//! An injection [`Port`] is a continuous Real input (no alias, not fed from data) whose unit
//! [`port_domain`] calls mechanical or thermal. A mechanical port pairs with the velocity and
//! position states (of its quantity: a force with translational ones, a torque with rotational
//! ones, where the model has any), a thermal one with the temperatures; of those, the ones in
//! the port's component (`pendulumJoint.tauExt` with `pendulumJoint.w` and `pendulumJoint.phi`),
//! or all of them when none is.

use serde::Serialize;

use crate::effects::Domain;
use crate::fmu::schema::{BaseUnit, Causality, ModelDescription, ScalarVariable, VarType, Variability};

/// What a state measures, from its unit (or its declared type's `quantity`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Quantity {
    /// Metres or metres per second.
    Translational,
    /// Radians or radians per second.
    Rotational,
    /// Kelvin (or degrees Celsius).
    Thermal,
    Other,
}

/// A state's part in the physics.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Role {
    /// Its derivative is another state (its velocity).
    Position,
    /// The derivative of another state, or unpaired in m/s or rad/s.
    Velocity,
    /// A state in K (or °C).
    Temperature,
    Other,
}

/// Which rule paired a position with its velocity (see the module documentation).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Pairing {
    /// `der(x)` is the velocity state itself (shared value, or a `derivative` attribute).
    Alias,
    /// `der(x)` depends on the velocity state only.
    Dependency,
    /// Same component prefix, and the velocity's unit is the position's per second.
    PrefixAndUnit,
}

impl Pairing {
    fn text(self) -> &'static str {
        match self {
            Pairing::Alias => "alias",
            Pairing::Dependency => "dependency",
            Pairing::PrefixAndUnit => "prefix and unit",
        }
    }
}

/// One continuous state.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct State {
    /// The state variable: the variable the derivative names (what the exporting tool calls
    /// the state), or its base where that variable is itself a `der(…)`. Other variables that
    /// share its value are in `aliases`.
    pub name: String,
    /// Position in the state vector (the order of [`ModelDescription::states`]).
    pub index: usize,
    /// Its derivative variable, as `ModelStructure/Derivatives` lists it.
    pub derivative: String,
    pub unit: Option<String>,
    pub quantity: Quantity,
    pub role: Role,
    /// For a velocity: the position state whose derivative it is.
    pub position: Option<String>,
    /// For a position: the velocity state that is its derivative.
    pub velocity: Option<String>,
    /// The rule that paired it with its position or velocity.
    pub paired_by: Option<Pairing>,
    /// Every other variable that is the derivative (sharing its value: Dymola's `mass.a`, or
    /// the velocity state itself), outputs first, then in the description's order. Negated
    /// aliases are left out.
    pub derivative_aliases: Vec<String>,
    /// The other names of the state variable itself (its aliases, not negated).
    pub aliases: Vec<String>,
    /// For a velocity: the other velocity states it is coupled with, each derivative depending
    /// on the other velocity (`ModelStructure/Derivatives`; none where a list is not given). A
    /// force or torque on its joint reaches theirs through the mass matrix.
    pub coupled: Vec<String>,
}

/// A continuous Real input whose unit makes it an injection port.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Port {
    pub name: String,
    pub unit: String,
    #[serde(serialize_with = "serialize_domain")]
    pub domain: Domain,
    /// Translational (a force), Rotational (a torque), Thermal (a heat flow), or Other for a
    /// mechanical port whose unit says neither.
    pub quantity: Quantity,
    /// The velocity states an effect on this port would be driven by (mechanical ports).
    pub velocities: Vec<String>,
    /// The position states (mechanical ports).
    pub positions: Vec<String>,
    /// The temperature states (thermal ports).
    pub temperatures: Vec<String>,
    /// Whether the states were chosen by the port's component prefix; false when none shares
    /// it and the port is paired with all states of its kind.
    pub by_prefix: bool,
}

fn serialize_domain<S: serde::Serializer>(d: &Domain, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(&d.to_string())
}

/// A model's states and injection ports.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Structure {
    pub states: Vec<State>,
    pub ports: Vec<Port>,
}

/// Whether a variable's unit makes it a mechanical (force, torque) or thermal (heat flow) port,
/// with the unit: by its SI base units where the description defines them (kg·m·s⁻² or
/// kg·m²·s⁻² mechanical, kg·m²·s⁻³ thermal), else by name (`N`, `N.m`; `W`, `J/s`). `None` for a
/// variable without a unit or with any other.
pub fn port_domain(md: &ModelDescription, v: &ScalarVariable) -> Option<(String, Domain)> {
    let unit = md.unit_of(v)?.to_owned();
    let by_base = base_unit(md, &unit).and_then(|b| {
        let other = b.a != 0 || b.k != 0 || b.mol != 0 || b.cd != 0 || b.rad != 0 || b.kg != 1;
        match (other, b.m, b.s) {
            (false, 1 | 2, -2) => Some(Domain::Mechanical),
            (false, 2, -3) => Some(Domain::Thermal),
            _ => None,
        }
    });
    let by_name = match normalise(&unit).as_str() {
        "N" | "N.m" | "Nm" | "m.N" => Some(Domain::Mechanical),
        "W" | "kW" | "J/s" => Some(Domain::Thermal),
        _ => None,
    };
    by_base.or(by_name).map(|d| (unit, d))
}

/// A unit name with the multiplication signs tools write made `.`.
fn normalise(unit: &str) -> String {
    unit.replace(['·', '*', ' '], ".")
}

fn base_unit<'a>(md: &'a ModelDescription, unit: &str) -> Option<&'a BaseUnit> {
    md.unit_definitions.iter().find(|u| u.name == unit).and_then(|u| u.base_unit.as_ref())
}

/// What a unit is the unit of: a position or a velocity of a quantity, or a temperature.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Order {
    Position,
    Velocity,
    Temperature,
}

/// The quantity and order a unit name stands for, by name, then by its SI base units.
fn classify_unit(md: &ModelDescription, unit: &str) -> Option<(Quantity, Order)> {
    use Order::*;
    use Quantity::*;
    let by_name = match normalise(unit).as_str() {
        "m" | "mm" | "cm" | "km" => Some((Translational, Position)),
        "m/s" | "mm/s" | "cm/s" | "km/h" | "m.s-1" => Some((Translational, Velocity)),
        "rad" | "deg" => Some((Rotational, Position)),
        "rad/s" | "deg/s" | "rpm" | "rev/min" | "rad.s-1" => Some((Rotational, Velocity)),
        "K" | "degC" | "°C" | "degF" | "°F" | "Cel" => Some((Thermal, Temperature)),
        _ => None,
    };
    by_name.or_else(|| {
        let b = base_unit(md, unit)?;
        if b.kg != 0 || b.a != 0 || b.mol != 0 || b.cd != 0 {
            return None;
        }
        match (b.m, b.rad, b.k, b.s) {
            (1, 0, 0, 0) => Some((Translational, Position)),
            (1, 0, 0, -1) => Some((Translational, Velocity)),
            (0, 1, 0, 0) => Some((Rotational, Position)),
            (0, 1, 0, -1) => Some((Rotational, Velocity)),
            (0, 0, 1, 0) => Some((Thermal, Temperature)),
            _ => None,
        }
    })
}

/// The quantity and order a declared type's `quantity` names (Modelica's SIunits names).
fn classify_quantity(quantity: &str) -> Option<(Quantity, Order)> {
    use Order::*;
    use Quantity::*;
    match quantity {
        "Length" | "Position" | "Distance" | "Height" | "Displacement" => Some((Translational, Position)),
        "Velocity" | "Speed" => Some((Translational, Velocity)),
        "Angle" | "Angle_deg" => Some((Rotational, Position)),
        "AngularVelocity" | "AngularVelocity_rpm" => Some((Rotational, Velocity)),
        "ThermodynamicTemperature" | "Temperature" | "CelsiusTemperature" => Some((Thermal, Temperature)),
        _ => None,
    }
}

/// A variable's quantity and order: from its unit (own or declared type's), or where it has
/// none, from its declared type's `quantity`.
fn classify(md: &ModelDescription, v: &ScalarVariable) -> Option<(Quantity, Order)> {
    match md.unit_of(v) {
        Some(unit) if !unit.is_empty() => classify_unit(md, unit),
        _ => {
            let t = v.declared_type.as_ref()?;
            let q = md.type_definitions.iter().find(|d| &d.name == t)?.quantity.as_deref()?;
            classify_quantity(q)
        }
    }
}

/// Whether unit `v` is unit `x` per second: `Some(true)` by name (`x/s`) or by SI base units
/// (the same factor, one more s⁻¹), `Some(false)` when both are known and neither holds,
/// `None` when either is missing.
fn per_second(md: &ModelDescription, x: Option<&str>, v: Option<&str>) -> Option<bool> {
    let (x, v) = (x.filter(|u| !u.is_empty())?, v.filter(|u| !u.is_empty())?);
    if normalise(v) == format!("{}/s", normalise(x)) {
        return Some(true);
    }
    if let (Some(bx), Some(bv)) = (base_unit(md, x), base_unit(md, v)) {
        let same = bx.kg == bv.kg
            && bx.m == bv.m
            && bx.s - 1 == bv.s
            && bx.a == bv.a
            && bx.k == bv.k
            && bx.mol == bv.mol
            && bx.cd == bv.cd
            && bx.rad == bv.rad
            && bx.offset == 0.0
            && bv.offset == 0.0
            && (bx.factor - bv.factor).abs() <= 1e-12 * bx.factor.abs().max(bv.factor.abs());
        if same {
            return Some(true);
        }
    }
    // The same quantity, one a position and the other a velocity (`deg` and `rpm`).
    match (classify_unit(md, x), classify_unit(md, v)) {
        (Some((qx, Order::Position)), Some((qv, Order::Velocity))) if qx == qv && qx != Quantity::Other => Some(true),
        _ => Some(false),
    }
}

/// The component prefix of a name: the text before its last `.` outside brackets, `""` for a
/// top-level name. `der(a.b)` is taken as `a.b`.
fn prefix(name: &str) -> &str {
    let name = name.strip_prefix("der(").and_then(|n| n.strip_suffix(')')).unwrap_or(name);
    let mut depth = 0i32;
    let mut last = None;
    for (k, c) in name.char_indices() {
        match c {
            '[' | '(' => depth += 1,
            ']' | ')' => depth -= 1,
            '.' if depth == 0 => last = Some(k),
            _ => {}
        }
    }
    last.map_or("", |k| &name[..k])
}

/// Whether `name` lies in component `prefix` (at any depth below it).
fn in_component(name: &str, prefix: &str) -> bool {
    name.strip_prefix(prefix).is_some_and(|rest| rest.starts_with('.'))
}

/// The variable whose value `v` shares (its base), `None` if `v` is a negated alias.
fn identity<'a>(md: &'a ModelDescription, v: &'a ScalarVariable) -> Option<&'a str> {
    (!v.negated).then(|| md.base_of(v).name.as_str())
}

/// The unit of der(`state`): the derivative's own, else the state's per second (what a state
/// effect's strength is measured in).
pub fn derivative_unit(md: &ModelDescription, state: &str) -> Option<String> {
    md.states()
        .into_iter()
        .find(|(s, _)| s.name == state)
        .and_then(|(s, d)| md.unit_of(d).map(str::to_owned).or_else(|| md.unit_of(s).map(|u| format!("{u}/s"))))
}

fn position_of(md: &ModelDescription, v: &ScalarVariable) -> Option<usize> {
    md.variables.iter().position(|w| std::ptr::eq(w, v))
}

impl Structure {
    /// Reads the states and injection ports of `md`. `mapped_inputs` are the inputs the job
    /// feeds from data: they are no injection ports.
    pub fn read(md: &ModelDescription, mapped_inputs: &[String]) -> Structure {
        let raw = md.states();
        // The state variables: the variable the derivative names (what the exporting tool
        // calls the state: `rightVolume.T`, not the output `outlet.T` that shares its value),
        // else its base when that one is a `der(…)`; with their identity.
        let vars: Vec<&ScalarVariable> =
            raw.iter().map(|(s, _)| if s.name.starts_with("der(") { md.base_of(s) } else { *s }).collect();
        let ids: Vec<&str> = raw.iter().map(|(s, _)| md.base_of(s).name.as_str()).collect();
        let state_of = |id: &str| ids.iter().position(|s| *s == id);
        let n = raw.len();
        let units: Vec<Option<&str>> = vars.iter().map(|v| md.unit_of(v)).collect();
        // The component prefixes of each state's names (its own and its aliases', not `der(…)`).
        let prefixes: Vec<Vec<&str>> = (0..n)
            .map(|k| {
                let mut p: Vec<&str> = md
                    .variables
                    .iter()
                    .filter(|w| {
                        (std::ptr::eq(*w, vars[k]) || identity(md, w) == Some(ids[k])) && !w.name.starts_with("der(")
                    })
                    .map(|w| prefix(&w.name))
                    .collect();
                p.dedup();
                p
            })
            .collect();

        let mut velocity: Vec<Option<(usize, Pairing)>> = vec![None; n];
        let mut position: Vec<Option<usize>> = vec![None; n];
        // Pairs position x with velocity v unless either is paired already.
        let pair = |x: usize,
                    v: usize,
                    how: Pairing,
                    velocity: &mut [Option<(usize, Pairing)>],
                    position: &mut [Option<usize>]| {
            if x != v && velocity[x].is_none() && position[v].is_none() {
                velocity[x] = Some((v, how));
                position[v] = Some(x);
            }
        };

        // 1. der(x) is v: the derivative variable shares v's value, or a variable sharing v's
        //    value carries a `derivative` attribute naming x (or an alias of x).
        for (x, (_, der)) in raw.iter().enumerate() {
            if let Some(v) = identity(md, der).and_then(state_of) {
                pair(x, v, Pairing::Alias, &mut velocity, &mut position);
            }
        }
        for w in &md.variables {
            let Some(target) = w.derivative.and_then(|j| md.variables.get(j - 1)) else { continue };
            let x = state_of(md.base_of(target).name.as_str());
            let v = identity(md, w).and_then(state_of);
            if let (Some(x), Some(v)) = (x, v) {
                pair(x, v, Pairing::Alias, &mut velocity, &mut position);
            }
        }
        // 2. der(x)'s only dependency is v.
        for (x, (_, der)) in raw.iter().enumerate() {
            let k = position_of(md, der);
            let Some(u) = md.model_structure.derivatives.iter().find(|u| Some(u.index - 1) == k) else { continue };
            let Some([d]) = u.dependencies.as_deref() else { continue };
            let Some(v) = md.variables.get(d.wrapping_sub(1)).and_then(|dep| identity(md, dep)).and_then(state_of)
            else {
                continue;
            };
            if per_second(md, units[x], units[v]) != Some(false) {
                pair(x, v, Pairing::Dependency, &mut velocity, &mut position);
            }
        }
        // 3. Same component prefix and v's unit is x's per second, the only such state.
        for x in 0..n {
            if velocity[x].is_some() {
                continue;
            }
            let candidates: Vec<usize> = (0..n)
                .filter(|&v| {
                    v != x
                        && position[v].is_none()
                        && prefixes[v].iter().any(|p| prefixes[x].contains(p))
                        && per_second(md, units[x], units[v]) == Some(true)
                })
                .collect();
            if let [v] = candidates[..] {
                pair(x, v, Pairing::PrefixAndUnit, &mut velocity, &mut position);
            }
        }

        let classes: Vec<Option<(Quantity, Order)>> = vars.iter().map(|v| classify(md, v)).collect();
        let mut states: Vec<State> = (0..n)
            .map(|k| {
                let der = raw[k].1;
                let der_id = identity(md, der);
                let mut derivative_aliases: Vec<&ScalarVariable> = md
                    .variables
                    .iter()
                    .filter(|w| !std::ptr::eq(*w, der) && der_id.is_some() && identity(md, w) == der_id)
                    .collect();
                derivative_aliases.sort_by_key(|w| w.causality != Causality::Output);
                let aliases = md
                    .variables
                    .iter()
                    .filter(|w| w.name != vars[k].name && identity(md, w) == Some(ids[k]))
                    .map(|w| w.name.clone())
                    .collect();
                let quantity = classes[k].map_or(Quantity::Other, |(q, _)| q);
                let paired_by = velocity[k]
                    .map(|(_, how)| how)
                    .or_else(|| position[k].and_then(|x| velocity[x].map(|(_, how)| how)));
                State {
                    name: vars[k].name.clone(),
                    index: k,
                    derivative: der.name.clone(),
                    unit: units[k].map(str::to_owned),
                    quantity,
                    role: Role::Other,
                    position: position[k].map(|x| vars[x].name.clone()),
                    velocity: velocity[k].map(|(v, _)| vars[v].name.clone()),
                    paired_by,
                    derivative_aliases: derivative_aliases.into_iter().map(|w| w.name.clone()).collect(),
                    aliases,
                    coupled: vec![],
                }
            })
            .collect();
        // A paired state of unknown quantity takes its partner's.
        for k in 0..n {
            if states[k].quantity == Quantity::Other {
                let partner = position[k].or(velocity[k].map(|(v, _)| v));
                if let Some(p) = partner {
                    states[k].quantity = classes[p].map_or(Quantity::Other, |(q, _)| q);
                }
            }
        }
        for k in 0..n {
            states[k].role = if position[k].is_some() {
                Role::Velocity
            } else if velocity[k].is_some() {
                Role::Position
            } else {
                match classes[k] {
                    Some((Quantity::Translational | Quantity::Rotational, Order::Velocity)) => Role::Velocity,
                    Some((Quantity::Thermal, Order::Temperature)) => Role::Temperature,
                    _ => Role::Other,
                }
            };
        }

        // Velocities coupled both ways: der(u) depends on v, and der(v) on u.
        let depends: Vec<Vec<usize>> = raw
            .iter()
            .map(|(_, der)| {
                let k = position_of(md, der);
                let u = md.model_structure.derivatives.iter().find(|u| Some(u.index - 1) == k);
                u.and_then(|u| u.dependencies.as_deref())
                    .unwrap_or_default()
                    .iter()
                    .filter_map(|d| md.variables.get(d.wrapping_sub(1)).and_then(|dep| identity(md, dep)))
                    .filter_map(state_of)
                    .collect()
            })
            .collect();
        for v in 0..n {
            if states[v].role != Role::Velocity {
                continue;
            }
            states[v].coupled = (0..n)
                .filter(|&u| {
                    u != v && states[u].role == Role::Velocity && depends[u].contains(&v) && depends[v].contains(&u)
                })
                .map(|u| vars[u].name.clone())
                .collect();
        }

        let mapped = |v: &ScalarVariable| {
            mapped_inputs.iter().any(|m| m == &v.name || md.variable(m).is_some_and(|w| md.base_of(w).name == v.name))
        };
        let ports = md
            .variables
            .iter()
            .filter(|v| {
                v.causality == Causality::Input
                    && v.var_type == VarType::Real
                    && v.variability == Variability::Continuous
                    && v.alias_of.is_none()
                    && !mapped(v)
            })
            .filter_map(|v| {
                let (unit, domain) = port_domain(md, v)?;
                Some(port(md, &states, v, unit, domain))
            })
            .collect();
        Structure { states, ports }
    }

    /// The state called `name`, or one of whose aliases is called `name`.
    pub fn state(&self, name: &str) -> Option<&State> {
        self.states
            .iter()
            .find(|s| s.name == name)
            .or_else(|| self.states.iter().find(|s| s.aliases.iter().any(|a| a == name)))
    }

    /// The injection port called `name`.
    pub fn port(&self, name: &str) -> Option<&Port> {
        self.ports.iter().find(|p| p.name == name)
    }
}

/// The port `v` with the states an effect on it would be driven by: those of its component
/// prefix, else all (of the port's quantity, where any state has it).
fn port(md: &ModelDescription, states: &[State], v: &ScalarVariable, unit: String, domain: Domain) -> Port {
    let quantity = match domain {
        Domain::Thermal => Quantity::Thermal,
        _ => {
            let by_base = base_unit(md, &unit).map(|b| b.m);
            match (normalise(&unit).as_str(), by_base) {
                ("N", _) | (_, Some(1)) => Quantity::Translational,
                ("N.m" | "Nm" | "m.N", _) | (_, Some(2)) => Quantity::Rotational,
                _ => Quantity::Other,
            }
        }
    };
    let roles: &[Role] = match domain {
        Domain::Thermal => &[Role::Temperature],
        _ => &[Role::Velocity, Role::Position],
    };
    let mut kind: Vec<&State> = states.iter().filter(|s| roles.contains(&s.role)).collect();
    if domain != Domain::Thermal && kind.iter().any(|s| s.quantity == quantity) {
        kind.retain(|s| s.quantity == quantity);
    }
    let own = prefix(&v.name);
    let near: Vec<&State> = if own.is_empty() {
        vec![]
    } else {
        kind.iter()
            .copied()
            .filter(|s| in_component(&s.name, own) || s.aliases.iter().any(|a| in_component(a, own)))
            .collect()
    };
    let by_prefix = !near.is_empty();
    let chosen = if by_prefix { near } else { kind };
    let names = |role: Role| chosen.iter().filter(|s| s.role == role).map(|s| s.name.clone()).collect();
    Port {
        name: v.name.clone(),
        unit,
        domain,
        quantity,
        velocities: names(Role::Velocity),
        positions: names(Role::Position),
        temperatures: names(Role::Temperature),
        by_prefix,
    }
}

impl Structure {
    /// The structure as text, in `fmucal inspect`'s style: one line per state (quantity, role,
    /// pair, derivative aliases), then one per injection port with its paired states.
    pub fn render(&self) -> String {
        let mut s = String::new();
        s.push_str(&format!("\nStructure ({} states, {} injection ports)\n", self.states.len(), self.ports.len()));
        if !self.states.is_empty() {
            s.push_str(&format!(
                "  {:<28} {:<13} {:<11} {:<44} {}\n",
                "state", "quantity", "role", "pair", "derivative aliases"
            ));
            for st in &self.states {
                let how = st.paired_by.map(|h| format!(" ({})", h.text())).unwrap_or_default();
                let mut pair = match (&st.velocity, &st.position) {
                    (Some(v), _) => format!("velocity {v}{how}"),
                    (None, Some(p)) => format!("position {p}{how}"),
                    (None, None) => "-".to_owned(),
                };
                if !st.coupled.is_empty() {
                    pair.push_str(&format!("; coupled with {}", st.coupled.join(", ")));
                }
                let aliases =
                    if st.derivative_aliases.is_empty() { "-".to_owned() } else { st.derivative_aliases.join(", ") };
                s.push_str(&format!(
                    "  {:<28} {:<13} {:<11} {:<44} {}\n",
                    st.name,
                    lower(st.quantity),
                    lower(st.role),
                    pair,
                    aliases
                ));
            }
        }
        if !self.ports.is_empty() {
            if !self.states.is_empty() {
                s.push('\n');
            }
            s.push_str(&format!("  {:<28} {:<13} {:<11} {}\n", "injection port", "unit", "domain", "paired states"));
            for p in &self.ports {
                let mut paired: Vec<String> = vec![];
                paired.extend(p.velocities.iter().map(|n| format!("{n} (velocity)")));
                paired.extend(p.positions.iter().map(|n| format!("{n} (position)")));
                paired.extend(p.temperatures.iter().map(|n| format!("{n} (temperature)")));
                let mut text = if paired.is_empty() { "-".to_owned() } else { paired.join(", ") };
                if !p.by_prefix && !paired.is_empty() {
                    text.push_str(" [no state shares its prefix: all]");
                }
                s.push_str(&format!("  {:<28} {:<13} {:<11} {}\n", p.name, p.unit, p.domain.to_string(), text));
            }
        }
        s
    }
}

/// The serde (lowercase) name of a unit enum variant.
fn lower<T: Serialize>(v: T) -> String {
    serde_json::to_value(v).ok().and_then(|v| v.as_str().map(str::to_owned)).unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An FMI 2.0 description with these units, variables and derivatives (`Unknown`s).
    fn md(units: &str, variables: &str, derivatives: &str) -> ModelDescription {
        let xml = format!(
            r#"<?xml version="1.0"?>
<fmiModelDescription fmiVersion="2.0" modelName="M" guid="{{g}}" generationTool="t">
  <ModelExchange modelIdentifier="M"/>
  <UnitDefinitions>{units}</UnitDefinitions>
  <TypeDefinitions>
    <SimpleType name="Length"><Real quantity="Length"/></SimpleType>
    <SimpleType name="Temp"><Real quantity="ThermodynamicTemperature"/></SimpleType>
  </TypeDefinitions>
  <ModelVariables>{variables}</ModelVariables>
  <ModelStructure><Derivatives>{derivatives}</Derivatives></ModelStructure>
</fmiModelDescription>"#
        );
        ModelDescription::parse(&xml).unwrap_or_else(|e| panic!("{e}\n{xml}"))
    }

    fn real(name: &str, vr: u32, causality: &str, attrs: &str) -> String {
        let input_start = if causality == "input" { r#" start="0""# } else { "" };
        format!(
            r#"<ScalarVariable name="{name}" valueReference="{vr}" causality="{causality}" variability="continuous"><Real {attrs}{input_start}/></ScalarVariable>"#
        )
    }

    /// Dymola's spring–mass: `der(mass.s)` shares `mass.v`'s value reference, `mass.a` (an
    /// output) shares `der(mass.v)`'s, and the force input `mass.f` is an injection port.
    fn dymola() -> ModelDescription {
        let vars = [
            real("mass.s", 0, "local", r#"unit="m""#),
            real("der(mass.s)", 1, "local", r#"unit="m/s" derivative="1""#),
            real("mass.v", 1, "local", r#"unit="m/s""#),
            real("der(mass.v)", 2, "local", r#"unit="m/s2" derivative="3""#),
            real("mass.a", 2, "output", r#"unit="m/s2""#),
            real("mass.f", 3, "input", r#"unit="N""#),
            real("F", 4, "input", r#"unit="N""#),
        ]
        .concat();
        md(
            r#"<Unit name="m"><BaseUnit m="1"/></Unit><Unit name="N"><BaseUnit kg="1" m="1" s="-2"/></Unit>"#,
            &vars,
            r#"<Unknown index="2"/><Unknown index="4"/>"#,
        )
    }

    #[test]
    fn dymola_spring_mass_pairs_through_shared_value_references() {
        let md = dymola();
        let s = Structure::read(&md, &[]);
        assert_eq!(s.states.len(), 2, "{s:#?}");
        let x = s.state("mass.s").unwrap();
        assert_eq!((x.index, x.quantity, x.role), (0, Quantity::Translational, Role::Position));
        assert_eq!(x.velocity.as_deref(), Some("mass.v"));
        assert_eq!(x.paired_by, Some(Pairing::Alias));
        assert_eq!(x.derivative, "der(mass.s)");
        let v = s.state("mass.v").unwrap();
        assert_eq!((v.index, v.quantity, v.role), (1, Quantity::Translational, Role::Velocity));
        assert_eq!(v.position.as_deref(), Some("mass.s"));
        assert_eq!(v.derivative, "der(mass.v)");
        assert_eq!(v.derivative_aliases, vec!["mass.a".to_owned()]);
        assert_eq!(x.derivative_aliases, vec!["mass.v".to_owned()]);
        // The force on the mass pairs with its own component; F, of no component, with all.
        let f = s.port("mass.f").unwrap();
        assert_eq!((f.domain, f.quantity, f.by_prefix), (Domain::Mechanical, Quantity::Translational, true));
        assert_eq!((f.velocities.clone(), f.positions.clone()), (vec!["mass.v".into()], vec!["mass.s".into()]));
        assert!(!s.port("F").unwrap().by_prefix);
        assert_eq!(s.port("F").unwrap().velocities, vec!["mass.v".to_owned()]);
    }

    #[test]
    fn a_mapped_input_is_no_port() {
        let s = Structure::read(&dymola(), &["F".to_owned()]);
        assert_eq!(s.ports.iter().map(|p| p.name.as_str()).collect::<Vec<_>>(), vec!["mass.f"]);
    }

    #[test]
    fn an_only_dependency_pairs_states_of_unrelated_names_without_units() {
        let vars = [
            real("p", 0, "local", ""),
            real("der(p)", 1, "local", r#"derivative="1""#),
            real("q", 2, "local", ""),
            real("der(q)", 3, "local", r#"derivative="3""#),
        ]
        .concat();
        let md = md("", &vars, r#"<Unknown index="2" dependencies="3"/><Unknown index="4" dependencies="1 3"/>"#);
        let s = Structure::read(&md, &[]);
        let p = s.state("p").unwrap();
        assert_eq!(
            (p.role, p.velocity.as_deref(), p.paired_by),
            (Role::Position, Some("q"), Some(Pairing::Dependency))
        );
        assert_eq!(s.state("q").unwrap().role, Role::Velocity);
        assert_eq!(p.quantity, Quantity::Other);
    }

    #[test]
    fn an_only_dependency_with_units_at_odds_pairs_nothing() {
        // Two temperatures, one driving the other: no position and velocity.
        let vars = [
            real("a.T", 0, "local", r#"unit="K""#),
            real("der(a.T)", 1, "local", r#"unit="K/s" derivative="1""#),
            real("b.T", 2, "local", r#"unit="K""#),
            real("der(b.T)", 3, "local", r#"unit="K/s" derivative="3""#),
            real("b.Q", 4, "input", r#"unit="W""#),
        ]
        .concat();
        let md = md("", &vars, r#"<Unknown index="2" dependencies="3"/><Unknown index="4" dependencies="1 3 5"/>"#);
        let s = Structure::read(&md, &[]);
        for st in &s.states {
            assert_eq!((st.quantity, st.role, st.velocity.as_ref()), (Quantity::Thermal, Role::Temperature, None));
        }
        let q = s.port("b.Q").unwrap();
        assert_eq!((q.domain, q.quantity, q.by_prefix), (Domain::Thermal, Quantity::Thermal, true));
        assert_eq!(q.temperatures, vec!["b.T".to_owned()]);
        assert!(q.velocities.is_empty() && q.positions.is_empty());
    }

    #[test]
    fn prefix_and_unit_pair_joint_angles_and_ports_follow_their_joint() {
        // The Furuta pendulum's shape: nothing but names and units relate phi and w.
        let vars = [
            real("arm.phi", 0, "local", r#"unit="rad""#),
            real("arm.w", 1, "local", r#"unit="rad/s""#),
            real("pend.phi", 2, "local", r#"unit="rad""#),
            real("pend.w", 3, "local", r#"unit="rad/s""#),
            real("der(arm.phi)", 4, "local", r#"unit="rad/s" derivative="1""#),
            real("der(arm.w)", 5, "local", r#"unit="rad/s2" derivative="2""#),
            real("der(pend.phi)", 6, "local", r#"unit="rad/s" derivative="3""#),
            real("der(pend.w)", 7, "local", r#"unit="rad/s2" derivative="4""#),
            real("arm.tau", 8, "input", r#"unit="N.m""#),
            real("pend.tau", 9, "input", r#"unit="N.m""#),
            real("u", 10, "input", r#"unit="N.m""#),
            real("heater", 11, "input", r#"unit="W""#),
        ]
        .concat();
        let units = r#"<Unit name="rad"/><Unit name="rad/s"><BaseUnit s="-1"/></Unit><Unit name="N.m"><BaseUnit kg="1" m="2" s="-2"/></Unit>"#;
        let derivatives = r#"<Unknown index="5"/><Unknown index="6"/><Unknown index="7"/><Unknown index="8"/>"#;
        let md = md(units, &vars, derivatives);
        let s = Structure::read(&md, &[]);
        for j in ["arm", "pend"] {
            let phi = s.state(&format!("{j}.phi")).unwrap();
            assert_eq!(phi.velocity.as_deref(), Some(format!("{j}.w").as_str()), "{s:#?}");
            assert_eq!(
                (phi.quantity, phi.role, phi.paired_by),
                (Quantity::Rotational, Role::Position, Some(Pairing::PrefixAndUnit))
            );
            let w = s.state(&format!("{j}.w")).unwrap();
            assert_eq!((w.quantity, w.role), (Quantity::Rotational, Role::Velocity));
            let port = s.port(&format!("{j}.tau")).unwrap();
            assert_eq!((port.quantity, port.by_prefix), (Quantity::Rotational, true));
            assert_eq!(port.velocities, vec![format!("{j}.w")]);
            assert_eq!(port.positions, vec![format!("{j}.phi")]);
        }
        let u = s.port("u").unwrap();
        assert!(!u.by_prefix);
        assert_eq!(u.velocities, vec!["arm.w".to_owned(), "pend.w".to_owned()]);
        assert_eq!(u.positions, vec!["arm.phi".to_owned(), "pend.phi".to_owned()]);
        // A heat flow into a model without temperatures is a port with no states to pair.
        let heater = s.port("heater").unwrap();
        assert_eq!((heater.domain, heater.temperatures.len()), (Domain::Thermal, 0));
    }

    #[test]
    fn prefix_without_unit_or_unit_without_prefix_pairs_nothing() {
        let vars = [
            real("a.x", 0, "local", r#"unit="m""#),
            real("der(a.x)", 1, "local", r#"unit="m/s" derivative="1""#),
            real("b.v", 2, "local", r#"unit="m/s""#),
            real("der(b.v)", 3, "local", r#"unit="m/s2" derivative="3""#),
            real("a.c", 4, "local", r#"unit="mol/l""#),
            real("der(a.c)", 5, "local", r#"unit="mol/(l.s)" derivative="5""#),
        ]
        .concat();
        let md = md("", &vars, r#"<Unknown index="2"/><Unknown index="4"/><Unknown index="6"/>"#);
        let s = Structure::read(&md, &[]);
        let x = s.state("a.x").unwrap();
        assert_eq!((x.quantity, x.role, x.velocity.as_ref()), (Quantity::Translational, Role::Other, None));
        // Unpaired, but its unit says it is a velocity.
        let v = s.state("b.v").unwrap();
        assert_eq!((v.quantity, v.role, v.position.as_ref()), (Quantity::Translational, Role::Velocity, None));
        let c = s.state("a.c").unwrap();
        assert_eq!((c.quantity, c.role, c.unit.as_deref()), (Quantity::Other, Role::Other, Some("mol/l")));
    }

    #[test]
    fn declared_quantity_stands_in_for_a_missing_unit_and_si_base_units_for_names() {
        let vars = [
            r#"<ScalarVariable name="h" valueReference="0" causality="local" variability="continuous"><Real declaredType="Length"/></ScalarVariable>"#.to_owned(),
            real("der(h)", 1, "local", r#"derivative="1""#),
            r#"<ScalarVariable name="T" valueReference="2" causality="local" variability="continuous"><Real declaredType="Temp"/></ScalarVariable>"#.to_owned(),
            real("der(T)", 3, "local", r#"derivative="3""#),
            real("s", 4, "local", r#"unit="mm""#),
            real("der(s)", 5, "local", r#"unit="mm/s" derivative="5""#),
            real("vs", 6, "local", r#"unit="mm/s""#),
            real("der(vs)", 7, "local", r#"derivative="7""#),
            real("y", 8, "local", r#"unit="myLength""#),
            real("der(y)", 9, "local", r#"derivative="9""#),
            real("f", 10, "input", r#"unit="kN""#),
        ]
        .concat();
        let units = r#"<Unit name="mm"><BaseUnit m="1" factor="0.001"/></Unit><Unit name="mm/s"><BaseUnit m="1" s="-1" factor="0.001"/></Unit><Unit name="myLength"><BaseUnit m="1"/></Unit><Unit name="kN"><BaseUnit kg="1" m="1" s="-2" factor="1000"/></Unit>"#;
        let md = md(
            units,
            &vars,
            r#"<Unknown index="2"/><Unknown index="4"/><Unknown index="6"/><Unknown index="8"/><Unknown index="10"/>"#,
        );
        let s = Structure::read(&md, &[]);
        assert_eq!(s.state("h").unwrap().quantity, Quantity::Translational);
        let t = s.state("T").unwrap();
        assert_eq!((t.quantity, t.role), (Quantity::Thermal, Role::Temperature));
        // s and vs: no component prefix, mm → mm/s.
        assert_eq!(s.state("s").unwrap().velocity.as_deref(), Some("vs"));
        assert_eq!(s.state("y").unwrap().quantity, Quantity::Translational);
        let f = s.port("f").unwrap();
        assert_eq!((f.domain, f.quantity), (Domain::Mechanical, Quantity::Translational));
        assert_eq!(f.velocities, vec!["vs".to_owned()]);
        assert_eq!(f.positions, vec!["s".to_owned()]);
    }

    #[test]
    fn a_derivative_attribute_on_an_alias_of_the_velocity_pairs_it() {
        // The DerivativeAttributes fixture's shape: der(h) is a variable of its own, but
        // `ball.v`, sharing v's value, says it is the derivative of h.
        let vars = [
            real("h", 0, "output", r#"unit="m""#),
            real("der(h)", 1, "local", r#"unit="m/s" derivative="1""#),
            real("v", 2, "output", r#"unit="m/s""#),
            real("der(v)", 3, "local", r#"unit="m/s2" derivative="3""#),
            real("ball.v", 2, "local", r#"unit="m/s" derivative="1""#),
            real("ball.a", 3, "local", r#"unit="m/s2""#),
        ]
        .concat();
        let md = md("", &vars, r#"<Unknown index="2"/><Unknown index="4"/>"#);
        let s = Structure::read(&md, &[]);
        let h = s.state("h").unwrap();
        assert_eq!((h.velocity.as_deref(), h.paired_by), (Some("v"), Some(Pairing::Alias)));
        assert_eq!(s.state("v").unwrap().derivative_aliases, vec!["ball.a".to_owned()]);
        assert_eq!(s.state("ball.v").unwrap().name, "v", "a state is found by its alias too");
    }

    #[test]
    fn a_state_shared_with_an_output_keeps_the_name_its_derivative_gives() {
        // The state `mass.s` shares its value with the output `y` (the base of the two): the
        // state keeps the name its derivative names, `y` is an alias, and the velocity
        // `mass.v` pairs with it through `mass.s`'s prefix.
        let vars = [
            real("mass.s", 0, "local", r#"unit="m""#),
            real("der(mass.s)", 1, "local", r#"unit="m/s" derivative="1""#),
            real("mass.v", 2, "local", r#"unit="m/s""#),
            real("der(mass.v)", 3, "local", r#"unit="m/s2" derivative="3""#),
            real("y", 0, "output", r#"unit="m""#),
            real("mass.f", 4, "input", r#"unit="N""#),
        ]
        .concat();
        let md = md("", &vars, r#"<Unknown index="2"/><Unknown index="4"/>"#);
        let s = Structure::read(&md, &[]);
        let x = s.state("mass.s").unwrap();
        assert_eq!((x.name.as_str(), x.aliases.clone()), ("mass.s", vec!["y".to_owned()]));
        assert_eq!(s.state("y").unwrap().name, "mass.s", "found by its output alias too");
        assert_eq!((x.velocity.as_deref(), x.paired_by), (Some("mass.v"), Some(Pairing::PrefixAndUnit)));
        let f = s.port("mass.f").unwrap();
        assert_eq!((f.positions.clone(), f.by_prefix), (vec!["mass.s".to_owned()], true));
    }

    #[test]
    fn port_domain_reads_names_and_si_base_units() {
        let vars = [
            real("a", 0, "input", r#"unit="N""#),
            real("b", 1, "input", r#"unit="N·m""#),
            real("c", 2, "input", r#"unit="W""#),
            real("d", 3, "input", r#"unit="myPower""#),
            real("e", 4, "input", r#"unit="V""#),
            real("f", 5, "input", ""),
        ]
        .concat();
        let md = md(r#"<Unit name="myPower"><BaseUnit kg="1" m="2" s="-3"/></Unit>"#, &vars, "");
        let domain = |n: &str| port_domain(&md, md.variable(n).unwrap()).map(|(_, d)| d);
        assert_eq!(
            ["a", "b", "c", "d", "e", "f"].map(domain),
            [
                Some(Domain::Mechanical),
                Some(Domain::Mechanical),
                Some(Domain::Thermal),
                Some(Domain::Thermal),
                None,
                None
            ]
        );
    }

    #[test]
    fn prefixes_ignore_dots_inside_brackets_and_der() {
        assert_eq!(prefix("a.b.c"), "a.b");
        assert_eq!(prefix("x"), "");
        assert_eq!(prefix("der(a.b)"), "a");
        assert_eq!(prefix("a[1.5].b"), "a[1.5]");
        assert!(in_component("a.b.c", "a") && !in_component("ab.c", "a"));
    }

    #[test]
    fn the_structure_serialises_with_lowercase_names() {
        let s = Structure::read(&dymola(), &[]);
        let json = serde_json::to_value(&s).unwrap();
        assert_eq!(json["states"][0]["quantity"], "translational");
        assert_eq!(json["states"][0]["role"], "position");
        assert_eq!(json["states"][0]["paired_by"], "alias");
        assert_eq!(json["ports"][0]["domain"], "mechanical");
        let text = s.render();
        assert!(text.contains("mass.s") && text.contains("velocity mass.v (alias)"), "{text}");
    }
}
