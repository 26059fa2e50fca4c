//! Compiles `fmucal/v1/fmucal.proto` with protox (pure Rust) and generates tonic code.
fn main() -> Result<(), Box<dyn std::error::Error>> {
    println!("cargo:rerun-if-changed=fmucal/v1/fmucal.proto");
    let fds = protox::compile(["fmucal/v1/fmucal.proto"], ["."])?;
    tonic_prost_build::configure().compile_fds(fds)?;
    Ok(())
}
