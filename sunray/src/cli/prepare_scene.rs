//! `sunray prepare-scene`: the keeper a worker starts to build and keep its host's prepared
//! scene (see [`crate::prepared::keeper`]). Not for typing: it reads the model on its
//! standard input and says on its standard output whether it kept it.

use crate::accel::{AccelKind, AccelOptions};
use crate::prepared::keeper;
use clap::Args;
use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

/// The flags of `sunray prepare-scene`.
#[derive(Args, Debug, Clone)]
pub struct PrepareSceneArgs {
    /// The prepared scene file to write.
    #[arg(long)]
    pub out: PathBuf,
    /// The model's FNV-1a 64 hash, in hex.
    #[arg(long)]
    pub model_hash: String,
    /// The accelerator asked for: `auto` or `bvh`.
    #[arg(long, default_value = "auto")]
    pub accel: String,
}

/// Keeps the model read from standard input as a prepared scene; fails when it could not.
pub fn run(args: PrepareSceneArgs) -> anyhow::Result<ExitCode> {
    keeper::bound_time();
    let hash = u64::from_str_radix(&args.model_hash, 16)?;
    let kind = match args.accel.as_str() {
        "bvh" => AccelKind::Bvh,
        _ => AccelKind::Auto,
    };
    let opts = AccelOptions {
        kind,
        ..AccelOptions::default()
    };
    let dir = std::env::var_os(rem::wire::env::CACHE_DIR).map(PathBuf::from);
    let cached = keeper::keep_model(
        &mut std::io::stdin().lock(),
        &args.out,
        hash,
        &opts,
        dir.as_deref(),
    )?;
    let said = if cached {
        keeper::KEPT_CACHED
    } else {
        keeper::KEPT_BUILT
    };
    // The worker may be gone (ended with its job): nobody to tell, and nothing lost.
    let _ = writeln!(std::io::stdout(), "{said}");
    Ok(ExitCode::SUCCESS)
}
