//! The library of candidate effects a diagnosis tests: small terms of physics the model may
//! lack. Each kind is a value implementing one of two traits:
//!
//! - [`PortEffect`]: a force, torque or heat flow computed from one signal the FMU lets us read
//!   (a velocity, a position, a temperature) and added to an injection port (a real input), or
//!   the same term in the units of a state's derivative, added to that derivative in Model
//!   Exchange (a state effect: on a velocity it is an acceleration, force per mass).
//! - [`SeriesEffect`]: a change to a whole measured output (sensor effects) or measured input
//!   (actuator effects), applied to its time series.
//!
//! A mechanical state effect may also name a `reaction`: a second velocity state whose
//! derivative receives the same term at its own strength, the `reaction` parameter
//! ([`REACTION`]). A torque in one joint of a multibody model reaches every coupled joint's
//! acceleration through the inverse mass matrix; a term on the joint's own acceleration alone
//! cannot express it, the pair can with a constant ratio (exact where the mass matrix is
//! constant, an approximation where it depends on the configuration).
//!
//! Adding a kind is one type implementing the trait and [`Guesses`] (how a diagnosis sizes it),
//! listed in [`port_kinds`] or [`series_kinds`], with its test. Parameters are in the order [`Kind::parameters`] lists them.
//!
//! | kind | domain | term | parameters |
//! |---|---|---|---|
//! | `viscous_damping` | mechanical | −c·v | c |
//! | `coulomb_friction` | mechanical | −F·tanh(v/v₀), v₀ = 1e-3 | force |
//! | `stribeck_friction` | mechanical | −(F_c + (F_s − F_c)·e^{−(v/v_s)²})·tanh(v/v₀) | coulomb, static, stribeck_velocity |
//! | `quadratic_drag` | mechanical | −c·v·\|v\| | c |
//! | `linear_spring` | mechanical | −k·(x − x₀) | k, x0 |
//! | `cubic_spring` | mechanical | −k₃·x³ | k3 |
//! | `constant_load` | mechanical | f | load |
//! | `dead_zone_spring` | mechanical | −k·(x − w) above w, −k·(x + w) below −w, else 0 | k, width |
//! | `convection` | thermal | h·(T_amb − T) | h, t_ambient |
//! | `radiation` | thermal | εA·σ·(T_amb⁴ − T⁴) | emissivity_area, t_ambient |
//! | `heat_loss` | thermal | −q | q |
//! | `linear_relaxation` | generic (states only) | −k·(x − x₀) | k, x0 |
//! | `constant_rate` | generic (states only) | b | rate |
//! | any mechanical kind but Stribeck's, on a velocity state, with `reaction` | mechanical (states only) | the term with its strength replaced by `reaction`, on der(reaction state) | + reaction |
//! | `sensor_offset` / `actuator_offset` | sensor / actuator | y + b | offset |
//! | `sensor_gain` / `actuator_gain` | sensor / actuator | k·y | gain |
//! | `sensor_lag` | sensor | τ·ẏ_s = y − y_s, y_s(t₀) = y(t₀) | time_constant |
//! | `sensor_delay` / `actuator_delay` | sensor / actuator | y(t − τ), y(t₀) before t₀ + τ | delay |
//! | `actuator_saturation` | actuator | min(max(u, lower), upper) | lower, upper |

use std::fmt;

pub mod guess;

use guess::Guesses;

/// Where an effect acts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Domain {
    /// A force or torque port, driven by a velocity or position.
    Mechanical,
    /// A heat-flow port, driven by a temperature.
    Thermal,
    /// A state of any quantity: a term added to its derivative, driven by the state itself.
    Generic,
    /// A measured output.
    Sensor,
    /// A measured input.
    Actuator,
}

impl fmt::Display for Domain {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Domain::Mechanical => "mechanical",
            Domain::Thermal => "thermal",
            Domain::Generic => "generic",
            Domain::Sensor => "sensor",
            Domain::Actuator => "actuator",
        })
    }
}

/// What every effect kind tells about itself.
pub trait Kind: Sync {
    /// The name a job file uses (`kind = "..."`).
    fn name(&self) -> &'static str;
    fn domain(&self) -> Domain;
    /// Parameter names, in the order the effect takes their values.
    fn parameters(&self) -> &'static [&'static str];
}

/// What a parameter of an effect is measured in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Scale {
    /// The unit of what the term is added to: a port's load, a state's derivative, a sensor's
    /// output or an actuator's input (a force, a strength, an offset).
    Load,
    /// The unit of the signal the term reads (a rest position, a velocity, a temperature).
    Signal,
    /// Its own unit (a ratio, a time, a coefficient between the two).
    Other,
}

/// The parameter a state effect with a `reaction` has after its kind's: the strength (first
/// parameter) of the same term on the reaction state's derivative, in that derivative's units
/// where the strength is a force and a coefficient where it is one.
pub const REACTION: &str = "reaction";

/// The scale of parameter `name` of any kind (the names are shared across kinds).
pub fn parameter_scale(name: &str) -> Scale {
    match name {
        "force" | "coulomb" | "static" | "load" | "q" | "rate" | "offset" | "lower" | "upper" | REACTION => Scale::Load,
        "x0" | "width" | "t_ambient" | "stribeck_velocity" => Scale::Signal,
        _ => Scale::Other,
    }
}

/// Whether parameter `name` is a load, written in its port's unit (in its derivative's on a
/// state): a [`Scale::Load`] that is not a position of the signal (a sensor offset, a dead
/// zone's bounds).
pub fn is_load(name: &str) -> bool {
    parameter_scale(name) == Scale::Load && !matches!(name, "offset" | "lower" | "upper")
}

/// A term added to an injection port, from one signal's value.
pub trait PortEffect: Kind + Guesses {
    /// The term at signal value `s` with parameter values `p`.
    fn term(&self, p: &[f64], s: f64) -> f64;

    /// The signal values where the term is not smooth (its slope jumps), as many for any
    /// parameter values. In Model Exchange each becomes an event indicator s − value that joins
    /// the FMU's, so the integrator stops at the kink instead of stepping across it. Smooth
    /// terms have none (the default).
    fn kinks(&self, _p: &[f64]) -> Vec<f64> {
        vec![]
    }

    /// Whether the term is zero for every signal value with parameters `p`. The simulator then
    /// neither reads its signal nor adds its kinks (a diagnosis's screening holds every
    /// candidate at once, all but one at zero strength). The default: the first parameter is
    /// the strength, and the term vanishes when it is 0.
    fn vanishes(&self, p: &[f64]) -> bool {
        p.first() == Some(&0.0)
    }

    /// Whether the term is its first parameter (the strength) times a shape the others set, so
    /// that the same term at another strength r is the term with r as first parameter: what a
    /// `reaction` needs. True of every kind but Stribeck friction, which has two levels.
    fn proportional(&self) -> bool {
        true
    }
}

/// A change to a measured series (`time` increasing, `values` aligned with it).
pub trait SeriesEffect: Kind + Guesses {
    fn apply(&self, p: &[f64], time: &[f64], values: &[f64]) -> Vec<f64>;
}

/// Smoothing velocity of Coulomb and Stribeck friction: the sign function becomes tanh(v/V0),
/// so the term is smooth for the integrator and needs no event of its own.
pub const V0: f64 = 1e-3;

/// Stefan–Boltzmann constant [W/(m²·K⁴)].
pub const SIGMA: f64 = 5.670_374_419e-8;

macro_rules! kind {
    ($t:ident, $name:literal, $domain:ident, [$($p:literal),*]) => {
        #[doc = concat!("The `", $name, "` effect (see the module table).")]
        pub struct $t;
        impl Kind for $t {
            fn name(&self) -> &'static str { $name }
            fn domain(&self) -> Domain { Domain::$domain }
            fn parameters(&self) -> &'static [&'static str] { &[$($p),*] }
        }
    };
}

kind!(ViscousDamping, "viscous_damping", Mechanical, ["c"]);
kind!(CoulombFriction, "coulomb_friction", Mechanical, ["force"]);
kind!(StribeckFriction, "stribeck_friction", Mechanical, ["coulomb", "static", "stribeck_velocity"]);
kind!(QuadraticDrag, "quadratic_drag", Mechanical, ["c"]);
kind!(LinearSpring, "linear_spring", Mechanical, ["k", "x0"]);
kind!(CubicSpring, "cubic_spring", Mechanical, ["k3"]);
kind!(ConstantLoad, "constant_load", Mechanical, ["load"]);
kind!(DeadZoneSpring, "dead_zone_spring", Mechanical, ["k", "width"]);
kind!(Convection, "convection", Thermal, ["h", "t_ambient"]);
kind!(Radiation, "radiation", Thermal, ["emissivity_area", "t_ambient"]);
kind!(HeatLoss, "heat_loss", Thermal, ["q"]);
kind!(LinearRelaxation, "linear_relaxation", Generic, ["k", "x0"]);
kind!(ConstantRate, "constant_rate", Generic, ["rate"]);
kind!(SensorLag, "sensor_lag", Sensor, ["time_constant"]);
kind!(ActuatorSaturation, "actuator_saturation", Actuator, ["lower", "upper"]);

/// A series effect with the same formula on a sensor and on an actuator: offset, gain, delay.
pub struct Shared {
    name: &'static str,
    domain: Domain,
    formula: SharedFormula,
}

enum SharedFormula {
    Offset,
    Gain,
    Delay,
}

impl Kind for Shared {
    fn name(&self) -> &'static str {
        self.name
    }
    fn domain(&self) -> Domain {
        self.domain
    }
    fn parameters(&self) -> &'static [&'static str] {
        match self.formula {
            SharedFormula::Offset => &["offset"],
            SharedFormula::Gain => &["gain"],
            SharedFormula::Delay => &["delay"],
        }
    }
}

const fn shared(name: &'static str, domain: Domain, formula: SharedFormula) -> Shared {
    Shared { name, domain, formula }
}

pub const SENSOR_OFFSET: Shared = shared("sensor_offset", Domain::Sensor, SharedFormula::Offset);
pub const SENSOR_GAIN: Shared = shared("sensor_gain", Domain::Sensor, SharedFormula::Gain);
pub const SENSOR_DELAY: Shared = shared("sensor_delay", Domain::Sensor, SharedFormula::Delay);
pub const ACTUATOR_OFFSET: Shared = shared("actuator_offset", Domain::Actuator, SharedFormula::Offset);
pub const ACTUATOR_GAIN: Shared = shared("actuator_gain", Domain::Actuator, SharedFormula::Gain);
pub const ACTUATOR_DELAY: Shared = shared("actuator_delay", Domain::Actuator, SharedFormula::Delay);

impl PortEffect for ViscousDamping {
    fn term(&self, p: &[f64], v: f64) -> f64 {
        -p[0] * v
    }
}

impl PortEffect for CoulombFriction {
    fn term(&self, p: &[f64], v: f64) -> f64 {
        -p[0] * (v / V0).tanh()
    }
}

impl PortEffect for StribeckFriction {
    /// Both levels are strengths.
    fn vanishes(&self, p: &[f64]) -> bool {
        p[0] == 0.0 && p[1] == 0.0
    }

    fn proportional(&self) -> bool {
        false
    }

    fn term(&self, p: &[f64], v: f64) -> f64 {
        let (fc, fs, vs) = (p[0], p[1], p[2]);
        let level = if vs > 0.0 { fc + (fs - fc) * (-(v / vs).powi(2)).exp() } else { fc };
        -level * (v / V0).tanh()
    }
}

impl PortEffect for QuadraticDrag {
    fn term(&self, p: &[f64], v: f64) -> f64 {
        -p[0] * v * v.abs()
    }
}

impl PortEffect for LinearSpring {
    fn term(&self, p: &[f64], x: f64) -> f64 {
        -p[0] * (x - p[1])
    }
}

impl PortEffect for CubicSpring {
    fn term(&self, p: &[f64], x: f64) -> f64 {
        -p[0] * x.powi(3)
    }
}

impl PortEffect for ConstantLoad {
    fn term(&self, p: &[f64], _: f64) -> f64 {
        p[0]
    }
}

impl PortEffect for DeadZoneSpring {
    fn term(&self, p: &[f64], x: f64) -> f64 {
        let (k, w) = (p[0], p[1].abs());
        if x > w {
            -k * (x - w)
        } else if x < -w {
            -k * (x + w)
        } else {
            0.0
        }
    }

    /// The edges of the dead zone, ±width.
    fn kinks(&self, p: &[f64]) -> Vec<f64> {
        let w = p[1].abs();
        vec![-w, w]
    }
}

impl PortEffect for Convection {
    fn term(&self, p: &[f64], t: f64) -> f64 {
        p[0] * (p[1] - t)
    }
}

impl PortEffect for Radiation {
    fn term(&self, p: &[f64], t: f64) -> f64 {
        p[0] * SIGMA * (p[1].powi(4) - t.powi(4))
    }
}

impl PortEffect for HeatLoss {
    fn term(&self, p: &[f64], _: f64) -> f64 {
        -p[0]
    }
}

impl PortEffect for LinearRelaxation {
    fn term(&self, p: &[f64], x: f64) -> f64 {
        -p[0] * (x - p[1])
    }
}

impl PortEffect for ConstantRate {
    fn term(&self, p: &[f64], _: f64) -> f64 {
        p[0]
    }
}

/// y(t − τ), linear between samples, the first value before t₀ + τ.
fn delay(p: &[f64], time: &[f64], values: &[f64]) -> Vec<f64> {
    let tau = p[0].max(0.0);
    time.iter()
        .map(|&t| {
            let s = t - tau;
            let i = time.partition_point(|&ti| ti <= s);
            match i {
                0 => values[0],
                i if i == time.len() => values[i - 1],
                i => {
                    let (t0, t1) = (time[i - 1], time[i]);
                    let w = if t1 > t0 { (s - t0) / (t1 - t0) } else { 1.0 };
                    values[i - 1] + w * (values[i] - values[i - 1])
                }
            }
        })
        .collect()
}

impl SeriesEffect for Shared {
    fn apply(&self, p: &[f64], time: &[f64], values: &[f64]) -> Vec<f64> {
        match self.formula {
            SharedFormula::Offset => values.iter().map(|y| y + p[0]).collect(),
            SharedFormula::Gain => values.iter().map(|y| y * p[0]).collect(),
            SharedFormula::Delay => delay(p, time, values),
        }
    }
}

impl SeriesEffect for SensorLag {
    /// The exact response of τ·ẏ_s = y − y_s to y linear between samples.
    fn apply(&self, p: &[f64], time: &[f64], values: &[f64]) -> Vec<f64> {
        let tau = p[0];
        let mut out = Vec::with_capacity(values.len());
        let Some(&first) = values.first() else { return out };
        let mut ys = first;
        out.push(ys);
        for i in 1..values.len() {
            let h = time[i] - time[i - 1];
            if tau <= 0.0 || h <= 0.0 {
                ys = values[i];
            } else {
                let (y0, y1) = (values[i - 1], values[i]);
                let slope = (y1 - y0) / h;
                let e = (-h / tau).exp();
                // y_s follows the ramp y0 + slope·s with a lag of slope·τ, plus a decaying gap.
                ys = y1 - slope * tau + (ys - y0 + slope * tau) * e;
            }
            out.push(ys);
        }
        out
    }
}

impl SeriesEffect for ActuatorSaturation {
    fn apply(&self, p: &[f64], _: &[f64], values: &[f64]) -> Vec<f64> {
        let (lo, hi) = (p[0].min(p[1]), p[0].max(p[1]));
        values.iter().map(|u| u.clamp(lo, hi)).collect()
    }
}

/// Every additive term: on an injection port (mechanical and thermal kinds) or on a state's
/// derivative (those and the generic kinds).
pub fn port_kinds() -> &'static [&'static dyn PortEffect] {
    &[
        &ViscousDamping,
        &CoulombFriction,
        &StribeckFriction,
        &QuadraticDrag,
        &LinearSpring,
        &CubicSpring,
        &ConstantLoad,
        &DeadZoneSpring,
        &Convection,
        &Radiation,
        &HeatLoss,
        &LinearRelaxation,
        &ConstantRate,
    ]
}

/// Every effect on a measured output or input.
pub fn series_kinds() -> &'static [&'static dyn SeriesEffect] {
    &[
        &SENSOR_OFFSET,
        &SENSOR_GAIN,
        &SensorLag,
        &SENSOR_DELAY,
        &ACTUATOR_OFFSET,
        &ACTUATOR_GAIN,
        &ACTUATOR_DELAY,
        &ActuatorSaturation,
    ]
}

/// Why an effect description is refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum EffectError {
    #[error("{0:?} is not an effect kind (kinds: {1})")]
    UnknownKind(String, String),
    #[error("{kind} has no parameter {name:?} (its parameters: {known})")]
    UnknownParameter { kind: &'static str, name: String, known: String },
    #[error("{kind} needs parameter {name:?}")]
    MissingParameter { kind: &'static str, name: &'static str },
}

/// The kind named `name`, as a port or a series effect.
pub enum Found {
    Port(&'static dyn PortEffect),
    Series(&'static dyn SeriesEffect),
}

impl Found {
    pub fn kind(&self) -> &dyn Kind {
        match self {
            Found::Port(k) => *k,
            Found::Series(k) => *k,
        }
    }
}

/// Looks up a kind by the name a job file uses.
///
/// # Errors
/// [`EffectError::UnknownKind`] listing the kinds.
pub fn find(name: &str) -> Result<Found, EffectError> {
    if let Some(k) = port_kinds().iter().find(|k| k.name() == name) {
        return Ok(Found::Port(*k));
    }
    if let Some(k) = series_kinds().iter().find(|k| k.name() == name) {
        return Ok(Found::Series(*k));
    }
    let all: Vec<&str> = port_kinds().iter().map(|k| k.name()).chain(series_kinds().iter().map(|k| k.name())).collect();
    Err(EffectError::UnknownKind(name.to_owned(), all.join(", ")))
}

/// The values of `kind`'s parameters in its order, from `(name, value)` pairs given in any
/// order.
///
/// # Errors
/// [`EffectError`] naming a misspelled or missing parameter.
pub fn parameter_values(kind: &dyn Kind, given: &[(String, f64)]) -> Result<Vec<f64>, EffectError> {
    let known = kind.parameters();
    if let Some((name, _)) = given.iter().find(|(n, _)| !known.contains(&n.as_str())) {
        return Err(EffectError::UnknownParameter { kind: kind.name(), name: name.clone(), known: known.join(", ") });
    }
    known
        .iter()
        .map(|k| {
            given
                .iter()
                .find(|(n, _)| n == k)
                .map(|(_, v)| *v)
                .ok_or(EffectError::MissingParameter { kind: kind.name(), name: k })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn port(name: &str) -> &'static dyn PortEffect {
        match find(name).unwrap() {
            Found::Port(k) => k,
            Found::Series(_) => panic!("{name} is a series effect"),
        }
    }

    fn series(name: &str) -> &'static dyn SeriesEffect {
        match find(name).unwrap() {
            Found::Series(k) => k,
            Found::Port(_) => panic!("{name} is a port effect"),
        }
    }

    #[test]
    fn names_are_unique_and_each_kind_has_parameters() {
        let mut names: Vec<&str> =
            port_kinds().iter().map(|k| k.name()).chain(series_kinds().iter().map(|k| k.name())).collect();
        assert_eq!(names.len(), 21);
        names.sort_unstable();
        names.dedup();
        assert_eq!(names.len(), 21);
        assert!(
            port_kinds().iter().all(|k| matches!(k.domain(), Domain::Mechanical | Domain::Thermal | Domain::Generic))
        );
        assert!(series_kinds().iter().all(|k| matches!(k.domain(), Domain::Sensor | Domain::Actuator)));
        assert!(port_kinds().iter().all(|k| !k.parameters().is_empty()));
    }

    #[test]
    fn port_terms_follow_their_formulas() {
        assert_eq!(port("viscous_damping").term(&[0.5], 2.0), -1.0);
        // Coulomb: −F sign(v) away from zero, 0 at rest, odd.
        let c = port("coulomb_friction");
        assert!((c.term(&[0.02], 0.5) + 0.02).abs() < 1e-15);
        assert_eq!(c.term(&[0.02], 0.0), 0.0);
        assert_eq!(c.term(&[0.02], -0.3), -c.term(&[0.02], 0.3));
        // Stribeck: the static level near rest, the Coulomb level far from it.
        let s = port("stribeck_friction");
        assert!((s.term(&[1.0, 2.0, 0.1], 0.01) + (1.0 + (-0.01f64).exp()) * (10.0f64).tanh()).abs() < 1e-12);
        assert!((s.term(&[1.0, 2.0, 0.1], 5.0) + 1.0).abs() < 1e-12);
        assert_eq!(port("quadratic_drag").term(&[2.0], -3.0), 18.0);
        assert_eq!(port("linear_spring").term(&[10.0, 0.5], 0.7), -10.0 * (0.7 - 0.5));
        assert_eq!(port("cubic_spring").term(&[2.0], -2.0), 16.0);
        assert_eq!(port("constant_load").term(&[3.5], 9.0), 3.5);
        let dz = port("dead_zone_spring");
        assert_eq!(
            [dz.term(&[4.0, 0.5], 0.3), dz.term(&[4.0, 0.5], 1.5), dz.term(&[4.0, 0.5], -1.5)],
            [0.0, -4.0, 4.0]
        );
        // Its kinks are the zone's edges, where the term is continuous; smooth terms have none.
        assert_eq!(dz.kinks(&[4.0, -0.5]), [-0.5, 0.5]);
        for edge in [-0.5, 0.5] {
            assert!(dz.term(&[4.0, 0.5], edge + 1e-12).abs() < 1e-11);
        }
        let with_kinks: Vec<&str> =
            port_kinds().iter().filter(|k| !k.kinks(&[1.0, 1.0, 1.0]).is_empty()).map(|k| k.name()).collect();
        assert_eq!(with_kinks, ["dead_zone_spring"]);
        assert!((port("convection").term(&[10.0, 293.15], 303.15) + 100.0).abs() < 1e-9);
        let r = port("radiation").term(&[0.5, 300.0], 400.0);
        assert!((r - 0.5 * SIGMA * (300.0f64.powi(4) - 400.0f64.powi(4))).abs() < 1e-9);
        assert_eq!(port("heat_loss").term(&[7.0], 1.0), -7.0);
        assert_eq!(port("linear_relaxation").term(&[0.5, 2.0], 3.0), -0.5);
        assert_eq!(port("constant_rate").term(&[-0.25], 8.0), -0.25);
    }

    #[test]
    fn a_term_said_to_vanish_is_zero_for_every_signal_and_a_strong_one_is_not() {
        let signals = [-300.0, -2.0, -1e-3, 0.0, 1e-3, 0.7, 2.0, 400.0];
        let others: [f64; 5] = [-2.0, 0.0, 0.3, 2.0, 350.0];
        for k in port_kinds() {
            let n = k.parameters().len();
            // Every combination of the other parameters with each strength at 0 or 1.
            for strength in [0.0, 1.0] {
                for i in 0..others.len() {
                    let mut p: Vec<f64> = (0..n).map(|j| others[(i + j) % others.len()]).collect();
                    p[0] = strength;
                    if k.name() == "stribeck_friction" {
                        p[1] = strength;
                    }
                    let zero = signals.iter().all(|&s| k.term(&p, s) == 0.0);
                    assert_eq!(k.vanishes(&p), zero, "{} at {p:?}", k.name());
                }
            }
        }
        let s = port("stribeck_friction");
        assert!(!s.vanishes(&[0.0, 1.0, 0.1]) && s.term(&[0.0, 1.0, 0.1], 0.01) != 0.0);
    }

    #[test]
    fn series_effects_follow_their_formulas() {
        let t = [0.0, 1.0, 2.0, 3.0];
        let y = [0.0, 1.0, 4.0, 9.0];
        assert_eq!(series("sensor_offset").apply(&[0.5], &t, &y), [0.5, 1.5, 4.5, 9.5]);
        assert_eq!(series("actuator_gain").apply(&[2.0], &t, &y), [0.0, 2.0, 8.0, 18.0]);
        assert_eq!(series("actuator_delay").apply(&[1.5], &t, &y), [0.0, 0.0, 0.5, 2.5]);
        assert_eq!(series("sensor_delay").apply(&[0.0], &t, &y), y);
        assert_eq!(series("actuator_saturation").apply(&[5.0, 1.0], &t, &y), [1.0, 1.0, 4.0, 5.0]);
    }

    #[test]
    fn the_lag_is_exact_for_a_step_and_a_ramp() {
        // A step from 0 to 1 at t = 0⁺ (the series starts at 1 after the first sample): the lag
        // of a constant 1 starting from 0 is 1 − e^{−t/τ}.
        let time: Vec<f64> = (0..=50).map(|i| i as f64 * 0.1).collect();
        let mut y = vec![1.0; time.len()];
        y[0] = 0.0;
        let tau = 0.7;
        let out = series("sensor_lag").apply(&[tau], &time, &y);
        // Between t = 0 and 0.1 the input ramps from 0 to 1; after that it is constant, so
        // y_s(t) = 1 − (1 − y_s(0.1)) e^{−(t − 0.1)/τ}.
        let at = out[1];
        for (t, v) in time.iter().zip(&out).skip(1) {
            let want = 1.0 - (1.0 - at) * (-(t - 0.1) / tau).exp();
            assert!((v - want).abs() < 1e-14, "{t}: {v} vs {want}");
        }
        // A ramp y = t from y_s(0) = 0: y_s(t) = t − τ(1 − e^{−t/τ}).
        let out = series("sensor_lag").apply(&[tau], &time, &time);
        for (t, v) in time.iter().zip(&out) {
            let want = t - tau * (1.0 - (-t / tau).exp());
            assert!((v - want).abs() < 1e-13, "{t}: {v} vs {want}");
        }
    }

    #[test]
    fn bad_descriptions_name_what_is_wrong() {
        let e = find("coulomb").err().unwrap().to_string();
        assert!(e.starts_with("\"coulomb\" is not an effect kind (kinds: viscous_damping, coulomb_friction"), "{e}");
        let k = port("linear_spring");
        let e = parameter_values(k, &[("k".into(), 1.0), ("x_0".into(), 0.0)]).unwrap_err();
        assert_eq!(e.to_string(), "linear_spring has no parameter \"x_0\" (its parameters: k, x0)");
        let e = parameter_values(k, &[("k".into(), 1.0)]).unwrap_err();
        assert_eq!(e.to_string(), "linear_spring needs parameter \"x0\"");
        assert_eq!(parameter_values(k, &[("x0".into(), 2.0), ("k".into(), 1.0)]).unwrap(), [1.0, 2.0]);
    }
}
