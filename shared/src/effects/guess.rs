//! How a diagnosis sets up a candidate effect it has not been told about: for every kind, which
//! sort of signal it reads ([`SignalRole`]) and, from the size of things in this job
//! ([`Scales`]), each parameter's neutral value (the value at which the effect does nothing),
//! the finite-difference step of the screening, and the bounds of the candidate's fit
//! ([`Guess`]). Every kind implements [`Guesses`]; it is a supertrait of the effect traits, so
//! a new kind cannot be added without saying how to guess it.
//!
//! A port effect's sizes come from the port's load scale `L` (the load that would move the
//! outputs about as much as the residual does) divided by the signal's typical size, so the
//! step changes the port's load by about L/10 and the bounds allow up to 20·L. A series
//! effect's come from the range `R` of the measured series.

use serde::{Deserialize, Serialize};

use super::{
    ActuatorSaturation, ConstantLoad, ConstantRate, Convection, CoulombFriction, CubicSpring, DeadZoneSpring, HeatLoss,
    Kind, LinearRelaxation, LinearSpring, QuadraticDrag, Radiation, SIGMA, SensorLag, Shared, StribeckFriction,
    ViscousDamping,
};

/// What an effect's signal must be.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SignalRole {
    Velocity,
    Position,
    Temperature,
    /// The state whose derivative the term is added to, whatever its quantity (the generic
    /// kinds).
    State,
    /// The term does not depend on its signal (a constant load or heat loss); any signal of
    /// the port will do.
    Any,
    /// A series effect: the measured output or input itself.
    Series,
}

/// Summary statistics of a signal on the calibration window.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SignalStats {
    pub min: f64,
    pub max: f64,
    pub mean: f64,
    /// Root mean square of the values (not of their deviation from the mean).
    pub rms: f64,
    /// Root mean square of the deviation from the mean.
    pub std: f64,
}

impl SignalStats {
    /// Statistics of the finite values (all zero when there is none).
    pub fn of(values: &[f64]) -> SignalStats {
        let v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
        if v.is_empty() {
            return SignalStats { min: 0.0, max: 0.0, mean: 0.0, rms: 0.0, std: 0.0 };
        }
        let n = v.len() as f64;
        let mean = v.iter().sum::<f64>() / n;
        SignalStats {
            min: v.iter().copied().fold(f64::INFINITY, f64::min),
            max: v.iter().copied().fold(f64::NEG_INFINITY, f64::max),
            mean,
            rms: (v.iter().map(|x| x * x).sum::<f64>() / n).sqrt(),
            std: (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n).sqrt(),
        }
    }

    pub fn range(&self) -> f64 {
        self.max - self.min
    }

    pub fn max_abs(&self) -> f64 {
        self.min.abs().max(self.max.abs())
    }
}

/// The sizes of things a guess is made from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Scales {
    /// Port effects: the port's load scale L. Series effects: the series' range R.
    pub load: f64,
    /// The signal the effect reads (port effects) or the series it changes.
    pub signal: SignalStats,
    /// Length of the calibration window and the typical sample interval [s].
    pub duration: f64,
    pub sample: f64,
    /// Ambient temperature of thermal effects.
    pub ambient: f64,
}

/// One parameter's guess.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Guess {
    /// The value at which the effect does nothing (strength parameters), or a typical value
    /// (shape parameters).
    pub neutral: f64,
    /// The screening's finite-difference step from `neutral`; `None` for a shape parameter,
    /// which the screening holds at `neutral`.
    pub step: Option<f64>,
    pub lower: f64,
    pub upper: f64,
}

impl Guess {
    fn strength(neutral: f64, step: f64, lower: f64, upper: f64) -> Guess {
        Guess { neutral, step: Some(step), lower, upper }
    }

    fn shape(value: f64, lower: f64, upper: f64) -> Guess {
        Guess { neutral: value, step: None, lower, upper }
    }

    /// A non-negative coefficient whose term is coefficient × `size`: step L/10, bounds
    /// [0, 20·L] in load.
    fn coefficient(load: f64, size: f64) -> Guess {
        let unit = load / positive(size);
        Guess::strength(0.0, 0.1 * unit, 0.0, 20.0 * unit)
    }
}

/// `x` if it is a positive number, else 1 (a signal that never moves gives its effect the
/// load's own scale rather than a division by zero).
fn positive(x: f64) -> f64 {
    if x > 0.0 && x.is_finite() { x } else { 1.0 }
}

/// How a kind guesses its parameters; one [`Guess`] per parameter, in the kind's order.
pub trait Guesses {
    fn signal_role(&self) -> SignalRole;
    fn guesses(&self, s: &Scales) -> Vec<Guess>;
}

/// The guess of a reaction's strength ([`crate::effects::REACTION`]): the kind's strength guess
/// with `s.load` the reaction state's derivative scale, of either sign (the mass matrix's share
/// may be negative).
pub fn reaction(kind: &dyn Guesses, s: &Scales) -> Guess {
    let g = kind.guesses(s).first().copied().unwrap_or(Guess::strength(0.0, 0.0, 0.0, 0.0));
    let reach = g.upper.abs().max(g.lower.abs());
    Guess { neutral: 0.0, step: g.step, lower: -reach, upper: reach }
}

/// Implements [`Guesses`] for each kind from its signal role and its guesses of the scales `s`.
macro_rules! guesses {
    ($($kind:ty: $role:ident, |$s:ident| $guesses:expr;)+) => {$(
        impl Guesses for $kind {
            fn signal_role(&self) -> SignalRole {
                SignalRole::$role
            }
            fn guesses(&self, $s: &Scales) -> Vec<Guess> {
                $guesses
            }
        }
    )+};
}

guesses! {
    ViscousDamping: Velocity, |s| vec![Guess::coefficient(s.load, s.signal.rms)];
    CoulombFriction: Velocity, |s| vec![Guess::coefficient(s.load, 1.0)];
    StribeckFriction: Velocity, |s| {
        let v = positive(s.signal.max_abs());
        vec![Guess::coefficient(s.load, 1.0), Guess::coefficient(s.load, 1.0), Guess::shape(0.1 * v, 0.01 * v, v)]
    };
    QuadraticDrag: Velocity, |s| vec![Guess::coefficient(s.load, s.signal.rms * s.signal.rms)];
    LinearSpring: Position, |s| about_rest(s);
    CubicSpring: Position, |s| vec![Guess::coefficient(s.load, s.signal.rms.powi(3))];
    ConstantLoad: Any, |s| constant(s);
    LinearRelaxation: State, |s| about_rest(s);
    ConstantRate: Any, |s| constant(s);
    DeadZoneSpring: Position, |s| {
        let x = positive(s.signal.max_abs());
        vec![Guess::coefficient(s.load, s.signal.rms), Guess::shape(0.1 * x, 0.0, x)]
    };
    Convection: Temperature, |s| {
        let dt = (s.signal.mean - s.ambient).abs().max(s.signal.std);
        vec![Guess::coefficient(s.load, dt), ambient(s)]
    };
    Radiation: Temperature, |s| {
        let flux = SIGMA * (s.signal.rms.powi(4) - s.ambient.powi(4)).abs();
        vec![Guess::coefficient(s.load, flux), ambient(s)]
    };
    HeatLoss: Any, |s| vec![Guess::coefficient(s.load, 1.0)];
    SensorLag: Series, |s| vec![time_shift(s)];
    // Neutral: the limits at the input's own extremes; the steps move each in by 5 % of the
    // range, and each may move in up to the middle.
    ActuatorSaturation: Series, |s| {
        let (lo, hi) = (s.signal.min, s.signal.max);
        let (mid, r) = (0.5 * (lo + hi), positive(hi - lo));
        vec![Guess::strength(lo, 0.05 * r, lo, mid), Guess::strength(hi, -0.05 * r, mid, hi)]
    };
}

/// A linear term about a rest value (a spring's rest position, a relaxation's target): its
/// coefficient on the signal's spread, and the rest value at the signal's mean, within its range.
fn about_rest(s: &Scales) -> Vec<Guess> {
    let (lo, hi) = (s.signal.min, s.signal.max);
    vec![Guess::coefficient(s.load, s.signal.std), Guess::shape(s.signal.mean, lo.min(hi), hi.max(lo))]
}

/// A constant term of either sign: step L/10, bounds ±20·L.
fn constant(s: &Scales) -> Vec<Guess> {
    vec![Guess::strength(0.0, 0.1 * s.load, -20.0 * s.load, 20.0 * s.load)]
}

/// The ambient temperature's bounds: 50 K either side of the guess.
fn ambient(s: &Scales) -> Guess {
    Guess::shape(s.ambient, s.ambient - 50.0, s.ambient + 50.0)
}

/// A time constant or delay: step one sample (at least 1e-3 of the window), at most a tenth of
/// the window.
fn time_shift(s: &Scales) -> Guess {
    let step = s.sample.max(1e-3 * s.duration);
    Guess::strength(0.0, step, 0.0, (0.1 * s.duration).max(10.0 * step))
}

impl Guesses for Shared {
    fn signal_role(&self) -> SignalRole {
        SignalRole::Series
    }
    fn guesses(&self, s: &Scales) -> Vec<Guess> {
        let r = positive(s.load);
        vec![match Kind::parameters(self)[0] {
            "offset" => Guess::strength(0.0, 0.01 * r, -0.5 * r, 0.5 * r),
            "gain" => Guess::strength(1.0, 0.01, 0.5, 2.0),
            _ => time_shift(s),
        }]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::effects::{Found, find, port_kinds, series_kinds};

    fn scales() -> Scales {
        Scales {
            load: 0.01,
            signal: SignalStats::of(&[-2.0, -1.0, 0.5, 1.0, 3.0]),
            duration: 10.0,
            sample: 0.01,
            ambient: 293.15,
        }
    }

    #[test]
    fn every_kind_guesses_each_parameter_with_the_neutral_value_inside_its_bounds() {
        let s = scales();
        for name in port_kinds().iter().map(|k| k.name()).chain(series_kinds().iter().map(|k| k.name())) {
            let (kind, guesses) = match find(name).unwrap() {
                Found::Port(k) => (k.parameters(), k.guesses(&s)),
                Found::Series(k) => (k.parameters(), k.guesses(&s)),
            };
            assert_eq!(guesses.len(), kind.len(), "{name}");
            for g in &guesses {
                assert!(g.lower < g.upper, "{name}: {g:?}");
                assert!((g.lower..=g.upper).contains(&g.neutral), "{name}: {g:?}");
                if let Some(h) = g.step {
                    assert!(h != 0.0 && (g.lower..=g.upper).contains(&(g.neutral + h)), "{name}: {g:?}");
                }
            }
            assert!(guesses.iter().any(|g| g.step.is_some()), "{name} has no strength parameter");
        }
    }

    #[test]
    fn at_its_neutral_values_every_effect_does_nothing() {
        let s = scales();
        let time: Vec<f64> = (0..50).map(|k| k as f64 * 0.1).collect();
        let values: Vec<f64> = time.iter().map(|t| (2.0 * t).sin() + 0.3 * t).collect();
        let stats = SignalStats::of(&values);
        for k in port_kinds() {
            let p: Vec<f64> = k.guesses(&s).iter().map(|g| if g.step.is_some() { g.neutral } else { 0.5 }).collect();
            for v in [-1.0, 0.0, 0.7] {
                assert_eq!(k.term(&p, v), 0.0, "{}", k.name());
            }
        }
        for k in series_kinds() {
            let p: Vec<f64> =
                k.guesses(&Scales { load: stats.range(), signal: stats, ..s }).iter().map(|g| g.neutral).collect();
            assert_eq!(k.apply(&p, &time, &values), values, "{}", k.name());
        }
    }

    #[test]
    fn a_coefficient_step_moves_the_load_by_a_tenth_of_the_scale() {
        let s = scales();
        let g = ViscousDamping.guesses(&s)[0];
        assert!((g.step.unwrap() * s.signal.rms - 0.1 * s.load).abs() < 1e-15);
        assert!((g.upper * s.signal.rms - 20.0 * s.load).abs() < 1e-15);
    }
}
