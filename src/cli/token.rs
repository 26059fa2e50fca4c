//! The shared token: from `FMUCAL_TOKEN`, a `--token-file`, or freshly generated for local runs.

use std::path::Path;

use anyhow::{Context, Result};

/// `--token-file` if given, else `FMUCAL_TOKEN`, else none.
pub fn load(file: Option<&Path>) -> Result<Option<String>> {
    if let Some(f) = file {
        let t = std::fs::read_to_string(f).with_context(|| format!("cannot read token file {}", f.display()))?;
        let t = t.trim().to_owned();
        anyhow::ensure!(!t.is_empty(), "token file {} is empty", f.display());
        return Ok(Some(t));
    }
    Ok(std::env::var("FMUCAL_TOKEN").ok().map(|t| t.trim().to_owned()).filter(|t| !t.is_empty()))
}

/// 32 random hex characters from the operating system.
pub fn generate() -> Result<String> {
    let mut bytes = [0u8; 16];
    use std::io::Read;
    std::fs::File::open("/dev/urandom")
        .and_then(|mut f| f.read_exact(&mut bytes))
        .context("cannot read /dev/urandom")?;
    Ok(bytes.iter().map(|b| format!("{b:02x}")).collect())
}
