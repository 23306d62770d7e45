//! Chunks across the cluster (the daemon's side of `PutChunk` and `GetChunk`).
//!
//! A chunk put here is cached here and on one more live host: the peer its name ranks first
//! by rendezvous hashing (`replicas`), unless that peer has it already. Different chunks of
//! one scene so land on different peers, and a host that lacks a chunk asks that peer first,
//! then the others: the submitting host sends about one copy of a scene, however many hosts
//! render it, and the copies hosts fetch are spread over the cluster. A fetched chunk is
//! checked against its name and cached (when the cache cannot take it, a full disk, it is
//! still served, with a warning).

use std::time::Duration;

use crate::auth::identity::Identity;
use crate::auth::peer_auth::method;
use crate::daemon::ops::Daemon;
use crate::error::{Error, Result};
use crate::wire::chunk_name::{check_name, name_of};
use crate::wire::proto::{
    GetChunkReply, GetChunkRequest, HasChunksRequest, HostInfo, PutChunkReply, PutChunkRequest,
};

/// How long one peer may take to send or take one chunk (a few MiB).
const CHUNK_CALL: Duration = Duration::from_secs(60);

/// Names one HasChunks request may carry.
pub const MAX_HAS: usize = 1024;

impl Daemon {
    fn check_chunk(&self, req: &PutChunkRequest) -> Result<()> {
        check_name(&req.hash)?;
        let limit = self.limits.chunk_bytes.min(self.max_message);
        if req.data.len() > limit {
            return Err(Error::TooLarge {
                size: req.data.len(),
                limit,
            });
        }
        if name_of(&req.data) != req.hash {
            return Err(Error::Invalid(format!(
                "chunk {}: its bytes do not hash to its name",
                req.hash
            )));
        }
        Ok(())
    }

    /// The live peers in the order `hash`'s copies are looked for.
    fn chunk_peers(&self, hash: &str) -> Vec<HostInfo> {
        let mut peers: Vec<HostInfo> = self.live_peers().collect();
        peers.sort_by(|a, b| {
            let (wa, wb) = (
                crate::store::replicas::weight(hash, &a.name),
                crate::store::replicas::weight(hash, &b.name),
            );
            wb.cmp(&wa).then_with(|| a.name.cmp(&b.name))
        });
        peers
    }

    /// Caches a chunk here and on its first live peer (unless that peer has it).
    pub async fn put_chunk(&self, _who: &Identity, req: PutChunkRequest) -> Result<PutChunkReply> {
        self.check_chunk(&req)?;
        let mut reply = PutChunkReply::default();
        match self.chunks.put(&req.hash, &req.data).await {
            Ok(()) => reply.stored_on.push(self.name.clone()),
            Err(e) => tracing::warn!(chunk = %req.hash, "cannot cache a chunk here: {e}"),
        }
        for peer in self.chunk_peers(&req.hash) {
            let has = HasChunksRequest {
                hashes: vec![req.hash.clone()],
            };
            // Each call is given up once the peer is no longer live (a host stopped).
            let held = self
                .while_live(
                    &peer.name,
                    self.peers.call(
                        &peer.name,
                        &peer.addr,
                        method::HAS_CHUNKS,
                        has,
                        |mut c, r| async move { c.has_chunks(r).await },
                    ),
                )
                .await;
            if held.is_ok_and(|h| h.has.first() == Some(&true)) {
                reply.stored_on.push(peer.name);
                break;
            }
            let sent = self
                .while_live(
                    &peer.name,
                    self.peers.call_proven(
                        &peer.name,
                        &peer.addr,
                        method::STORE_CHUNK,
                        CHUNK_CALL,
                        req.clone(),
                        |mut c, r| async move { c.store_chunk(r).await },
                    ),
                )
                .await;
            if sent.is_ok() {
                reply.bytes_sent += req.data.len() as u64;
                reply.stored_on.push(peer.name);
                break;
            }
        }
        if reply.stored_on.is_empty() {
            return Err(Error::Unreachable {
                host: "any host".into(),
                reason: format!("no host could keep chunk {}", req.hash),
            });
        }
        Ok(reply)
    }

    /// A chunk from this host's cache, else from the first live peer that has an intact copy
    /// (then cached here).
    pub async fn get_chunk(&self, _who: &Identity, hash: String) -> Result<GetChunkReply> {
        check_name(&hash)?;
        // One fetch per chunk at a time on this host: a second worker waits for the first.
        let _fetching = self.chunks.fetch_lock(&hash).await;
        if let Some(data) = self.chunks.get(&hash).await? {
            return Ok(GetChunkReply {
                data,
                from_host: self.name.clone(),
                cached: true,
            });
        }
        for peer in self.chunk_peers(&hash) {
            let req = GetChunkRequest { hash: hash.clone() };
            let fetched = self
                .peers
                .call_proven(
                    &peer.name,
                    &peer.addr,
                    method::FETCH_CHUNK,
                    CHUNK_CALL,
                    req,
                    |mut c, r| async move { c.fetch_chunk(r).await },
                )
                .await;
            let Ok((_, reply)) = fetched else { continue };
            if name_of(&reply.data) != hash {
                tracing::warn!(chunk = %hash, peer = %peer.name, "a peer sent a corrupt chunk");
                continue;
            }
            if let Err(e) = self.chunks.put(&hash, &reply.data).await {
                tracing::warn!(chunk = %hash, "cannot cache a fetched chunk (serving it from memory): {e}");
            }
            return Ok(GetChunkReply {
                data: reply.data,
                from_host: peer.name,
                cached: false,
            });
        }
        Err(Error::NotFound(format!(
            "chunk {hash}: no live host has an intact copy"
        )))
    }

    /// Which of `hashes` this host caches.
    pub async fn has_chunks(&self, hashes: &[String]) -> Result<Vec<bool>> {
        if hashes.len() > MAX_HAS {
            return Err(Error::Invalid(format!(
                "{} chunk names in one request (at most {MAX_HAS})",
                hashes.len()
            )));
        }
        let mut has = Vec::with_capacity(hashes.len());
        for h in hashes {
            has.push(self.chunks.has(h).await);
        }
        Ok(has)
    }

    /// A peer's copy for this host's cache.
    pub async fn store_chunk(&self, req: PutChunkRequest) -> Result<()> {
        self.check_chunk(&req)?;
        self.chunks.put(&req.hash, &req.data).await
    }

    /// This host's copy of `hash` only.
    pub async fn fetch_chunk(&self, hash: &str) -> Result<Vec<u8>> {
        self.chunks
            .get(hash)
            .await?
            .ok_or_else(|| Error::NotFound(format!("chunk {hash} is not cached here")))
    }
}
