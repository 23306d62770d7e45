//! Channels to daemons: plain HTTP/2 or TLS (rustls), with the same settings for clients,
//! processes and daemons talking to their peers.

use std::path::PathBuf;
use std::time::Duration;

use tonic::transport::{
    Certificate, Channel, ClientTlsConfig, Endpoint, Identity, ServerTlsConfig,
};

use crate::error::{Error, Result};
use crate::wire::env::{TLS_CA as ENV_TLS_CA, TLS_DOMAIN as ENV_TLS_DOMAIN};

/// How a client checks a daemon's certificate.
#[derive(Clone, Debug)]
pub struct ClientTls {
    /// PEM of the CA (or the self-signed certificate itself).
    pub ca_pem: Vec<u8>,
    /// Name to verify; `None` = the host part of the address.
    pub domain: Option<String>,
}

impl ClientTls {
    /// Reads the CA from a PEM file.
    pub fn from_file(ca: &std::path::Path, domain: Option<String>) -> Result<Self> {
        let ca_pem = std::fs::read(ca)
            .map_err(|e| Error::Config(format!("cannot read {}: {e}", ca.display())))?;
        Ok(ClientTls { ca_pem, domain })
    }

    /// From `REM_TLS_CA` / `REM_TLS_DOMAIN`; `None` when `REM_TLS_CA` is unset.
    pub fn from_env() -> Result<Option<Self>> {
        match std::env::var_os(ENV_TLS_CA).filter(|v| !v.is_empty()) {
            Some(ca) => Ok(Some(ClientTls::from_file(
                std::path::Path::new(&ca),
                std::env::var(ENV_TLS_DOMAIN).ok().filter(|d| !d.is_empty()),
            )?)),
            None => Ok(None),
        }
    }
}

/// A daemon's certificate and key (PEM files), and the CA its clients should trust.
#[derive(Clone, Debug)]
pub struct ServerTlsFiles {
    /// The daemon's certificate (PEM).
    pub cert: PathBuf,
    /// Its private key (PEM).
    pub key: PathBuf,
    /// CA for talking to peers; default: the daemon's own certificate (a shared self-signed one).
    pub ca: Option<PathBuf>,
    /// The name to expect in peers' certificates.
    pub domain: Option<String>,
}

impl ServerTlsFiles {
    /// The server side: this daemon's identity.
    pub fn server_config(&self) -> Result<ServerTlsConfig> {
        let cert = read(&self.cert)?;
        let key = read(&self.key)?;
        Ok(ServerTlsConfig::new().identity(Identity::from_pem(cert, key)))
    }

    /// The client side, for calls to peers: trust the CA (or the daemon's own certificate).
    pub fn client_tls(&self) -> Result<ClientTls> {
        let ca = self.ca.as_ref().unwrap_or(&self.cert);
        ClientTls::from_file(ca, self.domain.clone())
    }
}

fn read(path: &PathBuf) -> Result<Vec<u8>> {
    std::fs::read(path).map_err(|e| Error::Config(format!("cannot read {}: {e}", path.display())))
}

/// An endpoint for `addr` (`HOST:PORT`, or a full `http(s)://` URL).
pub fn endpoint(addr: &str, tls: Option<&ClientTls>) -> Result<Endpoint> {
    let url = if addr.contains("://") {
        addr.to_string()
    } else if tls.is_some() {
        format!("https://{addr}")
    } else {
        format!("http://{addr}")
    };
    let mut ep = Endpoint::from_shared(url)
        .map_err(|e| Error::Config(format!("bad address {addr:?}: {e}")))?
        .connect_timeout(Duration::from_secs(2))
        .tcp_nodelay(true)
        .http2_keep_alive_interval(Duration::from_secs(10))
        .keep_alive_timeout(Duration::from_secs(5));
    if let Some(tls) = tls {
        let mut cfg = ClientTlsConfig::new().ca_certificate(Certificate::from_pem(&tls.ca_pem));
        if let Some(domain) = &tls.domain {
            cfg = cfg.domain_name(domain.clone());
        }
        ep = ep.tls_config(cfg)?;
    }
    Ok(ep)
}

/// True when `addr` (`HOST:PORT` or a URL) names this host: a loopback IP or `localhost`.
pub fn is_loopback(addr: &str) -> bool {
    let rest = addr.split_once("://").map_or(addr, |(_, r)| r);
    let authority = rest.split('/').next().unwrap_or_default();
    let host = match authority.strip_prefix('[') {
        Some(v6) => v6.split(']').next().unwrap_or_default(),
        None => authority.rsplit_once(':').map_or(authority, |(h, _)| h),
    };
    host.eq_ignore_ascii_case("localhost")
        || host
            .parse::<std::net::IpAddr>()
            .is_ok_and(|ip| ip.is_loopback())
}

/// Connects now (fails if the daemon is not there).
pub async fn connect(addr: &str, tls: Option<&ClientTls>) -> Result<Channel> {
    Ok(endpoint(addr, tls)?.connect().await?)
}

/// A channel that connects on first use (and reconnects after failures).
pub fn connect_lazy(addr: &str, tls: Option<&ClientTls>) -> Result<Channel> {
    Ok(endpoint(addr, tls)?.connect_lazy())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn loopback_addresses_are_recognised() {
        for a in [
            "127.0.0.1:7077",
            "127.3.4.5:1",
            "localhost:80",
            "[::1]:7077",
            "http://127.0.0.1:9/",
        ] {
            assert!(is_loopback(a), "{a}");
        }
        for a in [
            "10.0.0.1:7077",
            "ws1.example.org:7070",
            "http://[2001:db8::1]:1",
            "0.0.0.0:1",
        ] {
            assert!(!is_loopback(a), "{a}");
        }
    }
}
