//! The `sunray` subcommands. Each lives in its own module with its clap `Args` struct and a
//! `run` function returning the process exit code.

use clap::{Parser, Subcommand};
use std::process::ExitCode;

#[derive(Parser, Debug)]
#[command(name = "sunray", version, about = "SunRay: a Hall-model ray tracer and its SunRay III render farm")]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand, Debug)]
pub enum Command {
}

/// Runs one subcommand.
pub fn run(cli: Cli) -> anyhow::Result<ExitCode> {
    match cli.command {}
}
