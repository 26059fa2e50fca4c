//! Discrepancy discovery (issue 10): finding where a calibrated model and its measurements
//! disagree. So far this holds the residual analysis of the localise step ([`residuals`]:
//! RMS per time window, Ljung–Box whiteness, correlation with candidate signals); effects,
//! candidate screening and the `diagnose` command build on it.

pub mod residuals;
