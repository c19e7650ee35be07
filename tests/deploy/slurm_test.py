#!/usr/bin/env python3
"""deploy/slurm/wormdrag-workers.sbatch on a real one-node Slurm cluster.

munged, slurmctld and slurmd run as root (no systemd) from a generated configuration and
state folders in a temporary directory (AuthInfo=socket= points at that munged; no system
file is read or changed). A coordinator listens on loopback; the script is submitted with
`sbatch --array=1-2`, and then:

* a job submitted with the CLI completes on those two workers, its bootstrap refits
  among their tasks, bit-identical to `wormdrag estimate` of the same inputs and options
  (every evaluation both stored, survivors, estimate and intervals);
* `scancel` of one array task while its worker is in the middle of a task: the worker
  drains (SIGTERM from Slurm; the task's result reported, nothing re-leased) and exits,
  and the job completes on the other worker, again identical to the embedded run;
* the remaining worker's --idle-exit ends its array task (COMPLETED, exit 0) once the
  queue is empty, freeing the allocation.

To catch a worker mid-task deterministically the test stops it (SIGSTOP) right after it
logs a lease and before it reports; Slurm's cancellation then continues it (SIGCONT)
and delivers SIGTERM, so the task is certainly in flight when the signal arrives.

Exits 77 (ctest SKIP_RETURN_CODE) with the reason when Slurm cannot start here: not root,
packages missing (scripts/dev.sh installs slurm-wlm and munge), or the daemons fail.

usage: slurm_test.py SOURCE_DIR BUILD_DIR
"""
import atexit
import json
import os
import re
import shlex
import shutil
import signal
import socket
import sqlite3
import subprocess
import sys
import tempfile
import time

SRC, BUILD = sys.argv[1], sys.argv[2]
CLI = os.path.join(BUILD, "client", "wormdrag")
SERVER = os.path.join(BUILD, "server", "wormdrag-server")
WORKER = os.path.join(BUILD, "worker", "wormdrag-worker")
SBATCH_SCRIPT = os.path.join(SRC, "deploy", "slurm", "wormdrag-workers.sbatch")
DATA = [os.path.join(SRC, "examples", "data", f) for f in ("L1.csv", "L2.csv")]
SKIP = 77
# Two small jobs that differ in E (t-max), so the second cannot reuse the first's sets.
# The first runs its bootstrap refits as worker tasks; the second has none, so the
# worker caught mid-task below holds a Phase 1-3 task.
JOB_OPTIONS = [["--n-max", "3", "--t-max", "1", "--bootstrap", "19"],
               ["--n-max", "3", "--t-max", "2", "--bootstrap", "0"]]
# Seconds; the workers' --idle-exit (WORMDRAG_IDLE_EXIT). It runs from a worker's start,
# and on a loaded machine the CLI's submission can come more than 10 s after it: the
# workers then leave before the job and the test waits for workers that never come.
IDLE_EXIT = 30

failures = []
procs = []  # every process this test started, stopped at the end by its own handle
cluster = {}  # slurmctld's process and the environment of the Slurm commands


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
    try:
        with open(path, errors="replace") as f:
            return f.read()
    except FileNotFoundError:
        return ""


def tail(path, n=15):
    return "\n".join(read(path).splitlines()[-n:])


def wait_until(pred, seconds, step=0.2):
    end = time.time() + seconds
    while time.time() < end:
        if pred():
            return True
        time.sleep(step)
    return pred()


def which(tool):
    return shutil.which(tool, path=os.environ.get("PATH", "") + ":/usr/sbin:/sbin")


def start(argv, log, env=None):
    p = subprocess.Popen(argv, stdout=open(log, "w"), stderr=subprocess.STDOUT, env=env)
    procs.append(p)
    return p


def stop_all():
    """Cancels this cluster's jobs (their steps end before slurmd does), then stops
    every process this test started, newest first."""
    if "slurmctld" in cluster and cluster["slurmctld"].poll() is None:
        env = cluster["env"]
        subprocess.run([which("scancel"), "--user=root"], env=env, capture_output=True, timeout=60)
        wait_until(lambda: not subprocess.run([which("squeue"), "-h"], env=env, capture_output=True,
                                              text=True).stdout.strip(), 40, 0.5)
    for p in reversed(procs):
        if p.poll() is None:
            p.send_signal(signal.SIGTERM)
            try:
                p.wait(timeout=20)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()


atexit.register(stop_all)
signal.signal(signal.SIGTERM, lambda *_: sys.exit(1))  # ctest's timeout: clean up too


def skip(reason):
    print("SKIP: " + reason, flush=True)
    sys.exit(SKIP)


# ---------------------------------------------------------------- the cluster

if os.geteuid() != 0:
    skip("slurmd must run as root to start job steps; this test runs Slurm only as root")
tools = ["munged", "slurmctld", "slurmd", "sbatch", "scancel", "scontrol", "sinfo", "squeue"]
missing = [t for t in tools if not which(t)]
if missing:
    skip(f"{', '.join(missing)} not installed (scripts/dev.sh installs slurm-wlm and munge)")

tmp = tempfile.mkdtemp(prefix="wormdrag-slurm-")
os.chmod(tmp, 0o755)  # munged wants its socket's folder reachable by every user
print(f"work folder {tmp}", flush=True)
munge_dir, state, spool, jobdir = (os.path.join(tmp, d) for d in ("munge", "state", "spool", "jobs"))
for d in (munge_dir, state, spool, jobdir):
    os.makedirs(d)
os.chmod(munge_dir, 0o755)
key = os.path.join(munge_dir, "munge.key")
with open(os.open(key, os.O_WRONLY | os.O_CREAT, 0o600), "wb") as f:
    f.write(os.urandom(1024))
munge_socket = os.path.join(munge_dir, "munge.socket")
start([which("munged"), "--foreground", "--force", f"--socket={munge_socket}", f"--key-file={key}",
       f"--pid-file={munge_dir}/munged.pid", f"--log-file={munge_dir}/munged.log",
       f"--seed-file={munge_dir}/munged.seed"], os.path.join(tmp, "munged.out"))
if not wait_until(lambda: os.path.exists(munge_socket), 10):
    skip("munged did not start: " + tail(os.path.join(munge_dir, "munged.log")) + read(os.path.join(tmp, "munged.out")))

node = socket.gethostname().split(".")[0]
with open("/proc/meminfo") as f:
    mem_mb = int(re.search(r"MemTotal:\s+(\d+)", f.read()).group(1)) // 1024
conf = os.path.join(tmp, "slurm.conf")
with open(conf, "w") as f:
    f.write(f"""ClusterName=wormdragtest
SlurmctldHost={node}(127.0.0.1)
SlurmctldPort={free_port()}
SlurmdPort={free_port()}
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
AuthInfo=socket={munge_socket}
CredType=cred/munge
StateSaveLocation={state}
SlurmdSpoolDir={spool}
SlurmctldPidFile={tmp}/slurmctld.pid
SlurmdPidFile={tmp}/slurmd.pid
SlurmctldLogFile={tmp}/slurmctld.log
SlurmdLogFile={tmp}/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
MpiDefault=none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
SchedulerType=sched/builtin
SlurmdParameters=config_overrides
ReturnToService=2
KillWait=30
NodeName={node} NodeAddr=127.0.0.1 CPUs={max(2, os.cpu_count() or 1)} RealMemory={mem_mb} State=UNKNOWN
PartitionName=test Nodes=ALL Default=YES MaxTime=INFINITE State=UP
""")
# The Slurm commands and the jobs see only this cluster: no SLURM_*/SBATCH_* settings of
# a surrounding allocation.
env = {k: v for k, v in os.environ.items() if not k.startswith(("SLURM_", "SBATCH_", "SRUN_", "WORMDRAG_"))}
env["SLURM_CONF"] = conf
cluster["env"] = env
cluster["slurmctld"] = start([which("slurmctld"), "-D", "-f", conf], os.path.join(tmp, "slurmctld.out"), env)
start([which("slurmd"), "-D", "-f", conf, "-N", node], os.path.join(tmp, "slurmd.out"), env)


def slurm(*argv, check_rc=True):
    r = subprocess.run([which(argv[0])] + list(argv[1:]), capture_output=True, text=True, env=env, timeout=60)
    if check_rc and r.returncode != 0:
        raise RuntimeError(f"{' '.join(argv)}: exit {r.returncode}: {r.stdout}{r.stderr}")
    return r.stdout


def node_idle():
    r = subprocess.run([which("sinfo"), "-h", "-o", "%t"], capture_output=True, text=True, env=env)
    return r.returncode == 0 and r.stdout.strip() == "idle"


if not wait_until(node_idle, 60, 0.5):
    skip("Slurm did not start (node not idle within 60 s)\n-- slurmctld:\n" + tail(os.path.join(tmp, "slurmctld.log")) +
         read(os.path.join(tmp, "slurmctld.out")) + "\n-- slurmd:\n" + tail(os.path.join(tmp, "slurmd.log")) +
         read(os.path.join(tmp, "slurmd.out")))
print(f"ok   one-node Slurm cluster up (node {node}, {max(2, os.cpu_count() or 1)} CPUs)", flush=True)

# ---------------------------------------------------------------- reference and coordinator

# The embedded runs of both jobs, in the background while the workers start.
reference_db = os.path.join(tmp, "embedded.db")
reference = subprocess.Popen(
    ["/bin/sh", "-c", " && ".join(
        shlex.join([CLI, "estimate", DATA[0], DATA[1], "--db", reference_db, "--threads", "2"] + o)
        for o in JOB_OPTIONS)],
    stdout=open(os.path.join(tmp, "embedded.log"), "w"), stderr=subprocess.STDOUT)
procs.append(reference)

token = "slurm-test-" + os.urandom(8).hex()
token_file = os.path.join(tmp, "token")
with open(os.open(token_file, os.O_WRONLY | os.O_CREAT, 0o600), "w") as f:
    f.write(token)
address = f"127.0.0.1:{free_port()}"
coordinator_db = os.path.join(tmp, "coordinator.db")
server_log = os.path.join(tmp, "server.log")
server = start([SERVER, "--listen", address, "--db", coordinator_db, "--token", token], server_log)
check(wait_until(lambda: "event=listening" in read(server_log), 30), "coordinator listening on " + address)

# ---------------------------------------------------------------- the workers, through sbatch

shim = os.path.join(tmp, "bin")  # what a lab's module or install puts on PATH
os.makedirs(shim)
os.symlink(WORKER, os.path.join(shim, "wormdrag-worker"))
job_env = dict(env, PATH=shim + ":" + env.get("PATH", "/usr/bin:/bin"), WORMDRAG_SERVER=address,
               WORMDRAG_TOKEN_FILE=token_file, WORMDRAG_IDLE_EXIT=str(IDLE_EXIT))
# The script's defaults ask for 8 CPUs and 2 GB; a site overrides them on the command line.
r = subprocess.run([which("sbatch"), "--parsable", "--array=1-2", "--cpus-per-task=1", "--mem=256M",
                    f"--chdir={jobdir}", SBATCH_SCRIPT], capture_output=True, text=True, env=job_env, timeout=60)
check(r.returncode == 0, "sbatch --array=1-2 accepts the script" + ("" if r.returncode == 0 else ": " + r.stderr))
array = r.stdout.strip().split(";")[0]
worker_log = {i: os.path.join(jobdir, f"wormdrag-worker-{array}_{i}.log") for i in (1, 2)}


def events(i):
    """The worker's log events in order: (event, {key: value})."""
    out = []
    for line in read(worker_log[i]).splitlines():
        m = re.search(r"event=(\w+)((?: \w+=[^ \"]*)*)", line)
        if m:
            out.append((m.group(1), dict(kv.split("=", 1) for kv in m.group(2).split())))
    return out


def has_event(i, name):
    return any(e == name for e, _ in events(i))


both = wait_until(lambda: has_event(1, "connected") and has_event(2, "connected"), 120, 0.5)
check(both, "both array tasks started a worker that connected to the coordinator" +
      ("" if both else f"\n{slurm('squeue', check_rc=False)}\n1: {tail(worker_log[1])}\n2: {tail(worker_log[2])}"))
for i in (1, 2):
    check(any(e == "start" and kv.get("worker") == f"slurm-{array}-{i}" for e, kv in events(i)),
          f"array task {i}: worker id slurm-{array}-{i} from SLURM_ARRAY_*")
    check("cluster configuration lacks support" not in read(worker_log[i]), f"array task {i}: srun without warnings")

# ---------------------------------------------------------------- job 1 on both workers

cli_env = dict(env, WORMDRAG_TOKEN=token)


def submit(options, wait):
    return subprocess.run([CLI, "submit", DATA[0], DATA[1], "--server", address] + options + (["--wait"] if wait else []),
                          capture_output=True, text=True, env=cli_env, timeout=900)


r = submit(JOB_OPTIONS[0], True)
check(r.returncode == 0, "job 1 completes on the Slurm workers" + ("" if r.returncode == 0 else ": " + r.stderr[-2000:]))
for i in (1, 2):
    check(any(e == "task_reported" and kv.get("job") == "1" for e, kv in events(i)),
          f"array task {i}'s worker computed part of job 1")
refits = sum(e == "task_reported" and kv.get("job") == "1" and kv.get("sets") == "0" for i in (1, 2)
             for e, kv in events(i))  # a bootstrap refit carries no sets
# Checked against the stored result below: 19 refits plus those checking determined ratios.

# ---------------------------------------------------------------- job 2: scancel mid-task

r = submit(JOB_OPTIONS[1], False)
check(r.returncode == 0, "job 2 submitted")
job2 = r.stdout.strip().split()[-1] if r.returncode == 0 else "2"
pid = next((int(kv["pid"]) for e, kv in events(1) if e == "start"), 0)


def in_flight(i):
    """The task worker i leased last and has not reported yet, if any."""
    current = None
    for e, kv in events(i):
        if e == "task_leased":
            current = kv.get("task")
        elif e == "task_reported" and kv.get("task") == current:
            current = None
    return current


caught = None
deadline = time.time() + 120
while time.time() < deadline and caught is None and pid:
    task = in_flight(1)
    if task and any(e == "task_leased" and kv.get("job") == job2 for e, kv in events(1)):
        os.kill(pid, signal.SIGSTOP)
        time.sleep(0.3)  # a report already on its way lands in the log
        if in_flight(1) == task:
            caught = task
        else:
            os.kill(pid, signal.SIGCONT)
    else:
        time.sleep(0.01)
check(caught is not None, "array task 1's worker caught with a task of job 2 in flight")
slurm("scancel", f"{array}_1")
time.sleep(1)
try:
    if pid:
        os.kill(pid, signal.SIGCONT)  # in case Slurm's SIGCONT did not come first; the SIGTERM is Slurm's either way
except ProcessLookupError:
    pass  # already drained and gone
check(wait_until(lambda: has_event(1, "drained"), 60), "scancel: the worker drained and exited")
ev1 = [e for e, _ in events(1)]
after = events(1)[ev1.index("draining"):] if "draining" in ev1 else []
check(after and after[0][1].get("signal") == "SIGTERM", "scancel reached the worker as SIGTERM")
check(any(e == "task_reported" and kv.get("task") == caught and kv.get("duplicate") == "false" for e, kv in after),
      f"the in-flight task {caught} was reported after SIGTERM (acknowledged, not a duplicate)")
check(not re.search(r"lease of task \S+ .* expired", read(server_log)), "no lease expired: nothing had to be re-run")


def job_state(job):
    out = slurm("scontrol", "-o", "show", "job", job, check_rc=False)
    m = re.search(r"JobState=(\S+).*ExitCode=(\S+)", out)
    return (m.group(1), m.group(2)) if m else ("?", "?")


check(wait_until(lambda: job_state(f"{array}_1")[0] == "CANCELLED", 60),
      f"array task 1 is CANCELLED ({job_state(array + '_1')})")

r = subprocess.run([CLI, "watch", job2, "--server", address], capture_output=True, text=True, env=cli_env, timeout=900)
check(r.returncode == 0, "job 2 still completes, on the remaining worker" + ("" if r.returncode == 0 else ": " + r.stderr[-2000:]))

# ---------------------------------------------------------------- --idle-exit

check(wait_until(lambda: has_event(2, "idle_exit"), IDLE_EXIT + 30), "the last worker exits when the queue stays empty")
check(wait_until(lambda: job_state(f"{array}_2") == ("COMPLETED", "0:0"), 60),
      f"its array task ends COMPLETED with exit 0, freeing the allocation ({job_state(array + '_2')})")
check(wait_until(lambda: not slurm("squeue", "-h", check_rc=False).strip(), 30), "nothing left in the Slurm queue")

# ---------------------------------------------------------------- same as embedded

check(reference.wait(timeout=900) == 0, "embedded reference runs: " + tail(os.path.join(tmp, "embedded.log"), 3))


# Which sets early abandoning stops, and so the knots simulated, depend on the order
# results arrive in; everything else in a result is the same double.
RUN_DEPENDENT = {"seconds", "abandoned", "knots"}


def strip_run_dependent(x):
    if isinstance(x, dict):
        return {k: strip_run_dependent(v) for k, v in x.items() if k not in RUN_DEPENDENT}
    if isinstance(x, list):
        return [strip_run_dependent(v) for v in x]
    return x


def stored(db, job):
    c = sqlite3.connect(db)
    state, options, result = c.execute("SELECT state, options_json, result_json FROM jobs WHERE id = ?", (job,)).fetchone()
    evals = c.execute("SELECT phase, mu_n, mu_t, eta_n, eta_t, e FROM evaluations WHERE job_id = ? "
                      "ORDER BY phase, mu_n, mu_t, eta_n, eta_t", (job,)).fetchall()
    surv = c.execute("SELECT phase, rank, mu_n, mu_t, eta_n, eta_t, e FROM survivors WHERE job_id = ? "
                     "ORDER BY phase, rank", (job,)).fetchall()
    c.close()
    return state, options, strip_run_dependent(json.loads(result or "{}")), evals, surv


for job in (1, 2):
    remote, embedded = stored(coordinator_db, job), stored(reference_db, job)
    check(remote[0] == "done", f"job {job} is done in the coordinator's store")
    check(remote[1] == embedded[1], f"job {job}: same options as the embedded run")
    # Each run stores its own subset of the abandoned sets; every E stored by both is the same.
    r_e, e_e = ({row[:5]: row[5] for row in rows} for rows in (remote[3], embedded[3]))
    both = r_e.keys() & e_e.keys()
    check(len(both) > 0 and all(r_e[k] == e_e[k] for k in both),
          f"job {job}: the {len(both)} evaluations both runs stored are bit-identical")
    check(remote[4] == embedded[4], f"job {job}: same survivors")
    check(remote[2] == embedded[2] and "estimate" in remote[2],
          f"job {job}: same result (estimate {remote[2].get('estimate')})")
boot = stored(coordinator_db, 1)[2].get("bootstrap", {})
check(boot.get("replicates", 0) + boot.get("failed", 0) == 19, f"job 1: its 19 bootstrap refits ran ({boot})")
expected = 19 + len(boot.get("smoothing_check", [])) + boot.get("check_refits", 0)
check(refits == expected, f"job 1's {expected} bootstrap refits (19 + checks) ran on the Slurm workers ({refits})")

# ---------------------------------------------------------------- end

server.send_signal(signal.SIGTERM)
check(server.wait(timeout=30) == 0, "coordinator exits 0 on SIGTERM")
stop_all()
if failures:
    print(f"\n{len(failures)} check(s) failed; logs in {tmp}")
    sys.exit(1)
shutil.rmtree(tmp)
print("\nall Slurm checks passed")
