//! Reaching REM: the configured remd (`--remd` / `REM_ADDR`, with the cluster secret from
//! `--secret-file`, `REM_SECRET_FILE` or `REM_SECRET`, over TLS when `REM_TLS_CA` names the
//! cluster's certificate, verified against `REM_TLS_DOMAIN`), or else a private embedded one.
//! Every way this can fail gets its own clear error.

use super::{embedded, job_record};
use rem::daemon::embedded::EmbeddedRemd;
use rem::{RemClient, Secret};
use std::path::Path;

/// Why REM could not be reached or used; every variant names the remd address involved.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ConnectionError {
    /// `--remd` was given but no secret was: neither `--secret-file` nor the environment.
    #[error("no cluster secret for remd at {addr}: give --secret-file, or set REM_SECRET_FILE or REM_SECRET")]
    NoSecret {
        /// The remd address asked for.
        addr: String,
    },
    /// The secret file (or variable) could not be read or parsed.
    #[error("cannot read the cluster secret: {0}")]
    Secret(rem::Error),
    /// No connection: nothing listens there, or the transport failed.
    #[error("cannot reach remd at {addr}: {reason}")]
    Unreachable {
        /// The remd address.
        addr: String,
        /// The innermost error of the chain, e.g. "Connection refused (os error 111)".
        reason: String,
    },
    /// remd answered that the credential is not good (unauthenticated).
    #[error("remd at {addr} refused the cluster secret (is it the right one?)")]
    WrongSecret {
        /// The remd address.
        addr: String,
    },
    /// Any other failed call to remd.
    #[error("remd at {addr} failed: {source}")]
    Rpc {
        /// The remd address.
        addr: String,
        /// REM's error.
        source: rem::Error,
    },
    /// The private remd (no `--remd` given) could not be started.
    #[error("cannot start the embedded remd: {0}")]
    Embedded(rem::Error),
}

/// A connection to REM, and the private daemon behind it if there is one.
pub struct RemConnection {
    /// The client, its secret already checked with one call.
    pub client: RemClient,
    /// The address of the remd connected to (the private one's when embedded).
    pub addr: String,
    /// The private daemon started because no `--remd` was given; stopped by
    /// [`RemConnection::close`].
    pub embedded: Option<EmbeddedRemd>,
}

impl RemConnection {
    /// Connects to `remd` if given, else starts a private daemon allowed to run `program`.
    pub async fn open(
        remd: Option<&str>,
        secret_file: Option<&Path>,
        program: &Path,
    ) -> Result<RemConnection, ConnectionError> {
        match remd.filter(|a| !a.is_empty()) {
            Some(addr) => {
                let secret = match secret_file {
                    Some(f) => Secret::from_file(f).map_err(ConnectionError::Secret)?,
                    None => match Secret::from_env() {
                        Ok(Some((s, _))) => s,
                        Ok(None) => {
                            return Err(ConnectionError::NoSecret {
                                addr: addr.to_string(),
                            })
                        }
                        Err(e) => return Err(ConnectionError::Secret(e)),
                    },
                };
                let mut opts = rem::ConnectOptions::new(addr, secret);
                opts.tls = rem::wire::transport::ClientTls::from_env().map_err(|e| {
                    ConnectionError::Unreachable {
                        addr: addr.to_string(),
                        reason: e.to_string(),
                    }
                })?;
                let tls = opts.tls.is_some();
                let client = connect(opts).await.map_err(|e| match e {
                    // A TLS remd closes a plain connection at once.
                    ConnectionError::Unreachable { addr, reason }
                        if !tls && !reason.contains("refused") =>
                    {
                        ConnectionError::Unreachable {
                            addr,
                            reason: format!(
                                "{reason} (if remd uses TLS, set REM_TLS_CA and REM_TLS_DOMAIN)"
                            ),
                        }
                    }
                    e => e,
                })?;
                Ok(RemConnection {
                    client,
                    addr: addr.to_string(),
                    embedded: None,
                })
            }
            None => {
                let rem = embedded::start(program.to_path_buf(), embedded::state_dir())
                    .await
                    .map_err(ConnectionError::Embedded)?;
                let opts = rem::ConnectOptions::new(rem.addr(), rem.secret().clone());
                let client = connect(opts).await?;
                // The private daemon's state outlives it: jobs of commands that ended without
                // saying so are recorded interrupted, never left running.
                job_record::close_abandoned(&client, crate::distrib::checkpoint::unix_ms()).await;
                Ok(RemConnection {
                    client,
                    addr: rem.addr().to_string(),
                    embedded: Some(rem),
                })
            }
        }
    }

    /// True when REM is the private embedded daemon rather than a cluster's remd.
    pub fn is_embedded(&self) -> bool {
        self.embedded.is_some()
    }

    /// The live hosts that take work.
    pub async fn live_hosts(&self) -> Result<Vec<rem::HostInfo>, ConnectionError> {
        let hosts = self.client.hosts().await.map_err(|e| self.rpc_error(e))?;
        Ok(hosts
            .into_iter()
            .filter(|h| h.alive && h.accepting)
            .collect())
    }

    /// Classifies a failed call to this remd (wrong secret, unreachable, or other).
    pub fn rpc_error(&self, e: rem::Error) -> ConnectionError {
        classify(&self.addr, e)
    }

    /// Stops the private daemon, if any.
    pub async fn close(self) {
        if let Some(rem) = self.embedded {
            rem.stop().await;
        }
    }
}

/// Connects and checks the secret with one call.
async fn connect(opts: rem::ConnectOptions) -> Result<RemClient, ConnectionError> {
    let addr = opts.addr.clone();
    let client = RemClient::connect_with(opts)
        .await
        .map_err(|e| ConnectionError::Unreachable {
            addr: addr.clone(),
            reason: e.root_cause(),
        })?;
    client.hosts().await.map_err(|e| classify(&addr, e))?;
    Ok(client)
}

fn classify(addr: &str, e: rem::Error) -> ConnectionError {
    let addr = addr.to_string();
    if e.is_transport() {
        return ConnectionError::Unreachable {
            addr,
            reason: e.root_cause(),
        };
    }
    match e.code() as i32 {
        // (PERMISSION_DENIED is a refusal of what was asked, e.g. a program not allowed.)
        tonic_code::UNAUTHENTICATED => ConnectionError::WrongSecret { addr },
        tonic_code::UNAVAILABLE => ConnectionError::Unreachable {
            addr,
            reason: e.root_cause(),
        },
        _ => ConnectionError::Rpc { addr, source: e },
    }
}

/// The gRPC codes we tell apart, without depending on tonic here.
mod tonic_code {
    pub const UNAUTHENTICATED: i32 = 16;
    pub const UNAVAILABLE: i32 = 14;
}
