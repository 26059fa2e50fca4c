//! Command-line parsing (clap) and dispatch. Each subcommand lives in its own module; errors
//! are printed as one line and give exit code 1 (clap's usage errors give 2, an interrupted
//! calibration 130).

mod calibrate;
mod client;
mod diagnose;
mod export;
mod health;
mod inspect;
mod known_archives;
mod local_cluster;
mod metrics_http;
mod model_arg;
mod outputs;
mod run_dir;
mod servers;
mod simulate;
mod tls;
pub mod token;

use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};

use anyhow::Context;
use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(name = "fmucal", version, about = "Calibrate FMU parameters against measurements")]
struct Cli {
    /// How logs are written to stderr: `text`, or `json` (one JSON object per line, for log
    /// collectors; status lines such as the listening address become info events, and the
    /// default level is info instead of warn). FMUCAL_LOG sets the level either way.
    #[arg(long, global = true, value_enum, default_value_t = LogFormat::Text)]
    log_format: LogFormat,
    #[command(subcommand)]
    command: Command,
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum LogFormat {
    Text,
    Json,
}

/// Whether logs are JSON lines (`--log-format json`).
static JSON_LOGS: AtomicBool = AtomicBool::new(false);

/// A status line for the person at the terminal (the address a server listens on): on stderr,
/// or as an info event when logs are JSON, so that every line stays JSON.
pub(crate) fn status(line: &str) {
    if JSON_LOGS.load(Ordering::Relaxed) {
        tracing::info!("{line}");
    } else {
        eprintln!("{line}");
    }
}

/// Sets up logging; a FMUCAL_LOG that does not parse is refused, not ignored.
fn init_logs(format: LogFormat) -> anyhow::Result<()> {
    let json = format == LogFormat::Json;
    JSON_LOGS.store(json, Ordering::Relaxed);
    let default_level = if json { "info" } else { "warn" };
    let filter = match std::env::var("FMUCAL_LOG") {
        Ok(v) if !v.trim().is_empty() => tracing_subscriber::EnvFilter::try_new(&v).map_err(|e| {
            let shown: String = v.chars().take(64).flat_map(char::escape_debug).collect();
            anyhow::anyhow!("FMUCAL_LOG: {e} in \"{shown}\" (a level such as `info`, or `fmucal=debug,warn`)")
        })?,
        Ok(_) => default_level.into(),
        Err(std::env::VarError::NotPresent) => default_level.into(),
        Err(std::env::VarError::NotUnicode(_)) => anyhow::bail!("FMUCAL_LOG: not UTF-8"),
    };
    let logs = tracing_subscriber::fmt().with_writer(std::io::stderr).with_env_filter(filter);
    if json {
        logs.json().init();
    } else {
        logs.with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr())).init();
    }
    Ok(())
}

#[derive(Subcommand)]
enum Command {
    /// Show an FMU's interfaces, default experiment and variables.
    ///
    /// The tables keep their columns: a name longer than 40 characters, a type longer than 12,
    /// a start value longer than 16, a unit longer than 10 or a description longer than 80 is
    /// cut with "…" (`--json` prints every value whole). Local variables are counted, and
    /// listed with `--all`.
    Inspect(inspect::Args),
    /// Simulate an FMU and write the results as CSV.
    Simulate(simulate::Args),
    /// List the built-in example FMUs and where they are.
    Examples,
    /// Calibrate a job's parameters (locally with worker processes, or on a coordinator).
    Calibrate(calibrate::Args),
    /// Find what the model lacks: calibrate, screen candidate effects, fit the best on the
    /// workers, and name the one that wins on held-out data (or none).
    Diagnose(diagnose::Args),
    /// Write the calibrated model, with the job's effects inside, as an FMI 2.0 FMU that any
    /// FMI tool runs (x86_64 Linux).
    Export(export::Args),
    /// Run a coordinator server.
    Coordinator(servers::CoordinatorArgs),
    /// Run a worker that evaluates points for a coordinator.
    Worker(servers::WorkerArgs),
    /// Make a private CA with a coordinator and a client certificate, for TLS.
    Certs(tls::CertsArgs),
    /// Ask a coordinator or worker for its gRPC health; exit 0 only when SERVING (for
    /// container healthchecks and probes).
    Health(health::Args),
    /// Redraw the plots of a calibration result folder.
    Plot {
        /// A folder written by `fmucal calibrate --out`.
        dir: std::path::PathBuf,
    },
}

/// A run stopped by Ctrl-C or SIGTERM (exit code 130, as a shell reports SIGINT).
#[derive(Debug, thiserror::Error)]
#[error("interrupted")]
pub(crate) struct Interrupted;

/// What an HTTP/2 error that a plaintext client gets from a TLS server (the server's TLS
/// alert read as an HTTP/2 frame) likely means.
fn protocol_hint(line: &str) -> Option<&'static str> {
    let garbled =
        ["frame with invalid size", "h2 protocol error", "invalid HTTP/2 preface", "connection error: PROTOCOL_ERROR"];
    garbled
        .iter()
        .any(|g| line.contains(g))
        .then_some(" (the server did not speak plaintext HTTP/2: if it serves TLS, use an https:// URL with --tls-ca)")
}

/// Runs the CLI with the process arguments.
pub fn main() -> ExitCode {
    let cli = Cli::parse();
    // Settings from the environment are checked before anything runs: a bad one is refused
    // in one line, never silently replaced by a default.
    if let Err(e) = init_logs(cli.log_format)
        .and_then(|()| fmucal_shared::fmu::ArchiveLimits::try_from_env().map(|_| ()).map_err(anyhow::Error::from))
    {
        eprintln!("error: {e:#}");
        return ExitCode::FAILURE;
    }
    let result = match cli.command {
        Command::Inspect(args) => inspect::run(args),
        Command::Simulate(args) => simulate::run(args),
        Command::Calibrate(args) => calibrate::run(args),
        Command::Diagnose(args) => diagnose::run(args),
        Command::Export(args) => export::run(args),
        Command::Coordinator(args) => servers::coordinator(args),
        Command::Worker(args) => servers::worker(args),
        Command::Certs(args) => tls::certs(args),
        Command::Health(args) => health::run(args),
        Command::Plot { dir } => outputs::read(&dir).and_then(|(result, fits)| {
            for (k, (folder, fit)) in fits.iter().enumerate() {
                let errors = result.experiments.get(k).map(|e| &e.errors).or(result.errors.as_ref());
                crate::report::draw_all(folder, fit, &result.history, &result.parameters, errors)?;
                eprintln!("wrote the plots to {}", folder.display());
            }
            Ok(())
        }),
        Command::Examples => fmucal_models::example_names().into_iter().try_for_each(|name| {
            let path = model_arg::example(name)?.context("an embedded example")?;
            println!("{name:<14} {}", path.display());
            Ok(())
        }),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) if e.is::<calibrate::Warned>() => {
            status(&format!("{e}"));
            ExitCode::from(3)
        }
        Err(e) if e.is::<Interrupted>() => {
            status("interrupted");
            ExitCode::from(130)
        }
        Err(e) => {
            // What the error quotes may come from a job file: bounded and escaped as a whole
            // too, so a long or hostile value the message did not quote itself stays harmless.
            // A TOML syntax error keeps the parser's layout (its line, a caret under the
            // column): each line escaped, as bounded as the one line of any other error.
            let toml = e.chain().any(|c| {
                matches!(c.downcast_ref::<fmucal_shared::job::JobError>(),
                    Some(fmucal_shared::job::JobError::Invalid { field, .. }) if field == "toml")
            });
            let text = format!("{e:#}");
            let mut line = if toml {
                text.lines()
                    .take(8)
                    .map(|l| fmucal_shared::quote::escape_user_text(l, fmucal_shared::quote::MAX_ERROR_LINE_CHARS / 8))
                    .collect::<Vec<_>>()
                    .join("\n")
            } else {
                fmucal_shared::quote::escape_user_text(
                    &text.replace('\n', " "),
                    fmucal_shared::quote::MAX_ERROR_LINE_CHARS,
                )
            };
            if let Some(hint) = protocol_hint(&line) {
                line.push_str(hint);
            }
            if JSON_LOGS.load(Ordering::Relaxed) {
                tracing::error!("{line}");
            } else {
                eprintln!("error: {line}");
            }
            ExitCode::FAILURE
        }
    }
}
