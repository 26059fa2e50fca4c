//! What the service benchmarks (`bench/capacity.rs`, `bench/load.rs`, `bench/service.rs`)
//! share: starting fmucal processes, connecting to a coordinator, a calibration client sending
//! a token, and uploading a model.
#![allow(dead_code)]

use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use fmucal_proto::auth::AttachToken;
use fmucal_proto::v1 as pb;
use fmucal_proto::v1::calibration_client::CalibrationClient;
use tonic::service::interceptor::InterceptedService;
use tonic::transport::Channel;

/// Starts `fmucal ARGS` with the client token `token` (and no worker token from the
/// environment), its stderr written to `log`, its stdin and stdout closed.
pub fn spawn_fmucal(args: &[&str], token: &str, log: std::fs::File) -> std::io::Result<Child> {
    Command::new(env!("CARGO_BIN_EXE_fmucal"))
        .args(args)
        .env("FMUCAL_TOKEN", token)
        .env_remove("FMUCAL_WORKER_TOKEN")
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(log)
        .spawn()
}

pub type Client = CalibrationClient<InterceptedService<Channel, AttachToken>>;

/// A channel to the coordinator at `url` (TCP_NODELAY, as tonic sets by default), tried again
/// every 50 ms until it answers; panics if it has not after `patience`.
pub async fn channel(url: &str, patience: Duration) -> Channel {
    let deadline = Instant::now() + patience;
    loop {
        match tonic::transport::Endpoint::from_shared(url.to_owned()).unwrap().tcp_nodelay(true).connect().await {
            Ok(ch) => return ch,
            Err(e) if Instant::now() > deadline => panic!("the coordinator at {url} does not answer: {e}"),
            Err(_) => tokio::time::sleep(Duration::from_millis(50)).await,
        }
    }
}

/// A calibration client on `channel` that sends `token`.
pub fn client(channel: Channel, token: &str) -> Client {
    CalibrationClient::with_interceptor(channel, AttachToken::new(Some(token)).unwrap())
}

/// Uploads the FMU `bytes` in one chunk; returns its model id.
pub async fn upload_model(c: &mut Client, bytes: Vec<u8>) -> String {
    c.upload_model(tokio_stream::iter(vec![pb::UploadModelRequest { chunk: bytes }]))
        .await
        .unwrap()
        .into_inner()
        .model_id
}
