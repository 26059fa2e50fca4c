//! The physical structure fmucal reads from the descriptions of the built models:
//! which states are positions, velocities and temperatures, how they pair, which variables are
//! a state's derivative, and which inputs are injection ports paired with which states — on the
//! examples (spring–mass, Furuta, exhaust pipe) and on fixtures shaped as tools export models
//! (FMI 2.0 aliases, `derivative` attributes on aliases, FMI 1.0 states from `der(x)` names).

use std::path::Path;

use fmucal_models::Fixture;
use fmucal_shared::effects::Domain;
use fmucal_shared::fmu::schema::ModelDescription;
use fmucal_shared::fmu::{ArchiveLimits, LoadOptions, describe};
use fmucal_shared::structure::{Pairing, Quantity, Role, Structure};

fn description(fmu: &Path, cache: &Path) -> ModelDescription {
    let opts = LoadOptions { cache_dir: cache.to_owned(), limits: ArchiveLimits::default() };
    let d = describe(fmu, &opts).unwrap_or_else(|e| panic!("{}: {e}", fmu.display()));
    d.description.as_ref().clone()
}

fn read(fmu: &Path, mapped: &[&str]) -> Structure {
    let dir = tempfile::tempdir().unwrap();
    let md = description(fmu, dir.path());
    Structure::read(&md, &mapped.iter().map(|s| s.to_string()).collect::<Vec<_>>())
}

fn strings(names: &[&str]) -> Vec<String> {
    names.iter().map(|s| s.to_string()).collect()
}

/// Asserts position `x` pairs with velocity `v` (in `quantity`, by `how`).
fn assert_pair(s: &Structure, x: &str, v: &str, quantity: Quantity, how: Pairing) {
    let p = s.state(x).unwrap_or_else(|| panic!("no state {x}: {s:#?}"));
    let w = s.state(v).unwrap_or_else(|| panic!("no state {v}: {s:#?}"));
    assert_eq!(
        (p.role, p.quantity, p.velocity.as_deref(), p.paired_by),
        (Role::Position, quantity, Some(v), Some(how)),
        "{x}: {s:#?}"
    );
    assert_eq!(
        (w.role, w.quantity, w.position.as_deref(), w.paired_by),
        (Role::Velocity, quantity, Some(x), Some(how)),
        "{v}: {s:#?}"
    );
}

/// Asserts port `name` (mechanical) pairs with exactly these velocities and positions.
fn assert_port(s: &Structure, name: &str, velocities: &[&str], positions: &[&str], by_prefix: bool) {
    let p = s.port(name).unwrap_or_else(|| panic!("no port {name}: {s:#?}"));
    assert_eq!(p.domain, Domain::Mechanical, "{name}");
    assert_eq!(
        (p.velocities.clone(), p.positions.clone(), p.by_prefix),
        (strings(velocities), strings(positions), by_prefix),
        "{name}: {s:#?}"
    );
    assert!(p.temperatures.is_empty());
}

fn port_names(s: &Structure) -> Vec<&str> {
    s.ports.iter().map(|p| p.name.as_str()).collect()
}

#[test]
fn spring_mass_pairs_position_and_velocity_and_its_force_ports() {
    let s = read(&Fixture::SpringMass.path(), &[]);
    assert_eq!(s.states.iter().map(|s| s.name.as_str()).collect::<Vec<_>>(), vec!["mass.x", "mass.v"]);
    assert_pair(&s, "mass.x", "mass.v", Quantity::Translational, Pairing::PrefixAndUnit);
    assert_eq!(s.state("mass.v").unwrap().derivative, "der(mass.v)");
    assert_eq!(port_names(&s), vec!["F", "mass.Fext"]);
    assert_port(&s, "mass.Fext", &["mass.v"], &["mass.x"], true);
    assert_port(&s, "F", &["mass.v"], &["mass.x"], false);
    assert_eq!(s.port("F").unwrap().quantity, Quantity::Translational);
    // The force the job feeds from data is no port.
    assert_eq!(port_names(&read(&Fixture::SpringMass.path(), &["F"])), vec!["mass.Fext"]);
}

/// The Furuta pendulum, whichever FMI version or alias shape describes it.
fn assert_furuta(s: &Structure) {
    let names: Vec<&str> = s.states.iter().map(|s| s.name.as_str()).collect();
    assert_eq!(names, vec!["armJoint.phi", "armJoint.w", "pendulumJoint.phi", "pendulumJoint.w"]);
    for (k, st) in s.states.iter().enumerate() {
        assert_eq!(st.index, k);
        assert_eq!(st.derivative, format!("der({})", st.name));
    }
    for j in ["armJoint", "pendulumJoint"] {
        assert_pair(s, &format!("{j}.phi"), &format!("{j}.w"), Quantity::Rotational, Pairing::PrefixAndUnit);
    }
    assert_eq!(port_names(s), vec!["armJoint.tauExt", "pendulumJoint.tauExt"]);
    assert_port(s, "armJoint.tauExt", &["armJoint.w"], &["armJoint.phi"], true);
    assert_port(s, "pendulumJoint.tauExt", &["pendulumJoint.w"], &["pendulumJoint.phi"], true);
    assert_eq!(s.port("armJoint.tauExt").unwrap().quantity, Quantity::Rotational);
}

#[test]
fn furuta_pairs_each_joint_and_its_torque_port() {
    let furuta = fmucal_models::example("furuta").unwrap();
    assert_furuta(&read(&furuta, &["u"]));
    // Unmapped, the motor torque of no component pairs with every joint.
    let s = read(&furuta, &[]);
    assert_port(&s, "u", &["armJoint.w", "pendulumJoint.w"], &["armJoint.phi", "pendulumJoint.phi"], false);
}

#[test]
fn furuta_as_fmi1_reads_states_from_der_names_and_units_from_declared_types() {
    let s = read(&Fixture::FurutaFmi1Me.path(), &["u"]);
    assert_furuta(&s);
    assert_eq!(s.state("armJoint.phi").unwrap().unit.as_deref(), Some("rad"));
    assert_eq!(s.port("armJoint.tauExt").unwrap().unit, "N.m");
}

#[test]
fn furuta_as_fmi3_and_with_fmi1_aliases_reads_the_same_structure() {
    assert_furuta(&read(&Fixture::FurutaFmi3.path(), &["u"]));
    let s = read(&Fixture::FurutaAliasesFmi1Me.path(), &["u"]);
    assert_furuta(&s);
    // The negated alias pendulumJoint.phiNeg is −phi: no other name of the state.
    assert!(s.state("pendulumJoint.phiNeg").is_none());
    assert_eq!(s.state("armAngleSensor.phi").unwrap().name, "armJoint.phi");
}

#[test]
fn furuta_with_fmi2_aliases_lists_the_derivative_aliases_and_finds_states_by_alias() {
    let s = read(&Fixture::FurutaAliases.path(), &["u"]);
    assert_furuta(&s);
    assert_eq!(s.state("armJoint.phi").unwrap().derivative_aliases, strings(&["der(armAngleSensor.phi)"]));
    assert_eq!(s.state("armAngleSensor.phi").unwrap().name, "armJoint.phi");
    assert_eq!(s.state("pendulumSpeedSensor.w").unwrap().name, "pendulumJoint.w");
    assert_eq!(s.state("pendulumJoint.w").unwrap().aliases, strings(&["pendulumSpeedSensor.w"]));
    // `motor.tau` is the input u's alias: u stays the one port of its value.
    assert_eq!(
        port_names(&read(&Fixture::FurutaAliases.path(), &["motor.tau"])),
        vec!["armJoint.tauExt", "pendulumJoint.tauExt"]
    );
}

#[test]
fn exhaust_pipe_has_temperatures_and_one_heat_flow_port_on_its_outlet_volume() {
    let s = read(&fmucal_models::example("exhaust-pipe").unwrap(), &[]);
    let names: Vec<&str> = s.states.iter().map(|s| s.name.as_str()).collect();
    assert_eq!(names, vec!["leftVolume.T", "leftVolume.wallT", "rightVolume.T", "rightVolume.wallT"]);
    for st in &s.states {
        assert_eq!(
            (st.quantity, st.role, st.unit.as_deref()),
            (Quantity::Thermal, Role::Temperature, Some("K")),
            "{st:?}"
        );
        assert!(st.position.is_none() && st.velocity.is_none());
    }
    assert_eq!(port_names(&s), vec!["rightVolume.wallQext"], "inlet.T (K), the pressures and speeds are no ports");
    let q = s.port("rightVolume.wallQext").unwrap();
    assert_eq!((q.domain, q.quantity, q.unit.as_str(), q.by_prefix), (Domain::Thermal, Quantity::Thermal, "W", true));
    assert_eq!(q.temperatures, strings(&["rightVolume.T", "rightVolume.wallT"]));
    assert!(q.velocities.is_empty() && q.positions.is_empty());
}

#[test]
fn derivative_attributes_on_aliases_pair_height_and_velocity() {
    let s = read(&Fixture::DerivativeAttributes.path(), &[]);
    assert_eq!(s.states.iter().map(|s| s.name.as_str()).collect::<Vec<_>>(), vec!["h", "v"]);
    // der(h) is a variable of its own; `ball.v`, an alias of v, says it is h's derivative.
    assert_pair(&s, "h", "v", Quantity::Translational, Pairing::Alias);
    assert_eq!(s.state("v").unwrap().derivative_aliases, strings(&["ball.a"]));
    assert_eq!(s.state("sensor.h").unwrap().name, "h");
    assert!(s.ports.is_empty());
}
