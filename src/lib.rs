//! The `fmucal` command-line interface, kept as a library so tests can call it.
pub mod cli;
