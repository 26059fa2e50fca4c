//! fmucal's core library: time series and their files ([`series`]), simulation ([`sim`]),
//! calibration jobs ([`job`]), the analysis of what a calibrated model still gets wrong
//! ([`diagnose`]) and the quoting of user text in errors ([`quote`]), over two leaf crates it
//! re-exports under their old paths: the FMI runtime (`fmucal-fmi`, as [`fmu`]) and the
//! ask/tell optimizers (`fmucal-optim`, as [`optim`]). It knows nothing of tokio, tonic or the
//! network, so everything in it is testable without a server.

#![forbid(unsafe_code)]

pub use fmucal_fmi as fmu;
pub use fmucal_optim as optim;

pub mod diagnose;
pub mod export;
pub mod job;
pub use fmucal_fmi::quote;
pub mod series;
pub mod sim;
