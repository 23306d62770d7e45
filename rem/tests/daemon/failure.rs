//! Failures: a killed daemon, a hung (SIGSTOPped) daemon, a restart, SIGTERM.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a test: a failed unwrap is a failed test

use std::time::{Duration, Instant};

use crate::common::*;
use rem::{EventKind, SpawnRequest};

const T: Duration = Duration::from_secs(10);
/// The bound on failure detection (default heartbeat settings are used here).
const DETECT: Duration = Duration::from_secs(2);

fn spin(owner: &rem::Relay, count: u32) -> SpawnRequest {
    SpawnRequest {
        program: ECHO.into(),
        args: vec!["spin".into(), "60".into()],
        nice: Some(10),
        count,
        owner: Some(owner.id().clone()),
        ..SpawnRequest::default()
    }
}

/// Kills or stops daemon c, checks a and b mark it lost within 2 s and the owner (on a)
/// gets LOST for c's process; returns the time to the LOST event.
async fn host_failure_is_detected(sig: i32) -> (RemdProcesses, Duration) {
    let mut cluster = remds(3, &[]);
    cluster.converge(T).await;
    let client = cluster.client(0).await;
    let mut owner = client.attach(None).await.unwrap();
    let job = client.spawn(spin(&owner, 3)).await.unwrap();
    let on_c = job
        .processes
        .iter()
        .find(|p| p.host == "c")
        .unwrap()
        .proc_id
        .clone();
    for _ in 0..3 {
        next_event(&mut owner, T, |e| e.kind == EventKind::Started as i32).await;
    }
    let victim = cluster.daemons.last_mut().unwrap();
    let t0 = Instant::now();
    victim.signal(sig);
    let ev = next_event(&mut owner, DETECT + Duration::from_millis(500), |e| {
        e.kind == EventKind::Lost as i32
    })
    .await;
    let detected = t0.elapsed();
    assert_eq!(ev.proc_id, on_c.as_str());
    assert_eq!(ev.host, "c");
    assert!(detected < DETECT, "lost after {detected:?}");
    let b = cluster.client(1).await;
    wait_hosts(
        &b,
        DETECT.saturating_sub(t0.elapsed()) + Duration::from_millis(100),
        |hs| hs.iter().any(|h| h.name == "c" && !h.alive),
    )
    .await;
    // No false alarm: a and b, with nice'd spinners on every core, still see each other.
    let a = cluster.client(0).await;
    let hosts = a.hosts().await.unwrap();
    assert!(
        hosts.iter().filter(|h| h.name != "c").all(|h| h.alive),
        "{hosts:#?}"
    );
    // New work avoids the lost host: two hosts left, three one-per-host is an error.
    let err = client.spawn(spin(&owner, 3)).await.unwrap_err();
    assert_eq!(err.code(), tonic::Code::FailedPrecondition);
    (cluster, detected)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn killed_daemon_is_lost_within_2s_and_rejoins_after_restart() {
    let (mut cluster, detected) = host_failure_is_detected(libc::SIGKILL).await;
    eprintln!("kill -9: LOST reported after {detected:?}");
    // Restart c (new port), joining through b: everyone sees it alive again.
    let old = cluster.daemons.pop().unwrap();
    drop(old);
    let join = cluster.daemons[1].addr.clone();
    let c = start_daemon(&cluster, "c", Some(&join), &[]);
    cluster.daemons.push(c);
    cluster.converge(T).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn stopped_daemon_is_lost_within_2s_and_comes_back_on_sigcont() {
    let (cluster, detected) = host_failure_is_detected(libc::SIGSTOP).await;
    eprintln!("kill -STOP: LOST reported after {detected:?}");
    cluster.daemons[2].signal(libc::SIGCONT);
    cluster.converge(T).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn sigterm_ends_children_reports_them_and_exits_cleanly() {
    let mut cluster = remds(2, &["--kill-grace-ms", "500"]);
    cluster.converge(T).await;
    let client = cluster.client(0).await;
    let mut owner = client.attach(None).await.unwrap();
    let job = client.spawn(spin(&owner, 2)).await.unwrap();
    let on_b = job
        .processes
        .iter()
        .find(|p| p.host == "b")
        .unwrap()
        .clone();
    next_event(&mut owner, T, |e| {
        e.proc_id == on_b.proc_id.as_str() && e.kind == EventKind::Started as i32
    })
    .await;
    cluster.daemons[1].signal(libc::SIGTERM);
    let ev = next_event(&mut owner, T, |e| {
        e.proc_id == on_b.proc_id.as_str() && e.kind != EventKind::Started as i32
    })
    .await;
    assert_eq!(ev.kind, EventKind::Exited as i32, "{ev:?}");
    assert_eq!(ev.signal, Some(libc::SIGTERM));
    let status = cluster.daemons[1].wait_exit(T).expect("remd did not exit");
    assert!(status.success(), "{status:?}");
    assert!(
        !std::path::Path::new(&format!("/proc/{}", on_b.pid)).exists()
            || proc_stat_field(on_b.pid, 3) == "Z"
    );
    // a marks it lost, and a restarted b rejoins.
    wait_hosts(&client, T, |hs| {
        hs.iter().any(|h| h.name == "b" && !h.alive)
    })
    .await;
    let join = cluster.daemons[0].addr.clone();
    let b = start_daemon(&cluster, "b", Some(&join), &[]);
    cluster.daemons[1] = b;
    cluster.converge(T).await;
}

/// A successor (a new job controller) adopts its predecessor's processes: their exit and
/// their host's loss are reported to it, and the exit no longer to the predecessor.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_adopted_process_reports_its_exit_and_its_hosts_loss_to_its_new_owner() {
    let cluster = remds(3, &[]);
    cluster.converge(T).await;
    let on_a = cluster.client(0).await;
    let mut first = on_a.attach(None).await.unwrap();
    let job = on_a.spawn(spin(&first, 3)).await.unwrap();
    for _ in 0..3 {
        next_event(&mut first, T, |e| e.kind == EventKind::Started as i32).await;
    }
    let on_b = cluster.client(1).await;
    let mut second = on_b.attach(None).await.unwrap();
    for p in &job.processes {
        let info = on_b.adopt(&p.proc_id, second.id()).await.unwrap();
        assert_eq!(info.owner, second.id().as_str());
        assert_eq!(info.state, "running");
    }
    let ps = on_a.ps().await.unwrap();
    for p in &job.processes {
        let listed = ps.iter().find(|i| i.proc_id == p.proc_id.as_str()).unwrap();
        assert_eq!(listed.owner, second.id().as_str(), "{listed:?}");
    }
    // The process on a exits: the new owner hears it, the old one does not.
    let on_host = |h: &str| {
        job.processes
            .iter()
            .find(|p| p.host == h)
            .unwrap()
            .proc_id
            .clone()
    };
    on_a.kill(&on_host("a")).await.unwrap();
    let ev = next_event(&mut second, T, |e| e.kind == EventKind::Exited as i32).await;
    assert_eq!(ev.proc_id, on_host("a").as_str());
    assert!(
        tokio::time::timeout(Duration::from_millis(500), async {
            loop {
                if let rem::Incoming::Event(e) = first.recv().await.unwrap() {
                    return e;
                }
            }
        })
        .await
        .is_err(),
        "the first owner still hears the adopted process"
    );
    // c is lost: b, where the new owner is attached, reports c's process LOST to it.
    let t0 = Instant::now();
    cluster.daemons[2].signal(libc::SIGKILL);
    let ev = next_event(&mut second, DETECT + Duration::from_millis(500), |e| {
        e.kind == EventKind::Lost as i32
    })
    .await;
    assert_eq!(ev.proc_id, on_host("c").as_str());
    eprintln!("adopted process LOST after {:?}", t0.elapsed());
    // An exited process cannot be adopted.
    let err = on_b.adopt(&on_host("a"), second.id()).await.unwrap_err();
    assert_eq!(err.code(), tonic::Code::NotFound, "{err}");
}
