//! A local `fmucal calibrate` uses the model the CLI has unpacked into the user's FMU cache: no
//! copy of the archive lands in the in-process coordinator's store and no worker unpacks it
//! again (checked on disk while the run goes on); a gRPC client cannot make the coordinator
//! read a path it names, nor a model unpacked on its machine that it was not given; the
//! worker's flag that names an unpacked model refuses bad values in one line.

mod common;

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use fmucal_proto::auth::AttachToken;
use fmucal_proto::convert::job_to_proto;
use fmucal_proto::v1 as pb;
use fmucal_proto::v1::calibration_client::CalibrationClient;
use fmucal_shared::job::{JobSpec, MeasurementTable};

const TOKEN: &str = "local-model-test-token";

/// Data of `x` from Decay at k = 1.7 (every 0.04 s of its 1 s default experiment) in
/// `dir/data.csv`, and a job fitting k in `dir/job.toml` with `extra` TOML appended.
fn write_job(dir: &Path, extra: &str) -> PathBuf {
    common::write_decay_csv(dir, common::decay_samples(&dir.join("reference-cache"), Some(1e-10), 4));
    let text = common::job_toml(
        &common::example("decay"),
        Some(Path::new("data.csv")),
        &[("x", "x")],
        &[],
        &[("k", 1.0, 0.1, 5.0)],
        &format!("[simulation]\ntolerance = 1e-10\n{extra}[optimizer]\nx_tol = 1e-8\nf_tol = 1e-14\nmax_iters = 4\n"),
    );
    common::write_file(dir, "job.toml", text)
}

/// Every file under `dir` (recursively), as paths.
fn files_under(dir: &Path) -> Vec<PathBuf> {
    let mut out = vec![];
    let Ok(entries) = std::fs::read_dir(dir) else { return out };
    for e in entries.flatten() {
        let p = e.path();
        if p.is_dir() {
            out.extend(files_under(&p));
        } else {
            out.push(p);
        }
    }
    out
}

#[test]
fn a_local_run_neither_uploads_nor_unpacks_the_model_again() {
    let dir = tempfile::tempdir().unwrap();
    // Each simulation sleeps 0.05 s, so the run lasts long enough to look at its folder.
    let job = write_job(dir.path(), "set = { delay = 0.05 }\n");
    let (tmp, cache) = (dir.path().join("tmp"), dir.path().join("cache"));
    std::fs::create_dir_all(&tmp).unwrap();
    let mut child = common::KillOnDrop(
        common::fmucal_in(dir.path())
            .args(["calibrate", job.to_str().unwrap(), "--workers", "2", "--out", "out"])
            .env("TMPDIR", &tmp)
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap(),
    );
    // While it runs: the run's folder (seen by its owner file) holds neither a job store (the
    // run's jobs stay in memory) nor an archive or an unpacked model.
    let (mut saw_run, mut saw_store, mut models_seen) = (false, false, vec![]);
    while child.0.try_wait().unwrap().is_none() {
        for f in files_under(&tmp) {
            let name = f.file_name().unwrap().to_string_lossy().into_owned();
            saw_run |= name == "owner";
            saw_store |= name == "jobs.redb";
            if name.ends_with(".fmu") || name == "modelDescription.xml" || name.starts_with(".upload-") {
                models_seen.push(f);
            }
        }
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
    let mut stderr = String::new();
    std::io::Read::read_to_string(child.0.stderr.as_mut().unwrap(), &mut stderr).unwrap();
    assert!(child.0.wait().unwrap().success(), "{stderr}");
    let result: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("out/result.json")).unwrap()).unwrap();
    assert!(result["evaluations"].as_u64().unwrap() >= 4, "{result}");
    assert!(saw_run, "never saw the run's folder under {}", tmp.display());
    assert!(!saw_store, "the local run wrote a job store under {}", tmp.display());
    assert!(models_seen.is_empty(), "the run copied or unpacked the model: {models_seen:?}");
    // The one unpacked copy is the CLI's, in the user's cache (beside the CLI's record of the
    // archive's SHA-256, a dot folder).
    let unpacked: Vec<_> = std::fs::read_dir(&cache)
        .unwrap()
        .flatten()
        .map(|e| e.file_name())
        .filter(|n| !n.to_string_lossy().starts_with('.'))
        .collect();
    assert_eq!(unpacked.len(), 1, "{unpacked:?}");
    let sha = unpacked[0].to_string_lossy().into_owned();
    let archive = std::fs::read(common::example("decay")).unwrap();
    assert_eq!(sha, fmucal_shared::fmu::archive::sha256_hex(&archive));
    assert!(files_under(&tmp).is_empty(), "left in the temporary folder: {:?}", files_under(&tmp));
}

type Client =
    CalibrationClient<tonic::service::interceptor::InterceptedService<tonic::transport::Channel, AttachToken>>;

/// Submits `spec` naming the model `model_id`; the status of a refusal.
async fn submit(c: &mut Client, spec: &JobSpec, data: &MeasurementTable, model_id: &str) -> Result<(), tonic::Status> {
    let req = pb::SubmitJobRequest { spec: Some(job_to_proto(spec, std::slice::from_ref(data), model_id)) };
    c.submit_job(req).await.map(|_| ())
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_client_cannot_make_the_coordinator_read_a_path_or_a_model_it_was_not_given() {
    let dir = tempfile::tempdir().unwrap();
    let cache = dir.path().join("cache");
    // Two models unpacked on the coordinator's machine: Decay, registered as a local run's
    // model, and Furuta, only unpacked.
    let decay = common::load_example("decay", &cache);
    let furuta = common::load_example("furuta", &cache);
    let local = fmucal_coordinator::models::LocalModel {
        archive: common::example("decay"),
        dir: decay.dir.clone(),
        sha256: decay.sha256.clone(),
    };
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
    let url = format!("http://{}", listener.local_addr().unwrap());
    let data_dir = dir.path().join("coordinator");
    let config =
        fmucal_coordinator::Config { token: Some(TOKEN.into()), ..fmucal_coordinator::Config::new(data_dir.clone()) };
    let (stop, stopped) = tokio::sync::oneshot::channel::<()>();
    let server = tokio::spawn(async move {
        fmucal_coordinator::run_with_local_models(config, &[local], listener, async {
            let _ = stopped.await;
        })
        .await
    });
    let channel = loop {
        match tonic::transport::Endpoint::from_shared(url.clone()).unwrap().connect().await {
            Ok(ch) => break ch,
            Err(_) => tokio::time::sleep(std::time::Duration::from_millis(50)).await,
        }
    };
    let mut c = CalibrationClient::with_interceptor(channel.clone(), AttachToken::new(Some(TOKEN)).unwrap());
    let job = write_job(dir.path(), "");
    let spec = JobSpec::from_toml_file(&job).unwrap();
    let data = fmucal_shared::job::data::read_all(&spec).unwrap().pop().unwrap();

    // The registered model is named by its SHA-256, with no upload.
    submit(&mut c, &spec, &data, &decay.sha256).await.unwrap();
    // Paths, absolute or relative, and a model unpacked on this machine but never given.
    let dir_text = decay.dir.to_string_lossy().into_owned();
    let relative = format!("../cache/{}", decay.sha256);
    for id in [dir_text.as_str(), relative.as_str(), furuta.sha256.as_str(), "/etc/passwd"] {
        let e = submit(&mut c, &spec, &data, id).await.unwrap_err();
        assert_eq!(e.code(), tonic::Code::InvalidArgument, "{id}: {e:?}");
        assert!(e.message().contains("model_id"), "{id}: {}", e.message());
    }
    // A worker cannot fetch them either (one token for both services here).
    let mut w =
        pb::worker_pool_client::WorkerPoolClient::with_interceptor(channel, AttachToken::new(Some(TOKEN)).unwrap());
    for id in [dir_text.as_str(), furuta.sha256.as_str()] {
        let fetched = match w.fetch_model(pb::FetchModelRequest { model_id: id.to_owned() }).await {
            Ok(stream) => {
                let mut stream = stream.into_inner();
                stream.message().await.map(|m| m.is_some())
            }
            Err(e) => Err(e),
        };
        assert!(fetched.is_err(), "{id}: the coordinator sent bytes");
    }
    // Nothing of either model was copied into the store.
    let stored: Vec<_> =
        files_under(&data_dir.join("models")).into_iter().chain(files_under(&data_dir.join("unpacked"))).collect();
    assert!(stored.is_empty(), "{stored:?}");
    let _ = stop.send(());
    let _ = server.await;
}

#[test]
fn the_workers_unpacked_model_flag_refuses_bad_values_in_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let sha = "a".repeat(64);
    let cases = [
        ("no-equals-sign".to_owned(), "is not SHA256=DIR"),
        ("/etc=/tmp".to_owned(), "does not start with 64 hex digits"),
        (format!("{sha}={}", dir.path().display()), "holds no modelDescription.xml"),
    ];
    for (value, why) in cases {
        let out = Command::new(env!("CARGO_BIN_EXE_fmucal"))
            .args(["worker", "--coordinator", "http://127.0.0.1:9", "--unpacked-model", &value])
            .env("FMUCAL_TOKEN", TOKEN)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{value}");
        assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
        assert!(stderr.contains("--unpacked-model") && stderr.contains(why), "{value}: {stderr}");
    }
}
