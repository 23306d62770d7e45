//! `sunray bench table41|table42|throughput|build`: the thesis's tables with our numbers;
//! `sunray bench accuracy|precision|features`: error against time, f32 against f64, and what a
//! scene pays for (docs/accuracy.md); `sunray bench scenes`: accuracy's scenes as YARI files;
//! `sunray bench limit`: eye + shadow rays without shading, beside Embree's single-ray kernels
//! (bench/limit/run.sh).

use crate::accel::AccelKind;
use clap::{Args, ValueEnum};
use std::process::ExitCode;

/// Which benchmark `sunray bench` runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Which {
    /// Table 4.1: exhaustive vs octree on tetra of sizes 2, 3, 4, 6.
    Table41,
    /// Table 4.2: the octree's mailbox on and off on tetra, mount, balls.
    Table42,
    /// Rays per second, one thread and all threads, BVH and octree.
    Throughput,
    /// Accelerator build time for a 1,000,000-triangle scene; reading its BVH back from a
    /// host cache; keeping and mapping its prepared scene.
    Build,
    /// Error against time of antialiasing, penumbra, gloss and depth of field at 1, 2, 4, ...
    /// samples per pixel; writes --out-dir/accuracy.png (log-log plot).
    Accuracy,
    /// The accuracy scenes (edges, penumbra, gloss, depth of field) as YARI at
    /// --accuracy-resolution, written to --out-dir/NAME.yari: to render by hand.
    Scenes,
    /// Time to reach RMSE 0.01, 0.005 and 0.002 with stratified, Sobol and adaptive
    /// sampling (and POV-Ray's +A where `povray` runs), and the RMSE of each at equal time;
    /// writes --out-dir/to_error.md and a plot per scene, --out-dir/to_error-SCENE.png.
    ToError,
    /// The hot path in f32 and f64: speed, and error on hard cases.
    Precision,
    /// Unused feature paths switched on vs off; `--accel auto` against the fastest.
    Features,
    /// Peak memory of `sunray render` (2 threads) on tetra of --tetra-size, in bytes per
    /// triangle; with --against OLD, that build too, alternately; with --smooth, also on
    /// tetra's triangles with vertex normals (this program only).
    Memory,
    /// A farm three users share: each job's wait, run time and slots over time and each
    /// user's slot-seconds against the fair share, from --input (the timeline that
    /// `deploy/bench/run.sh shares` records); writes --out-dir/shares.md and shares.png.
    Shares,
    /// SunRay's eye + shadow rays without shading on --scene (one eye ray per pixel, one
    /// shadow ray per light the hit faces), one thread, best of --repeat; prints one JSON
    /// line. bench/limit/run.sh sets it beside Embree 3's single-ray kernels.
    Limit,
}

/// The flags of `sunray bench`.
#[derive(Args, Debug, Clone)]
pub struct BenchArgs {
    // No doc comment: clap would print it above the possible values.
    pub(crate) which: Which,
    /// Image size (square).
    #[arg(long, default_value_t = 512)]
    pub resolution: u32,
    /// Tetra sizes for table41.
    #[arg(long, value_delimiter = ',', default_value = "2,3,4,6")]
    pub sizes: Vec<u32>,
    /// Threads for the all-thread throughput (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Triangles for `build`.
    #[arg(long, default_value_t = 1_000_000)]
    pub triangles: usize,
    /// accuracy, to-error, scenes: image size (square).
    #[arg(long, default_value_t = 128, value_parser = clap::value_parser!(u32).range(1..))]
    pub accuracy_resolution: u32,
    /// accuracy: the largest sample count measured (1, 2, 4, ... up to this).
    #[arg(long, default_value_t = 256)]
    pub max_samples: u32,
    /// accuracy: samples per pixel of the converged reference.
    #[arg(long, default_value_t = 16384)]
    pub reference_samples: u32,
    /// memory: the tetra size (4^size triangles; 10 is 1,048,576).
    #[arg(long, default_value_t = 10)]
    pub tetra_size: u32,
    /// memory: other `sunray` programs to measure alternately with this one.
    #[arg(long)]
    pub against: Vec<std::path::PathBuf>,
    /// memory: rounds (each program's lowest peak is shown).
    #[arg(long, default_value_t = 3)]
    pub rounds: usize,
    /// memory: also measure tetra's triangles as smooth triangles (vertex normals).
    #[arg(long)]
    pub smooth: bool,
    /// accuracy, to-error, scenes: where to write their files.
    #[arg(long, default_value = "bench/results")]
    pub out_dir: std::path::PathBuf,
    /// limit: the scene (YARI, NFF, ...).
    #[arg(long)]
    pub scene: Option<std::path::PathBuf>,
    /// limit: runs (the best time of each part is kept).
    #[arg(long, default_value_t = 5)]
    pub repeat: usize,
    /// shares: the timeline to read [default: deploy/bench/results/shares.json].
    #[arg(long)]
    pub input: Option<std::path::PathBuf>,
}

/// Runs the chosen benchmark and prints its table (or writes its files).
pub fn run(args: BenchArgs) -> anyhow::Result<ExitCode> {
    let threads = args
        .threads
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()))
        .max(1);
    let text = match args.which {
        Which::Table41 => crate::bench::table41(&args.sizes, args.resolution)?,
        Which::Table42 => crate::bench::table42(args.resolution)?,
        Which::Throughput => crate::bench::throughput(args.resolution, threads)?,
        Which::Build => build(args.triangles)?,
        Which::Accuracy => {
            std::fs::create_dir_all(&args.out_dir)?;
            let plot = args.out_dir.join("accuracy.png");
            let (_rows, text) = crate::bench::accuracy::run(
                args.accuracy_resolution,
                args.max_samples,
                args.reference_samples,
                threads,
                Some(&plot),
            )?;
            crate::cli::convert::write_output(Some(&args.out_dir.join("accuracy.md")), &text)?;
            format!("{text}\nplot: {}\n", plot.display())
        }
        Which::Scenes => {
            std::fs::create_dir_all(&args.out_dir)?;
            let mut written = String::new();
            for (file, source) in crate::bench::accuracy::scene_files(args.accuracy_resolution) {
                let path = args.out_dir.join(file);
                crate::cli::convert::write_output(Some(&path), &source)?;
                written += &format!("{}\n", path.display());
            }
            written
        }
        Which::ToError => {
            std::fs::create_dir_all(&args.out_dir)?;
            let text = crate::bench::to_error::run(
                args.accuracy_resolution,
                args.max_samples,
                args.reference_samples,
                &[0.16, 0.08, 0.04, 0.02, 0.01, 0.005, 0.0025, 0.00125],
                threads,
                Some(&args.out_dir),
            )?;
            crate::cli::convert::write_output(Some(&args.out_dir.join("to_error.md")), &text)?;
            text
        }
        Which::Shares => {
            let input = args
                .input
                .clone()
                .unwrap_or_else(|| "deploy/bench/results/shares.json".into());
            crate::bench::shares::run(&input, &args.out_dir)?
        }
        Which::Limit => limit(&args)?,
        Which::Precision => crate::bench::precision::run(),
        Which::Features => crate::bench::features::run(args.resolution)?,
        Which::Memory => {
            use crate::bench::memory;
            let me = std::env::current_exe()?;
            let dir = tempfile::tempdir()?;
            let scenes = memory::write_tetra(&me, dir.path(), args.tetra_size)?;
            let mut programs = vec![me.clone()];
            programs.extend(args.against.iter().cloned());
            let mut peaks = memory::measure(&programs, &scenes, args.rounds, dir.path())?;
            let ply = memory::write_ply(&me, dir.path(), args.tetra_size)?;
            peaks.extend(memory::measure(
                std::slice::from_ref(&me),
                &[ply],
                args.rounds,
                dir.path(),
            )?);
            if args.smooth {
                let twin = memory::write_smooth_twin(&me, &scenes[1])?;
                peaks.extend(memory::measure(&[me], &[twin], args.rounds, dir.path())?);
            }
            memory::table(&peaks, 4u64.saturating_pow(args.tetra_size))
        }
    };
    print!("{text}");
    Ok(ExitCode::SUCCESS)
}

/// `sunray bench build`: the accelerators' build times for `triangles` triangles, a host
/// cache's BVH read back, a prepared scene kept and mapped, and the peak memory.
fn build(triangles: usize) -> anyhow::Result<String> {
    let mut s = String::new();
    for kind in [AccelKind::Bvh, AccelKind::Octree] {
        let (n, secs) = crate::bench::build_big(triangles, kind);
        s += &format!(
            "{:>8}: {n} triangles, scene + accelerator built in {secs:.3} s\n",
            kind.name()
        );
    }
    let (built, read, bytes) = crate::bench::bvh_cache_big(triangles)?;
    s += &format!(
        "     bvh: built and kept in a host cache in {built:.3} s ({:.1} MB); \
         read back and checked in {read:.3} s ({:.1}x faster)\n",
        bytes as f64 / 1e6,
        built / read.max(1e-9)
    );
    let (kept, decoded, mapped) = crate::bench::prepared_big(triangles)
        .map_err(|e| anyhow::anyhow!("prepared scene: {e}"))?;
    s += &format!(
        "prepared scene: kept by a first worker in {kept:.3} s; a later worker's scene \
         ready: decoded + cached BVH read {decoded:.3} s, mapped {mapped:.4} s ({:.0}x faster)\n",
        decoded / mapped.max(1e-9)
    );
    s += &format!("peak resident memory: {:.0} MiB\n", peak_rss_mib());
    Ok(s)
}

/// Peak resident set size of this process (getrusage's ru_maxrss, KiB on Linux).
fn peak_rss_mib() -> f64 {
    // SAFETY: getrusage fills the zeroed struct; RUSAGE_SELF is always valid.
    let mut u: libc::rusage = unsafe { std::mem::zeroed() };
    if unsafe { libc::getrusage(libc::RUSAGE_SELF, &mut u) } != 0 {
        return 0.0;
    }
    u.ru_maxrss as f64 / 1024.0
}

/// `sunray bench limit`: SunRay's eye + shadow rays on --scene, as one JSON line.
fn limit(args: &BenchArgs) -> anyhow::Result<String> {
    let Some(path) = &args.scene else {
        anyhow::bail!("`sunray bench limit` needs --scene FILE");
    };
    let source = crate::scene::load::SceneSource::from_arg(path);
    let loaded = crate::scene::load::load(&source, None)?;
    let run = crate::bench::limit::run(
        &loaded.scene,
        &crate::accel::AccelOptions::default(),
        args.resolution,
        args.resolution,
        args.repeat,
    );
    Ok(format!("{}\n", serde_json::to_string(&run)?))
}
