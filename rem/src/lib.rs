//! REM, the remote execution manager (thesis section 4.2.4.1): a daemon (`remd`) on every
//! eligible host starts processes on the least-loaded hosts, carries their messages (so
//! applications open no sockets of their own), keeps checkpoints on more than one host and
//! reports load and failures. `rem` is the administrator's client; this library is also the
//! client that job owners (the SunRay III controller) and spawned processes (its workers) use.
//!
//! # Using REM from a program
//!
//! A job owner connects to its local remd, attaches to the relay (which gives it a process id
//! of its own), spawns workers owned by that id, then trades messages and receives events:
//!
//! ```no_run
//! # async fn demo() -> Result<(), rem::Error> {
//! use rem::{RemClient, Secret, SpawnRequest, Incoming};
//! let client = RemClient::connect("127.0.0.1:7077", Secret::new("s3cret")?).await?;
//! let mut relay = client.attach(Some("job-1")).await?;
//! let job = client
//!     .spawn(SpawnRequest {
//!         program: "/usr/local/bin/sunray".into(),
//!         args: vec!["worker".into()],
//!         nice: Some(10),
//!         count: 4,
//!         job: Some("job-1".into()),
//!         owner: Some(relay.id().clone()),
//!         ..SpawnRequest::default()
//!     })
//!     .await?;
//! relay.send(&job.processes[0].proc_id, b"hello".to_vec()).await?;
//! // recv() ends with Err(Error::Closed) when the stream ends.
//! while let Ok(incoming) = relay.recv().await {
//!     match incoming {
//!         Incoming::Message { from, payload } => { /* a worker's reply */ }
//!         Incoming::Event(ev) => { /* ev.kind: Started, Exited, Lost */ }
//!         Incoming::Undeliverable { to, reason } => { /* the target is gone */ }
//!     }
//! }
//! client.put_checkpoint("job-1", b"progress".to_vec()).await?;
//! # Ok(()) }
//! ```
//!
//! A spawned process attaches with one call, `RemClient::attach_from_env()`, which reads
//! `REM_ADDR`, `REM_PROC_ID`, `REM_PROC_TOKEN` (the process's own credential: processes never
//! see the cluster secret), `REM_JOB_ID`, `REM_OWNER_ID`,
//! and (with TLS) `REM_TLS_CA` / `REM_TLS_DOMAIN` (see [`wire::env`]).
//!
//! Messages are opaque bytes up to the daemon's limit (default 16 MiB, `--max-message`).
//! Delivery is in order per sender and receiver, with back-pressure through bounded queues;
//! what was in flight when a host or link fails may be lost (the owner gets `Lost` events).
//!
//! # Layout
//!
//! - [`proto`]: generated gRPC types (`proto/rem.proto`).
//! - [`error`]: [`Error`], and its mapping to gRPC status codes.
//! - [`ids`]: host names, job ids, [`ProcId`].
//! - [`auth`]: the cluster [`Secret`], the keys made from it, and the interceptors that send
//!   and check a user's key or a process's token.
//! - [`identity`]: who a client is (user, admin), users' keys and client-key files, and who
//!   may act on what (ownership).
//! - `peer_auth`: how daemons prove the secret to each other (HMAC) without sending it.
//! - `token`: random tokens (a spawned process attaches with its own).
//! - [`limits`]: the daemon's hard limits; `budget`: byte budgets of the relay's queues.
//! - [`policy`]: which programs (and first arguments) and environment names may be spawned.
//! - [`transport`]: channels, plain or TLS (rustls); [`cluster_files`]: the secret and TLS
//!   certificate a cluster's daemons share (`rem credentials`).
//! - [`cli`]: remd's flags (clap); [`config`]: remd settings from flags, environment and TOML.
//! - [`load`]: this host's load (sysinfo) and REM process count.
//! - [`cgroup`]: the CPU limit and use of remd's control group (containers).
//! - [`placement`]: ranking hosts by load per core.
//! - [`swim`]: the membership protocol (SWIM on foca, sealed datagrams, load reports,
//!   local health); [`membership`]: its UDP driver, joining, lost and returning hosts.
//! - [`peers`]: cached connections to other daemons.
//! - [`process`]: the OS processes REM runs here; [`child`]: building one (environment, nice).
//! - [`logbuf`]: bounded stdout / stderr keepers.
//! - [`relay`]: mailboxes and daemon-to-daemon links.
//! - [`attach`]: one process's relay stream.
//! - [`jobs`]: job owners and `Lost` reports.
//! - [`checkpoint`]: atomic checkpoint files; [`job_store`]: job records (epochs, retention);
//!   [`job_control`]: jobs the farm keeps running (`StartJob`, the supervisor, restarts);
//!   [`replicas`]: which peer keeps a key's second copy (rendezvous hashing).
//! - [`chunks`]: the content-addressed chunk cache (scenes in pieces, checked by hash, LRU);
//!   `chunk_sharing`: putting chunks on two hosts and fetching them from peers; [`blob`]:
//!   large byte strings as lists of chunks; [`process_cache`]: the folder where processes
//!   keep what they can rebuild (`REM_CACHE_DIR`), bounded, its contents untrusted.
//! - [`daemon`]: the daemon's operations; [`service`]: their gRPC face; [`server`]: wiring and shutdown.
//! - [`listener`]: the connection gate (caps, preface timeout, accept errors), [`bind_listener`],
//!   [`raise_fd_limit`].
//! - [`web`]: the web view (`remd --web`): the page, the JSON API, logins.
//! - [`embedded`]: a remd inside the current process (the embedded default, tests).
//! - [`wire`]: what client and daemon agree on (default address, limits, environment names).
//! - [`rpc`]: the generated client with the secret attached, under both of:
//! - [`client`]: [`RemClient`]; [`relay_client`]: [`Relay`] for job owners and processes.

mod attach;
pub mod auth;
pub mod blob;
mod budget;
mod cgroup;
mod checkpoint;
mod child;
mod chunk_sharing;
pub mod chunks;
pub mod cli;
pub mod client;
pub mod cluster_files;
pub mod config;
mod daemon;
pub mod embedded;
pub mod error;
pub mod identity;
pub mod ids;
pub mod job_control;
pub mod job_store;
mod jobs;
pub mod limits;
mod listener;
mod load;
mod logbuf;
mod membership;
mod peer_auth;
mod peers;
mod placement;
pub mod policy;
mod process;
pub mod process_cache;
mod relay;
pub mod relay_client;
pub mod replicas;
mod rpc;
pub mod server;
mod service;
pub mod swim;
mod token;
pub mod transport;
pub mod web;
pub mod wire;

/// Generated from `proto/rem.proto`.
#[allow(clippy::all, missing_docs)]
pub mod proto {
    tonic::include_proto!("rem.v1");
}

pub use auth::Secret;
pub use child::RunAs;
pub use client::{ConnectOptions, Credential, Job, RemClient, SpawnRequest};
pub use error::{Error, Result};
pub use identity::Identity;
pub use ids::ProcId;
pub use listener::{bind_listener, raise_fd_limit, ConnectionLimits};
pub use proto::{job_event::Kind as EventKind, HostInfo, JobEvent, JobRecord, ProcessInfo};
pub use relay_client::{Incoming, Relay, RelayReceiver, RelaySender};
