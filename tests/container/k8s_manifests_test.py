#!/usr/bin/env python3
"""The Kubernetes example (docker/k8s, issue 13): every manifest parses, and
the fields the README relies on hold: the PostgreSQL StatefulSet and its
Service, the queue URL in a Secret that names that Service, the worker
Deployment (image, command, queue URL from the Secret, LP_NUM_THREADS equal
to its CPU request, memory requests, the heartbeat liveness probe, the shared
frames volume, the image's unprivileged user, a grace period for one frame),
the ReadWriteMany claim, the enqueue Job, and the monitor (issue 41). Prints one line
per check."""
import glob
import os
import sys
from urllib.parse import urlparse

import yaml

root = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "docker", "k8s")
failed = 0


def check(what, condition):
    global failed
    print(("ok   " if condition else "FAIL ") + what)
    failed += 0 if condition else 1


docs = []
for path in sorted(glob.glob(os.path.join(root, "*.yaml"))):
    with open(path) as f:
        for doc in yaml.safe_load_all(f):
            if doc is not None:
                docs.append((os.path.basename(path), doc))
check("manifests parse (%d documents)" % len(docs), len(docs) >= 6)
for name, doc in docs:
    check("%s: %s has apiVersion, kind, metadata.name" % (name, doc.get("kind")),
          all(k in doc for k in ("apiVersion", "kind")) and doc.get("metadata", {}).get("name"))


def one(kind, name):
    found = [d for _, d in docs if d["kind"] == kind and d["metadata"]["name"] == name]
    check("one %s %s" % (kind, name), len(found) == 1)
    return found[0] if found else {}


def env_of(container):
    return {e["name"]: e for e in container.get("env", [])}


secret = one("Secret", "photonfarm-db")
service = one("Service", "photonfarm-db")
db = one("StatefulSet", "photonfarm-db")
claim = one("PersistentVolumeClaim", "photonfarm-frames")
workers = one("Deployment", "photonfarm-worker")
job = one("Job", "photonfarm-enqueue-demo")

url = urlparse(secret.get("stringData", {}).get("PHOTONFARM_DB", ""))
port = service.get("spec", {}).get("ports", [{}])[0].get("port")
check("the queue URL is postgresql:// at the Service's name and port",
      url.scheme in ("postgres", "postgresql") and url.hostname == "photonfarm-db" and
      url.port == port)
db_spec = db.get("spec", {})
check("PostgreSQL keeps its data on its own claim",
      len(db_spec.get("volumeClaimTemplates", [])) == 1)
check("the frames claim is ReadWriteMany",
      "ReadWriteMany" in claim.get("spec", {}).get("accessModes", []))

for label, owner, command in (("worker", workers, "worker"), ("enqueue", job, "enqueue")):
    pod = owner.get("spec", {}).get("template", {}).get("spec", {})
    container = (pod.get("containers") or [{}])[0]
    env = env_of(container)
    ref = env.get("PHOTONFARM_DB", {}).get("valueFrom", {}).get("secretKeyRef", {})
    check("%s: image photonfarm, command %s" % (label, command),
          container.get("image", "").startswith("photonfarm") and
          (container.get("args") or [""])[0] == command)
    check("%s: PHOTONFARM_DB from the Secret" % label,
          ref.get("name") == "photonfarm-db" and ref.get("key") == "PHOTONFARM_DB")
    check("%s: runs as the image's user 10001" % label,
          pod.get("securityContext", {}).get("runAsUser") == 10001)
    mounts = {m["mountPath"]: m["name"] for m in container.get("volumeMounts", [])}
    volumes = {v["name"]: v for v in pod.get("volumes", [])}
    check("%s: /data is the frames claim" % label,
          volumes.get(mounts.get("/data"), {}).get("persistentVolumeClaim", {}).get("claimName")
          == "photonfarm-frames")

pod = workers.get("spec", {}).get("template", {}).get("spec", {})
container = (pod.get("containers") or [{}])[0]
requests = container.get("resources", {}).get("requests", {})
threads = env_of(container).get("LP_NUM_THREADS", {}).get("value")
check("worker: LP_NUM_THREADS equals its CPU request",
      threads is not None and str(requests.get("cpu")) == str(threads))
check("worker: requests memory", "memory" in requests)
probe = " ".join(container.get("livenessProbe", {}).get("exec", {}).get("command", []))
check("worker: liveness is the heartbeat (workers --check)", "workers --check" in probe)
check("worker: a grace period for the frame in flight",
      pod.get("terminationGracePeriodSeconds", 0) >= 60)
# The monitor (issue 41): serve with a token from its Secret, the queue URL from the
# database's, /healthz probes, the image's user, and a Service in front of it.
monitor = one("Deployment", "photonfarm-monitor")
monitor_service = one("Service", "photonfarm-monitor")
monitor_token = one("Secret", "photonfarm-monitor-token")
pod = monitor.get("spec", {}).get("template", {}).get("spec", {})
container = (pod.get("containers") or [{}])[0]
args = container.get("args") or [""]
ref = env_of(container).get("PHOTONFARM_DB", {}).get("valueFrom", {}).get("secretKeyRef", {})
check("monitor: photonfarm serve on every address with a token file",
      container.get("image", "").startswith("photonfarm") and args[0] == "serve" and
      "--token-file" in args and "--listen" in args and
      args[args.index("--listen") + 1].startswith("0.0.0.0:"))
check("monitor: PHOTONFARM_DB from the Secret",
      ref.get("name") == "photonfarm-db" and ref.get("key") == "PHOTONFARM_DB")
check("monitor: the token file is the token Secret's",
      any(v.get("secret", {}).get("secretName") == "photonfarm-monitor-token"
          for v in pod.get("volumes", [])) and "token" in monitor_token.get("stringData", {}))
check("monitor: readiness and liveness ask /healthz",
      all(container.get(p, {}).get("httpGet", {}).get("path") == "/healthz"
          for p in ("readinessProbe", "livenessProbe")))
check("monitor: runs as the image's user 10001",
      pod.get("securityContext", {}).get("runAsUser") == 10001)
check("monitor: the Service selects it",
      monitor_service.get("spec", {}).get("selector") ==
      monitor.get("spec", {}).get("selector", {}).get("matchLabels"))
sys.exit(1 if failed else 0)
