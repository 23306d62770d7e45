//! The host that keeps the second copy of a farm job's checkpoint and record is stopped
//! (SIGSTOP) mid-job, on a farm whose daemons suspect a member 5 s before they declare it
//! lost: the controller's writes wait that long for the copy, but they are not the
//! controller's to wait for (its store writer's, and the lease's own bounded write), so lines
//! keep coming at the workers' pace, no worker is judged silent, the controller keeps its
//! lease, and the job finishes while that host is still stopped.

use super::*;

/// The pace the workers keep: every line takes this long, two at a time.
const LINE_MS: u64 = 60;

/// A job id whose checkpoint header and record daemon a keeps on `host` as well (REM's
/// rendezvous order among a's `peers`).
fn job_replicated_to(host: &str, peers: [&str; 3]) -> String {
    (0..1000)
        .map(|i| format!("frozen-{i}"))
        .find(|j| rem::store::replicas::order(j, peers)[0] == host)
        .unwrap()
}

/// The wall-clock times (`unix_ms`) of the accepted lines, in order.
fn line_times(events: &[serde_json::Value]) -> Vec<u64> {
    events
        .iter()
        .filter(|e| e["event"] == "line")
        .filter_map(|e| e["unix_ms"].as_u64())
        .collect()
}

#[test]
fn a_stopped_replica_host_holds_up_no_line_and_no_worker() {
    let cluster = LoopbackCluster::start_suspecting_for(4, 5000);
    let dir = tempfile::tempdir().unwrap();
    let job = job_replicated_to("d", ["b", "c", "d"]);
    let mut c = cluster.submit();
    c.env("SUNRAY_WORKER_LINE_DELAY_MS", LINE_MS.to_string())
        .args([
            "--hosts",
            "2",
            "--checkpoint-ms",
            "200",
            "--avoid-host",
            "d",
        ])
        .args(["--job", &job])
        .args(FLAGS)
        .arg(spd("mount6"))
        .arg("-o")
        .arg(dir.path().join("followed.png"));
    let mut run = SubmitRun::start(c);
    run.wait_done(8, Duration::from_secs(60));
    let d = cluster.daemon("d").pid();
    signal(d, libc::SIGSTOP);
    let stopped_ms = rem::store::job_store::unix_ms(std::time::SystemTime::now());
    // The job ends while d is still stopped.
    let status = run.wait(Duration::from_secs(120));
    signal(d, libc::SIGCONT);
    assert!(status.success(), "{}", run.text());
    let workers: Vec<String> = run.hosts().into_iter().map(|(_, h)| h).collect();
    assert!(
        !workers.iter().any(|h| h == "d"),
        "--avoid-host d: {workers:?}"
    );
    for e in &run.seen {
        assert!(
            !matches!(e["event"].as_str(), Some("silent" | "fault")),
            "{e}"
        );
    }
    // The longest wait for an accepted line from the stop on: a few lines' time, not the
    // 5 s a controller waiting on its writes would show.
    let after: Vec<u64> = std::iter::once(stopped_ms)
        .chain(
            line_times(&run.seen)
                .into_iter()
                .filter(|&t| t >= stopped_ms),
        )
        .collect();
    let longest = after.windows(2).map(|w| w[1].saturating_sub(w[0])).max();
    eprintln!(
        "{} lines after the stop, longest gap {longest:?} ms",
        after.len()
    );
    assert!(after.len() > 40, "{after:?}");
    assert!(longest.unwrap_or(0) < 2000, "{after:?}");
    let r = cluster.record("a", &job).unwrap();
    assert_eq!(
        (r.state.as_str(), r.epoch),
        ("finished", 1),
        "the controller kept its lease: {r:?}"
    );
    let (want, _) = reference(dir.path(), &spd("mount6"), &FLAGS);
    assert!(std::fs::read(dir.path().join("followed.png")).unwrap() == want);
}
