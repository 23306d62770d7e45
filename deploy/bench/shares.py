"""A farm three users share, on the six-workstation compose cluster (`deploy/bench/run.sh
shares`): each workstation lends one render slot (its CPU limit rounded up), so the farm
lends six. Alice, bob and carol hand in staggered jobs (their own client keys, `sunray submit
--detach`): alice's first job alone, bob's beside it, carol's, alice's second, and at last
carol's priority-90 preview. Every SHARES_POLL seconds (default 0.5) the farm's queue is read
(`rem queue --json` on ws1): each active job's state, slots held, share and place.

The timeline is kept in deploy/bench/results/shares.json; `sunray bench shares` turns it into
each job's wait (submit to first slot), run time and slots over time (a plotters plot) and
the slot-seconds each user got against the fair share the queue gave them
(deploy/bench/results/shares.md and shares.png). Every image is fetched and compared with
`sunray render` of the scene on ws1: a run that lost or changed anything fails.
"""

import json
import os
import subprocess
import time

USERS = ["alice", "bob", "carol"]
# (id, user, seconds after the start, --hosts, --priority)
JOBS = [
    ("a1", "alice", 0.0, 6, 50),
    ("b1", "bob", 6.0, 6, 50),
    ("c1", "carol", 12.0, 6, 50),
    ("a2", "alice", 18.0, 3, 50),
    ("p1", "carol", 24.0, 2, 90),
]


def sunray(farm, user, *argv, check=True, line_ms="0"):
    """`sunray ARGV` on ws1 as `user` (their client key); workers take `line_ms` more a line."""
    cmd = farm.exec_argv("ws1", [])
    cmd = cmd[:-1] + ["-e", f"REM_SECRET_FILE=/out/{user}.key",
                      "-e", f"SUNRAY_WORKER_LINE_DELAY_MS={line_ms}", "ws1", "/bin/sunray", *argv]
    return subprocess.run(cmd, env=farm.env, capture_output=True, text=True, check=check)


def keys(farm, work):
    for u in USERS:
        r = farm.compose("exec", "-T", "ws1", "/bin/rem", "client-key", "--user", u,
                         capture_output=True, text=True, check=True)
        path = os.path.join(work, f"{u}.key")
        with open(path, "w") as f:
            f.write(r.stdout)
        os.chmod(path, 0o644)


def queue(farm):
    r = farm.compose("exec", "-T", "ws1", "/bin/rem", "queue", "--json",
                     capture_output=True, text=True)
    try:
        return json.loads(r.stdout)
    except ValueError:
        return None


def run(farm, work, res, line_ms, poll):
    farm.up(6, "ws1")
    try:
        keys(farm, work)
        farm.compose("exec", "-T", "ws1", "/bin/sunray", "render", "-q", "--resolution", res,
                     "/scenes/mount6.nff", "-o", "/out/shares-ref.png", check=True,
                     capture_output=True)
        with open(os.path.join(work, "shares-ref.png"), "rb") as f:
            ref = f.read()
        hosts = farm.hosts("ws1")
        start = time.time()
        submitted, samples, ended = {}, [], set()
        pending = list(JOBS)
        while len(ended) < len(JOBS):
            now = time.time() - start
            if now > 900:
                raise SystemExit(f"shares: the jobs did not end: {samples[-1:]}")
            while pending and pending[0][2] <= now:
                job, user, _, n, prio = pending.pop(0)
                sunray(farm, user, "submit", "--detach", "--hosts", str(n), "--priority",
                       str(prio), "--checkpoint-ms", "500", "--job", job, "--resolution", res,
                       "/scenes/mount6.nff", line_ms=line_ms)
                submitted[job] = time.time() - start
                print(f"shares: {job} ({user}, {n} hosts, priority {prio}) at "
                      f"{submitted[job]:.1f} s", flush=True)
            q = queue(farm)
            if q is not None:
                t = time.time() - start
                samples.append({"t": t, "slots": q["slots"], "jobs": q["jobs"]})
                active = {j["id"] for j in q["jobs"]}
                ended |= {j for j in submitted if j not in active and
                          any(j in {x["id"] for x in s["jobs"]} for s in samples)}
            time.sleep(poll)
        end = time.time() - start
        lost = []
        for job, user, *_ in JOBS:
            sunray(farm, user, "fetch", job, "-o", f"/out/shares-{job}.png")
            with open(os.path.join(work, f"shares-{job}.png"), "rb") as f:
                if f.read() != ref:
                    lost.append(job)
        return {"resolution": res, "line_ms": line_ms, "poll_s": poll, "hosts": hosts,
                "jobs": [{"id": j, "user": u, "at_s": submitted.get(j), "hosts": n,
                          "priority": p} for j, u, _, n, p in JOBS],
                "samples": samples, "end_s": end, "differ": lost, "passed": not lost}
    finally:
        farm.down()
