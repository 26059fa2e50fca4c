//! fmucal's wire protocol, package `fmucal.v1`: the client-facing `Calibration` service and the
//! worker-facing `WorkerPool` service, generated from `fmucal/v1/fmucal.proto`, plus what every
//! networked part shares: conversions to and from fmucal's job types ([`convert`]) and the
//! bearer-token interceptors ([`auth`]), and TLS settings and endpoints ([`tls`]). Keeping them
//! here leaves `fmucal-shared` free of network types. [`diagnose`] converts the `Diagnose`
//! RPC's settings.

pub mod auth;
pub mod convert;
pub mod diagnose;
pub mod tls;

/// Version a worker must announce at registration; a mismatch is rejected.
pub const PROTOCOL_VERSION: u32 = 4;

/// Largest gRPC message any fmucal client or server encodes or decodes (a job with its data,
/// a batch of points, a result): 256 MiB.
pub const MAX_MESSAGE_BYTES: usize = 256 << 20;

/// Points a worker asks for per slot when it polls for work. The coordinator reads a poll's
/// `max_points` as a request for ⌈max_points / 4⌉ of the worker's slots, and grants at most
/// their fair share of the queue.
pub const POINTS_PER_SLOT: u32 = 4;

/// Most evaluation slots a worker may announce at registration (`fmucal worker --slots`).
pub const MAX_SLOTS: u32 = 256;

/// Most characters of a worker's chosen name kept in its worker id.
pub const MAX_WORKER_NAME_CHARS: usize = 64;

/// Longest job, model or worker id a request may carry: longer ones are refused without being
/// looked up or echoed.
pub const MAX_ID_BYTES: usize = 128;

/// Size of the chunks a model travels in (`UploadModel`, `FetchModel`): 1 MiB.
pub const MODEL_CHUNK_BYTES: usize = 1 << 20;

/// Generated messages and services.
pub mod v1 {
    tonic::include_proto!("fmucal.v1");
}
