//! The `sunray` subcommands. Each lives in its own module with its clap `Args` struct and a
//! `run` function returning the process exit code; they only turn flags into the library's
//! types (`render::Overrides`, `distrib::job::JobRequest`, ...) and print what comes back.
//! [`colours`] is the colour-name flag they share, [`values`] spells the library's choices
//! for clap, [`exit`] names the exit codes.

pub mod bench;
pub mod check;
pub mod check_board;
pub mod colours;
pub mod compile;
pub mod convert;
pub mod exit;
pub mod farm;
pub mod jobs;
pub mod prepare_scene;
pub mod render;
pub mod spd;
pub mod submit;
pub mod values;
pub mod worker;

use clap::{Parser, Subcommand};
use std::process::ExitCode;

/// What `sunray --version` prints: the package's version and the pixels it renders
/// ([`crate::render::image_version`]).
pub static VERSION: std::sync::LazyLock<String> = std::sync::LazyLock::new(|| {
    let image = crate::render::image_version::IMAGE_VERSION;
    format!("{}, image version {image}", env!("CARGO_PKG_VERSION"))
});

#[derive(Parser, Debug)]
#[command(
    name = "sunray",
    version = VERSION.as_str(),
    about = "SunRay: a Hall-model ray tracer and its SunRay III render farm"
)]
/// The `sunray` command line: one subcommand.
pub struct Cli {
    /// The subcommand to run.
    #[command(subcommand)]
    pub command: Command,
}

/// The subcommands, each with its module's flags.
#[derive(Subcommand, Debug)]
pub enum Command {
    /// Parse and compile a scene; print a summary and any warnings, or the errors.
    Check(check::CheckArgs),
    /// Compile a scene into a model file that workers load without parsing (`yc`).
    Compile(compile::CompileArgs),
    /// Convert an NFF or OFF scene to YARI (the thesis's nff2gfx / off2gfx).
    Convert(convert::ConvertArgs),
    /// Generate one of Haines's Standard Procedural Databases (tetra, mount, balls, gears,
    /// rings, tree, teapot, lattice, shells, jacks, sombrero).
    Spd(spd::SpdArgs),
    /// Generate a checkerboard of polygons (the thesis's `check`).
    CheckBoard(check_board::CheckBoardArgs),
    /// Render a scene on this machine with all cores.
    Render(render::RenderArgs),
    /// Benchmarks: the thesis's Tables 4.1 and 4.2 with our numbers, throughput, build time.
    Bench(bench::BenchArgs),
    /// Render a scene on the SunRay III farm: workers on the least-loaded hosts through REM.
    Submit(Box<submit::SubmitArgs>),
    /// The SunRay III worker process (started by REM for `submit`, not by hand).
    #[command(hide = true)]
    Worker(worker::WorkerArgs),
    /// Builds and keeps a host's prepared scene (started by a worker, not by hand).
    #[command(hide = true)]
    PrepareScene(prepare_scene::PrepareSceneArgs),
    /// List SunRay III jobs and their state.
    Jobs(jobs::JobsArgs),
    /// Follow a job from any host until it ends (exit 0 finished, 3 failed, 4 cancelled).
    Watch(farm::WatchArgs),
    /// Write a finished job's image (.png, .ppm, .pfm or .exr).
    Fetch(farm::FetchArgs),
    /// Cancel a job: its controller and workers end, and it is not started again.
    Cancel(farm::CancelArgs),
    /// A farm job's controller (started by REM for `submit --detach`, not by hand).
    #[command(hide = true)]
    Controller(farm::ControllerArgs),
}

/// Runs one subcommand.
pub fn run(cli: Cli) -> anyhow::Result<ExitCode> {
    match cli.command {
        Command::Check(args) => check::run(args),
        Command::Compile(args) => compile::run(args),
        Command::Convert(args) => convert::run(args),
        Command::Spd(args) => spd::run(args),
        Command::CheckBoard(args) => check_board::run(args),
        Command::Render(args) => render::run(args),
        Command::Bench(args) => bench::run(args),
        Command::Submit(args) => submit::run(*args),
        Command::Worker(args) => worker::run(args),
        Command::PrepareScene(args) => prepare_scene::run(args),
        Command::Jobs(args) => jobs::run(args),
        Command::Watch(args) => farm::watch(args),
        Command::Fetch(args) => farm::fetch(args),
        Command::Cancel(args) => farm::cancel(args),
        Command::Controller(args) => farm::controller(args),
    }
}

/// What `sunray` prints for an error: its message and its causes', joined by ": ", leaving
/// out a cause whose message is already in the line (several errors put their cause in their
/// own message and also report it as their source; printed as a plain chain, a bad scene's
/// diagnostics came out three times).
pub fn error_line(e: &anyhow::Error) -> String {
    let mut line = String::new();
    for cause in e.chain() {
        let text = cause.to_string();
        if line.contains(text.trim()) {
            continue;
        }
        if !line.is_empty() {
            line.push_str(": ");
        }
        line.push_str(&text);
    }
    line
}

/// The line `sunray` prints to stderr for an error: `sunray: error: ` and [`error_line`], or
/// only `sunray: ` where the line carries a scene's own `file:line:col: error:` diagnostic
/// (which says "error" itself).
pub fn error_report(e: &anyhow::Error) -> String {
    let line = error_line(e);
    if line.contains(": error: ") {
        format!("sunray: {line}")
    } else {
        format!("sunray: error: {line}")
    }
}

#[cfg(test)]
mod tests {
    use super::{error_line, error_report};
    use crate::scene::load::SceneLoadError;
    use yari::load::LoadError;

    #[test]
    fn the_version_names_the_pixels_this_build_renders() {
        let v = crate::render::image_version::IMAGE_VERSION;
        assert!(super::VERSION.ends_with(&format!(", image version {v}")));
    }

    #[test]
    fn a_cause_already_in_the_message_is_printed_once() {
        let io = std::io::Error::new(std::io::ErrorKind::NotFound, "no such file");
        let e = anyhow::Error::from(SceneLoadError::Scene(LoadError::Io {
            path: "a.yari".into(),
            source: io,
        }));
        assert_eq!(e.chain().count(), 3);
        assert_eq!(error_line(&e), "cannot read a.yari: no such file");
        let e = anyhow::Error::new(std::io::Error::other("disk full")).context("writing out.png");
        assert_eq!(error_line(&e), "writing out.png: disk full");
        assert_eq!(
            error_report(&e),
            "sunray: error: writing out.png: disk full"
        );
    }

    #[test]
    fn a_scene_diagnostic_says_error_once() {
        let e = anyhow::anyhow!("bad.yari:3:36: error: expected the radius, found `x`");
        assert_eq!(
            error_report(&e),
            "sunray: bad.yari:3:36: error: expected the radius, found `x`"
        );
    }
}
