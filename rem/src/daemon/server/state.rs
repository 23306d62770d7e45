//! Building one daemon's state from its settings: the state directory, the connections to
//! peers, the load gauge, membership, the relay, the process table and the stores, put
//! together in a [`Daemon`].

use std::net::SocketAddr;
use std::sync::atomic::{AtomicBool, AtomicU64};
use std::sync::Arc;
use std::time::{SystemTime, UNIX_EPOCH};

use tokio::sync::mpsc;
use tokio_util::sync::CancellationToken;

use crate::auth::peer_auth::DaemonKey;
use crate::daemon::config::DaemonSettings;
use crate::daemon::ops::Daemon;
use crate::daemon::process::table::{ProcessConfig, ProcessTable};
use crate::daemon::relay::jobs::Jobs;
use crate::daemon::relay::router::Router;
use crate::error::{Error, Result};
use crate::membership::driver::{Membership, MembershipConfig};
use crate::membership::load::LoadGauge;
use crate::membership::peers::PeerPool;
use crate::store::checkpoint::CheckpointStore;
use crate::store::chunks::ChunkStore;
use crate::store::job_store::JobStore;
use crate::store::process_cache::ProcessCache;
use crate::wire::{env, FRAME_OVERHEAD};

/// A daemon's state, started: the [`Daemon`] its services share, and what the server keeps
/// to run and stop it.
pub(super) struct Running {
    pub daemon: Arc<Daemon>,
    /// The address others reach this daemon at.
    pub advertise: String,
    /// Largest gRPC message (relay payload and overhead).
    pub max_frame: usize,
    /// The process cache, if it could be made (its trimming runs with the retention).
    pub process_cache: Option<ProcessCache>,
    /// A temporary state directory, removed when the daemon ends (no `state_dir` given).
    _temp_state: Option<tempfile::TempDir>,
}

impl Running {
    /// Builds and starts the state of a daemon whose gRPC listener is bound at `bound`.
    pub async fn start(settings: &DaemonSettings, bound: SocketAddr) -> Result<Running> {
        let key = DaemonKey::new(&settings.secret, &settings.name)?;
        let advertise = settings
            .advertise
            .clone()
            .unwrap_or_else(|| bound.to_string());
        let (state_dir, temp_state) = match &settings.state_dir {
            Some(d) => (d.clone(), None),
            None => {
                let t = tempfile::Builder::new().prefix("remd-state-").tempdir()?;
                (t.path().to_path_buf(), Some(t))
            }
        };
        let client_tls = settings.tls.as_ref().map(|t| t.client_tls()).transpose()?;
        let max_frame = settings.max_message + FRAME_OVERHEAD;
        let peers = PeerPool::new(key.clone(), client_tls, settings.insecure, max_frame);
        let gauge = LoadGauge::start(settings.load_interval, settings.slots, settings.owner_first);
        let accepting = Arc::new(AtomicBool::new(true));
        let stop = CancellationToken::new();
        let membership = start_membership(
            settings, bound, &advertise, &gauge, &accepting, &peers, &stop,
        )
        .await?;
        let (observer, observed) = mpsc::unbounded_channel();
        let router = Router::new(
            settings.queue,
            settings.limits.clone(),
            membership.clone(),
            peers.clone(),
            observer,
        );
        let start_ms = SystemTime::now()
            .duration_since(UNIX_EPOCH)
            .map_or(1, |d| d.as_millis() as u64);
        let seq = Arc::new(AtomicU64::new(start_ms));
        let process_cache = open_process_cache(settings, &state_dir);
        let processes = ProcessTable::start(
            ProcessConfig {
                host: settings.name.clone(),
                addr: advertise.clone(),
                policy: settings.policy.clone(),
                limits: settings.limits.clone(),
                base_env: child_env(settings),
                kill_grace: settings.kill_grace,
                run_as: settings.run_as,
                cache_dir: process_cache.as_ref().map(|c| c.dir().to_path_buf()),
            },
            router.clone(),
            gauge.rem_processes().clone(),
            gauge.slots().clone(),
            seq.clone(),
        );
        let jobs = Jobs::start(router.clone(), observed, membership.subscribe());
        let stores = Stores::open(settings, &state_dir, key)?;
        let daemon = Arc::new(Daemon {
            name: settings.name.clone(),
            max_message: settings.max_message,
            policy: settings.policy.clone(),
            limits: settings.limits.clone(),
            membership,
            router,
            processes,
            jobs,
            checkpoints: stores.checkpoints,
            chunks: stores.chunks,
            job_store: stores.job_store,
            peers,
            accepting,
            seq,
            stop,
            queue_memo: Default::default(),
        });
        Ok(Running {
            daemon,
            advertise,
            max_frame,
            process_cache,
            _temp_state: temp_state,
        })
    }
}

/// Binds membership's UDP socket (the gRPC listener's port) and starts the protocol.
async fn start_membership(
    settings: &DaemonSettings,
    bound: SocketAddr,
    advertise: &str,
    gauge: &LoadGauge,
    accepting: &Arc<AtomicBool>,
    peers: &PeerPool,
    stop: &CancellationToken,
) -> Result<Membership> {
    let udp = tokio::net::UdpSocket::bind(bound).await.map_err(|e| {
        Error::Config(format!(
            "cannot bind UDP {bound} for membership (the gRPC listener's port): {e}"
        ))
    })?;
    Membership::start(
        MembershipConfig {
            name: settings.name.clone(),
            addr: advertise.to_string(),
            join: settings.join.clone(),
            swim: settings.swim.clone(),
            // The daemons' key (a client-key file cannot make it): users cannot speak
            // the membership protocol.
            secret: settings
                .secret
                .daemon_key()
                .ok_or_else(|| Error::Config("a daemon needs the cluster secret".into()))?
                .to_vec(),
            protocol: settings.protocol,
        },
        udp,
        gauge.clone(),
        accepting.clone(),
        peers.clone(),
        stop.clone(),
    )
    .map_err(Error::from)
}

/// The host's process cache under `state_dir`, owned by the user children run as; `None`
/// (with a warning) when it cannot be made.
fn open_process_cache(
    settings: &DaemonSettings,
    state_dir: &std::path::Path,
) -> Option<ProcessCache> {
    let owner = settings.run_as.map(|u| (u.uid, u.gid));
    ProcessCache::open(
        &state_dir.join("cache"),
        settings.limits.process_cache_bytes,
        owner,
    )
    .map_err(|e| {
        tracing::warn!("no process cache for this host's processes: {e}");
        e
    })
    .ok()
}

/// The stores a daemon keeps under its state directory.
struct Stores {
    checkpoints: CheckpointStore,
    chunks: ChunkStore,
    job_store: JobStore,
}

impl Stores {
    fn open(
        settings: &DaemonSettings,
        state_dir: &std::path::Path,
        key: DaemonKey,
    ) -> Result<Stores> {
        let limits = &settings.limits;
        let checkpoints = CheckpointStore::open(
            &state_dir.join("checkpoints"),
            key.clone(),
            limits.checkpoint_bytes,
            limits.checkpoint_quota,
        )?;
        let records = CheckpointStore::open(
            &state_dir.join("jobs"),
            key,
            limits.checkpoint_bytes,
            limits.checkpoint_quota,
        )?;
        let chunks = ChunkStore::open(&state_dir.join("chunks"), limits.chunk_cache_bytes)?;
        let job_store = JobStore::new(records, checkpoints.clone());
        Ok(Stores {
            checkpoints,
            chunks,
            job_store,
        })
    }
}

/// Variables every child gets besides its own ids and token: how to reach remd. Never the
/// cluster secret: a process proves itself with its own token.
fn child_env(s: &DaemonSettings) -> Vec<(String, String)> {
    let mut out = vec![(env::MAX_MESSAGE.to_string(), s.max_message.to_string())];
    if let Some(tls) = &s.tls {
        let ca = tls.ca.as_ref().unwrap_or(&tls.cert);
        out.push((env::TLS_CA.into(), ca.display().to_string()));
        if let Some(d) = &tls.domain {
            out.push((env::TLS_DOMAIN.into(), d.clone()));
        }
    }
    out
}
