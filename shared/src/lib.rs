//! fmucal's core library: FMU loading ([`fmu`]), time series and their files ([`series`]),
//! simulation ([`sim`]), the ask/tell optimizers ([`optim`]), calibration jobs ([`job`]), the
//! analysis of what a calibrated model still gets wrong ([`diagnose`]) and the quoting of user
//! text in errors ([`quote`]). It knows nothing of tokio, tonic or the network, so everything
//! in it is testable without a server.

pub mod diagnose;
pub mod fmu;
pub mod job;
pub mod optim;
pub mod quote;
pub mod series;
pub mod sim;
