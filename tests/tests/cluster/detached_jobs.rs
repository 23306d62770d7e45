//! Detached jobs on the cluster: the job outlives its controller's container, killed or cut
//! off from the network, and finishes by itself elsewhere.

use super::*;
use std::process::Command;

/// `sunray jobs --json` in `host`: the row of `job`.
fn job_row(cluster: &ComposeCluster, host: &str, job: &str) -> Option<serde_json::Value> {
    let o = cluster
        .exec(host, &["/bin/sunray", "jobs", "--json"])
        .output()
        .unwrap();
    let rows: serde_json::Value = serde_json::from_slice(&o.stdout).ok()?;
    rows.as_array()?.iter().find(|r| r["job"] == job).cloned()
}

/// Submits the big mount6 job detached from ws1 (its controller starts there) and waits
/// until a quarter of its lines are checkpointed.
fn detached_big_job(cluster: &ComposeCluster, job: &str) {
    let o = output(&mut cluster.exec(
        "ws1",
        &submit_args(&[
            "--detach",
            "--hosts",
            "6",
            "--resolution",
            BIG,
            "--samples",
            BIG_SAMPLES,
            "--job",
            job,
            "--checkpoint-ms",
            "500",
            "/scenes/mount6.nff",
        ]),
    ));
    assert!(o.status.success(), "submit --detach failed");
    assert_eq!(String::from_utf8_lossy(&o.stdout).trim(), job);
    let end = std::time::Instant::now() + Duration::from_secs(180);
    loop {
        let row = job_row(cluster, "ws2", job);
        let done = row.as_ref().and_then(|r| r["lines_done"].as_u64());
        if done.is_some_and(|d| d >= BIG_LINES / 4) {
            assert_eq!(row.unwrap()["controller_host"], "ws1");
            return;
        }
        assert!(
            std::time::Instant::now() < end,
            "job {job} never got going: {row:?}"
        );
        std::thread::sleep(Duration::from_millis(300));
    }
}

/// The job finishes by itself: `watch` in ws2 exits 0, `fetch` is byte-identical to `sunray
/// render`, and one later epoch won, with its controller off ws1.
fn finishes_elsewhere(cluster: &ComposeCluster, job: &str) {
    let o = output(&mut cluster.exec("ws2", &["/bin/sunray", "watch", job, "--quiet"]));
    assert!(o.status.success(), "watch failed");
    let png = format!("/out/{job}.png");
    let o = output(&mut cluster.exec("ws2", &["/bin/sunray", "fetch", job, "-o", &png]));
    assert!(o.status.success(), "fetch failed");
    assert!(
        std::fs::read(cluster.out(&format!("{job}.png"))).unwrap() == big_reference(),
        "the image differs"
    );
    let row = job_row(cluster, "ws2", job).unwrap();
    assert_eq!(row["state"], "finished", "{row}");
    assert!(row["epoch"].as_u64().unwrap() >= 2, "{row}");
    assert_ne!(row["controller_host"], "ws1", "{row}");
}

#[test]
fn a_detached_job_survives_its_controllers_container_being_killed() {
    let _one_at_a_time = serial();
    let Some(_) = prepare() else { return };
    let cluster = ComposeCluster::up();
    detached_big_job(&cluster, "farm-kill");
    let o = output(cluster.compose().args(["kill", "ws1"]));
    assert!(o.status.success());
    finishes_elsewhere(&cluster, "farm-kill");
}

#[test]
fn a_detached_job_survives_its_controller_cut_off_for_20_seconds() {
    let _one_at_a_time = serial();
    let Some(_) = prepare() else { return };
    let cluster = ComposeCluster::up();
    detached_big_job(&cluster, "farm-cut");
    let ws1 = cluster.container("ws1");
    let net = cluster.network();
    let o = output(Command::new("docker").args(["network", "disconnect", &net, &ws1]));
    assert!(o.status.success());
    std::thread::sleep(Duration::from_secs(20));
    let o =
        output(Command::new("docker").args(["network", "connect", "--alias", "ws1", &net, &ws1]));
    assert!(o.status.success());
    finishes_elsewhere(&cluster, "farm-cut");
    // The cut-off controller (epoch 1) did not finish the job: a later one did.
    let ps = output(&mut cluster.exec("ws2", &["/bin/rem", "ps", "--json"]));
    let procs: serde_json::Value = serde_json::from_slice(&ps.stdout).unwrap();
    let of = |job: &str| -> Vec<serde_json::Value> {
        procs
            .as_array()
            .unwrap()
            .iter()
            .filter(|p| p["job"] == job)
            .cloned()
            .collect()
    };
    for p in of("farm-cut.c1") {
        assert_ne!(p["exit_code"], 0, "the cut-off controller finished: {p}");
    }
}
