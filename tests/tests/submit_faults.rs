//! Faults during `sunray submit` on three real remd daemons: a worker killed, a worker
//! host's remd killed, a worker stopped (SIGSTOP) in a job handed to the farm and followed;
//! the controller killed and resumed, and no worker left, with the controller in the
//! submitting process (`--in-process`, the thesis's way). Each run still gives an image
//! byte-identical to `sunray render`, with the lost lines rendered again and counted.
//!
//! "Mid-job" is made deterministic by watching the controller's `--events` and by making
//! every line take at least SUNRAY_WORKER_LINE_DELAY_MS (a worker test hook), so the job
//! is still running when the fault is made.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a test: a failed unwrap is a failed test

use std::path::PathBuf;
use std::process::Command;
use std::time::Duration;
use sunray_e2e::bins::{signal, sunray};
use sunray_e2e::fixtures::spd;
use sunray_e2e::reference::{output, read_json, reference};
use sunray_e2e::remd::LoopbackCluster;
use sunray_e2e::submit_run::SubmitRun;

#[path = "submit_faults/controller.rs"]
mod controller;

const FLAGS: [&str; 2] = ["--resolution", "64x128"];
const LINES: u64 = 128;

struct Job {
    /// Keeps the job's directory (output, stats) until the test ends.
    _dir: tempfile::TempDir,
    want: Vec<u8>,
    out: PathBuf,
    json: PathBuf,
}

fn job() -> Job {
    let dir = tempfile::tempdir().unwrap();
    let (want, _) = reference(dir.path(), &spd("mount6"), &FLAGS);
    Job {
        out: dir.path().join("submit.png"),
        json: dir.path().join("submit.json"),
        _dir: dir,
        want,
    }
}

fn slow_submit(cluster: &LoopbackCluster, job: &Job, delay_ms: u32, extra: &[&str]) -> Command {
    let mut c = cluster.submit();
    c.env("SUNRAY_WORKER_LINE_DELAY_MS", delay_ms.to_string())
        .args(["--hosts", "3"])
        .args(FLAGS)
        .args(extra)
        .arg(spd("mount6"))
        .arg("-o")
        .arg(&job.out)
        .arg("--stats-json")
        .arg(&job.json);
    c
}

/// The image is right, every line was accepted once, and node `victim` has `outcome`.
fn check(job: &Job, victim: u64, outcome: &str) -> serde_json::Value {
    assert!(
        std::fs::read(&job.out).unwrap() == job.want,
        "the image differs from sunray render"
    );
    let s = read_json(&job.json);
    let nodes = s["nodes"].as_array().unwrap();
    let accepted: u64 = nodes.iter().map(|n| n["scanlines"].as_u64().unwrap()).sum();
    assert_eq!(accepted + s["lines"]["resumed"].as_u64().unwrap(), LINES);
    let v = &nodes[victim as usize - 1];
    assert_eq!(v["outcome"], outcome, "{v}");
    s
}

#[test]
fn a_worker_killed_mid_job_gives_its_lines_back() {
    let cluster = LoopbackCluster::start(3);
    let job = job();
    let mut run = SubmitRun::start(slow_submit(&cluster, &job, 60, &[]));
    run.wait_lines_of(2, 2);
    signal(run.worker_pid(2), libc::SIGKILL);
    assert!(run.wait(Duration::from_secs(120)).success());
    let s = check(&job, 2, "fault");
    let victim = &s["nodes"][1];
    assert!(
        victim["fault"].as_str().unwrap().contains("signal 9"),
        "{victim}"
    );
    assert!(
        victim["lines_given_back"].as_u64().unwrap() >= 1,
        "{victim}"
    );
    assert!(s["lines"]["requeued"].as_u64().unwrap() >= 1);
    let fault = run.wait_until(Duration::ZERO, |seen| {
        seen.iter().find(|v| v["event"] == "fault").cloned()
    });
    assert_eq!(fault["node"], 2);
}

#[test]
fn a_worker_of_another_image_version_gets_no_lines() {
    let cluster = LoopbackCluster::start(3);
    let job = job();
    // The worker on host b says it renders other pixels (a host of another build).
    let mut c = slow_submit(&cluster, &job, 5, &[]);
    c.env("SUNRAY_WORKER_IMAGE_VERSION", "b:2");
    let mut run = SubmitRun::start(c);
    assert!(run.wait(Duration::from_secs(120)).success());
    let s = read_json(&job.json);
    let nodes = s["nodes"].as_array().unwrap();
    let b = nodes.iter().position(|n| n["host"] == "b").unwrap();
    let s = check(&job, b as u64 + 1, "fault");
    let v = &s["nodes"][b];
    assert!(
        v["fault"]
            .as_str()
            .unwrap()
            .contains("its sunray renders image version 2, the job's pixels are version 1"),
        "{v}"
    );
    assert_eq!(v["scanlines"], 0, "{v}");
}

#[test]
fn a_worker_host_whose_remd_is_killed_is_lost_and_its_lines_go_elsewhere() {
    let cluster = LoopbackCluster::start(3);
    let job = job();
    let mut run = SubmitRun::start(slow_submit(&cluster, &job, 80, &[]));
    // A worker that is not on the controller's host (a).
    let (victim, host) = run.wait_until(Duration::from_secs(60), |seen| {
        seen.iter()
            .find(|v| v["event"] == "spawned" && v["host"] != "a")
            .map(|v| {
                (
                    v["node"].as_u64().unwrap(),
                    v["host"].as_str().unwrap().to_string(),
                )
            })
    });
    run.wait_lines_of(victim, 2);
    cluster.daemon(&host).signal(libc::SIGKILL);
    assert!(run.wait(Duration::from_secs(120)).success());
    let s = check(&job, victim, "fault");
    let v = &s["nodes"][victim as usize - 1];
    let why = v["fault"].as_str().unwrap();
    assert!(why.contains("lost") || why.contains("unreachable"), "{v}");
    let redone =
        s["lines"]["requeued"].as_u64().unwrap() + s["lines"]["duplicated"].as_u64().unwrap();
    assert!(redone >= 1, "{s}");
}

#[test]
fn a_stopped_worker_times_out_and_the_job_finishes_without_it() {
    let cluster = LoopbackCluster::start(3);
    let job = job();
    let mut run = SubmitRun::start(slow_submit(
        &cluster,
        &job,
        60,
        &["--worker-timeout-ms", "800"],
    ));
    run.wait_lines_of(3, 2);
    let pid = run.worker_pid(3);
    signal(pid, libc::SIGSTOP);
    let status = run.wait(Duration::from_secs(120));
    signal(pid, libc::SIGKILL);
    signal(pid, libc::SIGCONT);
    assert!(status.success());
    let s = check(&job, 3, "silent");
    assert!(
        s["nodes"][2]["lines_given_back"].as_u64().unwrap() >= 1,
        "{s}"
    );
    assert!(run
        .seen
        .iter()
        .any(|v| v["event"] == "silent" && v["node"] == 3));
}

#[test]
fn workers_that_never_say_ready_time_out() {
    let cluster = LoopbackCluster::start(2);
    let job = job();
    let mut c = cluster.submit();
    c.env("SUNRAY_WORKER_READY_DELAY_MS", "120000")
        .args(["--in-process", "--hosts", "2", "--worker-timeout-ms", "500"])
        .args(FLAGS)
        .arg(spd("mount6"))
        .arg("-o")
        .arg(&job.out);
    let mut run = SubmitRun::start(c);
    let status = run.wait(Duration::from_secs(60));
    assert_eq!(status.code(), Some(3), "exit code 3: no worker left");
    for node in [1, 2] {
        assert!(
            run.seen
                .iter()
                .any(|v| v["event"] == "silent" && v["node"] == node),
            "node {node} timed out: {:#?}",
            run.seen
        );
    }
    assert!(!job.out.exists(), "no image from a failed job");
}
