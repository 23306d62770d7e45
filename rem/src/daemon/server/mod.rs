//! Wiring of one daemon: builds its state, starts its background tasks and web view, serves
//! both gRPC services and health on a listener, and shuts down in order when told to.
//!
//! Shutdown (SIGTERM in `remd`): stop accepting work (spawns get `UNAVAILABLE`, health says
//! NOT_SERVING, peers see `accepting = false`), end every child (SIGTERM, SIGKILL after the
//! grace period; their owners get `EXITED`), end relay streams, stop the server. Children are
//! ended, not handed off: a job's owner sees them exit and can place new ones.
//!
//! # Layout
//!
//! - this module: [`run`] / [`run_with_web`], the checks before starting, and shutdown.
//! - `state`: building the daemon's state (membership, relay, processes, stores).
//! - `background`: retention, job supervision, the web view's task.
//! - `grpc`: the gRPC server (services, health, TLS, the connection gate).
//! - `service`: the gRPC services' face of the daemon's operations; `attach`: one
//!   process's relay stream.

pub(crate) mod attach;
mod background;
mod grpc;
pub(crate) mod service;
mod state;

use std::future::Future;
use std::net::SocketAddr;
use std::sync::atomic::Ordering;
use std::sync::Arc;
use std::time::Duration;

use tokio::net::TcpListener;

use crate::daemon::config::DaemonSettings;
use crate::error::{Error, Result};
use grpc::Grpc;
use state::Running;

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
    let web = web_listener(web, &settings)?;
    let bound = listener.local_addr()?;
    check_exposure(&settings, bound)?;
    let running = Running::start(&settings, bound).await?;
    let daemon = &running.daemon;
    tokio::spawn(background::retention(
        daemon.job_store.clone(),
        running.process_cache.clone(),
        settings.limits.clone(),
        daemon.stop.clone(),
    ));
    tokio::spawn(background::supervision(
        Arc::downgrade(daemon),
        daemon.stop.clone(),
    ));
    if let Some(web) = web {
        background::web_view(daemon.clone(), settings.secret.clone(), web);
    }
    let mut grpc = Grpc::serve(daemon.clone(), &settings, listener, running.max_frame).await?;
    let advertise = &running.advertise;
    tracing::info!(name = %settings.name, %bound, %advertise, "remd running");

    tokio::select! {
        _ = shutdown => {}
        r = grpc.ended() => return r,
    }
    shut_down(running, grpc, &settings).await
}

/// The web view's listener: the one given, or one bound at `settings.web`, or none.
fn web_listener(
    web: Option<TcpListener>,
    settings: &DaemonSettings,
) -> Result<Option<TcpListener>> {
    Ok(match (web, settings.web) {
        (Some(l), _) => Some(l),
        (None, Some(addr)) => Some(
            crate::bind_listener(addr)
                .map_err(|e| Error::Config(format!("cannot serve the web view on {addr}: {e}")))?,
        ),
        (None, None) => None,
    })
}

/// Refuses plain HTTP/2 off loopback unless `insecure`, and warns of children run as root.
fn check_exposure(settings: &DaemonSettings, bound: SocketAddr) -> Result<()> {
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
    Ok(())
}

/// Stops in order: no new work, children ended, links flushed, streams and tasks stopped,
/// then the server.
async fn shut_down(running: Running, grpc: Grpc, settings: &DaemonSettings) -> Result<()> {
    tracing::info!("shutting down: no new work; ending child processes");
    let daemon = &running.daemon;
    daemon.accepting.store(false, Ordering::Relaxed);
    grpc.set_not_serving().await;
    let grace = settings.kill_grace + Duration::from_secs(2);
    if tokio::time::timeout(grace, daemon.processes.shutdown())
        .await
        .is_err()
    {
        tracing::warn!("some child processes did not exit in time");
    }
    daemon.router.flush_links(Duration::from_secs(2)).await;
    daemon.stop.cancel();
    // `running` (with a temporary state directory) lives until the server has stopped.
    grpc.stop().await
}
