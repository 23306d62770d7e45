//! Connections from this daemon to the others: one lazily connected channel per address,
//! shared by heartbeats, remote starts, relay links and checkpoint replicas; and the one way
//! to call another daemon, [`PeerPool::call`], which signs the call and believes only a reply
//! that proves the cluster secret (`peer_auth`).
//!
//! Plain HTTP/2 goes only to loopback addresses unless the daemon was told `insecure`; with
//! TLS configured, an `http://` address is refused.

use std::collections::HashMap;
use std::future::Future;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use prost::Message;
use tonic::transport::Channel;
use tonic::{Request, Response, Status};

use crate::auth::peer_auth::{digest, DaemonKey};
use crate::error::{Error, Result};
use crate::wire::proto::peer_client::PeerClient;
use crate::wire::transport::{self, ClientTls};

/// A Peer client (calls are signed by [`PeerPool::call`]).
pub type PeerRpc = PeerClient<Channel>;

/// Time allowed for a call to another daemon that does real work (start, kill, replica).
pub const PEER_CALL: Duration = Duration::from_secs(5);

/// Cache of peer clients by address.
#[derive(Clone, Debug)]
pub struct PeerPool {
    clients: Arc<Mutex<HashMap<String, PeerRpc>>>,
    key: DaemonKey,
    tls: Option<ClientTls>,
    insecure: bool,
    max_frame: usize,
}

impl PeerPool {
    /// `max_frame`: the largest gRPC message accepted or sent (relay limit plus overhead).
    /// `insecure`: allow plain HTTP/2 to addresses off this host.
    pub fn new(key: DaemonKey, tls: Option<ClientTls>, insecure: bool, max_frame: usize) -> Self {
        PeerPool {
            clients: Arc::default(),
            key,
            tls,
            insecure,
            max_frame,
        }
    }

    /// This daemon's key (to sign calls and check replies by hand, e.g. streams).
    pub fn key(&self) -> &DaemonKey {
        &self.key
    }

    /// The client for `addr` (connected on first use).
    pub fn client(&self, addr: &str) -> Result<PeerRpc> {
        let mut map = self.clients.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(c) = map.get(addr) {
            return Ok(c.clone());
        }
        self.check_transport(addr)?;
        let channel = transport::connect_lazy(addr, self.tls.as_ref())?;
        let client = PeerClient::new(channel)
            .max_decoding_message_size(self.max_frame)
            .max_encoding_message_size(self.max_frame);
        map.insert(addr.to_string(), client.clone());
        Ok(client)
    }

    fn check_transport(&self, addr: &str) -> Result<()> {
        if self.tls.is_some() {
            if addr.starts_with("http://") {
                return Err(Error::Config(format!(
                    "refusing plain HTTP to {addr}: this daemon uses TLS"
                )));
            }
            return Ok(());
        }
        if self.insecure || transport::is_loopback(addr) {
            return Ok(());
        }
        Err(Error::Config(format!(
            "refusing plain HTTP/2 to {addr}, off this host: configure TLS, or set insecure"
        )))
    }

    /// Calls daemon `name` at `addr`: signs the request (its body digested), awaits the reply
    /// within [`PEER_CALL`] and checks its proof.
    pub async fn call<T, R, F, Fut>(
        &self,
        name: &str,
        addr: &str,
        method: &'static str,
        msg: T,
        call: F,
    ) -> Result<R>
    where
        T: Message,
        R: Message,
        F: FnOnce(PeerRpc, Request<T>) -> Fut,
        Fut: Future<Output = std::result::Result<Response<R>, Status>>,
    {
        let proven = self.call_proven(name, addr, method, PEER_CALL, msg, call);
        Ok(proven.await?.1)
    }

    /// Like [`PeerPool::call`] within `timeout`, to `name` or to whoever holds the key at
    /// `addr` (`name` = [`crate::auth::peer_auth::ANY`]); returns the name the reply proved.
    pub async fn call_proven<T, R, F, Fut>(
        &self,
        name: &str,
        addr: &str,
        method: &'static str,
        timeout: Duration,
        msg: T,
        call: F,
    ) -> Result<(String, R)>
    where
        T: Message,
        R: Message,
        F: FnOnce(PeerRpc, Request<T>) -> Fut,
        Fut: Future<Output = std::result::Result<Response<R>, Status>>,
    {
        let client = self.client(addr)?;
        let (req, pending) = self.key.sign(name, method, &digest(&msg), msg);
        let unreachable = |reason: String| Error::Unreachable {
            host: name.to_string(),
            reason,
        };
        match tokio::time::timeout(timeout, call(client, req)).await {
            Ok(Ok(resp)) => Ok(self.key.check_reply(&pending, resp)?),
            Ok(Err(s)) if s.code() == tonic::Code::Unavailable => {
                Err(unreachable(s.message().to_string()))
            }
            Ok(Err(s)) => Err(Error::Rpc(s)),
            Err(_) => Err(unreachable("timed out".into())),
        }
    }

    /// Forgets the channel to `addr` (after the host was lost, so a restart reconnects).
    pub fn forget(&self, addr: &str) {
        self.clients
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .remove(addr);
    }
}
