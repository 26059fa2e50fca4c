//! The coordinator's errors and their one mapping to gRPC status codes.

use fmucal_shared::job::JobError;

#[derive(Debug, thiserror::Error)]
pub enum CoordinatorError {
    /// A request that cannot be honoured as sent; the message names the field.
    #[error("{0}")]
    InvalidArgument(String),
    #[error("{0} not found")]
    NotFound(String),
    #[error("{0}")]
    FailedPrecondition(String),
    /// A cap (the model store's size) would be passed.
    #[error("{0}")]
    ResourceExhausted(String),
    #[error("storage: {0}")]
    Storage(String),
    #[error("{0}")]
    Config(String),
    /// The coordinator cannot go on (its scheduler died); the process should exit non-zero.
    #[error("fatal: {0}")]
    Fatal(String),
    #[error("transport: {0}")]
    Transport(#[from] tonic::transport::Error),
    #[error("I/O: {0}")]
    Io(#[from] std::io::Error),
}

impl From<JobError> for CoordinatorError {
    fn from(e: JobError) -> Self {
        match e {
            JobError::Invalid { .. } | JobError::Optim(_) | JobError::Sim(_) => {
                CoordinatorError::InvalidArgument(e.to_string())
            }
            other => CoordinatorError::InvalidArgument(other.to_string()),
        }
    }
}

impl From<fmucal_proto::convert::ConvertError> for CoordinatorError {
    fn from(e: fmucal_proto::convert::ConvertError) -> Self {
        CoordinatorError::InvalidArgument(e.to_string())
    }
}

macro_rules! storage_from {
    ($($t:ty),*) => {$(
        impl From<$t> for CoordinatorError {
            fn from(e: $t) -> Self { CoordinatorError::Storage(e.to_string()) }
        }
    )*};
}
storage_from!(
    redb::Error,
    redb::DatabaseError,
    redb::TransactionError,
    redb::TableError,
    redb::StorageError,
    redb::CommitError,
    serde_json::Error
);

impl From<CoordinatorError> for tonic::Status {
    fn from(e: CoordinatorError) -> Self {
        match e {
            CoordinatorError::InvalidArgument(m) => tonic::Status::invalid_argument(m),
            CoordinatorError::NotFound(m) => tonic::Status::not_found(format!("{m} not found")),
            CoordinatorError::FailedPrecondition(m) => tonic::Status::failed_precondition(m),
            CoordinatorError::ResourceExhausted(m) => tonic::Status::resource_exhausted(m),
            other => tonic::Status::internal(other.to_string()),
        }
    }
}
