//! What the client library and the daemon agree on: the generated gRPC types, names and ids,
//! channels, the default address, message and batch limits, and the names of the environment
//! variables REM gives the processes it starts (and that the client reads). Nothing here
//! imports the rest of the crate but its [`Error`](crate::error::Error).
//!
//! # Layout
//!
//! - [`proto`]: generated gRPC types (`proto/rem.proto`).
//! - [`ids`]: host names, job ids, [`ProcId`](ids::ProcId).
//! - [`transport`]: channels, plain or TLS (rustls).
//! - [`chunk_name`]: a chunk's name, the SHA-256 of its bytes.
//! - [`protocol`]: the protocol a daemon speaks, and what it says of peers of another.
//! - this module: the default address, limits, remd's first lines of output, and [`env`].

pub mod chunk_name;
pub mod ids;
pub mod proto;
pub mod protocol;
pub mod transport;

/// Default address of remd and of the `rem` client.
pub const DEFAULT_ADDR: &str = "127.0.0.1:7077";
/// The port of [`DEFAULT_ADDR`].
pub const DEFAULT_PORT: u16 = 7077;
/// Default relay message size limit (bytes of one envelope's payload).
pub const DEFAULT_MAX_MESSAGE: usize = 16 << 20;
/// Bytes allowed in one gRPC message besides the relay payload limit (batches, headers).
pub const FRAME_OVERHEAD: usize = 1 << 20;
/// Largest number of envelopes (or peer items) sent in one batch.
pub const BATCH: usize = 512;
/// Bytes of envelopes in one batch (one envelope may be larger on its own).
pub const BATCH_BYTES: usize = 1 << 20;
/// Most hosts a spawn may ask to avoid (`SpawnRequest.avoid_hosts`).
pub const MAX_AVOID_HOSTS: usize = 1024;

/// What remd prints first on stdout, followed by the address it listens on, so whoever
/// started it with port 0 learns the port.
pub const LISTENING: &str = "remd listening on ";

/// The address in remd's first line of output ([`LISTENING`] ADDR), if it is that line.
pub fn listening_addr(line: &str) -> Option<&str> {
    line.trim().strip_prefix(LISTENING)
}

/// What remd prints on its second line of output when it serves the web view (`--web`),
/// followed by the page's URL.
pub const WEB_VIEW: &str = "remd web view on ";

/// The URL in remd's web view line ([`WEB_VIEW`] URL), if it is that line.
pub fn web_view_url(line: &str) -> Option<&str> {
    line.trim().strip_prefix(WEB_VIEW)
}

/// Environment variables every spawned process receives (and the client reads).
pub mod env {
    /// What every REM variable starts with (a spawn may not set these).
    pub const PREFIX: &str = "REM_";
    /// The token a spawned process attaches with (instead of the cluster secret, which
    /// processes never see).
    pub const PROC_TOKEN: &str = "REM_PROC_TOKEN";
    /// Address (`HOST:PORT`) of the local remd.
    pub const ADDR: &str = "REM_ADDR";
    /// This host's name.
    pub const HOST: &str = "REM_HOST";
    /// The process's own id (`HOST/NUMBER`).
    pub const PROC_ID: &str = "REM_PROC_ID";
    /// The job id.
    pub const JOB_ID: &str = "REM_JOB_ID";
    /// The process id of the job's owner (empty when the job has none).
    pub const OWNER_ID: &str = "REM_OWNER_ID";
    /// In a job's controller started by REM: the id of the job record it runs.
    pub const JOB_RECORD: &str = "REM_JOB_RECORD";
    /// In a job's controller started by REM: the epoch it runs at (its writes carry it).
    pub const JOB_EPOCH: &str = "REM_JOB_EPOCH";
    /// The render slots (threads) the process holds, when it was spawned with slots.
    pub const SLOTS: &str = "REM_SLOTS";
    /// Largest relay payload in bytes.
    pub const MAX_MESSAGE: &str = "REM_MAX_MESSAGE";
    /// The host's process cache: a folder for what a process can rebuild (see
    /// `process_cache`); its contents are not to be trusted.
    pub const CACHE_DIR: &str = "REM_CACHE_DIR";
    /// A file holding the cluster secret.
    pub const SECRET_FILE: &str = "REM_SECRET_FILE";
    /// The cluster secret itself (when no file is given).
    pub const SECRET: &str = "REM_SECRET";
    /// The user a holder of the cluster secret acts as (default: the login name).
    pub const USER: &str = "REM_USER";
    /// The CA certificate to trust for TLS to remd.
    pub const TLS_CA: &str = "REM_TLS_CA";
    /// The name to expect in remd's certificate.
    pub const TLS_DOMAIN: &str = "REM_TLS_DOMAIN";
}
