//! Why a diagnosis stopped: the one error type of the crate's [`driver`](crate::driver), with
//! the context each step adds (as `anyhow`'s `context` does, but typed, so that a caller can
//! tell a bad job from a failed evaluation). [`Error::one_line`] writes it with its causes, as
//! the report and the command line show it.

use fmucal_shared::job::JobError;

/// A failed diagnosis step.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The job, its data or its model refused something; names the field.
    #[error(transparent)]
    Job(#[from] JobError),
    /// Whatever ran the simulations (a coordinator, this process) failed.
    #[error(transparent)]
    Evaluate(Box<dyn std::error::Error + Send + Sync>),
    /// A check of the diagnosis's own, in words that name the field.
    #[error("{0}")]
    Message(String),
    /// What was being done when `source` happened.
    #[error("{context}")]
    Context {
        context: String,
        #[source]
        source: Box<Error>,
    },
}

impl Error {
    /// An error in words.
    pub fn msg(message: impl Into<String>) -> Self {
        Error::Message(message.into())
    }

    /// The error of an evaluator.
    pub fn evaluate(e: impl Into<Box<dyn std::error::Error + Send + Sync>>) -> Self {
        Error::Evaluate(e.into())
    }

    /// The error and its causes on one line, each after a colon (as `anyhow` writes `{:#}`).
    pub fn one_line(&self) -> String {
        let mut line = self.to_string();
        let mut cause = std::error::Error::source(self);
        while let Some(c) = cause {
            line.push_str(": ");
            line.push_str(&c.to_string());
            cause = c.source();
        }
        line
    }
}

impl From<fmucal_shared::sim::SimError> for Error {
    fn from(e: fmucal_shared::sim::SimError) -> Self {
        Error::Job(e.into())
    }
}

impl From<fmucal_shared::optim::OptimError> for Error {
    fn from(e: fmucal_shared::optim::OptimError) -> Self {
        Error::Job(e.into())
    }
}

/// A failed step with what it was doing.
pub trait Context<T> {
    /// `context` in front of the error, as the step that failed.
    fn context(self, context: impl Into<String>) -> Result<T, Error>;
}

impl<T, E: Into<Error>> Context<T> for Result<T, E> {
    fn context(self, context: impl Into<String>) -> Result<T, Error> {
        self.map_err(|e| Error::Context { context: context.into(), source: Box::new(e.into()) })
    }
}

impl<T> Context<T> for Option<T> {
    fn context(self, context: impl Into<String>) -> Result<T, Error> {
        self.ok_or_else(|| Error::Message(context.into()))
    }
}

/// Returns early with an [`Error::Message`] (for the driver's checks).
#[cfg(feature = "driver")]
macro_rules! bail {
    ($($arg:tt)*) => { return Err($crate::error::Error::msg(format!($($arg)*))) };
}
#[cfg(feature = "driver")]
pub(crate) use bail;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_line_writes_every_cause_after_a_colon() {
        let e: Result<(), JobError> = Err(JobError::invalid("outputs[0].column", "no such column"));
        let e = e.context("the base calibration").unwrap_err();
        assert_eq!(e.one_line(), "the base calibration: outputs[0].column: no such column");
        assert_eq!(e.to_string(), "the base calibration");
    }
}
