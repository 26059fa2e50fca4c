//! What the optimizer benchmarks (`bench/optim.rs`, `bench/cma_es.rs`,
//! `bench/least_squares.rs`) share: their command-line options and their output, one JSON row
//! per problem or run, which the shell scripts beside them read.

/// The value after `name` on the command line (`--json PATH`), if any.
pub fn option(name: &str) -> Option<String> {
    let args: Vec<String> = std::env::args().collect();
    args.iter().position(|a| a == name).and_then(|i| args.get(i + 1)).cloned()
}

/// Writes `rows` as a JSON array to the file named after `--json`, or prints it if none was.
pub fn write(rows: &[serde_json::Value]) {
    let text = serde_json::to_string_pretty(rows).expect("json");
    match option("--json") {
        Some(path) => std::fs::write(path, text).expect("write"),
        None => println!("{text}"),
    }
}
