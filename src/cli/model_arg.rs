//! Resolves the MODEL argument: a path to an `.fmu`, or `example:NAME` / a bare example name
//! for the FMUs built into fmucal (see `fmucal examples`).

use std::path::PathBuf;

use anyhow::{Result, bail};

pub fn resolve(arg: &str) -> Result<PathBuf> {
    let name = arg.strip_prefix("example:");
    let path = PathBuf::from(arg);
    if name.is_none() && path.exists() {
        return Ok(path);
    }
    let name = name.unwrap_or(arg);
    if let Some(p) = fmucal_models::example(name) {
        return Ok(p);
    }
    let names: Vec<_> = fmucal_models::examples().into_iter().map(|(n, _)| n).collect();
    bail!("no such file {arg:?}, and no built-in example of that name (examples: {})", names.join(", "))
}
