//! The compiled model file (`.srw`): a [`World`] in binary, so workers load a scene without
//! parsing or compiling it again.
//!
//! Layout (all integers little-endian):
//!
//! ```text
//! offset  size  what
//!      0     8  magic b"SUNRAYW1"
//!      8     4  format version (u32): 1, 2 when a polygon has vertex normals, 3 when the
//!               scene asks for a target error
//!     12     8  payload length in bytes (u64)
//!     20     8  FNV-1a 64-bit hash of the payload (u64)
//!     28     n  payload: the World serialized with serde by postcard 1.x
//! ```
//!
//! Versions: 1 is the format as it was before vertex normals; 2 is the same encoding in which
//! an object may also be a [`crate::model::Shape::SmoothPolygon`] (an enum variant added
//! after the others, so every other object encodes as in version 1). The writer writes the
//! lowest version that holds the world ([`version_for`]): a world without smooth polygons
//! gives the very bytes it gave before they existed, and a program that predates them refuses
//! a file with them by its version number instead of failing to decode it. Both versions
//! are read; a smooth polygon in a version 1 file is refused. Version 3 adds the scene's
//! `target_error` (a postcard `Option<f64>`) right after the head's surfaces, before the
//! object count; it may hold smooth polygons too. Only a world with a target error is written
//! as version 3.
//!
//! A wrong magic, another version, a short file, a hash mismatch, a payload that does not
//! decode to exactly one World, or a World that breaks the compiler's guarantees
//! ([`validate`]) each give their own [`ModelFileError`].
//!
//! [`stream`] decodes a file as its bytes arrive and hands over one object at a time; every
//! read here goes through it. [`encode`] writes one as its objects arrive; every write here
//! goes through it.

pub mod encode;
pub mod stream;

#[cfg(test)]
mod smooth_tests;

use crate::model::{Object, World};
pub use encode::ModelEncoder;
use std::io::{Read, Write};
use std::path::Path;
pub use stream::{read_stream, ModelStream};

/// The first 8 bytes of every model file.
pub const MAGIC: &[u8; 8] = b"SUNRAYW1";
/// The newest format version this code writes and reads (version 3: a target error).
pub const VERSION: u32 = 3;
/// The first format version with smooth polygons.
pub const SMOOTH_VERSION: u32 = 2;
/// The oldest format version this code reads, and the one it writes for every world
/// without smooth polygons (so those files are what they were before version 2).
pub const OLDEST_VERSION: u32 = 1;
/// The conventional file extension.
pub const EXTENSION: &str = "srw";
const HEADER_LEN: usize = 28;

/// A failed read or write of a model file.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ModelFileError {
    /// Reading or writing the file failed.
    #[error("I/O error: {0}")]
    Io(#[from] std::io::Error),
    /// The file does not start with [`MAGIC`].
    #[error("not a SunRay model file (bad magic number)")]
    BadMagic,
    /// The header's format version is not one of [`OLDEST_VERSION`] to [`VERSION`].
    #[error(
        "model file format version {found} is not supported (this program reads versions {OLDEST_VERSION} to {VERSION})"
    )]
    UnsupportedVersion {
        /// The version in the header.
        found: u32,
    },
    /// Shorter than its header says (or than a header).
    #[error("model file is truncated: expected {expected} bytes of model, found {found}")]
    Truncated {
        /// Payload bytes the header announces.
        expected: u64,
        /// Payload bytes present.
        found: u64,
    },
    /// The payload's FNV-1a hash differs from the header's.
    #[error("model file is corrupt: checksum mismatch")]
    Checksum,
    /// The payload does not (de)serialize as exactly one [`World`]; the text says why.
    #[error("model file is corrupt: {0}")]
    Corrupt(String),
    /// The world breaks what the compiler guarantees (see [`validate`]); the text says what.
    #[error("model file holds an invalid world: {0}")]
    Invalid(String),
}

/// FNV-1a's starting state, 64 bits.
pub const FNV_OFFSET: u64 = 0xcbf2_9ce4_8422_2325;

/// FNV-1a, 64 bits, continued from state `h` over `bytes` (from [`FNV_OFFSET`]: a hash
/// computed piece by piece).
pub fn fnv1a_update(mut h: u64, bytes: &[u8]) -> u64 {
    for b in bytes {
        h ^= u64::from(*b);
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

/// FNV-1a, 64 bits.
pub fn fnv1a(bytes: &[u8]) -> u64 {
    fnv1a_update(FNV_OFFSET, bytes)
}

/// The version a file of `world` is written with: [`OLDEST_VERSION`] unless an object is a
/// smooth polygon, which needs [`VERSION`].
pub fn version_for(world: &World) -> u32 {
    let smooth = world
        .objects
        .iter()
        .any(|o| matches!(o.shape, crate::model::Shape::SmoothPolygon { .. }));
    encode::version_of(smooth, world.target_error.is_some())
}

/// The whole file as bytes: the world's objects encoded one by one behind its head
/// ([`ModelEncoder`]).
pub fn to_bytes(world: &World) -> Result<Vec<u8>, ModelFileError> {
    let mut encoder = ModelEncoder::new();
    for o in &world.objects {
        encoder.push(o);
    }
    encoder.finish(world)
}

/// Writes a model file to `out`.
pub fn write(world: &World, out: &mut impl Write) -> Result<(), ModelFileError> {
    out.write_all(&to_bytes(world)?)?;
    Ok(())
}

/// Reads a model file from `input`.
pub fn read(input: &mut impl Read) -> Result<World, ModelFileError> {
    let mut objects = Vec::new();
    let mut world = read_stream(input, &mut |_, _, o| objects.push(o))?;
    world.objects = objects;
    Ok(world)
}

/// Checks what the compiler guarantees, so a renderer can rely on it: a non-empty image and
/// sample count, surface indices in range, polygons of 3 or more vertices (smooth ones with
/// one non-zero normal per vertex), spheres with a positive radius, and finite numbers
/// throughout.
pub fn validate(world: &World) -> Result<(), String> {
    validate_head(world)?;
    for (i, o) in world.objects.iter().enumerate() {
        validate_object(i, o, world.surfaces.len())?;
    }
    Ok(())
}

/// [`validate`] of everything but the objects.
fn validate_head(world: &World) -> Result<(), String> {
    let finite = |v: glam::DVec3| v.is_finite();
    if world.resolution.contains(&0) || world.samples == 0 {
        return Err("zero resolution or sample count".into());
    }
    if world
        .target_error
        .is_some_and(|e| !(e.is_finite() && e > 0.0))
    {
        return Err("the target error is not a number above 0".into());
    }
    let c = &world.camera;
    let camera_ok =
        finite(c.position) && finite(c.at) && finite(c.up) && c.half_angle_deg.is_finite();
    if !camera_ok || !c.aperture.is_finite() || !c.focus_distance.is_finite() {
        return Err("camera is not finite".into());
    }
    if !finite(world.background) || !finite(world.ambient) {
        return Err("background or ambient is not finite".into());
    }
    if world
        .lights
        .iter()
        .any(|l| !finite(l.position) || !finite(l.color) || !l.radius.is_finite())
    {
        return Err("a light is not finite".into());
    }
    for s in &world.surfaces {
        let nums = [
            s.kdr,
            s.kdt,
            s.ka,
            s.phong,
            s.refract,
            s.gloss,
            s.translucency,
            s.transmissivity,
        ];
        let tex_ok = s
            .texture
            .as_ref()
            .is_none_or(|t| finite(t.color) && finite(t.scale) && t.world_to_texture.is_finite());
        if !finite(s.color) || nums.iter().any(|v| !v.is_finite()) || !tex_ok {
            return Err("a surface is not finite".into());
        }
    }
    Ok(())
}

/// [`validate`] of object `i`, in a world of `surfaces` surfaces.
fn validate_object(i: usize, o: &Object, surfaces: usize) -> Result<(), String> {
    use crate::model::Shape;
    let finite = |v: glam::DVec3| v.is_finite();
    if o.surface as usize >= surfaces {
        return Err(format!(
            "object {i} refers to surface {} of {surfaces}",
            o.surface
        ));
    }
    let ok = finite(o.motion)
        && match &o.shape {
            Shape::Sphere { center, radius } => {
                finite(*center) && radius.is_finite() && *radius > 0.0
            }
            Shape::Ellipsoid { to_world } => to_world.is_finite() && to_world.inverse().is_finite(),
            Shape::Polygon { vertices } => {
                vertices.len() >= 3 && vertices.iter().all(|v| finite(*v))
            }
            Shape::SmoothPolygon { vertices, normals } => {
                vertices.len() >= 3
                    && normals.len() == vertices.len()
                    && vertices.iter().all(|v| finite(*v))
                    && normals.iter().all(|n| n.length_squared().is_normal())
            }
            Shape::Quadric(q) => {
                q.q.iter().all(|v| v.is_finite())
                    && q.clip
                        .iter()
                        .all(|h| finite(h.normal) && h.offset.is_finite())
            }
        };
    if !ok {
        return Err(format!("object {i} is degenerate or not finite"));
    }
    Ok(())
}

/// Whether object `i` can be in a file of format `version` (a smooth polygon needs 2).
fn fits_version(i: usize, o: &Object, version: u32) -> Result<(), String> {
    match o.shape {
        crate::model::Shape::SmoothPolygon { .. } if version < SMOOTH_VERSION => Err(format!(
            "object {i} has vertex normals, which a version {version} file cannot hold"
        )),
        _ => Ok(()),
    }
}

/// Reads a model file from bytes.
pub fn from_bytes(mut bytes: &[u8]) -> Result<World, ModelFileError> {
    read(&mut bytes)
}

/// True when `bytes` start like a model file.
pub fn has_magic(bytes: &[u8]) -> bool {
    bytes.starts_with(MAGIC)
}

/// Writes a model file to a temporary name beside `path`, then renames it over `path`, so a
/// reader never sees half a file.
pub fn save_atomic(world: &World, path: &Path) -> Result<(), ModelFileError> {
    save_bytes_atomic(&to_bytes(world)?, path)
}

/// [`save_atomic`] of a model file's bytes (from [`ModelEncoder::finish`]).
pub fn save_bytes_atomic(bytes: &[u8], path: &Path) -> Result<(), ModelFileError> {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "model".into());
    let tmp = path.with_file_name(format!(".{name}.tmp-{}", std::process::id()));
    let result = (|| {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    if let Err(e) = result {
        let _ = std::fs::remove_file(&tmp);
        return Err(e.into());
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::colour::ColourTable;
    use crate::span::Source;

    fn cubes() -> World {
        let text = crate::test_support::thesis_example("cubes.yari");
        let src = Source::new("cubes.yari", text);
        crate::compile::compile(&crate::parse::parse(&src).unwrap(), &ColourTable::builtin())
            .unwrap()
            .world
    }

    #[test]
    fn round_trip_and_atomic_save() {
        let w = cubes();
        let bytes = to_bytes(&w).unwrap();
        assert!(has_magic(&bytes));
        assert_eq!(from_bytes(&bytes).unwrap(), w);
        let dir = std::env::temp_dir().join(format!("yari-modelfile-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("cubes.srw");
        save_atomic(&w, &path).unwrap();
        assert_eq!(read(&mut std::fs::File::open(&path).unwrap()).unwrap(), w);
        assert_eq!(
            std::fs::read_dir(&dir).unwrap().count(),
            1,
            "no temporary file is left"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn damaged_files_are_errors() {
        let bytes = to_bytes(&cubes()).unwrap();
        assert!(matches!(
            from_bytes(b"NOTAMODELFILE..............."),
            Err(ModelFileError::BadMagic)
        ));
        assert!(matches!(from_bytes(b""), Err(ModelFileError::BadMagic)));
        assert!(matches!(
            from_bytes(&bytes[..10]),
            Err(ModelFileError::Truncated { .. })
        ));
        assert!(matches!(
            from_bytes(&bytes[..bytes.len() - 1]),
            Err(ModelFileError::Truncated { .. })
        ));
        let mut v = bytes.clone();
        v[8] = 4;
        assert!(matches!(
            from_bytes(&v),
            Err(ModelFileError::UnsupportedVersion { found: 4 })
        ));
        let mut v = bytes.clone();
        let last = v.len() - 1;
        v[last] ^= 0xff;
        assert!(matches!(from_bytes(&v), Err(ModelFileError::Checksum)));
        // A world that decodes but breaks an invariant is refused.
        let mut w = cubes();
        w.objects[0].surface = 99;
        let bytes2 = to_bytes(&w).unwrap();
        assert!(matches!(
            from_bytes(&bytes2),
            Err(ModelFileError::Invalid(_))
        ));
        // Every prefix is an error, never a panic.
        for n in 0..bytes.len() {
            assert!(from_bytes(&bytes[..n]).is_err());
        }
    }
}
