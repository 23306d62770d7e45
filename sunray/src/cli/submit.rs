//! `sunray submit`: renders a scene on the SunRay III farm (thesis section 4.2.4). Compiles
//! the scene once and checks it; on a cluster (`--remd`) it hands the job to the farm (REM
//! runs its controller, and starts it again if it or its host fails) and follows it: the
//! progress bar, the image written to `-o` (byte-identical to `sunray render` of the same
//! scene and options) and the per-node table. With no remd configured (a private one and
//! local workers), with `--in-process` or `--resume`, the controller runs in this process,
//! as the thesis's SunRay III did. See docs/sunray-iii.md.

use super::exit;
use super::render::RenderArgs;
use crate::distrib::connection::RemConnection;
use crate::distrib::farm::follow::{self, Ended, WatchView};
use crate::distrib::farm::{self, ControllerFlags, FarmError, Submitted};
use crate::distrib::job::input::{JobInput, Recalled};
use crate::distrib::job::{self, JobError, JobRequest, JobScene};
use crate::distrib::strategy::Strategy;
use crate::distrib::timeline::JobClock;
use crate::scene::load::BUILTIN;
use anyhow::Context;
use clap::Args;
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Duration;

/// The flags of `sunray submit`: those of `sunray render`, and the farm's.
#[derive(Args, Debug, Clone)]
#[command(mut_arg("scene", |a| a
    .required(false)
    .default_value(BUILTIN)
    .help("Scene: .yari, .nff, .off or a compiled model [default: the built-in example]")
    .hide_default_value(true)))]
pub struct SubmitArgs {
    /// The flags shared with `sunray render`: scene, output, image and tracing options.
    #[command(flatten)]
    pub render: RenderArgs,
    /// Workers to start, one per host, on the least-loaded hosts [default: 1; on resume, as before].
    #[arg(long)]
    pub hosts: Option<u32>,
    /// Run the workers at a low priority (nice 10), leaving the hosts responsive.
    #[arg(long)]
    pub nice: bool,
    /// The remd to use [default: a private one on loopback with local workers].
    #[arg(long, env = "REM_ADDR")]
    pub remd: Option<String>,
    /// File with the cluster secret (else REM_SECRET_FILE or REM_SECRET).
    #[arg(long)]
    pub secret_file: Option<PathBuf>,
    /// dynamic (SunRay III), blocks (SunRay I) or interleaved (SunRay II) [default: dynamic].
    #[arg(long, value_enum)]
    pub strategy: Option<Strategy>,
    /// Job id [default: made up]; the key of its checkpoint.
    #[arg(long)]
    pub job: Option<String>,
    /// Continue the job JOB from its checkpoint.
    #[arg(long, value_name = "JOB", conflicts_with = "job")]
    pub resume: Option<String>,
    /// Hand the job to the farm and exit: print its id alone on stdout. REM runs its
    /// controller and starts it again elsewhere if it or its host fails; follow it with
    /// `sunray watch ID`, get the image with `sunray fetch ID -o FILE`, stop it with `sunray
    /// cancel ID`. Needs a cluster (--remd): the private remd of the default set-up ends with
    /// this command, so without one a job lives as long as `submit` does.
    #[arg(long, conflicts_with_all = ["resume", "preview", "in_process"])]
    pub detach: bool,
    /// Run the controller in this process, as the thesis's SunRay III did, rather than
    /// handing the job to the farm: the job stops with this command (`--resume` continues
    /// it). Always so with the private remd of the default set-up, and with `--resume`.
    #[arg(long)]
    pub in_process: bool,
    /// Start the job's controller on the least-loaded live host rather than on the host of
    /// the remd it is submitted through (its restarts always go to the least-loaded).
    #[arg(long, conflicts_with_all = ["resume", "in_process"])]
    pub controller_anywhere: bool,
    /// Rewrite the partial image to FILE every few seconds.
    #[arg(long, value_name = "FILE")]
    pub preview: Option<PathBuf>,
    /// Print machine-readable events (JSON, one per line) on stderr instead of a progress bar.
    #[arg(long)]
    pub events: bool,
    /// The worker program on the hosts [default: this program].
    #[arg(long, env = "SUNRAY_WORKER_PROGRAM")]
    pub worker_program: Option<PathBuf>,
    /// Allow more than one worker per host.
    #[arg(long)]
    pub same_host: bool,
    /// The job's priority in the farm's queue, 0 to 100: a higher one is served first and
    /// may take the slots of lower ones (which carry on smaller, or wait); equal ones share
    /// the farm fairly between users.
    #[arg(long, default_value_t = 50, value_parser = clap::value_parser!(u32).range(0..=100))]
    pub priority: u32,
    /// Never start a worker on HOST, as REM names it (your own workstation, say); repeat
    /// it or list several with commas. A farm job keeps to it when it moves.
    #[arg(long = "avoid-host", value_name = "HOST", value_delimiter = ',')]
    pub avoid_hosts: Vec<String>,
    /// A worker holding a line longer than this is silent [default: 10 s or 20 slowest lines].
    #[arg(long, hide = true)]
    pub worker_timeout_ms: Option<u64>,
    /// Milliseconds between checkpoints (at least 50).
    #[arg(long, hide = true, default_value_t = 2000)]
    pub checkpoint_ms: u64,
    /// With a target error: the in-process controller compacts its checkpoint at every save
    /// that finds a line's record superseded (tests).
    #[arg(long, hide = true)]
    pub compact_every_save: bool,
    /// Milliseconds between preview rewrites (at least 100).
    #[arg(long, hide = true, default_value_t = 2000)]
    pub preview_ms: u64,
}

impl SubmitArgs {
    /// What the flags ask of the job, submitted now.
    pub fn request(&self, worker_program: PathBuf) -> JobRequest {
        JobRequest {
            job: self.job.clone(),
            hosts: self.hosts,
            nice: self.nice,
            strategy: self.strategy,
            same_host: self.same_host,
            avoid_hosts: self.avoid_hosts.clone(),
            priority: self.priority,
            threads: self.render.threads,
            output: self.render.output.clone(),
            samples_map: self.render.samples_map.clone(),
            colours: self.render.colours.colors.clone(),
            overrides: self.render.overrides(),
            worker_program,
            worker_timeout: self.worker_timeout_ms.map(Duration::from_millis),
            checkpoint_every: Duration::from_millis(self.checkpoint_ms.max(50)),
            compact_every_save: self.compact_every_save,
            preview: self.preview.clone(),
            preview_every: Duration::from_millis(self.preview_ms.max(100)),
            show_bar: !self.render.quiet && std::io::stderr().is_terminal(),
            events: self.events,
            submitted_unix_ms: crate::distrib::checkpoint::unix_ms(),
        }
    }
}

/// Runs the job and prints its per-node table; the exit code says whether the image is done.
pub fn run(args: SubmitArgs) -> anyhow::Result<ExitCode> {
    let program = match &args.worker_program {
        Some(p) => p.clone(),
        None => std::env::current_exe().context("cannot find this program's path")?,
    };
    let request = args.request(program);
    request.check()?;
    let for_farm = args.detach || args.controller_anywhere;
    if for_farm || (args.remd.is_some() && args.resume.is_none() && !args.in_process) {
        return in_farm(&args, &request);
    }
    // A new job's scene is compiled before anything else, so a bad scene starts nothing
    // (unless it was shipped before, unchanged: then it is not compiled at all).
    let new_scene = match &args.resume {
        None => Some(recall_or_compile(&args, &request)?),
        Some(_) => None,
    };
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()?;
    let outcome = runtime.block_on(async {
        let cluster = RemConnection::open(
            args.remd.as_deref(),
            args.secret_file.as_deref(),
            &request.worker_program,
        )
        .await?;
        let scene = match (new_scene, &args.resume) {
            (Some((recalled, compiled)), _) => {
                scene_input(&args, &request, &cluster, recalled, compiled)
                    .await
                    .map(JobScene::New)
            }
            (None, job) => Ok(JobScene::Resume {
                job: job.clone().unwrap_or_default(),
                scene: args.render.source().path().map(Path::to_path_buf),
            }),
        };
        let outcome = match scene {
            Ok(scene) => job::run(&cluster, &request, scene)
                .await
                .map_err(Into::into),
            Err(e) => Err(e),
        };
        cluster.close().await;
        outcome
    });
    let outcome = match outcome {
        Ok(outcome) => outcome,
        Err(e) => return interrupted_or(e),
    };
    let stats = &outcome.stats;
    if !args.render.quiet {
        eprint!("{}", stats.summary());
    }
    if let Some(path) = &args.render.stats_json {
        crate::film::write_atomically(path, &serde_json::to_vec_pretty(stats)?)?;
    }
    if !outcome.finished {
        eprintln!(
            "sunray: error: no worker is left; {} of {} lines are in the checkpoint; continue with `sunray submit --resume {}`",
            stats.lines.finished,
            stats.lines.total,
            outcome.job
        );
        return Ok(ExitCode::from(exit::NO_WORKERS_LEFT));
    }
    if !outcome.stored {
        eprintln!(
            "sunray: warning: {} is written, but the farm's checkpoint store refused the last save, so `sunray fetch {}` cannot give it; `sunray submit --resume {}` stores the rest",
            outcome.output.display(),
            outcome.job,
            outcome.job
        );
    }
    Ok(ExitCode::SUCCESS)
}

/// A job that Ctrl-C interrupted says so in one line (what its checkpoint kept, how to go on)
/// and exits 130; any other error is returned.
fn interrupted_or(e: anyhow::Error) -> anyhow::Result<ExitCode> {
    match e.downcast_ref::<JobError>() {
        Some(interrupted @ JobError::Interrupted { .. }) => {
            eprintln!("sunray: {interrupted}");
            Ok(ExitCode::from(exit::INTERRUPTED))
        }
        _ => Err(e),
    }
}

/// The new job's scene as remembered from an earlier submit of the same file (checked
/// against the farm later, in [`scene_input`]), else compiled now, its settings checked, so
/// that a bad scene or bad settings start nothing.
fn recall_or_compile(
    args: &SubmitArgs,
    request: &JobRequest,
) -> anyhow::Result<(Recalled, Option<JobInput>)> {
    let colours = args.render.colours.colors.as_deref();
    let recalled = Recalled::look_up(&args.render.source(), colours);
    if let Some(entry) = &recalled.entry {
        request.overrides.settings_for(&entry.summary)?;
        return Ok((recalled, None));
    }
    let compiled = compile(args, request, &recalled)?;
    Ok((recalled, Some(compiled)))
}

/// The scene compiled here, its warnings printed and its settings checked.
fn compile(
    args: &SubmitArgs,
    request: &JobRequest,
    recalled: &Recalled,
) -> anyhow::Result<JobInput> {
    let input = JobInput::compiled(args.render.compile_for_job()?, recalled.remember.clone());
    // Settings out of bounds are refused before a remd or a worker is started.
    request.overrides.settings_for(&input.summary)?;
    Ok(input)
}

/// The new job's input: compiled already, or remembered and every chunk of its model still
/// with the local remd (its warnings printed again), else compiled now.
async fn scene_input(
    args: &SubmitArgs,
    request: &JobRequest,
    cluster: &RemConnection,
    recalled: Recalled,
    compiled: Option<JobInput>,
) -> anyhow::Result<JobInput> {
    if let Some(input) = compiled {
        return Ok(input);
    }
    let source = args.render.source();
    match recalled.still_shipped(&cluster.client, &source).await {
        Some(input) => {
            for w in &input.warnings {
                eprintln!("{w}");
            }
            Ok(input)
        }
        None => tokio::task::block_in_place(|| compile(args, request, &recalled)),
    }
}

/// Hands the job to the farm; with `--detach` prints its id, else follows it to its end
/// and writes its image and statistics here.
fn in_farm(args: &SubmitArgs, request: &JobRequest) -> anyhow::Result<ExitCode> {
    let (recalled, compiled) = recall_or_compile(args, request)?;
    let flags = ControllerFlags {
        checkpoint_ms: args.checkpoint_ms.max(50),
        worker_timeout_ms: args.worker_timeout_ms,
        anywhere: args.controller_anywhere,
    };
    super::farm::runtime()?.block_on(async {
        let cluster = RemConnection::open(
            args.remd.as_deref(),
            args.secret_file.as_deref(),
            &request.worker_program,
        )
        .await?;
        let input = scene_input(args, request, &cluster, recalled, compiled).await?;
        let outcome = match farm::submit(&cluster, request, input, &flags).await {
            Ok(job) if args.detach => {
                println!("{}", job.job);
                Ok(ExitCode::SUCCESS)
            }
            Ok(job) => follow_here(args, request, &cluster, &job).await,
            Err(e) => Err(e.into()),
        };
        cluster.close().await;
        outcome
    })
}

/// Follows a job handed to the farm as the in-process controller shows it; Ctrl-C stops
/// following, not the job.
async fn follow_here(
    args: &SubmitArgs,
    request: &JobRequest,
    cluster: &RemConnection,
    submitted: &Submitted,
) -> anyhow::Result<ExitCode> {
    let job = &submitted.job;
    let quiet = args.render.quiet;
    if !quiet {
        eprintln!(
            "sunray: job {job} is in the farm; following it (Ctrl-C stops following, not the job)"
        );
    }
    let view = WatchView {
        bar: request.show_bar,
        events: args.events,
        controller_output: true,
        preview: args.preview.clone().map(|p| (p, request.preview_every)),
    };
    let end = tokio::select! {
        end = follow::watch(&cluster.client, &cluster.addr, job, view) => end?,
        _ = tokio::signal::ctrl_c() => {
            eprintln!(
                "sunray: stopped following job {job}; it goes on in the farm: `sunray watch {job}` follows it, `sunray fetch {job} -o FILE` writes its image, `sunray cancel {job}` stops it"
            );
            return Ok(ExitCode::from(exit::STOPPED_FOLLOWING));
        }
    };
    let Ended::Finished { summary } = &end else {
        return Ok(super::farm::report_end(job, &end, quiet));
    };
    let lost = |e: FarmError| match e {
        FarmError::Rem(e) => FarmError::from_rem(e, &cluster.addr, job),
        e => e,
    };
    // The image and the statistics at once: two reads, one wait.
    let stats = async {
        match &args.render.stats_json {
            Some(_) => follow::stats_json(&cluster.client, job).await,
            None => Ok(None),
        }
    };
    let (fetched, stats) = tokio::join!(
        follow::fetch(
            &cluster.client,
            job,
            &submitted.output,
            args.render.samples_map.as_deref()
        ),
        stats
    );
    fetched.map_err(lost)?;
    let written_s = JobClock::at(request.submitted_unix_ms).now();
    if let Some(path) = &args.render.stats_json {
        match stats.map_err(lost)? {
            Some(bytes) => {
                let bytes = follow::with_image_written(&bytes, written_s);
                crate::film::write_atomically(path, &bytes)?
            }
            None => eprintln!("sunray: warning: job {job} left no statistics for --stats-json"),
        }
    }
    if !quiet {
        eprint!("{summary}");
    }
    Ok(ExitCode::SUCCESS)
}

#[cfg(test)]
mod tests {
    use crate::cli::{Cli, Command};
    use crate::scene::load::SceneSource;
    use clap::Parser;

    fn submit(args: &[&str]) -> super::SubmitArgs {
        let argv = ["sunray", "submit"].iter().chain(args);
        match Cli::try_parse_from(argv).unwrap().command {
            Command::Submit(a) => *a,
            _ => unreachable!(),
        }
    }

    #[test]
    fn scene_is_optional_and_render_flags_are_shared() {
        let a = submit(&[]);
        assert_eq!(a.render.source(), SceneSource::Builtin);
        let a = submit(&[
            "--hosts",
            "3",
            "--strategy",
            "blocks",
            "--samples",
            "4",
            "--resolution",
            "64x32",
            "scene.yari",
        ]);
        assert_eq!(a.hosts, Some(3));
        assert_eq!(a.strategy, Some(crate::distrib::strategy::Strategy::Blocks));
        assert_eq!(a.render.samples, Some(4));
        assert_eq!(a.render.resolution, Some((64, 32)));
        assert_eq!(a.render.source(), SceneSource::File("scene.yari".into()));
        assert!(Cli::try_parse_from(["sunray", "submit", "--job", "a", "--resume", "b"]).is_err());
    }

    #[test]
    fn hosts_to_avoid_add_up_and_reach_the_request() {
        let a = submit(&["--avoid-host", "b,c", "--avoid-host", "d"]);
        assert_eq!(a.avoid_hosts, ["b", "c", "d"]);
        let req = a.request("sunray".into());
        assert_eq!(req.avoid_hosts, ["b", "c", "d"]);
        let live: Vec<rem::HostInfo> = ["a", "b", "e"]
            .map(|name| rem::HostInfo {
                name: name.into(),
                ..Default::default()
            })
            .to_vec();
        let names: Vec<String> = req.eligible(&live).into_iter().map(|h| h.name).collect();
        assert_eq!(names, ["a", "e"]);
        let mut many = req.clone();
        many.avoid_hosts = vec!["x".into(); rem::wire::MAX_AVOID_HOSTS + 1];
        assert!(many.check().is_err());
    }
}
