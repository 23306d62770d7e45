//! The scene's model on its way to the workers: cut into REM chunks named by their hash
//! (`rem::client::blob`), put once through the submitting host's remd (which keeps a second copy on
//! a peer), and fetched by each worker through its own host's remd, which caches them. No
//! message carries the whole model, so its size is bounded by memory and disk only, and a
//! host that has the scene (a second worker, a second job of the same scene) fetches
//! nothing. A worker decodes the model as its chunks arrive, straight into the scene's
//! compact primitives ([`SceneStream`]), and never holds it whole.

use std::time::Instant;

use crate::distrib::messages;
use crate::distrib::messages::proto;
use crate::scene::{Scene, SceneStream};
use rem::RemClient;

/// A model put into REM, as the Scene message names it (and as a submitting host remembers
/// it, without what that one put cost: [`shipped_scenes`](super::shipped_scenes)).
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ShippedModel {
    /// The chunks' names, in order.
    pub chunks: Vec<String>,
    /// The model's length in bytes.
    pub size: u64,
    /// FNV-1a 64 of the model (the checkpoint's `model_hash`).
    pub hash: u64,
    /// Bytes the submitting host's remd sent to its peers.
    #[serde(skip)]
    pub bytes_sent: u64,
}

impl ShippedModel {
    /// The Scene message of this model with `settings`, for `job`, at `epoch`.
    pub fn scene(&self, settings: proto::RenderSettings, job: &str, epoch: u64) -> proto::Scene {
        proto::Scene {
            model_chunks: self.chunks.clone(),
            model_size: self.size,
            model_hash: self.hash,
            settings: Some(settings),
            job: job.to_string(),
            epoch,
        }
    }
}

/// Puts `model` into REM through `client`'s daemon.
pub async fn ship(client: &RemClient, model: &bytes::Bytes) -> rem::Result<ShippedModel> {
    let put = rem::client::blob::put(client, model, rem::client::blob::CHUNK_BYTES).await?;
    Ok(ShippedModel {
        chunks: put.chunks,
        size: model.len() as u64,
        hash: messages::fnv1a(model),
        bytes_sent: put.bytes_sent,
    })
}

/// What a fetched model's bytes go to, on a blocking thread, in order, as they arrive.
pub trait ModelSink: Send + 'static {
    /// What the whole model made.
    type Out: Send + 'static;
    /// Takes the next bytes of the model.
    fn take(&mut self, piece: &[u8]) -> Result<(), String>;
    /// Ends, once every byte arrived.
    fn finish(self) -> Result<Self::Out, String>;
}

impl ModelSink for SceneStream {
    type Out = Scene;
    fn take(&mut self, piece: &[u8]) -> Result<(), String> {
        self.feed(piece).map_err(|e| e.to_string())
    }
    fn finish(self) -> Result<Scene, String> {
        SceneStream::finish(self).map_err(|e| e.to_string())
    }
}

/// Fetches the model a Scene names through `client`'s daemon and builds the scene from it
/// as its chunks arrive (decoded on a blocking thread, at most a few chunks in flight), so
/// the worker never holds the whole model; how the fetch went is the SceneFetch a worker
/// reports. A model that is not the Scene's (its hash) or does not decode is an error.
pub async fn fetch_scene(
    client: &RemClient,
    scene: &proto::Scene,
) -> rem::Result<(Scene, proto::SceneFetch)> {
    fetch_into(client, scene, SceneStream::new()).await
}

/// Fetches the model a Scene names through `client`'s daemon into `sink` as its chunks
/// arrive; what the sink made of it, and how the fetch went. A model that is not the
/// Scene's (its hash) or that the sink refuses is an error.
pub async fn fetch_into<S: ModelSink>(
    client: &RemClient,
    scene: &proto::Scene,
    mut sink: S,
) -> rem::Result<(S::Out, proto::SceneFetch)> {
    let t0 = Instant::now();
    let (tx, mut rx) = tokio::sync::mpsc::channel::<Vec<u8>>(2);
    let decode = tokio::task::spawn_blocking(move || {
        let mut hash = yari::modelfile::FNV_OFFSET;
        while let Some(piece) = rx.blocking_recv() {
            hash = yari::modelfile::fnv1a_update(hash, &piece);
            sink.take(&piece)?;
        }
        sink.finish().map(|out| (out, hash))
    });
    let got = rem::client::blob::get_each(client, &scene.model_chunks, scene.model_size, tx).await;
    let decoded = decode
        .await
        .map_err(|e| rem::Error::Invalid(format!("decoding the model failed: {e}")))?;
    let got = got?;
    let (built, hash) = decoded.map_err(rem::Error::Invalid)?;
    if hash != scene.model_hash {
        return Err(rem::Error::Invalid(
            "the model's chunks are not the scene's model (hash differs)".into(),
        ));
    }
    let report = proto::SceneFetch {
        bytes_received: got.bytes_fetched,
        cached: got.cached,
        fetch_s: t0.elapsed().as_secs_f64(),
        ..proto::SceneFetch::default()
    };
    Ok((built, report))
}
