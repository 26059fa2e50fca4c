//! fmucal's core library: time series and their files ([`series`]), the model's structure read
//! from its description ([`structure`]), the library of effects a job may add to a model
//! ([`effects`]), simulation ([`sim`]), calibration jobs ([`job`]) and the statistics of their
//! residuals ([`residuals`]), the corrected model's description ([`export`]) and the quoting of
//! user text in errors ([`quote`]), over two leaf crates it re-exports under their old paths: the FMI runtime (`fmucal-fmi`, as [`fmu`]) and the
//! ask/tell optimizers (`fmucal-optim`, as [`optim`]). It knows nothing of tokio, tonic or the
//! network, so everything in it is testable without a server. The diagnosis is a crate above
//! it (`fmucal-diagnose`); nothing here depends on it.

#![forbid(unsafe_code)]

pub use fmucal_fmi as fmu;
pub use fmucal_optim as optim;

pub mod effects;
pub mod export;
pub mod job;
pub use fmucal_fmi::quote;
pub mod residuals;
pub mod series;
pub mod sim;
pub mod structure;
