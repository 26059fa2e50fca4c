#!/usr/bin/env python3
"""Checks the Kubernetes manifests in deploy/k8s offline (no cluster, no network).

1. Schemas: every document of every deploy/k8s/*.yaml validates, in strict mode (a field the
   schema does not know is an error), against the Kubernetes OpenAPI schemas that
   kubernetes-validate bundles, for each version in KUBERNETES_VERSIONS. A kind without a
   bundled schema is an error too (kubernetes-validate's command line only warns).
2. Agreement with deploy/compose.yaml: the coordinator and worker containers (recognised by
   their subcommand) use compose's image; their arguments are compose's command flag for flag,
   but for the worker's coordinator address (which must name the coordinator's Service and
   port); their environment has compose's variables, from secrets; their startup, readiness and
   liveness probes run compose's healthcheck command (readiness at compose's interval, timeout
   and retries); their resource requests are compose's reservations; each container mounts
   exactly the certificate files its flags name (the worker: the CA only, never a key), taken
   from the secrets the header's `kubectl create secret` commands make.
3. Among the manifests and with the adapter rules: Services select pods and ports that exist,
   the coordinator's certificate (`fmucal certs --host` in the header) is valid for the name
   workers dial, metrics ports carry Prometheus scrape annotations, the autoscaler targets the
   worker Deployment (which leaves `replicas` to it) on External metrics that
   prometheus-adapter/values.yaml serves from gauges the coordinator exports.

Usage: check.py [--k8s-dir DIR] [--compose FILE] [--adapter-values FILE] [--metrics-source FILE]
Prints one line per error ("ERROR ...") and exits 1 if there is any, else prints what it checked
and exits 0. tests/deploy_manifests.rs runs it, also on broken copies that must fail.
"""

import argparse
import glob
import os
import re
import shlex
import sys

import yaml

import kubernetes_validate
from kubernetes_validate import utils as kv_utils

# Pinned: the schemas kubernetes-validate==1.37.0 (tests/fmpy/requirements.txt) bundles, every
# minor version from 1.25 to 1.37.
KUBERNETES_VERSIONS = tuple(f"1.{minor}.0" for minor in range(25, 38))

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))

errors = []


def error(where, message):
    errors.append(f"ERROR {where}: {message}")


def name_of(doc):
    meta = doc.get("metadata") or {}
    return f"{doc.get('kind')}/{meta.get('name')}"


# ---------------------------------------------------------------------------------------------
# Loading


def load_manifests(k8s_dir):
    """[(file, doc)] for every document of every *.yaml/*.yml directly in k8s_dir."""
    files = sorted(glob.glob(os.path.join(k8s_dir, "*.yaml")) + glob.glob(os.path.join(k8s_dir, "*.yml")))
    if not files:
        error(k8s_dir, "no *.yaml files")
    docs = []
    for path in files:
        rel = os.path.basename(path)
        try:
            with open(path, encoding="utf-8") as f:
                loaded = list(yaml.safe_load_all(f))
        except yaml.YAMLError as e:
            error(rel, f"not YAML: {e}")
            continue
        for doc in loaded:
            if doc is None:
                continue
            if not isinstance(doc, dict) or not doc.get("apiVersion") or not doc.get("kind"):
                error(rel, "a document that is not a Kubernetes object (no apiVersion and kind)")
                continue
            docs.append((rel, doc))
    return docs


def header_commands(k8s_dir):
    """Shell commands in the leading comments of the manifests (backslash continuations joined)."""
    commands = []
    for path in sorted(glob.glob(os.path.join(k8s_dir, "*.yaml"))):
        with open(path, encoding="utf-8") as f:
            lines = []
            for line in f:
                if not line.startswith("#"):
                    break
                lines.append(line[1:].strip())
        joined = "\n".join(lines).replace("\\\n", " ")
        for line in joined.split("\n"):
            line = re.sub(r"^\d+\.\s+", "", line)
            try:
                commands.append(shlex.split(line))
            except ValueError:
                pass
    return commands


def secrets_from_headers(commands):
    """{secret name: set of keys} made by `kubectl create secret generic NAME --from-...`."""
    secrets = {}
    for words in commands:
        if words[:4] != ["kubectl", "create", "secret", "generic"] or len(words) < 5:
            continue
        keys = secrets.setdefault(words[4], set())
        for w in words[5:]:
            if w.startswith("--from-literal="):
                keys.add(w.split("=", 2)[1])
            elif w.startswith("--from-file="):
                value = w.split("=", 1)[1]
                # --from-file=KEY=PATH or --from-file=PATH (key: the file's name).
                keys.add(value.split("=", 1)[0] if "=" in value else os.path.basename(value))
    return secrets


def cert_hosts_from_headers(commands):
    hosts = set()
    for words in commands:
        if words[:2] == ["fmucal", "certs"]:
            hosts |= {words[i + 1] for i, w in enumerate(words[:-1]) if w == "--host"}
    return hosts


# ---------------------------------------------------------------------------------------------
# 1. Schemas


def check_schemas(docs):
    bundled = set(kv_utils.all_versions())
    missing = [v for v in KUBERNETES_VERSIONS if v not in bundled]
    if missing:
        error("kubernetes-validate", f"version {kubernetes_validate.__version__} bundles no schemas for "
              f"Kubernetes {', '.join(missing)} (it has {', '.join(sorted(bundled))})")
        return
    seen = {}
    for rel, doc in docs:
        key = (doc.get("kind"), (doc.get("metadata") or {}).get("name"), (doc.get("metadata") or {}).get("namespace"))
        if key in seen:
            error(rel, f"{name_of(doc)} is also defined in {seen[key]}")
        seen[key] = rel
        # One line per distinct problem, naming the versions it occurs in.
        problems = {}
        for version in KUBERNETES_VERSIONS:
            try:
                kubernetes_validate.validate(doc, version, strict=True)
            except kubernetes_validate.ValidationError as e:
                path = ".".join(str(p) for p in e.path) or "(top)"
                problems.setdefault(f"{path}: {e.message}", []).append(version)
            except kubernetes_validate.SchemaNotFoundError:
                problems.setdefault(f"no schema for kind {doc.get('kind')} in API version "
                                    f"{doc.get('apiVersion')}", []).append(version)
            except Exception as e:  # noqa: BLE001 - an unreadable schema or document is an error too
                problems.setdefault(f"cannot validate: {e}", []).append(version)
        for problem, versions in problems.items():
            span = versions[0] if len(versions) == 1 else f"{versions[0]} to {versions[-1]} ({len(versions)} versions)"
            error(rel, f"{name_of(doc)}: {problem} [Kubernetes {span}]")


# ---------------------------------------------------------------------------------------------
# Units


def duration_seconds(text):
    """Compose durations: 1m30s, 5s, 500ms."""
    total, rest = 0.0, str(text)
    for number, unit in re.findall(r"(\d+(?:\.\d+)?)(us|ms|s|m|h)", rest):
        total += float(number) * {"us": 1e-6, "ms": 1e-3, "s": 1, "m": 60, "h": 3600}[unit]
    if not re.fullmatch(r"(\d+(?:\.\d+)?(us|ms|s|m|h))+", rest):
        raise ValueError(f"not a compose duration: {text!r}")
    return total


def compose_bytes(text):
    """Docker's byte values (go-units RAMInBytes): b, k, m, g, t, p with an optional b; binary."""
    m = re.fullmatch(r"(\d+(?:\.\d+)?)\s*([kmgtp]?)b?", str(text).strip().lower())
    if not m:
        raise ValueError(f"not a compose byte value: {text!r}")
    return int(float(m.group(1)) * 1024 ** " kmgtp".index(m.group(2) or " "))


def k8s_bytes(text):
    """Kubernetes quantities: Ki Mi Gi Ti Pi (binary), k M G T P (decimal), or plain."""
    m = re.fullmatch(r"(\d+(?:\.\d+)?)(Ki|Mi|Gi|Ti|Pi|k|M|G|T|P)?", str(text).strip())
    if not m:
        raise ValueError(f"not a Kubernetes memory quantity: {text!r}")
    unit = m.group(2) or ""
    factor = 1024 ** ("KMGTP".index(unit[0]) + 1) if unit.endswith("i") else 1000 ** (" kMGTP".index(unit or " "))
    return int(float(m.group(1)) * factor)


def compose_millicpu(text):
    return round(float(text) * 1000)


def k8s_millicpu(text):
    text = str(text).strip()
    return int(text[:-1]) if text.endswith("m") else round(float(text) * 1000)


# ---------------------------------------------------------------------------------------------
# Commands


def parse_flags(words):
    """(subcommand, {flag: value}) for `SUB --flag value --flag=value --switch`."""
    if not words:
        return None, {}
    flags, i = {}, 1
    while i < len(words):
        w = str(words[i])
        if w.startswith("--") and "=" in w:
            flag, value = w.split("=", 1)
            i += 1
        elif w.startswith("--"):
            flag = w
            if i + 1 < len(words) and not str(words[i + 1]).startswith("--"):
                value, i = str(words[i + 1]), i + 2
            else:
                value, i = True, i + 1
        else:
            flag, value, i = f"(argument {i})", w, i + 1
        flags[flag] = value
    return str(words[0]), flags


def port_of(address):
    m = re.search(r":(\d+)$", str(address))
    return int(m.group(1)) if m else None


# ---------------------------------------------------------------------------------------------
# 2. and 3. Consistency


def containers(docs):
    """[(file, doc, pod spec, container)] of every Deployment's pod template."""
    found = []
    for rel, doc in docs:
        if doc.get("kind") in ("Deployment", "StatefulSet", "DaemonSet", "Job"):
            template = ((doc.get("spec") or {}).get("template") or {})
            pod = template.get("spec") or {}
            for c in pod.get("containers") or []:
                found.append((rel, doc, template, c))
    return found


def compose_service(compose, role):
    for name, svc in (compose.get("services") or {}).items():
        command = svc.get("command")
        if isinstance(command, str):
            command = shlex.split(command)
        if command and command[0] == role:
            return name, svc, command
    return None, None, None


def compose_env_names(svc):
    env = svc.get("environment") or []
    if isinstance(env, dict):
        return set(env)
    return {str(e).split("=", 1)[0] for e in env}


def secret_files(pod, container, secrets):
    """{path in the container: (secret, key)} of the files mounted from secrets."""
    volumes = {v.get("name"): v for v in pod.get("volumes") or []}
    files = {}
    for mount in container.get("volumeMounts") or []:
        secret = (volumes.get(mount.get("name")) or {}).get("secret")
        if not secret:
            continue
        name = secret.get("secretName")
        items = secret.get("items")
        pairs = [(i.get("key"), i.get("path")) for i in items] if items else [(k, k) for k in sorted(secrets.get(name, ()))]
        base = mount.get("mountPath", "").rstrip("/")
        sub = mount.get("subPath")
        for key, path in pairs:
            if sub:
                if sub == path:
                    files[base] = (name, key)
            else:
                files[f"{base}/{path}"] = (name, key)
    return files


def check_container(rel, doc, template, c, role, compose_svc, compose_cmd, services, secrets, hosts):
    where = f"{rel}: {name_of(doc)} container {c.get('name')}"
    pod = template.get("spec") or {}
    # Image.
    if c.get("image") != compose_svc.get("image"):
        error(where, f"image {c.get('image')!r} is not deploy/compose.yaml's {compose_svc.get('image')!r}")
    # Command: the image's entrypoint is fmucal, so Kubernetes `args` play compose's `command`.
    if c.get("command"):
        error(where, "sets `command` (the image's entrypoint): put fmucal's arguments in `args`")
    sub, flags = parse_flags(c.get("args") or [])
    csub, cflags = parse_flags(compose_cmd)
    if sub != csub:
        error(where, f"runs `fmucal {sub}`, compose runs `fmucal {csub}`")
    for flag in sorted(set(flags) | set(cflags)):
        if flag not in flags:
            error(where, f"lacks compose's {flag} {cflags[flag]}")
        elif flag not in cflags:
            error(where, f"has {flag} {flags[flag]}, which compose's {role} command has not")
        elif role == "worker" and flag == "--coordinator":
            mine, theirs = str(flags[flag]), str(cflags[flag])
            if mine.split("://")[0] != theirs.split("://")[0]:
                error(where, f"reaches the coordinator at {mine}, not over {theirs.split('://')[0]} as compose does")
            m = re.fullmatch(r"\w+://([^:/]+):(\d+)", mine)
            if not m or (m.group(1), int(m.group(2))) not in services:
                error(where, f"--coordinator {mine} is not a Service port of the coordinator "
                      f"(those are {sorted(f'{h}:{p}' for h, p in services) or 'none'})")
            elif m.group(1) not in hosts:
                error(where, f"--coordinator {mine}: the header's `fmucal certs` makes no certificate "
                      f"for {m.group(1)} (--host {' '.join(sorted(hosts)) or 'none'})")
        elif flags[flag] != cflags[flag]:
            error(where, f"{flag} {flags[flag]}, compose has {cflags[flag]}")
    # Environment: compose's variables, each from a secret the header makes.
    env = {e.get("name"): e for e in c.get("env") or []}
    wanted = compose_env_names(compose_svc)
    for name in sorted(set(env) | wanted):
        if name not in env:
            error(where, f"lacks compose's environment variable {name}")
        elif name not in wanted:
            error(where, f"has environment variable {name}, which compose's {role} has not")
        else:
            ref = ((env[name].get("valueFrom") or {}).get("secretKeyRef") or {})
            if not ref:
                error(where, f"{name} is not taken from a secret")
            elif ref.get("key") not in secrets.get(ref.get("name"), ()):
                error(where, f"{name} comes from secret {ref.get('name')} key {ref.get('key')}, which the "
                      "header's `kubectl create secret` commands do not make")
    # Probes: compose's healthcheck command.
    test = (compose_svc.get("healthcheck") or {}).get("test")
    if not (isinstance(test, list) and test and test[0] == "CMD"):
        error(f"compose.yaml: {role}", f"healthcheck test {test!r} is not [\"CMD\", ...]")
        test = ["CMD"]
    for kind in ("startupProbe", "readinessProbe", "livenessProbe"):
        probe = c.get(kind)
        if not probe:
            error(where, f"has no {kind}")
            continue
        command = (probe.get("exec") or {}).get("command")
        if command != test[1:]:
            error(where, f"{kind} runs {command!r}, compose's healthcheck runs {test[1:]!r}")
    hc, ready = compose_svc.get("healthcheck") or {}, c.get("readinessProbe") or {}
    for compose_key, probe_key, default in (("interval", "periodSeconds", 10), ("timeout", "timeoutSeconds", 1),
                                            ("retries", "failureThreshold", 3)):
        if compose_key in hc:
            want = hc[compose_key] if compose_key == "retries" else duration_seconds(hc[compose_key])
            if ready.get(probe_key, default) != want:
                error(where, f"readinessProbe {probe_key} {ready.get(probe_key, default)}, compose's healthcheck "
                      f"{compose_key} is {hc[compose_key]}")
    # Resources: compose's reservations are the requests (and limits the limits).
    resources = (compose_svc.get("deploy") or {}).get("resources") or {}
    for compose_key, k8s_key in (("reservations", "requests"), ("limits", "limits")):
        theirs = resources.get(compose_key) or {}
        mine = (c.get("resources") or {}).get(k8s_key) or {}
        for ck, kk, cparse, kparse in (("cpus", "cpu", compose_millicpu, k8s_millicpu),
                                       ("memory", "memory", compose_bytes, k8s_bytes)):
            if ck not in theirs and kk not in mine:
                continue
            if ck not in theirs or kk not in mine:
                error(where, f"resources.{k8s_key}.{kk} {mine.get(kk)!r}, compose's {compose_key}.{ck} "
                      f"{theirs.get(ck)!r}")
                continue
            try:
                same = cparse(theirs[ck]) == kparse(mine[kk])
            except ValueError as e:
                error(where, str(e))
                continue
            if not same:
                amounts = (f"{kparse(mine[kk])} bytes, compose {cparse(theirs[ck])} (compose's units are binary)"
                           if kk == "memory" else f"{kparse(mine[kk])}m CPU, compose {cparse(theirs[ck])}m")
                error(where, f"resources.{k8s_key}.{kk} {mine[kk]} is not compose's {compose_key}.{ck} "
                      f"{theirs[ck]} ({amounts})")
        for kk in sorted(set(mine) - {"cpu", "memory"}):
            error(where, f"resources.{k8s_key}.{kk}, which compose does not reserve")
    # Certificates: the container sees exactly the secret files its flags name; a worker no key.
    files = secret_files(pod, c, secrets)
    for path, (secret, key) in sorted(files.items()):
        if key not in secrets.get(secret, ()):
            error(where, f"mounts key {key} of secret {secret}, which the header's `kubectl create secret` "
                  "commands do not make")
    named = {str(v) for f, v in flags.items() if f.startswith("--tls")}
    under_mounts = {v for v in named if v.startswith("/")}
    for path in sorted(under_mounts - set(files)):
        error(where, f"names {path}, which no secret volume provides")
    for path in sorted(set(files) - under_mounts):
        error(where, f"can read {path} (secret {files[path][0]}, key {files[path][1]}), which its flags do not "
              "name: mount only the files it needs")
    if role == "worker":
        for path, (secret, key) in sorted(files.items()):
            if "key" in key:
                error(where, f"a worker runs FMU code and must not read {key} (secret {secret}); the CA only")
    # Metrics: a port and scrape annotations for --metrics-listen.
    annotations = (template.get("metadata") or {}).get("annotations") or {}
    metrics_port = port_of(flags.get("--metrics-listen", ""))
    if metrics_port:
        if metrics_port not in {p.get("containerPort") for p in c.get("ports") or []}:
            error(where, f"serves metrics on {metrics_port} but declares no such containerPort")
        want = {"prometheus.io/scrape": "true", "prometheus.io/port": str(metrics_port)}
        for k, v in want.items():
            if annotations.get(k) != v:
                error(where, f"pod annotation {k} is {annotations.get(k)!r}, not {v!r}")
    # A worker stopping finishes or hands back its points within --stop-grace (default 20 s).
    if role == "worker":
        grace = float(flags.get("--stop-grace", 20))
        if pod.get("terminationGracePeriodSeconds", 30) <= grace:
            error(where, f"terminationGracePeriodSeconds {pod.get('terminationGracePeriodSeconds', 30)} does not "
                  f"exceed the worker's --stop-grace {grace:g} s")
    return flags


def selects(selector, labels):
    return bool(selector) and all(labels.get(k) == v for k, v in selector.items())


def check_consistency(docs, compose, k8s_dir, adapter, metrics_source):
    commands = header_commands(k8s_dir)
    secrets = secrets_from_headers(commands)
    hosts = cert_hosts_from_headers(commands)
    found = containers(docs)
    # Deployments' selectors match their pods.
    for rel, doc in docs:
        if doc.get("kind") == "Deployment":
            spec = doc.get("spec") or {}
            labels = ((spec.get("template") or {}).get("metadata") or {}).get("labels") or {}
            if not selects((spec.get("selector") or {}).get("matchLabels"), labels):
                error(rel, f"{name_of(doc)}: selector does not match its pod labels")
    by_role = {}
    for rel, doc, template, c in found:
        role = str((c.get("args") or [None])[0])
        by_role.setdefault(role, []).append((rel, doc, template, c))
    # The coordinator's Service ports, as (host, port).
    services = set()
    for role in ("coordinator", "worker"):
        if role not in by_role:
            error(k8s_dir, f"no container runs `fmucal {role}`")
    for rel, doc in docs:
        if doc.get("kind") != "Service":
            continue
        selector = (doc.get("spec") or {}).get("selector") or {}
        pods = [(d, t, c) for r, d, t, c in found if selects(selector, (t.get("metadata") or {}).get("labels") or {})]
        if not pods:
            error(rel, f"{name_of(doc)} selects no pod")
        for port in (doc.get("spec") or {}).get("ports") or []:
            target = port.get("targetPort", port.get("port"))
            ok = any(p.get("name") == target or p.get("containerPort") == target
                     for _, _, c in pods for p in c.get("ports") or [])
            if not ok:
                error(rel, f"{name_of(doc)} port {port.get('port')}: no selected container has port {target}")
            elif any((c.get("args") or [None])[0] == "coordinator" for _, _, c in pods):
                services.add((doc["metadata"]["name"], port.get("port")))
    flags_of = {}
    for role in ("coordinator", "worker"):
        name, svc, command = compose_service(compose, role)
        if not svc:
            error("compose.yaml", f"no service runs `fmucal {role}`")
            continue
        for rel, doc, template, c in by_role.get(role, []):
            flags_of[role] = check_container(rel, doc, template, c, role, svc, command, services, secrets, hosts)
    # The coordinator's gRPC port is the one its Service exposes.
    listen = port_of((flags_of.get("coordinator") or {}).get("--listen", ""))
    for rel, doc, template, c in by_role.get("coordinator", []):
        if listen not in {p.get("containerPort") for p in c.get("ports") or []}:
            error(rel, f"{name_of(doc)}: the coordinator listens on {listen} but declares no such containerPort")
    check_autoscaler(docs, by_role, flags_of.get("worker") or {}, adapter, metrics_source)


def check_autoscaler(docs, by_role, worker_flags, adapter, metrics_source):
    hpas = [(rel, doc) for rel, doc in docs if doc.get("kind") == "HorizontalPodAutoscaler"]
    if not hpas:
        error("deploy/k8s", "no HorizontalPodAutoscaler for the workers")
    workers = {(d.get("kind"), d["metadata"]["name"]) for _, d, _, _ in by_role.get("worker", [])}
    try:
        with open(metrics_source, encoding="utf-8") as f:
            # A name the coordinator registers: the first argument of `register(` or the first
            # element of a (name, help, metric) row of a table it registers from.
            exported = set(re.findall(r'(?:register\(|\()\s*"(fmucal_\w+)"\s*,', f.read()))
    except OSError as e:
        error(metrics_source, f"cannot read: {e}")
        exported = set()
    rules = {}
    for rule in ((adapter or {}).get("rules") or {}).get("external") or []:
        rules[((rule.get("name") or {}).get("as"))] = rule
    slots = float(worker_flags.get("--slots", 1))
    for rel, doc in hpas:
        where = f"{rel}: {name_of(doc)}"
        spec = doc.get("spec") or {}
        ref = spec.get("scaleTargetRef") or {}
        if (ref.get("kind"), ref.get("name")) not in workers or ref.get("apiVersion") != "apps/v1":
            error(where, f"scales {ref.get('apiVersion')} {ref.get('kind')}/{ref.get('name')}, not the worker Deployment")
        for _, d, _, _ in by_role.get("worker", []):
            if (d.get("kind"), d["metadata"]["name"]) == (ref.get("kind"), ref.get("name")) and "replicas" in d.get("spec", {}):
                error(where, f"{name_of(d)} sets replicas: applying it again would undo the autoscaler")
        if not 1 <= spec.get("minReplicas", 1) <= spec.get("maxReplicas", 0):
            error(where, f"minReplicas {spec.get('minReplicas', 1)}, maxReplicas {spec.get('maxReplicas')}")
        names = []
        for metric in spec.get("metrics") or []:
            if metric.get("type") != "External":
                continue
            ext = metric.get("external") or {}
            name = (ext.get("metric") or {}).get("name")
            names.append(name)
            target = ext.get("target") or {}
            if target.get("type") != "AverageValue" or float(target.get("averageValue", 0)) != slots:
                error(where, f"{name}: target {target}, not AverageValue {slots:g} (points a worker with --slots "
                      f"{slots:g} takes)")
            rule = rules.get(name)
            if rule is None:
                error(where, f"External metric {name}: prometheus-adapter/values.yaml has no rules.external entry "
                      f"named {name}")
                continue
            series = re.match(r"\s*(\w+)", rule.get("seriesQuery", ""))
            series = series.group(1) if series else None
            if series not in exported:
                error(where, f"External metric {name}: the adapter reads {series}, which the coordinator does not "
                      f"export ({os.path.relpath(metrics_source, REPO)} registers {', '.join(sorted(exported))})")
            overrides = ((rule.get("resources") or {}).get("overrides") or {})
            if (overrides.get("namespace") or {}).get("resource") != "namespace":
                error(where, f"External metric {name}: the adapter rule maps no `namespace` label to the namespace")
            if "<<.LabelMatchers>>" not in rule.get("metricsQuery", ""):
                error(where, f"External metric {name}: the adapter rule's metricsQuery ignores <<.LabelMatchers>> "
                      "(the namespace)")
        if "fmucal_points_queued" not in names:
            error(where, "does not scale on the External metric fmucal_points_queued (the coordinator's queue)")


# ---------------------------------------------------------------------------------------------


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--k8s-dir", default=HERE)
    parser.add_argument("--compose", default=os.path.join(REPO, "deploy", "compose.yaml"))
    parser.add_argument("--adapter-values", default=None,
                        help="default: K8S_DIR/prometheus-adapter/values.yaml")
    parser.add_argument("--metrics-source", default=os.path.join(REPO, "coordinator", "src", "metrics.rs"))
    args = parser.parse_args()
    adapter_path = args.adapter_values or os.path.join(args.k8s_dir, "prometheus-adapter", "values.yaml")

    docs = load_manifests(args.k8s_dir)
    check_schemas(docs)
    try:
        with open(args.compose, encoding="utf-8") as f:
            compose = yaml.safe_load(f) or {}
        with open(adapter_path, encoding="utf-8") as f:
            adapter = yaml.safe_load(f) or {}
    except (OSError, yaml.YAMLError) as e:
        error("input", str(e))
    else:
        try:
            check_consistency(docs, compose, args.k8s_dir, adapter, args.metrics_source)
        except Exception as e:  # noqa: BLE001 - a document of the wrong shape, already reported above
            if not errors:
                raise
            error("consistency", f"not checked to the end ({type(e).__name__}: {e}); fix the errors above first")

    for line in errors:
        print(line)
    if errors:
        print(f"{len(errors)} error(s) in {args.k8s_dir}", file=sys.stderr)
        return 1
    files = sorted({rel for rel, _ in docs})
    print(f"OK: {len(docs)} documents in {', '.join(files)} are valid (strict) against the schemas of Kubernetes "
          f"{KUBERNETES_VERSIONS[0]} to {KUBERNETES_VERSIONS[-1]} (kubernetes-validate "
          f"{kubernetes_validate.__version__}), and agree with {os.path.relpath(args.compose, REPO)} and "
          f"{os.path.relpath(adapter_path, REPO)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
