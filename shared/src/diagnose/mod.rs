//! Discrepancy discovery: finding where a calibrated model and its measurements
//! disagree, which effect the model lacks, and whether adding it pays.
//!
//! - [`effects`]: the library of effect kinds with their formulas;
//!   [`guess`]: how a diagnosis sizes a kind it was not told about.
//! - [`spec`]: the job file's `[diagnose]` section.
//! - [`structure`]: the model's states, their quantities and position/velocity pairs, and its
//!   injection inputs, read from the model description; [`places`]: where a diagnosis may add
//!   effects (ports by hand and from the structure, states in Model Exchange).
//! - [`residuals`] and [`localise`]: the residual analysis (RMS per window, whiteness,
//!   correlation with candidate signals).
//! - [`candidates`]: candidate generation and screening by the score statistic.
//! - [`jobs`]: the candidate calibrations and next-round bases built from the base job.
//! - [`decision`]: the three tests an effect must pass to be named.
//! - [`report`]: what a diagnosis found (`diagnosis/report.json`) and its summary.
//!
//! The steps that need simulations (calibrations, screening points) are driven by
//! `fmucal diagnose` over the coordinator's protocol, so they run on the workers.

pub mod candidates;
pub mod decision;
pub mod effects;
pub mod guess;
pub mod jobs;
pub mod localise;
pub mod places;
pub mod report;
pub mod residuals;
pub mod spec;
pub mod structure;
