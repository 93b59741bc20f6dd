"""What deploy/ promises beyond the schema (kubernetes-validate checks types and fields only),
run by .ci/container.sh with the PyYAML of its tools venv:
- every container of every workload runs as non-root with a read-only root filesystem, and
  every path it writes is a volume (the service: /tmp; PostgreSQL: its data, socket and /tmp);
- the service reads its job store URL (SPHEREFIT_JOB_STORE) from the `spherefit` Secret and its
  key file (SPHEREFIT_API_KEYS_FILE) from a file that Secret mounts;
- PostgreSQL keeps its data on a volume claim of its StatefulSet, its password from a Secret.
Exits 1 naming the first thing that is not so."""
import sys

import yaml

docs = {}
for path in sys.argv[1:]:
    for d in yaml.safe_load_all(open(path)):
        if d:
            docs[(d["kind"], d["metadata"]["name"])] = (path, d)


def fail(msg):
    sys.exit(f"deploy_check: {msg}")


for (kind, name), (path, d) in docs.items():
    if kind not in ("Deployment", "StatefulSet", "Job"):
        continue
    pod = d["spec"]["template"]["spec"]
    if not pod.get("securityContext", {}).get("runAsNonRoot"):
        fail(f"{path}: {kind} {name} may run as root")
    for c in pod["containers"]:
        sc = c.get("securityContext", {})
        if sc.get("readOnlyRootFilesystem") is not True:
            fail(f"{path}: {kind} {name}, container {c['name']}: readOnlyRootFilesystem is not true")
        if not c.get("volumeMounts"):
            fail(f"{path}: {kind} {name}, container {c['name']}: no writable volume")
    print(f"{path}: {kind} {name}: non-root, read-only root filesystem, writes to "
          + ", ".join(m["mountPath"] for c in pod["containers"] for m in c["volumeMounts"]
                      if not m.get("readOnly")))

_, svc = docs[("Deployment", "spherefit")]
pod = svc["spec"]["template"]["spec"]
c = pod["containers"][0]
env = {e["name"]: e for e in c["env"]}
ref = env.get("SPHEREFIT_JOB_STORE", {}).get("valueFrom", {}).get("secretKeyRef", {})
if (ref.get("name"), ref.get("key")) != ("spherefit", "job-store"):
    fail(f"the service's SPHEREFIT_JOB_STORE is not the spherefit Secret's job-store: {env.get('SPHEREFIT_JOB_STORE')}")
keys_file = env.get("SPHEREFIT_API_KEYS_FILE", {}).get("value", "")
volumes = {v["name"]: v for v in pod["volumes"]}
mounted = [m for m in c["volumeMounts"] if keys_file.startswith(m["mountPath"].rstrip("/") + "/")]
if not mounted or volumes[mounted[0]["name"]].get("secret", {}).get("secretName") != "spherefit":
    fail(f"SPHEREFIT_API_KEYS_FILE={keys_file!r} is not a file of the spherefit Secret")
if not any(m["mountPath"] == "/tmp" for m in c["volumeMounts"]):
    fail("the service's temporary directory is not a volume")
print("service: job store URL and key file from the spherefit Secret; /tmp a volume")

_, pg = docs[("StatefulSet", "spherefit-postgres")]
claims = [t["metadata"]["name"] for t in pg["spec"].get("volumeClaimTemplates", [])]
pgc = pg["spec"]["template"]["spec"]["containers"][0]
data = [m for m in pgc["volumeMounts"] if m["name"] in claims]
if not data:
    fail("PostgreSQL's data is not on a volume claim")
pw = {e["name"]: e for e in pgc["env"]}["POSTGRES_PASSWORD"]["valueFrom"]["secretKeyRef"]
print(f"postgres: data on the claim {data[0]['name']} at {data[0]['mountPath']}; password from the Secret {pw['name']}")
