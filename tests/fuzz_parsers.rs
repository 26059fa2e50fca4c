//! A bounded mutation fuzzer for what fmucal reads from untrusted input: the job file (TOML,
//! then validation), `modelDescription.xml`, and the FMU archive (unpacked with the zip-slip and
//! size checks, then described). Each target mutates real seed inputs (the examples' job files,
//! the example models' descriptions, a real FMU) with byte flips, cuts, repeats and inserted
//! tokens, from a fixed seed, and must return an error or a value for every input, never panic.
//! The suite runs each target for 60 s (in parallel); `bash bench/fuzz.sh` runs them for an hour
//! (`FMUCAL_FUZZ_SECONDS`, default 1200, per target). A failing input is written to `target/tmp/fuzz-failures/`.

mod common;

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use fmucal_shared::fmu::archive::ArchiveLimits;
use fmucal_shared::fmu::schema::ModelDescription;
use fmucal_shared::fmu::{LoadOptions, describe};
use fmucal_shared::job::JobSpec;

/// How long each target runs.
fn budget() -> Duration {
    let seconds = std::env::var("FMUCAL_FUZZ_SECONDS").ok().and_then(|s| s.parse().ok()).unwrap_or(60);
    Duration::from_secs(seconds)
}

/// xorshift64*: a fixed, dependency-free sequence.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }

    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

/// One to four random edits of `input`.
fn mutate(rng: &mut Rng, input: &[u8], tokens: &[impl AsRef<[u8]>]) -> Vec<u8> {
    let mut out = input.to_vec();
    for _ in 0..=rng.below(4) {
        let at = rng.below(out.len() + 1);
        match rng.below(6) {
            0 if !out.is_empty() => {
                let i = rng.below(out.len());
                out[i] ^= 1 << rng.below(8);
            }
            1 => {
                let end = (at + rng.below(64)).min(out.len());
                out.drain(at..end);
            }
            2 => {
                let end = (at + rng.below(256)).min(out.len());
                let piece = out[at..end].to_vec();
                out.splice(at..at, piece);
            }
            3 => out.truncate(at),
            4 if !out.is_empty() => {
                let i = rng.below(out.len());
                out[i] = rng.next() as u8;
            }
            _ => {
                let token = tokens[rng.below(tokens.len())].as_ref();
                out.splice(at..at, token.iter().copied());
            }
        }
    }
    out
}

/// Runs `target` on mutations of `seeds` until the budget is spent; fails with the first input
/// that panics (saved under `target/tmp/fuzz-failures/NAME-N`). Returns the number of inputs tried.
fn fuzz(name: &str, seeds: &[Vec<u8>], tokens: &[impl AsRef<[u8]>], target: impl Fn(&[u8])) -> u64 {
    assert!(!seeds.is_empty(), "{name}: no seed inputs");
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15 ^ name.len() as u64);
    let started = Instant::now();
    let mut tried = 0u64;
    while started.elapsed() < budget() {
        let seed = &seeds[rng.below(seeds.len())];
        let input = mutate(&mut rng, seed, tokens);
        let outcome = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| target(&input)));
        if outcome.is_err() {
            let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("fuzz-failures");
            std::fs::create_dir_all(&dir).unwrap();
            let path = dir.join(format!("{name}-{tried}"));
            std::fs::write(&path, &input).unwrap();
            panic!("{name}: input {tried} panicked; saved to {}", path.display());
        }
        tried += 1;
    }
    eprintln!("{name}: {tried} inputs in {:.0} s", started.elapsed().as_secs_f64());
    tried
}

/// The tokens of a fuzz dictionary (`tests/data/fuzz/*.json`: a JSON array of strings), which
/// [`mutate`] inserts.
fn dictionary(json: &str) -> Vec<String> {
    serde_json::from_str(json).expect("a fuzz dictionary is a JSON array of strings")
}

fn files(dir: &Path, ext: &str) -> Vec<Vec<u8>> {
    let mut out = vec![];
    for entry in std::fs::read_dir(dir).unwrap().flatten() {
        let path = entry.path();
        if path.is_dir() {
            out.extend(files(&path, ext));
        } else if path.extension().is_some_and(|e| e == ext) {
            out.push(std::fs::read(&path).unwrap());
        }
    }
    out
}

fn repo(path: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(path)
}

#[test]
fn job_files_never_panic_the_parser_or_validation() {
    let seeds = files(&repo("examples"), "toml");
    let tokens = dictionary(include_str!("data/fuzz/job_toml.json"));
    let n = fuzz("job-toml", &seeds, &tokens, |input| {
        let text = String::from_utf8_lossy(input);
        if let Ok(spec) = JobSpec::from_toml(&text, Path::new("/nonexistent")) {
            let _ = spec.validate();
        }
    });
    assert!(n > 100, "only {n} inputs");
}

#[test]
fn model_descriptions_never_panic_the_parser() {
    let seeds = files(&repo("models/xml"), "xml");
    let tokens = dictionary(include_str!("data/fuzz/model_description.json"));
    let n = fuzz("model-description", &seeds, &tokens, |input| {
        let _ = ModelDescription::parse(&String::from_utf8_lossy(input));
    });
    assert!(n > 100, "only {n} inputs");
}

#[test]
fn fmu_archives_never_panic_the_reader() {
    let dir = tempfile::tempdir().unwrap();
    let seeds =
        vec![std::fs::read(common::example("decay")).unwrap(), std::fs::read(common::example("furuta")).unwrap()];
    let tokens = ["PK\u{3}\u{4}", "PK\u{1}\u{2}", "PK\u{5}\u{6}", "../", "/", "\\", "modelDescription.xml", "\0"];
    let opts = LoadOptions {
        cache_dir: dir.path().join("cache"),
        limits: ArchiveLimits { max_total_bytes: 64 << 20, max_entries: 1000, max_archive_bytes: 64 << 20 },
    };
    let file = dir.path().join("input.fmu");
    let n = fuzz("fmu-archive", &seeds, &tokens, |input| {
        std::fs::write(&file, input).unwrap();
        let _ = describe(&file, &opts);
        // Unpacked copies are keyed by content: keep the cache from growing without bound.
        if opts.cache_dir.exists() && std::fs::read_dir(&opts.cache_dir).map_or(0, Iterator::count) > 200 {
            std::fs::remove_dir_all(&opts.cache_dir).unwrap();
        }
    });
    assert!(n > 100, "only {n} inputs");
    // Nothing was written outside the cache.
    let mut outside: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    outside.sort();
    outside.retain(|n| n != "cache" && n != "input.fmu");
    assert!(outside.is_empty(), "written beside the cache: {outside:?}");
}
