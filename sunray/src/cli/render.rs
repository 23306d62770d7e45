//! `sunray render [SCENE]`: renders a scene (by default the built-in example) on this machine with all cores.

use super::colours::ColourArgs;
use crate::accel::{Accel, AccelKind, AccelOptions};
use crate::render::{adaptive, render_image_summarized, Overrides, Progress};
use crate::sampler::Sampler;
use crate::scene::load::{self, CompiledScene, LoadedScene, SceneSource};
use crate::stats::process_cpu_seconds;
use clap::{Args, ValueEnum};
use std::io::IsTerminal;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

/// A switch on the command line.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum OnOff {
    /// Switched on.
    On,
    /// Switched off.
    Off,
}

/// The flags of `sunray render`, shared by `sunray submit`.
#[derive(Args, Debug, Clone)]
pub struct RenderArgs {
    /// Scene: .yari, .nff, .off or a compiled model [default: the built-in example scene,
    /// also named `@example`]
    #[arg(default_value = load::BUILTIN, hide_default_value = true)]
    pub scene: PathBuf,
    /// Output image (.png, .ppm, .pfm or .exr); default: the scene's name with .png, in the
    /// current directory.
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Samples per pixel (default: the scene's `samples`, else 1 = pixel centres).
    #[arg(long, conflicts_with = "target_error")]
    pub samples: Option<u32>,
    /// Render each pixel until the estimated standard error of its mean is at most E, in
    /// linear radiance (1 = white), from an Owen-scrambled Sobol sequence of its own, instead
    /// of a fixed number of samples.
    #[arg(long, value_name = "E", conflicts_with = "spd_corners")]
    pub target_error: Option<f64>,
    /// What a fixed number of samples per pixel draws from: stratified jitter (the default;
    /// every earlier image) or an Owen-scrambled Sobol sequence. With --target-error pixels
    /// always draw from Sobol sequences.
    #[arg(
        long,
        value_enum,
        default_value = "stratified",
        conflicts_with = "target_error"
    )]
    pub sampler: Sampler,
    /// With --target-error: the first samples every pixel takes (the fewest), 2 or more; a
    /// pixel with an open pixel within 2 of it (its first samples' error above E) goes on,
    /// to at least 4 times as many [default: 0.08/E rounded up to a power of two, at least
    /// 4, at most --max-samples].
    #[arg(long, requires = "target_error")]
    pub min_samples: Option<u32>,
    /// With --target-error: the most samples a pixel takes (at most 65536) [default: 1024].
    #[arg(long, requires = "target_error")]
    pub max_samples: Option<u32>,
    /// With --target-error (`sunray render`): write a heat map of the samples each pixel
    /// took (black the fewest, white the most, log scale) to this image file.
    #[arg(long, requires = "target_error", value_name = "FILE")]
    pub samples_map: Option<PathBuf>,
    /// The accelerator.
    #[arg(long, value_enum, default_value = "auto")]
    pub accel: AccelKind,
    /// The octree's intersection buffer.
    #[arg(long, value_enum, default_value = "on")]
    pub mailbox: OnOff,
    /// Octree: subdivide voxels holding more than this many primitives.
    #[arg(long, default_value_t = 10)]
    pub max_per_voxel: usize,
    /// Octree: maximum subdivision depth.
    #[arg(long, default_value_t = 8)]
    pub max_depth: u32,
    /// Maximum depth of the ray tree (eye ray = 1).
    #[arg(long, default_value_t = 5)]
    pub depth: u32,
    /// Rays whose weight falls to this or below are not spawned.
    #[arg(long, default_value_t = 0.001)]
    pub min_weight: f64,
    /// Override the resolution, WxH (each side 1 to 16384, at most 2^27 pixels).
    #[arg(long, value_parser = parse_resolution)]
    pub resolution: Option<(u32, u32)>,
    /// SPD invariant mode: (W+1)x(H+1) eye rays through the pixel corners, one sample each,
    /// and --min-weight 0.
    #[arg(long)]
    pub spd_corners: bool,
    /// Write the statistics as JSON.
    #[arg(long)]
    pub stats_json: Option<PathBuf>,
    /// The colour-name table (`--colors`).
    #[command(flatten)]
    pub colours: ColourArgs,
    /// Do not print the statistics table.
    #[arg(long, short)]
    pub quiet: bool,
}

fn parse_resolution(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or("expected WxH, e.g. 512x512")?;
    let w: u32 = w
        .trim()
        .parse()
        .map_err(|_| format!("bad width in {s:?}"))?;
    let h: u32 = h
        .trim()
        .parse()
        .map_err(|_| format!("bad height in {s:?}"))?;
    // The bounds are the render settings' (render::settings::MAX_SIDE), checked with the
    // scene's own resolution.
    Ok((w, h))
}

impl RenderArgs {
    /// The scene the SCENE argument names.
    pub fn source(&self) -> SceneSource {
        SceneSource::from_arg(&self.scene)
    }

    /// What the flags ask for on top of the scene's own settings.
    pub fn overrides(&self) -> Overrides {
        Overrides {
            resolution: self.resolution,
            samples: self.samples,
            depth: self.depth,
            min_weight: self.min_weight,
            spd_corners: self.spd_corners,
            accel: AccelOptions {
                kind: self.accel,
                max_per_voxel: self.max_per_voxel,
                max_depth: self.max_depth,
            },
            mailbox: self.mailbox == OnOff::On,
            adaptive: self
                .target_error
                .map(|e| adaptive::Adaptive::new(e, self.min_samples, self.max_samples)),
            sampler: self.sampler,
        }
    }

    /// Loads the scene, printing its warnings.
    pub fn load(&self) -> anyhow::Result<LoadedScene> {
        let loaded = load::load(&self.source(), self.colours.colors.as_deref())?;
        print_warnings(&loaded.warnings);
        Ok(loaded)
    }

    /// Compiles the scene for a job that ships it to workers, printing its warnings.
    pub fn compile_for_job(&self) -> anyhow::Result<CompiledScene> {
        let colours = self.colours.colors.as_deref();
        let compiled = load::compile_for_job(&self.source(), colours)?;
        print_warnings(&compiled.warnings);
        Ok(compiled)
    }
}

fn print_warnings(warnings: &[String]) {
    for w in warnings {
        eprintln!("{w}");
    }
}

/// Renders the scene on this machine and writes the image (and statistics).
pub fn run(args: RenderArgs) -> anyhow::Result<ExitCode> {
    let source = args.source();
    let out = args
        .output
        .clone()
        .unwrap_or_else(|| source.default_output());
    crate::film::Format::from_path(&out)?;
    let loaded = args.load()?;
    let mut scene = loaded.scene;
    let cpu0 = process_cpu_seconds();

    let t_accel = Instant::now();
    let settings = args.overrides().settings(&scene)?;
    let accel = Accel::build(&mut scene.prims, &settings.accel);
    let preprocess_s = loaded.prepare_s + t_accel.elapsed().as_secs_f64();

    let threads = args
        .threads
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()))
        .max(1);
    let progress = if std::io::stderr().is_terminal() && !args.quiet {
        Progress::Bar
    } else {
        Progress::Hidden
    };

    let t_render = Instant::now();
    let (film, counters, summaries) = render_image_summarized(
        &scene,
        &accel,
        &settings.render,
        threads,
        settings.mailbox,
        progress,
    );
    let render_s = t_render.elapsed().as_secs_f64();
    let cpu_s = process_cpu_seconds() - cpu0;

    film.write(&out)?;
    let r = &settings.render;
    let error = r
        .adaptive
        .map(|a| (adaptive::error_stats(&summaries, &a), a));
    if let (Some(path), Some((_, a))) = (&args.samples_map, &error) {
        adaptive::samples_map(&summaries, a, r.width, r.height).write(path)?;
    }

    let mut stats = settings.stats_header(&source.display_name(), &scene);
    stats.accel_nodes = accel.node_count();
    stats.threads = threads;
    stats.time.load_s = loaded.load_s;
    stats.time.preprocess_s = preprocess_s;
    stats.time.render_s = render_s;
    stats.time.cpu_s = cpu_s;
    stats.set_counters(&counters);
    stats.error = error.map(|(e, _)| e);
    if !args.quiet {
        eprint!("{}", stats.table());
    }
    if let Some(path) = &args.stats_json {
        let json = serde_json::to_vec_pretty(&stats)?;
        crate::film::write_atomically(path, &json)?;
    }
    Ok(ExitCode::SUCCESS)
}
