//! The limits page of the book (`docs/src/operations/limits.md`) says what the code does: each
//! row of its table that names a constant in its last column gives that constant's value in
//! its second column. A cap changed in the code and not on the page (or the other way round)
//! fails here.

use std::path::Path;
use std::time::Duration;

use fmucal_shared::job::limits;

/// A cap as the page writes it: a number with thousands separators (or `1e-14`), then
/// optionally a unit, `KiB`, `MiB`, `GiB` (powers of two) or `s`; other words (`bytes`,
/// `characters`) count one each.
fn parse_cap(cell: &str) -> Option<f64> {
    let mut words = cell.split_whitespace();
    let number: String = words.next()?.chars().filter(|c| *c != ',').collect();
    let value: f64 = number.parse().ok()?;
    let factor = match words.next() {
        Some("KiB") => f64::from(1u32 << 10),
        Some("MiB") => f64::from(1u32 << 20),
        Some("GiB") => f64::from(1u32 << 30),
        _ => 1.0,
    };
    Some(value * factor)
}

#[allow(clippy::cast_precision_loss)]
fn n(v: impl TryInto<u64>) -> f64 {
    v.try_into().ok().expect("a count") as f64
}

fn secs(d: Duration) -> f64 {
    d.as_secs_f64()
}

/// Each constant the page names in its last column, with its value in the code.
fn constants() -> Vec<(&'static str, f64)> {
    let archive = fmucal_shared::fmu::ArchiveLimits::default();
    let timing = fmucal_coordinator::Timing::default();
    vec![
        ("fmucal_shared::job::limits::MAX_PARAMETERS", n(limits::MAX_PARAMETERS)),
        ("fmucal_shared::job::limits::MAX_SIGNALS", n(limits::MAX_SIGNALS)),
        ("fmucal_shared::job::limits::MAX_EXPERIMENTS", n(limits::MAX_EXPERIMENTS)),
        ("fmucal_shared::job::limits::MAX_POPULATION", n(limits::MAX_POPULATION)),
        ("fmucal_shared::job::limits::MAX_ITERS", n(limits::MAX_ITERS)),
        ("fmucal_shared::job::limits::MAX_FEVALS", n(limits::MAX_FEVALS)),
        ("fmucal_shared::job::limits::MAX_ROUND_VALUES", n(limits::MAX_ROUND_VALUES)),
        ("fmucal_shared::job::limits::MAX_POINTS", n(limits::MAX_POINTS)),
        ("fmucal_shared::job::limits::MAX_KEPT_RESIDUALS", n(limits::MAX_KEPT_RESIDUALS)),
        ("fmucal_shared::job::limits::MAX_DATA_ROWS", n(limits::MAX_DATA_ROWS)),
        ("fmucal_shared::job::limits::MAX_DATA_VALUES", n(limits::MAX_DATA_VALUES)),
        ("fmucal_shared::job::limits::MAX_SET_VALUES", n(limits::MAX_SET_VALUES)),
        ("fmucal_shared::job::limits::MAX_WORKERS", n(limits::MAX_WORKERS)),
        ("fmucal_shared::job::limits::MAX_DATA_FILE_BYTES", n(limits::MAX_DATA_FILE_BYTES)),
        ("fmucal_shared::job::limits::MAX_JOB_FILE_BYTES", n(limits::MAX_JOB_FILE_BYTES)),
        ("fmucal_shared::job::spec::MIN_TOLERANCE", fmucal_shared::job::spec::MIN_TOLERANCE),
        ("fmucal::cli::token::MIN_TOKEN_FILE_CHARS", n(fmucal::cli::token::MIN_TOKEN_FILE_CHARS)),
        ("fmucal_shared::fmu::ArchiveLimits::default().max_total_bytes", n(archive.max_total_bytes)),
        ("fmucal_shared::fmu::ArchiveLimits::default().max_entries", n(archive.max_entries)),
        ("fmucal_coordinator::services::MAX_MODEL_BYTES", n(fmucal_coordinator::services::MAX_MODEL_BYTES)),
        ("fmucal_coordinator::models::DEFAULT_MAX_STORE_BYTES", n(fmucal_coordinator::models::DEFAULT_MAX_STORE_BYTES)),
        ("fmucal_proto::MAX_MESSAGE_BYTES", n(fmucal_proto::MAX_MESSAGE_BYTES)),
        (
            "fmucal_coordinator::connections::DEFAULT_MAX_CONNECTIONS",
            n(fmucal_coordinator::connections::DEFAULT_MAX_CONNECTIONS),
        ),
        (
            "fmucal_coordinator::connections::DEFAULT_IDLE_TIMEOUT",
            secs(fmucal_coordinator::connections::DEFAULT_IDLE_TIMEOUT),
        ),
        (
            "fmucal_coordinator::connections::DEFAULT_AUTH_TIMEOUT",
            secs(fmucal_coordinator::connections::DEFAULT_AUTH_TIMEOUT),
        ),
        ("fmucal_coordinator::Timing::default().worker_expiry", secs(timing.worker_expiry)),
        ("fmucal_coordinator::Timing::default().heartbeat_interval", secs(timing.heartbeat_interval)),
        ("fmucal_coordinator::Timing::default().evaluation_timeout", secs(timing.evaluation_timeout)),
        ("fmucal_coordinator::diagnoses::MAX_RUNNING", n(fmucal_coordinator::diagnoses::MAX_RUNNING)),
        ("fmucal_proto::MAX_ID_BYTES", n(fmucal_proto::MAX_ID_BYTES)),
        ("fmucal_proto::MAX_WORKER_NAME_CHARS", n(fmucal_proto::MAX_WORKER_NAME_CHARS)),
        ("fmucal_coordinator::error::MAX_MESSAGE_CHARS", n(fmucal_coordinator::error::MAX_MESSAGE_CHARS)),
        ("fmucal_shared::quote::MAX_QUOTED_CHARS", n(fmucal_shared::quote::MAX_QUOTED_CHARS)),
        ("fmucal_shared::quote::MAX_ERROR_LINE_CHARS", n(fmucal_shared::quote::MAX_ERROR_LINE_CHARS)),
        ("fmucal_proto::MAX_SLOTS", n(fmucal_proto::MAX_SLOTS)),
        ("fmucal_worker::DEFAULT_STOP_GRACE", secs(fmucal_worker::DEFAULT_STOP_GRACE)),
        ("fmucal_shared::fmu::schema::MAX_VARIABLES", n(fmucal_shared::fmu::schema::MAX_VARIABLES)),
    ]
}

/// The rows of the page's table: (what, cap, how to change it, in the code).
fn rows(page: &str) -> Vec<[String; 4]> {
    page.lines()
        .skip_while(|l| !l.starts_with("| what | cap |"))
        .skip(2)
        .take_while(|l| l.starts_with('|'))
        .map(|l| {
            let cells: Vec<String> = l.trim_matches('|').split(" | ").map(|c| c.trim().to_owned()).collect();
            assert_eq!(cells.len(), 4, "a row of four cells: {l}");
            [cells[0].clone(), cells[1].clone(), cells[2].clone(), cells[3].clone()]
        })
        .collect()
}

#[test]
fn the_limits_page_gives_the_caps_of_the_code() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/src/operations/limits.md");
    let page = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let rows = rows(&page);
    assert!(rows.len() >= 40, "the table has {} rows", rows.len());
    let constants = constants();
    let mut checked = vec![];
    for [what, cap, _, code] in &rows {
        let code = code.trim_matches('`');
        // A constant (or a default) the page names must be one this test reads.
        let names_a_constant = code.rsplit("::").next().is_some_and(|last| {
            last.starts_with("MAX_")
                || last.starts_with("MIN_")
                || last.starts_with("DEFAULT_")
                || last.contains("default()")
        });
        let Some((_, value)) = constants.iter().find(|(name, _)| *name == code) else {
            assert!(!names_a_constant, "{what}: {code} is not checked by this test");
            continue;
        };
        let written = parse_cap(cap).unwrap_or_else(|| panic!("{what}: the cap {cap:?} does not parse"));
        assert!(
            (written - value).abs() <= 1e-9 * value.abs(),
            "{what}: the page says {cap} ({written}), the code {code} = {value}"
        );
        checked.push(code);
    }
    // Every constant listed above appears on the page.
    for (name, _) in &constants {
        assert!(checked.contains(name), "{name} is not on the page");
    }
}

#[test]
fn caps_parse_as_the_page_writes_them() {
    assert_eq!(parse_cap("1,000"), Some(1000.0));
    assert_eq!(parse_cap("256 MiB"), Some(f64::from(256u32 << 20)));
    assert_eq!(parse_cap("2 GiB"), Some(2.0 * f64::from(1u32 << 30)));
    assert_eq!(parse_cap("1e-14"), Some(1e-14));
    assert_eq!(parse_cap("60 s"), Some(60.0));
    assert_eq!(parse_cap("12 characters"), Some(12.0));
    assert_eq!(parse_cap("all"), None);
}
