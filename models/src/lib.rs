//! fmucal's example FMUs, built from `models/c` by this crate's build script: the paper's two
//! examples (Furuta pendulum, diesel exhaust pipe), a bouncing ball (state events), Robertson
//! kinetics (stiff), and Decay (resources, declared types, aliases, time events, failures).
//! Each offers Model Exchange and Co-Simulation with a linux64 binary.

use std::path::PathBuf;

/// Folder holding the built `.fmu` files.
pub fn fmu_dir() -> PathBuf {
    PathBuf::from(env!("OUT_DIR")).join("fmus")
}

/// The example models: (short name, path of the `.fmu`).
pub fn examples() -> Vec<(&'static str, PathBuf)> {
    [
        ("furuta", "Furuta"),
        ("bouncing-ball", "BouncingBall"),
        ("decay", "Decay"),
        ("robertson", "Robertson"),
        ("exhaust-pipe", "ExhaustPipe"),
    ]
    .into_iter()
    .map(|(name, id)| (name, fmu_dir().join(format!("{id}.fmu"))))
    .collect()
}

/// Path of an example by its short name (`furuta`, `bouncing-ball`, ...), if it exists.
pub fn example(name: &str) -> Option<PathBuf> {
    examples().into_iter().find(|(n, _)| *n == name).map(|(_, p)| p)
}

/// Test fixture: the Decay FMU with `fmi2GetReal` missing from its binary.
pub fn missing_symbol_fixture() -> PathBuf {
    fmu_dir().join("MissingSymbol.fmu")
}

/// Test fixture: the Decay FMU whose `fmi2Reset` always returns `fmi2Error`.
pub fn reset_fails_fixture() -> PathBuf {
    fmu_dir().join("ResetFails.fmu")
}
