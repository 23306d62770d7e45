"""The chaos soak on the six-workstation compose cluster (`deploy/bench/run.sh chaos`).

Three users, each with a client key of their own (`rem client-key`), hand eight jobs to the
farm with `sunray submit --detach` over the run (mount6, tetra6 and balls4; the three
strategies), each through a workstation that is up. Meanwhile, at times drawn from a seed
(CHAOS_SEED, default 42), faults come until at least CHAOS_FAULTS (default 30) were injected
and every job was submitted: a container killed (`docker kill`, every process in it) and
started again on its own state directory; a container frozen (`docker pause`, or SIGSTOP to
its processes where the freezer does not work) and thawed; a container cut off its network
and connected again; a container restarted (`docker restart`: remd's SIGTERM, then the
same state directory). At most two workstations are out at once, so a majority stays.

At the end every fault is undone and every job waited for; each image is fetched and
compared with `sunray render` of the same scene on ws1; no `sunray` process may be left on
any host, every state directory must stay under CHAOS_STATE_MB (default 64) and every daemon
must answer. The table (faults by kind, controller moves, time lost against the same jobs
on the quiet farm, and what was lost) is printed and kept for the report; a soak that lost
anything fails the run (exit status 1) once its figures are saved.
"""

import json
import os
import random
import subprocess
import time

USERS = ["alice", "bob", "carol"]
SCENES = ["mount6", "tetra6", "balls4"]
STRATEGIES = ["dynamic", "blocks", "interleaved"]
JOBS = 8
MAX_OUT = 2
KINDS = ["kill", "freeze", "disconnect", "restart"]


class Chaos:
    def __init__(self, farm, work, seed, res, line_ms):
        self.farm, self.work, self.res, self.line_ms = farm, work, res, line_ms
        self.rng = random.Random(seed)
        self.hosts = [f"ws{i}" for i in range(1, 7)]
        self.out = {}          # host -> (kind, time it comes back)
        self.faults = {k: 0 for k in KINDS}
        self.log = []

    def cid(self, host):
        return self.farm.compose("ps", "-q", host, capture_output=True,
                                 text=True).stdout.strip()

    def docker(self, *args):
        return subprocess.run(["docker", *args], capture_output=True, text=True)

    def up(self):
        return [h for h in self.hosts if h not in self.out]

    def sunray(self, via, user, *argv, check=True, timeout=None):
        """`sunray ARGV` in `via`'s container as `user` (their client key)."""
        cmd = self.farm.exec_argv(via, [])
        cmd = cmd[:-1] + ["-e", f"SUNRAY_WORKER_LINE_DELAY_MS={self.line_ms}",
                          "-e", f"REM_SECRET_FILE=/out/{user}.key", via,
                          "/bin/sunray", *argv]
        return subprocess.run(cmd, env=self.farm.env, capture_output=True, text=True,
                              check=check, timeout=timeout)

    def keys(self):
        for u in USERS:
            r = self.farm.compose("exec", "-T", "ws1", "/bin/rem", "client-key", "--user", u,
                                  capture_output=True, text=True, check=True)
            path = os.path.join(self.work, f"{u}.key")
            with open(path, "w") as f:
                f.write(r.stdout)
            os.chmod(path, 0o644)

    def submit(self, job, via):
        self.sunray(via, job["user"], "submit", "--detach", "--hosts", "3",
                    "--checkpoint-ms", "500", "--job", job["id"], "--strategy",
                    job["strategy"], "--resolution", self.res, f"/scenes/{job['scene']}.nff")

    def inject(self, now):
        up = self.up()
        if len(self.out) >= MAX_OUT or len(up) < 3:
            return
        host = self.rng.choice(up)
        kind = self.rng.choice(KINDS)
        back = now + self.rng.uniform(2.0, 10.0)
        cid = self.cid(host)
        if kind == "kill":
            self.docker("kill", cid)
        elif kind == "freeze":
            if self.docker("pause", cid).returncode != 0:
                self.signal_all(cid, "STOP")
        elif kind == "disconnect":
            self.docker("network", "disconnect", self.farm.network(), cid)
        else:
            self.docker("restart", "-t", "2", cid)
            back = now
        self.faults[kind] += 1
        self.log.append({"t": now, "host": host, "kind": kind, "back": back})
        if kind != "restart":
            self.out[host] = (kind, back)

    def signal_all(self, cid, sig):
        top = self.docker("top", cid, "-eo", "pid").stdout.split()[1:]
        for pid in top:
            subprocess.run(["kill", f"-{sig}", pid], capture_output=True)

    def heal(self, now, everything=False):
        for host, (kind, back) in list(self.out.items()):
            if not everything and back > now:
                continue
            cid = self.cid(host)
            if kind == "kill":
                self.docker("start", cid)
            elif kind == "freeze":
                self.docker("unpause", cid)
                self.signal_all(cid, "CONT")
            elif kind == "disconnect":
                self.docker("network", "connect", "--alias", host, self.farm.network(), cid)
            del self.out[host]

    def wait_ended(self, job, limit=600):
        t0 = time.time()
        while time.time() - t0 < limit:
            r = self.sunray("ws1", job["user"], "jobs", "--json", check=False)
            try:
                rows = [x for x in json.loads(r.stdout or "[]") if x["job"] == job["id"]]
            except ValueError:
                rows = []
            if rows and rows[0]["state"] not in ("running", "recovering", "queued"):
                return rows[0]
            time.sleep(1)
        return {"job": job["id"], "state": "never ended"}


def run(farm, work, res, line_ms):
    seed = int(os.environ.get("CHAOS_SEED", "42"))
    min_faults = int(os.environ.get("CHAOS_FAULTS", "30"))
    state_limit = int(os.environ.get("CHAOS_STATE_MB", "64")) << 20
    c = Chaos(farm, work, seed, res, line_ms)
    farm.up(6, "ws1")
    try:
        return soak(c, farm, work, res, seed, min_faults, state_limit)
    finally:
        c.heal(time.time(), everything=True)
        farm.down()


def soak(c, farm, work, res, seed, min_faults, state_limit):
    c.keys()
    refs = {}
    for s in SCENES:
        farm.compose("exec", "-T", "ws1", "/bin/sunray", "render", "-q", "--resolution", res,
                     f"/scenes/{s}.nff", "-o", f"/out/chaos-ref-{s}.png", check=True,
                     capture_output=True)
        with open(os.path.join(work, f"chaos-ref-{s}.png"), "rb") as f:
            refs[s] = f.read()
    quiet = {}
    for i, s in enumerate(SCENES):
        job = {"id": f"chaos-quiet-{seed}-{i}", "user": USERS[i], "scene": s,
               "strategy": "dynamic"}
        t0 = time.time()
        c.submit(job, "ws1")
        r = c.wait_ended(job)
        quiet[s] = (r.get("updated_unix_ms") or 0) / 1000.0 - t0
    print(f"chaos: quiet farm, seconds a job: {quiet}", flush=True)
    jobs = [{"id": f"chaos-{seed}-{i}", "user": USERS[i % 3], "scene": SCENES[i % 3],
             "strategy": STRATEGIES[(i // 2) % 3],
             "at": i * 6.0 + c.rng.uniform(0, 3)} for i in range(JOBS)]
    start = time.time()
    next_fault = start + c.rng.uniform(0.5, 2.0)
    submitted = 0
    while submitted < JOBS or sum(c.faults.values()) < min_faults:
        now = time.time()
        if now - start > 900:
            raise SystemExit(f"chaos: the schedule overran: {c.faults}")
        c.heal(now)
        if submitted < JOBS and now - start >= jobs[submitted]["at"]:
            job = jobs[submitted]
            job["submitted_at"] = now
            c.submit(job, c.rng.choice(c.up()))
            submitted += 1
        if now >= next_fault:
            c.inject(now)
            next_fault = now + c.rng.uniform(1.0, 3.0)
        time.sleep(0.1)
    injected_s = time.time() - start
    c.heal(time.time(), everything=True)
    rows, lost = [], []
    for job in jobs:
        r = c.wait_ended(job)
        row = {"job": job["id"], "user": job["user"], "scene": job["scene"],
               "strategy": job["strategy"], "state": r["state"], "epoch": r.get("epoch", 1),
               # The record's last write is the job's end.
               "job_s": (r.get("updated_unix_ms") or 0) / 1000.0 - job["submitted_at"]}
        row["lost_s"] = row["job_s"] - quiet[job["scene"]]
        if r["state"] == "finished":
            c.sunray("ws1", job["user"], "fetch", job["id"], "-o", f"/out/{job['id']}.png")
            with open(os.path.join(c.work, f"{job['id']}.png"), "rb") as f:
                row["identical"] = f.read() == refs[job["scene"]]
            if not row["identical"]:
                lost.append(f"{job['id']}: the image differs from sunray render")
        else:
            lost.append(f"{job['id']}: {r['state']}")
        rows.append(row)
    end_t = time.time()
    left = {}
    while time.time() - end_t < 120:
        left = {h: n for h, n in farm.sunray_processes(c.hosts).items() if n}
        if not left:
            break
        time.sleep(2)
    # The image has no `du`: the state directory's size is that of its tar stream (a little
    # more than its bytes), through `docker cp`.
    sizes = {}
    for h in c.hosts:
        tar = subprocess.run(["docker", "cp", f"{c.cid(h)}:/var/lib/rem", "-"],
                             capture_output=True)
        sizes[h] = len(tar.stdout) if tar.returncode == 0 else -1
    answering = [h["name"] for h in farm.hosts("ws1") if h.get("alive")]
    table = {
        "seed": seed,
        "faults": c.faults,
        "faults_total": sum(c.faults.values()),
        "injected_s": injected_s,
        "controller_moves": sum(max(0, int(r["epoch"] or 1) - 1) for r in rows),
        "time_lost_s": sum(r["lost_s"] for r in rows),
        "quiet_s": quiet,
        "jobs": rows,
        "lost": lost,
        "sunray_left": left,
        "state_bytes": sizes,
        "state_limit": state_limit,
        "answering": answering,
        "log": c.log,
    }
    print(f"chaos: seed {seed}, {table['faults_total']} faults in {injected_s:.0f} s "
          f"({c.faults}); controller moves {table['controller_moves']}; lost {lost or 'nothing'}; "
          f"sunray processes left {left or 'none'}; state {sizes}; answering {answering}",
          flush=True)
    bad = (lost or left or any(v > state_limit or v < 0 for v in sizes.values())
           or len(answering) != 6)
    table["passed"] = not bad
    return table
