//! Serves a Prometheus registry at `GET /metrics` (text format 0.0.4) on a listener of its own,
//! for `fmucal coordinator --metrics-listen` and `fmucal worker --metrics-listen`. The port
//! answers without a token: it tells counts and timings only, so bind it where only the
//! scraper reaches it.

use std::net::SocketAddr;
use std::sync::Arc;

use anyhow::{Context, Result};
use axum::http::{StatusCode, header};
use axum::response::{IntoResponse, Response};
use prometheus_client::encoding::prometheus_text;
use prometheus_client::registry::Registry;

/// Binds `addr` and serves `registry` there in the background, for as long as the process
/// runs; returns the bound address.
///
/// # Errors
/// If `addr` cannot be bound.
pub async fn spawn(addr: SocketAddr, registry: Registry) -> Result<SocketAddr> {
    let listener =
        tokio::net::TcpListener::bind(addr).await.with_context(|| format!("cannot listen for metrics on {addr}"))?;
    let bound = listener.local_addr()?;
    let registry = Arc::new(registry);
    let app = axum::Router::new().route(
        "/metrics",
        axum::routing::get(move || {
            let registry = registry.clone();
            async move { scrape(&registry) }
        }),
    );
    tokio::spawn(async move {
        if let Err(e) = axum::serve(listener, app).await {
            tracing::error!("the metrics listener failed: {e}");
        }
    });
    Ok(bound)
}

fn scrape(registry: &Registry) -> Response {
    let mut body = String::new();
    match prometheus_text::encode(&mut body, registry) {
        Ok(()) => ([(header::CONTENT_TYPE, prometheus_text::CONTENT_TYPE)], body).into_response(),
        Err(e) => (StatusCode::INTERNAL_SERVER_ERROR, format!("cannot encode the metrics: {e}")).into_response(),
    }
}
