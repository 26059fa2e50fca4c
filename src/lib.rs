//! The `fmucal` command-line interface and the calibration report (plots), kept as a library
//! so tests can call them.
pub mod cli;
pub mod report;
