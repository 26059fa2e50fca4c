//! TLS end to end: `fmucal certs` makes a CA and certificates; a coordinator serving TLS with
//! client certificates required (mutual TLS) runs a job from `fmucal calibrate` for a worker
//! process, both over `https://`; a plaintext client and a client without a certificate are
//! refused; a coordinator refuses to listen off loopback without TLS unless `--insecure`.

mod common;

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::Duration;

use fmucal_proto::auth::AttachToken;
use fmucal_proto::tls::{ClientTls, ServerTls};
use fmucal_proto::v1 as pb;
use fmucal_proto::v1::calibration_client::CalibrationClient;

const TOKEN: &str = "tls-test-client-token";
const WORKER_TOKEN: &str = "tls-test-worker-token";

fn fmucal(args: &[&str], dir: &Path) -> Command {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_fmucal"));
    cmd.args(args).current_dir(dir).env("FMUCAL_CACHE_DIR", dir.join("cache"));
    for var in ["FMUCAL_TOKEN", "FMUCAL_WORKER_TOKEN", "FMUCAL_TLS_CA", "FMUCAL_TLS_CERT", "FMUCAL_TLS_KEY"] {
        cmd.env_remove(var);
    }
    cmd
}

fn read(dir: &Path, name: &str) -> Vec<u8> {
    std::fs::read(dir.join(name)).unwrap()
}

/// A `ListJobs` call on `url` with `tls`.
async fn list_jobs(url: &str, tls: Option<&ClientTls>) -> Result<(), String> {
    let endpoint = fmucal_proto::tls::endpoint(url, tls)?;
    let channel = endpoint.connect().await.map_err(|e| format!("{e:?}"))?;
    let mut c = CalibrationClient::with_interceptor(channel, AttachToken::new(Some(TOKEN)).unwrap());
    c.list_jobs(pb::ListJobsRequest {}).await.map(|_| ()).map_err(|s| s.to_string())
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_job_runs_over_mutual_tls_and_plaintext_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let certs = dir.path().join("certs");
    let out = fmucal(&["certs", "--out", certs.to_str().unwrap()], dir.path()).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));

    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
    let url = format!("https://localhost:{}", listener.local_addr().unwrap().port());
    let (stop, stopped) = tokio::sync::oneshot::channel::<()>();
    let config = fmucal_coordinator::Config {
        token: Some(TOKEN.into()),
        worker_token: Some(WORKER_TOKEN.into()),
        tls: Some(ServerTls {
            cert_pem: read(&certs, "coordinator.pem"),
            key_pem: read(&certs, "coordinator-key.pem"),
            client_ca_pem: Some(read(&certs, "ca.pem")),
            ca_pem: Some(read(&certs, "ca.pem")),
        }),
        ..fmucal_coordinator::Config::new(dir.path().join("coord"))
    };
    let server = tokio::spawn(fmucal_coordinator::run(config, listener, async {
        let _ = stopped.await;
    }));

    let client = ClientTls {
        ca_pem: read(&certs, "ca.pem"),
        identity: Some((read(&certs, "client.pem"), read(&certs, "client-key.pem"))),
    };
    let mut ok = Err(String::new());
    for _ in 0..50 {
        ok = list_jobs(&url, Some(&client)).await;
        if ok.is_ok() {
            break;
        }
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
    ok.unwrap();
    // Plaintext, and TLS without a client certificate, are refused.
    assert!(list_jobs(&url.replace("https", "http"), None).await.is_err(), "plaintext was served");
    let e = list_jobs(&url.replace("https", "http"), Some(&client)).await.unwrap_err();
    assert!(e.contains("is not https://"), "{e}");
    let anonymous = ClientTls { identity: None, ..client.clone() };
    assert!(list_jobs(&url, Some(&anonymous)).await.is_err(), "a client without a certificate was served");

    // A worker and `fmucal calibrate`, both over mutual TLS.
    let tls_args = |args: &[&str]| {
        let mut all: Vec<String> = args.iter().map(|s| s.to_string()).collect();
        for (flag, file) in [("--tls-ca", "ca.pem"), ("--tls-cert", "client.pem"), ("--tls-key", "client-key.pem")] {
            all.push(flag.into());
            all.push(certs.join(file).to_string_lossy().into_owned());
        }
        all
    };
    let worker_args = tls_args(&["worker", "--coordinator", &url, "--cache-dir", "wcache"]);
    let mut worker = common::KillOnDrop(
        fmucal(&worker_args.iter().map(String::as_str).collect::<Vec<_>>(), dir.path())
            .env("FMUCAL_WORKER_TOKEN", WORKER_TOKEN)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap(),
    );
    common::write_decay_csv(dir.path(), common::decay_samples(&dir.path().join("cache"), None, 4));
    let job = common::decay_job_toml(5.0, "[optimizer]\nmax_iters = 40\n");
    std::fs::write(dir.path().join("job.toml"), job).unwrap();
    let calibrate_args = tls_args(&["calibrate", "job.toml", "--coordinator", &url, "--out", "out"]);
    let out = tokio::task::spawn_blocking({
        let mut cmd = fmucal(&calibrate_args.iter().map(String::as_str).collect::<Vec<_>>(), dir.path());
        cmd.env("FMUCAL_TOKEN", TOKEN);
        move || cmd.output().unwrap()
    })
    .await
    .unwrap();
    let _ = worker.kill();
    let _ = worker.wait();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let result: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("out/result.json")).unwrap()).unwrap();
    let k = result["x_opt"]["k"].as_f64().unwrap();
    assert!((k - 1.7).abs() < 1e-3, "k = {k}");
    let _ = stop.send(());
    server.await.unwrap().unwrap();
}

#[test]
fn a_coordinator_off_loopback_needs_tls_or_insecure() {
    let dir = tempfile::tempdir().unwrap();
    let out = fmucal(&["coordinator", "--listen", "0.0.0.0:0", "--data-dir", "data"], dir.path())
        .env("FMUCAL_TOKEN", TOKEN)
        .output()
        .unwrap();
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("without TLS") && stderr.contains("--insecure"), "{stderr}");
    // Certificates from `fmucal certs` are accepted, and `--keep` leaves them as they are.
    let certs = dir.path().join("certs");
    for _ in 0..2 {
        let out = fmucal(&["certs", "--out", "certs", "--host", "coordinator", "--keep"], dir.path()).output().unwrap();
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    }
    let out = fmucal(&["certs", "--out", "certs"], dir.path()).output().unwrap();
    assert!(!out.status.success(), "existing certificates were overwritten");
    std::fs::remove_file(certs.join("client.pem")).unwrap();
    let out = fmucal(&["certs", "--out", "certs", "--keep"], dir.path()).output().unwrap();
    assert!(String::from_utf8_lossy(&out.stderr).contains("some are missing"), "an incomplete set was kept");
    let tls = ServerTls {
        cert_pem: read(&certs, "coordinator.pem"),
        key_pem: read(&certs, "coordinator-key.pem"),
        client_ca_pem: None,
        ca_pem: None,
    };
    assert!(
        tonic::transport::Server::builder()
            .tls_config(
                tonic::transport::ServerTlsConfig::new()
                    .identity(tonic::transport::Identity::from_pem(&tls.cert_pem, &tls.key_pem))
            )
            .is_ok()
    );
}
