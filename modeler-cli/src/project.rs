//! The project: a scene being edited, with the names and the structure that plain YARI
//! loses, kept as JSON and saved atomically (a temporary file, then a rename).
//!
//! A project holds the scene settings (the YARI preamble), named skeletons, and a tree of
//! named objects. Each object is one YARI `begin ... end` block: an optional surface (its
//! `attribute`), transformations, primitives and child objects. Transformations are kept
//! only on objects without children, so that an operation on a composite (translate,
//! rotate, scale) can be applied to every part in world space; see [`crate::tree`].

use crate::error::ModelError;
use crate::skeleton::Skeleton;
use serde::{Deserialize, Serialize};
use std::io::Write;
use std::path::Path;

/// The project file format version written by this program.
pub const FORMAT_VERSION: u32 = 1;

pub type V3 = [f64; 3];

/// A scene being edited.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Project {
    pub version: u32,
    pub settings: Settings,
    /// Skeletons (outlines, profiles, point sets); the modeler's own, not exported.
    #[serde(default)]
    pub skeletons: Vec<Skeleton>,
    /// The top-level objects: the nested blocks of the world block, in order.
    #[serde(default)]
    pub objects: Vec<Object>,
}

/// The YARI preamble plus the preview's viewpoint.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Settings {
    #[serde(default)]
    pub resolution: Option<[u32; 2]>,
    #[serde(default)]
    pub samples: Option<u32>,
    #[serde(default)]
    pub background: Option<Color>,
    #[serde(default)]
    pub ambient: Option<Color>,
    #[serde(default)]
    pub camera: Option<Camera>,
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
    Named(String),
    Rgb(V3),
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Camera {
    pub position: V3,
    pub at: V3,
    pub up: V3,
    /// Half angle of view in degrees (YARI's `angle`).
    pub angle: f64,
    #[serde(default)]
    pub aperture: Option<f64>,
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

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Light {
    pub name: String,
    pub position: V3,
    pub color: Color,
    #[serde(default)]
    pub radius: Option<f64>,
}

/// The preview's perspective viewpoint.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct View {
    pub from: V3,
    pub at: V3,
    pub up: V3,
    /// Half angle of view in degrees.
    pub angle: f64,
}

/// One composite object: a YARI block.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Object {
    pub name: String,
    /// The block's `attribute(...)`; `None` inherits the enclosing block's surface.
    #[serde(default)]
    pub surface: Option<Surface>,
    /// Applied in the order written (YARI: the first one moves a point first).
    #[serde(default)]
    pub transforms: Vec<Transform>,
    #[serde(default)]
    pub primitives: Vec<Primitive>,
    #[serde(default)]
    pub children: Vec<Object>,
}

/// Surface properties (YARI `attribute`); fields left `None` are not written and take the
/// renderer's defaults (an attribute replaces the whole surface).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Surface {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub color: Option<Color>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub kdr: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub kdt: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ka: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub phong: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub refract: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub texture: Option<Texture>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gloss: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub translucency: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub transmissivity: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub texture_space: Option<[f64; 12]>,
}

/// `texture = id r,g,b sx,sy,sz`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Texture {
    pub id: f64,
    pub color: V3,
    pub scale: V3,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Transform {
    Translate(V3),
    Scale(V3),
    /// Degrees about x, then y, then z.
    Rotate(V3),
    Motion(V3),
    Matrix([f64; 12]),
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Primitive {
    Sphere {
        center: V3,
        radius: f64,
    },
    Polygon {
        vertices: Vec<V3>,
    },
    /// Coefficients in YARI's order (see `yari::model::Quadric`) and clipping.
    Quadric {
        coeffs: [f64; 10],
        clip: Vec<Clip>,
    },
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Clip {
    Box { min: V3, max: V3 },
    Plane { normal: V3, offset: f64 },
}

impl Project {
    /// A new project that renders as it stands: 512x512, the default camera looking at the
    /// origin from +z, one white light, a dim ambient.
    pub fn new_default() -> Project {
        Project {
            version: FORMAT_VERSION,
            settings: Settings {
                resolution: Some([512, 512]),
                samples: None,
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
