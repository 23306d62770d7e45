"""A rolling upgrade of the six-workstation compose cluster (`deploy/bench/run.sh upgrade`).

The cluster starts on UPGRADE_FROM (default sunray-rem:latest); a long farm job is handed to it
(`sunray submit --detach --hosts 3`, mount6, every line slowed to UPGRADE_LINE_MS, default 400).
Once the job is under way, ws1 .. ws6 are replaced one at a time by containers of UPGRADE_TO
(default sunray-rem:next, which run.sh builds anew), each on its own state volume, as an
administrator would (`docker-compose up -d --no-deps wsN` with the new image), the next only
once `rem hosts` shows the one before alive on its new protocol. The upgraded daemons announce
UPGRADE_ANNOUNCE (default: one more than the old daemons' protocol, so the old ones meet a
newer protocol; empty: the new image's own, then UPGRADE_EXPECT says which protocol that is,
so a host counts as back only once it announces it).

At the end the job must have finished byte-identical to `sunray render` on ws1, each old
daemon must have said once per upgraded peer that it speaks a newer protocol (when the old
image announces protocols at all), and no daemon may have panicked. The table (per host: the
seconds it was out, the notices it logged) is printed and kept for the report; an upgrade
that lost anything fails the run (exit status 1) once its figures are saved.
"""

import json
import os
import subprocess
import time

HOSTS = [f"ws{i}" for i in range(1, 7)]
JOB = "rolling-upgrade"


def protocol_of(farm, via, host, fresh_ms=None):
    """The protocol `via` sees `host` announce (1: none announced; None: not alive, or with
    `fresh_ms`, not heard from within that many milliseconds)."""
    for h in farm.hosts(via):
        if h.get("name") == host and h.get("alive"):
            if fresh_ms is not None and (h.get("last_heard_ms") or 0) > fresh_ms:
                return None
            return h.get("protocol") or 1
    return None


def back(farm, host, via, want, announced):
    """Whether the upgraded `host` is back. With a protocol announced to the old daemons,
    once `via` hears it; else (a daemon older than protocol announcements drops the field) once
    the host itself says it speaks `want` and `via` heard it within the last second (the old
    daemon, stopped, is heard no more)."""
    if want is None:
        return protocol_of(farm, via, host) is not None
    if announced:
        return protocol_of(farm, via, host) == want
    return (protocol_of(farm, host, host) == want
            and protocol_of(farm, via, host, fresh_ms=1000) is not None)


def container_log(farm, host):
    cid = farm.compose("ps", "-q", host, capture_output=True, text=True).stdout.strip()
    if not cid:
        return ""
    r = subprocess.run(["docker", "logs", cid], capture_output=True, text=True)
    return r.stdout + r.stderr


def job_row(farm):
    r = farm.compose("exec", "-T", "ws1", "/bin/sunray", "jobs", "--json",
                     capture_output=True, text=True)
    try:
        rows = [x for x in json.loads(r.stdout or "[]") if x["job"] == JOB]
    except ValueError:
        rows = []
    return rows[0] if rows else None


def write_override(path, image, announce, upgraded):
    """A compose file over the base one giving the upgraded hosts the new image."""
    lines = ["services:"]
    for host in upgraded:
        lines += [f"  {host}:", f"    image: {image}"]
        if announce:
            lines += ["    environment:", f"      REMD_ANNOUNCE_PROTOCOL: \"{announce}\""]
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")


def run(farm, work, res, line_ms):
    override = os.path.join(work, "upgrade.override.yml")
    farm.env["SUNRAY_IMAGE"] = os.environ.get("UPGRADE_FROM", "sunray-rem:latest")
    farm.up(6, "ws1")
    try:
        return upgrade(farm, work, res, line_ms, override)
    finally:
        farm.down()


def upgrade(farm, work, res, line_ms, override):
    to_image = os.environ.get("UPGRADE_TO", "sunray-rem:next")
    old_protocol = protocol_of(farm, "ws1", "ws1") or 1
    announce = os.environ.get("UPGRADE_ANNOUNCE", str(old_protocol + 1))
    farm.compose("exec", "-T", "ws1", "/bin/sunray", "render", "-q", "--resolution", res,
                 "/scenes/mount6.nff", "-o", "/out/upgrade-ref.png", check=True,
                 capture_output=True)
    with open(os.path.join(work, "upgrade-ref.png"), "rb") as f:
        ref = f.read()
    submit = farm.exec_argv("ws1", [])[:-1] + [
        "-e", f"SUNRAY_WORKER_LINE_DELAY_MS={line_ms}", "ws1", "/bin/sunray", "submit",
        "--detach", "--hosts", "3", "--checkpoint-ms", "500", "--job", JOB,
        "--resolution", res, "/scenes/mount6.nff"]
    t0 = time.time()
    subprocess.run(submit, env=farm.env, check=True, capture_output=True)
    while (job_row(farm) or {}).get("state") != "running" and time.time() - t0 < 120:
        time.sleep(0.5)
    time.sleep(3)
    base = farm.file
    files = ["-f", base, "-f", override]
    hosts, upgraded = [], []
    for i, host in enumerate(HOSTS):
        via = HOSTS[(i + 1) % len(HOSTS)]
        before = container_log(farm, host)
        upgraded.append(host)
        write_override(override, to_image, announce, upgraded)
        t = time.time()
        subprocess.run(farm.compose_argv(*files, "up", "-d", "--no-deps", host),
                       env=farm.env, check=True, capture_output=True)
        # Back: heard announcing the new protocol (UPGRADE_EXPECT when the new image announces
        # its own: without a protocol to tell them apart, the old daemon, not yet declared
        # lost, could pass for the new one).
        expect = announce or os.environ.get("UPGRADE_EXPECT", "")
        want = int(expect) if expect else None
        out_s = None
        while time.time() - t < 120:
            if back(farm, host, via, want, bool(announce)):
                out_s = time.time() - t
                break
            time.sleep(0.5)
        hosts.append({"host": host, "out_s": out_s, "log_before": before})
        print(f"upgrade: {host} back after {out_s} s on {to_image}", flush=True)
        time.sleep(2)
    upgraded_s = time.time() - t0
    during = job_row(farm) or {}
    row = during
    while row.get("state") in ("running", "recovering", "queued", None) and time.time() - t0 < 900:
        time.sleep(1)
        row = job_row(farm) or {}
    identical = False
    if row.get("state") == "finished":
        farm.compose("exec", "-T", "ws1", "/bin/sunray", "fetch", JOB, "-o",
                     "/out/upgrade-job.png", check=True, capture_output=True)
        with open(os.path.join(work, "upgrade-job.png"), "rb") as f:
            identical = f.read() == ref
    for h in hosts:
        h["log_after"] = container_log(farm, h["host"])
    return table(hosts, row, during, identical, old_protocol, announce, to_image, upgraded_s,
                 t0)


def table(hosts, row, during, identical, old_protocol, announce, to_image, upgraded_s, t0):
    lost = []
    if row.get("state") != "finished":
        lost.append(f"the job ended {row.get('state')}")
    elif not identical:
        lost.append("the image differs from sunray render")
    if during.get("state") != "running":
        lost.append(f"the job was {during.get('state')} before every host was upgraded")
    rows = []
    for i, h in enumerate(hosts):
        newer = [p["host"] for p in hosts[:i]]
        said = {p: h["log_before"].count(f"peer {p} speaks REM protocol {announce}, newer")
                for p in newer}
        panics = (h["log_before"] + h["log_after"]).count("panicked")
        if h["out_s"] is None:
            lost.append(f"{h['host']} never came back")
        if panics:
            lost.append(f"{h['host']} panicked")
        # Only a daemon that announces protocols (2 on) knows to say so.
        if old_protocol >= 2 and announce and any(n != 1 for n in said.values()):
            lost.append(f"{h['host']} did not say once that each upgraded peer is newer: {said}")
        rows.append({"host": h["host"], "out_s": h["out_s"], "newer_noticed": said,
                     "panics": panics})
    t = {"from_protocol": old_protocol, "to_protocol": int(announce) if announce else None,
         "to_image": to_image, "upgraded_s": upgraded_s, "hosts": rows,
         "job_s": (row.get("updated_unix_ms") or 0) / 1000.0 - t0,
         "epoch": row.get("epoch"), "state": row.get("state"), "identical": identical,
         "lost": lost}
    print(f"upgrade: six hosts replaced in {upgraded_s:.0f} s, job {t['state']} after "
          f"{t['job_s']:.0f} s at epoch {t['epoch']}, identical {identical}; "
          f"lost {lost or 'nothing'}", flush=True)
    t["passed"] = not lost
    return t
