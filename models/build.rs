//! Compiles the example models' C sources into shared libraries with the `cc` crate's compiler
//! and packages each into a real `.fmu` (zip with modelDescription.xml, binaries/linux64,
//! sources/ and resources/). Also builds the fixture FMUs the tests need: broken ones
//! (MissingSymbol.fmu, ResetFails.fmu), ones that behave as tool-exported FMUs do
//! (StickSlip.fmu, InputKinds.fmu, Threshold.fmu, DerivativeAttributes.fmu), and a Furuta
//! with an effect its description does not mention (FurutaHiddenCoulomb.fmu).

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
];

const FRAMEWORK: &[&str] = &["fmi2.h", "fmu_framework.h", "fmu_framework.c"];

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
        package(&root, model, &xml, &so, &out.join(format!("{}.fmu", model.identifier)));
    }

    // Fixture: Decay built without the fmi2GetReal export (renamed by the preprocessor).
    let decay = &MODELS[2];
    let so = out.join("MissingSymbol.so");
    compile(&root.join("c").join(decay.source), &so, &["-Dfmi2GetReal=fmucal_hidden_fmi2GetReal"]);
    let xml = fs::read(root.join("xml").join("Decay.xml")).unwrap();
    package(&root, decay, &xml, &so, &out.join("MissingSymbol.fmu"));

    // Fixture: Decay whose fmi2Reset always fails (exercises re-instantiation).
    let so = out.join("ResetFails.so");
    compile(&root.join("c").join(decay.source), &so, &["-DFMUCAL_RESET_FAILS"]);
    package(&root, decay, &xml, &so, &out.join("ResetFails.fmu"));

    // Fixture: the Furuta pendulum with a Coulomb friction of 0.004 N·m in the pendulum joint
    // that its description does not mention: data with an effect the base model lacks.
    let furuta = &MODELS[0];
    let so = out.join("FurutaHiddenCoulomb.so");
    compile(&root.join("c").join(furuta.source), &so, &["-DHIDDEN_PENDULUM_COULOMB=0.004"]);
    let xml = fs::read(root.join("xml").join("Furuta.xml")).unwrap();
    package(&root, furuta, &xml, &so, &out.join("FurutaHiddenCoulomb.fmu"));

    // Fixture: the bouncing ball described as tools export it, with `derivative` attributes on
    // aliases and on variables that are not continuous states (FMI 2.0 allows them; only
    // ModelStructure/Derivatives defines the states).
    let ball = &MODELS[1];
    let xml = fs::read(root.join("xml").join("DerivativeAttributes.xml")).unwrap();
    package(&root, ball, &xml, &out.join("BouncingBall.so"), &out.join("DerivativeAttributes.fmu"));
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

fn package(root: &Path, model: &Model, xml: &[u8], so: &Path, fmu: &Path) {
    let mut zip = zip::ZipWriter::new(File::create(fmu).unwrap());
    let opts = SimpleFileOptions::default().compression_method(zip::CompressionMethod::Deflated);
    let mut add = |name: String, bytes: &[u8]| {
        zip.start_file(name, opts).unwrap();
        zip.write_all(bytes).unwrap();
    };
    add("modelDescription.xml".into(), xml);
    add(format!("binaries/linux64/{}.so", model.identifier), &fs::read(so).unwrap());
    if model.extra_platforms {
        let note = b"placeholder: fmucal's examples ship only a linux64 binary";
        add(format!("binaries/win64/{}.dll", model.identifier), note);
        add(format!("binaries/win32/{}.dll", model.identifier), note);
        add(format!("binaries/darwin64/{}.dylib", model.identifier), note);
    }
    add(format!("sources/{}", model.source), &fs::read(root.join("c").join(model.source)).unwrap());
    for file in FRAMEWORK {
        add(format!("sources/{file}"), &fs::read(root.join("c").join(file)).unwrap());
    }
    for res in model.resources {
        add(format!("resources/{res}"), &fs::read(root.join("resources").join(res)).unwrap());
    }
    zip.finish().unwrap();
}
