//! Wiring of one daemon: builds the actors, serves both services and health on a listener,
//! and shuts down in order when told to.
//!
//! Shutdown (SIGTERM in `remd`): stop accepting work (spawns get `UNAVAILABLE`, health says
//! NOT_SERVING, peers see `accepting = false`), end every child (SIGTERM, SIGKILL after the
//! grace period; their owners get `EXITED`), end relay streams, stop the server. Children are
//! ended, not handed off: a job's owner sees them exit and can place new ones.

pub(crate) mod attach;
pub(crate) mod service;

use std::future::Future;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use tokio::net::TcpListener;
use tokio::sync::mpsc;
use tokio_util::sync::CancellationToken;
use tonic::service::interceptor::InterceptedService;
use tonic::transport::Server;

use crate::auth::secret::RequireSecret;
use crate::store::checkpoint::CheckpointStore;
use crate::daemon::config::DaemonSettings;
use crate::daemon::ops::Daemon;
use crate::error::{Error, Result};
use crate::store::job_store::JobStore;
use crate::daemon::relay::jobs::Jobs;
use crate::daemon::listener::Gate;
use crate::membership::load::LoadGauge;
use crate::membership::driver::{Membership, MembershipConfig};
use crate::auth::peer_auth::DaemonKey;
use crate::membership::peers::PeerPool;
use crate::daemon::process::table::{ProcessConfig, ProcessTable};
use crate::wire::proto::{peer_server::PeerServer, rem_server::RemServer};
use crate::daemon::relay::router::Router;
use crate::daemon::server::service::Service;
use crate::wire::env;

use crate::wire::FRAME_OVERHEAD;

/// Runs a daemon on `listener` until `shutdown` completes, then shuts down cleanly; with
/// `settings.web`, its web view too.
pub async fn run(
    settings: DaemonSettings,
    listener: TcpListener,
    shutdown: impl Future<Output = ()>,
) -> Result<()> {
    run_with_web(settings, listener, None, shutdown).await
}

/// [`run`], serving the web view on `web` (bound by the caller, to print its address) or,
/// when that is `None`, on `settings.web` if set.
pub async fn run_with_web(
    settings: DaemonSettings,
    listener: TcpListener,
    web: Option<TcpListener>,
    shutdown: impl Future<Output = ()>,
) -> Result<()> {
    let web = match (web, settings.web) {
        (Some(l), _) => Some(l),
        (None, Some(addr)) => Some(
            crate::bind_listener(addr)
                .map_err(|e| Error::Config(format!("cannot serve the web view on {addr}: {e}")))?,
        ),
        (None, None) => None,
    };
    let bound = listener.local_addr()?;
    if settings.tls.is_none() && !bound.ip().is_loopback() {
        if !settings.insecure {
            return Err(Error::Config(format!(
                "refusing to listen on {bound} without TLS: anyone on the network could read \
                 the relay; configure --tls-cert/--tls-key, or pass --insecure"
            )));
        }
        tracing::warn!(%bound, "INSECURE: listening off loopback without TLS (--insecure)");
    }
    // SAFETY: geteuid has no preconditions.
    if unsafe { libc::geteuid() } == 0 && settings.run_as.is_none() {
        tracing::warn!(
            "remd runs as root and no --run-as is set: spawned processes run as root too"
        );
    }
    let key = DaemonKey::new(&settings.secret, &settings.name)?;
    let advertise = settings
        .advertise
        .clone()
        .unwrap_or_else(|| bound.to_string());
    let _temp_state;
    let state_dir = match &settings.state_dir {
        Some(d) => d.clone(),
        None => {
            let t = tempfile::Builder::new().prefix("remd-state-").tempdir()?;
            let p = t.path().to_path_buf();
            _temp_state = t;
            p
        }
    };
    let client_tls = settings.tls.as_ref().map(|t| t.client_tls()).transpose()?;
    let max_frame = settings.max_message + FRAME_OVERHEAD;
    let peers = PeerPool::new(key.clone(), client_tls, settings.insecure, max_frame);
    let gauge = LoadGauge::start(settings.load_interval);
    let accepting = Arc::new(AtomicBool::new(true));
    let stop = CancellationToken::new();
    // Membership datagrams use the listener's port, over UDP.
    let udp = tokio::net::UdpSocket::bind(bound).await.map_err(|e| {
        Error::Config(format!(
            "cannot bind UDP {bound} for membership (the gRPC listener's port): {e}"
        ))
    })?;
    let membership = Membership::start(
        MembershipConfig {
            name: settings.name.clone(),
            addr: advertise.clone(),
            join: settings.join.clone(),
            swim: settings.swim.clone(),
            // The daemons' key (a client-key file cannot make it): users cannot speak
            // the membership protocol.
            secret: settings
                .secret
                .daemon_key()
                .ok_or_else(|| Error::Config("a daemon needs the cluster secret".into()))?
                .to_vec(),
        },
        udp,
        gauge.clone(),
        accepting.clone(),
        peers.clone(),
        stop.clone(),
    )?;
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
    let owner = settings.run_as.map(|u| (u.uid, u.gid));
    let process_cache = crate::store::process_cache::ProcessCache::open(
        &state_dir.join("cache"),
        settings.limits.process_cache_bytes,
        owner,
    )
    .map_err(|e| {
        tracing::warn!("no process cache for this host's processes: {e}");
        e
    })
    .ok();
    let processes = ProcessTable::start(
        ProcessConfig {
            host: settings.name.clone(),
            addr: advertise.clone(),
            policy: settings.policy.clone(),
            limits: settings.limits.clone(),
            base_env: child_env(&settings),
            kill_grace: settings.kill_grace,
            run_as: settings.run_as,
            cache_dir: process_cache.as_ref().map(|c| c.dir().to_path_buf()),
        },
        router.clone(),
        gauge.rem_processes().clone(),
        seq.clone(),
    );
    let jobs = Jobs::start(router.clone(), observed, membership.subscribe());
    let checkpoints = CheckpointStore::open(
        &state_dir.join("checkpoints"),
        key.clone(),
        settings.limits.checkpoint_bytes,
        settings.limits.checkpoint_quota,
    )?;
    let records = CheckpointStore::open(
        &state_dir.join("jobs"),
        key,
        settings.limits.checkpoint_bytes,
        settings.limits.checkpoint_quota,
    )?;
    let chunks = crate::store::chunks::ChunkStore::open(
        &state_dir.join("chunks"),
        settings.limits.chunk_cache_bytes,
    )?;
    let job_store = JobStore::new(records, checkpoints.clone());
    tokio::spawn(retention(
        job_store.clone(),
        process_cache,
        settings.limits.clone(),
        stop.clone(),
    ));
    let daemon = Arc::new(Daemon {
        name: settings.name.clone(),
        max_message: settings.max_message,
        policy: settings.policy.clone(),
        limits: settings.limits.clone(),
        membership,
        router: router.clone(),
        processes: processes.clone(),
        jobs,
        checkpoints,
        chunks,
        job_store,
        peers,
        accepting: accepting.clone(),
        seq,
        stop: stop.clone(),
    });

    tokio::spawn(supervision(Arc::downgrade(&daemon), stop.clone()));
    if let Some(web) = web {
        let (daemon, secret, stop) = (daemon.clone(), settings.secret.clone(), stop.clone());
        tokio::spawn(async move {
            if let Err(e) = crate::daemon::web::serve(daemon, &secret, web, stop).await {
                tracing::error!("web view: {e}");
            }
        });
    }
    let service = Service(daemon);
    let auth = RequireSecret::new(&settings.secret)?;
    let rem = RemServer::new(service.clone())
        .max_decoding_message_size(max_frame)
        .max_encoding_message_size(max_frame);
    let peer = PeerServer::new(service)
        .max_decoding_message_size(max_frame)
        .max_encoding_message_size(max_frame);
    let (health, health_service) = tonic_health::server::health_reporter();
    health.set_serving::<RemServer<Service>>().await;

    let mut builder = Server::builder()
        .tcp_nodelay(true)
        .http2_keepalive_interval(Some(Duration::from_secs(5)))
        .http2_keepalive_timeout(Some(Duration::from_secs(5)))
        // Bounds per connection: open streams, and streams reset before being served
        // (HTTP/2 rapid reset).
        .max_concurrent_streams(Some(256))
        .http2_max_pending_accept_reset_streams(Some(64));
    if let Some(tls) = &settings.tls {
        builder = builder.tls_config(tls.server_config()?)?;
    }
    let server_stop = CancellationToken::new();
    let server = builder
        .add_service(health_service)
        .add_service(InterceptedService::new(rem, auth))
        // Peer calls are checked by the service itself (each proves the daemon key).
        .add_service(peer)
        .serve_with_incoming_shutdown(
            Gate::new(listener, settings.limits.connection_limits()),
            server_stop.clone().cancelled_owned(),
        );
    let mut server = tokio::spawn(server);
    tracing::info!(name = %settings.name, %bound, %advertise, "remd running");

    tokio::select! {
        _ = shutdown => {}
        r = &mut server => {
            return match r {
                Ok(r) => r.map_err(Error::from),
                Err(e) => Err(Error::Io(std::io::Error::other(e))),
            };
        }
    }
    tracing::info!("shutting down: no new work; ending child processes");
    accepting.store(false, Ordering::Relaxed);
    health.set_not_serving::<RemServer<Service>>().await;
    let grace = settings.kill_grace + Duration::from_secs(2);
    if tokio::time::timeout(grace, processes.shutdown())
        .await
        .is_err()
    {
        tracing::warn!("some child processes did not exit in time");
    }
    router.flush_links(Duration::from_secs(2)).await;
    stop.cancel();
    server_stop.cancel();
    match tokio::time::timeout(Duration::from_secs(3), server).await {
        Ok(Ok(r)) => r.map_err(Error::from),
        Ok(Err(e)) => Err(Error::Io(std::io::Error::other(e))),
        Err(_) => {
            tracing::warn!("server did not stop in time");
            Ok(())
        }
    }
}

/// How often the retention of ended jobs and old checkpoints runs.
const RETENTION_EVERY: Duration = Duration::from_secs(60);

/// Applies the job store's retention now and then, and keeps the process cache within its
/// limit, until `stop`.
async fn retention(
    store: JobStore,
    cache: Option<crate::store::process_cache::ProcessCache>,
    limits: crate::daemon::limits::Limits,
    stop: CancellationToken,
) {
    loop {
        if let Some(cache) = &cache {
            let c = cache.clone();
            match tokio::task::spawn_blocking(move || c.trim()).await {
                Ok(Ok((0, _))) => {}
                Ok(Ok((files, bytes))) => tracing::info!(files, bytes, "process cache trimmed"),
                Ok(Err(e)) => tracing::warn!("process cache: {e}"),
                Err(_) => {}
            }
        }
        match store
            .expire(SystemTime::now(), limits.kept_jobs, limits.kept_secs)
            .await
        {
            Ok((0, 0)) => {}
            Ok((records, checkpoints)) => {
                tracing::info!(records, checkpoints, "retention: removed ended jobs' state")
            }
            Err(e) => tracing::warn!("retention: {e}"),
        }
        tokio::select! {
            _ = tokio::time::sleep(RETENTION_EVERY) => {}
            _ = stop.cancelled() => break,
        }
    }
}

/// Keeps the farm's jobs running (see `job_control`): notes this host's controllers that
/// exited, and, on the supervisor, restarts what needs it; until `stop`.
async fn supervision(daemon: std::sync::Weak<Daemon>, stop: CancellationToken) {
    let mut seen = std::collections::HashSet::new();
    let mut view = crate::daemon::ops::job_control::ViewSettle::new(std::time::Instant::now());
    loop {
        let every = {
            let Some(d) = daemon.upgrade() else { break };
            d.note_exited_controllers(&mut seen).await;
            if let Err(e) = d.supervise(&mut view).await {
                tracing::warn!("supervising jobs: {e}");
            }
            crate::daemon::ops::job_control::tick(d.limits.job_lease_ms)
        };
        tokio::select! {
            _ = tokio::time::sleep(every) => {}
            _ = stop.cancelled() => break,
        }
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
