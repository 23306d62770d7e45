//! `sunray check-board`: the thesis's `check` tool, a checkerboard of square polygons in two
//! colours, any size and orientation (see [`yari::spd::checkerboard`]).
//!
//! ```text
//! sunray check-board --squares 8 --square-size 0.5 --colors 1,1,1 0.8,0.1,0.1 \
//!     --center 0,0,-0.5 --rotate 0,0,45 -o board.yari
//! ```

use super::convert::{output_format, render_scene, write_bytes, OutputFormat};
use anyhow::{bail, Context};
use clap::Args;
use std::path::PathBuf;
use std::process::ExitCode;
use yari::colour::ColourTable;
use yari::spd::{checkerboard, CheckerboardOptions};

/// Generate a checkerboard of polygons (the thesis's `check`).
#[derive(Args, Debug)]
pub struct CheckBoardArgs {
    /// Squares along x and y: `N` for a square board or `NX,NY`.
    #[arg(long, default_value = "8")]
    pub squares: String,
    /// Side length of one square.
    #[arg(long, default_value_t = 1.0)]
    pub square_size: f64,
    /// The two colours, each `r,g,b` (0-1) or a colour name (built in or from $YARI_COLORS):
    /// the corner square's first.
    #[arg(long, num_args = 2, value_names = ["FIRST", "SECOND"], default_values = ["1,1,1", "0,0,0"])]
    pub colors: Vec<String>,
    /// Where the board's centre goes, `x,y,z`.
    #[arg(long, default_value = "0,0,0", allow_hyphen_values = true)]
    pub center: String,
    /// Rotation in degrees about x, then y, then z, `x,y,z` (the board starts in the x-y plane).
    #[arg(long, default_value = "0,0,0", allow_hyphen_values = true)]
    pub rotate: String,
    /// Only the board: no camera, light or background.
    #[arg(long)]
    pub no_view: bool,
    /// Where to write (`.nff` for NFF, else YARI; default: YARI on stdout).
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Force the output format regardless of the extension.
    #[arg(long, value_enum)]
    pub(crate) format: Option<OutputFormat>,
}

/// Writes the checkerboard scene to the output (or stdout).
pub fn run(args: CheckBoardArgs) -> anyhow::Result<ExitCode> {
    let squares = match numbers(&args.squares, "--squares")?.as_slice() {
        [n] => [count(*n)?, count(*n)?],
        [x, y] => [count(*x)?, count(*y)?],
        _ => bail!("--squares takes N or NX,NY"),
    };
    let colors = [colour(&args.colors[0])?, colour(&args.colors[1])?];
    let options = CheckerboardOptions {
        squares,
        square_size: args.square_size,
        colors,
        center: triple(&args.center, "--center")?,
        rotate: triple(&args.rotate, "--rotate")?,
        view: !args.no_view,
    };
    let scene = checkerboard(&options)?;
    let format = output_format(args.format, args.output.as_deref());
    write_bytes(args.output.as_deref(), &render_scene(&scene, format)?)?;
    Ok(ExitCode::SUCCESS)
}

fn numbers(text: &str, what: &str) -> anyhow::Result<Vec<f64>> {
    text.split(|c: char| c == ',' || c.is_ascii_whitespace())
        .filter(|s| !s.is_empty())
        .map(|s| {
            s.parse::<f64>()
                .with_context(|| format!("{what}: `{s}` is not a number"))
        })
        .collect()
}

fn triple(text: &str, what: &str) -> anyhow::Result<[f64; 3]> {
    match numbers(text, what)?.as_slice() {
        [x, y, z] => Ok([*x, *y, *z]),
        _ => bail!("{what} takes three numbers `x,y,z`, not `{text}`"),
    }
}

fn count(n: f64) -> anyhow::Result<u32> {
    if n >= 1.0 && n.fract() == 0.0 && n <= u32::MAX as f64 {
        Ok(n as u32)
    } else {
        bail!("--squares must be whole numbers of at least 1, not {n}")
    }
}

fn colour(text: &str) -> anyhow::Result<[f64; 3]> {
    if text.starts_with(|c: char| c.is_ascii_alphabetic() || c == '_') {
        let table = ColourTable::for_run(None)?;
        return match table.get(text) {
            Some(c) => Ok(c.to_array()),
            None => match table.suggest(text) {
                Some(near) => bail!("unknown colour `{text}`; did you mean `{near}`?"),
                None => bail!("unknown colour `{text}`"),
            },
        };
    }
    triple(text, "--colors")
        .with_context(|| format!("colour `{text}` is neither `r,g,b` nor a name"))
}
