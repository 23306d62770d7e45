//! REM benchmark: relay throughput and round-trip latency through two daemons, spawn latency,
//! failure-detection time. Run with `cargo bench -p rem --bench relay`.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a measurement tool: a failure ends it with a message

use std::time::{Duration, Instant};

use rem::testing::{next_event, wait_hosts, LocalRemds, RemdProcesses};
use rem::{EventKind, Incoming, ProcId, Relay, SpawnRequest};

const REMD: &str = env!("CARGO_BIN_EXE_remd");
const ECHO: &str = env!("CARGO_BIN_EXE_rem-echo");

const T: Duration = Duration::from_secs(30);

fn main() {
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .unwrap();
    rt.block_on(run());
}

async fn next_message(relay: &mut Relay) -> Vec<u8> {
    loop {
        if let Incoming::Message { payload, .. } = relay.recv().await.unwrap() {
            return payload;
        }
    }
}

/// Waits until the processes have attached to the relay (before that, only a bounded number
/// of messages is kept for them).
async fn wait_attached(client: &rem::RemClient, ids: &[&ProcId]) {
    let end = Instant::now() + T;
    loop {
        let ps = client.ps().await.unwrap();
        if ids
            .iter()
            .all(|id| ps.iter().any(|p| p.proc_id == id.as_str() && p.attached))
        {
            return;
        }
        assert!(Instant::now() < end, "processes did not attach");
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
}

fn percentile(sorted: &[Duration], p: f64) -> Duration {
    sorted[((sorted.len() - 1) as f64 * p).round() as usize]
}

async fn run() {
    let mut cluster = RemdProcesses::new(REMD, "bench-cluster-secret");
    cluster.start_all(3, |_| {
        vec!["--allow".into(), ECHO.into(), "--allow-any-args".into()]
    });
    cluster.converge(T).await;
    let client = cluster.client(0).await;
    let mut owner = client.attach(Some("bench")).await.unwrap();
    let spawn_on_b = |args: Vec<&str>, owner: ProcId| SpawnRequest {
        program: ECHO.into(),
        args: args.into_iter().map(String::from).collect(),
        count: 3,
        owner: Some(owner),
        ..SpawnRequest::default()
    };

    // Throughput: a on host a -> sink on host b, 32-byte messages.
    const N: u64 = 500_000;
    let job = client
        .spawn(spawn_on_b(vec!["sink", &N.to_string()], owner.id().clone()))
        .await
        .unwrap();
    let sink = job
        .processes
        .iter()
        .find(|p| p.host == "b")
        .unwrap()
        .proc_id
        .clone();
    wait_attached(&client, &[&sink]).await;
    // Warm up the path (one full round).
    for round in 0..2 {
        let sender = owner.sender();
        let to = sink.clone();
        let t0 = Instant::now();
        tokio::spawn(async move {
            for i in 0..N {
                let mut m = vec![0u8; 32];
                m[..8].copy_from_slice(&i.to_le_bytes());
                sender.send(&to, m).await.unwrap();
            }
        });
        let done = tokio::time::timeout(T, next_message(&mut owner))
            .await
            .expect("sink answered");
        assert_eq!(done, b"done");
        let secs = t0.elapsed().as_secs_f64();
        if round == 1 {
            println!(
                "relay throughput: {N} messages of 32 bytes a->b in {secs:.3} s = {:.0} messages/s",
                N as f64 / secs
            );
        }
    }

    // Round trip: a -> echo on b -> a, one message at a time.
    let job = client
        .spawn(spawn_on_b(vec!["echo"], owner.id().clone()))
        .await
        .unwrap();
    let echo = job
        .processes
        .iter()
        .find(|p| p.host == "b")
        .unwrap()
        .proc_id
        .clone();
    wait_attached(&client, &[&echo]).await;
    let mut times = Vec::new();
    for i in 0..21_000u32 {
        let t0 = Instant::now();
        owner.send(&echo, i.to_le_bytes().to_vec()).await.unwrap();
        let back = next_message(&mut owner).await;
        if i >= 1000 {
            times.push(t0.elapsed());
        }
        assert_eq!(back, i.to_le_bytes());
    }
    times.sort();
    println!(
        "round trip a->b->a (20,000 sequential): p50 {:?}  p99 {:?}  max {:?}",
        percentile(&times, 0.5),
        percentile(&times, 0.99),
        times.last().unwrap()
    );

    // Spawn latency: request -> reply (processes started), and -> Started event.
    let mut local = Vec::new();
    let mut all3 = Vec::new();
    for i in 0..20 {
        let count = if i % 2 == 0 { 1 } else { 3 };
        let t0 = Instant::now();
        let job = client
            .spawn(SpawnRequest {
                program: ECHO.into(),
                args: vec!["exit".into(), "0".into()],
                count,
                owner: Some(owner.id().clone()),
                ..SpawnRequest::default()
            })
            .await
            .unwrap();
        let d = t0.elapsed();
        if count == 1 {
            local.push(d)
        } else {
            all3.push(d)
        }
        let mut exited = 0;
        while exited < job.processes.len() {
            if let Incoming::Event(e) = owner.recv().await.unwrap() {
                if e.kind == EventKind::Exited as i32 {
                    exited += 1;
                }
            }
        }
    }
    local.sort();
    all3.sort();
    println!(
        "spawn latency (request to reply, processes running): 1 process p50 {:?}; 3 processes on 3 hosts p50 {:?}",
        percentile(&local, 0.5),
        percentile(&all3, 0.5)
    );

    // Failure detection (default probe 200 ms, suspected for 400 ms): kill -9 c.
    let b = cluster.client(1).await;
    let job = client
        .spawn(SpawnRequest {
            program: ECHO.into(),
            args: vec!["spin".into(), "30".into()],
            nice: Some(19),
            count: 3,
            owner: Some(owner.id().clone()),
            ..SpawnRequest::default()
        })
        .await
        .unwrap();
    let on_c = job
        .processes
        .iter()
        .find(|p| p.host == "c")
        .unwrap()
        .proc_id
        .clone();
    let t0 = Instant::now();
    cluster.daemons[2].signal(libc::SIGKILL);
    // Every process of the bench on c is reported (the sink and echo too); time the first.
    let mut first = None;
    loop {
        let ev = next_event(&mut owner, T, |e| e.kind == EventKind::Lost as i32).await;
        assert_eq!(ev.host, "c");
        first.get_or_insert(t0.elapsed());
        if ev.proc_id == on_c.as_str() {
            break;
        }
    }
    let to_event = first.unwrap();
    wait_hosts(&b, T, |hs| hs.iter().any(|h| h.name == "c" && !h.alive)).await;
    let to_b = t0.elapsed();
    println!("failure detection (kill -9): owner got LOST after {to_event:?}; host b marked c lost by {to_b:?}");
}
