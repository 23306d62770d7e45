//! `RemClient`: a connection to a (usually the local) remd, for the `rem` command, job
//! owners and spawned processes.

use crate::auth::secret::{Secret, SendSecret};
use crate::client::relay::Relay;
use crate::error::{Error, Result};
use crate::wire::ids::ProcId;
use crate::wire::proto::{self, rem_client};
use crate::wire::transport::{self, ClientTls};
use crate::wire::{env, DEFAULT_ADDR, DEFAULT_MAX_MESSAGE, FRAME_OVERHEAD};

pub use crate::client::rpc::RemRpc;
pub use crate::client::spawn::{Job, SpawnRequest, Spawned};

/// Where and how to connect.
#[derive(Clone, Debug)]
pub struct ConnectOptions {
    /// `HOST:PORT` (or an `http(s)://` URL).
    pub addr: String,
    /// What the client proves itself with.
    pub credential: Credential,
    /// Verify the daemon's TLS certificate with this; `None` = plain HTTP/2.
    pub tls: Option<ClientTls>,
    /// Largest relay payload this side sends (the daemon has its own limit).
    pub max_message: usize,
    /// The user to act as with the cluster secret (`None`: `REM_USER`, else the login name);
    /// a client-key file is always its own user's.
    pub user: Option<String>,
    /// Present the admin key (needs the cluster secret): act on every user's processes.
    pub admin: bool,
}

/// A client's credential.
#[derive(Clone, Debug)]
pub enum Credential {
    /// The cluster secret or a client key (`rem client-key`): the client key made from it is
    /// sent, never the secret.
    Secret(Secret),
    /// The token of a process REM started (`REM_PROC_TOKEN`): good only to attach as itself.
    ProcessToken(String),
}

impl ConnectOptions {
    /// Plain HTTP/2 to `addr` with `secret` and the default message limit.
    pub fn new(addr: impl Into<String>, secret: Secret) -> Self {
        ConnectOptions {
            addr: addr.into(),
            credential: Credential::Secret(secret),
            tls: None,
            max_message: DEFAULT_MAX_MESSAGE,
            user: None,
            admin: false,
        }
    }

    /// The same, acting as `user`.
    pub fn as_user(mut self, user: impl Into<String>) -> Self {
        self.user = Some(user.into());
        self
    }

    /// From the environment: `REM_ADDR` (default `127.0.0.1:7077`), the credential
    /// (`REM_PROC_TOKEN` in a process REM started, else `REM_SECRET_FILE` or `REM_SECRET`),
    /// `REM_TLS_CA` / `REM_TLS_DOMAIN`, `REM_MAX_MESSAGE`; the user is `REM_USER` or the login
    /// name (see [`crate::auth::identity::default_user`]).
    pub fn from_env() -> Result<Self> {
        let addr = std::env::var(env::ADDR)
            .ok()
            .filter(|a| !a.is_empty())
            .unwrap_or_else(|| DEFAULT_ADDR.into());
        let mut opts = match std::env::var(env::PROC_TOKEN)
            .ok()
            .filter(|t| !t.is_empty())
        {
            Some(token) => ConnectOptions {
                credential: Credential::ProcessToken(token),
                ..ConnectOptions::new(addr, Secret::new("unused")?)
            },
            None => ConnectOptions::new(addr, Secret::resolve(None)?.0),
        };
        opts.tls = ClientTls::from_env()?;
        if let Some(m) = std::env::var(env::MAX_MESSAGE)
            .ok()
            .and_then(|m| m.parse().ok())
        {
            opts.max_message = m;
        }
        Ok(opts)
    }
}

/// A kept checkpoint.
#[derive(Clone, Debug)]
pub struct StoredCheckpoint {
    /// Increases with every store of the same key.
    pub version: u64,
    /// Hosts that hold it.
    pub stored_on: Vec<String>,
}

/// A process's kept output.
#[derive(Clone, Debug)]
pub struct Logs {
    /// The last bytes of its standard output.
    pub stdout: Vec<u8>,
    /// The last bytes of its standard error.
    pub stderr: Vec<u8>,
    /// Whether older output was dropped to keep within the daemon's limit.
    pub truncated: bool,
    /// The offset (bytes written since the process started) of `stdout`'s first byte.
    pub stdout_start: u64,
    /// The offset of `stderr`'s first byte.
    pub stderr_start: u64,
}

/// A connection to a remd. Cheap to clone.
#[derive(Clone, Debug)]
pub struct RemClient {
    rpc: RemRpc,
    opts: ConnectOptions,
}

impl RemClient {
    /// Connects to `addr` (plain HTTP/2) with the cluster secret.
    pub async fn connect(addr: &str, secret: Secret) -> Result<Self> {
        RemClient::connect_with(ConnectOptions::new(addr, secret)).await
    }

    /// Connects with full options (TLS, message limit).
    pub async fn connect_with(opts: ConnectOptions) -> Result<Self> {
        let channel = transport::connect(&opts.addr, opts.tls.as_ref()).await?;
        let frame = opts.max_message + FRAME_OVERHEAD;
        let credential = match &opts.credential {
            Credential::Secret(s) => SendSecret::new(s, opts.user.as_deref(), opts.admin)?,
            Credential::ProcessToken(t) => SendSecret::process(t)?,
        };
        let rpc = rem_client::RemClient::with_interceptor(channel, credential)
            .max_decoding_message_size(frame)
            .max_encoding_message_size(frame);
        Ok(RemClient { rpc, opts })
    }

    /// Connects as described by the environment (see [`ConnectOptions::from_env`]).
    pub async fn from_env() -> Result<Self> {
        RemClient::connect_with(ConnectOptions::from_env()?).await
    }

    /// For a process started by REM: connects to `REM_ADDR` and attaches as `REM_PROC_ID`
    /// of job `REM_JOB_ID`, proving it with `REM_PROC_TOKEN`.
    pub async fn attach_from_env() -> Result<Relay> {
        let client = RemClient::from_env().await?;
        let id = std::env::var(env::PROC_ID)
            .ok()
            .and_then(|s| ProcId::parse(&s))
            .ok_or_else(|| Error::Config(format!("{} is not set to a process id", env::PROC_ID)))?;
        let job = std::env::var(env::JOB_ID).unwrap_or_default();
        let owner = std::env::var(env::OWNER_ID)
            .ok()
            .and_then(|s| ProcId::parse(&s));
        let max = client.options().max_message;
        Relay::open(client.rpc_mut(), max, Some(&id), &job, owner).await
    }

    /// How this client connected.
    pub fn options(&self) -> &ConnectOptions {
        &self.opts
    }

    /// The generated client, for calls this wrapper does not cover.
    pub fn rpc(&self) -> RemRpc {
        self.rpc.clone()
    }

    /// Every host known to the daemon, itself first.
    pub async fn hosts(&self) -> Result<Vec<proto::HostInfo>> {
        Ok(self
            .rpc
            .clone()
            .hosts(proto::HostsRequest {})
            .await?
            .into_inner()
            .hosts)
    }

    /// Places and starts processes; all or nothing.
    pub async fn spawn(&self, req: SpawnRequest) -> Result<Job> {
        let req = req.to_proto();
        let reply = self.rpc.clone().spawn(req).await?.into_inner();
        let processes = reply
            .processes
            .into_iter()
            .map(|p| {
                let proc_id = ProcId::parse(&p.proc_id).ok_or_else(|| {
                    Error::Invalid(format!("daemon sent a bad process id {:?}", p.proc_id))
                })?;
                Ok(Spawned {
                    proc_id,
                    host: p.host,
                    pid: p.pid,
                    slots: p.slots,
                })
            })
            .collect::<Result<Vec<_>>>()?;
        Ok(Job {
            id: reply.job,
            processes,
        })
    }

    /// Every REM process on the live hosts.
    pub async fn ps(&self) -> Result<Vec<proto::ProcessInfo>> {
        Ok(self
            .rpc
            .clone()
            .ps(proto::PsRequest {})
            .await?
            .into_inner()
            .processes)
    }

    /// Ends a process (SIGTERM to its process group, SIGKILL after the grace period).
    pub async fn kill(&self, id: &ProcId) -> Result<()> {
        self.rpc
            .clone()
            .kill(proto::KillRequest {
                proc_id: id.to_string(),
            })
            .await?;
        Ok(())
    }

    /// From now on the events of running process `id` (Exited, Lost) go to `owner`, a relay
    /// process attached through this daemon by the same user. Answers the process as its
    /// host lists it; `NotFound` once it has exited.
    pub async fn adopt(&self, id: &ProcId, owner: &ProcId) -> Result<proto::ProcessInfo> {
        let reply = self
            .rpc
            .clone()
            .adopt_process(proto::AdoptProcessRequest {
                proc_id: id.to_string(),
                owner: owner.to_string(),
            })
            .await?
            .into_inner();
        reply
            .process
            .ok_or_else(|| Error::NotFound(format!("process {id}")))
    }

    /// The kept stdout and stderr of a process.
    pub async fn logs(&self, id: &ProcId) -> Result<Logs> {
        self.logs_since(id, (0, 0)).await
    }

    /// The kept stdout and stderr of a process from the offsets `from` (stdout, stderr; bytes
    /// written since it started) on: a follower asks for what is new since its last read.
    pub async fn logs_since(&self, id: &ProcId, from: (u64, u64)) -> Result<Logs> {
        let r = self
            .rpc
            .clone()
            .logs(proto::LogsRequest {
                proc_id: id.to_string(),
                stdout_from: from.0,
                stderr_from: from.1,
            })
            .await?
            .into_inner();
        Ok(Logs {
            stdout: r.stdout,
            stderr: r.stderr,
            truncated: r.truncated,
            stdout_start: r.stdout_start,
            stderr_start: r.stderr_start,
        })
    }

    /// Stores `data` as the checkpoint of `job`, on this daemon's host and one more.
    pub async fn put_checkpoint(&self, job: &str, data: Vec<u8>) -> Result<StoredCheckpoint> {
        self.put_checkpoint_fenced(job, data, 0, "").await
    }

    /// [`put_checkpoint`](Self::put_checkpoint) by the controller of epoch `epoch` of job
    /// record `fence_job` (empty: `job`): refused ([`Error::is_fenced`]) where a newer epoch
    /// is known.
    pub async fn put_checkpoint_fenced(
        &self,
        job: &str,
        data: Vec<u8>,
        epoch: u64,
        fence_job: &str,
    ) -> Result<StoredCheckpoint> {
        if data.len() > self.opts.max_message {
            return Err(Error::TooLarge {
                size: data.len(),
                limit: self.opts.max_message,
            });
        }
        let r = self
            .rpc
            .clone()
            .put_checkpoint(proto::PutCheckpointRequest {
                job: job.to_string(),
                data,
                epoch,
                fence_job: fence_job.to_string(),
            })
            .await?
            .into_inner();
        Ok(StoredCheckpoint {
            version: r.version,
            stored_on: r.stored_on,
        })
    }

    /// The newest checkpoint of `job` on any live host.
    pub async fn get_checkpoint(&self, job: &str) -> Result<Option<Vec<u8>>> {
        let r = self
            .rpc
            .clone()
            .get_checkpoint(proto::GetCheckpointRequest {
                job: job.to_string(),
            })
            .await?;
        Ok(r.into_inner().checkpoint.map(|c| c.data))
    }

    /// Stores the record of one of your jobs on this daemon's host and one more; refused
    /// ([`Error::is_fenced`]) when a record of a newer epoch is kept, or the job has ended.
    /// Returns the hosts.
    pub async fn put_job(&self, record: proto::JobRecord) -> Result<Vec<String>> {
        let r = self
            .rpc
            .clone()
            .put_job(proto::PutJobRequest {
                record: Some(record),
            })
            .await?;
        Ok(r.into_inner().stored_on)
    }

    /// The newest record of each of your jobs on the live hosts (every user's as admin).
    pub async fn list_jobs(&self) -> Result<Vec<proto::JobRecord>> {
        let r = self
            .rpc
            .clone()
            .list_jobs(proto::ListJobsRequest {})
            .await?;
        Ok(r.into_inner().records)
    }

    /// The farm's queue: every user's active jobs with their shares of the slots.
    pub async fn queue(&self) -> Result<proto::QueueReply> {
        let r = self.rpc.clone().queue(proto::QueueRequest {}).await?;
        Ok(r.into_inner())
    }

    /// Stores a new job (epoch 1) and starts its controller, `record.controller_spawn`, on
    /// the host that spawn names, or else on the least-loaded live host when `anywhere`, or
    /// else on this daemon's host; the daemons keep it running from then on. Returns the
    /// record as stored.
    pub async fn start_job(
        &self,
        record: proto::JobRecord,
        anywhere: bool,
    ) -> Result<proto::JobRecord> {
        let r = self
            .rpc
            .clone()
            .start_job(proto::StartJobRequest {
                record: Some(record),
                controller_anywhere: anywhere,
            })
            .await?;
        r.into_inner()
            .record
            .ok_or_else(|| Error::Invalid("the daemon sent no job record".into()))
    }

    /// Caches chunk `hash` (the SHA-256 of `data`, see [`crate::wire::chunk_name::name_of`]) on
    /// this daemon's host and on one more.
    pub async fn put_chunk(&self, hash: &str, data: bytes::Bytes) -> Result<proto::PutChunkReply> {
        let req = proto::PutChunkRequest {
            hash: hash.to_string(),
            data,
        };
        Ok(self.rpc.clone().put_chunk(req).await?.into_inner())
    }

    /// Chunk `hash`, from this daemon's cache or through it from a peer (checked).
    pub async fn get_chunk(&self, hash: &str) -> Result<proto::GetChunkReply> {
        let req = proto::GetChunkRequest {
            hash: hash.to_string(),
        };
        let reply = self.rpc.clone().get_chunk(req).await?.into_inner();
        if crate::wire::chunk_name::name_of(&reply.data) != hash {
            return Err(Error::Invalid(format!(
                "the daemon sent chunk {hash} with other bytes"
            )));
        }
        Ok(reply)
    }

    /// Attaches to the relay as a new process (a job owner); `job` is informational.
    pub async fn attach(&self, job: Option<&str>) -> Result<Relay> {
        let max = self.options().max_message;
        Relay::open(self.rpc_mut(), max, None, job.unwrap_or_default(), None).await
    }

    /// Attaches as an already spawned process `id` (what [`RemClient::attach_from_env`] does).
    pub async fn attach_as(&self, id: &ProcId, job: &str) -> Result<Relay> {
        let max = self.options().max_message;
        Relay::open(self.rpc_mut(), max, Some(id), job, None).await
    }

    pub(crate) fn rpc_mut(&self) -> RemRpc {
        self.rpc.clone()
    }
}
