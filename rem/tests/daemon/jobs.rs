//! Job records: kept on two hosts, listed from any, fenced by epoch, per user, and removed
//! (with their checkpoints) some time after the job ended.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a test: a failed unwrap is a failed test

use std::time::Duration;

use crate::common::*;
use rem::daemon::embedded::EmbeddedRemd;
use rem::{ConnectOptions, JobRecord, RemClient, Secret};
use tonic::Code;

const T: Duration = Duration::from_secs(10);

fn record(id: &str, state: &str, epoch: u64, done: u64) -> JobRecord {
    JobRecord {
        id: id.into(),
        state: state.into(),
        epoch,
        progress_done: done,
        progress_total: 64,
        app: b"scene.yari".to_vec(),
        ..JobRecord::default()
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_record_outlives_its_writers_host_and_an_old_epoch_cannot_overwrite_it() {
    let mut cluster = in_process(3, |_| {}).await;
    cluster.converge(T).await;
    let a = cluster.client(0).await;
    let stored = a.put_job(record("render", "running", 1, 10)).await.unwrap();
    assert_eq!(stored.len(), 2, "{stored:?}");
    // The controller moves: epoch 2 takes over, through another daemon.
    let b = cluster.client(1).await;
    b.put_job(record("render", "running", 2, 20)).await.unwrap();
    // The old controller (epoch 1) is refused everywhere it writes.
    let err = a
        .put_job(record("render", "finished", 1, 64))
        .await
        .unwrap_err();
    assert_eq!(err.code(), Code::Aborted, "{err}");
    // Whichever host wrote it dies: the record is listed by the others.
    let writer = stored[0].clone();
    let idx = cluster
        .daemons
        .iter()
        .position(|d| d.name() == writer)
        .unwrap();
    cluster.daemons.remove(idx).stop().await;
    let survivor = cluster.daemons[0].addr().to_string();
    let c = RemClient::connect(&survivor, cluster.secret())
        .await
        .unwrap();
    let end = std::time::Instant::now() + T;
    let jobs = loop {
        let jobs = c.list_jobs().await.unwrap();
        if !jobs.is_empty() || std::time::Instant::now() > end {
            break jobs;
        }
        tokio::time::sleep(Duration::from_millis(100)).await;
    };
    assert_eq!(jobs.len(), 1, "{jobs:?}");
    let r = &jobs[0];
    assert_eq!(
        (r.epoch, r.progress_done, r.state.as_str()),
        (2, 20, "running")
    );
    assert_eq!(
        r.user,
        rem::auth::identity::default_user(),
        "REM sets the user"
    );
    assert!(r.updated_unix_ms > 0, "REM sets the time");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn users_see_only_their_own_jobs_and_bad_records_are_refused() {
    let cluster = in_process(2, |_| {}).await;
    cluster.converge(T).await;
    let as_user = |user: &str| {
        let key = Secret::new(cluster.secret().client_key_line(user).unwrap()).unwrap();
        RemClient::connect_with(ConnectOptions::new(cluster.addrs()[0].clone(), key))
    };
    let alice = as_user("alice").await.unwrap();
    let mallory = as_user("mallory").await.unwrap();
    let mut forged = record("render", "running", 1, 0);
    forged.user = "mallory".into(); // ignored: REM sets the user from the caller
    alice.put_job(forged).await.unwrap();
    // Mallory's record of the same id, with a huge epoch, is hers alone.
    mallory
        .put_job(record("render", "running", u64::MAX, 0))
        .await
        .unwrap();
    let mine = alice.list_jobs().await.unwrap();
    assert_eq!(mine.len(), 1);
    assert_eq!((mine[0].user.as_str(), mine[0].epoch), ("alice", 1));
    alice
        .put_job(record("render", "running", 2, 5))
        .await
        .unwrap();
    let theirs = mallory.list_jobs().await.unwrap();
    assert_eq!(theirs.len(), 1);
    assert_eq!(theirs[0].user, "mallory");
    // An admin sees both.
    let mut opts = ConnectOptions::new(cluster.addrs()[1].clone(), cluster.secret());
    opts.admin = true;
    let admin = RemClient::connect_with(opts).await.unwrap();
    assert_eq!(admin.list_jobs().await.unwrap().len(), 2);
    for bad in [record("a/b", "running", 1, 0), record("j", "dancing", 1, 0)] {
        let err = alice.put_job(bad).await.unwrap_err();
        assert_eq!(err.code(), Code::InvalidArgument, "{err}");
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn ended_jobs_beyond_the_retention_go_with_their_checkpoints() {
    let dir = tempfile::tempdir().unwrap();
    let settings = || {
        let mut s = rem::daemon::config::DaemonSettings::new("a", Secret::new(SECRET).unwrap());
        s.state_dir = Some(dir.path().to_path_buf());
        s.limits.kept_jobs = 1;
        s
    };
    let remd = EmbeddedRemd::start(settings()).await.unwrap();
    let c = RemClient::connect(remd.addr(), Secret::new(SECRET).unwrap())
        .await
        .unwrap();
    for (id, state) in [
        ("old", "finished"),
        ("new", "finished"),
        ("live", "running"),
    ] {
        c.put_job(record(id, state, 1, 0)).await.unwrap();
        c.put_checkpoint(id, b"pixels".to_vec()).await.unwrap();
        c.put_checkpoint(&format!("{id}.seg1"), b"more".to_vec())
            .await
            .unwrap();
        tokio::time::sleep(Duration::from_millis(5)).await;
    }
    remd.stop().await;
    // The retention runs when the daemon starts (and every minute after).
    let remd = EmbeddedRemd::start(settings()).await.unwrap();
    let c = RemClient::connect(remd.addr(), Secret::new(SECRET).unwrap())
        .await
        .unwrap();
    let end = std::time::Instant::now() + T;
    let ids = loop {
        let mut ids: Vec<String> = c
            .list_jobs()
            .await
            .unwrap()
            .into_iter()
            .map(|r| r.id)
            .collect();
        ids.sort();
        if ids.len() <= 2 || std::time::Instant::now() > end {
            break ids;
        }
        tokio::time::sleep(Duration::from_millis(50)).await;
    };
    assert_eq!(ids, ["live", "new"]);
    assert!(c.get_checkpoint("old").await.unwrap().is_none());
    assert!(c.get_checkpoint("old.seg1").await.unwrap().is_none());
    assert!(c.get_checkpoint("new").await.unwrap().is_some());
    assert!(c.get_checkpoint("live.seg1").await.unwrap().is_some());
    remd.stop().await;
}

/// A checkpoint over the host's quota takes the place of ended jobs' checkpoints, oldest
/// first, and never of a running job's: then it is refused with a clear status.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn over_the_quota_ended_jobs_checkpoints_make_room() {
    let dir = tempfile::tempdir().unwrap();
    let mut s = rem::daemon::config::DaemonSettings::new("a", Secret::new(SECRET).unwrap());
    s.state_dir = Some(dir.path().to_path_buf());
    s.limits.checkpoint_quota = 100_000;
    let remd = EmbeddedRemd::start(s).await.unwrap();
    let c = RemClient::connect(remd.addr(), Secret::new(SECRET).unwrap())
        .await
        .unwrap();
    // Written in this order: oldest first by the daemon's clock, and by id where two share
    // a millisecond.
    for (id, state) in [
        ("a-old", "finished"),
        ("b-new", "cancelled"),
        ("live", "running"),
    ] {
        c.put_job(record(id, state, 1, 0)).await.unwrap();
        c.put_checkpoint(&format!("{id}.s0"), vec![1; 30_000])
            .await
            .unwrap();
    }
    // 90 KB kept: 30 KB more fit once the oldest ended job's checkpoint has gone.
    c.put_checkpoint("live.s1", vec![2; 30_000]).await.unwrap();
    assert!(c.get_checkpoint("a-old.s0").await.unwrap().is_none());
    assert!(c.get_checkpoint("b-new.s0").await.unwrap().is_some());
    c.put_checkpoint("live.s2", vec![3; 30_000]).await.unwrap();
    assert!(c.get_checkpoint("b-new.s0").await.unwrap().is_none());
    // Only the running job's are left: no room is made of them.
    let err = c
        .put_checkpoint("live.s3", vec![4; 30_000])
        .await
        .unwrap_err();
    assert!(err.to_string().contains("checkpoint quota"), "{err}");
    assert!(c.get_checkpoint("live.s0").await.unwrap().is_some());
    assert_eq!(c.list_jobs().await.unwrap().len(), 3, "records stay");
    remd.stop().await;
}
