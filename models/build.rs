//! Compiles the example models' C sources into shared libraries with the `cc` crate's compiler
//! and packages each into a real `.fmu` (zip with modelDescription.xml, binaries/linux64,
//! sources/ and resources/). Also builds the fixture FMUs the tests need: broken ones
//! (MissingSymbol.fmu, ResetFails.fmu), ones that behave as tool-exported FMUs do
//! (StickSlip.fmu, InputKinds.fmu, Threshold.fmu, DerivativeAttributes.fmu), a spring–mass–damper
//! with an injection port (SpringMass.fmu), an array parameter's elements as scalars
//! (ArrayParams.fmu), FMI 3.0 and FMI 1.0 builds of the same C sources (below), and hidden-effect fixtures: a
//! model's C source built with a define that adds physics its (unchanged) description does not
//! mention, each exactly one of fmucal's effect formulas (shared/src/effects.rs):
//!
//! | fixture | base | define | effect |
//! |---|---|---|---|
//! | FurutaHiddenCoulomb.fmu | Furuta | `HIDDEN_PENDULUM_COULOMB=0.004` | pendulum joint −0.004·tanh(w/1e-3) N·m |
//! | FurutaHiddenSensorOffset.fmu | Furuta | `HIDDEN_ARM_SENSOR_OFFSET=0.1` | reported `armJoint.phi` + 0.1 rad |
//! | FurutaHiddenArmDrag.fmu | Furuta | `HIDDEN_ARM_QUADRATIC_DRAG=1e-3` | arm joint −1e-3·w·\|w\| N·m |
//! | SpringMassHiddenCubic.fmu | SpringMass | `HIDDEN_CUBIC_SPRING=0.2` | force −0.2·x³ N |
//! | ExhaustPipeHiddenRadiation.fmu | ExhaustPipe | `HIDDEN_RADIATION_AREA=0.2` | right wall 0.2·σ·(293.15⁴ − T_wall⁴) W |
//!
//! The magnitudes follow one criterion (tests/diagnosis_grid.rs, `EFFECT_OVER_NOISE`): on every
//! input profile of the diagnosis grid, each effect changes the outputs (RMS over them) by at
//! least the grid's largest noise floor (2 % of each output's range); each is the smallest
//! 1-2-5 value that does.
//!
//! Fixtures described as modelling tools export them (Dymola's FMI 2.0 shape: `declaredType`s
//! from `Modelica.Units.SI`, `der(x)` an alias of the velocity state, `dependencies` in
//! `ModelStructure`), without injection ports (the binary keeps its port, undeclared, at 0), and
//! hidden-effect variants of them (table `EXPORTED` below). "Change" is the largest over the
//! outputs of max |Δy| / range(y) on the DefaultExperiment, inputs at their starts, in FMPy:
//!
//! | fixture | base | description / define | effect | change |
//! |---|---|---|---|---|
//! | SpringMassExported.fmu | SpringMass | `xml/exported/SpringMassExported.xml`, `SPRING_MASS_X0=0.5` | none; `mass.Fext` undeclared, x(0) = 0.5 m | |
//! | FurutaExported.fmu | Furuta | `xml/exported/FurutaExported.xml` | none; `*.tauExt` undeclared | |
//! | ExhaustPipeExported.fmu | ExhaustPipe | `xml/exported/ExhaustPipeExported.xml` | none; `rightVolume.wallQext` undeclared | |
//! | SpringMassExportedHiddenCoulomb.fmu | SpringMassExported | `HIDDEN_COULOMB=0.05` | −0.05·tanh(v/1e-3) N | 10.6 % |
//! | SpringMassExportedHiddenStribeck.fmu | SpringMassExported | `HIDDEN_STRIBECK_COULOMB=0.05`, `_STATIC=0.1`, `_VELOCITY=0.1` | −(0.05 + 0.05·e^{−(v/0.1)²})·tanh(v/1e-3) N | 13.4 % |
//! | SpringMassExportedHiddenViscous.fmu | SpringMassExported | `HIDDEN_VISCOUS=0.2` | −0.2·v N | 11.6 % |
//! | SpringMassExportedHiddenQuadraticDrag.fmu | SpringMassExported | `HIDDEN_QUADRATIC_DRAG=0.5` | −0.5·v·\|v\| N | 13.5 % |
//! | SpringMassExportedHiddenCubic.fmu | SpringMassExported | `HIDDEN_CUBIC_SPRING=2` | −2·x³ N | 7.9 % |
//! | SpringMassExportedHiddenSensorOffset.fmu | SpringMassExported | `HIDDEN_POSITION_SENSOR_OFFSET=0.05` | reported `mass.x` + 0.05 m | 5.6 % |
//! | FurutaExportedHiddenCoulomb.fmu | FurutaExported | `HIDDEN_PENDULUM_COULOMB=0.004` | pendulum joint −0.004·tanh(w/1e-3) N·m | 14.9 % |
//! | ExhaustPipeExportedHiddenRadiation.fmu | ExhaustPipeExported | `HIDDEN_RADIATION_AREA=0.2` | right wall 0.2·σ·(293.15⁴ − T_wall⁴) W | 15.9 % |
//! | SpringMassExportedDriftingStiffness.fmu | SpringMassExported | `HIDDEN_DRIFTING_STIFFNESS=0.5` | stiffness k·(1 + 0.5·t/20 s) (no effect kind) | 16.4 % |
//! | SpringMassExportedPeriodicForce.fmu | SpringMassExported | `HIDDEN_PERIODIC_FORCE=0.15` | +0.15·sin(2.7·t) N (no effect kind) | 12.4 % |
//! | SpringMassExportedOneSidedFriction.fmu | SpringMassExported | `HIDDEN_ONE_SIDED_FRICTION=0.1` | −0.1·tanh(v/1e-3)·(1 + tanh(x/0.01))/2 N, friction only for x > 0 (no effect kind) | 11.8 % |
//! | SpringMassExportedGrowingMass.fmu | SpringMassExported | `HIDDEN_GROWING_MASS=0.5` | mass m·(1 + 0.5·t/20 s) (no effect kind) | 15.9 % |
//! | SpringMassExportedLooseTolerance.fmu | SpringMassExported | its description with `tolerance="0.0001"`, Dymola's default | none | |
//! | SpringMassExportedDocumented.fmu | SpringMassExported | its archive plus `documentation/` (HTML and 12 MB of images), as tools package it | none | |
//!
//! FMI 3.0 fixtures (`<Identifier>Fmi3.fmu`): the same model source compiled with `-DFMUCAL_FMI3`,
//! which makes models/c/fmu_framework.c export the FMI 3.0 API (fmu_framework3.c) instead of
//! 2.0's, packaged with `xml/fmi3/<Identifier>.xml`, the binary in `binaries/x86_64-linux/` (the
//! FMI 3.0 platform tuple) and a `sources/buildDescription.xml` that names the define.
//!
//! FMI 1.0 fixtures: FMI 1.0's Model Exchange and Co-Simulation are separate FMUs with different
//! function sets, so each model is built twice, `<Identifier>Fmi1Me.fmu` with `-DFMUCAL_FMI1=1`
//! and `<Identifier>Fmi1Cs.fmu` with `-DFMUCAL_FMI1=2` (models/c/fmu_framework1.c), packaged with
//! `xml/fmi1/<Identifier>Me.xml` or `<Identifier>Cs.xml`, the binary in `binaries/linux64/`. The
//! exported names carry the model identifier as their prefix (`Furuta_fmiGetReal`), as FMI 1.0
//! requires; UnprefixedFmi1.fmu is the Furuta Model Exchange FMU built with
//! `-DFMUCAL_FMI1_UNPREFIXED`, whose binary exports the plain names (`fmiGetReal`) instead.
//!
//! Fixtures of what exporting tools write, each shaped after the Modelica Reference FMUs'
//! descriptions or the FMI standard's examples (the description files say which):
//!
//! | fixture | binary | description | what it has |
//! |---|---|---|---|
//! | FurutaAliasesFmi3.fmu | FurutaFmi3's | `xml/fmi3/FurutaAliases.xml` | FMI 3.0 `<Alias name description displayUnit/>` children on an output, a state, a state derivative, a parameter and an input |
//! | FurutaAliases.fmu | Furuta's | `xml/FurutaAliases.xml` | FMI 2.0 aliases: extra ScalarVariables sharing the value reference (local; the parameter's a calculatedParameter), same names and positions |
//! | FurutaAliasesFmi1Me.fmu | FurutaFmi1Me's | `xml/fmi1/FurutaAliasesMe.xml` | FMI 1.0 `alias="alias"` and `alias="negatedAlias"` (a negated output, `pendulumJoint.phiNeg`, and a negated parameter) |
//! | StringsFmi3.fmu, Strings.fmu | `c/strings.c` | `xml/fmi3/Strings.xml`, `xml/Strings.xml` | String (3.0 and 2.0) and Binary (3.0) parameters, inputs and outputs with start values (`<Start value=…/>` in 3.0); the output y = len(String_parameter)·x, Binary_length = bytes of Binary_input |
//! | StringsFmi1Me.fmu | `c/strings.c` | `xml/fmi1/StringsMe.xml` | the same String variables in FMI 1.0 |
//! | ArrayOutputsFmi3.fmu, ArrayOutputs.fmu | `c/array_outputs.c` | `xml/fmi3/ArrayOutputs.xml`, `xml/ArrayOutputs.xml` | a Float64 array output y sized by `<Dimension valueReference/>` of the UInt64 structuralParameter n = 3 (2.0: scalars y[1] to y[3]) |
//! | StairFmi3.fmu, Stair.fmu | `c/stair.c` | `xml/fmi3/Stair.xml`, `xml/Stair.xml` | a Co-Simulation counter that asks to terminate at t = 9 (counter 10) and refuses to go on; stop time 10, step 0.2 |
//!
//! The skeleton stores String variables for models that define `N_STRING`, and Binary and UInt64
//! ones (FMI 3.0) for models that define `N_BINARY` or `N_UINT64` (models/c/fmu_framework.h).

use std::fs::{self, File};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::Command;

use zip::write::SimpleFileOptions;

struct Model {
    identifier: &'static str,
    source: &'static str,
    resources: &'static [&'static str],
    extra_platforms: bool,
}

const MODELS: &[Model] = &[
    Model { identifier: "Furuta", source: "furuta.c", resources: &[], extra_platforms: false },
    Model { identifier: "BouncingBall", source: "bouncing_ball.c", resources: &[], extra_platforms: false },
    Model { identifier: "Decay", source: "decay.c", resources: &["decay.txt"], extra_platforms: true },
    Model { identifier: "Robertson", source: "robertson.c", resources: &[], extra_platforms: false },
    Model { identifier: "ExhaustPipe", source: "exhaust_pipe.c", resources: &[], extra_platforms: false },
];

/// Conformance fixtures: built like the examples, not listed as examples.
const FIXTURES: &[Model] = &[
    Model { identifier: "StickSlip", source: "stick_slip.c", resources: &[], extra_platforms: false },
    Model { identifier: "InputKinds", source: "input_kinds.c", resources: &[], extra_platforms: false },
    Model { identifier: "Threshold", source: "threshold.c", resources: &[], extra_platforms: false },
    Model { identifier: "SpringMass", source: "spring_mass.c", resources: &[], extra_platforms: false },
    Model { identifier: "ArrayParams", source: "array_params.c", resources: &[], extra_platforms: false },
    Model { identifier: "Strings", source: "strings.c", resources: &[], extra_platforms: false },
    Model { identifier: "ArrayOutputs", source: "array_outputs.c", resources: &[], extra_platforms: false },
    Model { identifier: "Stair", source: "stair.c", resources: &[], extra_platforms: false },
];

/// Models also built for FMI 3.0 (identifiers of [`MODELS`] or [`FIXTURES`]), packaged as
/// `<Identifier>Fmi3.fmu` with `xml/fmi3/<Identifier>.xml`.
const FMI3: &[&str] = &["Furuta", "BouncingBall", "Robertson", "ArrayParams", "Strings", "ArrayOutputs", "Stair"];

/// Models also built for FMI 1.0 (identifiers of [`MODELS`]; each model file defines
/// `FMI1_PREFIX`), packaged as `<Identifier>Fmi1Me.fmu` and `<Identifier>Fmi1Cs.fmu` with
/// `xml/fmi1/<Identifier>Me.xml` and `xml/fmi1/<Identifier>Cs.xml`.
const FMI1: &[&str] = &["Furuta", "BouncingBall", "Robertson"];

/// Alias fixtures: (file name, FMI version, description under `xml/`). Each is Furuta's binary
/// of that version (FMI 1.0: Model Exchange) packaged with a description that adds aliases.
const ALIASES: &[(&str, Fmi, &str)] = &[
    ("FurutaAliases", Fmi::V2, "FurutaAliases.xml"),
    ("FurutaAliasesFmi3", Fmi::V3, "fmi3/FurutaAliases.xml"),
    ("FurutaAliasesFmi1Me", Fmi::V1, "fmi1/FurutaAliasesMe.xml"),
];

/// Hidden-effect fixtures: (file name, identifier of the base model, define). Each is the base
/// model's source compiled with the define and packaged with the base model's description.
const HIDDEN: &[(&str, &str, &str)] = &[
    // Coulomb friction of 0.004 N·m in the pendulum joint, smoothed as fmucal's
    // coulomb_friction: data with an effect the base model lacks.
    ("FurutaHiddenCoulomb", "Furuta", "-DHIDDEN_PENDULUM_COULOMB=0.004"),
    // The arm angle sensor reads 0.1 rad too much (a misaligned encoder zero): fmi2GetReal
    // reports armJoint.phi + 0.1, the equations use the true angle (fmucal's sensor_offset).
    ("FurutaHiddenSensorOffset", "Furuta", "-DHIDDEN_ARM_SENSOR_OFFSET=0.1"),
    // Quadratic drag −c·w1·|w1| on the arm (fmucal's quadratic_drag), c = 1e-3 N·m·s²/rad²:
    // on the example's first 10 s of motor torque it turns the arm 2.3 rad less, 15.7 % of the
    // arm angle's 14.4 rad range.
    ("FurutaHiddenArmDrag", "Furuta", "-DHIDDEN_ARM_QUADRATIC_DRAG=1e-3"),
    // A hardening spring −k3·x³ on the mass (fmucal's cubic_spring), k3 = 0.2 N/m³: 5 % of the
    // linear spring force (k = 4 N/m) at |x| = 1 m; with F = 3·sin(t) N, which drives x to
    // about ±1 m over 20 s, it changes x by up to 0.11 m, 5 % of its range.
    ("SpringMassHiddenCubic", "SpringMass", "-DHIDDEN_CUBIC_SPRING=0.2"),
    // Radiation of the outlet (right) wall to surroundings at 293.15 K, εA·σ·(T_amb⁴ − T_wall⁴)
    // (fmucal's radiation), εA = 0.2 m² (e.g. emissivity 0.8 on 0.25 m²): about 1.4 kW at a
    // 600 K wall. On the exhaust example's inputs (30 min) it lowers the output outlet.T by up
    // to 3.8 K, 2.9 % of its 132 K range.
    ("ExhaustPipeHiddenRadiation", "ExhaustPipe", "-DHIDDEN_RADIATION_AREA=0.2"),
];

/// SpringMassExported's description and start position (shared by its variants).
const SM_XML: &str = "exported/SpringMassExported.xml";
const SM_X0: &str = "-DSPRING_MASS_X0=0.5";

/// Fixtures described as modelling tools export them (Dymola's FMI 2.0 shape): (file name,
/// identifier of the base model, description under `xml/`, defines). Each is the base model's
/// source compiled with the defines and packaged with an exported-shape description that
/// declares no injection port (the binary keeps it, undeclared, at 0). The hidden-effect
/// variants add a define each, their description is their exported base's; the changes quoted
/// are the largest difference over the outputs of the DefaultExperiment run with the inputs at
/// their start values, relative to each output's range in the base run, measured with FMPy
/// (Model Exchange, rtol 1e-8) and checked by tests/exported_fixtures.rs.
const EXPORTED: &[(&str, &str, &str, &[&str])] = &[
    // The bases: the mass starts 0.5 m away from rest, so it moves with F = 0.
    ("SpringMassExported", "SpringMass", SM_XML, &[SM_X0]),
    ("FurutaExported", "Furuta", "exported/FurutaExported.xml", &[]),
    ("ExhaustPipeExported", "ExhaustPipe", "exported/ExhaustPipeExported.xml", &[]),
    // fmucal's effect kinds, each with fmucal's formula.
    ("SpringMassExportedHiddenCoulomb", "SpringMass", SM_XML, &[SM_X0, "-DHIDDEN_COULOMB=0.05"]),
    (
        "SpringMassExportedHiddenStribeck",
        "SpringMass",
        SM_XML,
        &[SM_X0, "-DHIDDEN_STRIBECK_COULOMB=0.05", "-DHIDDEN_STRIBECK_STATIC=0.1", "-DHIDDEN_STRIBECK_VELOCITY=0.1"],
    ),
    ("SpringMassExportedHiddenViscous", "SpringMass", SM_XML, &[SM_X0, "-DHIDDEN_VISCOUS=0.2"]),
    ("SpringMassExportedHiddenQuadraticDrag", "SpringMass", SM_XML, &[SM_X0, "-DHIDDEN_QUADRATIC_DRAG=0.5"]),
    ("SpringMassExportedHiddenCubic", "SpringMass", SM_XML, &[SM_X0, "-DHIDDEN_CUBIC_SPRING=2"]),
    ("SpringMassExportedHiddenSensorOffset", "SpringMass", SM_XML, &[SM_X0, "-DHIDDEN_POSITION_SENSOR_OFFSET=0.05"]),
    ("FurutaExportedHiddenCoulomb", "Furuta", "exported/FurutaExported.xml", &["-DHIDDEN_PENDULUM_COULOMB=0.004"]),
    (
        "ExhaustPipeExportedHiddenRadiation",
        "ExhaustPipe",
        "exported/ExhaustPipeExported.xml",
        &["-DHIDDEN_RADIATION_AREA=0.2"],
    ),
    // Effects none of fmucal's effect kinds expresses.
    ("SpringMassExportedDriftingStiffness", "SpringMass", SM_XML, &[SM_X0, "-DHIDDEN_DRIFTING_STIFFNESS=0.5"]),
    ("SpringMassExportedPeriodicForce", "SpringMass", SM_XML, &[SM_X0, "-DHIDDEN_PERIODIC_FORCE=0.15"]),
    ("SpringMassExportedOneSidedFriction", "SpringMass", SM_XML, &[SM_X0, "-DHIDDEN_ONE_SIDED_FRICTION=0.1"]),
    ("SpringMassExportedGrowingMass", "SpringMass", SM_XML, &[SM_X0, "-DHIDDEN_GROWING_MASS=0.5"]),
    // The base as Dymola exports it unless told otherwise: DefaultExperiment tolerance 1e-4.
    ("SpringMassExportedLooseTolerance", "SpringMass", SM_XML, &[SM_X0]),
];

/// Exported fixtures whose description is their base's with Dymola's default
/// `DefaultExperiment tolerance="0.0001"` instead of the base's 1e-6.
const LOOSE_TOLERANCE: &[&str] = &["SpringMassExportedLooseTolerance"];

/// The FMI version an archive is built for.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Fmi {
    /// FMI 1.0, one interface per FMU (Model Exchange or Co-Simulation).
    V1,
    V2,
    V3,
}

impl Fmi {
    /// Folder of the binary under `binaries/`: FMI 2.0's platform name or FMI 3.0's tuple.
    fn platform(self) -> &'static str {
        match self {
            Fmi::V1 | Fmi::V2 => "linux64",
            Fmi::V3 => "x86_64-linux",
        }
    }

    /// The skeleton's files a model source includes, shipped under `sources/`.
    fn framework(self) -> &'static [&'static str] {
        match self {
            Fmi::V1 => &["fmi2.h", "fmi1.h", "fmu_framework.h", "fmu_framework.c", "fmu_cosim.c", "fmu_framework1.c"],
            Fmi::V2 => &["fmi2.h", "fmu_framework.h", "fmu_framework.c", "fmu_cosim.c", "fmu_framework2.c"],
            Fmi::V3 => &["fmi2.h", "fmi3.h", "fmu_framework.h", "fmu_framework.c", "fmu_cosim.c", "fmu_framework3.c"],
        }
    }
}

fn main() {
    let root = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").unwrap());
    let out = PathBuf::from(std::env::var("OUT_DIR").unwrap()).join("fmus");
    fs::create_dir_all(&out).unwrap();
    for dir in ["c", "xml", "resources"] {
        println!("cargo:rerun-if-changed={}", root.join(dir).display());
    }

    for model in MODELS.iter().chain(FIXTURES) {
        let so = out.join(format!("{}.so", model.identifier));
        compile(&root.join("c").join(model.source), &so, &[]);
        let xml = fs::read(root.join("xml").join(format!("{}.xml", model.identifier))).unwrap();
        package(&root, model, Fmi::V2, &xml, &so, &out.join(format!("{}.fmu", model.identifier)));
    }

    // FMI 3.0 builds of the same sources.
    for id in FMI3 {
        let model = MODELS.iter().chain(FIXTURES).find(|m| m.identifier == *id).unwrap();
        let so = out.join(format!("{id}Fmi3.so"));
        compile(&root.join("c").join(model.source), &so, &["-DFMUCAL_FMI3"]);
        let xml = fs::read(root.join("xml").join("fmi3").join(format!("{id}.xml"))).unwrap();
        package(&root, model, Fmi::V3, &xml, &so, &out.join(format!("{id}Fmi3.fmu")));
    }

    // FMI 1.0 builds of the same sources: Model Exchange and Co-Simulation are separate FMUs.
    for id in FMI1 {
        let model = MODELS.iter().find(|m| m.identifier == *id).unwrap();
        for (suffix, define) in [("Me", "-DFMUCAL_FMI1=1"), ("Cs", "-DFMUCAL_FMI1=2")] {
            let so = out.join(format!("{id}Fmi1{suffix}.so"));
            compile(&root.join("c").join(model.source), &so, &[define]);
            let xml = fs::read(root.join("xml").join("fmi1").join(format!("{id}{suffix}.xml"))).unwrap();
            package(&root, model, Fmi::V1, &xml, &so, &out.join(format!("{id}Fmi1{suffix}.fmu")));
        }
    }

    // Aliases: Furuta's binaries (built above) with descriptions that add aliases.
    let furuta = &MODELS[0];
    for (name, fmi, xml) in ALIASES {
        let so = match fmi {
            Fmi::V1 => "FurutaFmi1Me.so",
            Fmi::V2 => "Furuta.so",
            Fmi::V3 => "FurutaFmi3.so",
        };
        let xml = fs::read(root.join("xml").join(xml)).unwrap();
        package(&root, furuta, *fmi, &xml, &out.join(so), &out.join(format!("{name}.fmu")));
    }

    // FMI 1.0 Model Exchange build of the String fixture.
    let strings = FIXTURES.iter().find(|m| m.identifier == "Strings").unwrap();
    let so = out.join("StringsFmi1Me.so");
    compile(&root.join("c").join(strings.source), &so, &["-DFMUCAL_FMI1=1"]);
    let xml = fs::read(root.join("xml").join("fmi1").join("StringsMe.xml")).unwrap();
    package(&root, strings, Fmi::V1, &xml, &so, &out.join("StringsFmi1Me.fmu"));

    // Fixture: the Furuta FMI 1.0 Model Exchange FMU whose binary exports the functions without
    // the model identifier prefix (fmiGetReal instead of Furuta_fmiGetReal).
    let so = out.join("UnprefixedFmi1.so");
    compile(&root.join("c").join(furuta.source), &so, &["-DFMUCAL_FMI1=1", "-DFMUCAL_FMI1_UNPREFIXED"]);
    let xml = fs::read(root.join("xml").join("fmi1").join("FurutaMe.xml")).unwrap();
    package(&root, furuta, Fmi::V1, &xml, &so, &out.join("UnprefixedFmi1.fmu"));

    // Fixture: Decay built without the fmi2GetReal export (renamed by the preprocessor).
    let decay = &MODELS[2];
    let so = out.join("MissingSymbol.so");
    compile(&root.join("c").join(decay.source), &so, &["-Dfmi2GetReal=fmucal_hidden_fmi2GetReal"]);
    let xml = fs::read(root.join("xml").join("Decay.xml")).unwrap();
    package(&root, decay, Fmi::V2, &xml, &so, &out.join("MissingSymbol.fmu"));

    // Fixture: Decay whose fmi2Reset always fails (exercises re-instantiation).
    let so = out.join("ResetFails.so");
    compile(&root.join("c").join(decay.source), &so, &["-DFMUCAL_RESET_FAILS"]);
    package(&root, decay, Fmi::V2, &xml, &so, &out.join("ResetFails.fmu"));

    // Hidden-effect fixtures: the base model's source with a define, its description unchanged.
    for (name, base, define) in HIDDEN {
        let model = MODELS.iter().chain(FIXTURES).find(|m| m.identifier == *base).unwrap();
        let so = out.join(format!("{name}.so"));
        compile(&root.join("c").join(model.source), &so, &[define]);
        let xml = fs::read(root.join("xml").join(format!("{base}.xml"))).unwrap();
        package(&root, model, Fmi::V2, &xml, &so, &out.join(format!("{name}.fmu")));
    }

    // Fixtures described as modelling tools export them, and their hidden-effect variants.
    for (name, base, xml, defines) in EXPORTED {
        let model = MODELS.iter().chain(FIXTURES).find(|m| m.identifier == *base).unwrap();
        let so = out.join(format!("{name}.so"));
        compile(&root.join("c").join(model.source), &so, defines);
        let mut xml = fs::read_to_string(root.join("xml").join(xml)).unwrap();
        if LOOSE_TOLERANCE.contains(name) {
            assert!(xml.contains(r#"tolerance="1e-06""#), "{name}: its base states no tolerance of 1e-06");
            xml = xml.replace(r#"tolerance="1e-06""#, r#"tolerance="0.0001""#);
        }
        package(&root, model, Fmi::V2, xml.as_bytes(), &so, &out.join(format!("{name}.fmu")));
    }

    // Fixture: SpringMassExported packaged as commercial tools package an FMU, with HTML
    // documentation and images under `documentation/` that make up most of the archive.
    documented(&out.join("SpringMassExported.fmu"), &out.join("SpringMassExportedDocumented.fmu"));

    // Fixture: the bouncing ball described as tools export it, with `derivative` attributes on
    // aliases and on variables that are not continuous states (FMI 2.0 allows them; only
    // ModelStructure/Derivatives defines the states).
    let ball = &MODELS[1];
    let xml = fs::read(root.join("xml").join("DerivativeAttributes.xml")).unwrap();
    package(&root, ball, Fmi::V2, &xml, &out.join("BouncingBall.so"), &out.join("DerivativeAttributes.fmu"));
}

fn compile(source: &Path, output: &Path, defines: &[&str]) {
    let compiler = cc::Build::new().opt_level(2).get_compiler();
    let mut cmd: Command = compiler.to_command();
    cmd.args(["-std=c99", "-shared", "-fPIC", "-fvisibility=hidden", "-O2", "-Wall"])
        .args(defines)
        .arg("-o")
        .arg(output)
        .arg(source)
        .arg("-lm");
    let status = cmd.status().unwrap_or_else(|e| panic!("cannot run the C compiler: {e}"));
    assert!(status.success(), "compiling {} failed", source.display());
}

fn package(root: &Path, model: &Model, fmi: Fmi, xml: &[u8], so: &Path, fmu: &Path) {
    let mut zip = zip::ZipWriter::new(File::create(fmu).unwrap());
    let opts = SimpleFileOptions::default().compression_method(zip::CompressionMethod::Deflated);
    let mut add = |name: String, bytes: &[u8]| {
        zip.start_file(name, opts).unwrap();
        zip.write_all(bytes).unwrap();
    };
    add("modelDescription.xml".into(), xml);
    add(format!("binaries/{}/{}.so", fmi.platform(), model.identifier), &fs::read(so).unwrap());
    if model.extra_platforms {
        let note = b"placeholder: fmucal's examples ship only a linux64 binary";
        add(format!("binaries/win64/{}.dll", model.identifier), note);
        add(format!("binaries/win32/{}.dll", model.identifier), note);
        add(format!("binaries/darwin64/{}.dylib", model.identifier), note);
    }
    add(format!("sources/{}", model.source), &fs::read(root.join("c").join(model.source)).unwrap());
    for file in fmi.framework() {
        add(format!("sources/{file}"), &fs::read(root.join("c").join(file)).unwrap());
    }
    if fmi == Fmi::V3 {
        add("sources/buildDescription.xml".into(), build_description(model).as_bytes());
    }
    for res in model.resources {
        add(format!("resources/{res}"), &fs::read(root.join("resources").join(res)).unwrap());
    }
    zip.finish().unwrap();
}

/// Images in [`documented`]'s `documentation/images/`, and the bytes of each.
const DOC_IMAGES: usize = 12;
const DOC_IMAGE_BYTES: usize = 1 << 20;

/// Writes `fmu` as `base` with a `documentation/` folder as Dymola and OpenModelica write it:
/// `index.html` (the entry point FMI 2.0 names), `_main.html` with the model's diagram and
/// plots, a license page, and [`DOC_IMAGES`] PNG images of [`DOC_IMAGE_BYTES`] each whose
/// pixels (pseudo-random, fixed seed) do not compress, as photos and rendered plots barely do:
/// about 13 MB in all, almost all of it documentation.
fn documented(base: &Path, fmu: &Path) {
    let mut archive = zip::ZipArchive::new(File::open(base).unwrap()).unwrap();
    let mut zip = zip::ZipWriter::new(File::create(fmu).unwrap());
    for i in 0..archive.len() {
        zip.raw_copy_file(archive.by_index_raw(i).unwrap()).unwrap();
    }
    let opts = SimpleFileOptions::default().compression_method(zip::CompressionMethod::Deflated);
    let mut add = |name: &str, bytes: &[u8]| {
        zip.start_file(name, opts).unwrap();
        zip.write_all(bytes).unwrap();
    };
    let images: Vec<String> = (0..DOC_IMAGES).map(|k| format!("images/plot{k:02}.png")).collect();
    let figures: String = images.iter().map(|i| format!("<p><img src=\"{i}\" alt=\"{i}\"></p>\n")).collect();
    add(
        "documentation/index.html",
        b"<html><head><title>SpringMass</title></head><body><a href=\"_main.html\">SpringMass</a></body></html>\n",
    );
    add(
        "documentation/_main.html",
        format!("<html><body><h1>SpringMass</h1><p>A mass on a spring with a damper.</p>\n{figures}</body></html>\n")
            .as_bytes(),
    );
    add("documentation/licenses/license.html", b"<html><body>Licensed to the fmucal test suite.</body></html>\n");
    // xorshift64*: a fixed stream of bytes that deflate cannot shrink.
    let mut state: u64 = 0x9e37_79b9_7f4a_7c15;
    for name in &images {
        let mut bytes = b"\x89PNG\r\n\x1a\n".to_vec();
        while bytes.len() < DOC_IMAGE_BYTES {
            state ^= state >> 12;
            state ^= state << 25;
            state ^= state >> 27;
            bytes.extend_from_slice(&state.wrapping_mul(0x2545_f491_4f6c_dd1d).to_le_bytes());
        }
        add(&format!("documentation/{name}"), &bytes);
    }
    zip.finish().unwrap();
}

/// FMI 3.0's `sources/buildDescription.xml`: compile the model file (it includes the skeleton)
/// with `FMUCAL_FMI3` defined, and link the C math library.
fn build_description(model: &Model) -> String {
    format!(
        r#"<?xml version="1.0" encoding="UTF-8"?>
<fmiBuildDescription fmiVersion="3.0">
  <BuildConfiguration modelIdentifier="{id}">
    <SourceFileSet language="C99">
      <SourceFile name="{source}"/>
      <PreprocessorDefinition name="FMUCAL_FMI3" description="export the FMI 3.0 API (without it: FMI 2.0)"/>
    </SourceFileSet>
    <Library name="m" external="true" description="the C math library"/>
  </BuildConfiguration>
</fmiBuildDescription>
"#,
        id = model.identifier,
        source = model.source
    )
}
