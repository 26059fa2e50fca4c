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

/// Conformance fixture: a stick-slip friction oscillator driven by a continuous input `F`
/// (stiction, Coulomb friction, event indicators on the velocity and on the force balance).
pub fn stick_slip_fixture() -> PathBuf {
    fmu_dir().join("StickSlip.fmu")
}

/// Conformance fixture: a continuous Real, a discrete Real, an Integer and a Boolean input,
/// with the FMI rule that discrete inputs cannot be set in Continuous-Time Mode enforced.
pub fn input_kinds_fixture() -> PathBuf {
    fmu_dir().join("InputKinds.fmu")
}

/// Conformance fixture: a comparator without continuous states whose one event indicator only
/// its continuous input `u` moves.
pub fn threshold_fixture() -> PathBuf {
    fmu_dir().join("Threshold.fmu")
}

/// Conformance fixture: the bouncing ball with `derivative` attributes on variables that
/// `ModelStructure/Derivatives` does not list (aliases, non-state velocities).
pub fn derivative_attributes_fixture() -> PathBuf {
    fmu_dir().join("DerivativeAttributes.fmu")
}
