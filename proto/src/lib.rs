//! fmucal's wire protocol, package `fmucal.v1`: the client-facing `Calibration` service and the
//! worker-facing `WorkerPool` service, generated from `fmucal/v1/fmucal.proto`, plus what every
//! networked part shares: conversions to and from fmucal's job types ([`convert`]) and the
//! bearer-token interceptors ([`auth`]). Keeping them here leaves `fmucal-shared` free of
//! network types.

pub mod auth;
pub mod convert;

/// Version a worker must announce at registration; a mismatch is rejected.
pub const PROTOCOL_VERSION: u32 = 1;

/// Generated messages and services.
pub mod v1 {
    tonic::include_proto!("fmucal.v1");
}
