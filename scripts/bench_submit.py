#!/usr/bin/env python3
"""SunRay III benchmarks (docs/sunray-iii.md, "Figures"). Needs release binaries:

    cargo build --release -p sunray -p rem --bins
    python3 scripts/bench_submit.py [--bin target/release] [--size 512] [--only overhead,workers,strategies,timeline]

1. overhead:   controller CPU and messages per scanline and the workers' share of render
               time spent waiting for work (and, apart, at the tail for duplicates of
               stragglers): mount6 SIZExSIZE, 1 and 4 samples, two remd daemons on loopback.
2. workers:    1 vs 2 local workers (embedded default, one render thread each, and all
               cores), elapsed and speed-up, next to `sunray render`.
3. strategies: SunRay I, II and III side by side on mount6 with three workers, one thread
               each, workers 1 and 2 pinned to CPU 0 and worker 3 pinned to CPU 1 at nice 10
               behind a CPU hog; the finish-time spread of the nodes per strategy.
4. timeline:   the fixed cost of a job on a warm farm: mount6 64x64 (or --timeline-scene at
               --timeline-size) on three remd daemons on loopback, submitted --runs times
               (the first warms the hosts' caches, and its timeline is printed too); the
               median of each step of the job's timeline (seconds since submit) and of the
               submit's wall time, next to `sunray render` of the same image.
"""

import argparse
import json
import os
import signal
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
# Haines's mount6.nff, written by `sunray spd mount` (byte for byte his file) in main().
MOUNT6 = None


def remds(bin_dir, tmp, names):
    secret = os.path.join(tmp, "secret")
    with open(os.open(secret, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600), "w") as f:
        f.write("bench-secret\n")
    procs, addrs = [], []
    for n in names:
        cmd = [os.path.join(bin_dir, "remd"), "--name", n, "--listen", "127.0.0.1:0",
               "--allow", os.path.join(bin_dir, "sunray") + ":worker|controller", "--secret-file", secret,
               "--state-dir", os.path.join(tmp, "state-" + n)]
        if addrs:
            cmd += ["--join", addrs[0]]
        p = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
        line = p.stdout.readline().strip()
        addrs.append(line.removeprefix("remd listening on "))
        procs.append(p)
    time.sleep(1.5)  # let the daemons see each other (membership)
    return procs, addrs, secret


def stop(procs):
    for p in procs:
        p.kill()
        p.wait()


def submit(bin_dir, tmp, args, env=None, on_event=None):
    out = os.path.join(tmp, "out.png")
    stats = os.path.join(tmp, "stats.json")
    cmd = [os.path.join(bin_dir, "sunray"), "submit", "-q", "--events", "-o", out,
           "--stats-json", stats] + args
    e = dict(os.environ)
    e.pop("REM_ADDR", None)
    e.update(env or {})
    t0 = time.time()
    p = subprocess.Popen(cmd, stderr=subprocess.PIPE, text=True, env=e)
    for line in p.stderr:
        if on_event and line.startswith("{"):
            on_event(json.loads(line))
    p.wait()
    wall = time.time() - t0
    if p.returncode != 0:
        sys.exit(f"submit failed: {cmd}")
    with open(stats) as f:
        return json.load(f), wall


def render(bin_dir, tmp, size, threads=None, scene=None):
    cmd = [os.path.join(bin_dir, "sunray"), "render", "-q", scene or MOUNT6, "--resolution",
           f"{size}x{size}", "-o", os.path.join(tmp, "ref.png")]
    if threads:
        cmd += ["--threads", str(threads)]
    t0 = time.time()
    subprocess.run(cmd, check=True)
    return time.time() - t0


def overhead(bin_dir, size, samples):
    with tempfile.TemporaryDirectory() as tmp:
        procs, addrs, secret = remds(bin_dir, tmp, ["a", "b"])
        try:
            s, wall = submit(bin_dir, tmp, ["--remd", addrs[0], "--secret-file", secret,
                                            "--hosts", "2", "--resolution", f"{size}x{size}",
                                            "--samples", str(samples), MOUNT6])
        finally:
            stop(procs)
        c = s["controller"]
        print(f"overhead: mount6 {size}x{size} x{samples}, 2 workers on 2 remd daemons: elapsed "
              f"{s['elapsed_s']:.2f} s; controller {c['cpu_ms_per_line']:.3f} ms CPU and "
              f"{c['messages_per_line']:.2f} messages per line ({c['messages_in']} in, "
              f"{c['messages_out']} out); workers waited {100 * s['wait_share']:.3f}% "
              f"of their render-thread time (and {100 * s.get('tail_wait_share', 0):.3f}% at the "
              f"tail for copies of stragglers)")
        for n in s["nodes"]:
            print(f"  node {n['node']} {n['host']}: {n['scanlines']} lines, threads "
                  f"{n['threads']}, render {n['render_s']:.2f} s, waited {n['wait_s']:.3f} s "
                  f"(and {n['first_wait_s']:.3f} s for the first lines, "
                  f"{n.get('tail_wait_s', 0):.3f} s at the tail)")


def workers(bin_dir, size):
    with tempfile.TemporaryDirectory() as tmp:
        env = {"SUNRAY_STATE_DIR": os.path.join(tmp, "state")}
        res = f"{size}x{size}"
        r1 = render(bin_dir, tmp, size, threads=1)
        rall = render(bin_dir, tmp, size)
        print(f"workers: mount6 {res}; sunray render: 1 thread {r1:.2f} s, all cores {rall:.2f} s")
        for threads in (["--threads", "1"], []):
            times = {}
            for hosts in (1, 2):
                s, wall = submit(bin_dir, tmp, ["--hosts", str(hosts), "--resolution", res]
                                 + threads + [MOUNT6], env=env)
                times[hosts] = (s["elapsed_s"], wall)
            label = "1 thread per worker" if threads else "cores shared among workers"
            print(f"  {label}: 1 worker {times[1][0]:.2f} s (process {times[1][1]:.2f} s), "
                  f"2 workers {times[2][0]:.2f} s (process {times[2][1]:.2f} s), speed-up "
                  f"{times[1][0] / times[2][0]:.2f}")


def strategies(bin_dir, size, samples):
    cpus = os.cpu_count() or 1
    with tempfile.TemporaryDirectory() as tmp:
        procs, addrs, secret = remds(bin_dir, tmp, ["a", "b", "c"])
        hog = None
        try:
            for strategy in ("blocks", "interleaved", "dynamic"):
                hog = subprocess.Popen(["taskset", "-c", str(cpus - 1), "sh", "-c",
                                        "while :; do :; done"])

                def on_event(ev):
                    if ev.get("event") != "spawned":
                        return
                    pid = str(ev["pid"])
                    if ev["node"] == 3:
                        subprocess.run(["taskset", "-a", "-p", "-c", str(cpus - 1), pid],
                                       stdout=subprocess.DEVNULL)
                        subprocess.run(["renice", "-n", "10", "-g", pid],
                                       stdout=subprocess.DEVNULL)
                    else:
                        subprocess.run(["taskset", "-a", "-p", "-c", "0", pid],
                                       stdout=subprocess.DEVNULL)

                s, wall = submit(bin_dir, tmp, ["--remd", addrs[0], "--secret-file", secret,
                                                "--hosts", "3", "--threads", "1",
                                                "--strategy", strategy, "--resolution",
                                                f"{size}x{size}", "--samples", str(samples),
                                                MOUNT6],
                                 on_event=on_event)
                hog.kill()
                hog.wait()
                hog = None
                ends = [n["finished_at_s"] for n in s["nodes"]]
                lines = [n["scanlines"] for n in s["nodes"]]
                print(f"strategies: {strategy:<11} elapsed {s['elapsed_s']:6.2f} s; node finish "
                      f"times {', '.join(f'{e:.2f}' for e in ends)} s (spread "
                      f"{max(ends) - min(ends):.2f} s); lines {lines}; duplicated "
                      f"{s['lines']['duplicated']}")
        finally:
            if hog:
                hog.kill()
            stop(procs)


def timeline(bin_dir, runs, scene=None, size=64):
    scene = scene or MOUNT6
    steps = ["model_ready", "model_stored", "controller_started", "first_line", "last_line",
             "image_stored", "finished", "image_written"]
    with tempfile.TemporaryDirectory() as tmp:
        procs, addrs, secret = remds(bin_dir, tmp, ["a", "b", "c"])
        got, walls = {k: [] for k in steps}, []
        try:
            for i in range(runs + 1):
                s, wall = submit(bin_dir, tmp, ["--remd", addrs[0], "--secret-file", secret,
                                                "--hosts", "3", "--resolution", f"{size}x{size}",
                                                "--job", f"fixed{i}", scene])
                if i == 0:
                    print(f"  first job (caches cold): wall {wall:.3f} s; timeline {s['timeline']}")
                    continue
                walls.append(wall)
                for k in steps:
                    if s["timeline"].get(k) is not None:
                        got[k].append(s["timeline"][k])
                nodes = "; ".join(
                    f"{n['host']} " + " ".join(f"{k} {v:.3f}" for k, v in n["timeline"].items()
                                                 if v is not None) for n in s["nodes"])
                print(f"  run {i}: wall {wall:.3f} s; nodes: {nodes}")
        finally:
            stop(procs)
        local = sorted(render(bin_dir, tmp, size, scene=scene) for _ in range(runs))
    med = lambda xs: sorted(xs)[len(xs) // 2] if xs else float("nan")
    name = os.path.basename(scene)
    print(f"timeline: {name} {size}x{size}, 3 workers on 3 loopback remd daemons, median of {runs} warm "
          "jobs, seconds since submit: " +
          ", ".join(f"{k} {med(v):.3f}" for k, v in got.items() if v) +
          f"; submit wall {med(walls):.3f} s against `sunray render` {med(local):.3f} s")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--bin", default=os.path.join(ROOT, "target", "release"))
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--strategy-size", type=int, default=512)
    ap.add_argument("--strategy-samples", type=int, default=4)
    ap.add_argument("--only", default="overhead,workers,strategies")
    ap.add_argument("--runs", type=int, default=5, help="warm jobs for the timeline")
    ap.add_argument("--timeline-scene", help="the timeline's scene [default: mount6]")
    ap.add_argument("--timeline-size", type=int, default=64)
    a = ap.parse_args()
    global MOUNT6
    scenes = tempfile.mkdtemp(prefix="bench-submit-scenes-")
    MOUNT6 = os.path.join(scenes, "mount6.nff")
    subprocess.run([os.path.join(a.bin, "sunray"), "spd", "mount", "-o", MOUNT6], check=True)
    print(f"load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores")
    only = a.only.split(",")
    if "overhead" in only:
        for samples in (1, 4):
            overhead(a.bin, a.size, samples)
    if "workers" in only:
        workers(a.bin, a.size)
    if "strategies" in only:
        print(f"strategies: mount6 {a.strategy_size}x{a.strategy_size} x{a.strategy_samples}, "
              "3 workers of 1 thread, worker 3 at nice 10 behind a CPU hog")
        strategies(a.bin, a.strategy_size, a.strategy_samples)
    if "timeline" in only:
        timeline(a.bin, a.runs, a.timeline_scene, a.timeline_size)


if __name__ == "__main__":
    signal.signal(signal.SIGINT, signal.SIG_DFL)
    main()
