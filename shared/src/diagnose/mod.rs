//! Discrepancy discovery (issue 10): finding where a calibrated model and its measurements
//! disagree. So far this holds the residual analysis of the localise step ([`residuals`]:
//! RMS per time window, Ljung–Box whiteness, correlation with candidate signals) and the
//! library of candidate effects with their formulas ([`effects`]); injecting effects into a
//! simulation, candidate screening and the `diagnose` command build on them.

pub mod effects;
pub mod residuals;
