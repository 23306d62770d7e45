//! The web view (`remd --web ADDR`): one page that shows the farm live (hosts and their
//! load, jobs and their progress, a job's image filling in, its per-node table and events)
//! and the read-only JSON API behind it, for people and scripts alike. Off by default.
//!
//! | request | what |
//! |---|---|
//! | `GET /` | the page (plain HTML, CSS and JavaScript from the binary) |
//! | `POST /login` (form `token`) | a login token for a session cookie |
//! | `POST /logout` | ends the session |
//! | `GET /api/session` | who is logged in, and the session's CSRF token |
//! | `GET /api/hosts` | the hosts, their load and a few minutes of its history |
//! | `GET /api/jobs` | the caller's jobs (an admin's: everyone's), with rate and ETA |
//! | `GET /api/jobs/ID` | one job and what its application published |
//! | `GET /api/jobs/ID/image.png` | its image so far (or finished) |
//! | `POST /api/jobs/ID/cancel` | cancels it (its owner or an admin) |
//! | `GET /api/stream[?job=ID]` | server-sent events: `hosts`, `jobs` and `job` as they change |
//!
//! Every request but `/`, its assets and `/login` needs a credential ([`login`]); without
//! one it gets 401. Limits: [`MAX_CONNECTIONS`] connections, [`MAX_STREAMS`] event streams,
//! small request bodies, 10 s to send a request's head.
//!
//! # Layout
//! - [`login`]: tokens, sessions, CSRF.
//! - [`farm_view`]: the sampler and the hosts' and jobs' rows.
//! - [`job_view`]: one job's published view and image, and cancelling it.
//! - `routes`: the HTTP handlers; `assets`: the page.

pub mod farm_view;
pub mod job_view;
pub mod login;
mod routes;

use std::sync::Arc;
use std::time::Duration;

use tokio::net::TcpListener;
use tokio::sync::{watch, Semaphore};
use tokio_util::sync::CancellationToken;

use crate::daemon::ops::Daemon;
use crate::error::Result;
use farm_view::{Demand, FarmView};
use login::{Sessions, TokenCheck};

/// Most open connections to the web view.
pub const MAX_CONNECTIONS: usize = 64;

/// Most event streams open at once (each holds a connection).
pub const MAX_STREAMS: usize = 16;

/// Time a client has to send a request's head.
pub const HEAD_TIMEOUT: Duration = Duration::from_secs(10);

/// What every handler shares.
#[derive(Clone)]
pub(crate) struct WebState {
    pub daemon: Arc<Daemon>,
    pub tokens: TokenCheck,
    pub sessions: Arc<Sessions>,
    pub view: watch::Receiver<Arc<FarmView>>,
    pub demand: Demand,
    pub streams: Arc<Semaphore>,
}

/// Serves the web view of `daemon` on `listener` until `stop`.
pub async fn serve(
    daemon: Arc<Daemon>,
    secret: &crate::Secret,
    listener: TcpListener,
    stop: CancellationToken,
) -> Result<()> {
    let bound = listener.local_addr()?;
    if !bound.ip().is_loopback() {
        tracing::warn!(
            %bound,
            "the web view is plain HTTP off loopback: put it behind a TLS proxy or reach it \
             through a tunnel"
        );
    }
    let (tx, rx) = watch::channel(Arc::new(FarmView::default()));
    let demand = Demand::default();
    tokio::spawn(farm_view::sample(daemon.clone(), demand.clone(), tx));
    let state = WebState {
        daemon,
        tokens: TokenCheck::new(secret)?,
        sessions: Arc::new(Sessions::default()),
        view: rx,
        demand,
        streams: Arc::new(Semaphore::new(MAX_STREAMS)),
    };
    let app = routes::router(state);
    let connections = Arc::new(Semaphore::new(MAX_CONNECTIONS));
    tracing::info!(%bound, "web view on http://{bound}/");
    loop {
        let permit = tokio::select! {
            p = connections.clone().acquire_owned() => match p {
                Ok(p) => p,
                Err(_) => return Ok(()),
            },
            _ = stop.cancelled() => return Ok(()),
        };
        let stream = tokio::select! {
            accepted = listener.accept() => match accepted {
                Ok((stream, _)) => stream,
                Err(e) => {
                    // Out of descriptors, say: wait rather than spin.
                    tracing::warn!("web view: accept: {e}");
                    tokio::time::sleep(Duration::from_millis(100)).await;
                    continue;
                }
            },
            _ = stop.cancelled() => return Ok(()),
        };
        let service = hyper_util::service::TowerToHyperService::new(app.clone());
        let stop = stop.clone();
        tokio::spawn(async move {
            let _permit = permit;
            let conn = hyper::server::conn::http1::Builder::new()
                .timer(hyper_util::rt::TokioTimer::new())
                .header_read_timeout(HEAD_TIMEOUT)
                .serve_connection(hyper_util::rt::TokioIo::new(stream), service);
            tokio::select! {
                _ = conn => {}
                _ = stop.cancelled() => {}
            }
        });
    }
}
