//! The daemon's gRPC server: the client service behind the secret check, the peer service
//! (each call proves the daemon key itself), and health, on the connection [`Gate`].

use std::sync::Arc;
use std::time::Duration;

use tokio::net::TcpListener;
use tokio::task::JoinHandle;
use tokio_util::sync::CancellationToken;
use tonic::service::interceptor::InterceptedService;
use tonic::transport::Server;
use tonic_health::server::HealthReporter;

use super::service::Service;
use crate::auth::secret::RequireSecret;
use crate::daemon::config::DaemonSettings;
use crate::daemon::listener::Gate;
use crate::daemon::ops::Daemon;
use crate::error::{Error, Result};
use crate::wire::proto::{peer_server::PeerServer, rem_server::RemServer};

/// The gRPC server, serving on its own task until [`Grpc::stop`].
pub(super) struct Grpc {
    health: HealthReporter,
    server: JoinHandle<std::result::Result<(), tonic::transport::Error>>,
    stop: CancellationToken,
}

impl Grpc {
    /// Serves `daemon` on `listener`, with messages up to `max_frame` bytes.
    pub async fn serve(
        daemon: Arc<Daemon>,
        settings: &DaemonSettings,
        listener: TcpListener,
        max_frame: usize,
    ) -> Result<Grpc> {
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
        let stop = CancellationToken::new();
        let server = builder
            .add_service(health_service)
            .add_service(InterceptedService::new(rem, auth))
            // Peer calls are checked by the service itself (each proves the daemon key).
            .add_service(peer)
            .serve_with_incoming_shutdown(
                Gate::new(listener, settings.limits.connection_limits()),
                stop.clone().cancelled_owned(),
            );
        Ok(Grpc {
            health,
            server: tokio::spawn(server),
            stop,
        })
    }

    /// Completes if the server ends on its own (an error), with its result.
    pub async fn ended(&mut self) -> Result<()> {
        match (&mut self.server).await {
            Ok(r) => r.map_err(Error::from),
            Err(e) => Err(Error::Io(std::io::Error::other(e))),
        }
    }

    /// Tells health checks the daemon no longer serves.
    pub async fn set_not_serving(&self) {
        self.health.set_not_serving::<RemServer<Service>>().await;
    }

    /// Stops the server and waits (a little) for it to end.
    pub async fn stop(self) -> Result<()> {
        self.stop.cancel();
        match tokio::time::timeout(Duration::from_secs(3), self.server).await {
            Ok(Ok(r)) => r.map_err(Error::from),
            Ok(Err(e)) => Err(Error::Io(std::io::Error::other(e))),
            Err(_) => {
                tracing::warn!("server did not stop in time");
                Ok(())
            }
        }
    }
}
