//! How daemons prove themselves to each other without ever sending the cluster secret.
//!
//! Every call of the `Peer` service carries `x-rem-peer: FROM TO MILLIS NONCE MAC`, where MAC
//! is an HMAC-SHA256, under the daemon key (derived from the cluster secret; clients hold only
//! the client key, so they cannot make one), of the method, both names, the time, a random
//! nonce and a digest of the request body. The receiver checks that the call is for itself
//! (`TO` is its name), that the
//! time is within [`MAX_SKEW`] of its own clock, the MAC, and that the nonce is new, so a
//! captured call cannot be replayed nor redirected to another daemon, and whoever answers at a
//! lost member's address learns nothing it could use. Every reply carries
//! `x-rem-peer-proof: NAME MAC`, a MAC of the caller's nonce and the reply's digest, so a
//! caller believes only answers from a daemon that holds the key.
//!
//! The identity a call proves (`FROM`) is what the receiver acts on: envelopes in a relay link
//! must come from processes of that host.

use std::collections::HashMap;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use hmac::{Mac, SimpleHmac};
use prost::Message;
use sha2::{Digest, Sha256};
use subtle::ConstantTimeEq;
use tonic::metadata::AsciiMetadataValue;
use tonic::{Request, Response, Status};

use crate::auth::secret::Secret;
use crate::error::{Error, Result};

/// Metadata entry of a call's proof.
pub const CALL_METADATA: &str = "x-rem-peer";
/// Metadata entry of a reply's proof.
pub const REPLY_METADATA: &str = "x-rem-peer-proof";
/// How far a call's time may be from the receiver's clock.
pub const MAX_SKEW: Duration = Duration::from_secs(30);
/// Nonces remembered at most (a full table refuses calls until old ones expire).
pub const MAX_NONCES: usize = 200_000;
/// The `TO` of a call to an address whose daemon is not known (refused by every daemon).
pub const ANY: &str = "-";

/// The method names signed (one per `Peer` RPC).
pub mod method {
    /// `Peer.StartLocal`.
    pub const START: &str = "StartLocal";
    /// `Peer.KillLocal`.
    pub const KILL: &str = "KillLocal";
    /// `Peer.LogsLocal`.
    pub const LOGS: &str = "LogsLocal";
    /// `Peer.PsLocal`.
    pub const PS: &str = "PsLocal";
    /// `Peer.Forward` (a stream: its body is not digested; each item is checked).
    pub const FORWARD: &str = "Forward";
    /// `Peer.StoreReplica`.
    pub const STORE: &str = "StoreReplica";
    /// `Peer.FetchReplica`.
    pub const FETCH: &str = "FetchReplica";
    /// `Peer.StoreJob`.
    pub const STORE_JOB: &str = "StoreJob";
    /// `Peer.ListJobsLocal`.
    pub const LIST_JOBS: &str = "ListJobsLocal";
    /// `Peer.StoreChunk`.
    pub const STORE_CHUNK: &str = "StoreChunk";
    /// `Peer.HasChunks`.
    pub const HAS_CHUNKS: &str = "HasChunks";
    /// `Peer.FetchChunk`.
    pub const FETCH_CHUNK: &str = "FetchChunk";
    /// `Peer.AdoptLocal`.
    pub const ADOPT: &str = "AdoptLocal";
}

/// This daemon's key and name, and the nonces it has seen.
#[derive(Clone)]
pub struct DaemonKey {
    key: [u8; 32],
    me: String,
    seen: Arc<Mutex<HashMap<String, Instant>>>,
}

impl std::fmt::Debug for DaemonKey {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "DaemonKey({})", self.me)
    }
}

/// What a caller keeps to check the reply to one call.
#[derive(Clone, Debug)]
pub struct Pending {
    nonce: String,
    method: &'static str,
    to: String,
}

type HmacSha256 = SimpleHmac<Sha256>;

fn unix_ms() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_millis() as u64)
}

/// The digest of a message's encoding (`-` stands for a stream's).
pub fn digest<T: Message>(msg: &T) -> String {
    digest_bytes(&msg.encode_to_vec())
}

/// The SHA-256 of `bytes`, in hex.
pub fn digest_bytes(bytes: &[u8]) -> String {
    hex::encode(Sha256::digest(bytes))
}

impl DaemonKey {
    /// The key of the cluster secret `secret`, for daemon `me`. A client key cannot make one.
    pub fn new(secret: &Secret, me: &str) -> Result<Self> {
        let key = secret.daemon_key().ok_or_else(|| {
            Error::Config(
                "the secret file holds a client key; a daemon needs the cluster secret".into(),
            )
        })?;
        Ok(DaemonKey {
            key,
            me: me.to_string(),
            seen: Arc::default(),
        })
    }

    /// An HMAC under the daemon key of `fields` (each length-prefixed), e.g. to seal a
    /// checkpoint.
    pub fn seal(&self, fields: &[&str]) -> [u8; 32] {
        self.mac(fields)
    }

    fn mac(&self, fields: &[&str]) -> [u8; 32] {
        let mut mac = <HmacSha256 as Mac>::new_from_slice(&self.key)
            .unwrap_or_else(|_| unreachable!("HMAC accepts keys of every length"));
        for f in fields {
            mac.update(&(f.len() as u64).to_le_bytes());
            mac.update(f.as_bytes());
        }
        mac.finalize().into_bytes().into()
    }

    /// Attaches a proof to a call of `method` to daemon `to` ([`ANY`] when unknown) whose
    /// body digests to `body` ([`digest`], or `-` for a stream).
    pub fn sign<T>(
        &self,
        to: &str,
        method: &'static str,
        body: &str,
        msg: T,
    ) -> (Request<T>, Pending) {
        static COUNT: AtomicU64 = AtomicU64::new(0);
        let mut nonce = [0u8; 16];
        // Without the OS's randomness the count still makes each nonce distinct.
        let _ = getrandom::getrandom(&mut nonce);
        let nonce = format!(
            "{}{:x}",
            hex::encode(nonce),
            COUNT.fetch_add(1, Ordering::Relaxed)
        );
        let ts = unix_ms().to_string();
        let mac = hex::encode(self.mac(&["call", method, &self.me, to, &ts, &nonce, body]));
        let mut req = Request::new(msg);
        let line = format!("{} {to} {ts} {nonce} {mac}", self.me);
        if let Ok(v) = AsciiMetadataValue::try_from(line) {
            req.metadata_mut().insert(CALL_METADATA, v);
        }
        let pending = Pending {
            nonce,
            method,
            to: to.to_string(),
        };
        (req, pending)
    }

    /// Checks the proof of an incoming call of `method` whose body digests to `body`; returns
    /// the calling daemon's name.
    pub fn verify<T>(&self, req: &Request<T>, method: &str, body: &str) -> Result<String, Status> {
        let deny = |why: &str| Status::unauthenticated(format!("peer call refused: {why}"));
        let line = req
            .metadata()
            .get(CALL_METADATA)
            .ok_or_else(|| deny("no daemon proof (clients use the Rem service)"))?
            .to_str()
            .map_err(|_| deny("malformed proof"))?;
        let parts: Vec<&str> = line.split(' ').collect();
        let [from, to, ts, nonce, mac] = parts[..] else {
            return Err(deny("malformed proof"));
        };
        if !crate::wire::ids::is_valid_name(from) || from == self.me || nonce.len() > 128 {
            return Err(deny("bad caller"));
        }
        if to != self.me {
            return Err(deny("the call was meant for another daemon"));
        }
        let ts_ms: u64 = ts.parse().map_err(|_| deny("bad time"))?;
        if ts_ms.abs_diff(unix_ms()) > MAX_SKEW.as_millis() as u64 {
            return Err(deny("the call's time is too far from this host's clock"));
        }
        let want = self.mac(&["call", method, from, to, ts, nonce, body]);
        let given = hex::decode(mac).map_err(|_| deny("malformed proof"))?;
        if !bool::from(want.as_slice().ct_eq(&given)) {
            return Err(deny("wrong proof"));
        }
        self.fresh(nonce)?;
        Ok(from.to_string())
    }

    /// Remembers `nonce`; an error if it was seen (a replay) or the table is full.
    fn fresh(&self, nonce: &str) -> Result<(), Status> {
        let mut seen = self.seen.lock().unwrap_or_else(|e| e.into_inner());
        let now = Instant::now();
        if seen.len() >= MAX_NONCES {
            seen.retain(|_, t| now.duration_since(*t) < MAX_SKEW * 2);
            if seen.len() >= MAX_NONCES {
                return Err(Status::resource_exhausted("too many peer calls"));
            }
        }
        if seen.insert(nonce.to_string(), now).is_some() {
            return Err(Status::unauthenticated("peer call refused: replayed"));
        }
        Ok(())
    }

    /// A reply to a call that proved `req`'s nonce, with this daemon's proof attached.
    pub fn reply<T: Message, R>(&self, req: &Request<R>, method: &str, msg: T) -> Response<T> {
        let nonce = req
            .metadata()
            .get(CALL_METADATA)
            .and_then(|v| v.to_str().ok())
            .and_then(|l| l.split(' ').nth(3))
            .unwrap_or_default()
            .to_string();
        let mac = hex::encode(self.mac(&["reply", method, &self.me, &nonce, &digest(&msg)]));
        let mut resp = Response::new(msg);
        if let Ok(v) = AsciiMetadataValue::try_from(format!("{} {mac}", self.me)) {
            resp.metadata_mut().insert(REPLY_METADATA, v);
        }
        resp
    }

    /// Checks the reply to a call; returns the answering daemon's name and the message.
    pub fn check_reply<T: Message>(
        &self,
        pending: &Pending,
        resp: Response<T>,
    ) -> Result<(String, T), Status> {
        let deny = |why: &str| Status::unauthenticated(format!("peer reply refused: {why}"));
        let line = resp
            .metadata()
            .get(REPLY_METADATA)
            .ok_or_else(|| deny("no proof"))?
            .to_str()
            .map_err(|_| deny("malformed proof"))?
            .to_string();
        let (from, mac) = line
            .split_once(' ')
            .ok_or_else(|| deny("malformed proof"))?;
        if pending.to != ANY && from != pending.to {
            return Err(deny("another daemon answered"));
        }
        let msg = resp.into_inner();
        let want = self.mac(&["reply", pending.method, from, &pending.nonce, &digest(&msg)]);
        let given = hex::decode(mac).map_err(|_| deny("malformed proof"))?;
        if !bool::from(want.as_slice().ct_eq(&given)) {
            return Err(deny("wrong proof"));
        }
        Ok((from.to_string(), msg))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::wire::proto::{HostInfo, KillRequest};

    fn key(secret: &str, me: &str) -> DaemonKey {
        DaemonKey::new(&Secret::new(secret).unwrap(), me).unwrap()
    }

    #[test]
    fn a_signed_call_is_accepted_once_by_its_target() {
        let (a, b, c) = (key("s", "a"), key("s", "b"), key("s", "c"));
        let body = KillRequest {
            proc_id: "b/1".into(),
        };
        let (req, _) = a.sign("b", method::KILL, &digest(&body), body.clone());
        assert_eq!(b.verify(&req, method::KILL, &digest(&body)).unwrap(), "a");
        // Replayed: refused. Sent on to another daemon: refused.
        assert!(b.verify(&req, method::KILL, &digest(&body)).is_err());
        assert!(c.verify(&req, method::KILL, &digest(&body)).is_err());
        // Another body or method under the same proof: refused.
        let (req, _) = a.sign("b", method::KILL, &digest(&body), body.clone());
        let other = KillRequest {
            proc_id: "b/2".into(),
        };
        assert!(b.verify(&req, method::KILL, &digest(&other)).is_err());
        assert!(b.verify(&req, method::LOGS, &digest(&body)).is_err());
        // The reply is believed only with b's proof of the same nonce.
        let (req, pending) = a.sign("b", method::KILL, &digest(&body), body.clone());
        let reply = b.reply(&req, method::KILL, HostInfo::default());
        assert_eq!(a.check_reply(&pending, reply).unwrap().0, "b");
        let forged = Response::new(HostInfo::default());
        assert!(a.check_reply(&pending, forged).is_err());
    }

    #[test]
    fn another_secret_proves_nothing() {
        let a = key("s", "a");
        let mallory = key("not-s", "a");
        let (req, pending) = mallory.sign("b", method::PS, "-", ());
        assert!(key("s", "b").verify(&req, method::PS, "-").is_err());
        let reply = key("not-s", "b").reply(&req, method::PS, HostInfo::default());
        assert!(a.check_reply(&pending, reply).is_err());
        // No proof at all, or one for "anyone".
        assert!(key("s", "b")
            .verify(&Request::new(()), method::PS, "-")
            .is_err());
        let (req, _) = a.sign(ANY, method::PS, "-", ());
        assert!(key("s", "b").verify(&req, method::PS, "-").is_err());
    }
}
