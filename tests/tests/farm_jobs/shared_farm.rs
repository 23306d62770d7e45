//! A farm many people share (DESIGN section 12), on four loopback daemons lending one render
//! slot each: alice's job holds every slot; bob submits and both run, alice's falling to her
//! share; carol's priority-90 job takes what it wants and the others shrink to one worker;
//! with every slot taken dave's job waits, first in the queue, and starts when a slot frees;
//! erin's, second, is cancelled while it waits.
//! Every image is byte-identical to `sunray render`.

use super::*;
use std::collections::BTreeMap;

const SHARE_FLAGS: [&str; 2] = ["--resolution", "48x64"];
/// Milliseconds every line takes at least: the jobs overlap for seconds.
const LINE_MS: &str = "120";

/// Submits `job` (mount6) detached as `user` through daemon a, with `extra` flags.
fn submit_as(cluster: &LoopbackCluster, user: &str, job: &str, extra: &[&str]) {
    let id = succeed(
        cluster
            .sunray_as(user, "a")
            .env("SUNRAY_WORKER_LINE_DELAY_MS", LINE_MS)
            .args(["submit", "--detach", "--checkpoint-ms", "300", "--job", job])
            .args(extra)
            .args(SHARE_FLAGS)
            .arg(spd("mount6")),
    );
    assert_eq!(id.trim(), job);
}

/// Slots held by each job's running workers, as REM's processes say (`JOB.wE` jobs).
fn held(cluster: &LoopbackCluster) -> BTreeMap<String, u32> {
    let mut out = BTreeMap::new();
    for p in cluster.processes() {
        if p.state != "running" {
            continue;
        }
        if let Some((job, _)) = p.job.rsplit_once(".w") {
            *out.entry(job.to_string()).or_default() += p.slots;
        }
    }
    out
}

/// Waits (bounded) until the slots held are what `want` says of each job named; returns how
/// long it took.
fn wait_held(cluster: &LoopbackCluster, want: &[(&str, u32)], what: &str) -> Duration {
    let start = Instant::now();
    loop {
        let now = held(cluster);
        if want
            .iter()
            .all(|(job, n)| now.get(*job).copied().unwrap_or(0) == *n)
        {
            return start.elapsed();
        }
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "{what}: slots held {now:?}, wanted {want:?}; queue {:#?}",
            cluster.queue()
        );
        std::thread::sleep(Duration::from_millis(25));
    }
}

/// `sunray jobs --json` as `user`: that user's job `job`.
fn listed(cluster: &LoopbackCluster, user: &str, job: &str) -> serde_json::Value {
    let out = succeed(cluster.sunray_as(user, "b").args(["jobs", "--json"]));
    let jobs: serde_json::Value = serde_json::from_str(&out).unwrap();
    jobs.as_array()
        .unwrap()
        .iter()
        .find(|j| j["job"] == job)
        .cloned()
        .unwrap_or_else(|| panic!("{user} does not list {job}: {out}"))
}

#[test]
fn users_share_the_farm_a_higher_priority_goes_first_and_a_full_farm_queues() {
    let cluster = LoopbackCluster::start_with_flags(4, &["--slots", "1"]);
    let dir = tempfile::tempdir().unwrap();
    submit_as(&cluster, "alice", "a1", &["--hosts", "4"]);
    wait_held(&cluster, &[("a1", 4)], "alice's job never held every slot");
    submit_as(&cluster, "bob", "b1", &["--hosts", "4"]);
    let took = wait_held(&cluster, &[("a1", 2), ("b1", 2)], "the users never shared");
    eprintln!(
        "bob's job and alice's share: {:.2} s after bob's submit",
        took.as_secs_f64()
    );
    // The issue asks for a second (0.43 s measured here in release); a loaded 2-core CI
    // machine gets slack, but a rule paced by the lease or a slow poll would not make it.
    assert!(took < Duration::from_secs(4), "{took:?} to share");
    let a1 = listed(&cluster, "alice", "a1");
    assert_eq!(
        (a1["user"].as_str(), a1["priority"].as_u64()),
        (Some("alice"), Some(50))
    );
    assert_eq!(
        a1["queue_position"],
        serde_json::Value::Null,
        "a running job has no place"
    );
    // A priority-90 job takes the two slots it wants; the others keep one worker each.
    submit_as(
        &cluster,
        "carol",
        "p1",
        &["--hosts", "2", "--priority", "90"],
    );
    wait_held(
        &cluster,
        &[("a1", 1), ("b1", 1), ("p1", 2)],
        "the priority was not served",
    );
    // Every slot is taken: dave's job waits, first in the queue, and `sunray jobs` says so.
    submit_as(&cluster, "dave", "d1", &["--hosts", "1"]);
    let start = Instant::now();
    let d1 = loop {
        let d1 = listed(&cluster, "dave", "d1");
        if d1["queue_position"].as_u64() == Some(1) || start.elapsed() > Duration::from_secs(30) {
            break d1;
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    assert_eq!(d1["queue_position"].as_u64(), Some(1), "{d1}");
    assert_eq!(held(&cluster).get("d1"), None, "a queued job holds nothing");
    // A job behind it is second, and cancelled while it waits it leaves the queue.
    submit_as(&cluster, "erin", "e1", &["--hosts", "1"]);
    let place = |q: &rem::wire::proto::QueueReply, id: &str| {
        q.jobs.iter().find(|j| j.id == id).map(|j| j.queue_position)
    };
    let start = Instant::now();
    while place(&cluster.queue(), "e1") != Some(2) {
        assert!(
            start.elapsed() < Duration::from_secs(30),
            "{:#?}",
            cluster.queue()
        );
        std::thread::sleep(Duration::from_millis(50));
    }
    succeed(cluster.sunray_as("erin", "b").args(["cancel", "e1"]));
    // Cancelled through b, it leaves a's queue too (a daemon answers a queue it computed
    // less than 150 ms ago again).
    let start = Instant::now();
    while place(&cluster.queue(), "e1").is_some() {
        assert!(
            start.elapsed() < Duration::from_secs(5),
            "a cancelled job stays queued"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
    assert_eq!(held(&cluster).get("e1"), None);
    // It starts when a slot frees (carol's job ends first: it has two workers).
    let mut finished = Vec::new();
    for (user, job) in [
        ("carol", "p1"),
        ("dave", "d1"),
        ("alice", "a1"),
        ("bob", "b1"),
    ] {
        let watched = cluster
            .sunray_as(user, "b")
            .args(["watch", job, "--events"])
            .output()
            .unwrap();
        let events = String::from_utf8_lossy(&watched.stderr).to_string();
        assert!(watched.status.success(), "watch {job}: {events}");
        let out = dir.path().join(format!("{job}.png"));
        succeed(
            cluster
                .sunray_as(user, "b")
                .args(["fetch", job, "-o"])
                .arg(&out),
        );
        finished.push((job, std::fs::read(&out).unwrap()));
    }
    let (want, _) = reference(dir.path(), &spd("mount6"), &SHARE_FLAGS);
    for (job, got) in finished {
        assert!(got == want, "{job}'s image differs from sunray render");
    }
}
