//! `fmucal health URL`: asks a coordinator or a worker's `--health-listen` address for its
//! `grpc.health.v1` status and exits 0 only when it is SERVING. Container healthchecks and
//! Kubernetes exec probes use it, so they speak TLS to a coordinator as every client does.

use std::time::Duration;

use anyhow::{Context, Result, bail};
use tonic_health::pb::HealthCheckRequest;
use tonic_health::pb::health_check_response::ServingStatus;
use tonic_health::pb::health_client::HealthClient;

use super::tls::ClientArgs;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// The coordinator (`https://HOST:PORT` with --tls-ca, or `http://`) or a worker's
    /// `--health-listen` address (`http://HOST:PORT`).
    url: String,
    /// The service to ask about; empty asks about the server as a whole.
    #[arg(long, default_value = "")]
    service: String,
    /// Give up after this many seconds.
    #[arg(long, default_value_t = 5.0)]
    timeout: f64,
    #[command(flatten)]
    tls: ClientArgs,
}

/// Checks the server's health.
///
/// # Errors
/// The server cannot be reached within the timeout, or its status is not SERVING.
pub fn run(args: Args) -> Result<()> {
    if !(args.timeout.is_finite() && args.timeout > 0.0) {
        bail!("--timeout must be a positive number of seconds, not {}", args.timeout);
    }
    super::client::check_url("URL", &args.url)?;
    let tls = args.tls.load()?;
    let timeout = Duration::try_from_secs_f64(args.timeout)
        .map_err(|_| anyhow::anyhow!("--timeout must be a positive number of seconds, not {}", args.timeout))?;
    // Connecting (with the TLS handshake) may take the whole --timeout, as under a flood of
    // connections: the clients' usual 2 s would cut it short.
    let endpoint =
        fmucal_proto::tls::endpoint(&args.url, tls.as_ref()).map_err(anyhow::Error::msg)?.connect_timeout(timeout);
    let rt = tokio::runtime::Builder::new_current_thread().enable_all().build()?;
    let outcome = rt.block_on(async {
        tokio::time::timeout(timeout, async {
            let channel = endpoint.connect().await.with_context(|| format!("cannot reach {}", args.url))?;
            let request = HealthCheckRequest { service: args.service.clone() };
            let response = HealthClient::new(channel)
                .check(request)
                .await
                .with_context(|| format!("{} did not answer the health check", args.url))?;
            anyhow::Ok(response.into_inner().status)
        })
        .await
    });
    let status = match outcome {
        // Nothing answered within --timeout: no time is left to look for TLS, and a TLS server
        // would have answered a plaintext client at once.
        Err(elapsed) => {
            return Err(
                anyhow::Error::new(elapsed).context(format!("{} did not answer within {} s", args.url, args.timeout))
            );
        }
        Ok(Ok(status)) => status,
        Ok(Err(e)) if fmucal_proto::tls::http_url_serves_tls(&args.url) => {
            return Err(e.context(format!("{} serves TLS: use an https:// URL with --tls-ca", args.url)));
        }
        Ok(Err(e)) => return Err(e),
    };
    let status = ServingStatus::try_from(status).unwrap_or(ServingStatus::Unknown);
    if status != ServingStatus::Serving {
        bail!("{} is {}", args.url, status.as_str_name());
    }
    println!("{} is SERVING", args.url);
    Ok(())
}
