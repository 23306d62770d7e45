//! Jobs owned by the farm (`sunray submit --detach`) on three real remd daemons: the
//! controller is a REM process, and neither its death (kill -9), nor its host's (the remd and
//! every process under it), nor its stopping (SIGSTOP past the lease, then SIGCONT) stops the
//! job; the new controller takes over the workers that still run. Each time the job finishes by itself, `sunray watch` through another remd exits 0,
//! and `sunray fetch` gives an image byte-identical to `sunray render`. A cancelled job ends
//! its processes, is not restarted, and `sunray jobs` counts the lines of its checkpoint.
//!
//! Following a job ([`following`]): Ctrl-C and a lost remd stop the following, not the job.
//! A scene submitted again unchanged is not compiled again ([`remembered_scenes`]). The host
//! keeping the copy of the job's checkpoint stopped holds up no line ([`frozen_replica`]); a
//! full state directory on the controller's host loses nothing ([`full_disk`]). Every daemon
//! restarted in turn on a newer protocol, the job finishes ([`rolling_upgrade`]). Users share
//! the farm's slots by priority and fair shares, and a full farm queues ([`shared_farm`]). A
//! host whose sunray renders another image version gets no lines and no second worker.
//!
//! "Mid-job" is made deterministic by waiting for the job's record to show checkpointed
//! lines, with every line taking at least SUNRAY_WORKER_LINE_DELAY_MS.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a test: a failed unwrap is a failed test

use std::path::Path;
use std::process::{Command, Output};
use std::time::{Duration, Instant};
use sunray_e2e::bins::signal;
use sunray_e2e::fixtures::spd;
use sunray_e2e::reference::{read_json, reference, succeed};
use sunray_e2e::remd::LoopbackCluster;
use sunray_e2e::submit_run::SubmitRun;

#[path = "farm_jobs/cancelled.rs"]
mod cancelled;
#[path = "farm_jobs/following.rs"]
mod following;
#[path = "farm_jobs/frozen_replica.rs"]
mod frozen_replica;
#[path = "farm_jobs/full_disk.rs"]
mod full_disk;
#[path = "farm_jobs/remembered_scenes.rs"]
mod remembered_scenes;
#[path = "farm_jobs/rolling_upgrade.rs"]
mod rolling_upgrade;
#[path = "farm_jobs/shared_farm.rs"]
mod shared_farm;

const FLAGS: [&str; 2] = ["--resolution", "64x96"];
const LINES: u64 = 96;

/// Submits mount6 detached through daemon a (the controller starts there): the job id.
fn submit(cluster: &LoopbackCluster, job: &str, delay_ms: u32) -> String {
    let id = succeed(
        cluster
            .submit()
            .env("SUNRAY_WORKER_LINE_DELAY_MS", delay_ms.to_string())
            .args(["--detach", "--hosts", "2", "--checkpoint-ms", "200"])
            .args(["--job", job])
            .args(FLAGS)
            .arg(spd("mount6")),
    );
    assert_eq!(id.trim(), job, "--detach prints the job id alone");
    id.trim().to_string()
}

/// `sunray submit` through daemon a, following the job (no --detach).
fn follow(cluster: &LoopbackCluster, job: &str, delay_ms: u32, dir: &Path) -> SubmitRun {
    let mut c = cluster.submit();
    c.env("SUNRAY_WORKER_LINE_DELAY_MS", delay_ms.to_string())
        .args(["--hosts", "2", "--checkpoint-ms", "200", "--job", job])
        .args(FLAGS)
        .arg(spd("mount6"))
        .arg("-o")
        .arg(dir.join("followed.png"));
    let mut run = SubmitRun::start(c);
    // The controller's own events reach the follower, through REM.
    run.wait_done(8, Duration::from_secs(60));
    run
}

/// Waits until the job's record shows some checkpointed lines (and not all).
fn wait_mid_job(cluster: &LoopbackCluster, job: &str) -> rem::JobRecord {
    cluster.wait_record("b", job, "got going", |r| {
        r.state == "running" && r.progress_done >= 8 && !r.controller.is_empty()
    })
}

/// `sunray watch JOB` through daemon `via`, to its end.
fn watch(cluster: &LoopbackCluster, via: &str, job: &str) -> Output {
    cluster
        .sunray_via(via)
        .args(["watch", job, "--events"])
        .output()
        .unwrap()
}

/// The OS pid of the running REM process of job `rem_job`.
fn pid_of(cluster: &LoopbackCluster, via: &str, rem_job: &str) -> i32 {
    let end = Instant::now() + Duration::from_secs(20);
    loop {
        let procs = cluster.processes_via(via);
        if let Some(p) = procs
            .iter()
            .find(|p| p.job == rem_job && p.state == "running")
        {
            return p.pid as i32;
        }
        assert!(
            Instant::now() < end,
            "no running process of {rem_job}: {procs:#?}"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// The job ended by itself: watch exits 0 through `via`, the image fetched is `sunray
/// render`'s, and the record's epoch is past the first.
fn check_finished(cluster: &LoopbackCluster, via: &str, job: &str, dir: &Path) -> rem::JobRecord {
    let watched = watch(cluster, via, job);
    let events = String::from_utf8_lossy(&watched.stderr).to_string();
    assert!(watched.status.success(), "watch: {events}");
    assert!(events.contains(r#""state":"finished""#), "{events}");
    let out = dir.join("fetched.png");
    let fetched = cluster
        .sunray_via(via)
        .args(["fetch", job, "-o"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(
        fetched.status.success(),
        "{}",
        String::from_utf8_lossy(&fetched.stderr)
    );
    let (want, _) = reference(dir, &spd("mount6"), &FLAGS);
    assert!(
        std::fs::read(&out).unwrap() == want,
        "the fetched image differs from sunray render"
    );
    let r = cluster.record(via, job).unwrap();
    assert_eq!((r.state.as_str(), r.progress_done), ("finished", LINES));
    r
}

#[test]
fn a_controller_killed_mid_job_is_replaced_and_the_job_finishes_by_itself() {
    let cluster = LoopbackCluster::start(3);
    let dir = tempfile::tempdir().unwrap();
    let job = submit(&cluster, "kill9", 100);
    wait_mid_job(&cluster, &job);
    signal(pid_of(&cluster, "a", "kill9.c1"), libc::SIGKILL);
    let r = check_finished(&cluster, "b", &job, dir.path());
    assert_eq!(r.epoch, 2, "one replacement: {r:?}");
    // The new controller took both workers over: they finished the job (exit 0, not 3 for
    // "controller gone") and none was started for epoch 2.
    let first = exited_workers(&cluster, "b", "kill9.w1");
    assert_eq!(first.len(), 2, "{first:#?}");
    assert!(
        first.iter().all(|p| p.exit_code == Some(0)),
        "taken over, they finish the job: {first:#?}"
    );
    assert!(exited_workers(&cluster, "b", "kill9.w2").is_empty());
    // The page remd's web view shows tells the move, after the first controller's history.
    let page: serde_json::Value =
        serde_json::from_slice(&cluster.stored("c", "kill9.web.json").unwrap()).unwrap();
    let events: Vec<(&str, &str)> = page["events"]
        .as_array()
        .unwrap()
        .iter()
        .map(|e| (e["kind"].as_str().unwrap(), e["text"].as_str().unwrap()))
        .collect();
    let at = |want: &str| events.iter().position(|(_, t)| t.contains(want));
    let (started, moved) = (at("controller started on a, epoch 1"), at("epoch 2"));
    assert!(started.is_some() && moved > started, "{events:#?}");
    assert!(events[moved.unwrap()].1.contains("moved"), "{events:#?}");
    assert_eq!(events.last().map(|e| e.0), Some("finished"), "{events:#?}");
    assert_eq!(page["image"]["full"], true);
}

#[test]
fn a_taken_over_worker_that_dies_is_reported_to_its_new_controller_at_once() {
    let cluster = LoopbackCluster::start(3);
    let dir = tempfile::tempdir().unwrap();
    // Slow lines (two workers, 96 lines of 300 ms): time for a takeover, then a fault.
    let job = submit(&cluster, "adopted", 300);
    wait_mid_job(&cluster, &job);
    signal(pid_of(&cluster, "a", "adopted.c1"), libc::SIGKILL);
    let second = cluster.wait_record("b", &job, "moved to epoch 2", |r| {
        r.epoch == 2 && r.state == "running" && !r.controller.is_empty()
    });
    // REM now sends the first epoch's workers' events to the second controller.
    let end = Instant::now() + Duration::from_secs(20);
    let victim = loop {
        let workers: Vec<_> = cluster
            .processes_via("b")
            .into_iter()
            .filter(|p| p.job == "adopted.w1" && p.state == "running")
            .collect();
        if !workers.is_empty() && workers.iter().all(|p| p.owner == second.controller) {
            break workers[0].clone();
        }
        assert!(Instant::now() < end, "never adopted: {workers:#?}");
        std::thread::sleep(Duration::from_millis(50));
    };
    let t0 = Instant::now();
    signal(victim.pid as i32, libc::SIGKILL);
    // The fault is the process's exit (not a silence of 10 s, nor an undeliverable line).
    let log = loop {
        let log = cluster.output_via("b", &second.controller);
        if log.contains(r#""event":"fault""#) {
            break log;
        }
        assert!(
            t0.elapsed() < Duration::from_secs(5),
            "no fault seen: {log}"
        );
        std::thread::sleep(Duration::from_millis(50));
    };
    let fault = log
        .lines()
        .find(|l| l.contains(r#""event":"fault""#))
        .unwrap();
    assert!(fault.contains("killed by signal 9"), "{fault}");
    eprintln!("fault seen by the new controller after {:?}", t0.elapsed());
    let r = check_finished(&cluster, "c", &job, dir.path());
    assert_eq!(r.epoch, 2, "{r:?}");
}

/// The processes of REM job `rem_job` once none of them runs (bounded wait).
fn exited_workers(cluster: &LoopbackCluster, via: &str, rem_job: &str) -> Vec<rem::ProcessInfo> {
    let end = Instant::now() + Duration::from_secs(10);
    loop {
        let procs: Vec<_> = cluster
            .processes_via(via)
            .into_iter()
            .filter(|p| p.job == rem_job)
            .collect();
        if procs.iter().all(|p| p.state == "exited") {
            return procs;
        }
        assert!(Instant::now() < end, "{rem_job} still runs: {procs:#?}");
        std::thread::sleep(Duration::from_millis(100));
    }
}

#[test]
fn losing_the_controllers_host_moves_the_job_to_a_live_host() {
    let mut cluster = LoopbackCluster::start(3);
    let dir = tempfile::tempdir().unwrap();
    let job = submit(&cluster, "hostloss", 100);
    let before = wait_mid_job(&cluster, &job);
    assert_eq!(before.controller_host, "a");
    cluster.kill_daemon("a");
    let r = check_finished(&cluster, "c", &job, dir.path());
    assert_ne!(r.controller_host, "a", "{r:?}");
    assert!(r.epoch >= 2, "the controller was never replaced: {r:?}");
    // The worker that was not on a was taken over and finished the job.
    let survivors: Vec<_> = exited_workers(&cluster, "c", "hostloss.w1")
        .into_iter()
        .filter(|p| p.host != "a")
        .collect();
    assert!(!survivors.is_empty());
    assert!(
        survivors.iter().all(|p| p.exit_code == Some(0)),
        "{survivors:#?}"
    );
    // New workers went to other hosts than the ones taken over.
    let mut hosts: Vec<String> = cluster
        .processes_via("c")
        .into_iter()
        .filter(|p| p.job.starts_with("hostloss.w") && p.job != "hostloss.w1")
        .map(|p| p.host)
        .chain(survivors.iter().map(|p| p.host.clone()))
        .collect();
    let n = hosts.len();
    hosts.sort();
    hosts.dedup();
    assert_eq!(hosts.len(), n, "two workers on one host: {hosts:?}");
}

#[test]
fn controller_anywhere_starts_the_controller_on_the_least_loaded_host() {
    let cluster = LoopbackCluster::start(3);
    let dir = tempfile::tempdir().unwrap();
    // A job whose two workers make their hosts busier than the third (REM processes count).
    let busy = submit(&cluster, "busy", 100);
    wait_mid_job(&cluster, &busy);
    let procs = cluster.processes_via("a");
    let worker_hosts: Vec<String> = procs
        .iter()
        .filter(|p| p.job == "busy.w1" && p.state == "running")
        .map(|p| p.host.clone())
        .collect();
    assert_eq!(worker_hosts.len(), 2, "{procs:#?}");
    let idle = ["a", "b", "c"]
        .into_iter()
        .find(|h| !worker_hosts.iter().any(|w| w == h))
        .unwrap();
    // Submitted through a busy host, the controller goes to the idle one.
    let via = worker_hosts[0].as_str();
    succeed(
        cluster
            .sunray_via(via)
            .args(["submit", "--detach", "--controller-anywhere"])
            .args(["--job", "anywhere"])
            .args(FLAGS)
            .arg(spd("mount6")),
    );
    let r = cluster.wait_record(via, "anywhere", "got its controller", |r| {
        !r.controller_host.is_empty()
    });
    assert_eq!(
        r.controller_host, idle,
        "{r:?} (workers of busy on {worker_hosts:?})"
    );
    check_finished(&cluster, via, "anywhere", dir.path());
}

#[test]
fn a_stopped_controller_is_replaced_and_stands_down_when_it_wakes() {
    let cluster = LoopbackCluster::start(3);
    let dir = tempfile::tempdir().unwrap();
    let job = submit(&cluster, "stopped", 100);
    wait_mid_job(&cluster, &job);
    let old = pid_of(&cluster, "a", "stopped.c1");
    signal(old, libc::SIGSTOP);
    // Past the lease, a second controller takes the job.
    cluster.wait_record("b", &job, "moved to epoch 2", |r| r.epoch == 2);
    signal(old, libc::SIGCONT);
    let r = check_finished(&cluster, "b", &job, dir.path());
    assert!(r.epoch >= 2, "{r:?}");
    let procs = cluster.processes_via("b");
    let first = procs.iter().find(|p| p.job == "stopped.c1").unwrap();
    assert_eq!(
        first.state, "exited",
        "the old controller still runs: {first:?}"
    );
}

#[test]
fn detach_refuses_the_embedded_default_and_a_running_job_id() {
    let out = sunray_e2e::bins::sunray()
        .env_remove("REM_ADDR")
        .args(["submit", "--detach", "--resolution", "8x8"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let said = String::from_utf8_lossy(&out.stderr);
    assert!(said.contains("need a cluster (--remd"), "{said}");
    assert_eq!(said.trim().lines().count(), 1, "{said}");
    let cluster = LoopbackCluster::start(2);
    let job = submit(&cluster, "twice", 150);
    let again: Command = {
        let mut c = cluster.submit();
        c.args(["--detach", "--job", &job])
            .args(FLAGS)
            .arg(spd("mount6"));
        c
    };
    let out = {
        let mut again = again;
        again.output().unwrap()
    };
    let said = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(said.contains("exists and is"), "{said}");
    let cancel = cluster
        .sunray_via("a")
        .args(["cancel", &job])
        .output()
        .unwrap();
    assert!(cancel.status.success());
}

#[test]
fn a_controller_whose_job_moved_on_stands_down_and_the_job_finishes() {
    let cluster = LoopbackCluster::start(3);
    let dir = tempfile::tempdir().unwrap();
    let job = submit(&cluster, "fenced", 100);
    let r = wait_mid_job(&cluster, &job);
    let pid = pid_of(&cluster, "a", "fenced.c1");
    // A successor's record (epoch 2, no live controller yet), as a partition's other side
    // would write it: every write of epoch 1 is refused from now on.
    let mut next = r.clone();
    next.epoch = 2;
    next.controller = String::new();
    next.controller_host = String::new();
    next.state = "recovering".into();
    cluster.put_record("b", next);
    // The epoch-1 controller learns it at its next write and stands down (exit 5) ...
    let end = Instant::now() + Duration::from_secs(20);
    let first = loop {
        let procs = cluster.processes_via("b");
        let p = procs
            .iter()
            .find(|p| p.pid as i32 == pid && p.job == "fenced.c1")
            .cloned();
        if let Some(p) = p.as_ref().filter(|p| p.state == "exited") {
            break p.clone();
        }
        assert!(
            Instant::now() < end,
            "the fenced controller still runs: {p:?}"
        );
        std::thread::sleep(Duration::from_millis(100));
    };
    assert_eq!(first.exit_code, Some(5), "{first:?}");
    // ... and the job, with no controller at epoch 2, is started again and finishes.
    let r = check_finished(&cluster, "b", &job, dir.path());
    assert!(r.epoch >= 3, "{r:?}");
}

#[test]
fn a_host_of_another_image_version_gets_no_lines_and_no_second_worker() {
    let cluster = LoopbackCluster::start(3);
    let dir = tempfile::tempdir().unwrap();
    // One worker a host; the one on b says it renders other pixels (a host of another build).
    let id = succeed(
        cluster
            .submit()
            .env("SUNRAY_WORKER_LINE_DELAY_MS", "30")
            .env("SUNRAY_WORKER_IMAGE_VERSION", "b:2")
            .args(["--detach", "--hosts", "3", "--checkpoint-ms", "200"])
            .args(["--job", "versions"])
            .args(FLAGS)
            .arg(spd("mount6")),
    );
    assert_eq!(id.trim(), "versions");
    check_finished(&cluster, "a", "versions", dir.path());
    // The share keeper, a worker short, asked for none on b again: one there, refused.
    let on_b: Vec<_> = cluster
        .processes()
        .into_iter()
        .filter(|p| p.host == "b" && p.args.first().is_some_and(|a| a == "worker"))
        .collect();
    assert_eq!(on_b.len(), 1, "{on_b:#?}");
}
