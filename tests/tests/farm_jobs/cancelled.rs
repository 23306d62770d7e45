//! A job cancelled mid-way: its processes end, nothing starts it again, its checkpointed
//! lines stay counted, and `sunray fetch` says why there is no image (unfinished, a record
//! ahead of the copies that answer, or a checkpoint no host keeps any more).

use super::*;

#[test]
fn a_cancelled_job_ends_its_processes_and_keeps_its_checkpointed_lines() {
    let cluster = LoopbackCluster::start(3);
    let job = submit(&cluster, "cancelme", 150);
    wait_mid_job(&cluster, &job);
    let cancel = cluster
        .sunray_via("c")
        .args(["cancel", &job])
        .output()
        .unwrap();
    assert!(
        cancel.status.success(),
        "{}",
        String::from_utf8_lossy(&cancel.stderr)
    );
    let watched = watch(&cluster, "b", &job);
    assert_eq!(
        watched.status.code(),
        Some(4),
        "{}",
        String::from_utf8_lossy(&watched.stderr)
    );
    // Nothing of the job runs, and nothing starts it again.
    let end = Instant::now() + Duration::from_secs(15);
    while cluster
        .processes_via("b")
        .iter()
        .any(|p| p.job.starts_with("cancelme.") && p.state == "running")
    {
        assert!(
            Instant::now() < end,
            "the cancelled job's processes still run"
        );
        std::thread::sleep(Duration::from_millis(100));
    }
    std::thread::sleep(Duration::from_millis(sunray_e2e::remd::LEASE_MS + 500));
    let r = cluster.record("b", &job).unwrap();
    assert_eq!((r.state.as_str(), r.epoch), ("cancelled", 1));
    // `sunray jobs` counts the checkpoint's lines; fetch refuses the unfinished image with the
    // same count.
    let listed = cluster
        .sunray_via("b")
        .args(["jobs", "--json"])
        .output()
        .unwrap();
    let rows: serde_json::Value = serde_json::from_slice(&listed.stdout).unwrap();
    let row = rows
        .as_array()
        .unwrap()
        .iter()
        .find(|r| r["job"] == job)
        .unwrap()
        .clone();
    assert_eq!(row["state"], "cancelled");
    let done = row["lines_done"].as_u64().unwrap();
    assert!(done > 0 && done < LINES, "{row}");
    let said = refused_fetch(&cluster, &job, Path::new("/dev/null.png"));
    assert!(
        said.contains(&format!("{done} of {LINES} lines are in")),
        "{said} vs {row}"
    );
    // A record that says finished while the checkpoint copies that answer lack lines (a copy
    // trailing its record): fetch reads again for its 10 s, then says so, and writes nothing.
    let mut finished = r.clone();
    finished.state = "finished".into();
    finished.epoch += 1;
    cluster.put_record("b", finished);
    let out = std::env::temp_dir().join(format!("{job}.png"));
    let t0 = Instant::now();
    let said = refused_fetch(&cluster, &job, &out);
    assert!(t0.elapsed() >= Duration::from_secs(10), "{said}");
    assert!(
        said.contains(&format!("its record says finished, but after 10 s the hosts that answer hold {done} of {LINES} lines")),
        "{said}"
    );
    // Its checkpoint gone from every host (as REM's retention or its quota removes an ended
    // job's): fetch says why there is no image.
    remove_checkpoints(cluster.dir.path(), &job);
    let said = refused_fetch(&cluster, &job, &out);
    assert!(
        said.contains("its record says finished, but no host keeps its image any more"),
        "{said}"
    );
}

/// `sunray fetch JOB -o out` through daemon b, which must fail and write nothing: what it
/// said.
fn refused_fetch(cluster: &LoopbackCluster, job: &str, out: &Path) -> String {
    let fetched = cluster
        .sunray_via("b")
        .args(["fetch", job, "-o"])
        .arg(out)
        .output()
        .unwrap();
    let said = String::from_utf8_lossy(&fetched.stderr).to_string();
    assert!(!fetched.status.success() && !out.exists(), "{said}");
    said
}

/// Removes job `job`'s checkpoint files (`JOB.ckpt`, `JOB.sN.ckpt`) under `dir`.
fn remove_checkpoints(dir: &Path, job: &str) {
    for e in std::fs::read_dir(dir).into_iter().flatten().flatten() {
        let path = e.path();
        let name = e.file_name().to_string_lossy().into_owned();
        let dot = format!("{job}.");
        if path.is_dir() {
            remove_checkpoints(&path, job);
        } else if name.ends_with(".ckpt")
            && name.starts_with(&dot)
            && path
                .parent()
                .is_some_and(|p| p.ancestors().any(|a| a.ends_with("checkpoints")))
        {
            std::fs::remove_file(&path).unwrap();
        }
    }
}
