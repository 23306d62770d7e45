//! `sunray submit`: renders a scene on the SunRay III farm (thesis section 4.2.4). Compiles
//! the scene once, asks REM for N workers on the least-loaded hosts, runs the controller,
//! writes the image (byte-identical to `sunray render` of the same scene and options) and
//! prints the per-node table. With no remd configured it runs a private one and local
//! workers. See docs/sunray-iii.md.

use super::render::RenderArgs;
use crate::distrib::checkpoint::{self, Checkpointer};
use crate::distrib::cluster::Cluster;
use crate::distrib::controller::{self, ControllerConfig, Start, WorkerProc};
use crate::distrib::jobs;
use crate::distrib::messages::{self, proto, Body, Settings};
use crate::distrib::nodes::{self, JobStats};
use crate::distrib::scene_input::{self, SceneInput};
use crate::distrib::strategy::Strategy;
use anyhow::{bail, Context};
use clap::Args;
use std::io::IsTerminal;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

/// Exit code when no worker was left to finish the image (the checkpoint is kept).
pub const EXIT_NO_WORKERS: u8 = 3;

#[derive(Args, Debug, Clone)]
#[command(mut_arg("scene", |a| a
    .required(false)
    .default_value(scene_input::BUILTIN)
    .help("Scene: .yari, .nff, .off or a compiled model [default: the built-in example]")
    .hide_default_value(true)))]
pub struct SubmitArgs {
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
    /// A worker holding a line longer than this is silent [default: 10 s or 20 slowest lines].
    #[arg(long, hide = true)]
    pub worker_timeout_ms: Option<u64>,
    #[arg(long, hide = true, default_value_t = 2000)]
    pub checkpoint_ms: u64,
    #[arg(long, hide = true, default_value_t = 2000)]
    pub preview_ms: u64,
}

pub fn run(args: SubmitArgs) -> anyhow::Result<ExitCode> {
    if args.hosts == Some(0) {
        bail!("--hosts must be at least 1");
    }
    if let Some(job) = &args.job {
        check_job_id(job)?;
    }
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()?;
    runtime.block_on(submit(args))
}

fn check_job_id(job: &str) -> anyhow::Result<()> {
    if !rem::ids::is_valid_name(job) || job.len() > 100 || job == jobs::INDEX_KEY {
        bail!("bad job id {job:?}: use up to 100 of [A-Za-z0-9._-]");
    }
    Ok(())
}

/// Everything decided before the workers start.
struct Plan {
    job: String,
    input: SceneInput,
    settings: Settings,
    model: Vec<u8>,
    output: PathBuf,
    strategy: Strategy,
    hosts: u32,
    nice: bool,
    threads: Option<usize>,
    restored: Option<checkpoint::Restored>,
}

async fn submit(args: SubmitArgs) -> anyhow::Result<ExitCode> {
    let program = match &args.worker_program {
        Some(p) => p.clone(),
        None => std::env::current_exe().context("cannot find this program's path")?,
    };
    // A new job's scene is compiled before anything else, so a bad scene starts nothing.
    let fresh = match &args.resume {
        None => Some(scene_input::load(&args.render)?),
        Some(_) => None,
    };
    let cluster =
        Cluster::open(args.remd.as_deref(), args.secret_file.as_deref(), &program).await?;
    let result = run_job(&args, &cluster, fresh, &program).await;
    cluster.close().await;
    result
}

async fn run_job(
    args: &SubmitArgs,
    cluster: &Cluster,
    fresh: Option<SceneInput>,
    program: &std::path::Path,
) -> anyhow::Result<ExitCode> {
    let plan = match fresh {
        Some(input) => new_plan(args, input)?,
        None => resume_plan(args, cluster).await?,
    };
    let allow_same_host = cluster.is_embedded() || args.same_host;
    let live = cluster.live_hosts().await?;
    if !allow_same_host && plan.hosts as usize > live.len() {
        let names: Vec<&str> = live.iter().map(|h| h.name.as_str()).collect();
        bail!(
            "asked for {} hosts, but the cluster has {} live host(s): {}",
            plan.hosts,
            live.len(),
            names.join(", ")
        );
    }
    let scene_msg = messages::encode(Body::Scene(proto::Scene {
        model: plan.model.clone(),
        settings: Some(plan.settings.to_proto()),
        job: plan.job.clone(),
    }));
    let relay = cluster
        .client
        .attach(Some(&plan.job))
        .await
        .map_err(|e| cluster.rpc_error(e))?;
    let limit = relay.sender().max_message();
    if scene_msg.len() > limit {
        bail!(
            "the compiled model ({} bytes) is larger than REM's message limit ({limit} bytes); raise remd --max-message",
            scene_msg.len()
        );
    }

    let spec = proto::JobSpec {
        scene: plan.input.spec_path(),
        settings: Some(plan.settings.to_proto()),
        output: std::path::absolute(&plan.output)
            .unwrap_or_else(|_| plan.output.clone())
            .display()
            .to_string(),
        strategy: plan.strategy.name().to_string(),
        hosts: plan.hosts,
        nice: plan.nice,
        colours: args
            .render
            .colours
            .as_ref()
            .map(|c| c.display().to_string())
            .unwrap_or_default(),
        spd_corners: args.render.spd_corners,
        threads: plan.threads.unwrap_or(0) as u32,
    };
    let mut checkpointer = Checkpointer::new(
        &plan.job,
        spec,
        messages::fnv1a(&plan.model),
        plan.restored.as_ref(),
    );
    checkpointer
        .save(&cluster.client, "running")
        .await
        .context("writing the first checkpoint")?;
    let mut entry = proto::JobEntry {
        job: plan.job.clone(),
        scene: plan.input.display_name(),
        state: "running".into(),
        lines_done: checkpointer.lines_done(),
        height: plan.settings.render.height,
        hosts: plan.hosts,
        started_unix_ms: checkpoint::unix_ms(),
        output: plan.output.display().to_string(),
        ..Default::default()
    };
    index_update(cluster, &entry).await;

    let threads = plan.threads.or_else(|| {
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
        cluster
            .is_embedded()
            .then(|| (cores / plan.hosts as usize).max(1))
    });
    let mut worker_args = vec!["worker".to_string()];
    if let Some(t) = threads {
        worker_args.extend(["--threads".to_string(), t.to_string()]);
    }
    let rem_job = format!("{}.{}", plan.job, checkpoint::unix_ms() / 1000);
    // A resumed job whose lines are all in needs no worker.
    let all_in = plan
        .restored
        .as_ref()
        .is_some_and(|r| r.lines.len() as u32 >= plan.settings.render.height);
    let spawned = if all_in {
        rem::Job {
            id: rem_job,
            processes: Vec::new(),
        }
    } else {
        cluster
            .client
            .spawn(rem::SpawnRequest {
                program: program.display().to_string(),
                args: worker_args,
                env: std::env::vars()
                    .filter(|(k, _)| k.starts_with("SUNRAY_WORKER_"))
                    .collect(),
                nice: plan.nice.then_some(10),
                count: plan.hosts,
                allow_same_host,
                job: Some(rem_job),
                owner: Some(relay.id().clone()),
            })
            .await
            .map_err(|e| cluster.rpc_error(e))
            .context("starting the workers")?
    };
    let workers: Vec<WorkerProc> = spawned
        .processes
        .iter()
        .map(|p| WorkerProc {
            proc_id: p.proc_id.clone(),
            host: p.host.clone(),
            pid: p.pid,
            load_at_start: live
                .iter()
                .find(|h| h.name == p.host)
                .and_then(|h| h.load.as_ref())
                .map(|l| l.load_per_core),
        })
        .collect();
    let (sender, receiver) = relay.split();
    let show_bar = !args.render.quiet && std::io::stderr().is_terminal();
    let cfg = ControllerConfig {
        job: plan.job.clone(),
        strategy: plan.strategy,
        width: plan.settings.render.width,
        height: plan.settings.render.height,
        scene: scene_msg,
        worker_timeout: args.worker_timeout_ms.map(Duration::from_millis),
        checkpoint_every: Duration::from_millis(args.checkpoint_ms.max(50)),
        preview: args.preview.clone(),
        preview_every: Duration::from_millis(args.preview_ms.max(100)),
        show_bar,
        events: args.events,
        finish_grace: Duration::from_secs(3),
    };
    let handle = controller::spawn(Start {
        cfg,
        client: cluster.client.clone(),
        sender,
        receiver,
        workers,
        restored: plan.restored,
        checkpointer,
    });
    let result = handle.join().await?;

    entry.lines_done = result.lines.resumed + result.lines.rendered;
    entry.state = if result.finished {
        "finished"
    } else {
        "failed"
    }
    .into();
    index_update(cluster, &entry).await;
    if result.finished {
        result.film.write(&plan.output)?;
    }
    let mut totals = plan.input.stats(&plan.settings, &result.counters);
    totals.threads = result.nodes.iter().map(|n| n.threads as usize).sum();
    totals.time.render_s = result.elapsed_s;
    totals.time.cpu_s = result.nodes.iter().map(|n| n.cpu_s).sum();
    totals.set_counters(&result.counters);
    let busy: f64 = result
        .nodes
        .iter()
        .map(|n| n.render_s * f64::from(n.threads))
        .sum();
    let waited: f64 = result.nodes.iter().map(|n| n.wait_s).sum();
    let tail_waited: f64 = result.nodes.iter().map(|n| n.tail_wait_s).sum();
    let share = |s: f64| if busy > 0.0 { s / busy } else { 0.0 };
    let stats = JobStats {
        job: plan.job.clone(),
        strategy: Some(plan.strategy),
        hosts: plan.hosts,
        lines: result.lines,
        elapsed_s: result.elapsed_s,
        totals,
        controller: result.cost,
        wait_share: share(waited),
        tail_wait_share: share(tail_waited),
        nodes: result.nodes,
    };
    if !args.render.quiet {
        eprintln!(
            "SunRay III job {} ({} strategy, {} worker(s)): {:.2} s",
            stats.job, plan.strategy, plan.hosts, stats.elapsed_s
        );
        eprint!("{}", nodes::table(&stats.nodes));
        let l = &stats.lines;
        eprintln!(
            "lines: {} ({} from the checkpoint, {} rendered; {} given back, {} handed back unstarted, {} duplicated, {} dropped)",
            l.total, l.resumed, l.rendered, l.requeued, l.released, l.duplicated, l.dropped
        );
        let c = &stats.controller;
        eprintln!(
            "controller: {:.3} ms CPU and {:.1} messages per line; workers waited {:.2}% of their render time for work ({:.2}% at the tail for copies of stragglers)",
            c.cpu_ms_per_line,
            c.messages_per_line,
            stats.wait_share * 100.0,
            stats.tail_wait_share * 100.0
        );
    }
    if let Some(path) = &args.render.stats_json {
        crate::film::write_atomically(path, &serde_json::to_vec_pretty(&stats)?)?;
    }
    if !result.finished {
        eprintln!(
            "sunray: error: no worker is left; {} of {} lines are in the checkpoint; continue with `sunray submit --resume {}`",
            stats.lines.resumed + stats.lines.rendered,
            stats.lines.total,
            plan.job
        );
        return Ok(ExitCode::from(EXIT_NO_WORKERS));
    }
    Ok(ExitCode::SUCCESS)
}

fn new_plan(args: &SubmitArgs, input: SceneInput) -> anyhow::Result<Plan> {
    let settings = input.settings(&args.render);
    let output = args
        .render
        .output
        .clone()
        .unwrap_or_else(|| input.default_output());
    crate::film::Format::from_path(&output)?;
    let job = args.job.clone().unwrap_or_else(|| {
        format!(
            "sunray-{}-{}",
            checkpoint::unix_ms() / 1000,
            std::process::id()
        )
    });
    Ok(Plan {
        job,
        model: input.model_bytes()?,
        settings,
        output,
        strategy: args.strategy.unwrap_or(Strategy::Dynamic),
        hosts: args.hosts.unwrap_or(1),
        nice: args.nice,
        threads: args.render.threads.filter(|&t| t > 0),
        restored: None,
        input,
    })
}

async fn resume_plan(args: &SubmitArgs, cluster: &Cluster) -> anyhow::Result<Plan> {
    let job = args.resume.clone().unwrap_or_default();
    check_job_id(&job)?;
    let restored = checkpoint::load(&cluster.client, &job)
        .await?
        .with_context(|| format!("no checkpoint of job {job} on {}", cluster.addr))?;
    let spec = restored.header.spec.clone().unwrap_or_default();
    let given = scene_input::given_path(&args.render);
    let scene_path = given.or_else(|| (!spec.scene.is_empty()).then(|| PathBuf::from(&spec.scene)));
    let colours = (!spec.colours.is_empty()).then(|| PathBuf::from(&spec.colours));
    let input = scene_input::load_path(scene_path, colours.as_deref())?;
    let model = input.model_bytes()?;
    if messages::fnv1a(&model) != restored.header.model_hash {
        bail!("the scene has changed since job {job} was checkpointed; it cannot be resumed");
    }
    let settings = spec
        .settings
        .as_ref()
        .map(Settings::from_proto)
        .transpose()?
        .context("the checkpoint has no render settings")?;
    let output = args
        .render
        .output
        .clone()
        .unwrap_or_else(|| PathBuf::from(&spec.output));
    crate::film::Format::from_path(&output)?;
    Ok(Plan {
        job,
        input,
        settings,
        model,
        output,
        strategy: args
            .strategy
            .or_else(|| Strategy::from_name(&spec.strategy))
            .unwrap_or(Strategy::Dynamic),
        hosts: args.hosts.unwrap_or(spec.hosts.max(1)),
        nice: args.nice || spec.nice,
        threads: args
            .render
            .threads
            .or((spec.threads > 0).then_some(spec.threads as usize)),
        restored: Some(restored),
    })
}

async fn index_update(cluster: &Cluster, entry: &proto::JobEntry) {
    if let Err(e) = jobs::update(&cluster.client, entry.clone()).await {
        eprintln!("sunray: warning: job index: {e}");
    }
}

#[cfg(test)]
mod tests {
    use crate::cli::{Cli, Command};
    use clap::Parser;

    fn submit(args: &[&str]) -> super::SubmitArgs {
        let argv = ["sunray", "submit"].iter().chain(args);
        match Cli::try_parse_from(argv).unwrap().command {
            Command::Submit(a) => a,
            _ => unreachable!(),
        }
    }

    #[test]
    fn scene_is_optional_and_render_flags_are_shared() {
        let a = submit(&[]);
        assert!(crate::distrib::scene_input::given_path(&a.render).is_none());
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
        assert_eq!(
            crate::distrib::scene_input::given_path(&a.render),
            Some("scene.yari".into())
        );
        assert!(Cli::try_parse_from(["sunray", "submit", "--job", "a", "--resume", "b"]).is_err());
    }

    #[test]
    fn job_ids_are_checked() {
        assert!(super::check_job_id("render-7.b_c").is_ok());
        for bad in ["", "a/b", "a b", "sunray-jobs"] {
            assert!(super::check_job_id(bad).is_err(), "{bad:?}");
        }
    }
}
