//! What a simulation is asked to do ([`SimSpec`]), what it returns ([`SimResult`]) and how it
//! fails ([`SimError`]).

use std::time::Duration;

use serde::Serialize;

use crate::fmu::{FmuError, Interface};
use crate::series::TimeSeries;

/// Integrator for Model Exchange (all from diffsol).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
pub enum Solver {
    /// Variable-order BDF (NDF), for stiff and non-stiff models. The default.
    #[default]
    Bdf,
    /// ESDIRK34, a stiffly accurate implicit Runge-Kutta method.
    Esdirk34,
    /// TR-BDF2, a second-order implicit Runge-Kutta method.
    TrBdf2,
    /// Tsitouras 5(4), an explicit Runge-Kutta method for non-stiff models.
    Tsit45,
}

impl std::fmt::Display for Solver {
    /// The name [`FromStr`](std::str::FromStr) reads back.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Solver::Bdf => "bdf",
            Solver::Esdirk34 => "esdirk34",
            Solver::TrBdf2 => "tr-bdf2",
            Solver::Tsit45 => "tsit45",
        })
    }
}

impl std::str::FromStr for Solver {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.to_ascii_lowercase().as_str() {
            "bdf" => Ok(Solver::Bdf),
            "esdirk34" => Ok(Solver::Esdirk34),
            "tr-bdf2" | "trbdf2" => Ok(Solver::TrBdf2),
            "tsit45" | "explicit" => Ok(Solver::Tsit45),
            other => Err(format!("unknown solver {other:?} (expected bdf, esdirk34, tr-bdf2 or tsit45)")),
        }
    }
}

/// Where results are reported.
#[derive(Debug, Clone, PartialEq)]
pub enum OutputTimes {
    /// Every `dt` from the start time, plus the stop time.
    Interval(f64),
    /// Exactly these times (sorted, within start..=stop); need not be evenly spaced.
    Times(Vec<f64>),
}

/// A simulation request. `None` fields fall back to the FMU's `DefaultExperiment`.
#[derive(Debug, Clone, Default)]
pub struct SimSpec {
    /// Interface to use. Default: Model Exchange when offered, else Co-Simulation.
    pub interface: Option<Interface>,
    /// Default: `DefaultExperiment/startTime`, else 0.
    pub start_time: Option<f64>,
    /// Default: `DefaultExperiment/stopTime`, else start + 1.
    pub stop_time: Option<f64>,
    /// Default: `DefaultExperiment/stepSize`, else (stop - start) / 500.
    pub output_times: Option<OutputTimes>,
    /// Parameters and start values by variable name, as text (numbers, true/false, enum item names).
    pub parameters: Vec<(String, String)>,
    /// Input time series.
    pub inputs: Option<TimeSeries>,
    /// Variables to report. Default: all outputs, or all states if there are none.
    pub outputs: Vec<String>,
    /// Relative tolerance of the integrator. Default: `DefaultExperiment/tolerance`, else 1e-6.
    pub tolerance: Option<f64>,
    /// Model Exchange integrator. Default: BDF.
    pub solver: Solver,
    /// Co-Simulation: largest `fmi2DoStep` size; output intervals are split to respect it.
    /// Default: none.
    /// Model Exchange: largest integrator step. Default: (stop − start) / 50, as FMPy.
    pub max_step: Option<f64>,
    /// Most integrator steps and events (ME) or `fmi2DoStep` calls (CS) before giving up.
    /// Default: 10,000,000.
    pub max_steps: Option<u64>,
    /// Wall-clock budget. Default: none.
    pub timeout: Option<Duration>,
    /// Effects added to injection ports (see [`crate::effects`]).
    pub port_terms: Vec<PortTerm>,
    /// Effects added to state derivatives (Model Exchange only).
    pub state_terms: Vec<StateTerm>,
}

/// An effect added to an injection port: `kind`'s term of the value of `signal`, with
/// `parameters` in the kind's order, added to the input `port` (on top of any input column
/// mapped to it). Model Exchange evaluates it inside every derivative evaluation, after the
/// states are set; Co-Simulation at every communication point (first order in the step).
#[derive(Debug, Clone, PartialEq)]
pub struct PortTerm {
    pub kind: String,
    pub port: String,
    pub signal: String,
    pub parameters: Vec<f64>,
}

/// An effect added to a continuous state's derivative: `kind`'s term of the value of the state
/// `signal` (the state itself, or the position whose derivative `state` is), with
/// `parameters` in the kind's order, added to der(`state`) inside every derivative evaluation
/// and to every output that is that derivative. Its strength is in the derivative's units (an
/// acceleration on a velocity). Model Exchange only: in Co-Simulation the FMU integrates itself.
#[derive(Debug, Clone, PartialEq)]
pub struct StateTerm {
    pub kind: String,
    pub state: String,
    pub signal: String,
    pub parameters: Vec<f64>,
}

impl StateTerm {
    /// The terms of one state effect whose parameter values are `values` (its kind's, then the
    /// reaction's strength when it has a `reaction` state): its own on der(`state`), and the
    /// same term with the reaction's strength as first parameter on der(`reaction`).
    pub fn of_effect(kind: &str, state: &str, signal: &str, reaction: Option<&str>, values: &[f64]) -> Vec<StateTerm> {
        let term = |state: &str, parameters: Vec<f64>| StateTerm {
            kind: kind.to_owned(),
            state: state.to_owned(),
            signal: signal.to_owned(),
            parameters,
        };
        match (reaction, values.split_last()) {
            (Some(reaction), Some((r, own))) => {
                let mut at_reaction = own.to_vec();
                if let Some(strength) = at_reaction.first_mut() {
                    *strength = *r;
                }
                vec![term(state, own.to_vec()), term(reaction, at_reaction)]
            }
            _ => vec![term(state, values.to_vec())],
        }
    }
}

/// Counters of one simulation.
#[derive(Debug, Clone, Default, Serialize)]
pub struct SimStats {
    /// Integrator steps (ME) or `fmi2DoStep` calls (CS).
    pub steps: u64,
    /// Derivative evaluations (ME).
    pub rhs_evaluations: u64,
    /// Events handled after initialisation.
    pub events: u64,
}

/// Results at exactly the requested times.
#[derive(Debug, Clone, Serialize)]
pub struct SimResult {
    pub names: Vec<String>,
    pub time: Vec<f64>,
    /// One column per name, aligned with `time`.
    pub columns: Vec<Vec<f64>>,
    /// Times at which events were handled after initialisation (state, time, step and input events).
    pub event_times: Vec<f64>,
    /// True if the FMU asked to terminate before the stop time; results end there.
    pub terminated_early: bool,
    pub stats: SimStats,
}

impl SimResult {
    /// The column of a variable by name.
    pub fn column(&self, name: &str) -> Option<&[f64]> {
        self.names.iter().position(|n| n == name).map(|i| self.columns[i].as_slice())
    }
}

/// Why a simulation failed.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    /// The request does not fit the FMU; the message names the field or variable.
    #[error("invalid simulation request: {0}")]
    Invalid(String),
    #[error(transparent)]
    Fmu(#[from] FmuError),
    #[error("integrator failed at t={time}: {message}")]
    Solver { time: f64, message: String },
    #[error("state {variable} is not finite ({value}) at t={time}")]
    NonFinite { time: f64, variable: String, value: f64 },
    #[error("simulation stopped at t={time}: {what}")]
    Budget { time: f64, what: String },
}
