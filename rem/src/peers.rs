//! Connections from this daemon to the others: one lazily connected channel per address,
//! shared by heartbeats, remote starts, relay links and checkpoint replicas.

use std::collections::HashMap;
use std::sync::{Arc, Mutex};

use tonic::service::interceptor::InterceptedService;
use tonic::transport::Channel;

use crate::auth::{Secret, SendSecret};
use crate::error::Result;
use crate::proto::peer_client::PeerClient;
use crate::transport::{self, ClientTls};

/// A Peer client that sends the cluster secret.
pub type PeerRpc = PeerClient<InterceptedService<Channel, SendSecret>>;

/// Cache of peer clients by address.
#[derive(Clone, Debug)]
pub struct PeerPool {
    clients: Arc<Mutex<HashMap<String, PeerRpc>>>,
    secret: SendSecret,
    tls: Option<ClientTls>,
    max_frame: usize,
}

impl PeerPool {
    /// `max_frame`: the largest gRPC message accepted or sent (relay limit plus overhead).
    pub fn new(secret: &Secret, tls: Option<ClientTls>, max_frame: usize) -> Self {
        PeerPool {
            clients: Arc::default(),
            secret: SendSecret::new(secret),
            tls,
            max_frame,
        }
    }

    /// The client for `addr` (connected on first use).
    pub fn client(&self, addr: &str) -> Result<PeerRpc> {
        let mut map = self.clients.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(c) = map.get(addr) {
            return Ok(c.clone());
        }
        let channel = transport::connect_lazy(addr, self.tls.as_ref())?;
        let client = PeerClient::with_interceptor(channel, self.secret.clone())
            .max_decoding_message_size(self.max_frame)
            .max_encoding_message_size(self.max_frame);
        map.insert(addr.to_string(), client.clone());
        Ok(client)
    }

    /// Forgets the channel to `addr` (after the host was lost, so a restart reconnects).
    pub fn forget(&self, addr: &str) {
        self.clients
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .remove(addr);
    }
}
