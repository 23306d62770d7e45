//! `sunray compile SCENE -o MODEL`: compile a scene (YARI, NFF or OFF) into a model file
//! that workers load without parsing (the thesis's `yc`).

use super::check::{display_name, summary};
use clap::Args;
use std::path::PathBuf;
use std::process::ExitCode;
use yari::colour::ColourTable;
use yari::load::{stream_path, LoadError};
use yari::modelfile::ModelEncoder;

/// The flags of `sunray compile`.
#[derive(Args, Debug)]
pub struct CompileArgs {
    /// The scene: .yari, .nff or .off (a .srw model is copied as it is).
    pub scene: PathBuf,
    /// Where to write the model file (conventionally `.srw`); written to a temporary name
    /// and renamed.
    #[arg(short = 'o', long = "output", value_name = "MODEL")]
    pub output: PathBuf,
    /// The colour-name table (`--colors`).
    #[command(flatten)]
    pub colours: super::colours::ColourArgs,
}

/// Compiles the scene and writes the model file; a scene with errors prints them and writes
/// nothing. The scene is read as a stream, each object encoded as soon as it is compiled.
pub fn run(args: CompileArgs) -> anyhow::Result<ExitCode> {
    let colours = ColourTable::for_run(args.colours.colors.as_deref())?;
    let mut encoder = ModelEncoder::new();
    let loaded = match stream_path(&args.scene, &colours, &mut |_, o| encoder.push(&o)) {
        Ok(l) => l,
        Err(e @ LoadError::Scene(_)) => {
            eprintln!("{e}");
            return Ok(ExitCode::FAILURE);
        }
        Err(e) => return Err(e.into()),
    };
    eprint!("{}", loaded.render_warnings());
    let cannot = |e| anyhow::anyhow!("cannot write {}: {e}", args.output.display());
    let bytes = encoder.finish(&loaded.world).map_err(cannot)?;
    yari::modelfile::save_bytes_atomic(&bytes, &args.output).map_err(cannot)?;
    let size = std::fs::metadata(&args.output)
        .map(|m| m.len())
        .unwrap_or(0);
    println!(
        "{} -> {} ({size} bytes)",
        summary(&display_name(&args.scene), &loaded.world),
        args.output.display()
    );
    Ok(ExitCode::SUCCESS)
}
