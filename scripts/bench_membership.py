#!/usr/bin/env python3
"""REM membership benchmark: what an idle cluster costs, and how fast a dead daemon is noticed.

Starts clusters of `remd` daemons on loopback (a0 first, the others joining through a0) and
prints:

1. idle:   CPU time (utime+stime, /proc/PID/stat) of every daemon of a converged, idle cluster of
           N daemons for each N in --sizes, over --idle-s seconds (after 3 s of settling), in ms
           per second per daemon: median, max and mean over the daemons; then how old the load
           reports the first and the last daemon hold are (`rem hosts --json`, last_heard_ms).
2. detect: N = the largest size. --kills times: `kill -9` a daemon (never a0, a different one each
           run), then poll `rem hosts --json` on a0 and on the last other daemon every 20 ms until
           each lists the victim not alive. A time is taken when the answer arrives, so it includes
           the poll period and one or two `rem` calls (~10-30 ms). Any other host a0 lists not alive
           meanwhile is a false alarm. The victim then rejoins under its name (as many as 30 s).
3. hog:    N = the largest size. cpu_count() busy loops at nice 0 and as many at nice 10 for
           --hog-s seconds; every 0.5 s a0, the middle and the last daemon are asked for the hosts:
           each (observer, host) with the host not alive (or not listed) is a false alarm.

With --old-remd/--old-rem every measurement runs for the old build then the new one, alternately
(idle size by size), printing new/old; a markdown table sums up at the end. The binaries are
copied to a temp dir first, so a rebuild meanwhile can't mix builds. Linux only (/proc). Anything
else busy on the machine shows in the figures: keep it quiet. Usage (from the workspace root):

    python3 scripts/bench_membership.py --remd target/release/remd --rem target/release/rem \\
        [--old-remd /tmp/remd-old --old-rem /tmp/rem-old] [--sizes 10,40] [--idle-s 20] \\
        [--kills 5] [--hog-s 60] [--only idle|detect|hog]
"""

import argparse, collections, json, os, random, secrets, select, shutil, signal  # noqa: E401 (standard library only)
import statistics, subprocess, sys, tempfile, threading, time  # noqa: E401

PREFIX = "remd listening on "
CLK = os.sysconf("SC_CLK_TCK")
STARTED = []  # every process started (daemons, hogs): killed at exit, whatever happens
TMPS = []  # every temp dir made: removed at exit
ENV = {k: v for k, v in os.environ.items() if k not in ("REM_SECRET", "REM_SECRET_FILE")}
ENV["RUST_LOG"] = "warn"


class Fail(Exception):
    pass


def tail(path, n=20):
    try:
        with open(path, errors="replace") as f:
            return "".join(f.readlines()[-n:])
    except OSError as e:
        return f"({e})\n"


def cpu_ticks(pid):
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()  # fields[0] is field 3 (the state)
    return int(fields[11]) + int(fields[12])  # fields 14 and 15: utime, stime


class Cluster:
    """N daemons a0..a(N-1), converged when this returns; stop() kills them and removes the dir."""

    def __init__(self, build, n):
        self.remd, self.rem = build
        self.tmp = tempfile.mkdtemp(prefix="bench-membership-")
        TMPS.append(self.tmp)
        self.secret = os.path.join(self.tmp, "secret")
        with os.fdopen(os.open(self.secret, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600), "w") as f:
            f.write(secrets.token_hex(32) + "\n")
        self.names = [f"a{i}" for i in range(n)]
        self.procs, self.addrs = {}, {}
        try:
            for name in self.names:
                self.start(name)
            self.converge(max(30.0, 1.5 * n))
        except BaseException:
            self.stop()
            raise

    def start(self, name):
        log = os.path.join(self.tmp, name + ".log")
        cmd = [self.remd, "--name", name, "--listen", "127.0.0.1:0", "--secret-file", self.secret,
               "--state-dir", os.path.join(self.tmp, "state-" + name)]
        if name != self.names[0]:
            cmd += ["--join", self.addrs[self.names[0]]]
        with open(log, "ab") as err:
            p = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=err, env=ENV, text=True)
        STARTED.append(p)
        line = p.stdout.readline().strip() if select.select([p.stdout], [], [], 10)[0] else ""
        if not line.startswith(PREFIX):
            p.kill()
            raise Fail(f"remd {name} did not start (first line {line!r}, exit {p.wait()}); "
                       f"{log} ends:\n{tail(log)}")
        threading.Thread(target=collections.deque, args=(p.stdout, 0), daemon=True).start()  # never full
        self.procs[name], self.addrs[name] = p, line[len(PREFIX):]

    def hosts(self, name):
        """{host: alive} as daemon `name` lists them; None when rem fails or takes over 5 s."""
        cmd = [self.rem, "--remd", self.addrs[name], "--secret-file", self.secret, "hosts", "--json"]
        try:
            r = subprocess.run(cmd, capture_output=True, text=True, timeout=5, env=ENV)
            return {h["name"]: h.get("alive") is True for h in json.loads(r.stdout)} if r.returncode == 0 else None
        except (subprocess.TimeoutExpired, ValueError, KeyError, TypeError):
            return None

    def report_ages(self, name):
        """How old (ms) the load reports daemon `name` holds of the others are (LAST HEARD)."""
        cmd = [self.rem, "--remd", self.addrs[name], "--secret-file", self.secret, "hosts", "--json"]
        r = subprocess.run(cmd, capture_output=True, text=True, timeout=5, env=ENV)
        hosts = json.loads(r.stdout) if r.returncode == 0 else []
        return [h["last_heard_ms"] for h in hosts if h["name"] != name and h.get("last_heard_ms") is not None]

    def lost(self, view):
        return [h for h in self.names if not view.get(h, False)]

    def check_running(self):
        for name, p in self.procs.items():
            if p.poll() is not None:
                raise Fail(f"remd {name} exited ({p.returncode}); its log ends:\n"
                           f"{tail(os.path.join(self.tmp, name + '.log'))}")

    def converge(self, timeout, observers=("a0",)):
        """Until each observer lists exactly the N hosts, all alive."""
        deadline, todo, view = time.monotonic() + timeout, list(observers), None
        while todo and time.monotonic() < deadline:
            view = self.hosts(todo[0])
            if view is not None and len(view) == len(self.names) and not self.lost(view):
                todo.pop(0)
                continue
            self.check_running()
            time.sleep(0.1)
        if todo:
            raise Fail(f"{len(self.names)} daemons not converged in {timeout:.0f} s; {todo[0]} lists {view}")

    def stop(self):
        for p in self.procs.values():
            if p.poll() is None:
                p.kill()
            p.wait()
        shutil.rmtree(self.tmp, ignore_errors=True)


def idle(build, n, secs):
    c = Cluster(build, n)
    try:
        time.sleep(3)
        pids = [p.pid for p in c.procs.values()]
        t0, before = time.monotonic(), [cpu_ticks(pid) for pid in pids]
        time.sleep(secs)
        after, dt = [cpu_ticks(pid) for pid in pids], time.monotonic() - t0
        c.check_running()
        ages = c.report_ages(c.names[0]) + c.report_ages(c.names[-1])
    finally:
        c.stop()
    rates = [(b - a) * 1000.0 / CLK / dt for a, b in zip(before, after)]
    return statistics.median(rates), max(rates), statistics.mean(rates), ages


def detect(build, n, kills):
    c = Cluster(build, n)
    a0, runs, alarms = c.names[0], [], {}
    try:
        victims = random.Random(n).sample(c.names[1:], min(kills, n - 1))  # same ones for both builds
        for k, victim in enumerate(victims, 1):
            other = c.names[-1] if victim != c.names[-1] else c.names[-2]
            seen = {a0: None, other: None}
            c.converge(30, list(seen))  # the second observer too knows them all alive first
            t0 = time.monotonic()
            c.procs[victim].kill()
            c.procs[victim].wait()
            while None in seen.values() and time.monotonic() - t0 < 30:
                for obs in seen:
                    view = c.hosts(obs)
                    now = time.monotonic() - t0
                    if view is None:
                        continue
                    if seen[obs] is None and not view.get(victim, False):
                        seen[obs] = now
                    for h in (c.lost(view) if obs == a0 else []):
                        if h != victim:
                            alarms[h] = alarms.get(h, 0) + 1
                time.sleep(0.02)
            both = max(seen.values()) if None not in seen.values() else None
            runs.append((seen[a0], both))
            show = lambda t: "not seen in 30 s" if t is None else f"{t:.3f} s"
            print(f"  run {k}: kill -9 {victim}: a0 {show(seen[a0])}, {other} {show(seen[other])}, "
                  f"both {show(both)}; false alarms so far {sum(alarms.values())}")
            if k < len(victims):
                c.start(victim)  # rejoins through a0; the next run waits for it to be seen alive
    finally:
        c.stop()
    med = lambda xs: statistics.median(xs) if xs else None
    return (med([a for a, _ in runs if a is not None]), med([b for _, b in runs if b is not None]),
            sum(a is None for a, _ in runs), alarms)


def hog(build, n, secs):
    c = Cluster(build, n)
    hogs, loop = [], [sys.executable, "-c", "while True: pass"]
    polls, failed, alarms = 0, 0, {}
    try:
        observers = [c.names[0], c.names[len(c.names) // 2], c.names[-1]]
        c.converge(30, observers)  # the three observers know them all alive before the hogs start
        for _ in range(os.cpu_count() or 1):
            for cmd in (loop, ["nice", "-n", "10"] + loop):
                hogs.append(subprocess.Popen(cmd))
                STARTED.append(hogs[-1])
        t0, tick = time.monotonic(), 0
        while tick * 0.5 < secs:
            time.sleep(max(0.0, t0 + tick * 0.5 - time.monotonic()))
            for obs in observers:
                view = c.hosts(obs)
                polls += 1
                if view is None:
                    failed += 1
                    continue
                for h in c.lost(view):
                    alarms[(obs, h)] = alarms.get((obs, h), 0) + 1
            tick = max(tick + 1, int((time.monotonic() - t0) / 0.5) + 1)  # late: skip the ticks missed
        c.check_running()
    finally:
        for p in hogs:
            p.kill()
            p.wait()
        c.stop()
    return polls, failed, alarms


def main():
    ap = argparse.ArgumentParser(description="REM membership cost and failure detection (see the docstring)")
    for flag in ("--remd", "--rem", "--old-remd", "--old-rem"):
        ap.add_argument(flag, required=not flag.startswith("--old"))
    ap.add_argument("--sizes", default="10,40", type=lambda v: [int(x) for x in v.split(",")])
    ap.add_argument("--idle-s", type=float, default=20)
    ap.add_argument("--kills", type=int, default=5)
    ap.add_argument("--hog-s", type=float, default=60)
    ap.add_argument("--only", help="idle, detect or hog (or several, comma-separated)")
    args = ap.parse_args()
    if (args.old_remd is None) != (args.old_rem is None):
        ap.error("--old-remd and --old-rem go together")
    sizes, only = args.sizes, set(args.only.split(",")) if args.only else {"idle", "detect", "hog"}
    if min(sizes) < 2 or args.kills < 1 or not only <= {"idle", "detect", "hog"}:
        ap.error("sizes must be >= 2, --kills >= 1, --only among idle, detect, hog")
    given = [("old", args.old_remd, args.old_rem)] if args.old_remd else []
    given.append(("new", args.remd, args.rem))
    for p in [p for _, *paths in given for p in paths if not (os.path.isfile(p) and os.access(p, os.X_OK))]:
        ap.error(f"{p}: not an executable file")
    labels, n, cores = [label for label, *_ in given], max(sizes), os.cpu_count() or 1
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(143))
    sys.stdout.reconfigure(line_buffering=True)
    rows, results = [], {}  # rows: [(title, format)]; results: {(title, label): value}

    def record(title, fmt, label, value):
        if (title, fmt) not in rows:
            rows.append((title, fmt))
        results[(title, label)] = value
        old = results.get((title, "old"))
        if label == "new" and old and value is not None:  # the new build runs right after the old one
            print(f"  new/old {title}: {value / old:.2f}")

    try:
        bins = tempfile.mkdtemp(prefix="bench-membership-bin-")
        TMPS.append(bins)
        builds = {}
        for label, remd, rem in given:
            builds[label] = tuple(shutil.copy2(p, os.path.join(bins, f"{label}-{os.path.basename(p)}"))
                                  for p in (remd, rem))
            stamp = time.strftime("%Y-%m-%d %H:%M:%S", time.localtime(os.path.getmtime(remd)))
            print(f"{label}: {remd} (modified {stamp}), {rem}")
        print(f"{cores} cores, {CLK} clock ticks/s")
        if "idle" in only:
            for size in sizes:
                for label in labels:
                    med, mx, mean, ages = idle(builds[label], size, args.idle_s)
                    print(f"idle [{label}] {size} daemons, {args.idle_s:g} s: CPU per daemon median {med:.2f} "
                          f"ms/s, max {mx:.2f}, mean {mean:.2f} (1 tick = {1000 / CLK / args.idle_s:.2f})")
                    if ages:
                        print(f"  load reports held by the first and last daemon: {len(ages)}, age median "
                              f"{statistics.median(ages):.0f} ms, max {max(ages)} ms")
                        record(f"load report age at the end, {size} daemons (ms, median)", "{:.0f}", label,
                               statistics.median(ages))
                    record(f"idle CPU per daemon, {size} daemons (ms/s, median)", "{:.2f}", label, med)
                    record(f"idle CPU per daemon, {size} daemons (ms/s, max)", "{:.2f}", label, mx)
        if "detect" in only:
            k = min(args.kills, n - 1)
            for label in labels:
                print(f"detect [{label}] {n} daemons, {k} kills")
                a0, both, missed, alarms = detect(builds[label], n, args.kills)
                fmt = lambda t: "-" if t is None else f"{t:.3f} s"
                print(f"detect [{label}] median: a0 {fmt(a0)}, two observers {fmt(both)}; not seen {missed}; "
                      f"false alarms {sum(alarms.values())} {sorted(alarms.items())}")
                record(f"kill -9 seen by a0 (s, median of {k})", "{:.3f}", label, a0)
                record(f"kill -9 seen by a0 and the last daemon (s, median of {k})", "{:.3f}", label, both)
                record(f"false alarms at a0 during the {k} kills ({n} daemons)", "{}", label, sum(alarms.values()))
        if "hog" in only:
            for label in labels:
                polls, failed, alarms = hog(builds[label], n, args.hog_s)
                who = ", ".join(f"{o} saw {h} down x{c}" for (o, h), c in sorted(alarms.items())) or "none"
                print(f"hog [{label}] {n} daemons, {cores}+{cores} hogs (nice 0 + nice 10), {args.hog_s:g} s: "
                      f"{polls} polls ({failed} failed), {sum(alarms.values())} false alarms: {who}")
                record(f"false alarms with every core busy ({n} daemons, {args.hog_s:g} s)", "{}", label,
                       sum(alarms.values()))
                record(f"hosts polls failed with every core busy ({n} daemons, {args.hog_s:g} s)", "{}", label, failed)
    except Fail as e:
        print(f"error: {e}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    finally:
        for p in STARTED:
            if p.poll() is None:
                p.kill()
            p.wait()
        for d in TMPS:
            shutil.rmtree(d, ignore_errors=True)
    print("\n| measure | " + " | ".join(labels) + (" | new/old |" if len(labels) == 2 else " |"))
    print("|---" * (len(labels) + 1 + (len(labels) == 2)) + "|")
    for title, fmt in rows:
        vals = [results.get((title, label)) for label in labels]
        cells = ["-" if v is None else fmt.format(v) for v in vals]
        if len(labels) == 2:
            cells.append(f"{vals[1] / vals[0]:.2f}" if vals[0] and vals[1] is not None else "-")
        print(f"| {title} | " + " | ".join(cells) + " |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
