//! The relay: two processes on two daemons exchange 100,000 messages in order; checkpoints
//! survive the writing host.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a test: a failed unwrap is a failed test

use std::time::{Duration, Instant};

use crate::common::*;
use rem::{EventKind, Incoming, SpawnRequest};

const T: Duration = Duration::from_secs(10);

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn hundred_thousand_messages_between_two_daemons_in_order() {
    const N: u64 = 100_000;
    let cluster = in_process(2, |_| {}).await;
    cluster.converge(T).await;
    let client = cluster.client(0).await;
    let mut owner = client.attach(Some("relay-test")).await.unwrap();
    // One echo per host; use the one on b (the other daemon).
    let job = client
        .spawn(SpawnRequest {
            program: ECHO.into(),
            args: vec!["echo".into()],
            count: 2,
            owner: Some(owner.id().clone()),
            ..SpawnRequest::default()
        })
        .await
        .unwrap();
    let echo = job
        .processes
        .iter()
        .find(|p| p.host == "b")
        .unwrap()
        .proc_id
        .clone();
    assert_eq!(owner.host(), "a");

    // Wait until the echo has attached: until then b queues at most 4096 messages for it,
    // and the burst below would overflow that queue (a documented limit, not a loss).
    let probe = u64::MAX.to_le_bytes().to_vec();
    owner.send(&echo, probe.clone()).await.unwrap();
    tokio::time::timeout(T, async {
        loop {
            match owner.recv().await.unwrap() {
                Incoming::Message { payload, .. } if payload == probe => break,
                Incoming::Undeliverable { to, reason } => panic!("undeliverable to {to}: {reason}"),
                _ => {}
            }
        }
    })
    .await
    .expect("the echo attaches within 10 s");

    let sender = owner.sender();
    let to = echo.clone();
    let t0 = Instant::now();
    let send_all = tokio::spawn(async move {
        for i in 0..N {
            sender.send(&to, i.to_le_bytes().to_vec()).await.unwrap();
        }
    });
    let mut next = 0u64;
    tokio::time::timeout(Duration::from_secs(60), async {
        while next < N {
            match owner.recv().await.unwrap() {
                Incoming::Message { from, payload } => {
                    assert_eq!(from, echo.as_str());
                    let got = u64::from_le_bytes(payload.as_slice().try_into().unwrap());
                    assert_eq!(got, next, "out of order or lost");
                    next += 1;
                }
                Incoming::Event(e) => assert_ne!(e.kind, EventKind::Lost as i32, "{e:?}"),
                Incoming::Undeliverable { to, reason } => panic!("undeliverable to {to}: {reason}"),
            }
        }
    })
    .await
    .expect("all echoes within 60 s");
    send_all.await.unwrap();
    let secs = t0.elapsed().as_secs_f64();
    eprintln!(
        "{N} messages there and back in {secs:.2} s ({:.0} round trips/s, debug build)",
        N as f64 / secs
    );

    // Large messages (a compiled scene travels as one) pass whole and in order with small ones.
    let big: Vec<u8> = (0..6 << 20).map(|i: u32| (i % 251) as u8).collect();
    owner.send(&echo, big.clone()).await.unwrap();
    owner.send(&echo, b"after".to_vec()).await.unwrap();
    let mut got = Vec::new();
    while got.len() < 2 {
        if let Incoming::Message { payload, .. } = tokio::time::timeout(T, owner.recv())
            .await
            .unwrap()
            .unwrap()
        {
            got.push(payload);
        }
    }
    assert!(got[0] == big, "large message changed");
    assert_eq!(got[1], b"after");

    // Envelopes to a process that does not exist on a live host, or to an unknown host,
    // come back as undeliverable, in order.
    let ghost: rem::ProcId = "b/1".parse().unwrap();
    owner.send(&ghost, b"x".to_vec()).await.unwrap();
    let nowhere: rem::ProcId = "nohost/1".parse().unwrap();
    owner.send(&nowhere, b"x".to_vec()).await.unwrap();
    let mut notices = Vec::new();
    tokio::time::timeout(T, async {
        while notices.len() < 2 {
            if let Incoming::Undeliverable { to, .. } = owner.recv().await.unwrap() {
                notices.push(to);
            }
        }
    })
    .await
    .unwrap();
    notices.sort();
    assert_eq!(notices, ["b/1", "nohost/1"]);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn checkpoint_is_kept_on_two_hosts_and_survives_the_writer() {
    let mut cluster = remds(3, &[]);
    cluster.converge(T).await;
    let writer = cluster.client(0).await;
    assert_eq!(writer.get_checkpoint("job-ck").await.unwrap(), None);
    writer
        .put_checkpoint("job-ck", b"first".to_vec())
        .await
        .unwrap();
    let stored = writer
        .put_checkpoint("job-ck", b"second".to_vec())
        .await
        .unwrap();
    assert_eq!(stored.stored_on.len(), 2, "{stored:?}");
    assert_eq!(stored.stored_on[0], "a");
    // The writing host dies; the others still serve the newest version.
    cluster.daemons[0].signal(libc::SIGKILL);
    for i in 1..3 {
        let c = cluster.client(i).await;
        wait_hosts(&c, T, |hs| hs.iter().any(|h| h.name == "a" && !h.alive)).await;
        assert_eq!(
            c.get_checkpoint("job-ck").await.unwrap().as_deref(),
            Some(&b"second"[..])
        );
    }
    // Bad job ids are refused.
    let c = cluster.client(1).await;
    let err = c.put_checkpoint("../x", b"y".to_vec()).await.unwrap_err();
    assert_eq!(err.code(), tonic::Code::InvalidArgument);
    drop(cluster.daemons.remove(0));
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_process_can_attach_again_and_gets_what_was_sent_meanwhile() {
    let cluster = in_process(1, |_| {}).await;
    let admin = cluster.client(0).await;
    // A process that never attaches by itself; the test attaches in its name, with its token.
    let (id, env) = spawn_env_printer(&admin, "re", 30).await;
    let client = process_client(&cluster.addrs()[0], &env["REM_PROC_TOKEN"]).await;
    let sender = admin.attach(None).await.unwrap();
    let first = client.attach_as(&id, "re").await.unwrap();
    assert_eq!(first.id(), &id);
    let ps = admin.ps().await.unwrap();
    assert!(
        ps.iter()
            .find(|p| p.proc_id == id.as_str())
            .unwrap()
            .attached
    );
    // A second attachment while the first is live is refused.
    assert_eq!(
        client.attach_as(&id, "re").await.unwrap_err().code(),
        tonic::Code::FailedPrecondition
    );
    drop(first);
    // Once remd has seen it go (what was in flight on the broken connection may be lost) ...
    let end = Instant::now() + T;
    while admin
        .ps()
        .await
        .unwrap()
        .iter()
        .any(|p| p.proc_id == id.as_str() && p.attached)
    {
        assert!(Instant::now() < end, "detach not noticed");
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    // ... messages sent while it is away wait in its queue.
    for i in 0..3u8 {
        sender.send(&id, vec![i]).await.unwrap();
    }
    let end = Instant::now() + T;
    let mut again = loop {
        match client.attach_as(&id, "re").await {
            Ok(r) => break r,
            Err(e) => {
                assert_eq!(e.code(), tonic::Code::FailedPrecondition);
                assert!(Instant::now() < end, "could not attach again");
                tokio::time::sleep(Duration::from_millis(20)).await;
            }
        }
    };
    for i in 0..3u8 {
        let got = tokio::time::timeout(T, again.recv())
            .await
            .unwrap()
            .unwrap();
        assert_eq!(
            got,
            Incoming::Message {
                from: sender.id().to_string(),
                payload: vec![i]
            }
        );
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_blob_put_several_chunks_at_once_reads_back_in_order_from_the_other_host() {
    let cluster = in_process(2, |_| {}).await;
    cluster.converge(T).await;
    let (a, b) = (cluster.client(0).await, cluster.client(1).await);
    // 23 chunks of 1000 bytes (the last one short), each different.
    let data: Vec<u8> = (0..22_500u32).map(|i| (i * 7 + i / 1000) as u8).collect();
    let put = rem::client::blob::put(&a, &data.clone().into(), 1000)
        .await
        .unwrap();
    assert_eq!(put.chunks, rem::client::blob::chunk_names(&data, 1000));
    assert!(put.bytes_sent > 0, "each chunk was copied to the peer");
    let got = rem::client::blob::get(&b, &put.chunks, data.len() as u64)
        .await
        .unwrap();
    assert!(got.data == data, "the blob read back differs");
    assert!(
        got.cached,
        "b kept every chunk put through a: {} bytes fetched",
        got.bytes_fetched
    );
}
