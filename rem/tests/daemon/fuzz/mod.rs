//! A fuzz run of remd's protobuf API (issue "Security"): inputs made from a fixed seed are sent
//! to every RPC of both services (`Rem` and `Peer`) of two real, joined remd processes, and
//! neither may exit nor stop answering.
//!
//! Each input is one call: its body is (a) raw random bytes, (b) a valid message with hostile
//! field values (huge counts, `u32::MAX`, negative nice, long, empty, non-ASCII and NUL
//! strings, ids like `../x`, big maps), or (c) a valid message encoded, then mutated (bit
//! flips, truncation, duplicated and inserted bytes, overlong varints). Bodies go on the wire
//! as they are, through a pass-through codec ([`RawCodec`]). Half the inputs carry a valid
//! credential: the client key for `Rem`, a daemon's proof (made here with the daemon key of
//! the test secret, over the body's digest, as `peer_auth` wants) for `Peer`, so that fuzzed
//! bodies reach what lies behind the checks; the other half carry none, or garbage (wrong
//! keys, made-up process tokens, forged or stale proofs, the client key on `Peer`).
//!
//! `cargo test` sends 20,000 inputs; `REM_FUZZ_INPUTS=1000000` sends a million
//! (`cargo test --release -p rem --test daemon fuzz:: -- --nocapture` prints the figures).
//! `REM_FUZZ_SEED` changes the seed; `REM_FUZZ_ONLY=I,J,...` replays single inputs one at a
//! time (to minimise one that harmed a daemon: its index is printed).
//!
//! # Layout
//! - this module: the constants, the run (checks, tally) and the tests;
//! - [`rng`]: SplitMix64, the generator of each input;
//! - [`values`]: hostile values of every field type;
//! - [`bodies`]: a call's body: a valid message of each request type, raw bytes, mutations;
//! - [`inputs`]: every RPC of both services, and an input (RPC, body, credential);
//! - [`credentials`]: the client key, daemons' proofs and seals, put on a request;
//! - [`send`]: sending an input's bytes as they are, and what became of the call.
//!
//! [`RawCodec`]: send::RawCodec
#![allow(clippy::unwrap_used, clippy::expect_used)] // a test: a failed unwrap is a failed test

mod bodies;
mod credentials;
mod inputs;
mod rng;
mod send;
mod values;

use std::collections::{BTreeMap, BTreeSet};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use crate::common::*;
use credentials::{checkpoint_seal, client_key, fuzz_user, unix_ms};
use inputs::{Credential, Input, Rpc, Shape};
use prost::Message;
use rem::wire::proto;
use send::{send, Outcome};
use tokio::task::JoinSet;
use tonic::transport::{Channel, Endpoint};
use tonic::Code;
use values::{now_ns, World};

/// The fixed seed (`REM_FUZZ_SEED` overrides it).
const SEED: u64 = 0x5EC0_F022_2026;
/// Inputs sent inside `cargo test` (`REM_FUZZ_INPUTS` overrides it).
const DEFAULT_INPUTS: usize = 20_000;
/// Calls in flight at once.
const IN_FLIGHT: usize = 64;
/// Every this many inputs both daemons are checked (process alive, `hosts` answers).
const CHECK_EVERY: usize = 10_000;
/// A call not answered in this time counts as a hang.
const CALL_DEADLINE: Duration = Duration::from_secs(30);
/// How long a stream's answer is read before the call is dropped.
const STREAM_READ: Duration = Duration::from_millis(200);
/// The names the fuzzer signs peer calls as (never a real daemon's).
const FAKE_DAEMONS: [&str; 4] = ["fz0", "fz1", "fz2", "fz3"];
/// Extra daemon flags: rem-echo may only `exit` (so nothing heavy runs whatever the
/// arguments), and processes and checkpoints are bounded (the temp dir stays small).
const LIMITS: [&str; 8] = [
    "--limit",
    "host_processes=64",
    "--limit",
    "checkpoint_bytes=256K",
    "--limit",
    "checkpoint_quota=16M",
    "--limit",
    "log_quota=16M",
];

// ---------------------------------------------------------------------------------------
// The run.

fn env_number(name: &str) -> Option<u64> {
    let v = std::env::var(name).ok()?;
    let v = v.replace('_', "");
    match v.strip_prefix("0x") {
        Some(hex) => u64::from_str_radix(hex, 16).ok(),
        None => v.parse().ok(),
    }
}

/// Resident set size of a process, in MiB.
fn rss_mib(pid: i32) -> u64 {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).unwrap_or_default();
    let kb: u64 = status
        .lines()
        .find_map(|l| l.strip_prefix("VmRSS:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok())
        .unwrap_or(0);
    kb / 1024
}

/// The fuzzer's connection to a daemon. It takes header blocks of any size, so that a status
/// echoing a huge input arrives as a status instead of closing the connection (and failing
/// the calls in flight on it).
async fn channel(addr: &str) -> Channel {
    Endpoint::from_shared(format!("http://{addr}"))
        .unwrap()
        .tcp_nodelay(true)
        .http2_max_header_list_size(64 << 20)
        .connect()
        .await
        .unwrap()
}

/// Panics if a daemon exited, naming the inputs in flight.
fn check_alive(cluster: &mut RemdProcesses, in_flight: &Mutex<BTreeSet<usize>>, at: usize) {
    for d in &mut cluster.daemons {
        if let Ok(Some(status)) = d.child.try_wait() {
            panic!(
                "remd {} exited ({status}) after {at} inputs; inputs in flight: {:?} \
                 (replay with REM_FUZZ_ONLY=...)",
                d.name,
                in_flight.lock().unwrap()
            );
        }
    }
}

/// Panics unless every daemon answers `hosts` (with a valid client) within 5 s.
async fn check_answering(cluster: &RemdProcesses, at: usize) {
    for i in 0..cluster.daemons.len() {
        let answered = tokio::time::timeout(Duration::from_secs(5), async {
            cluster.client(i).await.hosts().await
        })
        .await;
        assert!(
            matches!(answered, Ok(Ok(_))),
            "remd {} did not answer hosts within 5 s after {at} inputs: {answered:?}",
            cluster.daemons[i].name
        );
    }
}

/// Counts by outcome, and by RPC and credential (valid or not).
#[derive(Default)]
struct Tally {
    outcomes: BTreeMap<Outcome, u64>,
    by_rpc: BTreeMap<(Rpc, bool), BTreeMap<Outcome, u64>>,
    /// The first message seen with each outcome, and its input.
    examples: BTreeMap<Outcome, (usize, String)>,
    hung: Vec<usize>,
}

impl Tally {
    fn add(&mut self, input: &Input, outcome: Outcome, message: String) {
        *self.outcomes.entry(outcome).or_default() += 1;
        self.examples
            .entry(outcome)
            .or_insert_with(|| (input.index, message));
        let valid = matches!(input.credential, Credential::Valid(_));
        *self
            .by_rpc
            .entry((input.rpc, valid))
            .or_default()
            .entry(outcome)
            .or_default() += 1;
        if outcome == Outcome::Hung {
            self.hung.push(input.index);
        }
    }

    fn print(&self) {
        let line = |m: &BTreeMap<Outcome, u64>| {
            m.iter()
                .map(|(o, n)| format!("{o} {n}"))
                .collect::<Vec<_>>()
                .join(", ")
        };
        println!("fuzz: status counts: {}", line(&self.outcomes));
        for ((rpc, valid), m) in &self.by_rpc {
            let cred = if *valid { "valid" } else { "none/garbage" };
            println!("fuzz:   {:<13} {cred:<12} {}", rpc.name(), line(m));
        }
        for (outcome, (index, message)) in &self.examples {
            let message: String = message.chars().take(160).collect();
            println!("fuzz: e.g. {outcome} (input {index}): {message:?}");
        }
    }
}

/// Sends inputs `indices` of `seed` to the cluster, `IN_FLIGHT` at a time, checking the
/// daemons as it goes; returns the tally.
async fn run(
    cluster: &mut RemdProcesses,
    seed: u64,
    indices: Vec<usize>,
    parallel: usize,
) -> Tally {
    let world = Arc::new(World {
        names: cluster.daemons.iter().map(|d| d.name.clone()).collect(),
        addrs: cluster.addrs(),
    });
    let mut channels = Vec::new();
    for addr in &world.addrs {
        channels.push(channel(addr).await);
    }
    let in_flight: Arc<Mutex<BTreeSet<usize>>> = Arc::default();
    let mut tally = Tally::default();
    let mut tasks: JoinSet<(Input, (Outcome, String))> = JoinSet::new();
    for (n, index) in indices.into_iter().enumerate() {
        while tasks.len() >= parallel {
            let (input, outcome) = tasks.join_next().await.unwrap().unwrap();
            in_flight.lock().unwrap().remove(&input.index);
            tally.add(&input, outcome.0, outcome.1);
        }
        if n > 0 && n % CHECK_EVERY == 0 {
            check_alive(cluster, &in_flight, n);
            check_answering(cluster, n).await;
        }
        in_flight.lock().unwrap().insert(index);
        let (world, channels) = (world.clone(), channels.clone());
        tasks.spawn(async move {
            let input = Input::make(seed, index, &world);
            let outcome = send(channels[input.daemon].clone(), &input, &world).await;
            (input, outcome)
        });
    }
    while let Some(done) = tasks.join_next().await {
        let (input, outcome) = done.unwrap();
        in_flight.lock().unwrap().remove(&input.index);
        tally.add(&input, outcome.0, outcome.1);
    }
    check_alive(cluster, &in_flight, usize::MAX);
    tally
}

/// Two joined remd processes that see each other.
async fn cluster() -> RemdProcesses {
    let rule = format!("{ECHO}:exit");
    let cluster = remds_allowing(2, &[&rule], &LIMITS);
    cluster.converge(Duration::from_secs(15)).await;
    cluster
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn fuzzed_requests_to_every_rpc_leave_both_daemons_alive_and_answering() {
    let seed = env_number("REM_FUZZ_SEED").unwrap_or(SEED);
    let only: Option<Vec<usize>> = std::env::var("REM_FUZZ_ONLY")
        .ok()
        .map(|v| v.split(',').map(|s| s.trim().parse().unwrap()).collect());
    let mut cluster = cluster().await;
    let rss_before: Vec<u64> = cluster.daemons.iter().map(|d| rss_mib(d.pid())).collect();
    let started = Instant::now();
    let tally = match only {
        // One at a time, so that a daemon's exit names its input.
        Some(indices) => {
            let mut tally = Tally::default();
            for i in indices {
                let t = run(&mut cluster, seed, vec![i], 1).await;
                let input = Input::make(
                    seed,
                    i,
                    &World {
                        names: cluster.daemons.iter().map(|d| d.name.clone()).collect(),
                        addrs: cluster.addrs(),
                    },
                );
                println!(
                    "fuzz: input {i}: {:?} {:?} {:?} -> {:?}",
                    input.rpc, input.shape, input.credential, t.outcomes
                );
                for (o, n) in t.outcomes {
                    *tally.outcomes.entry(o).or_default() += n;
                }
            }
            tally
        }
        None => {
            let n = env_number("REM_FUZZ_INPUTS").map_or(DEFAULT_INPUTS, |n| n as usize);
            run(&mut cluster, seed, (0..n).collect(), IN_FLIGHT).await
        }
    };
    let secs = started.elapsed().as_secs_f64();
    let inputs: u64 = tally.outcomes.values().sum();
    // Still there, answering, and still a cluster.
    check_answering(&cluster, inputs as usize).await;
    let names: Vec<String> = cluster.daemons.iter().map(|d| d.name.clone()).collect();
    for i in 0..cluster.daemons.len() {
        let c = cluster.client(i).await;
        wait_hosts(&c, Duration::from_secs(15), |hosts| {
            names
                .iter()
                .all(|n| hosts.iter().any(|h| &h.name == n && h.alive))
        })
        .await;
    }
    let mut alive = Vec::new();
    for d in &mut cluster.daemons {
        alive.push(format!(
            "{} {}",
            d.name,
            d.child.try_wait().unwrap().is_none()
        ));
    }
    let rss_after: Vec<u64> = cluster.daemons.iter().map(|d| rss_mib(d.pid())).collect();
    println!(
        "fuzz: seed {seed:#x}: {inputs} inputs in {secs:.1} s ({:.0} inputs/s); \
         daemons alive: {}; RSS MiB before {rss_before:?} after {rss_after:?}",
        inputs as f64 / secs,
        alive.join(", ")
    );
    tally.print();
    assert!(tally.hung.is_empty(), "calls that hung: {:?}", tally.hung);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_fuzzers_codec_and_credentials_reach_past_the_checks() {
    let cluster = cluster().await;
    let world = World {
        names: cluster.daemons.iter().map(|d| d.name.clone()).collect(),
        addrs: cluster.addrs(),
    };
    let ch = channel(&world.addrs[0]).await;
    let call = |rpc: Rpc, body: Vec<u8>, credential: Credential| {
        let input = Input {
            index: 0,
            daemon: 0,
            rpc,
            shape: Shape::Valid,
            frames: vec![body],
            credential,
        };
        let (ch, world) = (ch.clone(), world.clone());
        async move { send(ch, &input, &world).await.0 }
    };
    let ok = Outcome::Status(Code::Ok);
    let refused = Outcome::Status(Code::Unauthenticated);
    let valid = || Credential::Valid("fz0".into());
    // Rem: the client key passes, nothing or a wrong key does not.
    assert_eq!(call(Rpc::Hosts, Vec::new(), valid()).await, ok);
    assert_eq!(
        call(Rpc::Hosts, Vec::new(), Credential::None).await,
        refused
    );
    let wrong = Credential::ClientKey(vec![7; 32]);
    assert_eq!(call(Rpc::Hosts, Vec::new(), wrong).await, refused);
    // Peer: the fuzzer's proofs pass; the client key, a stale or misdirected proof do not.
    assert_eq!(call(Rpc::PsLocal, Vec::new(), valid()).await, ok);
    let key = Credential::ClientKey(client_key().to_vec());
    assert_eq!(call(Rpc::PsLocal, Vec::new(), key).await, refused);
    let stale = Credential::SignedAt("fz0".into(), "a".into(), unix_ms() - 60_000);
    assert_eq!(call(Rpc::PsLocal, Vec::new(), stale).await, refused);
    let elsewhere = Credential::SignedAt("fz0".into(), "b".into(), unix_ms());
    assert_eq!(call(Rpc::PsLocal, Vec::new(), elsewhere).await, refused);
    let other = Credential::SignedOtherBody("fz0".into());
    let kill = proto::KillLocalRequest {
        proc_id: "a/1".into(),
        acting: None,
    };
    assert_eq!(
        call(Rpc::KillLocal, kill.encode_to_vec(), other).await,
        refused
    );
    // A body with unknown fields is signed as the daemon re-encodes it.
    let mut has = proto::HasChunksRequest {
        hashes: vec!["0".repeat(64)],
    }
    .encode_to_vec();
    has.extend([0xF8, 0x01, 0x05]); // field 31, varint 5: unknown, dropped by decoding
    assert_eq!(call(Rpc::HasChunks, has, valid()).await, ok);
    // A checkpoint sealed as a daemon seals it is stored; with another seal it is not.
    let mut cp = proto::Checkpoint {
        job: "fuzz-job".into(),
        data: b"state".to_vec(),
        version: now_ns(),
        written_by: "fz0".into(),
        mac: Vec::new(),
        user: fuzz_user(),
        epoch: 0,
    };
    cp.mac = checkpoint_seal(&cp).to_vec();
    assert_eq!(
        call(Rpc::StoreReplica, cp.encode_to_vec(), valid()).await,
        ok
    );
    cp.mac[0] ^= 1;
    assert_ne!(
        call(Rpc::StoreReplica, cp.encode_to_vec(), valid()).await,
        ok
    );
    let got = cluster
        .client(0)
        .await
        .get_checkpoint("fuzz-job")
        .await
        .unwrap();
    assert_eq!(got.unwrap(), b"state");
}

/// FOUND BY THIS FUZZ RUN, now fixed (process ids are bounded, and so is every status
/// message). It was: a client's `Kill` (or `Logs`) of a process id
/// `b/999…` with ~100,000 digits, sent to daemon a, makes a forward `KillLocal` to b; b
/// answers NOT_FOUND with the id in its message, so the reply's `grpc-message` trailer is
/// over 100 KB; a's HTTP/2 client refuses such a header block (`GOAWAY ENHANCE_YOUR_CALM,
/// too_many_continuations`) and closes its one connection to b, which also carries the relay
/// link: envelopes queued towards b are dropped without a notice to their senders. A client
/// repeating the call keeps the link between two daemons broken (about 10 % of envelopes lost
/// in a 2 s trial). Minimised input: `Rem.Kill { proc_id: "b/" + "9" × 100_000 }` with the
/// client key, to daemon a.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn found_a_kill_of_a_long_process_id_loses_no_envelope_between_daemons() {
    let cluster = cluster().await;
    let a = cluster.client(0).await;
    let b = cluster.client(1).await;
    let sender = a.attach(None).await.unwrap();
    let mut receiver = b.attach(None).await.unwrap();
    let to = receiver.id().clone();
    let long = format!("b/{}", "9".repeat(100_000));
    let (sender_tx, mut sender_rx) = sender.split();
    let mut sent = 0u32;
    for _ in 0..20 {
        for _ in 0..20 {
            sender_tx
                .send(&to, sent.to_le_bytes().to_vec())
                .await
                .unwrap();
            sent += 1;
        }
        // Any answer is fine; what matters is what it does to the link a -> b.
        let kill = rem::wire::proto::KillRequest {
            proc_id: long.clone(),
        };
        let _ = a.rpc().kill(kill).await;
    }
    let mut delivered = 0u32;
    while let Ok(Ok(m)) = tokio::time::timeout(Duration::from_secs(3), receiver.recv()).await {
        if matches!(m, rem::Incoming::Message { .. }) {
            delivered += 1;
        }
    }
    let mut refused = 0u32;
    while let Ok(Ok(m)) = tokio::time::timeout(Duration::from_millis(500), sender_rx.recv()).await {
        if matches!(m, rem::Incoming::Undeliverable { .. }) {
            refused += 1;
        }
    }
    assert_eq!(
        delivered + refused,
        sent,
        "{sent} envelopes sent, {delivered} delivered, {refused} reported undeliverable: \
         the rest vanished"
    );
}
