//! Discrepancy discovery: finding where a calibrated model and its measurements
//! disagree, which effect the model lacks, and whether adding it pays.
//!
//! - [`spec`]: the job file's `[diagnose]` section.
//! - [`places`]: where a diagnosis may add effects (ports by hand and from the model's
//!   [`structure`](fmucal_shared::structure), states in Model Exchange), each a kind of the
//!   [`effects`](fmucal_shared::effects) library sized by its [`guess`](fmucal_shared::effects::guess).
//! - [`localise`]: the residual analysis (RMS per window, whiteness, correlation with candidate
//!   signals) with the statistics of [`residuals`](fmucal_shared::residuals).
//! - [`candidates`]: candidate generation and screening by the score statistic.
//! - [`jobs`]: the candidate calibrations and next-round bases built from the base job.
//! - [`decision`]: the three tests an effect must pass to be named.
//! - [`report`]: what a diagnosis found (`diagnosis/report.json`) and its summary.
//!
//! The effect library, the structure reader and the residual statistics sit below this module
//! (simulation and jobs use them too); nothing below it uses the diagnosis, except the job
//! file's `[diagnose]` section, which a job carries for `fmucal diagnose`.
//!
//! - [`error`]: why a diagnosis stopped.
//! - `driver` (feature `driver`): the rounds of a diagnosis, one function per phase, over an
//!   evaluator (the command line's gRPC client, so the simulations run on the workers), with
//!   progress to an observer. The `fmucal` binary turns the feature on; the coordinator runs a
//!   diagnosis as that binary's child process, so it never loads model code.

#![forbid(unsafe_code)]

pub mod candidates;
pub mod decision;
#[cfg(feature = "driver")]
pub mod driver;
pub mod error;
pub mod jobs;
pub mod localise;
pub mod places;
pub mod report;
pub mod spec;
