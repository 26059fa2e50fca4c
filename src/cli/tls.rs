//! TLS on the command line: the coordinator's certificate, key and optional client CA
//! ([`ServerArgs`]); what a client or worker needs to reach an `https://` coordinator
//! ([`ClientArgs`], also from `FMUCAL_TLS_CA`, `FMUCAL_TLS_CERT` and `FMUCAL_TLS_KEY`); and
//! `fmucal certs`, which makes a private CA with a coordinator and a client certificate, so a
//! pool can run TLS without openssl.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use fmucal_proto::tls::{ClientTls, ServerTls};

fn read(path: &Path, what: &str) -> Result<Vec<u8>> {
    std::fs::read(path).with_context(|| format!("cannot read the {what} {}", path.display()))
}

/// The base64 payloads of the PEM blocks labelled `label` in `text`, decoded (`None`: not
/// valid base64).
fn pem_blocks(text: &str, label: &str) -> Vec<Option<Vec<u8>>> {
    let (begin, end) = (format!("-----BEGIN {label}-----"), format!("-----END {label}-----"));
    let mut out = vec![];
    let mut rest = text;
    while let Some(at) = rest.find(&begin) {
        let body = &rest[at + begin.len()..];
        let Some(stop) = body.find(&end) else {
            out.push(None);
            break;
        };
        out.push(base64_decode(&body[..stop]));
        rest = &body[stop + end.len()..];
    }
    out
}

/// Standard base64 (whitespace ignored, `=` padding); `None` if it is not.
fn base64_decode(text: &str) -> Option<Vec<u8>> {
    let mut out = vec![];
    let (mut acc, mut bits) = (0u32, 0u32);
    for c in text.bytes().filter(|c| !c.is_ascii_whitespace()) {
        let v = match c {
            b'A'..=b'Z' => c - b'A',
            b'a'..=b'z' => c - b'a' + 26,
            b'0'..=b'9' => c - b'0' + 52,
            b'+' => 62,
            b'/' => 63,
            b'=' => continue,
            _ => return None,
        };
        acc = (acc << 6) | u32::from(v);
        bits += 6;
        if bits >= 8 {
            bits -= 8;
            out.push((acc >> bits) as u8);
            acc &= (1 << bits) - 1;
        }
    }
    Some(out)
}

/// The certificates (DER) of the PEM file at `path`, refusing one that holds none or a
/// damaged one, with the file's name.
fn certificates(pem: &[u8], path: &Path, what: &str) -> Result<Vec<Vec<u8>>> {
    let text = std::str::from_utf8(pem).ok();
    let blocks = text.map(|t| pem_blocks(t, "CERTIFICATE")).unwrap_or_default();
    anyhow::ensure!(
        !blocks.is_empty(),
        "the {what} {} holds no PEM certificate (-----BEGIN CERTIFICATE-----)",
        path.display()
    );
    blocks
        .into_iter()
        .enumerate()
        .map(|(k, der)| {
            // A certificate is a DER SEQUENCE.
            der.filter(|d| d.len() > 64 && d[0] == 0x30).with_context(|| {
                format!("the {what} {}: certificate {} is damaged (not base64 DER)", path.display(), k + 1)
            })
        })
        .collect()
}

/// Checks that the PEM file at `key_path` holds a private key, and that it is the key of the
/// certificate `cert` (read from `cert_path`) where the key's type can be read here.
fn check_key(key: &[u8], key_path: &Path, cert: &[u8], cert_path: &Path) -> Result<()> {
    let text = std::str::from_utf8(key).ok().filter(|t| t.contains("PRIVATE KEY-----"));
    let text = text.with_context(|| format!("the key {} holds no PEM private key", key_path.display()))?;
    if let Ok(pair) = rcgen::KeyPair::from_pem(text) {
        let public = pair.public_key_raw();
        anyhow::ensure!(
            !public.is_empty() && cert.windows(public.len()).any(|w| w == public),
            "the key {} does not belong to the certificate {}",
            key_path.display(),
            cert_path.display()
        );
    }
    Ok(())
}

/// The flag if given, else the environment variable.
fn flag_or_env(flag: &Option<PathBuf>, var: &str) -> Option<PathBuf> {
    flag.clone().or_else(|| std::env::var_os(var).filter(|v| !v.is_empty()).map(PathBuf::from))
}

/// How this client reaches an `https://` coordinator.
#[derive(clap::Args, Debug, Default)]
pub struct ClientArgs {
    /// CA certificate (PEM) an https:// coordinator's certificate is signed by (else FMUCAL_TLS_CA).
    #[arg(long)]
    tls_ca: Option<PathBuf>,
    /// This client's certificate (PEM), for a coordinator that requires one (else FMUCAL_TLS_CERT).
    #[arg(long, requires = "tls_key")]
    tls_cert: Option<PathBuf>,
    /// The key of --tls-cert (PEM; else FMUCAL_TLS_KEY).
    #[arg(long, requires = "tls_cert")]
    tls_key: Option<PathBuf>,
}

impl ClientArgs {
    /// The TLS settings, `None` if no CA is given.
    ///
    /// # Errors
    /// An unreadable file, or a certificate without its key.
    pub fn load(&self) -> Result<Option<ClientTls>> {
        let Some(ca) = flag_or_env(&self.tls_ca, "FMUCAL_TLS_CA") else { return Ok(None) };
        let identity =
            match (flag_or_env(&self.tls_cert, "FMUCAL_TLS_CERT"), flag_or_env(&self.tls_key, "FMUCAL_TLS_KEY")) {
                (Some(cert), Some(key)) => {
                    let (cert_pem, key_pem) = (read(&cert, "certificate")?, read(&key, "key")?);
                    let ders = certificates(&cert_pem, &cert, "certificate")?;
                    check_key(&key_pem, &key, &ders[0], &cert)?;
                    Some((cert_pem, key_pem))
                }
                (None, None) => None,
                _ => anyhow::bail!("give both a client certificate and its key (--tls-cert and --tls-key)"),
            };
        let ca_pem = read(&ca, "CA certificate")?;
        certificates(&ca_pem, &ca, "CA certificate")?;
        Ok(Some(ClientTls { ca_pem, identity }))
    }

    /// The CA certificate's file, if one is given.
    pub fn ca_path(&self) -> Option<PathBuf> {
        flag_or_env(&self.tls_ca, "FMUCAL_TLS_CA")
    }
}

/// The coordinator's TLS.
#[derive(clap::Args, Debug)]
pub struct ServerArgs {
    /// Serve TLS with this certificate (PEM, its chain after it).
    #[arg(long, requires = "tls_key")]
    tls_cert: Option<PathBuf>,
    /// The key of --tls-cert (PEM).
    #[arg(long, requires = "tls_cert")]
    tls_key: Option<PathBuf>,
    /// Require client certificates signed by this CA (PEM) from clients and workers (mutual TLS).
    #[arg(long, requires = "tls_cert")]
    tls_client_ca: Option<PathBuf>,
    /// The CA (PEM) that signed --tls-cert: the coordinator's own diagnosis process trusts it.
    #[arg(long, requires = "tls_cert")]
    tls_ca: Option<PathBuf>,
    /// Listen off loopback without TLS (the token then crosses the network in clear text).
    #[arg(long)]
    insecure: bool,
}

impl ServerArgs {
    /// The TLS settings (`None`: plaintext), refusing plaintext off loopback without
    /// `--insecure`.
    ///
    /// # Errors
    /// An unreadable file, or plaintext on a non-loopback address without `--insecure`.
    pub fn load(&self, listen: std::net::SocketAddr) -> Result<Option<ServerTls>> {
        let (Some(cert), Some(key)) = (&self.tls_cert, &self.tls_key) else {
            anyhow::ensure!(
                listen.ip().is_loopback() || self.insecure,
                "refusing to listen on {listen} without TLS: the token and the models would cross the network in \
                 clear text; give --tls-cert and --tls-key (`fmucal certs` makes them), or --insecure"
            );
            return Ok(None);
        };
        let optional = |p: &Option<PathBuf>, what: &str| {
            p.as_deref()
                .map(|p| {
                    let pem = read(p, what)?;
                    certificates(&pem, p, what)?;
                    Ok::<_, anyhow::Error>(pem)
                })
                .transpose()
        };
        let (cert_pem, key_pem) = (read(cert, "certificate")?, read(key, "key")?);
        let ders = certificates(&cert_pem, cert, "certificate")?;
        check_key(&key_pem, key, &ders[0], cert)?;
        Ok(Some(ServerTls {
            cert_pem,
            key_pem,
            client_ca_pem: optional(&self.tls_client_ca, "client CA certificate")?,
            ca_pem: optional(&self.tls_ca, "CA certificate")?,
        }))
    }
}

/// `fmucal certs`.
#[derive(clap::Args, Debug)]
pub struct CertsArgs {
    /// Folder to write ca.pem, coordinator.pem, coordinator-key.pem, client.pem and
    /// client-key.pem to (created; existing files are not overwritten).
    #[arg(long)]
    out: PathBuf,
    /// Names and addresses the coordinator is reached at (localhost and 127.0.0.1 are always
    /// included), e.g. `--host coordinator --host fmucal.example.org`.
    #[arg(long)]
    host: Vec<String>,
    /// Do nothing if `--out` already holds the certificates (for a setup step that runs at
    /// every start).
    #[arg(long)]
    keep: bool,
    /// Also copy ca.pem into this folder (what workers mount: they need no key).
    #[arg(long)]
    ca_out: Option<PathBuf>,
}

/// The files `fmucal certs` writes.
const FILES: [&str; 5] = ["ca.pem", "coordinator.pem", "coordinator-key.pem", "client.pem", "client-key.pem"];

/// PEM text of a private CA, a coordinator certificate (valid for `hosts`, localhost and
/// 127.0.0.1, for server and client authentication), and a client certificate, each with its
/// key: `(ca, (coordinator, key), (client, key))`.
///
/// # Errors
/// If a host name is not a valid DNS name or IP address.
pub fn make_certificates(hosts: &[String]) -> Result<(String, (String, String), (String, String))> {
    use rcgen::{
        BasicConstraints, CertificateParams, DnType, ExtendedKeyUsagePurpose, IsCa, Issuer, KeyPair, KeyUsagePurpose,
    };
    let mut ca = CertificateParams::new(Vec::<String>::new())?;
    ca.is_ca = IsCa::Ca(BasicConstraints::Unconstrained);
    ca.distinguished_name.push(DnType::CommonName, "fmucal private CA");
    ca.key_usages = vec![KeyUsagePurpose::KeyCertSign, KeyUsagePurpose::CrlSign, KeyUsagePurpose::DigitalSignature];
    let ca_key = KeyPair::generate()?;
    let ca_pem = ca.self_signed(&ca_key)?.pem();
    let issuer = Issuer::new(ca, ca_key);
    let leaf = |names: Vec<String>, cn: &str, usages: Vec<ExtendedKeyUsagePurpose>| -> Result<(String, String)> {
        let mut params = CertificateParams::new(names).context("a --host is not a DNS name or IP address")?;
        params.distinguished_name.push(DnType::CommonName, cn);
        params.extended_key_usages = usages;
        let key = KeyPair::generate()?;
        Ok((params.signed_by(&key, &issuer)?.pem(), key.serialize_pem()))
    };
    let mut names = vec!["localhost".to_owned(), "127.0.0.1".to_owned()];
    names.extend(hosts.iter().filter(|h| !names.contains(h)).cloned().collect::<Vec<_>>());
    let both = vec![ExtendedKeyUsagePurpose::ServerAuth, ExtendedKeyUsagePurpose::ClientAuth];
    let coordinator = leaf(names, "fmucal coordinator", both)?;
    let client = leaf(vec![], "fmucal client", vec![ExtendedKeyUsagePurpose::ClientAuth])?;
    Ok((ca_pem, coordinator, client))
}

/// Checks a `--host` of `fmucal certs`: an IP address, or a DNS name of at most 253
/// characters in dot-separated labels of 1 to 63 letters, digits and hyphens (not at either
/// end of a label), the first label optionally `*`.
///
/// # Errors
/// In one line naming `--host` and quoting the name.
pub fn check_host(host: &str) -> Result<()> {
    if host.parse::<std::net::IpAddr>().is_ok() {
        return Ok(());
    }
    let label_ok = |(k, l): (usize, &str)| {
        (k == 0 && l == "*")
            || (!l.is_empty()
                && l.len() <= 63
                && l.bytes().all(|b| b.is_ascii_alphanumeric() || b == b'-')
                && !l.starts_with('-')
                && !l.ends_with('-'))
    };
    anyhow::ensure!(
        !host.is_empty() && host.len() <= 253 && host.split('.').enumerate().all(label_ok),
        "--host: {} is not an IP address or a DNS name (labels of letters, digits and '-', at most 63 characters each and 253 in all)",
        fmucal_shared::quote::quote_user_text(host)
    );
    Ok(())
}

pub fn certs(args: CertsArgs) -> Result<()> {
    for host in &args.host {
        check_host(host)?;
    }
    let present = FILES.iter().filter(|f| args.out.join(f).is_file()).count();
    if args.keep && present == FILES.len() {
        eprintln!("kept the certificates in {}", args.out.display());
        return copy_ca(&args);
    }
    anyhow::ensure!(
        present == 0,
        "{} already holds certificates: remove them to make new ones{}",
        args.out.display(),
        if args.keep { " (some are missing, so --keep cannot keep them)" } else { "" }
    );
    let (ca, (cert, key), (client, client_key)) = make_certificates(&args.host)?;
    std::fs::create_dir_all(&args.out).with_context(|| format!("cannot create {}", args.out.display()))?;
    for (name, text, private) in [
        ("ca.pem", &ca, false),
        ("coordinator.pem", &cert, false),
        ("coordinator-key.pem", &key, true),
        ("client.pem", &client, false),
        ("client-key.pem", &client_key, true),
    ] {
        let path = args.out.join(name);
        let mut options = std::fs::OpenOptions::new();
        options.write(true).create_new(true);
        if private {
            std::os::unix::fs::OpenOptionsExt::mode(&mut options, 0o600);
        }
        let mut file = options.open(&path).with_context(|| format!("cannot create {}", path.display()))?;
        std::io::Write::write_all(&mut file, text.as_bytes())?;
    }
    eprintln!("wrote {} to {}", FILES.join(", "), args.out.display());
    copy_ca(&args)
}

fn copy_ca(args: &CertsArgs) -> Result<()> {
    if let Some(dir) = &args.ca_out {
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
        std::fs::copy(args.out.join("ca.pem"), dir.join("ca.pem"))
            .with_context(|| format!("cannot copy ca.pem to {}", dir.display()))?;
    }
    Ok(())
}
