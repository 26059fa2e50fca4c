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
    serde_json::Error,
    crate::journal::JournalError
);

/// Most characters of an error message sent back (it travels in the `grpc-message` header,
/// which clients cap at a few kB).
pub const MAX_MESSAGE_CHARS: usize = 1000;

/// User text in a message: bounded and escaped, as every fmucal error quotes it.
pub(crate) use fmucal_shared::quote::quote_user_text as quote;

/// `c` as a message shows it: control characters and bidirectional formatting characters (which
/// reorder the text a terminal shows) escaped, every other character as is.
fn escaped(c: char) -> Vec<char> {
    let bidi = matches!(c, '\u{200e}' | '\u{200f}' | '\u{202a}'..='\u{202e}' | '\u{2066}'..='\u{2069}');
    if c.is_control() || bidi { c.escape_default().collect() } else { vec![c] }
}

/// A message safe to send back whatever it quotes: escaped as [`quote`] escapes, and cut in the
/// middle (keeping its start, which names the field, and its end) past [`MAX_MESSAGE_CHARS`].
pub fn bounded_message(message: &str) -> String {
    let chars: Vec<char> = message.chars().flat_map(escaped).collect();
    if chars.len() <= MAX_MESSAGE_CHARS {
        return chars.into_iter().collect();
    }
    let (head, tail) = (MAX_MESSAGE_CHARS * 3 / 4, MAX_MESSAGE_CHARS / 5);
    let cut = chars.len() - head - tail;
    let mut out: String = chars[..head].iter().collect();
    out.push_str(&format!(" …({cut} characters cut)… "));
    out.extend(&chars[chars.len() - tail..]);
    out
}

impl From<CoordinatorError> for tonic::Status {
    fn from(e: CoordinatorError) -> Self {
        match e {
            CoordinatorError::InvalidArgument(m) => tonic::Status::invalid_argument(bounded_message(&m)),
            CoordinatorError::NotFound(m) => tonic::Status::not_found(bounded_message(&format!("{m} not found"))),
            CoordinatorError::FailedPrecondition(m) => tonic::Status::failed_precondition(bounded_message(&m)),
            CoordinatorError::ResourceExhausted(m) => tonic::Status::resource_exhausted(bounded_message(&m)),
            other => tonic::Status::internal(bounded_message(&other.to_string())),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_long_message_keeps_its_field_and_its_end() {
        let m = format!("parameters[0].name: no variable named {} in the model", "y".repeat(1 << 20));
        let status = tonic::Status::from(CoordinatorError::InvalidArgument(m));
        assert_eq!(status.code(), tonic::Code::InvalidArgument);
        let text = status.message();
        assert!(text.chars().count() < MAX_MESSAGE_CHARS + 50, "{} characters", text.len());
        assert!(text.starts_with("parameters[0].name: no variable named yyy"), "{text}");
        assert!(text.ends_with("yyy in the model") && text.contains("characters cut"), "{text}");
    }
}
