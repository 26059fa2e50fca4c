//! What an FMU instance logs through the FMI logger callback: each message is sent to
//! `tracing` (target `fmu`) once per instance and status, repeats are counted and summed up in
//! one line when the instance is freed, and the latest warnings and errors are kept so a failed
//! call can quote what the model said. The C side (the variadic callback) is in [`super::ffi`].
//!
//! Exported FMUs often repeat one message at every call (a warning per `fmi2SetupExperiment`,
//! per derivative evaluation); a calibration of thousands of simulations would otherwise print
//! it thousands of times.
#![deny(unsafe_code)]

use std::collections::{HashMap, VecDeque};
use std::sync::Mutex;

use super::ffi::Status;

/// Distinct messages remembered per instance. Past it, new warnings and errors are still logged
/// (without counting their repeats) and new informational messages are counted, not logged.
const MAX_DISTINCT: usize = 1024;

/// Distinct warnings and errors kept for error reports.
const KEEP_RECENT: usize = 16;

#[derive(Debug, Default)]
struct Seen {
    /// (status, category, message) → times received.
    counts: HashMap<(Status, String, String), u64>,
    /// Order of first arrival, for a stable summary.
    order: Vec<(Status, String, String)>,
    /// New distinct informational messages received after `MAX_DISTINCT` was reached.
    dropped: u64,
    instance: String,
}

/// The log of one FMU instance.
#[derive(Debug, Default)]
pub struct InstanceLog {
    recent: Mutex<VecDeque<String>>,
    seen: Mutex<Seen>,
}

/// Sends one message to `tracing` at the level its status calls for.
pub(super) fn emit(status: Status, instance: &str, category: &str, message: &str) {
    match status {
        Status::Ok | Status::Pending => tracing::debug!(target: "fmu", %instance, %category, "{message}"),
        Status::Warning | Status::Discard => tracing::warn!(target: "fmu", %instance, %category, "{message}"),
        // Errors also travel in the returned FmuError::Call; log them quietly here.
        Status::Error | Status::Fatal => tracing::info!(target: "fmu", %instance, %category, "{message}"),
    }
}

impl InstanceLog {
    /// Takes one message from the FMU: logs it if it is new for this instance, status and
    /// category, counts it otherwise, and keeps it for error reports if it is a warning or
    /// worse (once: a warning repeated at every call does not crowd out the others).
    pub fn receive(&self, status: Status, instance: &str, category: &str, message: &str) {
        if status >= Status::Warning {
            let mut recent = self.recent.lock().unwrap_or_else(|p| p.into_inner());
            if !recent.iter().any(|m| m == message) {
                if recent.len() == KEEP_RECENT {
                    recent.pop_front();
                }
                recent.push_back(message.to_owned());
            }
        }
        let mut seen = self.seen.lock().unwrap_or_else(|p| p.into_inner());
        if seen.instance.is_empty() {
            seen.instance = instance.to_owned();
        }
        let key = (status, category.to_owned(), message.to_owned());
        if let Some(n) = seen.counts.get_mut(&key) {
            *n += 1;
            return;
        }
        if seen.counts.len() >= MAX_DISTINCT {
            if status >= Status::Warning {
                drop(seen);
                emit(status, instance, category, message);
            } else {
                seen.dropped += 1;
            }
            return;
        }
        seen.counts.insert(key.clone(), 1);
        seen.order.push(key);
        drop(seen);
        emit(status, instance, category, message);
    }

    /// Takes the distinct warnings and errors logged since the last call (at most the latest
    /// 16).
    pub fn drain(&self) -> Vec<String> {
        self.recent.lock().unwrap_or_else(|p| p.into_inner()).drain(..).collect()
    }

    /// Logs, once, how often each repeated message came after its first time, and how many
    /// distinct messages were not logged because the instance logged too many different ones.
    /// Called when the instance is freed.
    pub fn summarize(&self) {
        let mut seen = self.seen.lock().unwrap_or_else(|p| p.into_inner());
        let seen = std::mem::take(&mut *seen);
        for key in &seen.order {
            let n = seen.counts[key];
            if n > 1 {
                let (status, category, message) = key;
                emit(*status, &seen.instance, category, &format!("{message} (repeated {} more times)", n - 1));
            }
        }
        if seen.dropped > 0 {
            tracing::warn!(
                target: "fmu",
                instance = %seen.instance,
                "{} further distinct informational messages were not logged (more than {MAX_DISTINCT} from one instance)",
                seen.dropped
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn repeats_are_counted_and_errors_kept_for_reports() {
        let log = InstanceLog::default();
        for _ in 0..5 {
            log.receive(Status::Warning, "i", "cat", "same");
        }
        log.receive(Status::Ok, "i", "cat", "info");
        log.receive(Status::Error, "i", "cat", "bad");
        let seen = log.seen.lock().unwrap();
        assert_eq!(seen.counts[&(Status::Warning, "cat".into(), "same".into())], 5);
        assert_eq!(seen.order.len(), 3);
        drop(seen);
        // Kept for error reports: each distinct warning or error once, not OK messages.
        assert_eq!(log.drain(), ["same", "bad"]);
        assert!(log.drain().is_empty());
    }

    #[test]
    fn distinct_messages_are_capped_but_warnings_are_never_silenced() {
        let log = InstanceLog::default();
        for i in 0..MAX_DISTINCT + 10 {
            log.receive(Status::Ok, "i", "cat", &format!("message {i}"));
        }
        log.receive(Status::Warning, "i", "cat", "late warning");
        let seen = log.seen.lock().unwrap();
        assert_eq!(seen.counts.len(), MAX_DISTINCT);
        assert_eq!(seen.dropped, 10);
        drop(seen);
        assert_eq!(log.drain(), ["late warning"]);
    }
}
