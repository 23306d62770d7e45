//! Credentials, made with the test secret: the client key, daemons' proofs of peer calls
//! and checkpoint seals, and putting an input's credential (valid or not) on a request.

use std::time::{SystemTime, UNIX_EPOCH};

use super::inputs::{Credential, Input};
use super::values::World;
use crate::common::SECRET;
use hmac::{Mac, SimpleHmac};
use rem::wire::proto;
use sha2::{Digest, Sha256};
use tonic::metadata::{AsciiMetadataValue, BinaryMetadataValue};
use tonic::Request;

fn secret() -> rem::Secret {
    rem::Secret::new(SECRET).unwrap()
}

/// The user the fuzzer's valid client credential proves (the harness's clients act as the
/// same, the default user).
pub(super) fn fuzz_user() -> String {
    rem::auth::identity::default_user()
}

pub(super) fn client_key() -> [u8; 32] {
    secret().client_credential(Some(&fuzz_user())).unwrap().1
}

pub(super) fn unix_ms() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_millis() as u64)
}

pub(super) fn sha256_hex(bytes: &[u8]) -> String {
    hex::encode(Sha256::digest(bytes))
}

/// HMAC-SHA256 under the daemon key of `fields`, each length-prefixed (as `peer_auth`).
fn daemon_mac(fields: &[&str]) -> [u8; 32] {
    let key = secret().daemon_key().unwrap();
    let mut mac = <SimpleHmac<Sha256> as Mac>::new_from_slice(&key).unwrap();
    for f in fields {
        mac.update(&(f.len() as u64).to_le_bytes());
        mac.update(f.as_bytes());
    }
    mac.finalize().into_bytes().into()
}

/// The seal a daemon puts on a checkpoint it writes.
pub(super) fn checkpoint_seal(cp: &proto::Checkpoint) -> [u8; 32] {
    daemon_mac(&[
        "checkpoint",
        &cp.user,
        &cp.job,
        &cp.version.to_string(),
        &cp.written_by,
        &sha256_hex(&cp.data),
        &cp.epoch.to_string(),
    ])
}

/// A peer call's proof: `FROM TO MILLIS NONCE MAC`.
fn peer_line(method: &str, from: &str, to: &str, ms: u64, body: &str) -> String {
    static NONCES: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    let nonce = format!(
        "fuzz{:x}",
        NONCES.fetch_add(1, std::sync::atomic::Ordering::Relaxed)
    );
    let ts = ms.to_string();
    let mac = hex::encode(daemon_mac(&["call", method, from, to, &ts, &nonce, body]));
    format!("{from} {to} {ts} {nonce} {mac}")
}

/// Puts `input`'s credential on `req`.
pub(super) fn authorize<T>(req: &mut Request<T>, input: &Input, world: &World) {
    let md = req.metadata_mut();
    let me = &world.names[input.daemon];
    let body = || {
        input
            .rpc
            .body_digest(input.frames.first().map_or(&[], Vec::as_slice))
    };
    let peer_line_value = match &input.credential {
        Credential::Valid(_) if !input.rpc.is_peer() => {
            md.insert(
                rem::auth::secret::USER_METADATA,
                fuzz_user().parse().unwrap(),
            );
            md.insert_bin(
                rem::auth::secret::CLIENT_KEY_METADATA,
                BinaryMetadataValue::from_bytes(&client_key()),
            );
            None
        }
        Credential::Valid(from) => Some(peer_line(input.rpc.name(), from, me, unix_ms(), &body())),
        Credential::None => None,
        Credential::ClientKey(k) => {
            md.insert(
                rem::auth::secret::USER_METADATA,
                fuzz_user().parse().unwrap(),
            );
            md.insert_bin(
                rem::auth::secret::CLIENT_KEY_METADATA,
                BinaryMetadataValue::from_bytes(k),
            );
            None
        }
        Credential::ProcessToken(t) => {
            if let Ok(v) = AsciiMetadataValue::try_from(t.as_str()) {
                md.insert(rem::auth::secret::PROC_TOKEN_METADATA, v);
            }
            None
        }
        Credential::PeerLine(line) => Some(line.clone()),
        Credential::SignedOtherBody(from) => Some(peer_line(
            input.rpc.name(),
            from,
            me,
            unix_ms(),
            &sha256_hex(b"other"),
        )),
        Credential::SignedAt(from, to, ms) => {
            Some(peer_line(input.rpc.name(), from, to, *ms, &body()))
        }
    };
    if let Some(line) = peer_line_value {
        if let Ok(v) = AsciiMetadataValue::try_from(line) {
            md.insert(PEER_METADATA, v);
        }
    }
}

/// The metadata entry of a peer call's proof (`peer_auth::CALL_METADATA`).
const PEER_METADATA: &str = "x-rem-peer";
