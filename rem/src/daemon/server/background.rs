//! The daemon's background tasks: retention of ended jobs and old checkpoints (and trimming
//! of the process cache), supervision of the farm's jobs, and the web view.

use std::sync::{Arc, Weak};
use std::time::{Duration, SystemTime};

use tokio::net::TcpListener;
use tokio_util::sync::CancellationToken;

use crate::auth::secret::Secret;
use crate::daemon::limits::Limits;
use crate::daemon::ops::job_control::{tick, ViewSettle};
use crate::daemon::ops::Daemon;
use crate::store::job_store::JobStore;
use crate::store::process_cache::ProcessCache;

/// How often the retention of ended jobs and old checkpoints runs.
const RETENTION_EVERY: Duration = Duration::from_secs(60);

/// Applies the job store's retention now and then, and keeps the process cache within its
/// limit, until `stop`.
pub(super) async fn retention(
    store: JobStore,
    cache: Option<ProcessCache>,
    limits: Limits,
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
pub(super) async fn supervision(daemon: Weak<Daemon>, stop: CancellationToken) {
    let mut seen = std::collections::HashSet::new();
    let mut view = ViewSettle::new(std::time::Instant::now());
    loop {
        let every = {
            let Some(d) = daemon.upgrade() else { break };
            d.note_exited_controllers(&mut seen).await;
            if let Err(e) = d.supervise(&mut view).await {
                tracing::warn!("supervising jobs: {e}");
            }
            tick(d.limits.job_lease_ms)
        };
        tokio::select! {
            _ = tokio::time::sleep(every) => {}
            _ = stop.cancelled() => break,
        }
    }
}

/// Serves the web view of `daemon` on `web` on a task of its own, until the daemon stops.
pub(super) fn web_view(daemon: Arc<Daemon>, secret: Secret, web: TcpListener) {
    let stop = daemon.stop.clone();
    tokio::spawn(async move {
        if let Err(e) = crate::daemon::web::serve(daemon, &secret, web, stop).await {
            tracing::error!("web view: {e}");
        }
    });
}
