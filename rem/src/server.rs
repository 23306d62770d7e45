//! Wiring of one daemon: builds the actors, serves both services and health on a listener,
//! and shuts down in order when told to.
//!
//! Shutdown (SIGTERM in `remd`): stop accepting work (spawns get `UNAVAILABLE`, health says
//! NOT_SERVING, peers see `accepting = false`), end every child (SIGTERM, SIGKILL after the
//! grace period; their owners get `EXITED`), end relay streams, stop the server. Children are
//! ended, not handed off: a job's owner sees them exit and can place new ones.

use std::future::Future;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use tokio::net::TcpListener;
use tokio::sync::mpsc;
use tokio_util::sync::CancellationToken;
use tonic::service::interceptor::InterceptedService;
use tonic::transport::Server;

use crate::auth::RequireSecret;
use crate::checkpoint::CheckpointStore;
use crate::config::DaemonSettings;
use crate::daemon::Daemon;
use crate::error::{Error, Result};
use crate::jobs::Jobs;
use crate::listener::{ConnectionLimits, Gate};
use crate::load::LoadGauge;
use crate::membership::{Membership, MembershipConfig};
use crate::peers::PeerPool;
use crate::process::{ProcessConfig, ProcessTable};
use crate::proto::{peer_server::PeerServer, rem_server::RemServer};
use crate::relay::Router;
use crate::service::Service;
use crate::wire::env;

use crate::wire::FRAME_OVERHEAD;

/// Runs a daemon on `listener` until `shutdown` completes, then shuts down cleanly.
pub async fn run(
    settings: DaemonSettings,
    listener: TcpListener,
    shutdown: impl Future<Output = ()>,
) -> Result<()> {
    let bound = listener.local_addr()?;
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
    let peers = PeerPool::new(&settings.secret, client_tls, max_frame);
    let gauge = LoadGauge::start(settings.load_interval);
    let accepting = Arc::new(AtomicBool::new(true));
    let stop = CancellationToken::new();
    let membership = Membership::start(
        MembershipConfig {
            name: settings.name.clone(),
            addr: advertise.clone(),
            join: settings.join.clone(),
            heartbeat: settings.heartbeat,
            lost_after: settings.lost_after,
        },
        gauge.clone(),
        accepting.clone(),
        peers.clone(),
        stop.clone(),
    );
    let (observer, observed) = mpsc::unbounded_channel();
    let router = Router::new(settings.queue, membership.clone(), peers.clone(), observer);
    let start_ms = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(1, |d| d.as_millis() as u64);
    let seq = Arc::new(AtomicU64::new(start_ms));
    let processes = ProcessTable::start(
        ProcessConfig {
            host: settings.name.clone(),
            addr: advertise.clone(),
            allow: settings.allow.clone(),
            base_env: child_env(&settings),
            log_bytes: settings.log_bytes,
            kill_grace: settings.kill_grace,
        },
        router.clone(),
        gauge.rem_processes().clone(),
        seq.clone(),
    );
    let jobs = Jobs::start(router.clone(), observed, membership.subscribe());
    let checkpoints = CheckpointStore::open(&state_dir.join("checkpoints"))?;
    let daemon = Arc::new(Daemon {
        name: settings.name.clone(),
        max_message: settings.max_message,
        allow: settings.allow.clone(),
        membership,
        router: router.clone(),
        processes: processes.clone(),
        jobs,
        checkpoints,
        peers,
        accepting: accepting.clone(),
        seq,
        stop: stop.clone(),
    });

    let service = Service(daemon);
    let auth = RequireSecret(settings.secret.clone());
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
        .add_service(InterceptedService::new(rem, auth.clone()))
        .add_service(InterceptedService::new(peer, auth))
        .serve_with_incoming_shutdown(
            Gate::new(listener, ConnectionLimits::default()),
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

/// Variables every child gets besides its own ids: how to authenticate and reach remd.
fn child_env(s: &DaemonSettings) -> Vec<(String, String)> {
    let mut out = vec![(env::MAX_MESSAGE.to_string(), s.max_message.to_string())];
    match &s.secret_file {
        Some(path) => out.push((env::SECRET_FILE.into(), path.display().to_string())),
        None => out.push((
            env::SECRET.into(),
            String::from_utf8_lossy(s.secret.as_bytes()).into_owned(),
        )),
    }
    if let Some(tls) = &s.tls {
        let ca = tls.ca.as_ref().unwrap_or(&tls.cert);
        out.push((env::TLS_CA.into(), ca.display().to_string()));
        if let Some(d) = &tls.domain {
            out.push((env::TLS_DOMAIN.into(), d.clone()));
        }
    }
    out
}
