//! The closed sets of choices a job names — its kind, optimizer algorithm, parameter scale,
//! experiment role, FMI interface, integrator and status — as enums. Each is read from and
//! written as the same text in the TOML job file and in the protocol, so the names live here
//! once ([`text`] and [`optional_text`] are the serde adapters for the text form).

use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Serialize};

use crate::fmu::Interface;
use crate::quote::quote_user_text;

/// What a job does with its parameter points.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub enum JobKind {
    /// Minimize the objective with the job's optimizer.
    #[default]
    Calibration,
    /// Evaluate these points (user units, in parameter order) once, as one batch, keeping each
    /// point's value and residual vector: the finite-difference points of an identifiability
    /// analysis run this way on the workers.
    EvaluatePoints(Vec<Vec<f64>>),
}

impl JobKind {
    /// Whether the points' residual vectors are wanted back, not only the objective value.
    pub fn wants_residuals(&self) -> bool {
        matches!(self, JobKind::EvaluatePoints(_))
    }
}

/// A closed set of choices written as text: each value with its name, in the order an error
/// lists them.
trait Choice: Copy + PartialEq + 'static {
    const NAMES: &'static [(Self, &'static str)];

    fn name(self) -> &'static str {
        Self::NAMES.iter().find(|(v, _)| *v == self).map(|(_, n)| *n).unwrap_or_default()
    }

    /// The value named `s`; else an error that lists the names: `"ln" is not linear or log`.
    fn from_name(s: &str) -> Result<Self, String> {
        Self::NAMES.iter().find(|(_, n)| *n == s).map(|(v, _)| *v).ok_or_else(|| {
            let names: Vec<&str> = Self::NAMES.iter().map(|(_, n)| *n).collect();
            let (last, others) = names.split_last().expect("a choice has names");
            format!("{} is not {} or {last}", quote_user_text(s), others.join(", "))
        })
    }
}

/// `Display` and `FromStr` of [`Choice`] enums: the text is the name.
macro_rules! text_is_the_name {
    ($($choice:ty),+) => {$(
        impl fmt::Display for $choice {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str(self.name())
            }
        }

        impl FromStr for $choice {
            type Err = String;
            fn from_str(s: &str) -> Result<Self, String> {
                Self::from_name(s)
            }
        }
    )+};
}

/// The optimizer of a calibration.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum Algorithm {
    #[default]
    NelderMead,
    DifferentialEvolution,
    Genetic,
    CmaEs,
    LeastSquares,
}

impl Choice for Algorithm {
    const NAMES: &'static [(Self, &'static str)] = &[
        (Algorithm::NelderMead, "nelder-mead"),
        (Algorithm::DifferentialEvolution, "differential-evolution"),
        (Algorithm::Genetic, "genetic"),
        (Algorithm::CmaEs, "cma-es"),
        (Algorithm::LeastSquares, "least-squares"),
    ];
}

/// How the optimizer sees a parameter: as it is, or as its logarithm (for values that span
/// decades; the bounds must then be positive).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum Scale {
    #[default]
    Linear,
    Log,
}

impl Choice for Scale {
    const NAMES: &'static [(Self, &'static str)] = &[(Scale::Linear, "linear"), (Scale::Log, "log")];
}

/// What an experiment of a job is for: fitted, or only simulated with the optimum and reported.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum ExperimentRole {
    #[default]
    Fit,
    Validation,
}

impl Choice for ExperimentRole {
    const NAMES: &'static [(Self, &'static str)] =
        &[(ExperimentRole::Fit, "fit"), (ExperimentRole::Validation, "validation")];
}

text_is_the_name!(Algorithm, Scale, ExperimentRole);

impl Choice for Interface {
    const NAMES: &'static [(Self, &'static str)] = &[(Interface::ModelExchange, "me"), (Interface::CoSimulation, "cs")];
}

/// The FMI interface's name in a job: `me` or `cs`.
pub fn interface_name(i: Interface) -> &'static str {
    i.name()
}

/// Reads `me` or `cs`.
///
/// # Errors
/// The text, when it is neither.
pub fn parse_interface(s: &str) -> Result<Interface, String> {
    Interface::from_name(s)
}

/// Where a job stands.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum JobStatus {
    Running,
    Succeeded,
    Failed,
    Cancelled,
}

/// Serde adapter: a value written as its `Display` text and read with `FromStr`.
pub mod text {
    use super::*;

    pub fn serialize<T: fmt::Display, S: serde::Serializer>(v: &T, s: S) -> Result<S::Ok, S::Error> {
        s.collect_str(v)
    }

    pub fn deserialize<'de, T, D>(d: D) -> Result<T, D::Error>
    where
        T: FromStr<Err: fmt::Display>,
        D: serde::Deserializer<'de>,
    {
        String::deserialize(d)?.parse().map_err(serde::de::Error::custom)
    }
}

/// Serde adapter: [`text`] for an optional value.
pub mod optional_text {
    use super::*;

    pub fn serialize<T: fmt::Display, S: serde::Serializer>(v: &Option<T>, s: S) -> Result<S::Ok, S::Error> {
        match v {
            Some(v) => s.serialize_some(&v.to_string()),
            None => s.serialize_none(),
        }
    }

    pub fn deserialize<'de, T, D>(d: D) -> Result<Option<T>, D::Error>
    where
        T: FromStr<Err: fmt::Display>,
        D: serde::Deserializer<'de>,
    {
        Option::<String>::deserialize(d)?.map(|t| t.parse().map_err(serde::de::Error::custom)).transpose()
    }
}

/// Serde adapter for an optional [`Interface`] written as `me` or `cs`.
pub mod optional_interface {
    use super::*;

    pub fn serialize<S: serde::Serializer>(v: &Option<Interface>, s: S) -> Result<S::Ok, S::Error> {
        match v {
            Some(i) => s.serialize_some(interface_name(*i)),
            None => s.serialize_none(),
        }
    }

    pub fn deserialize<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Option<Interface>, D::Error> {
        Option::<String>::deserialize(d)?.map(|t| parse_interface(&t).map_err(serde::de::Error::custom)).transpose()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_algorithm_reads_back_from_its_name() {
        for &(a, name) in Algorithm::NAMES {
            assert_eq!(a.to_string(), name);
            assert_eq!(name.parse::<Algorithm>(), Ok(a));
        }
        assert!("points".parse::<Algorithm>().unwrap_err().contains("\"points\" is not nelder-mead"));
    }

    #[test]
    fn interfaces_read_back_from_their_names() {
        for i in [Interface::ModelExchange, Interface::CoSimulation] {
            assert_eq!(parse_interface(interface_name(i)), Ok(i));
        }
        assert_eq!(parse_interface("ME").unwrap_err(), "\"ME\" is not me or cs");
    }

    #[test]
    fn scales_and_roles_read_back_from_their_names() {
        for s in [Scale::Linear, Scale::Log] {
            assert_eq!(s.to_string().parse::<Scale>(), Ok(s));
        }
        for r in [ExperimentRole::Fit, ExperimentRole::Validation] {
            assert_eq!(r.to_string().parse::<ExperimentRole>(), Ok(r));
        }
        assert_eq!("ln".parse::<Scale>().unwrap_err(), "\"ln\" is not linear or log");
    }
}
