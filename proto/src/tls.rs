//! TLS for every connection to a coordinator (rustls through tonic): what a client or worker
//! needs to reach an `https://` coordinator — the CA that signed the coordinator's certificate
//! and, where the coordinator asks for client certificates (mutual TLS), its own certificate and
//! key — and the endpoint built from it. An `http://` URL is plaintext.

use std::time::Duration;

use tonic::transport::{Certificate, ClientTlsConfig, Endpoint, Identity};

/// How a client reaches an `https://` coordinator (PEM text).
#[derive(Debug, Clone, Default)]
pub struct ClientTls {
    /// The CA that signed the coordinator's certificate.
    pub ca_pem: Vec<u8>,
    /// This client's certificate and key, for a coordinator that asks for one.
    pub identity: Option<(Vec<u8>, Vec<u8>)>,
}

/// The coordinator's side (PEM text).
#[derive(Debug, Clone)]
pub struct ServerTls {
    pub cert_pem: Vec<u8>,
    pub key_pem: Vec<u8>,
    /// Require client certificates signed by this CA (mutual TLS), of clients and workers alike.
    pub client_ca_pem: Option<Vec<u8>>,
    /// The CA that signed `cert_pem`: what the coordinator's own diagnosis process trusts.
    pub ca_pem: Option<Vec<u8>>,
}

/// How often every fmucal client pings its coordinator, and how long it waits for the answer.
pub const KEEP_ALIVE: Duration = Duration::from_secs(5);

/// An endpoint for `url`, with TLS when it is `https://`, and the timeouts every fmucal client
/// uses (2 s to connect, HTTP/2 pings every [`KEEP_ALIVE`]).
///
/// # Errors
/// A one-line reason: a malformed URL, an `https://` URL without `tls` (or TLS settings for
/// another URL), or TLS settings tonic refuses.
pub fn endpoint(url: &str, tls: Option<&ClientTls>) -> Result<Endpoint, String> {
    let endpoint = Endpoint::from_shared(url.to_owned())
        .map_err(|e| format!("{url:?} is not a coordinator URL: {e}"))?
        .tcp_nodelay(true)
        .connect_timeout(Duration::from_secs(2))
        // A connection whose peer vanished without closing it (a network partition, a
        // coordinator container replaced) is found dead within 10 s, so the channel reconnects
        // instead of waiting on TCP's retransmission timeout for minutes.
        .http2_keep_alive_interval(KEEP_ALIVE)
        .keep_alive_timeout(KEEP_ALIVE)
        .keep_alive_while_idle(true);
    if !url.starts_with("https://") {
        if tls.is_some() {
            return Err(format!("TLS settings were given but {url} is not https://"));
        }
        return Ok(endpoint);
    }
    let tls =
        tls.ok_or_else(|| format!("{url} uses TLS: give the CA of its certificate (--tls-ca or FMUCAL_TLS_CA)"))?;
    let mut config = ClientTlsConfig::new().ca_certificate(Certificate::from_pem(&tls.ca_pem));
    if let Some((cert, key)) = &tls.identity {
        config = config.identity(Identity::from_pem(cert, key));
    }
    endpoint.tls_config(config).map_err(|e| format!("TLS settings for {url}: {e}"))
}

/// `e` and every error it was caused by, joined by `: ` (tonic's transport errors say only
/// "transport error" by themselves; the cause, such as a certificate refused, is in the chain).
pub fn error_chain(e: &(dyn std::error::Error + 'static)) -> String {
    let mut text = e.to_string();
    let mut source = e.source();
    while let Some(s) = source {
        let next = s.to_string();
        if !text.ends_with(&next) {
            text.push_str(": ");
            text.push_str(&next);
        }
        source = s.source();
    }
    text
}

/// Whether the server at an `http://` URL in fact speaks TLS: it answers the HTTP/2 preface
/// with a TLS record (an alert) instead of HTTP/2 frames. For an error message after a
/// plaintext call failed at the connection level; `false` when it cannot tell.
pub fn http_url_serves_tls(url: &str) -> bool {
    use std::io::{Read, Write};
    use std::net::ToSocketAddrs;
    let Some(rest) = url.strip_prefix("http://") else { return false };
    let authority = rest.split('/').next().unwrap_or_default();
    let Some(addr) = authority.to_socket_addrs().ok().and_then(|mut a| a.next()) else { return false };
    let Ok(mut stream) = std::net::TcpStream::connect_timeout(&addr, Duration::from_secs(2)) else { return false };
    let _ = stream.set_read_timeout(Some(Duration::from_secs(2)));
    let _ = stream.set_write_timeout(Some(Duration::from_secs(2)));
    if stream.write_all(b"PRI * HTTP/2.0\r\n\r\nSM\r\n\r\n").is_err() {
        return false;
    }
    let mut head = [0u8; 3];
    // A TLS record starts with its type (21: alert, 22: handshake) and version 3.x.
    stream.read_exact(&mut head).is_ok() && matches!(head[0], 21 | 22) && head[1] == 3
}
