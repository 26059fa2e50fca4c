//! fmucal's wire protocol, package `fmucal.v1`: the client-facing `Calibration` service and the
//! worker-facing `WorkerPool` service. Generated from `fmucal/v1/fmucal.proto`.

/// Version a worker must announce at registration; a mismatch is rejected.
pub const PROTOCOL_VERSION: u32 = 1;

pub mod v1 {
    tonic::include_proto!("fmucal.v1");
}
