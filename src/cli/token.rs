//! The tokens: the client token (`FMUCAL_TOKEN` or `--token-file`) and the optional worker
//! token (`FMUCAL_WORKER_TOKEN` or `--worker-token-file`), or freshly generated for local runs.

use std::path::Path;

use anyhow::{Context, Result};

/// `--token-file` if given, else `FMUCAL_TOKEN`, else none.
pub fn load(file: Option<&Path>) -> Result<Option<String>> {
    from_file_or_env("--token-file", file, &["FMUCAL_TOKEN"])
}

/// The coordinator's worker token: `--worker-token-file` if given, else `FMUCAL_WORKER_TOKEN`,
/// else none (workers then use the client token).
pub fn load_worker_token(file: Option<&Path>) -> Result<Option<String>> {
    from_file_or_env("--worker-token-file", file, &["FMUCAL_WORKER_TOKEN"])
}

/// The token a worker presents: `--token-file` if given, else `FMUCAL_WORKER_TOKEN`, else
/// `FMUCAL_TOKEN`.
pub fn load_for_worker(file: Option<&Path>) -> Result<Option<String>> {
    from_file_or_env("--token-file", file, &["FMUCAL_WORKER_TOKEN", "FMUCAL_TOKEN"])
}

/// Characters a token read from a file must have at least: a typo'd or truncated file (one
/// character, a stray newline) is refused rather than used as a guessable secret.
pub const MIN_TOKEN_FILE_CHARS: usize = 12;

/// Bytes of a token file read at most (a token is a line; `/dev/zero` is no token file).
const MAX_TOKEN_FILE_BYTES: u64 = 64 * 1024;

/// The trimmed contents of `file` (given in `flag`), else of the first of `vars` that is set
/// and not blank.
fn from_file_or_env(flag: &str, file: Option<&Path>, vars: &[&str]) -> Result<Option<String>> {
    if let Some(f) = file {
        fmucal_shared::job::limits::check_regular_file(flag, f, MAX_TOKEN_FILE_BYTES)?;
        let t = std::fs::read_to_string(f).with_context(|| format!("{flag}: cannot read {}", f.display()))?;
        let t = t.trim().to_owned();
        let n = t.chars().count();
        anyhow::ensure!(
            n >= MIN_TOKEN_FILE_CHARS,
            "{flag}: the token in {} is {n} characters long; a token needs at least {MIN_TOKEN_FILE_CHARS} (make one with `openssl rand -hex 16`)",
            f.display()
        );
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
