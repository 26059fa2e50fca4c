//! Per-job context fetched once: the spec and data (`FetchJob`), the model bytes
//! (`FetchModel`, stored by hash) unless the worker was given the model unpacked, the loaded
//! FMU and the prepared objective.

use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::Arc;

use fmucal_proto::convert::SubmittedJob;
use fmucal_proto::v1 as pb;
use fmucal_shared::fmu::{Fmu, LoadOptions};
use fmucal_shared::job::PreparedJob;
use tokio::sync::Mutex;

use crate::Client;

/// What a slot needs to evaluate a job's points.
pub struct JobContext {
    pub fmu: Arc<Fmu>,
    pub job: Arc<PreparedJob>,
    /// The FMU may be instantiated only once per process: all its points go to slot 0.
    pub exclusive: bool,
}

pub struct JobCache {
    dir: PathBuf,
    /// Folders of models given unpacked, by SHA-256 ([`crate::Config::unpacked_models`]).
    unpacked: HashMap<String, PathBuf>,
    jobs: Mutex<HashMap<String, Arc<JobContext>>>,
}

impl JobCache {
    pub fn new(dir: PathBuf, unpacked: HashMap<String, PathBuf>) -> Self {
        JobCache { dir, unpacked, jobs: Mutex::new(HashMap::new()) }
    }

    /// Whether a cached job's model may be instantiated only once per process.
    pub async fn has_exclusive(&self) -> bool {
        self.jobs.lock().await.values().any(|c| c.exclusive)
    }

    /// The job's context, fetching and loading it on first use.
    pub async fn get(&self, client: &mut Client, job_id: &str) -> Result<Arc<JobContext>, String> {
        let mut jobs = self.jobs.lock().await;
        if let Some(c) = jobs.get(job_id) {
            return Ok(c.clone());
        }
        let spec = client
            .fetch_job(pb::FetchJobRequest { job_id: job_id.to_owned() })
            .await
            .map_err(|s| format!("fetching job {job_id}: {}", s.message()))?
            .into_inner()
            .spec
            .ok_or("the coordinator sent a job without a spec")?;
        let model_id = spec.model_id.clone();
        // An id is a SHA-256, never a path: no coordinator names a file or folder here.
        if model_id.len() != 64 || !model_id.bytes().all(|b| b.is_ascii_hexdigit()) {
            return Err(format!("job {job_id}: model id {model_id:?} is not a SHA-256"));
        }
        let path = self.dir.join("models").join(format!("{model_id}.fmu"));
        let unpacked = self.unpacked.get(&model_id).cloned();
        if unpacked.is_none() && !path.is_file() {
            let mut stream = client
                .fetch_model(pb::FetchModelRequest { model_id: model_id.clone() })
                .await
                .map_err(|s| format!("fetching model {model_id}: {}", s.message()))?
                .into_inner();
            let mut bytes = vec![];
            while let Some(m) =
                stream.message().await.map_err(|s| format!("fetching model {model_id}: {}", s.message()))?
            {
                bytes.extend_from_slice(&m.chunk);
            }
            if fmucal_shared::fmu::archive::sha256_hex(&bytes) != model_id {
                return Err(format!("model {model_id}: the bytes received do not match their hash"));
            }
            std::fs::create_dir_all(path.parent().expect("has a parent")).map_err(|e| e.to_string())?;
            let tmp = path.with_extension("part");
            std::fs::write(&tmp, &bytes).map_err(|e| e.to_string())?;
            std::fs::rename(&tmp, &path).map_err(|e| e.to_string())?;
        }
        let opts = LoadOptions { cache_dir: self.dir.join("unpacked"), ..Default::default() };
        let ctx = tokio::task::spawn_blocking(move || -> Result<JobContext, String> {
            let submitted = SubmittedJob::try_from(spec).map_err(|e| e.to_string())?;
            let fmu = match unpacked {
                Some(dir) => Fmu::open_unpacked(&dir, model_id),
                None => Fmu::load_with(&path, &opts),
            }
            .map_err(|e| e.to_string())?;
            let job = PreparedJob::new(&submitted.spec, &fmu.description, &fmu.interfaces(), &submitted.data)
                .map_err(|e| e.to_string())?;
            let exclusive = fmu.once_per_process(job.interface);
            Ok(JobContext { fmu: Arc::new(fmu), job: Arc::new(job), exclusive })
        })
        .await
        .map_err(|e| e.to_string())??;
        let ctx = Arc::new(ctx);
        jobs.insert(job_id.to_owned(), ctx.clone());
        Ok(ctx)
    }
}
