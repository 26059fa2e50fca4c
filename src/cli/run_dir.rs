//! The temporary folder of a local run (`fmucal calibrate` or `diagnose` without
//! `--coordinator`) and the worker processes' tie to the run.
//!
//! A run's folder is `$TMPDIR/fmucal-run-XXXXXX` and holds an `owner` file naming the process
//! that made it (its pid and its start time, so a reused pid is not mistaken for it). A run
//! killed with SIGKILL cannot remove its folder; the next run does: it removes every
//! `fmucal-run-*` folder of this user whose `owner` file names a process that no longer runs.
//! A folder without a readable `owner` file (another program's, or one being made this very
//! moment) and a running run's folder are never touched.
//!
//! Worker processes die with the run: each sets its parent-death signal to SIGKILL when the
//! run asks it to ([`die_with_parent`], Linux), so a SIGKILL of the run takes its workers with
//! it.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};

/// The prefix of a run folder's name.
pub const PREFIX: &str = "fmucal-run-";

/// The file in a run folder naming its owner: `PID START_TIME PID_NAMESPACE` (the start time
/// in clock ticks after boot; the namespace as `/proc/self/ns/pid` names it, so a run in
/// another container sharing the folder is never judged by a pid that is not its own).
const OWNER: &str = "owner";

/// A local run's temporary folder, removed when dropped.
pub struct RunDir {
    dir: tempfile::TempDir,
}

impl RunDir {
    /// Removes the folders of dead runs in the temporary folder, then makes this run's.
    ///
    /// # Errors
    /// If the folder or its owner file cannot be written.
    pub fn create() -> Result<RunDir> {
        let parent = std::env::temp_dir();
        let removed = remove_stale(&parent);
        if removed > 0 {
            tracing::info!(removed, "removed the folders of local runs that were killed");
        }
        let dir = tempfile::Builder::new()
            .prefix(PREFIX)
            .tempdir_in(&parent)
            .with_context(|| format!("cannot make a run folder in {}", parent.display()))?;
        let me = std::process::id();
        let line = format!("{me} {} {}\n", start_time(me).unwrap_or_default(), pid_namespace().unwrap_or_default());
        std::fs::write(dir.path().join(OWNER), line).context("cannot write the run folder's owner file")?;
        Ok(RunDir { dir })
    }

    pub fn path(&self) -> &Path {
        self.dir.path()
    }
}

/// Removes the `fmucal-run-*` folders under `parent` that belong to this user and whose owner
/// no longer runs; returns how many.
pub fn remove_stale(parent: &Path) -> usize {
    let Ok(entries) = std::fs::read_dir(parent) else { return 0 };
    let me = my_uid();
    let mut removed = 0;
    for entry in entries.flatten() {
        let (path, name) = (entry.path(), entry.file_name());
        // `symlink_metadata`: a link named like a run folder is not followed.
        let Ok(meta) = std::fs::symlink_metadata(&path) else { continue };
        if !name.to_string_lossy().starts_with(PREFIX) || !meta.is_dir() || me.is_none_or(|me| uid(&meta) != me) {
            continue;
        }
        if owner_is_dead(&path) && std::fs::remove_dir_all(&path).is_ok() {
            tracing::debug!(folder = %path.display(), "removed a killed run's folder");
            removed += 1;
        }
    }
    removed
}

/// Whether the owner file of `dir` names a process that no longer runs (false if it cannot
/// tell: no owner file, an unreadable one, or no `/proc`).
fn owner_is_dead(dir: &Path) -> bool {
    let Ok(text) = std::fs::read_to_string(dir.join(OWNER)) else { return false };
    let mut words = text.split_whitespace();
    let (Some(Ok(pid)), Some(Ok(started)), Some(namespace)) =
        (words.next().map(str::parse::<u32>), words.next().map(str::parse::<u64>), words.next())
    else {
        return false;
    };
    if pid_namespace().is_none_or(|mine| mine != namespace) {
        return false;
    }
    // Alive only if a process of that pid runs and started when the owner did.
    start_time(pid) != Some(started)
}

/// The start time of process `pid` (field 22 of `/proc/PID/stat`, clock ticks after boot).
fn start_time(pid: u32) -> Option<u64> {
    let stat = std::fs::read_to_string(PathBuf::from(format!("/proc/{pid}/stat"))).ok()?;
    // The command name (field 2) is in parentheses and may hold spaces: count after it.
    let after = &stat[stat.rfind(')')? + 1..];
    after.split_whitespace().nth(19)?.parse().ok()
}

/// This process's pid namespace (`pid:[4026531836]`), if `/proc` tells it.
fn pid_namespace() -> Option<String> {
    let ns = std::fs::read_link("/proc/self/ns/pid").ok()?;
    Some(ns.to_string_lossy().into_owned()).filter(|n| !n.is_empty() && !n.contains(char::is_whitespace))
}

#[cfg(unix)]
fn uid(meta: &std::fs::Metadata) -> u32 {
    std::os::unix::fs::MetadataExt::uid(meta)
}

#[cfg(not(unix))]
fn uid(_: &std::fs::Metadata) -> u32 {
    0
}

/// This process's user id (the owner of `/proc/self`), if it can be told.
fn my_uid() -> Option<u32> {
    std::fs::metadata("/proc/self").ok().map(|m| uid(&m))
}

/// The environment variable that asks a worker to die with the process named in it.
const DIE_WITH_PARENT: &str = "FMUCAL_DIE_WITH_PARENT";

/// Asks `cmd`'s process, a worker, to receive SIGKILL when the thread that starts it ends
/// (Linux's parent-death signal, set by the worker itself: [`die_with_parent_if_asked`]). The
/// local cluster starts its workers from the thread that runs the whole run, so they die with
/// the run, also when it is killed with SIGKILL. Elsewhere the workers go when the run ends
/// normally, through `kill_on_drop`.
pub fn die_with_parent(cmd: &mut tokio::process::Command) {
    cmd.env(DIE_WITH_PARENT, std::process::id().to_string());
}

/// In a worker started by [`die_with_parent`]: sets the parent-death signal to SIGKILL, and
/// exits at once if the parent named is already gone (it may have died before the signal was
/// set). Does nothing when not asked, or off Linux.
///
/// # Errors
/// If the parent-death signal cannot be set.
pub fn die_with_parent_if_asked() -> Result<()> {
    let Some(parent) = std::env::var(DIE_WITH_PARENT).ok().and_then(|p| p.parse::<i32>().ok()) else {
        return Ok(());
    };
    #[cfg(target_os = "linux")]
    {
        nix::sys::prctl::set_pdeathsig(nix::sys::signal::Signal::SIGKILL)
            .context("cannot set the parent-death signal")?;
        if nix::unistd::getppid().as_raw() != parent {
            std::process::exit(1);
        }
    }
    #[cfg(not(target_os = "linux"))]
    let _ = parent;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_dead_runs_folders_are_removed() {
        let parent = tempfile::tempdir().unwrap();
        let make = |name: &str, owner: Option<String>| {
            let d = parent.path().join(name);
            std::fs::create_dir(&d).unwrap();
            if let Some(o) = owner {
                std::fs::write(d.join(OWNER), o).unwrap();
            }
            d
        };
        let (me, ns) = (std::process::id(), pid_namespace().unwrap());
        let alive = make("fmucal-run-alive", Some(format!("{me} {} {ns}", start_time(me).unwrap())));
        // A pid that ran, with a start time it never had: the run is gone (or the pid reused).
        let dead = make("fmucal-run-dead", Some(format!("{me} 1 {ns}")));
        let no_owner = make("fmucal-run-new", None);
        let other = make("other-program", Some(format!("{me} 1 {ns}")));
        // Another container's run: its pids are not ours to look up.
        let elsewhere = make("fmucal-run-elsewhere", Some(format!("{me} 1 pid:[1]")));
        assert_eq!(remove_stale(parent.path()), 1);
        assert!(!dead.exists());
        assert!(alive.exists() && no_owner.exists() && other.exists() && elsewhere.exists());
    }
}
