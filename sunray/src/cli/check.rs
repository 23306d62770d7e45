//! `sunray check SCENE`: parse and compile a scene, print a one-line summary and any
//! warnings, or the diagnostics; exit 0 only when the scene is valid.

use clap::Args;
use std::path::PathBuf;
use std::process::ExitCode;
use yari::colour::ColourTable;
use yari::load::{load_path, LoadError};
use yari::model::World;

/// The flags of `sunray check`.
#[derive(Args, Debug)]
pub struct CheckArgs {
    /// The scene: .yari, .nff, .off, an .obj, .ply, .gltf or .glb mesh, or a compiled .srw
    /// model.
    pub scene: PathBuf,
    /// The colour-name table (`--colors`).
    #[command(flatten)]
    pub colours: super::colours::ColourArgs,
}

/// Checks the scene: prints its summary and warnings and exits 0, or prints the diagnostics
/// and exits 1.
pub fn run(args: CheckArgs) -> anyhow::Result<ExitCode> {
    let colours = ColourTable::for_run(args.colours.colors.as_deref())?;
    match load_path(&args.scene, &colours) {
        Ok(loaded) => {
            eprint!("{}", loaded.render_warnings());
            println!("{}", summary(&display_name(&args.scene), &loaded.world));
            if let Some(mesh) = &loaded.mesh {
                println!("{}", mesh_summary(mesh));
            }
            for placed in &loaded.meshes {
                let label = format!("mesh {}", placed.path.display());
                println!("{}", labelled_mesh_summary(&label, &placed.summary));
            }
            Ok(ExitCode::SUCCESS)
        }
        Err(e @ LoadError::Scene(_)) => {
            eprintln!("{e}");
            Ok(ExitCode::FAILURE)
        }
        Err(e) => Err(e.into()),
    }
}

/// The file name of a path, for summaries.
pub fn display_name(path: &std::path::Path) -> String {
    path.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| path.display().to_string())
}

/// `mesh: 2048 vertices, 4096 faces (4096 triangles), no normals; bounds -1,-1,-1 to 1,1,1`.
pub fn mesh_summary(m: &yari::mesh::MeshSummary) -> String {
    labelled_mesh_summary("mesh", m)
}

/// [`mesh_summary`] under another label (`mesh models/statue.ply: ...`).
fn labelled_mesh_summary(label: &str, m: &yari::mesh::MeshSummary) -> String {
    let point = |p: [f64; 3]| format!("{},{},{}", p[0], p[1], p[2]);
    let bounds = if m.bounds.is_empty() {
        "no bounds (no faces)".to_string()
    } else {
        format!("bounds {} to {}", point(m.bounds.min), point(m.bounds.max))
    };
    let n = |k: u64, one, many| plural(k as usize, one, many);
    format!(
        "{label}: {}, {} ({}), {}; {bounds}",
        n(m.vertices, "vertex", "vertices"),
        n(m.faces, "face", "faces"),
        n(m.triangles, "triangle", "triangles"),
        if m.normals {
            "vertex normals"
        } else {
            "no normals"
        }
    )
}

fn plural(n: usize, one: &str, many: &str) -> String {
    format!("{n} {}", if n == 1 { one } else { many })
}

/// `tetra16.yari: 16 polygons, 1 light, 512x512` plus the features the world uses.
pub fn summary(name: &str, world: &World) -> String {
    let f = &world.features;
    let kinds: Vec<String> = [
        (f.polygons, "polygon", "polygons"),
        (f.spheres, "sphere", "spheres"),
        (f.ellipsoids, "ellipsoid", "ellipsoids"),
        (f.quadrics, "quadric", "quadrics"),
    ]
    .iter()
    .filter(|(n, _, _)| *n > 0)
    .map(|(n, one, many)| plural(*n, one, many))
    .collect();
    let prims = if kinds.is_empty() {
        "no primitives".to_string()
    } else {
        kinds.join(" + ")
    };
    let mut line = format!(
        "{name}: {prims}, {}, {}x{}",
        plural(world.lights.len(), "light", "lights"),
        world.resolution[0],
        world.resolution[1]
    );
    let used: Vec<String> = [
        (f.reflection, "reflection"),
        (f.transparency, "transparency"),
        (f.textures, "textures"),
        (f.area_lights, "area lights"),
        (f.gloss, "gloss"),
        (f.translucency, "translucency"),
        (f.depth_of_field, "depth of field"),
        (f.motion_blur, "motion blur"),
    ]
    .iter()
    .filter(|(on, _)| *on)
    .map(|(_, name)| name.to_string())
    .chain(
        f.antialiasing
            .then(|| format!("{} samples per pixel", world.samples)),
    )
    .collect();
    if !used.is_empty() {
        line.push_str("; uses ");
        line.push_str(&used.join(", "));
    }
    line
}
