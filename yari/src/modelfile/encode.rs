//! Writing a model file as its objects arrive: each object is encoded as soon as it is
//! compiled ([`ModelEncoder::push`]), so a scene read as a stream is never held as a
//! [`World`] with all its objects, and the file's bytes are the only copy of the model.
//!
//! The payload's head (camera, lights, surfaces) comes before the objects but is complete
//! only after the last of them (a later `f` adds a surface, a later `l` a light), and the
//! header's version depends on every object, so [`ModelEncoder::finish`] moves the encoded
//! objects up in their own buffer and writes the header, the head and the object count in
//! front of them (the model is held once: a large buffer grows, and moves, in place), and
//! hashes the payload once. The bytes are those [`super::to_bytes`] gives for
//! the same world: it is this encoder fed the world's objects.

use super::{fnv1a, ModelFileError, HEADER_LEN, MAGIC, OLDEST_VERSION, SMOOTH_VERSION, VERSION};
use crate::model::{Camera, Features, Light, Object, Shape, Surface, World};
use glam::DVec3;
use serde::Serialize;

/// The fields of a [`World`] before its objects, borrowed, in the order postcard writes
/// them (the writing half of the stream decoder's `Head`).
#[derive(Serialize)]
struct HeadRef<'a> {
    resolution: &'a [u32; 2],
    background: &'a DVec3,
    ambient: &'a DVec3,
    camera: &'a Camera,
    lights: &'a Vec<Light>,
    samples: &'a u32,
    surfaces: &'a Vec<Surface>,
}

/// A model file being written one object at a time.
#[derive(Default)]
pub struct ModelEncoder {
    /// The encoded objects, in order.
    objects: Vec<u8>,
    count: u64,
    smooth: bool,
    failed: Option<String>,
}

impl ModelEncoder {
    /// An encoder with no objects yet.
    pub fn new() -> ModelEncoder {
        ModelEncoder::default()
    }

    /// Encodes the next object.
    pub fn push(&mut self, object: &Object) {
        if self.failed.is_some() {
            return;
        }
        let buffer = std::mem::take(&mut self.objects);
        match postcard::to_extend(object, buffer) {
            Ok(b) => self.objects = b,
            Err(e) => self.failed = Some(e.to_string()),
        }
        self.count += 1;
        self.smooth |= matches!(object.shape, Shape::SmoothPolygon { .. });
    }

    /// The whole file: `head`'s fields before and after its objects (its own `objects` are
    /// not written; those pushed are) around the objects pushed.
    pub fn finish(self, head: &World) -> Result<Vec<u8>, ModelFileError> {
        if let Some(e) = self.failed {
            return Err(ModelFileError::Corrupt(e));
        }
        let corrupt = |e: postcard::Error| ModelFileError::Corrupt(e.to_string());
        let version = version_of(self.smooth, head.target_error.is_some());
        let mut front = Vec::with_capacity(HEADER_LEN + 256);
        front.extend_from_slice(MAGIC);
        front.extend_from_slice(&version.to_le_bytes());
        front.resize(HEADER_LEN, 0);
        let head_ref = HeadRef {
            resolution: &head.resolution,
            background: &head.background,
            ambient: &head.ambient,
            camera: &head.camera,
            lights: &head.lights,
            samples: &head.samples,
            surfaces: &head.surfaces,
        };
        let mut front = postcard::to_extend(&head_ref, front).map_err(corrupt)?;
        if version >= VERSION {
            front = postcard::to_extend(&head.target_error, front).map_err(corrupt)?;
        }
        push_varint(&mut front, self.count);
        let back = postcard::to_extend::<Features, Vec<u8>>(&head.features, Vec::new())
            .map_err(corrupt)?;
        let mut out = self.objects;
        let objects = out.len();
        out.reserve_exact(front.len() + back.len());
        out.resize(objects + front.len(), 0);
        out.copy_within(0..objects, front.len());
        out[..front.len()].copy_from_slice(&front);
        out.extend_from_slice(&back);
        let len = (out.len() - HEADER_LEN) as u64;
        let hash = fnv1a(&out[HEADER_LEN..]);
        out[12..20].copy_from_slice(&len.to_le_bytes());
        out[20..28].copy_from_slice(&hash.to_le_bytes());
        Ok(out)
    }
}

/// The lowest format version that holds a world with smooth polygons or not, and a target
/// error or not.
pub(super) fn version_of(smooth: bool, target_error: bool) -> u32 {
    match (smooth, target_error) {
        (_, true) => VERSION,
        (true, false) => SMOOTH_VERSION,
        (false, false) => OLDEST_VERSION,
    }
}

/// A postcard varint (a sequence's length).
fn push_varint(out: &mut Vec<u8>, mut n: u64) {
    while n >= 0x80 {
        out.push((n as u8) | 0x80);
        n >>= 7;
    }
    out.push(n as u8);
}
