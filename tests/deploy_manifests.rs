//! The Kubernetes manifests (`deploy/k8s`), checked offline by `deploy/k8s/check.py` in the
//! Python venv of `tests/fmpy/ensure_venv.sh` (kubernetes-validate, which bundles the
//! Kubernetes schemas, and PyYAML): every document validates in strict mode against the schemas
//! of Kubernetes 1.25 to 1.37, and the manifests agree with `deploy/compose.yaml` (image,
//! command flags, environment, health probes, resource requests, certificate files) and with
//! the prometheus-adapter rules the worker autoscaler needs. No cluster runs here.
//!
//! The checker is also run on broken copies, each of which it must reject with an error naming
//! what is wrong, so a checker that passes everything fails this test.

mod common;

use std::path::Path;
use std::process::{Command, Output};

fn repo() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn check(args: &[&Path]) -> Output {
    let mut cmd = Command::new(common::fmpy_python());
    cmd.arg(repo().join("deploy/k8s/check.py"));
    for pair in args.chunks(2) {
        cmd.arg(pair[0]).arg(pair[1]);
    }
    cmd.output().expect("run deploy/k8s/check.py")
}

fn text(out: &Output) -> String {
    format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr))
}

/// Replaces the one occurrence of `old` in `path` by `new`. Panics if `old` does not occur
/// exactly once, so a mutation that no longer applies fails instead of testing nothing.
fn replace_once(path: &Path, old: &str, new: &str) {
    let body = std::fs::read_to_string(path).unwrap();
    assert_eq!(body.matches(old).count(), 1, "{} should contain exactly once:\n{old}", path.display());
    std::fs::write(path, body.replacen(old, new, 1)).unwrap();
}

#[test]
fn the_manifests_validate_and_agree_with_compose() {
    let out = check(&[]);
    let said = text(&out);
    println!("{said}");
    assert!(out.status.success(), "deploy/k8s/check.py failed:\n{said}");
    assert!(said.contains("OK:") && said.contains("Kubernetes 1.25.0 to 1.37.0"), "{said}");
    for file in ["fmucal.yaml", "worker-hpa.yaml"] {
        assert!(said.contains(file), "{file} was not checked:\n{said}");
    }
}

/// (file under deploy/k8s, or "compose.yaml"; text to replace; replacement; what the error must say)
const BROKEN: &[(&str, &str, &str, &str)] = &[
    // Schema, strict: a misspelt field, and a kind Kubernetes does not have.
    (
        "fmucal.yaml",
        "terminationGracePeriodSeconds: 60",
        "terminationGracePeriodSecond: 60",
        "Deployment/fmucal-worker: spec.template.spec: Additional properties are not allowed \
         ('terminationGracePeriodSecond' was unexpected) [Kubernetes 1.25.0 to 1.37.0",
    ),
    ("fmucal.yaml", "kind: Service\n", "kind: Servce\n", "Servce/fmucal-coordinator: no schema for kind Servce"),
    // Schema: a wrong type (a count as a word).
    (
        "worker-hpa.yaml",
        "maxReplicas: 20",
        "maxReplicas: twenty",
        "spec.maxReplicas: 'twenty' is not of type 'integer'",
    ),
    // Against compose: image, flags, probes, resources, certificates, environment.
    (
        "fmucal.yaml",
        "image: fmucal:latest\n          imagePullPolicy: IfNotPresent\n          args: [\"worker\"",
        "image: fmucal:0.9\n          imagePullPolicy: IfNotPresent\n          args: [\"worker\"",
        "container worker: image 'fmucal:0.9' is not deploy/compose.yaml's 'fmucal:latest'",
    ),
    (
        "fmucal.yaml",
        "\"--tls-ca\", \"/certs/ca.pem\", \"--metrics-listen\", \"0.0.0.0:9090\"]",
        "\"--tls-ca\", \"/certs/ca.pem\"]",
        "container coordinator: lacks compose's --metrics-listen 0.0.0.0:9090",
    ),
    (
        "fmucal.yaml",
        "exec: { command: [\"fmucal\", \"health\", \"http://127.0.0.1:8081\"] }\n            periodSeconds: 10",
        "exec: { command: [\"fmucal\", \"health\", \"http://127.0.0.1:8082\"] }\n            periodSeconds: 10",
        "container worker: livenessProbe runs ['fmucal', 'health', 'http://127.0.0.1:8082'], compose's healthcheck",
    ),
    (
        "fmucal.yaml",
        "resources: { requests: { cpu: \"1\", memory: 512Mi } }",
        "resources: { requests: { cpu: \"1\", memory: 512M } }",
        "container worker: resources.requests.memory 512M is not compose's reservations.memory 512M",
    ),
    (
        "fmucal.yaml",
        "items: [{ key: ca.pem, path: ca.pem }]",
        "items: [{ key: ca.pem, path: ca.pem }, { key: coordinator-key.pem, path: coordinator-key.pem }]",
        "container worker: a worker runs FMU code and must not read coordinator-key.pem",
    ),
    (
        "fmucal.yaml",
        "          env:\n            - name: FMUCAL_WORKER_TOKEN",
        "          env:\n            - name: FMUCAL_TOKEN\n              valueFrom: { secretKeyRef: { name: fmucal-token, key: token } }\n            - name: FMUCAL_WORKER_TOKEN",
        "container worker: has environment variable FMUCAL_TOKEN, which compose's worker has not",
    ),
    // The header's commands: the certificate must be valid for the name workers dial.
    (
        "fmucal.yaml",
        "fmucal certs --out certs --host fmucal-coordinator",
        "fmucal certs --out certs --host coordinator",
        "the header's `fmucal certs` makes no certificate for fmucal-coordinator",
    ),
    // The autoscaler and its adapter rules.
    (
        "fmucal.yaml",
        "  selector: { matchLabels: { app: fmucal-worker } }",
        "  replicas: 4\n  selector: { matchLabels: { app: fmucal-worker } }",
        "Deployment/fmucal-worker sets replicas: applying it again would undo the autoscaler",
    ),
    (
        "prometheus-adapter/values.yaml",
        "seriesQuery: 'fmucal_points_queued{namespace!=\"\"}'",
        "seriesQuery: 'fmucal_queue_depth{namespace!=\"\"}'",
        "External metric fmucal_points_queued: the adapter reads fmucal_queue_depth, which the coordinator does not export",
    ),
    // A compose change the manifests have not followed.
    (
        "compose.yaml",
        "\"--health-listen\", \"0.0.0.0:8081\"",
        "\"--health-listen\", \"0.0.0.0:8081\", \"--stop-grace\", \"30\"",
        "container worker: lacks compose's --stop-grace 30",
    ),
];

#[test]
fn the_checker_rejects_broken_manifests() {
    let mut missed = Vec::new();
    for (i, (file, old, new, expected)) in BROKEN.iter().enumerate() {
        let dir = tempfile::tempdir().unwrap();
        let k8s = dir.path().join("k8s");
        common::copy_dir(&repo().join("deploy/k8s"), &k8s);
        let compose = dir.path().join("compose.yaml");
        std::fs::copy(repo().join("deploy/compose.yaml"), &compose).unwrap();
        let target = if *file == "compose.yaml" { compose.clone() } else { k8s.join(file) };
        replace_once(&target, old, new);
        let out = check(&[Path::new("--k8s-dir"), &k8s, Path::new("--compose"), &compose]);
        let said = text(&out);
        if out.status.code() != Some(1) || !said.contains(expected) {
            missed.push(format!(
                "case {i} ({file}: {old:?} -> {new:?}): exit {:?}, expected an error with {expected:?}, got:\n{said}",
                out.status.code()
            ));
        }
    }
    assert!(missed.is_empty(), "the checker accepted broken manifests:\n{}", missed.join("\n"));
}
