//! Resolves the MODEL argument: a path to an `.fmu`, or `example:NAME` / a bare example name
//! for the FMUs built into fmucal (see `fmucal examples`). Examples are embedded in the binary
//! and written to `<cache dir>/examples/` on first use, so they work from any installed binary.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};

/// Where the built-in examples are written: `examples/` in the unpack cache folder.
pub fn examples_dir() -> PathBuf {
    fmucal_shared::fmu::archive::default_cache_dir().join("examples")
}

/// The path of built-in example `name`, written out if needed; `None` if there is no such
/// example.
///
/// # Errors
/// If the example cannot be written to [`examples_dir`].
pub fn example(name: &str) -> Result<Option<PathBuf>> {
    let dir = examples_dir();
    fmucal_models::install_example(name, &dir)
        .with_context(|| format!("cannot write example {name:?} to {}", dir.display()))
}

pub fn resolve(arg: &str) -> Result<PathBuf> {
    let name = arg.strip_prefix("example:");
    if name.is_none() && Path::new(arg).exists() {
        return Ok(PathBuf::from(arg));
    }
    let name = name.unwrap_or(arg);
    if let Some(p) = example(name)? {
        return Ok(p);
    }
    bail!(
        "no such file {arg:?}, and no built-in example of that name (examples: {})",
        fmucal_models::example_names().join(", ")
    )
}
