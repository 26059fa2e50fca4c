//! The `fmucal` binary: parses the command line and hands over to [`fmucal::cli`].
fn main() -> std::process::ExitCode {
    fmucal::cli::main()
}
