//! Reaching REM: the configured remd (`--remd` / `REM_ADDR`, with the cluster secret from
//! `--secret-file`, `REM_SECRET_FILE` or `REM_SECRET`), or else a private embedded one. Every
//! way this can fail gets its own clear error.

use super::embedded;
use rem::embedded::EmbeddedRemd;
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
    /// remd answered with unauthenticated or permission denied.
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
                let client = connect(addr, secret).await?;
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
                let client = connect(rem.addr(), rem.secret().clone()).await?;
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
async fn connect(addr: &str, secret: Secret) -> Result<RemClient, ConnectionError> {
    let client =
        RemClient::connect(addr, secret)
            .await
            .map_err(|e| ConnectionError::Unreachable {
                addr: addr.to_string(),
                reason: root_cause(&e),
            })?;
    client.hosts().await.map_err(|e| classify(addr, e))?;
    Ok(client)
}

fn classify(addr: &str, e: rem::Error) -> ConnectionError {
    let addr = addr.to_string();
    match e.code() as i32 {
        tonic_code::UNAUTHENTICATED | tonic_code::PERMISSION_DENIED
            if matches!(e, rem::Error::Rpc(_)) =>
        {
            ConnectionError::WrongSecret { addr }
        }
        tonic_code::UNAVAILABLE => ConnectionError::Unreachable {
            addr,
            reason: root_cause(&e),
        },
        _ => ConnectionError::Rpc { addr, source: e },
    }
}

/// The innermost error of a chain: "Connection refused (os error 111)" rather than four
/// layers of "transport error".
fn root_cause(e: &(dyn std::error::Error + 'static)) -> String {
    let mut cur = e;
    while let Some(next) = cur.source() {
        cur = next;
    }
    cur.to_string()
}

/// The gRPC codes we tell apart, without depending on tonic here.
mod tonic_code {
    pub const UNAUTHENTICATED: i32 = 16;
    pub const PERMISSION_DENIED: i32 = 7;
    pub const UNAVAILABLE: i32 = 14;
}
