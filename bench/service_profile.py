#!/usr/bin/env python3
"""Per worker and phase: tasks, their compute, lease-to-report and report-to-next-lease
times, from one service run's JSON logs (PREFIX.server.log, PREFIX.w1.log, PREFIX.w2.log …)
and its `submit --wait` output (PREFIX.submit.log). "after" is everything after Phase 3
(the bootstrap's refits among it). Used by bench/service_profile.sh."""
import datetime
import os
import json
import re
import statistics
import sys


def stamp(text):
    return datetime.datetime.fromisoformat(text.rstrip("Z")).timestamp()


def events(path):
    with open(path) as f:
        return [json.loads(line) for line in f if line.startswith("{")]


def tasks_of(path):
    tasks, current, last_report = [], None, None
    for e in events(path):
        t, msg = stamp(e["ts"]), e["msg"]
        if "event=task_leased" in msg:
            sets = int(re.search(r"sets=(\d+)", msg).group(1))
            current = {"lease": t, "sets": sets, "gap": t - last_report if last_report else 0.0}
        elif "event=task_reported" in msg and current:
            current["report"] = t
            current["compute"] = float(re.search(r"seconds=([\d.]+)", msg).group(1))
            tasks.append(current)
            last_report, current = t, None
    return tasks


def main(prefix):
    server = events(prefix + ".server.log")
    start = next(stamp(e["ts"]) for e in server if e["msg"].startswith("event=job_started"))
    done = next(stamp(e["ts"]) for e in server if e["msg"].startswith("event=job_done"))
    summary = open(prefix + ".submit.log").read()
    windows, t = {}, start
    for phase in ("phase1", "phase2", "phase3"):
        seconds = float(re.search(r"  " + phase + r"[^\n]*?\s\d+ sets\s+([\d.]+) s", summary).group(1))
        windows[phase], t = (t, t + seconds), t + seconds
    windows["after"] = (t, done)
    print(f"job {done - start:.2f} s: " + ", ".join(f"{p} {b - a:.2f} s" for p, (a, b) in windows.items()))
    worker = 0
    while os.path.exists(f"{prefix}.w{worker + 1}.log"):
        worker += 1
        tasks = tasks_of(f"{prefix}.w{worker}.log")
        if not tasks:
            print(f"w{worker}: no tasks")
            continue
        print(f"w{worker}: {len(tasks)} tasks, first lease {tasks[0]['lease'] - start:.2f} s after the job started")
        for phase, (a, b) in windows.items():
            share = [x for x in tasks if a <= x["lease"] < b]
            if not share:
                continue
            compute = sum(x["compute"] for x in share)
            held = sum(x["report"] - x["lease"] for x in share)
            waited = sum(x["gap"] for x in share)
            median_gap = 1000 * statistics.median(x["gap"] for x in share)
            median_sets = statistics.median(x["sets"] for x in share)
            print(f"  {phase}: {len(share)} tasks of median {median_sets:g} sets; compute {compute:.2f} s, "
                  f"held {held:.2f} s, waited {waited:.2f} s (median {median_gap:.1f} ms)")


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit("usage: service_profile.py PREFIX")
    main(sys.argv[1])
