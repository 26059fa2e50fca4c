//! fmucal's core library: FMU loading ([`fmu`]), time series and their files ([`series`]),
//! simulation ([`sim`]) and the ask/tell optimizers ([`optim`]). It knows nothing of
//! tokio, tonic or the network, so everything in it is testable without a server.

pub mod fmu;
pub mod job;
pub mod optim;
pub mod series;
pub mod sim;
