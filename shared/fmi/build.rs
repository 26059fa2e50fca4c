//! Compiles the C logger shim (`csrc/logger_shim.c`) that formats the FMI 2.0 variadic logger.
fn main() {
    println!("cargo:rerun-if-changed=csrc/logger_shim.c");
    cc::Build::new().file("csrc/logger_shim.c").warnings(true).compile("fmucal_logger_shim");
}
