//! The project: a scene being edited, with the names and the structure that plain YARI
//! loses, kept as JSON and saved atomically (a temporary file, then a rename).
//!
//! A project holds the scene settings (the YARI preamble), named skeletons, and a tree of
//! named objects. Each object is one YARI `begin ... end` block: an optional surface (its
//! `attribute`), transformations, primitives and child objects. Transformations are kept
//! only on objects without children, so that an operation on a composite (translate,
//! rotate, scale) can be applied to every part in world space; see the `tree` module.

use crate::error::ModelError;
use crate::skeleton::Skeleton;
use serde::{Deserialize, Serialize};
use std::io::Write;
use std::path::Path;

/// The project file format version written by this program.
pub const FORMAT_VERSION: u32 = 1;

/// A point, vector or `r,g,b` triple (x, y, z), as in YARI.
pub type V3 = [f64; 3];

/// A scene being edited.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Project {
    /// The file format version ([`FORMAT_VERSION`]); a file of a newer version is refused.
    pub version: u32,
    /// The preamble: resolution, samples, colours, camera, lights, preview viewpoint.
    pub settings: SceneSettings,
    /// Skeletons (outlines, profiles, point sets); the modeler's own, not exported.
    #[serde(default)]
    pub skeletons: Vec<Skeleton>,
    /// The top-level objects: the nested blocks of the world block, in order.
    #[serde(default)]
    pub objects: Vec<Object>,
}

/// The YARI preamble plus the preview's viewpoint.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct SceneSettings {
    /// `resolution(w, h)` in pixels, 1..65536 each; `None` writes none (YARI's default).
    #[serde(default)]
    pub resolution: Option<[u32; 2]>,
    /// `samples(n)`, samples per pixel (a YARI extension); `None` writes none (1).
    #[serde(default)]
    pub samples: Option<u32>,
    /// `target_error(E)` (a YARI extension): each pixel rendered to this error instead of a
    /// sample count; `None` writes none.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub target_error: Option<f64>,
    /// `background(color = ...)`; `None` writes none (black).
    #[serde(default)]
    pub background: Option<Color>,
    /// `ambient(color = ...)`; `None` writes none (black).
    #[serde(default)]
    pub ambient: Option<Color>,
    /// `camera(...)`; `None` writes none (the compiler's default camera, with a warning).
    #[serde(default)]
    pub camera: Option<Camera>,
    /// The lights, each with a name unique among lights, in the order written.
    #[serde(default)]
    pub lights: Vec<Light>,
    /// Where the preview's perspective view looks from (the editor's "view location");
    /// `None` uses the camera. Not part of the YARI output.
    #[serde(default)]
    pub view: Option<View>,
}

/// A colour by name (looked up in the renderer's colour table) or as linear RGB.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Color {
    /// A colour name (checked against the colour table when set; case is ignored).
    Named(String),
    /// `r,g,b`, linear, normally 0..1.
    Rgb(V3),
}

/// The YARI camera, in world space.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Camera {
    /// The eye point.
    pub position: V3,
    /// The point looked at.
    pub at: V3,
    /// Which way is up in the image.
    pub up: V3,
    /// Half angle of view in degrees (YARI's `angle`).
    pub angle: f64,
    /// Lens radius for depth of field (a YARI extension); `None` is a pinhole.
    #[serde(default)]
    pub aperture: Option<f64>,
    /// Distance to the plane in focus; `None` is the distance from `position` to `at`.
    #[serde(default)]
    pub focus: Option<f64>,
}

impl Default for Camera {
    fn default() -> Camera {
        Camera {
            position: [0.0, 0.0, 10.0],
            at: [0.0; 3],
            up: [0.0, 1.0, 0.0],
            angle: 22.5,
            aperture: None,
            focus: None,
        }
    }
}

/// A named light (the name is written as a comment before its `light(...)`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Light {
    /// Unique among the project's lights.
    pub name: String,
    /// Its centre in world space.
    pub position: V3,
    /// Its colour and intensity.
    pub color: Color,
    /// Radius of a spherical area light (a YARI extension); `None` is a point light.
    #[serde(default)]
    pub radius: Option<f64>,
}

/// The preview's perspective viewpoint.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct View {
    /// The eye point, in world space.
    pub from: V3,
    /// The point looked at.
    pub at: V3,
    /// Which way is up in the view.
    pub up: V3,
    /// Half angle of view in degrees.
    pub angle: f64,
}

/// One composite object: a YARI block.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Object {
    /// Unique among all objects of the project (written as a comment before the block).
    pub name: String,
    /// The block's `attribute(...)`; `None` inherits the enclosing block's surface.
    #[serde(default)]
    pub surface: Option<Surface>,
    /// Applied in the order written (YARI: the first one moves a point first).
    #[serde(default)]
    pub transforms: Vec<Transform>,
    /// The primitives drawn in this block, after its transformations.
    #[serde(default)]
    pub primitives: Vec<Primitive>,
    /// Nested objects (parts), drawn after the primitives; an object with children has no
    /// transformations of its own.
    #[serde(default)]
    pub children: Vec<Object>,
}

/// Surface properties (YARI `attribute`); fields left `None` are not written and take the
/// renderer's defaults (an attribute replaces the whole surface).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Surface {
    /// `color`: the surface colour (white when not written).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub color: Option<Color>,
    /// `kdr`: diffuse reflection, 0..1 (0 = mirror, 1 = matte).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub kdr: Option<f64>,
    /// `kdt`: diffuse transmission, 0..1 (0 = clear, 1 = opaque).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub kdt: Option<f64>,
    /// `ka`: ambient coefficient, >= 0.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ka: Option<f64>,
    /// `phong`: Phong exponent of highlights, >= 0.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub phong: Option<f64>,
    /// `refract`: index of refraction; > 0 when kdt < 1.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub refract: Option<f64>,
    /// `texture`: a solid texture.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub texture: Option<Texture>,
    /// `gloss` (extension): blurry reflection, half-angle spread in degrees.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gloss: Option<f64>,
    /// `translucency` (extension): blurry transmission, half-angle spread in degrees.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub translucency: Option<f64>,
    /// `transmissivity` (extension): per unit length inside the object, 0..1.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub transmissivity: Option<f64>,
    /// `texture_space` (extension): explicit world-to-texture map, 3x4 row by row.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub texture_space: Option<[f64; 12]>,
}

/// `texture = id r,g,b sx,sy,sz`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Texture {
    /// 1 wood, 2 marble, 3 bumps, 4 turbulence, 5 checker (`docs/yari.md` section 5).
    pub id: f64,
    /// The second colour (veins, mix colour or odd cells), linear RGB.
    pub color: V3,
    /// Feature size along x, y, z of texture space; no component 0.
    pub scale: V3,
}

/// A YARI transformation of an object's primitives, in the object's block.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Transform {
    /// `translate(x,y,z)`: move by (x, y, z).
    Translate(V3),
    /// `scale(x,y,z)`: scale each axis; no factor 0.
    Scale(V3),
    /// Degrees about x, then y, then z.
    Rotate(V3),
    /// `motion(x,y,z)` (extension): world-space displacement while the shutter is open.
    Motion(V3),
    /// `transform(m00 ... m23)` (extension): a general affine map, 3x4 row by row.
    Matrix([f64; 12]),
}

/// A YARI primitive in its object's space (before the object's transformations).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Primitive {
    /// `sphere(center = ... ; radius = ...)`.
    Sphere {
        /// The centre.
        center: V3,
        /// The radius, > 0.
        radius: f64,
    },
    /// `polygon(...)`: a planar polygon.
    Polygon {
        /// The vertices in order, at least 3.
        vertices: Vec<V3>,
        /// One normal per vertex for smooth shading (YARI's `normals = ...`); `None` (and
        /// absent from the file) for a flat polygon.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        normals: Option<Vec<V3>>,
    },
    /// Coefficients in YARI's order (see `yari::model::Quadric`) and clipping.
    Quadric {
        /// The ten coefficients `a b c d e f g h i j`.
        coeffs: [f64; 10],
        /// The `clip` and `plane` fields, in order; empty is unclipped.
        clip: Vec<Clip>,
    },
    /// `mesh(file = "..." [; materials = file])` (extension): a mesh file's faces, read
    /// when the scene is compiled.
    Mesh {
        /// The file: relative to the project file's folder unless absolute (as a scene's is
        /// to the YARI file's; [`crate::mesh_files`]).
        file: String,
        /// Whether the faces take the file's own materials (else the object's surface).
        #[serde(default, skip_serializing_if = "std::ops::Not::not")]
        materials_file: bool,
    },
}

/// How a quadric is clipped (YARI extension), in the quadric's own space.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Clip {
    /// `clip = min max`: keep the part inside the axis-aligned box.
    Box {
        /// The minimum corner.
        min: V3,
        /// The maximum corner.
        max: V3,
    },
    /// `plane = a,b,c d`: keep the part where a*x + b*y + c*z <= d.
    Plane {
        /// (a, b, c), not zero.
        normal: V3,
        /// d.
        offset: f64,
    },
}

impl Project {
    /// A new project that renders as it stands: 512x512, the default camera looking at the
    /// origin from +z, one white light, a dim ambient.
    pub fn new_default() -> Project {
        Project {
            version: FORMAT_VERSION,
            settings: SceneSettings {
                resolution: Some([512, 512]),
                samples: None,
                target_error: None,
                background: Some(Color::Rgb([0.0, 0.0, 0.0])),
                ambient: Some(Color::Rgb([0.2, 0.2, 0.2])),
                camera: Some(Camera::default()),
                lights: vec![Light {
                    name: "key".into(),
                    position: [10.0, 10.0, 10.0],
                    color: Color::Rgb([1.0, 1.0, 1.0]),
                    radius: None,
                }],
                view: None,
            },
            skeletons: Vec::new(),
            objects: Vec::new(),
        }
    }

    /// Reads a project file.
    pub fn load(path: &Path) -> Result<Project, ModelError> {
        let text = std::fs::read_to_string(path).map_err(|e| ModelError::io(path, e))?;
        let project: Project =
            serde_json::from_str(&text).map_err(|e| ModelError::ProjectFormat {
                path: path.display().to_string(),
                message: e.to_string(),
            })?;
        if project.version > FORMAT_VERSION {
            return Err(ModelError::ProjectFormat {
                path: path.display().to_string(),
                message: format!(
                    "format version {} is newer than this modeler ({FORMAT_VERSION})",
                    project.version
                ),
            });
        }
        Ok(project)
    }

    /// Writes the project as JSON, atomically.
    pub fn save(&self, path: &Path) -> Result<(), ModelError> {
        let mut text =
            serde_json::to_string_pretty(self).map_err(|e| ModelError::ProjectFormat {
                path: path.display().to_string(),
                message: e.to_string(),
            })?;
        text.push('\n');
        write_atomic(path, text.as_bytes())
    }
}

/// Writes a file by writing a temporary file beside it and renaming it over the target, so
/// that a reader never sees a half-written file and a failure leaves the old one.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), ModelError> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => std::path::PathBuf::from("."),
    };
    let file_name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "out".into());
    let tmp = dir.join(format!(".{file_name}.tmp{}", std::process::id()));
    let result = (|| {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    if let Err(e) = result {
        let _ = std::fs::remove_file(&tmp);
        return Err(ModelError::io(path, e));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn save_and_load_are_lossless() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("p.json");
        let mut p = Project::new_default();
        p.objects.push(Object {
            name: "ball".into(),
            surface: Some(Surface {
                color: Some(Color::Named("red".into())),
                kdr: Some(0.3),
                ..Surface::default()
            }),
            transforms: vec![Transform::Rotate([0.1, 1.0 / 3.0, 7.0])],
            primitives: vec![
                Primitive::Sphere {
                    center: [1.0, 2.0, 3.0],
                    radius: 0.1 + 0.2,
                },
                // Values that a fast, inexact float parser reads back wrongly.
                Primitive::Polygon {
                    vertices: vec![
                        [
                            4.9751276215361216e-17,
                            -1.4925382864608366e-16,
                            0.57452425971407,
                        ],
                        [1e-300, 5e-324, f64::MAX],
                        [0.1, 0.2, 0.3],
                    ],
                    normals: Some(vec![[0.1, 0.2, 0.3], [1e-300, 0.0, 1.0], [0.0, 0.0, -1.0]]),
                },
            ],
            children: vec![],
        });
        p.save(&path).unwrap();
        assert_eq!(Project::load(&path).unwrap(), p);
        // No temporary file is left behind.
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }

    #[test]
    fn a_bad_file_is_a_clear_error() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("p.json");
        std::fs::write(&path, "{ not json").unwrap();
        let err = Project::load(&path).unwrap_err().to_string();
        assert!(err.contains("p.json"), "{err}");
        let missing = Project::load(&dir.path().join("none.json"))
            .unwrap_err()
            .to_string();
        assert!(missing.contains("none.json"), "{missing}");
    }
}
