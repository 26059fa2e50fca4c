//! fmucal's example FMUs, built from `models/c` by this crate's build script: the paper's two
//! examples (Furuta pendulum, diesel exhaust pipe), a bouncing ball (state events), Robertson
//! kinetics (stiff), and Decay (resources, declared types, aliases, time events, failures).
//! Each offers Model Exchange and Co-Simulation with a linux64 binary.
//!
//! The examples' bytes are embedded in every binary that links this crate, so `example:NAME`
//! works from `cargo install` or a container image: [`install_example`] writes one into a
//! folder the first time it is asked for. [`example`] and [`Fixture::path`] point into the
//! build tree, for tests and benchmarks.

use std::io::Write;
use std::path::{Path, PathBuf};

/// Folder holding the built `.fmu` files (exists only where this crate was built).
pub fn fmu_dir() -> PathBuf {
    PathBuf::from(env!("OUT_DIR")).join("fmus")
}

macro_rules! embedded {
    ($($name:literal => $id:literal),* $(,)?) => {
        /// (short name, model identifier, archive bytes) of each example.
        const EMBEDDED: &[(&str, &str, &[u8])] = &[
            $(($name, $id, include_bytes!(concat!(env!("OUT_DIR"), "/fmus/", $id, ".fmu")))),*
        ];
    };
}

embedded! {
    "furuta" => "Furuta",
    "bouncing-ball" => "BouncingBall",
    "decay" => "Decay",
    "robertson" => "Robertson",
    "exhaust-pipe" => "ExhaustPipe",
}

/// The examples' short names (`furuta`, `bouncing-ball`, ...).
pub fn example_names() -> Vec<&'static str> {
    EMBEDDED.iter().map(|(name, _, _)| *name).collect()
}

/// Writes the example `name` as `dir/<ModelIdentifier>.fmu`, unless an identical file is there
/// already, and returns its path; `None` if there is no such example. The file is written to
/// a temporary name and renamed, so concurrent callers never see half a file.
///
/// # Errors
/// The I/O error of creating `dir` or writing the file.
pub fn install_example(name: &str, dir: &Path) -> std::io::Result<Option<PathBuf>> {
    let Some((_, id, bytes)) = EMBEDDED.iter().find(|(n, _, _)| *n == name) else {
        return Ok(None);
    };
    let path = dir.join(format!("{id}.fmu"));
    if std::fs::read(&path).is_ok_and(|have| have == *bytes) {
        return Ok(Some(path));
    }
    std::fs::create_dir_all(dir)?;
    let tmp = dir.join(format!(".{id}.fmu.{}.tmp", std::process::id()));
    std::fs::File::create(&tmp)?.write_all(bytes)?;
    std::fs::rename(&tmp, &path)?;
    Ok(Some(path))
}

/// The example models in the build tree: (short name, path of the `.fmu`). For tests and
/// benchmarks; binaries use [`install_example`].
pub fn examples() -> Vec<(&'static str, PathBuf)> {
    EMBEDDED.iter().map(|(name, id, _)| (*name, fmu_dir().join(format!("{id}.fmu")))).collect()
}

/// Path of an example in the build tree by its short name, if it exists.
pub fn example(name: &str) -> Option<PathBuf> {
    examples().into_iter().find(|(n, _)| *n == name).map(|(_, p)| p)
}

/// The test fixtures: FMUs built like the examples but not listed as examples, either broken or
/// behaving as tool-exported FMUs do.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Fixture {
    /// The Decay FMU with `fmi2GetReal` missing from its binary.
    MissingSymbol,
    /// The Decay FMU whose `fmi2Reset` always returns `fmi2Error`.
    ResetFails,
    /// Conformance: a stick-slip friction oscillator driven by a continuous input `F`
    /// (stiction, Coulomb friction, event indicators on the velocity and on the force balance).
    StickSlip,
    /// Conformance: a continuous Real, a discrete Real, an Integer and a Boolean input, with the
    /// FMI rule that discrete inputs cannot be set in Continuous-Time Mode enforced.
    InputKinds,
    /// Conformance: a comparator without continuous states whose one event indicator only its
    /// continuous input `u` moves.
    Threshold,
    /// Conformance: the bouncing ball with `derivative` attributes on variables that
    /// `ModelStructure/Derivatives` does not list (aliases, non-state velocities).
    DerivativeAttributes,
    /// Discrepancy: the Furuta pendulum with Coulomb friction (0.004 N·m, smoothed as
    /// fmucal's `coulomb_friction`) in the pendulum joint, in its C code but not in its
    /// description.
    FurutaHiddenCoulomb,
}

impl Fixture {
    /// Path of the fixture's `.fmu` in the build tree.
    pub fn path(self) -> PathBuf {
        let file = match self {
            Fixture::MissingSymbol => "MissingSymbol.fmu",
            Fixture::ResetFails => "ResetFails.fmu",
            Fixture::StickSlip => "StickSlip.fmu",
            Fixture::InputKinds => "InputKinds.fmu",
            Fixture::Threshold => "Threshold.fmu",
            Fixture::DerivativeAttributes => "DerivativeAttributes.fmu",
            Fixture::FurutaHiddenCoulomb => "FurutaHiddenCoulomb.fmu",
        };
        fmu_dir().join(file)
    }
}
