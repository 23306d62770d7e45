//! A new job's scene as the job takes it: where it came from, its [summary](SceneSummary),
//! and its model, either compiled here (bytes to ship) or [shipped before](ShippedScenes)
//! and still in REM (only the chunks' names). A job compiled here is remembered once shipped,
//! so the next submit of the same file compiles and sends nothing.

use crate::distrib::model_chunks::{self, ShippedModel};
use crate::distrib::shipped_scenes::{
    SceneKey, ShippedInput, ShippedScene, ShippedScenes, MAX_INPUTS,
};
use crate::scene::load::{CompiledScene, SceneSource};
use crate::scene::summary::SceneSummary;
use rem::RemClient;

/// A job's model.
pub enum JobModel {
    /// Compiled here: the bytes to ship (shared: each chunk sent is a slice of them).
    Bytes(bytes::Bytes),
    /// Shipped before: its chunks are in REM.
    Shipped(ShippedModel),
}

/// Where a job's model is remembered once shipped.
#[derive(Clone, Debug)]
pub struct Remember {
    /// The folder of remembered scenes.
    pub scenes: ShippedScenes,
    /// The scene's key there.
    pub key: SceneKey,
    /// The other files its model was made from, with their keys when it was.
    pub inputs: Vec<ShippedInput>,
}

/// A new job's scene.
pub struct JobInput {
    /// Where it came from.
    pub source: SceneSource,
    /// Its counts and own settings.
    pub summary: SceneSummary,
    /// Its model.
    pub model: JobModel,
    /// The compiler's warnings (printed once already, when it was compiled).
    pub warnings: Vec<String>,
    /// Where to remember it once shipped (a scene compiled here from a file).
    pub remember: Option<Remember>,
}

impl JobInput {
    /// The input of a scene compiled here (remembered once shipped only when every other
    /// file it was made from can be keyed).
    pub fn compiled(compiled: CompiledScene, remember: Option<Remember>) -> JobInput {
        let remember = remember.and_then(|r| r.made_from(&compiled.inputs));
        JobInput {
            summary: compiled.summary,
            source: compiled.source,
            model: JobModel::Bytes(compiled.model.into()),
            warnings: compiled.warnings,
            remember,
        }
    }

    /// The input of a scene shipped before (`entry`), from `source`.
    pub fn shipped_before(source: SceneSource, entry: &ShippedScene) -> JobInput {
        JobInput {
            source,
            summary: entry.summary,
            model: JobModel::Shipped(entry.model.clone()),
            warnings: entry.warnings.clone(),
            remember: None,
        }
    }
}

impl JobModel {
    /// Puts the model into REM through `client`'s daemon (a model shipped before is there:
    /// nothing is sent).
    pub async fn ship(&self, client: &RemClient) -> rem::Result<ShippedModel> {
        match self {
            JobModel::Bytes(bytes) => model_chunks::ship(client, bytes).await,
            JobModel::Shipped(m) => Ok(m.clone()),
        }
    }
}

/// A scene file recalled from this user's remembered scenes: its entry if one is kept, and
/// where to remember it once shipped.
pub struct Recalled {
    /// The entry kept for the file, if any (its chunks are not checked yet).
    pub entry: Option<ShippedScene>,
    /// Where the job is remembered once shipped; none for the built-in scene, an unreadable
    /// file, or no cache folder.
    pub remember: Option<Remember>,
}

impl Recalled {
    /// Looks `source` (compiled with the colour file `colours`, the one that applies) up
    /// in this user's remembered scenes.
    pub fn look_up(source: &SceneSource, colours: Option<&std::path::Path>) -> Recalled {
        let remember = source.path().and_then(|path| {
            let scenes = ShippedScenes::for_user()?;
            let key = scenes.key_of(path, colours).ok()?;
            Some(Remember {
                scenes,
                key,
                inputs: Vec::new(),
            })
        });
        let entry = remember.as_ref().and_then(|r| r.scenes.find(&r.key));
        Recalled { entry, remember }
    }

    /// The entry's input when `client`'s daemon still has every chunk of its model; none
    /// when there is no entry or a chunk is gone (the scene is then compiled again).
    pub async fn still_shipped(
        &self,
        client: &RemClient,
        source: &SceneSource,
    ) -> Option<JobInput> {
        let entry = self.entry.as_ref()?;
        let held = rem::client::blob::cached(client, &entry.model.chunks)
            .await
            .ok()?;
        held.iter()
            .all(|&h| h)
            .then(|| JobInput::shipped_before(source.clone(), entry))
    }
}

impl Remember {
    /// This, for a model made from the scene file and `files` as they are now; none when
    /// one cannot be read or there are too many to remember.
    fn made_from(mut self, files: &[std::path::PathBuf]) -> Option<Remember> {
        if files.len() > MAX_INPUTS {
            return None;
        }
        self.inputs = files
            .iter()
            .map(|f| {
                let path = std::path::absolute(f).ok()?;
                let key = self.scenes.key_of(&path, None).ok()?;
                Some(ShippedInput { path, key })
            })
            .collect::<Option<Vec<_>>>()?;
        Some(self)
    }

    /// Remembers a scene of `summary` and `warnings` as shipped as `model` (a failure only
    /// warns: the job goes on).
    pub fn keep(&self, summary: SceneSummary, warnings: Vec<String>, model: &ShippedModel) {
        let entry = ShippedScene::new(summary, warnings, model, self.inputs.clone());
        if let Err(e) = self.scenes.keep(&self.key, &entry) {
            eprintln!("sunray: warning: cannot remember the shipped scene: {e}");
        }
    }
}
