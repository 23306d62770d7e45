//! `sunray render [SCENE]`: renders a scene (by default the built-in example) on this machine with all cores.

use crate::accel::{Accel, AccelKind, AccelOptions};
use crate::distrib::scene_input;
use crate::render::{render_image, Progress, RenderOptions};
use crate::scene::Scene;
use crate::stats::{process_cpu_seconds, RenderStats};
use clap::{Args, ValueEnum};
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum OnOff {
    On,
    Off,
}

#[derive(Args, Debug, Clone)]
pub struct RenderArgs {
    /// Scene: .yari, .nff, .off or a compiled model [default: the built-in example scene,
    /// also named `@example`]
    #[arg(default_value = scene_input::BUILTIN, hide_default_value = true)]
    pub scene: PathBuf,
    /// Output image (.png, .ppm or .pfm); default: the scene's name with .png, in the
    /// current directory.
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Samples per pixel (default: the scene's `samples`, else 1 = pixel centres).
    #[arg(long)]
    pub samples: Option<u32>,
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
    /// Override the resolution, WxH.
    #[arg(long, value_parser = parse_resolution)]
    pub resolution: Option<(u32, u32)>,
    /// SPD invariant mode: (W+1)x(H+1) eye rays through the pixel corners, one sample each,
    /// and --min-weight 0.
    #[arg(long)]
    pub spd_corners: bool,
    /// Write the statistics as JSON.
    #[arg(long)]
    pub stats_json: Option<PathBuf>,
    /// A colour-name file extending the built-in table (default: $YARI_COLORS).
    #[arg(long)]
    pub colours: Option<PathBuf>,
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
    if w == 0 || h == 0 || w > 65536 || h > 65536 {
        return Err(format!("resolution {s:?} out of range 1..65536"));
    }
    Ok((w, h))
}

/// Loads a scene file (.yari, .nff, .off or a compiled model) into a world, printing the
/// compiler's warnings.
pub fn load_world(path: &Path, colours: Option<&Path>) -> anyhow::Result<yari::model::World> {
    let table = yari::colour::ColourTable::for_run(colours)?;
    let loaded = yari::load::load_path(path, &table).map_err(|e| anyhow::anyhow!("{e}"))?;
    let warnings = loaded.render_warnings();
    if !warnings.is_empty() {
        eprintln!("{}", warnings.trim_end());
    }
    Ok(loaded.world)
}

impl RenderArgs {
    /// What the flags make of the scene's own settings. `sunray render` and `sunray submit`
    /// both use this, so a distributed render decides its pixels exactly as a local one.
    pub fn render_options(&self, scene: &Scene) -> RenderOptions {
        let mut opts = RenderOptions::for_scene(scene);
        if let Some((w, h)) = self.resolution {
            (opts.width, opts.height) = (w, h);
        }
        if let Some(s) = self.samples {
            opts.samples = s.max(1);
        }
        opts.trace.max_depth = self.depth;
        opts.trace.min_weight = self.min_weight;
        if self.spd_corners {
            opts = opts.spd_corners();
        }
        opts
    }

    /// The accelerator the flags ask for.
    pub fn accel_options(&self) -> AccelOptions {
        AccelOptions {
            kind: self.accel,
            max_per_voxel: self.max_per_voxel.max(1),
            max_depth: self.max_depth,
        }
    }
}

pub fn run(args: RenderArgs) -> anyhow::Result<ExitCode> {
    let path = scene_input::given_path(&args);
    let out = args.output.clone().unwrap_or_else(|| {
        let stem = match &path {
            Some(p) => p.file_stem().unwrap_or_else(|| "image".as_ref()),
            None => "example".as_ref(),
        };
        PathBuf::from(stem).with_extension("png")
    });
    crate::film::Format::from_path(&out)?;
    let t_load = Instant::now();
    let world = match &path {
        Some(p) => load_world(p, args.colours.as_deref())?,
        None => scene_input::builtin_world(args.colours.as_deref())?,
    };
    let load_s = t_load.elapsed().as_secs_f64();
    let cpu0 = process_cpu_seconds();

    let t_pre = Instant::now();
    let scene = Scene::new(world);
    for d in &scene.dropped {
        eprintln!(
            "sunray: warning: {}: object {} dropped: {}",
            args.scene.display(),
            d.object,
            d.reason
        );
    }
    let accel = Accel::build(&scene.prims, &args.accel_options());
    let preprocess_s = t_pre.elapsed().as_secs_f64();

    let opts = args.render_options(&scene);
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
    let (film, counters) = render_image(
        &scene,
        &accel,
        &opts,
        threads,
        args.mailbox == OnOff::On,
        progress,
    );
    let render_s = t_render.elapsed().as_secs_f64();
    let cpu_s = process_cpu_seconds() - cpu0;

    film.write(&out)?;

    let mut stats = RenderStats {
        scene: args.scene.display().to_string(),
        width: opts.width,
        height: opts.height,
        samples: opts.samples,
        accel: accel.kind.name().to_string(),
        mailbox: args.mailbox == OnOff::On && accel.kind == AccelKind::Octree,
        objects: scene.world.objects.len(),
        primitives: scene.prims.len(),
        unbounded: accel.unbounded_count(),
        accel_nodes: accel.node_count(),
        threads,
        ..Default::default()
    };
    stats.time.load_s = load_s;
    stats.time.preprocess_s = preprocess_s;
    stats.time.render_s = render_s;
    stats.time.cpu_s = cpu_s;
    stats.set_counters(&counters);
    if !args.quiet {
        eprint!("{}", stats.table());
    }
    if let Some(path) = &args.stats_json {
        let json = serde_json::to_vec_pretty(&stats)?;
        crate::film::write_atomically(path, &json)?;
    }
    Ok(ExitCode::SUCCESS)
}
