//! Render slots and the queue: a host never starts processes holding more slots than it
//! lends, a process learns its grant from REM_SLOTS and gives it back when it exits, a spawn
//! of "as many as fit" keeps what started, and `Queue` shares the farm's slots by priority and
//! then fairly between users, for any user to see.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a test: a failed unwrap is a failed test

use std::time::{Duration, Instant};

use crate::common::*;
use rem::{ConnectOptions, JobRecord, RemClient, Secret, SpawnRequest};
use tonic::Code;

const T: Duration = Duration::from_secs(10);

/// `rem-echo env 30` holding at least `min` and at most `max` slots, `count` of them.
fn env_printers(count: u32, (min, max): (u32, u32), up_to: bool) -> SpawnRequest {
    SpawnRequest {
        program: ECHO.into(),
        args: vec!["env".into(), "30".into()],
        count,
        slots_min: min,
        slots_max: max,
        up_to,
        allow_same_host: true,
        ..SpawnRequest::default()
    }
}

/// The REM_SLOTS that process `id` printed.
async fn printed_slots(c: &RemClient, id: &rem::ProcId) -> String {
    let end = Instant::now() + T;
    loop {
        let out = c.logs(id).await.unwrap().stdout;
        let text = String::from_utf8_lossy(&out).to_string();
        if text.contains("uid=") {
            return text
                .lines()
                .find_map(|l| l.strip_prefix("REM_SLOTS="))
                .unwrap_or("unset")
                .to_string();
        }
        assert!(Instant::now() < end, "rem-echo env printed nothing");
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
}

/// Waits until every host's reported slots in use are `used` (by name).
async fn wait_used(c: &RemClient, used: &[(&str, u32)]) {
    wait_hosts(c, T, |hs| {
        used.iter().all(|(name, n)| {
            hs.iter()
                .any(|h| h.name == *name && h.load.is_some_and(|l| l.slots_used == *n))
        })
    })
    .await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn hosts_start_no_more_slots_than_they_lend_and_get_them_back_at_exit() {
    let cluster = in_process(2, |s| s.slots = Some(if s.name == "a" { 2 } else { 1 })).await;
    cluster.converge(T).await;
    let c = cluster.client(0).await;
    wait_hosts(&c, T, |hs| {
        hs.iter()
            .any(|h| h.name == "b" && h.load.is_some_and(|l| l.slots == 1))
    })
    .await;
    // All that is free on each host: a gives 2, b gives 1.
    let both = c.spawn(env_printers(2, (1, 0), false)).await.unwrap();
    let mut got = Vec::new();
    for p in &both.processes {
        got.push((p.host.clone(), printed_slots(&c, &p.proc_id).await));
    }
    got.sort();
    assert_eq!(got, [("a".into(), "2".into()), ("b".into(), "1".into())]);
    wait_used(&c, &[("a", 2), ("b", 1)]).await;
    let ps = c.ps().await.unwrap();
    assert_eq!(ps.iter().map(|p| p.slots).sum::<u32>(), 3, "{ps:?}");
    // Nothing is free: refused, a clear RESOURCE_EXHAUSTED; a process holding no slots is
    // not counted and still starts.
    let err = c.spawn(env_printers(1, (1, 1), false)).await.unwrap_err();
    assert_eq!(err.code(), Code::ResourceExhausted, "{err}");
    assert!(err.to_string().contains("slots"), "{err}");
    let free_rider = c.spawn(env_printers(1, (0, 0), false)).await.unwrap();
    assert_eq!(
        printed_slots(&c, &free_rider.processes[0].proc_id).await,
        "unset"
    );
    // The process on a ends: its 2 slots come back, and "as many as fit" of 3 one-slot
    // processes starts 2 there.
    let on_a = both.processes.iter().find(|p| p.host == "a").unwrap();
    c.kill(&on_a.proc_id).await.unwrap();
    wait_used(&c, &[("a", 0), ("b", 1)]).await;
    let err = c.spawn(env_printers(3, (1, 1), false)).await.unwrap_err();
    assert_eq!(err.code(), Code::ResourceExhausted, "all or none: {err}");
    let some = c.spawn(env_printers(3, (1, 1), true)).await.unwrap();
    assert_eq!(some.processes.len(), 2, "{some:?}");
    assert!(some.processes.iter().all(|p| p.host == "a"));
    wait_used(&c, &[("a", 2), ("b", 1)]).await;
}

fn job(id: &str, priority: u32, wanted: u32) -> JobRecord {
    JobRecord {
        id: id.into(),
        state: "running".into(),
        epoch: 1,
        priority,
        slots_wanted: wanted,
        title: format!("{id}.yari"),
        ..JobRecord::default()
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_queue_shares_slots_by_priority_then_fairly_between_users() {
    let cluster = in_process(2, |s| {
        s.slots = Some(2);
        s.limits.user_slots = Some(3);
    })
    .await;
    cluster.converge(T).await;
    let as_user = |user: &str| {
        let key = Secret::new(cluster.secret().client_key_line(user).unwrap()).unwrap();
        RemClient::connect_with(ConnectOptions::new(cluster.addrs()[0].clone(), key))
    };
    let (alice, bob) = (
        as_user("alice").await.unwrap(),
        as_user("bob").await.unwrap(),
    );
    wait_hosts(&alice, T, |hs| {
        hs.iter()
            .filter(|h| h.load.is_some_and(|l| l.slots == 2))
            .count()
            == 2
    })
    .await;
    let created = |mut r: JobRecord, ms| {
        r.created_unix_ms = ms;
        r
    };
    alice.put_job(created(job("a1", 50, 4), 1)).await.unwrap();
    let q = bob.queue().await.unwrap();
    assert_eq!((q.slots, q.user_slots), (4, 3));
    assert_eq!(q.jobs.len(), 1);
    assert_eq!(
        (q.jobs[0].user.as_str(), q.jobs[0].share),
        ("alice", 3),
        "the user cap"
    );
    bob.put_job(created(job("b1", 50, 4), 2)).await.unwrap();
    let share = |q: &rem::wire::proto::QueueReply, id: &str| {
        let j = q.jobs.iter().find(|j| j.id == id).unwrap();
        (j.share, j.queue_position)
    };
    let q = alice.queue().await.unwrap();
    assert_eq!((share(&q, "a1"), share(&q, "b1")), ((2, 0), (2, 0)));
    // A priority-90 job takes what it wants; the younger of equal priority waits, first.
    alice.put_job(created(job("p", 90, 3), 3)).await.unwrap();
    let q = bob.queue().await.unwrap();
    assert_eq!(
        (share(&q, "p"), share(&q, "a1"), share(&q, "b1")),
        ((3, 0), (0, 1), (1, 0)),
        "alice's cap of 3 is held by p, so a1 waits"
    );
    let err = bob.put_job(job("high", 101, 1)).await.unwrap_err();
    assert_eq!(err.code(), Code::InvalidArgument, "{err}");
    // Ended jobs are not in the queue.
    let mut done = created(job("p", 90, 3), 3);
    done.state = "finished".into();
    alice.put_job(done).await.unwrap();
    let q = bob.queue().await.unwrap();
    assert_eq!(q.jobs.len(), 2);
    assert_eq!((share(&q, "a1"), share(&q, "b1")), ((2, 0), (2, 0)));
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_host_whose_owner_keeps_it_busy_lends_fewer_slots() {
    let cluster = in_process(1, |s| {
        s.slots = Some(2);
        s.owner_first = true;
        s.load_interval = Duration::from_millis(100);
    })
    .await;
    let c = cluster.client(0).await;
    // The owner's own work (not REM's): two threads spinning in this process.
    let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let spinners: Vec<_> = (0..2)
        .map(|_| {
            let stop = stop.clone();
            std::thread::spawn(move || {
                let mut x = 0u64;
                while !stop.load(std::sync::atomic::Ordering::Relaxed) {
                    x = std::hint::black_box(x.wrapping_add(1));
                }
            })
        })
        .collect();
    wait_hosts(&c, T, |hs| {
        hs.iter().any(|h| h.load.is_some_and(|l| l.slots < 2))
    })
    .await;
    let err = c.spawn(env_printers(1, (2, 2), false)).await.unwrap_err();
    assert_eq!(err.code(), Code::ResourceExhausted, "{err}");
    stop.store(true, std::sync::atomic::Ordering::Relaxed);
    for s in spinners {
        s.join().unwrap();
    }
}
