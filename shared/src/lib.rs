//! fmucal's core library: FMU loading ([`fmu`]) and simulation ([`sim`]). It knows nothing of
//! tokio, tonic or the network, so everything in it is testable without a server.

pub mod fmu;
pub mod sim;
