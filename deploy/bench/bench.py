#!/usr/bin/env python3
"""SunRay III benchmarks on the compose clusters (run through deploy/bench/run.sh).

scaling    1, 2, 4, 6, 8 workers of 0.25 CPU each (docker-compose.bench.yml), mount6:
           elapsed, speed-up and efficiency, total and render-only (thesis Table 4.9).
hetero     the six workstations of deploy/docker-compose.yml at half their CPU limits, two of
           them loaded by deploy/load.sh: per-node table and finish-time spread for SunRay I
           (blocks), II (interleaved) and III (dynamic) side by side (Table 4.8).
fault      8 workers, 2 killed once a quarter of the image is in: the extra time against the
           ideal for the remaining capacity (Table 4.7).
failover   a detached job (`submit --detach`) on the six workstations, its controller's
           container (ws1) killed once a quarter of the image is in: the time from the kill
           to ws1 being seen lost, and from then to the new controller's first Assign; the
           job's total time with and without the fault.
bigscene   tetra of 1,048,576 and 4,194,304 triangles (sizes 10 and 11; BENCH_BIG_SIZES) on
           the six workstations: `sunray render` on ws1 (the user's own workstation), then
           the scene submitted three times from ws1, each later submit once no `sunray`
           process runs on any host (the seconds waited are reported): time to the first finished
           line, total time, bytes the submitting host sent, per node the bytes fetched and
           whether the scene and the BVH were cached, the job's timeline; the later jobs
           find the model on every host (and ws1 finds it remembered: nothing compiled).
bigscene-long  the same at 1M triangles, 1024x1024 and 256 samples: long enough for every
           workstation to get the scene and render.
chaos      eight detached jobs of three users while containers are killed, frozen, cut off
           and restarted (deploy/bench/chaos.py): every job finished and byte-identical,
           nothing left running, and the table of faults, moves and time lost.
shares     three users' staggered jobs on the six workstations (deploy/bench/shares.py): each
           job's wait, run time and slots over time, and each user's slot-seconds against the
           fair share (`sunray bench shares` writes results/shares.md and shares.png).
upgrade    a rolling upgrade (deploy/bench/upgrade.py): while a long job runs, ws1..ws6 are
           replaced one at a time by containers of a newly built image announcing a newer
           protocol; the job finishes byte-identical, each old daemon says once per upgraded
           peer that it is newer, and none panics.

Raw outputs go to deploy/bench/work/ (ignored by git); the report and plots to
deploy/bench/results/. Every figure in the report is computed from the saved JSON.
"""

import json
import os
import shutil
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
DEPLOY = os.path.dirname(HERE)
WORK = os.path.join(HERE, "work")
RESULTS = os.path.join(HERE, "results")
RES = os.environ.get("BENCH_RES", "512x512")
SAMPLES = os.environ.get("BENCH_SAMPLES", "")
COUNTS = [int(n) for n in os.environ.get("BENCH_COUNTS", "1 2 4 6 8").split()]
WORKSTATIONS = [f"ws{i}" for i in range(1, 7)]


def compose_cmd():
    if shutil.which("docker-compose"):
        return ["docker-compose"]
    return ["docker", "compose"]


def env_for(project):
    e = dict(os.environ)
    e["SUNRAY_OUT"] = WORK
    e["REM_CREDENTIALS"] = os.path.join(WORK, "credentials")
    e["COMPOSE_PROJECT_NAME"] = project
    e.pop("COMPOSE_FILE", None)
    return e


class Farm:
    def __init__(self, project, file, extra_env=None):
        self.project, self.file = project, file
        self.env = env_for(project)
        self.env.update(extra_env or {})
        self.env["COMPOSE_FILE"] = file

    def compose_argv(self, *args):
        """The compose command line for `args` (which may name compose files of their own)."""
        return compose_cmd() + ["-p", self.project, *args]

    def compose(self, *args, **kw):
        return subprocess.run(compose_cmd() + ["-p", self.project, "-f", self.file, *args],
                              env=self.env, **kw)

    def up(self, hosts, via, remd=None):
        self.compose("down", "-v", "-t", "1", capture_output=True)
        self.compose("up", "-d", check=True, capture_output=True)
        end = time.time() + 90
        while time.time() < end:
            h = self.hosts(via, remd)
            if sum(1 for x in h if x.get("alive")) >= hosts:
                return h
            time.sleep(0.5)
        raise SystemExit(f"{self.project}: the cluster did not form")

    def down(self):
        self.compose("down", "-v", "-t", "1", capture_output=True)

    def hosts(self, via, remd=None):
        args = ["exec", "-T", via, "/bin/rem"] + (["--remd", remd] if remd else []) + ["hosts", "--json"]
        r = self.compose(*args, capture_output=True)
        try:
            return json.loads(r.stdout)
        except ValueError:
            return []

    def sunray_processes(self, hosts):
        """How many `sunray` processes (workers, keepers, controllers) run in each of `hosts`'
        containers, as `docker top` lists them."""
        counts = {}
        for host in hosts:
            cid = self.compose("ps", "-q", host, capture_output=True, text=True).stdout.strip()
            top = subprocess.run(["docker", "top", cid, "-eo", "pid,comm"], capture_output=True,
                                 text=True).stdout if cid else ""
            counts[host] = sum(1 for line in top.splitlines() if line.split()[-1:] == ["sunray"])
        return counts

    def wait_quiet(self, hosts, limit=300):
        """Waits (at most `limit` seconds) until no `sunray` process runs on any of `hosts`:
        the previous job's workers, and the keepers still preparing its scene for the next
        job, have ended. The seconds waited."""
        t0 = time.time()
        while time.time() - t0 < limit and any(self.sunray_processes(hosts).values()):
            time.sleep(1)
        return time.time() - t0

    def network(self):
        return f"{self.project}_farm"

    def exec_argv(self, via, argv):
        return compose_cmd() + ["-p", self.project, "-f", self.file, "exec", "-T", via] + argv


def render_flags():
    f = ["--resolution", RES]
    if SAMPLES:
        f += ["--samples", SAMPLES]
    return f


def submit(farm, via, name, hosts, extra=(), kill=None, scene="/scenes/mount6.nff",
           flags=None):
    """Runs one submit with --events; returns (wall seconds, stats, events, kill time)."""
    argv = ["/bin/sunray", "submit", "--hosts", str(hosts), *(flags or render_flags()),
            *extra, "--events", scene, "-o", f"/out/{name}.png",
            "--stats-json", f"/out/{name}.json"]
    t0 = time.time()
    p = subprocess.Popen(farm.exec_argv(via, argv), env=farm.env, stdout=subprocess.DEVNULL,
                         stderr=subprocess.PIPE, text=True)
    events, text, killed_at = [], [], None
    for line in p.stderr:
        try:
            ev = json.loads(line)
        except ValueError:
            text.append(line)
            continue
        if not isinstance(ev, dict) or "event" not in ev:
            text.append(line)
            continue
        ev["t"] = time.time() - t0
        events.append(ev)
        if kill and killed_at is None and ev["event"] == "line" and ev["done"] >= kill["after"]:
            killed_at = time.time() - t0
            for host in kill["hosts"]:
                cid = farm.compose("ps", "-q", host, capture_output=True, text=True).stdout.strip()
                subprocess.run(["docker", "kill", cid], capture_output=True)
    p.wait()
    wall = time.time() - t0
    with open(os.path.join(WORK, f"{name}.table.txt"), "w") as f:
        f.writelines(text)
    if p.returncode != 0:
        sys.stderr.writelines(text)
        raise SystemExit(f"{name}: submit failed ({p.returncode})")
    with open(os.path.join(WORK, f"{name}.json")) as f:
        stats = json.load(f)
    with open(os.path.join(WORK, f"{name}.events.json"), "w") as f:
        json.dump(events, f)
    print(f"{name}: {wall:.2f} s wall, {stats['elapsed_s']:.2f} s job", flush=True)
    first_line = min((e["t"] for e in events if e["event"] == "line"), default=None)
    return {"wall_s": wall, "stats": stats, "killed_at_s": killed_at,
            "first_line_s": first_line, "table": "".join(text)}


def bench_farm():
    return Farm("sunraybench8", os.path.join(HERE, "docker-compose.bench.yml"),
                {"SUNRAY_SCENES": os.environ["SUNRAY_SCENES"]})


def scaling():
    farm = bench_farm()
    farm.up(8, "ctl", "n1:7070")
    runs = {}
    try:
        for n in COUNTS:
            runs[n] = submit(farm, "ctl", f"scale-{n}", n)
    finally:
        farm.down()
    return runs


def fault():
    farm = bench_farm()
    farm.up(8, "ctl", "n1:7070")
    try:
        total = int(RES.split("x")[1])
        clean = submit(farm, "ctl", "fault-none", 8)
        hit = submit(farm, "ctl", "fault-kill2", 8,
                     kill={"after": total // 4, "hosts": ["n7", "n8"]})
    finally:
        farm.down()
    return {"clean": clean, "kill2": hit}


def detached(farm, name, kill_after=None):
    """A detached job from ws1 (its controller starts there), followed from ws2; with
    `kill_after`, ws1 is killed once that many lines are checkpointed. Returns times."""
    argv = ["/bin/sunray", "submit", "--detach", "--hosts", "6", *render_flags(),
            "--job", name, "--checkpoint-ms", "500", "/scenes/mount6.nff"]
    t0 = time.time()
    subprocess.run(farm.exec_argv("ws1", argv), env=farm.env, check=True, capture_output=True)
    out = {"name": name}
    if kill_after is not None:
        while True:
            r = farm.compose("exec", "-T", "ws2", "/bin/sunray", "jobs", "--json",
                             capture_output=True)
            rows = [x for x in json.loads(r.stdout or "[]") if x["job"] == name]
            if rows and rows[0]["lines_done"] >= kill_after:
                break
            time.sleep(0.2)
        farm.compose("kill", "ws1", capture_output=True)
        out["killed_at"] = time.time()
        while not any(h["name"] == "ws1" and not h.get("alive") for h in farm.hosts("ws2")):
            time.sleep(0.05)
        out["lost_at"] = time.time()
    subprocess.run(farm.exec_argv("ws2", ["/bin/sunray", "watch", name, "-q"]),
                   env=farm.env, check=True, capture_output=True)
    out["finished_at"] = time.time()
    out["total_s"] = out["finished_at"] - t0
    if kill_after is not None:
        ps = farm.compose("exec", "-T", "ws2", "/bin/rem", "ps", "--json",
                          capture_output=True)
        ctl = [p for p in json.loads(ps.stdout) if p["job"] == f"{name}.c2"]
        if not ctl:
            raise SystemExit(f"{name}: no second controller ran: the job was over before the "
                             "kill (a longer job: BENCH_SAMPLES=64)")
        logs = farm.compose("exec", "-T", "ws2", "/bin/rem", "logs", ctl[0]["proc_id"],
                            capture_output=True, text=True)
        assigns = []
        adopted = 0
        for line in (logs.stdout + logs.stderr).splitlines():
            try:
                ev = json.loads(line)
            except ValueError:
                continue
            if isinstance(ev, dict) and ev.get("event") == "assign":
                assigns.append(ev["unix_ms"] / 1000.0)
            if isinstance(ev, dict) and ev.get("event") == "spawned" and ev.get("adopted"):
                adopted += 1
        out["workers_taken_over"] = adopted
        out["controller_started_at"] = ctl[0]["started_unix_ms"] / 1000.0
        out["first_assign_at"] = min(assigns)
        out["detect_s"] = out["lost_at"] - out["killed_at"]
        out["takeover_s"] = out["first_assign_at"] - out["lost_at"]
        out["kill_to_assign_s"] = out["first_assign_at"] - out["killed_at"]
    print(f"{name}: " + ", ".join(f"{k} {v:.2f}" for k, v in out.items()
                                   if k.endswith("_s")), flush=True)
    if "workers_taken_over" in out:
        print(f"{name}: the new controller took over {out['workers_taken_over']} workers",
              flush=True)
    return out


def failover():
    farm = Farm("sunraybench6", os.path.join(DEPLOY, "docker-compose.yml"),
                {"SUNRAY_SCENES": os.environ["SUNRAY_SCENES"]})
    total = int(RES.split("x")[1])
    runs = {"settings": {"resolution": RES, "samples": SAMPLES or "default"}}
    try:
        farm.up(6, "ws1")
        runs["clean"] = detached(farm, "failover-clean")
        runs["kill"] = detached(farm, "failover-kill", kill_after=total // 4)
    finally:
        farm.down()
    c, k = runs["clean"], runs["kill"]
    print(f"failover: ws1 seen lost {k['detect_s']:.2f} s after the kill; the new controller's "
          f"first Assign {k['takeover_s']:.2f} s after that ({k['kill_to_assign_s']:.2f} s "
          f"after the kill); job {c['total_s']:.1f} s clean, {k['total_s']:.1f} s with the "
          f"fault; {k.get('workers_taken_over', 0)} workers taken over", flush=True)
    return runs


def bigscene_long():
    """bigscene at 1M triangles with a render long enough (1024x1024, 256 samples) that every
    workstation, the slowest too, gets the scene and renders."""
    return bigscene(sizes=[10], flags=["--resolution", "1024x1024", "--samples", "256"])


def bigscene(sizes=None, flags=None):
    sizes = sizes or [int(n) for n in os.environ.get("BENCH_BIG_SIZES", "10 11").split()]
    scenes = os.environ["SUNRAY_SCENES"]
    sunray = os.path.join(os.environ.get("CARGO_TARGET_DIR", "target"), "release", "sunray")
    for size in sizes:
        path = os.path.join(scenes, f"tetra{size}.nff")
        if not os.path.exists(path):
            subprocess.run([sunray, "spd", "tetra", "--size", str(size), "-o", path], check=True)
    farm = Farm("sunraybench6", os.path.join(DEPLOY, "docker-compose.yml"),
                {"SUNRAY_SCENES": scenes})
    flags = flags or ["--resolution", os.environ.get("BENCH_BIG_RES", "256x256")]
    runs = {"settings": {"resolution": flags[1], "flags": " ".join(flags), "sizes": sizes}}
    try:
        farm.up(6, "ws1")
        for size in sizes:
            # The user's own workstation: `sunray render` on ws1, in the same run.
            runs[f"{size}-local"] = local_render(farm, "ws1", f"big{size}-local",
                                                 f"/scenes/tetra{size}.nff", flags)
            for run in ["first", "second", "third"]:
                # A later job starts once the farm is quiet: the hosts that were still
                # fetching or building the scene when the job before ended have kept it.
                quiet_s = farm.wait_quiet(WORKSTATIONS) if run != "first" else 0.0
                r = submit(farm, "ws1", f"big{size}-{run}", 6, scene=f"/scenes/tetra{size}.nff",
                           flags=flags)
                st = r["stats"]
                r["summary"] = {
                    "waited_for_quiet_s": quiet_s,
                    "triangles": st["totals"]["primitives"],
                    "first_line_s": r["first_line_s"],
                    "total_s": r["wall_s"],
                    "scene_bytes_sent": st["scene_bytes_sent"],
                    "timeline": st.get("timeline", {}),
                    "nodes": [{k: n[k] for k in ["host", "scene_bytes_received", "scene_cached",
                                                 "scene_fetch_s", "accel_cached", "preprocess_s"]}
                              for n in st["nodes"]],
                }
                print(f"big{size}-{run}: {json.dumps(r['summary'])}", flush=True)
                runs[f"{size}-{run}"] = r
    finally:
        farm.down()
    return runs


def local_render(farm, via, name, scene, flags):
    """`sunray render` of `scene` on host `via`: its wall time, and its statistics."""
    argv = ["/bin/sunray", "render", "-q", *flags, scene, "-o", f"/out/{name}.png",
            "--stats-json", f"/out/{name}.json"]
    t0 = time.time()
    subprocess.run(farm.exec_argv(via, argv), env=farm.env, check=True, capture_output=True)
    wall = time.time() - t0
    with open(os.path.join(WORK, f"{name}.json")) as f:
        stats = json.load(f)
    print(f"{name}: {wall:.2f} s wall (sunray render on {via})", flush=True)
    return {"wall_s": wall, "stats": stats}


def chaos_soak():
    import chaos
    scenes = os.environ["SUNRAY_SCENES"]
    sunray = os.path.join(os.environ.get("CARGO_TARGET_DIR", "target"), "release", "sunray")
    for db, name in [("tetra", "tetra6"), ("balls", "balls4")]:
        path = os.path.join(scenes, f"{name}.nff")
        if not os.path.exists(path):
            subprocess.run([sunray, "spd", db, "-o", path], check=True)
    farm = Farm("sunraybench6", os.path.join(DEPLOY, "docker-compose.yml"),
                {"SUNRAY_SCENES": scenes})
    res = os.environ.get("CHAOS_RES", "96x128")
    table = chaos.run(farm, WORK, res, os.environ.get("CHAOS_LINE_MS", "100"))
    table["resolution"] = res
    return table


def rolling_upgrade():
    import upgrade
    if not os.environ.get("UPGRADE_TO"):
        # A newly built image of the same binaries (a new image id: its build time is a
        # label), to upgrade to.
        subprocess.run([os.path.join(DEPLOY, "build-image.sh")], check=True,
                       env=dict(os.environ, SUNRAY_IMAGE="sunray-rem:next", SKIP_CARGO="1"))
    farm = Farm("sunraybench6", os.path.join(DEPLOY, "docker-compose.yml"),
                {"SUNRAY_SCENES": os.environ["SUNRAY_SCENES"]})
    res = os.environ.get("UPGRADE_RES", "128x192")
    table = upgrade.run(farm, WORK, res, os.environ.get("UPGRADE_LINE_MS", "400"))
    table["resolution"] = res
    return table


def shares():
    import shares as scenario
    farm = Farm("sunraybench6", os.path.join(DEPLOY, "docker-compose.yml"),
                {"SUNRAY_SCENES": os.environ["SUNRAY_SCENES"]})
    res = os.environ.get("SHARES_RES", "96x128")
    table = scenario.run(farm, WORK, res, os.environ.get("SHARES_LINE_MS", "150"),
                         float(os.environ.get("SHARES_POLL", "0.5")))
    # The timeline is kept with the report: its figures are computed from it.
    timeline = os.path.join(RESULTS, "shares.json")
    with open(timeline, "w") as f:
        json.dump(table, f)
    sunray = os.path.join(os.environ.get("CARGO_TARGET_DIR", "target"), "release", "sunray")
    subprocess.run([sunray, "bench", "shares", "--input", timeline, "--out-dir", RESULTS],
                   check=True)
    return {"passed": table["passed"], "differ": table["differ"], "resolution": res}


def hetero():
    scale = {"WS_CPUS_FAST": "0.5", "WS_CPUS_MEDIUM": "0.25", "WS_CPUS_SLOW": "0.125",
             "SUNRAY_SCENES": os.environ["SUNRAY_SCENES"]}
    farm = Farm("sunraybench6", os.path.join(DEPLOY, "docker-compose.yml"), scale)
    farm.up(6, "ws1")
    loaded = ["ws2", "ws5"]
    load_env = dict(farm.env)
    subprocess.run(["bash", os.path.join(DEPLOY, "load.sh"), "start", "--seconds", "1800",
                    *loaded], env=load_env, check=True, capture_output=True)
    runs = {}
    try:
        # Let the loaded hosts' figures show the load before placing.
        end = time.time() + 30
        while time.time() < end:
            h = {x["name"]: x for x in farm.hosts("ws1")}
            if all(h.get(n, {}).get("load_per_core", 0) > 0.6 for n in loaded):
                break
            time.sleep(0.5)
        runs["hosts"] = farm.hosts("ws1")
        for strategy in ["blocks", "interleaved", "dynamic"]:
            runs[strategy] = submit(farm, "ws1", f"hetero-{strategy}", 6,
                                    ["--strategy", strategy])
    finally:
        farm.down()
    return runs


def main():
    os.makedirs(WORK, exist_ok=True)
    os.makedirs(RESULTS, exist_ok=True)
    which = sys.argv[1:] or ["scaling", "hetero", "fault", "failover"]
    data = {}
    path = os.path.join(WORK, "bench.json")
    # The other benchmarks' results are kept: from the last run here, else from the report.
    for seed in [path, os.path.join(RESULTS, "bench.json")]:
        if os.path.exists(seed):
            with open(seed) as f:
                data = json.load(f)
            break
    if any(not name.startswith("bigscene") and name not in ("chaos", "upgrade", "shares")
           for name in which):
        # The mount6 runs' settings (bigscene keeps its own).
        data["settings"] = {"resolution": RES, "samples": SAMPLES or "default"}
        data["machine"] = (f"{os.cpu_count()} cores, load average "
                           f"{os.getloadavg()[0]:.1f} when the run started")
    for name in which:
        data[name] = {"scaling": scaling, "hetero": hetero, "fault": fault,
                      "failover": failover, "bigscene": bigscene,
                      "bigscene-long": bigscene_long, "chaos": chaos_soak,
                      "upgrade": rolling_upgrade, "shares": shares}[name]()
        with open(path, "w") as f:
            json.dump(data, f, indent=1, default=str)
        if name in ("chaos", "upgrade", "shares") and not data[name]["passed"]:
            raise SystemExit(f"{name}: something was lost or left (see the table above)")
    print(f"raw results in {path}")


if __name__ == "__main__":
    main()
