//! A worker's scene from its host's prepared scene ([`crate::prepared`]): mapped when the
//! host's cache has a good one (no model fetched, nothing decoded or built), else made by a
//! keeper (`sunray prepare-scene`, a process of its own that a job's end does not
//! interrupt) from the model the worker fetches and streams to it, then mapped. Anything
//! that goes wrong on the way is a warning: the worker then fetches and builds the scene
//! itself, as without a cache.

use super::{settings_of, Link, ReadyScene, WorkerError};
use crate::distrib::messages::proto;
use crate::distrib::model_chunks::{self, ModelSink};
use crate::prepared::keeper;
use rem::RemClient;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ChildStdin;
use std::sync::Arc;
use std::time::Instant;

/// The scene of `msg` from the prepared scene at `path`, mapped: the one there, or the one a
/// keeper makes (the controller told of its stages through `link`); None (after a warning)
/// when neither came.
pub(super) async fn ready(
    msg: &proto::Scene,
    path: PathBuf,
    t0: Instant,
    link: &Link,
) -> Option<ReadyScene> {
    let hash = msg.model_hash;
    let fetch = proto::SceneFetch {
        cached: true,
        accel_cached: true,
        ..proto::SceneFetch::default()
    };
    if let Some(r) = mapped(msg, path.clone(), fetch, t0).await {
        return Some(r);
    }
    let settings = settings_of(msg).ok()?;
    link.preparing(proto::preparing::Stage::Fetching, None)
        .await
        .ok()?;
    let mut child = keeper::spawn(&path, hash, &settings.accel)
        .map_err(|e| {
            warn(&format!(
                "cannot start the keeper of the prepared scene: {e}"
            ))
        })
        .ok()?;
    let stdin = child.stdin.take()?;
    let fed = match RemClient::from_env().await {
        Ok(client) => model_chunks::fetch_into(&client, msg, Feed(stdin)).await,
        Err(e) => Err(e),
    };
    // A keeper that found the file kept by another (a second worker of the job on this
    // host) ends without reading the model: the feed fails, and what it found is mapped.
    let mut fetch = match fed {
        Ok((_, f)) => f,
        Err(_) => proto::SceneFetch {
            cached: true,
            ..proto::SceneFetch::default()
        },
    };
    link.preparing(proto::preparing::Stage::Building, Some(&fetch))
        .await
        .ok()?;
    let said = tokio::task::spawn_blocking(move || child.wait_with_output()).await;
    let said = match said {
        Ok(Ok(out)) if out.status.success() => String::from_utf8_lossy(&out.stdout).into_owned(),
        other => {
            warn(&format!(
                "the keeper of the prepared scene failed: {other:?}"
            ));
            return None;
        }
    };
    fetch.accel_cached = said.trim() == keeper::KEPT_CACHED;
    mapped(msg, path, fetch, t0).await
}

/// The prepared scene at `path`, mapped, reported as `fetch` says and as mapped; None when
/// there is none or it is refused (a warning; the caller makes it anew).
async fn mapped(
    msg: &proto::Scene,
    path: PathBuf,
    mut fetch: proto::SceneFetch,
    t0: Instant,
) -> Option<ReadyScene> {
    let settings = settings_of(msg).ok()?;
    let hash = msg.model_hash;
    let t_map = Instant::now();
    let loaded = tokio::task::spawn_blocking(move || crate::prepared::load(&path, hash)).await;
    let (scene, accel) = match loaded {
        Ok(Ok(Some(s))) => s,
        Ok(Ok(None)) => return None,
        Ok(Err(e)) => {
            warn(&format!("prepared scene refused, made anew: {e}"));
            return None;
        }
        Err(e) => {
            warn(&format!("reading the prepared scene failed: {e}"));
            return None;
        }
    };
    fetch.scene_mapped = true;
    fetch.scene_ready_s = t0.elapsed().as_secs_f64();
    Some(ReadyScene {
        scene_at: Instant::now(),
        scene: Arc::new(scene),
        accel: Arc::new(accel),
        settings,
        fetch,
        preprocess_s: t_map.elapsed().as_secs_f64(),
    })
}

fn warn(what: &str) {
    eprintln!("sunray worker: warning: {what}");
}

/// The keeper's standard input, which the model is streamed to.
struct Feed(ChildStdin);

impl ModelSink for Feed {
    type Out = ();
    fn take(&mut self, piece: &[u8]) -> Result<(), String> {
        self.0
            .write_all(piece)
            .map_err(|e| format!("the keeper: {e}"))
    }
    fn finish(self) -> Result<(), String> {
        Ok(())
    }
}

/// The prepared scene file of `msg` in the host's cache, when the worker has a cache and
/// such scenes are kept for its accelerator.
pub(super) fn path_of(msg: &proto::Scene) -> Result<Option<PathBuf>, WorkerError> {
    let settings = settings_of(msg)?;
    let dir = std::env::var_os(rem::wire::env::CACHE_DIR).map(PathBuf::from);
    Ok(dir
        .as_deref()
        .and_then(|d: &Path| crate::prepared::path_of(d, msg.model_hash, &settings.accel)))
}
