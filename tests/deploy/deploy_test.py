#!/usr/bin/env python3
"""Runs what deploy/ describes, as far as this machine can.

There is no container engine, Kubernetes cluster, Slurm or HTCondor here, so:

* systemd units: `systemd-analyze verify` (syntax, known keys, executables), then the
  command lines of the coordinator unit and the worker template are started for real
  (paths moved into a temporary folder, environment files honoured, %i/%H expanded);
* the Slurm script is run by bash as sbatch would run it (SLURM_* set; `srun` is a
  stand-in that drops its options and execs the command);
* the HTCondor submit file's executable, arguments and environment are expanded and run;
* a job submitted with the CLI then completes on those three workers, and SIGTERM
  drains every worker (exit 0);
* Kubernetes manifests, the compose file and the Dockerfile's CMD: every command line
  uses flags the binaries accept, ports/probes/services/volumes agree with each other;
* the Dockerfile's runtime stage installs the Debian packages that provide every shared
  library the three binaries load (ldd + dpkg + apt-cache), and its build stage has the
  build packages of scripts/dev.sh.

usage: deploy_test.py SOURCE_DIR BUILD_DIR
"""
import os
import re
import shlex
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time

import yaml

SRC, BUILD = sys.argv[1], sys.argv[2]
DEPLOY = os.path.join(SRC, "deploy")
BIN = {
    "wormdrag": os.path.join(BUILD, "client", "wormdrag"),
    "wormdrag-server": os.path.join(BUILD, "server", "wormdrag-server"),
    "wormdrag-worker": os.path.join(BUILD, "worker", "wormdrag-worker"),
}
failures = []


def check(cond, what):
    print(("ok   " if cond else "FAIL ") + what, flush=True)
    if not cond:
        failures.append(what)
    return cond


def free_port():
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()
    return port


def read(path):
    with open(path) as f:
        return f.read()


def help_flags(binary):
    out = subprocess.run([BIN[binary], "--help"], capture_output=True, text=True).stdout
    return set(re.findall(r"--[a-z][a-z0-9-]*", out))


FLAGS = {b: help_flags(b) for b in ("wormdrag-server", "wormdrag-worker")}


def check_flags(argv, where):
    binary = os.path.basename(argv[0])
    if not check(binary in FLAGS, f"{where}: runs a wormdrag binary ({binary})"):
        return
    for a in argv[1:]:
        if a.startswith("--"):
            check(a in FLAGS[binary], f"{where}: {binary} accepts {a}")


def unit_exec(path):
    m = re.search(r"^ExecStart=(.*)$", read(path), re.M)
    return shlex.split(m.group(1))


# ---------------------------------------------------------------- systemd-analyze

tmp = tempfile.mkdtemp(prefix="wormdrag-deploy-")
units = os.path.join(tmp, "units")
os.makedirs(units)
for name, binary in (("wormdrag-server.service", "wormdrag-server"),
                     ("wormdrag-worker@.service", "wormdrag-worker")):
    text = read(os.path.join(DEPLOY, "systemd", name)).replace("/usr/local/bin/" + binary, BIN[binary])
    with open(os.path.join(units, name), "w") as f:
        f.write(text)
shutil.copy(os.path.join(units, "wormdrag-worker@.service"), os.path.join(units, "wormdrag-worker@1.service"))
if shutil.which("systemd-analyze"):
    r = subprocess.run(["systemd-analyze", "verify", "--man=no", os.path.join(units, "wormdrag-server.service"),
                        os.path.join(units, "wormdrag-worker@1.service")], capture_output=True, text=True)
    check(r.returncode == 0 and not r.stderr.strip() and not r.stdout.strip(),
          "systemd-analyze verify: both units clean" + ("" if r.returncode == 0 else ": " + r.stdout + r.stderr))
else:
    check(False, "systemd-analyze is installed (scripts/dev.sh installs systemd)")

# ---------------------------------------------------------------- live run

port = free_port()
address = f"127.0.0.1:{port}"
token = "deploy-test-token"
state, cache = os.path.join(tmp, "state"), os.path.join(tmp, "cache")
os.makedirs(state)
os.makedirs(cache)
procs = {}


def start(name, argv, env_extra):
    env = dict(os.environ)
    env.pop("WORMDRAG_SERVER", None)
    env.pop("WORMDRAG_TOKEN", None)
    env.update(env_extra)
    log = open(os.path.join(tmp, name + ".log"), "w")
    procs[name] = subprocess.Popen(argv, stdout=log, stderr=subprocess.STDOUT, env=env, cwd=tmp)


def log_of(name):
    return read(os.path.join(tmp, name + ".log"))


def env_file(text):
    return dict(line.split("=", 1) for line in text.splitlines() if "=" in line and not line.startswith("#"))


# Coordinator: the unit's ExecStart with its state directory and address moved here,
# and the token from its EnvironmentFile.
server_argv = unit_exec(os.path.join(DEPLOY, "systemd", "wormdrag-server.service"))
check_flags(server_argv, "systemd coordinator unit")
server_argv = [BIN["wormdrag-server"]] + [
    a.replace("/var/lib/wormdrag", state).replace("0.0.0.0:50051", address) for a in server_argv[1:]]
check("EnvironmentFile=-/etc/wormdrag/server.env" in read(os.path.join(DEPLOY, "systemd", "wormdrag-server.service")),
      "coordinator unit reads /etc/wormdrag/server.env")
start("server", server_argv, env_file(f"WORMDRAG_TOKEN={token}\n"))

# Worker template, instance 1, with the environment file deploy/README.md describes.
worker_argv = unit_exec(os.path.join(DEPLOY, "systemd", "wormdrag-worker@.service"))
check_flags(worker_argv, "systemd worker unit")
worker_argv = [BIN["wormdrag-worker"]] + [
    a.replace("%H", socket.gethostname()).replace("%i", "1").replace("/var/cache/wormdrag", cache)
    for a in worker_argv[1:]]
start("systemd-worker", worker_argv, env_file(f"WORMDRAG_SERVER={address}\nWORMDRAG_TOKEN={token}\n"))

# Slurm: the batch script as sbatch runs it, with srun standing in.
shim = os.path.join(tmp, "shim")
os.makedirs(shim)
for b, path in BIN.items():
    os.symlink(path, os.path.join(shim, b))
with open(os.path.join(shim, "srun"), "w") as f:
    f.write('#!/bin/sh\nwhile [ "${1#-}" != "$1" ]; do shift; done\nexec "$@"\n')
os.chmod(os.path.join(shim, "srun"), 0o755)
sbatch = os.path.join(DEPLOY, "slurm", "wormdrag-workers.sbatch")
check("#SBATCH --signal=TERM@" in read(sbatch), "Slurm script asks for SIGTERM before the time limit")
start("slurm-worker", ["bash", sbatch], {
    "PATH": shim + ":" + os.environ["PATH"], "WORMDRAG_SERVER": address, "WORMDRAG_TOKEN": token,
    "SLURM_CPUS_PER_TASK": "1", "SLURM_ARRAY_JOB_ID": "41", "SLURM_ARRAY_TASK_ID": "2"})

# HTCondor: executable + arguments + environment with the submit-time macros.
sub = read(os.path.join(DEPLOY, "htcondor", "wormdrag-worker.sub"))
keys = dict(re.findall(r"^(\w+)\s*=\s*(.*)$", sub, re.M))
macros = {"server": address, "token": token, "Cluster": "9", "Process": "0", "request_cpus": "1"}


def expand(s):
    return re.sub(r"\$\((\w+)\)", lambda m: macros[m.group(1)], s).strip('"')


condor_argv = [keys["executable"]] + shlex.split(expand(keys["arguments"]))
check_flags(condor_argv, "HTCondor submit file")
check(keys.get("kill_sig") == "SIGTERM", "HTCondor removes workers with SIGTERM (drain)")
condor_argv[0] = BIN["wormdrag-worker"]
start("condor-worker", condor_argv, env_file(expand(keys["environment"])))

# A job from the CLI completes on these workers (once all three are connected: workers
# started before the coordinator listens back off first).
WORKERS = ("systemd-worker", "slurm-worker", "condor-worker")
deadline = time.time() + 60
while time.time() < deadline and not all("event=connected" in log_of(w) for w in WORKERS):
    time.sleep(0.2)
for w in WORKERS:
    check("event=connected" in log_of(w), f"{w} connected to the coordinator")
data = os.path.join(SRC, "examples", "data")
submit = subprocess.run([BIN["wormdrag"], "submit", os.path.join(data, "L1.csv"), os.path.join(data, "L2.csv"),
                         "--server", address, "--n-max", "3", "--t-max", "0.5", "--bootstrap", "0", "--wait"],
                        capture_output=True, text=True, timeout=600,
                        env=dict(os.environ, WORMDRAG_TOKEN=token))
check(submit.returncode == 0, "job submitted with the CLI completes" + ("" if submit.returncode == 0 else
                                                                        ": " + submit.stdout + submit.stderr))
check(sum("event=task_reported" in log_of(w) for w in WORKERS) >= 2,
      "the job's tasks were spread over more than one deployed worker")
check("slurm-41-2" in log_of("server") or "slurm-41-2" in log_of("slurm-worker"), "Slurm worker id from SLURM_*")
for w in WORKERS:
    procs[w].send_signal(signal.SIGTERM)
    try:
        code = procs[w].wait(timeout=60)
    except subprocess.TimeoutExpired:
        procs[w].kill()
        code = None
    check(code == 0, f"{w} drains and exits 0 on SIGTERM (got {code})")
procs["server"].send_signal(signal.SIGTERM)
check(procs["server"].wait(timeout=30) == 0, "coordinator exits 0 on SIGTERM")
check(os.path.exists(os.path.join(state, "jobs.db")), "the job store is where the unit's --db says")

# ---------------------------------------------------------------- manifests

docs = {}
for name in ("coordinator.yaml", "workers.yaml"):
    for d in yaml.safe_load_all(read(os.path.join(DEPLOY, "k8s", name))):
        docs[d["kind"]] = d
coord = docs["StatefulSet"]["spec"]["template"]["spec"]["containers"][0]
check_flags(coord["args"], "k8s coordinator")
listen = coord["args"][coord["args"].index("--listen") + 1]
db = coord["args"][coord["args"].index("--db") + 1]
cport = int(listen.rsplit(":", 1)[1])
check(coord["ports"][0]["containerPort"] == cport, "k8s containerPort = --listen port")
check(coord["readinessProbe"]["grpc"]["port"] == cport and coord["livenessProbe"]["grpc"]["port"] == cport,
      "k8s gRPC probes on the listen port (the server implements grpc.health.v1)")
check(os.path.dirname(db) == coord["volumeMounts"][0]["mountPath"], "k8s --db lives on the persistent volume")
check(docs["StatefulSet"]["spec"]["replicas"] == 1, "k8s: exactly one coordinator (one SQLite writer)")
svc = docs["Service"]
check(svc["spec"]["ports"][0]["targetPort"] == cport, "k8s Service targets the coordinator port")
check(svc["spec"]["selector"] == docs["StatefulSet"]["spec"]["template"]["metadata"]["labels"],
      "k8s Service selects the coordinator pods")
wk = docs["Deployment"]["spec"]["template"]["spec"]["containers"][0]
check_flags(wk["args"], "k8s worker")
check(wk["args"][wk["args"].index("--server") + 1] == f"{svc['metadata']['name']}:{svc['spec']['ports'][0]['port']}",
      "k8s workers dial the Service")
check(docs["PersistentVolumeClaim"]["metadata"]["name"] ==
      docs["StatefulSet"]["spec"]["template"]["spec"]["volumes"][0]["persistentVolumeClaim"]["claimName"],
      "k8s coordinator mounts the claim")

compose = yaml.safe_load(read(os.path.join(DEPLOY, "docker", "compose.yaml")))
cc, cw = compose["services"]["coordinator"], compose["services"]["worker"]
check_flags(cc["command"], "compose coordinator")
check_flags(cw["command"], "compose worker")
cport = cc["command"][cc["command"].index("--listen") + 1].rsplit(":", 1)[1]
check(cw["command"][cw["command"].index("--server") + 1] == f"coordinator:{cport}", "compose workers dial the coordinator")
check(cc["volumes"][0].split(":")[1] == os.path.dirname(cc["command"][cc["command"].index("--db") + 1]),
      "compose --db lives on the named volume")

dockerfile = read(os.path.join(DEPLOY, "docker", "Dockerfile"))
cmd = yaml.safe_load(re.search(r"^CMD (\[.*\])$", dockerfile, re.M).group(1))
check(cmd == cc["command"], "Dockerfile CMD = compose coordinator command")
stages = re.split(r"^FROM ", dockerfile, flags=re.M)[1:]
check(len(stages) == 2, "Dockerfile has a build and a runtime stage")
check("/src/build/client/wormdrag-track" in stages[1],
      "Dockerfile installs wormdrag-track (wormdrag track runs it from wormdrag's folder)")


def apt_packages(stage):
    m = re.search(r"apt-get install -y --no-install-recommends(.*?)&&", stage, re.S)
    return set(m.group(1).replace("\\", " ").split())


build_pkgs, runtime_pkgs = apt_packages(stages[0]), apt_packages(stages[1])
dev = read(os.path.join(SRC, "scripts", "dev.sh"))
dev_pkgs = set(re.search(r"packages=\((.*?)\)", dev, re.S).group(1).split())
test_only = {"libgtest-dev", "libgmock-dev", "googletest", "libbenchmark-dev", "unzip", "chromium", "openssl",
             "systemd", "python3", "python3-yaml", "slurm-wlm", "munge",
             "clang", "libclang-rt-dev"}  # clang: the fuzz targets (scripts/fuzz.sh) only
if "build-essential" in build_pkgs:
    build_pkgs.add("g++")
missing = sorted(dev_pkgs - test_only - build_pkgs)
check(not missing, "Dockerfile build stage has scripts/dev.sh's build packages" + (f" (missing {missing})" if missing else ""))

# Every shared library the binaries load comes from a package the runtime stage installs
# (or one of their dependencies).
if shutil.which("apt-cache") and shutil.which("dpkg"):
    r = subprocess.run(["apt-cache", "depends", "--recurse", "--no-recommends", "--no-suggests", "--no-conflicts",
                        "--no-breaks", "--no-replaces", "--no-enhances"] + sorted(runtime_pkgs),
                       capture_output=True, text=True)
    closure = set(re.findall(r"^(\S+)$", r.stdout, re.M)) | set(re.findall(r"Depends: <?([^\s>]+)>?", r.stdout))
    closure = {p.split(":")[0] for p in closure}
    check(r.returncode == 0 and runtime_pkgs <= closure,
          "apt-cache knows the runtime stage's packages (Debian 12 names; needs apt lists)" +
          ("" if runtime_pkgs <= closure else f": unknown {sorted(runtime_pkgs - closure)}"))
    libs = set()
    for path in [BIN["wormdrag"], os.path.join(BUILD, "client", "wormdrag-track"), BIN["wormdrag-server"],
                 BIN["wormdrag-worker"]]:
        out = subprocess.run(["ldd", path], capture_output=True, text=True).stdout
        libs |= set(re.findall(r"=> (/\S+)", out))
    # dpkg -S knows a library by the path its package installed (usr-merge: /lib or /usr/lib).
    candidates = {}
    for lib in libs:
        real = os.path.realpath(lib)
        candidates[lib] = {lib, real, lib.replace("/usr/lib", "/lib", 1), real.replace("/usr/lib", "/lib", 1)}
    paths = sorted(set().union(*candidates.values()))
    q = subprocess.run(["dpkg", "-S"] + paths, capture_output=True, text=True)
    owner_of = {}
    for line in q.stdout.splitlines():
        pkgs, path = line.split(": ", 1)
        owner_of[path.strip()] = pkgs.split(",")[0].split(":")[0].strip()
    uncovered = []
    for lib in sorted(libs):
        owners = {owner_of[p] for p in candidates[lib] if p in owner_of}
        if not owners or not owners & closure:
            uncovered.append(f"{os.path.basename(lib)} ({','.join(sorted(owners)) or 'no package'})")
    check(not uncovered, f"Dockerfile runtime stage provides all {len(libs)} shared libraries"
          + (f"; not covered: {uncovered}" if uncovered else ""))

for p in procs.values():
    if p.poll() is None:
        p.kill()
if failures:
    print(f"\n{len(failures)} check(s) failed; logs in {tmp}")
    sys.exit(1)
shutil.rmtree(tmp)
print("\nall deploy checks passed")
