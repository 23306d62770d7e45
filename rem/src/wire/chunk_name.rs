//! A chunk's name, as client and daemon agree on it: the SHA-256 of its bytes in lower-case
//! hex. The name is the chunk's check (every read and every copy between hosts compares the
//! bytes against it) and its file name in the daemon's cache.

use sha2::{Digest, Sha256};

use crate::error::{Error, Result};

/// The name of `data`: its SHA-256, in lower-case hex.
pub fn name_of(data: &[u8]) -> String {
    hex::encode(Sha256::digest(data))
}

/// Whether `hash` is a chunk name (64 lower-case hex digits): it becomes a file name.
pub fn is_chunk_name(hash: &str) -> bool {
    hash.len() == 64 && hash.bytes().all(|b| matches!(b, b'0'..=b'9' | b'a'..=b'f'))
}

/// The checked name of a request.
pub fn check_name(hash: &str) -> Result<()> {
    if is_chunk_name(hash) {
        Ok(())
    } else {
        Err(Error::Invalid(format!(
            "bad chunk name {} (64 lower-case hex digits)",
            crate::wire::ids::shown(hash)
        )))
    }
}
