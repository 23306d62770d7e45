//! A job's plan: everything decided before the workers start, for a new scene
//! ([`new_plan`]: settings, output and job id from the request and the [input](JobInput)) or for a job resumed from
//! its checkpoint ([`resume_plan`]: the same scene, checked against the checkpoint's model
//! hash, with the settings it was started with).

use super::input::{JobInput, JobModel, Remember};
use super::{check_job_id, JobError, JobRequest};
use crate::distrib::checkpoint::{self, Restored};
use crate::distrib::connection::RemConnection;
use crate::distrib::messages;
use crate::distrib::model_chunks::ShippedModel;
use crate::distrib::strategy::Strategy;
use crate::film::Format;
use crate::render::Settings;
use crate::scene::load::{self, SceneSource};
use crate::scene::summary::SceneSummary;
use std::path::PathBuf;

/// Everything decided before the workers start.
pub(crate) struct Plan {
    pub(crate) job: String,
    pub(crate) source: SceneSource,
    pub(crate) summary: SceneSummary,
    pub(crate) settings: Settings,
    pub(crate) model: JobModel,
    /// Where a model compiled here is remembered once shipped, with its warnings.
    pub(crate) remember: Option<(Remember, Vec<String>)>,
    pub(crate) output: PathBuf,
    pub(crate) colours: Option<PathBuf>,
    pub(crate) strategy: Strategy,
    pub(crate) hosts: u32,
    pub(crate) nice: bool,
    pub(crate) threads: Option<usize>,
    pub(crate) restored: Option<Restored>,
}

/// The plan of a new job: `input` rendered with the request's settings.
pub(crate) fn new_plan(req: &JobRequest, input: JobInput) -> Result<Plan, JobError> {
    let settings = req.overrides.settings_for(&input.summary)?;
    let output = req
        .output
        .clone()
        .unwrap_or_else(|| input.source.default_output());
    Format::from_path(&output)?;
    let job = req.job.clone().unwrap_or_else(|| {
        format!(
            "sunray-{}-{}",
            checkpoint::unix_ms() / 1000,
            std::process::id()
        )
    });
    Ok(Plan {
        job,
        source: input.source,
        summary: input.summary,
        remember: input.remember.map(|r| (r, input.warnings)),
        model: input.model,
        settings,
        output,
        colours: req.colours.clone(),
        strategy: req.strategy.unwrap_or(Strategy::Dynamic),
        hosts: req.hosts.unwrap_or(1),
        nice: req.nice,
        threads: req.threads.filter(|&t| t > 0),
        restored: None,
    })
}

impl Plan {
    /// Ships the model through `client`'s daemon, and remembers a model compiled here as
    /// shipped.
    pub(crate) async fn ship(&self, client: &rem::RemClient) -> rem::Result<ShippedModel> {
        let shipped = self.model.ship(client).await?;
        if let Some((r, warnings)) = &self.remember {
            r.keep(self.summary, warnings.clone(), &shipped);
        }
        Ok(shipped)
    }
}

/// The plan of resuming `job` from its checkpoint on `cluster` (its scene from `scene`, or
/// where the checkpoint remembers it).
pub(super) async fn resume_plan(
    req: &JobRequest,
    cluster: &RemConnection,
    job: String,
    scene: Option<PathBuf>,
) -> Result<Plan, JobError> {
    check_job_id(&job)?;
    let restored = checkpoint::load(&cluster.client, &job)
        .await
        .map_err(|source| JobError::ReadCheckpoint {
            job: job.clone(),
            source,
        })?
        .ok_or_else(|| JobError::NoCheckpoint {
            job: job.clone(),
            addr: cluster.addr.clone(),
        })?;
    let spec = restored.header.spec.clone().unwrap_or_default();
    let source = match scene {
        Some(p) => SceneSource::File(p),
        None => SceneSource::from_remembered(&spec.scene),
    };
    let colours = (!spec.colours.is_empty()).then(|| PathBuf::from(&spec.colours));
    let compiled = load::compile_for_job(&source, colours.as_deref())?;
    let model = compiled.model;
    if messages::fnv1a(&model) != restored.header.model_hash {
        return Err(JobError::SceneChanged(job));
    }
    let settings = match spec.settings.as_ref().map(Settings::from_proto) {
        Some(Ok(s)) => s,
        Some(Err(e)) => {
            return Err(JobError::BadSettings {
                job,
                reason: Some(e),
            })
        }
        None => return Err(JobError::BadSettings { job, reason: None }),
    };
    let output = req
        .output
        .clone()
        .unwrap_or_else(|| PathBuf::from(&spec.output));
    Format::from_path(&output)?;
    Ok(Plan {
        job,
        source: compiled.source,
        summary: compiled.summary,
        settings,
        model: JobModel::Bytes(model.into()),
        remember: None,
        output,
        colours,
        strategy: req
            .strategy
            .or_else(|| Strategy::from_name(&spec.strategy))
            .unwrap_or(Strategy::Dynamic),
        hosts: req.hosts.unwrap_or(spec.hosts.max(1)),
        nice: req.nice || spec.nice,
        threads: req
            .threads
            .or((spec.threads > 0).then_some(spec.threads as usize)),
        restored: Some(restored),
    })
}
