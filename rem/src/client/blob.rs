//! Blobs as lists of chunks: a large byte string (a scene's model) cut into chunks of at
//! most `chunk_bytes`, put through the local daemon, and read back by any process of the
//! cluster from the list of names alone. No message carries more than one chunk, so a blob
//! is bounded by memory and disk, not by the message limit.

use crate::client::rem_client::RemClient;
use crate::error::{Error, Result};
use crate::wire::chunk_name::name_of;

/// The default size of a chunk (the daemons' default `chunk_bytes` limit).
pub const CHUNK_BYTES: usize = 4 << 20;

/// Most chunks one blob may have (64 GiB at the default size).
pub const MAX_CHUNKS: usize = 16_384;

/// What putting a blob cost.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Put {
    /// The chunks' names, in order.
    pub chunks: Vec<String>,
    /// Bytes the local daemon sent to peers (0 when they had every chunk).
    pub bytes_sent: u64,
}

/// What reading a blob cost.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Got {
    /// The blob.
    pub data: Vec<u8>,
    /// Bytes the local daemon fetched from peers for it.
    pub bytes_fetched: u64,
    /// Whether the local daemon had every chunk already.
    pub cached: bool,
}

/// The names of `data`'s chunks of `chunk_bytes`, as [`put`] cuts it.
pub fn chunk_names(data: &[u8], chunk_bytes: usize) -> Vec<String> {
    data.chunks(chunk_bytes.max(1)).map(name_of).collect()
}

/// Chunks one [`put`] has on their way at once: the daemon checks, stores and copies each to
/// a peer (hashing it twice and sending it twice), so one chunk at a time leaves the cores
/// waiting on the network and the network on the cores.
pub const PUTS_IN_FLIGHT: usize = 4;

/// Puts `data` in chunks of `chunk_bytes` through `client`'s daemon, [`PUTS_IN_FLIGHT`] at
/// a time; the first failure ends it.
/// Each chunk is a slice of `data`, shared with the call that sends it, never a copy.
pub async fn put(client: &RemClient, data: &bytes::Bytes, chunk_bytes: usize) -> Result<Put> {
    let chunk_bytes = chunk_bytes.max(1);
    let count = data.len().div_ceil(chunk_bytes);
    if count > MAX_CHUNKS {
        return Err(Error::TooLarge {
            size: data.len(),
            limit: MAX_CHUNKS * chunk_bytes,
        });
    }
    let mut out = Put {
        chunks: vec![String::new(); count],
        bytes_sent: 0,
    };
    let mut pieces = (0..count)
        .map(|i| data.slice(i * chunk_bytes..data.len().min((i + 1) * chunk_bytes)))
        .enumerate();
    let mut flying = tokio::task::JoinSet::new();
    loop {
        while flying.len() < PUTS_IN_FLIGHT {
            let Some((i, piece)) = pieces.next() else {
                break;
            };
            let client = client.clone();
            flying.spawn(async move {
                let hash = name_of(&piece);
                let reply = client.put_chunk(&hash, piece).await?;
                Ok::<_, Error>((i, hash, reply.bytes_sent))
            });
        }
        let Some(done) = flying.join_next().await else {
            break;
        };
        let (i, hash, sent) = done.map_err(|e| {
            Error::Io(std::io::Error::other(format!("a chunk's put stopped: {e}")))
        })??;
        out.bytes_sent += sent;
        out.chunks[i] = hash;
    }
    Ok(out)
}

/// Which of `chunks` `client`'s daemon has in its own cache (`CachedChunks`), in order, asked
/// 1024 names at a time (the daemon's limit): a blob put before is still there when every
/// answer is true.
pub async fn cached(client: &RemClient, chunks: &[String]) -> Result<Vec<bool>> {
    let mut has = Vec::with_capacity(chunks.len());
    for part in chunks.chunks(1024) {
        let req = crate::wire::proto::HasChunksRequest {
            hashes: part.to_vec(),
        };
        let answer = client.rpc_mut().cached_chunks(req).await?.into_inner().has;
        if answer.len() != part.len() {
            return Err(Error::Invalid(format!(
                "the daemon answered {} of {} chunk names",
                answer.len(),
                part.len()
            )));
        }
        has.extend(answer);
    }
    Ok(has)
}

/// Reads the blob of `chunks` through `client`'s daemon; `size` is its length (checked).
pub async fn get(client: &RemClient, chunks: &[String], size: u64) -> Result<Got> {
    let (tx, mut rx) = tokio::sync::mpsc::channel::<Vec<u8>>(2);
    // The size is the sender's word: room for it is made as the bytes arrive, not before.
    let cap = usize::try_from(size).unwrap_or(0).min(16 * CHUNK_BYTES);
    let gather = async move {
        let mut data = Vec::with_capacity(cap);
        while let Some(piece) = rx.recv().await {
            data.extend_from_slice(&piece);
        }
        data
    };
    let (got, data) = tokio::join!(get_each(client, chunks, size, tx), gather);
    Ok(Got { data, ..got? })
}

/// Reads the blob of `chunks` through `client`'s daemon one chunk at a time, sending each
/// into `pieces` in order (so that a reader decodes it as it arrives and never holds it
/// whole); `size` is its length, checked before a chunk past it is sent. The answer's `data`
/// is empty. A reader that stops early (drops its receiver) ends the reading with
/// [`Error::Closed`].
pub async fn get_each(
    client: &RemClient,
    chunks: &[String],
    size: u64,
    pieces: tokio::sync::mpsc::Sender<Vec<u8>>,
) -> Result<Got> {
    if chunks.len() > MAX_CHUNKS {
        return Err(Error::Invalid(format!(
            "a blob of {} chunks (at most {MAX_CHUNKS})",
            chunks.len()
        )));
    }
    let mut out = Got {
        data: Vec::new(),
        bytes_fetched: 0,
        cached: true,
    };
    let mut read = 0u64;
    for hash in chunks {
        let reply = client.get_chunk(hash).await?;
        if !reply.cached {
            out.cached = false;
            out.bytes_fetched += reply.data.len() as u64;
        }
        read += reply.data.len() as u64;
        if read > size {
            return Err(Error::Invalid(format!(
                "the blob's chunks hold more than its {size} bytes"
            )));
        }
        pieces.send(reply.data).await.map_err(|_| Error::Closed)?;
    }
    if read != size {
        return Err(Error::Invalid(format!(
            "the blob's chunks hold {read} bytes, not {size}"
        )));
    }
    Ok(out)
}
