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
//! The crate has one folder per concern; dependencies point down this list (a folder uses
//! those above it, never one below):
//!
//! - [`error`]: [`Error`], and its mapping to gRPC status codes.
//! - [`wire`]: what client and daemon agree on: the generated gRPC types ([`wire::proto`]),
//!   ids ([`ProcId`]), channels (plain or TLS), limits and environment names.
//! - [`auth`]: the cluster [`Secret`] and the keys made from it, users and admins
//!   ([`Identity`]), daemons proving the secret to each other, process tokens, and the
//!   files a cluster's daemons share.
//! - [`store`]: what a daemon keeps on disk: checkpoints, job records, chunks, the process
//!   cache, and which peer keeps a key's second copy.
//! - [`membership`]: which daemons are alive and their load (SWIM), and the connections to
//!   them.
//! - [`client`]: [`RemClient`], [`Relay`] for job owners and processes, blobs as chunks.
//! - [`daemon`]: remd: settings (the `remd` binary parses the flags), state and operations,
//!   the relay, processes, the gRPC and web faces, the server that wires them, and
//!   [`bind_listener`] / [`raise_fd_limit`].
//! - `testing` (feature `testing`): the test harness, remd daemons on loopback.

pub mod auth;
pub mod client;
pub mod daemon;
pub mod error;
pub mod membership;
pub mod store;
#[cfg(feature = "testing")]
pub mod testing;
pub mod wire;

pub use auth::identity::Identity;
pub use auth::secret::Secret;
pub use client::relay::{Incoming, Relay, RelayReceiver, RelaySender};
pub use client::rem_client::{ConnectOptions, Credential, Job, RemClient, SpawnRequest};
pub use daemon::listener::{bind_listener, raise_fd_limit, ConnectionLimits};
pub use daemon::process::child::RunAs;
pub use error::{Error, Result};
pub use wire::ids::ProcId;
pub use wire::proto::{job_event::Kind as EventKind, HostInfo, JobEvent, JobRecord, ProcessInfo};
