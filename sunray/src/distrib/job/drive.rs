//! One run of a job's controller, wherever it runs: start (or take over) the workers, run
//! the [controller actor](crate::distrib::controller) to its end, and total the statistics
//! of the whole image. The in-process job ([`run`](super::run), `sunray submit
//! --in-process`) and the farm's controller process
//! ([`controller_process`](crate::distrib::farm::controller_process)) both go through
//! [`run_controller`]; what differs between them (how the workers are found, the farm's lease on the
//! job) is their [`ControllerSite`].

use crate::distrib::checkpoint::{Checkpointer, Restored};
use crate::distrib::controller::{self, ControllerConfig, ControllerError, Start, WorkerProc};
use crate::distrib::line_passes::LinePasses;
use crate::distrib::nodes::{self, JobStats};
use crate::distrib::strategy::Strategy;
use crate::distrib::timeline::{JobClock, Timeline};
use crate::film::Film;
use crate::stats::RenderStats;
use rem::RemClient;
use std::time::Duration;

/// Where a job's controller runs: in the submitting process (`--in-process`, `--resume`) or
/// in the farm's controller process.
pub(crate) trait ControllerSite {
    /// Why the job could not run here.
    type Error;

    /// The job's workers, owned by `owner` (the relay the controller reads): started, or
    /// taken over from an earlier controller.
    async fn workers(&mut self, owner: &rem::ProcId) -> Result<Vec<WorkerProc>, Self::Error>;

    /// Runs beside the controller (the farm's lease on the job, and its share of the
    /// farm's slots: workers it starts or retires go to the actor through `feed`); returns
    /// only when the controller must stand down, with why.
    async fn hold(&mut self, feed: tokio::sync::mpsc::Sender<controller::Input>) -> String;

    /// The job's image is stored and every line is in (`ended` is the job as it is then);
    /// its workers are winding down. The farm's controller says now that the job is
    /// finished; a job in this process ends with its controller.
    async fn image_stored(&mut self, ended: &Ended) -> Result<(), Self::Error> {
        let _ = ended;
        Ok(())
    }

    /// The error of a controller that failed (a newer controller's refusal is not one: that
    /// is [`Ran::Superseded`]).
    fn controller_failed(&self, e: ControllerError) -> Self::Error;
}

/// What a controller starts from, besides its workers.
pub(crate) struct Drive {
    /// How the controller actor runs.
    pub(crate) cfg: ControllerConfig,
    /// The REM client: checkpoints, and the workers' ends.
    pub(crate) client: RemClient,
    /// The relay the controller reads, attached for the job.
    pub(crate) relay: rem::Relay,
    /// Lines and state from the job's checkpoint (a resumed or restarted job).
    pub(crate) restored: Option<Restored>,
    /// Where checkpoints are written.
    pub(crate) checkpointer: Checkpointer,
    /// The job's epoch in the farm (0: in this process).
    pub(crate) epoch: u64,
}

/// The parts of the job's statistics known before it runs.
#[derive(Clone)]
pub(crate) struct Totals {
    /// The scene and image ([`Settings::stats_header`](crate::render::Settings::stats_header)).
    pub(crate) header: RenderStats,
    /// Workers the job asked for.
    pub(crate) hosts: u32,
    /// What the submitting host's remd sent of the model.
    pub(crate) scene_bytes_sent: u64,
}

/// How a controller's run ended.
// One per run, moved once: the size of the `Ended` variant costs nothing worth a Box.
#[allow(clippy::large_enum_variant)]
pub(crate) enum Ran {
    /// The controller ran to its end.
    Ended(Ended),
    /// A newer controller has the job (REM refused this one's writes).
    Superseded(String),
}

/// A controller's run to its end.
pub(crate) struct Ended {
    /// False when no worker was left to finish the image.
    pub(crate) finished: bool,
    /// Whether the job's last checkpoint was stored (a finished job's image is on the farm).
    pub(crate) stored: bool,
    /// The image of the accepted lines (and those of earlier runs).
    pub(crate) film: Film,
    /// The per-node table and the totals.
    pub(crate) stats: JobStats,
    /// With a target error: what each pixel took.
    pub(crate) passes: Option<LinePasses>,
}

/// How long a job's end waits for its workers to exit (see
/// [`ControllerConfig::finish_grace`]).
pub(crate) const FINISH_GRACE: Duration = Duration::from_secs(3);

/// A controller's settings for `job`, as they are wherever it runs; the site sets what it
/// shows (bar, events, preview, web view) and what a farm controller takes over.
pub(crate) fn controller_config(
    job: &str,
    strategy: Strategy,
    (width, height): (u32, u32),
    scene: Vec<u8>,
    worker_timeout: Option<Duration>,
    checkpoint_every: Duration,
) -> ControllerConfig {
    let adaptive = adaptive_of(&scene);
    ControllerConfig {
        job: job.to_string(),
        strategy,
        width,
        height,
        scene,
        worker_timeout,
        checkpoint_every,
        preview: None,
        preview_every: Duration::from_secs(3600),
        show_bar: false,
        events: false,
        finish_grace: FINISH_GRACE,
        fetch_grace: FINISH_GRACE,
        checkpointed: None,
        adopt: None,
        web: None,
        clock: JobClock::at(0),
        timeline: Timeline::default(),
        adaptive,
        crew: None,
    }
}

/// The target error of the Scene message `scene` (which this process encoded): the job's
/// lines then go out a pass at a time.
fn adaptive_of(scene: &[u8]) -> Option<crate::render::adaptive::Adaptive> {
    use crate::distrib::messages::{self, Body};
    match messages::decode(scene) {
        Ok(Body::Scene(s)) => s
            .settings
            .as_ref()
            .and_then(|p| crate::render::Settings::from_proto(p).ok())
            .and_then(|s| s.render.adaptive),
        _ => None,
    }
}

/// Runs a controller at `site`: its workers, the actor to its end (or until the site says
/// to stand down), and the statistics.
pub(crate) async fn run_controller<S: ControllerSite>(
    site: &mut S,
    mut start: Drive,
    totals: Totals,
) -> Result<Ran, S::Error> {
    let cfg = &mut start.cfg;
    cfg.timeline
        .controller_started
        .get_or_insert(cfg.clock.now());
    let workers = site.workers(start.relay.id()).await?;
    let (job, strategy) = (start.cfg.job.clone(), start.cfg.strategy);
    let (sender, receiver) = start.relay.split();
    let handle = controller::spawn(Start {
        cfg: start.cfg,
        client: start.client,
        sender,
        receiver,
        workers,
        restored: start.restored,
        checkpointer: start.checkpointer,
        epoch: start.epoch,
    });
    // What comes first: the controller's end, its stored image, or the site's word to stand
    // down (the farm's lease). Once the image is stored the job is finished: the lease is
    // not held while the workers wind down.
    enum First {
        Joined(Result<controller::JobResult, ControllerError>),
        Image(controller::JobResult),
        StandDown(String),
    }
    // A controller that stands down stops at once: it says and writes nothing more.
    let stop = handle.task.abort_handle();
    let feed = handle.tx.clone();
    let (mut image, joined) = handle.split();
    tokio::pin!(joined);
    let first = tokio::select! {
        r = &mut joined => First::Joined(r),
        Ok(now) = &mut image => First::Image(now),
        why = site.hold(feed) => First::StandDown(why),
    };
    let result = match first {
        First::StandDown(why) => {
            stop.abort();
            return Ok(Ran::Superseded(why));
        }
        First::Joined(r) => r,
        First::Image(now) => {
            let at_image = job_stats(&job, strategy, totals.clone(), now);
            site.image_stored(&at_image).await?;
            match joined.await {
                Ok(result) => return Ok(Ran::Ended(job_stats(&job, strategy, totals, result))),
                // The job was finished already; its wind-down failing changes nothing.
                Err(_) => return Ok(Ran::Ended(at_image)),
            }
        }
    };
    match result {
        Ok(result) => Ok(Ran::Ended(job_stats(&job, strategy, totals, result))),
        Err(ControllerError::Superseded(why)) => Ok(Ran::Superseded(why)),
        Err(e) => Err(site.controller_failed(e)),
    }
}

/// The statistics of a controller's run of `job`: the per-node table, and the header (the
/// scene and image) with the counted totals of every line; and the image.
fn job_stats(
    job: &str,
    strategy: Strategy,
    totals: Totals,
    result: controller::JobResult,
) -> Ended {
    let controller::JobResult {
        film,
        nodes,
        counters,
        lines,
        elapsed_s,
        finished,
        stored,
        cost,
        timeline,
        passes,
    } = result;
    let mut sums = totals.header;
    sums.threads = nodes.iter().map(|n| n.threads as usize).sum();
    sums.time.render_s = elapsed_s;
    sums.time.cpu_s = nodes.iter().map(|n| n.cpu_s).sum();
    sums.set_counters(&counters);
    sums.error = passes.as_ref().map(LinePasses::error_stats);
    let (wait_share, tail_wait_share) = nodes::wait_shares(&nodes);
    let stats = JobStats {
        job: job.to_string(),
        strategy: Some(strategy),
        hosts: totals.hosts,
        lines,
        elapsed_s,
        totals: sums,
        controller: cost,
        scene_bytes_sent: totals.scene_bytes_sent,
        wait_share,
        tail_wait_share,
        nodes,
        timeline,
    };
    Ended {
        finished,
        stored,
        film,
        stats,
        passes,
    }
}
