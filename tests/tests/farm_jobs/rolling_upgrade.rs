//! A rolling upgrade on loopback: while a farm job runs, every daemon in turn is ended
//! (SIGTERM) and started again on its own state directory announcing a newer REM protocol,
//! as a newly built remd would, each once the one before is back. The job finishes
//! byte-identical to `sunray render`; each daemon says once, in its log, which peer speaks a
//! newer protocol (and, upgraded, which an older one), and none of them stops for it.

use super::*;

#[test]
fn a_farm_upgraded_one_daemon_at_a_time_finishes_its_job_and_says_who_is_newer() {
    let mut cluster = LoopbackCluster::start(3);
    let dir = tempfile::tempdir().unwrap();
    // Two workers, 96 lines of 300 ms each: about 15 s of rendering, longer than the three
    // restarts take.
    let job = submit(&cluster, "upgrade", 300);
    wait_mid_job(&cluster, &job);
    let ours = rem::wire::protocol::PROTOCOL;
    let newer = (ours + 1).to_string();
    let mut upgraded = vec![];
    for (name, via) in [("a", "b"), ("b", "c"), ("c", "a")] {
        cluster.stop_daemon(name);
        cluster.restart_daemon_with(name, via, &["--announce-protocol", &newer]);
        upgraded.push(name);
        // Back once the others hear it on its new protocol (not its old self, not yet
        // declared lost), and it hears them.
        for other in ["a", "b", "c"].into_iter().filter(|o| *o != name) {
            wait_protocol(&cluster, other, name, ours + 1);
            let theirs = if upgraded.contains(&other) {
                ours + 1
            } else {
                ours
            };
            wait_protocol(&cluster, name, other, theirs);
        }
    }
    let mid = cluster.record("a", &job).unwrap();
    assert_eq!(mid.state, "running", "the job ended before the upgrade did");
    let r = check_finished(&cluster, "a", &job, dir.path());
    assert!(r.epoch >= 2, "a's restart moved the controller: {r:?}");

    let said = |name: &str, peer: &str, protocol: u32, how: &str| {
        let want = format!(
            "peer {peer} speaks REM protocol {protocol}, {how} than this daemon's {}",
            if how == "newer" { ours } else { ours + 1 }
        );
        cluster.log(name).matches(&want).count()
    };
    // Before its own restart, each daemon heard the upgraded ones as newer, once each.
    assert_eq!(said("b", "a", ours + 1, "newer"), 1, "{}", cluster.log("b"));
    assert_eq!(said("c", "a", ours + 1, "newer"), 1, "{}", cluster.log("c"));
    assert_eq!(said("c", "b", ours + 1, "newer"), 1, "{}", cluster.log("c"));
    // Upgraded, each heard those not yet upgraded as older, once each.
    assert_eq!(said("a", "b", ours, "older"), 1, "{}", cluster.log("a"));
    assert_eq!(said("a", "c", ours, "older"), 1, "{}", cluster.log("a"));
    assert_eq!(said("b", "c", ours, "older"), 1, "{}", cluster.log("b"));
    for name in ["a", "b", "c"] {
        let log = cluster.log(name);
        assert!(!log.contains("panicked"), "{name}: {log}");
    }
    // `rem hosts` shows every host on the new protocol.
    let p = Some(u64::from(ours + 1));
    let protocols = protocols(&cluster, "b");
    assert_eq!(
        protocols,
        [("b".into(), p), ("a".into(), p), ("c".into(), p)]
    );
}

/// Each live host and the protocol it announces, as `rem hosts --json` through `via` says.
fn protocols(cluster: &LoopbackCluster, via: &str) -> Vec<(String, Option<u64>)> {
    let out = Command::new(sunray_e2e::bins::rem_bin())
        .args(["--remd", &cluster.daemon(via).addr, "hosts", "--json"])
        .env("REM_SECRET_FILE", &cluster.secret_file)
        .env_remove("REM_SECRET")
        .output()
        .unwrap();
    let hosts: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap_or_default();
    hosts
        .as_array()
        .into_iter()
        .flatten()
        .filter(|h| h["alive"] == true)
        .map(|h| {
            let name = h["name"].as_str().unwrap_or_default().to_string();
            (name, h["protocol"].as_u64())
        })
        .collect()
}

/// Waits (bounded) until daemon `via` hears `host` alive announcing `protocol`.
fn wait_protocol(cluster: &LoopbackCluster, via: &str, host: &str, protocol: u32) {
    let end = Instant::now() + Duration::from_secs(20);
    let want = (host.to_string(), Some(u64::from(protocol)));
    loop {
        let seen = protocols(cluster, via);
        if seen.contains(&want) {
            return;
        }
        assert!(Instant::now() < end, "{via} never heard {want:?}: {seen:?}");
        std::thread::sleep(Duration::from_millis(100));
    }
}
