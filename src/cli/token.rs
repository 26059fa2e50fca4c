//! The tokens: the client token (`FMUCAL_TOKEN` or `--token-file`) and the optional worker
//! token (`FMUCAL_WORKER_TOKEN` or `--worker-token-file`), or freshly generated for local runs.

use std::path::Path;

use anyhow::{Context, Result};

/// `--token-file` if given, else `FMUCAL_TOKEN`, else none.
pub fn load(file: Option<&Path>) -> Result<Option<String>> {
    from_file_or_env(file, &["FMUCAL_TOKEN"])
}

/// The coordinator's worker token: `--worker-token-file` if given, else `FMUCAL_WORKER_TOKEN`,
/// else none (workers then use the client token).
pub fn load_worker_token(file: Option<&Path>) -> Result<Option<String>> {
    from_file_or_env(file, &["FMUCAL_WORKER_TOKEN"])
}

/// The token a worker presents: `--token-file` if given, else `FMUCAL_WORKER_TOKEN`, else
/// `FMUCAL_TOKEN`.
pub fn load_for_worker(file: Option<&Path>) -> Result<Option<String>> {
    from_file_or_env(file, &["FMUCAL_WORKER_TOKEN", "FMUCAL_TOKEN"])
}

/// The trimmed contents of `file`, else of the first of `vars` that is set and not blank.
fn from_file_or_env(file: Option<&Path>, vars: &[&str]) -> Result<Option<String>> {
    if let Some(f) = file {
        let t = std::fs::read_to_string(f).with_context(|| format!("cannot read token file {}", f.display()))?;
        let t = t.trim().to_owned();
        anyhow::ensure!(!t.is_empty(), "token file {} is empty", f.display());
        return Ok(Some(t));
    }
    Ok(vars.iter().find_map(|v| std::env::var(v).ok().map(|t| t.trim().to_owned()).filter(|t| !t.is_empty())))
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
