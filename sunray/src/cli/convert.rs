//! `sunray convert IN [-o OUT.yari]`: NFF or OFF to YARI (the thesis's `nff2gfx` and
//! `off2gfx`), or an OBJ or PLY mesh to YARI (polygons with normals, framed as
//! [`yari::mesh`] frames a mesh on its own); `sunray convert IN.nff -o OUT.obj|.ply|.glb`: an
//! NFF scene's polygons as a mesh (binary PLY, binary glTF); `sunray convert IN.yari -o
//! OUT.yari`: a YARI scene (or model) as its compiled world, flat (the triangles of its `mesh`
//! statements in full); `sunray convert IN -o OUT.pov`: any scene (YARI, NFF, OFF, model) to
//! POV-Ray SDL ([`yari::pov`]), for the side-by-side benchmark in bench/pov. Also the output
//! helpers the scene generators (`spd`, `check-board`) share:
//! YARI or NFF text chosen by the output's extension, written to a temporary file and
//! renamed, or printed to stdout.

use anyhow::{bail, Context};
use clap::{Args, ValueEnum};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use yari::span::Source;

/// Convert an NFF (`.nff`) or OFF (`.off`) scene, or an OBJ (`.obj`), PLY (`.ply`) or glTF
/// mesh, to YARI; a YARI scene (or `.srw` model) to flat YARI, its meshes' triangles in full;
/// or any scene to POV-Ray SDL (`-o OUT.pov`).
#[derive(Args, Debug)]
pub struct ConvertArgs {
    /// The scene to convert (`-` reads stdin; then give --from).
    pub input: PathBuf,
    /// Where to write the YARI scene (default: stdout).
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// The input format, when the extension does not say.
    #[arg(long, value_enum)]
    pub(crate) from: Option<InputFormat>,
}

/// Formats `convert` reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub(crate) enum InputFormat {
    Nff,
    Off,
    Obj,
    Ply,
    Gltf,
}

/// Formats the generators write.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub(crate) enum OutputFormat {
    Yari,
    Nff,
    /// Wavefront OBJ: the scene's polygons only.
    Obj,
    /// PLY, binary little-endian: the scene's polygons only.
    Ply,
    /// PLY, ASCII.
    PlyAscii,
    /// PLY, binary big-endian.
    PlyBigEndian,
    /// Binary glTF 2.0 (`.glb`): the scene's polygons as 32-bit float triangles.
    Glb,
}

/// Converts the scene and writes it (or prints it on stdout).
pub fn run(args: ConvertArgs) -> anyhow::Result<ExitCode> {
    if let Some(out) = &args.output {
        if extension(out).as_deref() == Some("pov") {
            return compiled_to(&args.input, Some(out), yari::pov::write_pov);
        }
    }
    let compiled = matches!(extension(&args.input).as_deref(), Some("yari" | "srw"));
    if args.from.is_none() && compiled {
        return flat_yari(&args.input, args.output.as_deref());
    }
    let format = match args.from {
        Some(f) => f,
        None => match extension(&args.input).as_deref() {
            Some("nff") => InputFormat::Nff,
            Some("off") => InputFormat::Off,
            Some("obj") => InputFormat::Obj,
            Some("ply") => InputFormat::Ply,
            Some("gltf" | "glb") => InputFormat::Gltf,
            _ => bail!(
                "cannot tell the format of {} from its name; give --from nff, off, obj, ply or gltf",
                args.input.display()
            ),
        },
    };
    let mesh_out = args
        .output
        .as_deref()
        .and_then(|out| match extension(out).as_deref() {
            Some("obj") => Some(OutputFormat::Obj),
            Some("ply") => Some(OutputFormat::Ply),
            Some("glb") => Some(OutputFormat::Glb),
            _ => None,
        });
    if let Some(out) = &args.output {
        if matches!(extension(out).as_deref(), Some("nff" | "off" | "gltf"))
            || (mesh_out.is_some() && format != InputFormat::Nff)
        {
            bail!(
                "convert writes YARI (or, from NFF, an .obj or .ply mesh); name the output {} \
                 with a .yari extension",
                out.display()
            );
        }
    }
    let mesh = match format {
        InputFormat::Obj => Some(yari::mesh::MeshKind::Obj),
        InputFormat::Ply => Some(yari::mesh::MeshKind::Ply),
        InputFormat::Gltf => Some(yari::mesh::MeshKind::Gltf),
        _ => None,
    };
    if let Some(kind) = mesh {
        // A mesh may be binary: read from its file (beside its material libraries).
        if args.input.as_os_str() == "-" {
            bail!("a mesh is read from its file, not stdin");
        }
        let (scene, _) = yari::mesh::parse_path(kind, &args.input)?;
        write_output(args.output.as_deref(), &yari::writer::write_scene(&scene))?;
        return Ok(ExitCode::SUCCESS);
    }
    let (name, text) = if args.input.as_os_str() == "-" {
        let mut text = String::new();
        std::io::Read::read_to_string(&mut std::io::stdin(), &mut text).context("reading stdin")?;
        ("<stdin>".to_string(), text)
    } else {
        let text = std::fs::read_to_string(&args.input)
            .with_context(|| format!("reading {}", args.input.display()))?;
        (args.input.display().to_string(), text)
    };
    let src = Source::new(name, text);
    if let Some(mesh) = mesh_out {
        return nff_to_mesh(&src, mesh, args.output.as_deref());
    }
    let result = match format {
        InputFormat::Nff => yari::nff::parse_with_warnings(&src),
        _ => yari::off::parse_with_warnings(&src),
    };
    match result {
        Ok((scene, warnings)) => {
            eprint!("{}", warnings.render(&src));
            write_output(args.output.as_deref(), &yari::writer::write_scene(&scene))?;
            Ok(ExitCode::SUCCESS)
        }
        Err(diags) => {
            eprint!("{}", diags.render(&src));
            let n = diags.errors().count();
            eprintln!(
                "sunray: {} error{} in {}; nothing written",
                n,
                if n == 1 { "" } else { "s" },
                src.name
            );
            Ok(ExitCode::FAILURE)
        }
    }
}

/// An NFF scene's polygons as a mesh (`format` OBJ or PLY), exactly as the file gives them.
fn nff_to_mesh(src: &Source, format: OutputFormat, out: Option<&Path>) -> anyhow::Result<ExitCode> {
    match yari::nff::read(src) {
        Ok((scene, warnings)) => {
            eprint!("{}", warnings.render(src));
            write_bytes(out, &render_scene(&scene, format)?)?;
            Ok(ExitCode::SUCCESS)
        }
        Err(diags) => {
            eprint!("{}", diags.render(src));
            eprintln!("sunray: {} not converted; nothing written", src.name);
            Ok(ExitCode::FAILURE)
        }
    }
}

/// A YARI scene or model written as its compiled world, flat (its meshes' triangles in full).
fn flat_yari(input: &Path, output: Option<&Path>) -> anyhow::Result<ExitCode> {
    if let Some(out) = output.filter(|o| extension(o).as_deref() != Some("yari")) {
        bail!(
            "a YARI scene or model converts to a flat YARI file (its meshes' triangles in full) \
             or to POV-Ray SDL; name the output {} with a .yari or .pov extension",
            out.display()
        );
    }
    compiled_to(input, output, yari::writer::write_world)
}

/// Compiles any scene file and writes its world as `write` prints it (POV-Ray SDL, or flat
/// YARI), to `output` or stdout.
fn compiled_to(
    input: &Path,
    output: Option<&Path>,
    write: fn(&yari::model::World) -> String,
) -> anyhow::Result<ExitCode> {
    let colours = yari::colour::ColourTable::builtin();
    match yari::load::load_path(input, &colours) {
        Ok(loaded) => {
            eprint!("{}", loaded.render_warnings());
            write_output(output, &write(&loaded.world))?;
            Ok(ExitCode::SUCCESS)
        }
        Err(e) => {
            eprintln!("{e}");
            eprintln!("sunray: {} not converted; nothing written", input.display());
            Ok(ExitCode::FAILURE)
        }
    }
}

fn extension(path: &Path) -> Option<String> {
    path.extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
}

/// The format to write: `--format` if given, else the output's extension (`.nff` is NFF,
/// `.obj` OBJ, `.ply` binary PLY, anything else YARI), else YARI on stdout.
pub(crate) fn output_format(flag: Option<OutputFormat>, output: Option<&Path>) -> OutputFormat {
    flag.unwrap_or_else(|| match output.and_then(extension).as_deref() {
        Some("nff") => OutputFormat::Nff,
        Some("obj") => OutputFormat::Obj,
        Some("ply") => OutputFormat::Ply,
        Some("glb") => OutputFormat::Glb,
        _ => OutputFormat::Yari,
    })
}

/// A generated NFF scene in `format`: text, or for PLY perhaps binary. A mesh format holds
/// only the scene's polygons (their geometry and normals): a scene with spheres or cones is
/// refused (`--patches` makes them polygons).
pub(crate) fn render_scene(
    scene: &yari::nff::NffScene,
    format: OutputFormat,
) -> anyhow::Result<Vec<u8>> {
    use yari::mesh::write;
    let ply = |encoding| -> anyhow::Result<Vec<u8>> {
        let mut out = Vec::new();
        write::ply(&yari::mesh::faces_of(scene)?, encoding, &mut out)?;
        Ok(out)
    };
    Ok(match format {
        OutputFormat::Nff => yari::nff::write(scene).into_bytes(),
        OutputFormat::Yari => yari::writer::write_scene(&yari::nff::to_yari(scene)).into_bytes(),
        OutputFormat::Obj => {
            let mut out = Vec::new();
            write::obj(&yari::mesh::faces_of(scene)?, &mut out)?;
            out
        }
        OutputFormat::Ply => ply(write::PlyEncoding::BinaryLittleEndian)?,
        OutputFormat::PlyAscii => ply(write::PlyEncoding::Ascii)?,
        OutputFormat::PlyBigEndian => ply(write::PlyEncoding::BinaryBigEndian)?,
        OutputFormat::Glb => write::glb(&yari::mesh::faces_of(scene)?)?,
    })
}

/// Writes `text` to `path` through a temporary file in the same directory and a rename, so a
/// failed run leaves no half-written file; `None` prints to stdout.
pub fn write_output(path: Option<&Path>, text: &str) -> anyhow::Result<()> {
    write_bytes(path, text.as_bytes())
}

/// [`write_output`] of bytes.
pub fn write_bytes(path: Option<&Path>, text: &[u8]) -> anyhow::Result<()> {
    let Some(path) = path else {
        let mut out = std::io::stdout().lock();
        out.write_all(text)
            .and_then(|_| out.flush())
            .context("writing to stdout")?;
        return Ok(());
    };
    let dir = path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let file_name = path
        .file_name()
        .with_context(|| format!("{} is not a file name", path.display()))?;
    let tmp = dir.join(format!(
        ".{}.tmp{}",
        file_name.to_string_lossy(),
        std::process::id()
    ));
    let written = std::fs::File::create(&tmp)
        .and_then(|mut f| f.write_all(text).and_then(|_| f.sync_all()))
        .and_then(|_| std::fs::rename(&tmp, path));
    if let Err(e) = written {
        let _ = std::fs::remove_file(&tmp);
        return Err(e).with_context(|| format!("writing {}", path.display()));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn format_follows_flag_then_extension() {
        assert_eq!(
            output_format(None, Some(Path::new("a/b.NFF"))),
            OutputFormat::Nff
        );
        assert_eq!(
            output_format(None, Some(Path::new("b.yari"))),
            OutputFormat::Yari
        );
        assert_eq!(output_format(None, None), OutputFormat::Yari);
        assert_eq!(
            output_format(Some(OutputFormat::Nff), Some(Path::new("b.yari"))),
            OutputFormat::Nff
        );
    }

    #[test]
    fn output_is_renamed_into_place() {
        let dir = std::env::temp_dir().join(format!("sunray-convert-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("out.yari");
        write_output(Some(&path), "hello\n").unwrap();
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "hello\n");
        let leftovers: Vec<_> = std::fs::read_dir(&dir)
            .unwrap()
            .filter_map(|e| e.ok())
            .collect();
        assert_eq!(leftovers.len(), 1, "temporary file left behind");
        // A directory that does not exist fails cleanly.
        assert!(write_output(Some(&dir.join("missing/out.yari")), "x").is_err());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
