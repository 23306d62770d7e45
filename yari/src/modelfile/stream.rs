//! Reading a model file as a stream: its bytes are fed in pieces of any size (a file read
//! block by block, REM chunks as they arrive), and each object is handed over, checked, as
//! soon as its bytes are in. Nothing holds the whole file or every object at once, so a
//! renderer builds its own compact geometry from a model of millions of polygons without
//! keeping the model twice.
//!
//! The payload is the [`World`] as postcard writes it: the fields before `objects`
//! ([`Head`]), the object count as a varint, the objects, then [`Features`]. The checksum
//! and the length are checked at [`ModelStream::finish`]; a caller uses nothing it was handed
//! before that succeeds.

use super::{fits_version, fnv1a_update, validate_head, validate_object};
use super::{ModelFileError, HEADER_LEN};
use super::{FNV_OFFSET, MAGIC, OLDEST_VERSION, VERSION};
use crate::model::{Camera, Features, Light, Object, Surface, World};
use glam::DVec3;
use serde::Deserialize;
use std::io::Read;

/// The fields of a [`World`] that come before its objects, in the same order (postcard
/// writes a struct as its fields one after another). A test checks that a stream decodes
/// every world as [`postcard`] does.
#[derive(Deserialize)]
struct Head {
    resolution: [u32; 2],
    background: DVec3,
    ambient: DVec3,
    camera: Camera,
    lights: Vec<Light>,
    samples: u32,
    surfaces: Vec<Surface>,
}

impl Head {
    /// The head of a file of `version` and its target error (a version 3 file's, right after
    /// the head: postcard writes a struct as its fields one after another), from the front of
    /// `bytes`, with how many bytes they took.
    fn take(
        bytes: &[u8],
        version: u32,
    ) -> Result<Option<(Head, Option<f64>, usize)>, ModelFileError> {
        let Some((head, used)) = take::<Head>(bytes)? else {
            return Ok(None);
        };
        if version < VERSION {
            return Ok(Some((head, None, used)));
        }
        Ok(take::<Option<f64>>(&bytes[used..])?.map(|(target, more)| (head, target, used + more)))
    }
}

/// Where the decoder is in the payload.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Stage {
    Header,
    Head,
    Count,
    Objects,
    Features,
    Done,
}

/// A model file being decoded as its bytes arrive ([`ModelStream::feed`]).
pub struct ModelStream {
    stage: Stage,
    header: Vec<u8>,
    /// The header's format version.
    version: u32,
    /// Payload length and checksum from the header.
    len: u64,
    expected_hash: u64,
    /// Payload bytes fed so far, and their running FNV-1a.
    received: u64,
    hash: u64,
    /// Payload bytes fed but not yet decoded.
    pending: Vec<u8>,
    /// The world without its objects, once the head is decoded.
    world: Option<World>,
    objects_left: u64,
    next_object: usize,
    /// The first decoding error; reported by [`ModelStream::finish`] unless the checksum
    /// fails (a damaged byte is a checksum error, as when the file is read whole).
    failed: Option<ModelFileError>,
}

impl Default for ModelStream {
    fn default() -> ModelStream {
        ModelStream::new()
    }
}

impl ModelStream {
    /// A decoder at the start of a file.
    pub fn new() -> ModelStream {
        ModelStream {
            stage: Stage::Header,
            header: Vec::with_capacity(HEADER_LEN),
            version: 0,
            len: 0,
            expected_hash: 0,
            received: 0,
            hash: FNV_OFFSET,
            pending: Vec::new(),
            world: None,
            objects_left: 0,
            next_object: 0,
            failed: None,
        }
    }

    /// The world decoded so far, without its objects (camera, lights, surfaces ...); `None`
    /// until the bytes before the first object are in.
    pub fn head(&self) -> Option<&World> {
        self.world.as_ref()
    }

    /// Takes the next bytes of the file; `object(head, index, object)` is called for each
    /// object completed, in order, after it was checked against the head (its surface index
    /// in range, its numbers finite). Bytes past the payload the header announces are
    /// ignored, as [`super::read`] ignores them. An error is returned at once only for the
    /// header; one found in the payload stops the decoding, and [`ModelStream::finish`]
    /// reports it.
    pub fn feed(
        &mut self,
        mut bytes: &[u8],
        object: &mut dyn FnMut(&World, usize, Object),
    ) -> Result<(), ModelFileError> {
        if self.stage == Stage::Header {
            let take = (HEADER_LEN - self.header.len()).min(bytes.len());
            self.header.extend_from_slice(&bytes[..take]);
            bytes = &bytes[take..];
            if self.header.len() >= MAGIC.len() && &self.header[..MAGIC.len()] != MAGIC {
                return Err(ModelFileError::BadMagic);
            }
            if self.header.len() < HEADER_LEN {
                return Ok(());
            }
            self.read_header()?;
        }
        let room = self.len - self.received;
        let payload = &bytes[..bytes.len().min(usize::try_from(room).unwrap_or(usize::MAX))];
        self.received += payload.len() as u64;
        self.hash = fnv1a_update(self.hash, payload);
        if self.failed.is_some() {
            return Ok(());
        }
        self.pending.extend_from_slice(payload);
        match self.decode(object) {
            Ok(used) => {
                self.pending.drain(..used);
            }
            Err(e) => {
                self.failed = Some(e);
                self.pending = Vec::new();
            }
        }
        Ok(())
    }

    fn read_header(&mut self) -> Result<(), ModelFileError> {
        let h = &self.header;
        let word = |at: usize| u64::from_le_bytes(h[at..at + 8].try_into().unwrap_or([0; 8]));
        let version = u32::from_le_bytes(h[8..12].try_into().unwrap_or([0; 4]));
        if !(OLDEST_VERSION..=VERSION).contains(&version) {
            return Err(ModelFileError::UnsupportedVersion { found: version });
        }
        self.version = version;
        self.len = word(12);
        self.expected_hash = word(20);
        self.stage = Stage::Head;
        Ok(())
    }

    /// Decodes what `pending` holds whole; how many of its bytes were used.
    fn decode(
        &mut self,
        object: &mut dyn FnMut(&World, usize, Object),
    ) -> Result<usize, ModelFileError> {
        let mut at = 0;
        loop {
            let rest = &self.pending[at..];
            let used = match self.stage {
                Stage::Header | Stage::Done => return Ok(at),
                Stage::Head => match Head::take(rest, self.version)? {
                    None => return Ok(at),
                    Some((head, target_error, used)) => {
                        let world = World {
                            resolution: head.resolution,
                            background: head.background,
                            ambient: head.ambient,
                            camera: head.camera,
                            lights: head.lights,
                            samples: head.samples,
                            target_error,
                            surfaces: head.surfaces,
                            objects: Vec::new(),
                            features: Features::default(),
                        };
                        validate_head(&world).map_err(ModelFileError::Invalid)?;
                        self.world = Some(world);
                        self.stage = Stage::Count;
                        used
                    }
                },
                Stage::Count => match varint(rest)? {
                    None => return Ok(at),
                    Some((n, used)) => {
                        self.objects_left = n;
                        self.stage = Stage::Objects;
                        used
                    }
                },
                Stage::Objects if self.objects_left == 0 => {
                    self.stage = Stage::Features;
                    0
                }
                Stage::Objects => match take::<Object>(rest)? {
                    None => return Ok(at),
                    Some((obj, used)) => {
                        let Some(world) = self.world.as_ref() else {
                            return Err(ModelFileError::Corrupt("objects before the head".into()));
                        };
                        let i = self.next_object;
                        validate_object(i, &obj, world.surfaces.len())
                            .and_then(|()| fits_version(i, &obj, self.version))
                            .map_err(ModelFileError::Invalid)?;
                        object(world, i, obj);
                        self.next_object += 1;
                        self.objects_left -= 1;
                        used
                    }
                },
                Stage::Features => match take::<Features>(rest)? {
                    None => return Ok(at),
                    Some((features, used)) => {
                        if let Some(w) = self.world.as_mut() {
                            w.features = features;
                        }
                        self.stage = Stage::Done;
                        used
                    }
                },
            };
            at += used;
        }
    }

    /// Ends the stream: the world without its objects, once the whole payload has arrived,
    /// decoded to exactly one world, and matched the header's checksum.
    pub fn finish(self) -> Result<World, ModelFileError> {
        if self.stage == Stage::Header {
            if self.header.len() < MAGIC.len() {
                return Err(ModelFileError::BadMagic);
            }
            return Err(ModelFileError::Truncated {
                expected: HEADER_LEN as u64,
                found: self.header.len() as u64,
            });
        }
        if self.received < self.len {
            return Err(ModelFileError::Truncated {
                expected: self.len,
                found: self.received,
            });
        }
        if self.hash != self.expected_hash {
            return Err(ModelFileError::Checksum);
        }
        if let Some(e) = self.failed {
            return Err(e);
        }
        if self.stage != Stage::Done {
            return Err(ModelFileError::Corrupt(
                "the model ends before its last object".into(),
            ));
        }
        if !self.pending.is_empty() {
            return Err(ModelFileError::Corrupt(format!(
                "{} bytes after the model",
                self.pending.len()
            )));
        }
        self.world
            .ok_or_else(|| ModelFileError::Corrupt("no model".into()))
    }
}

/// One value from the front of `bytes` and the bytes it took; `None` when `bytes` end
/// inside it (more are needed).
fn take<'a, T: Deserialize<'a>>(bytes: &'a [u8]) -> Result<Option<(T, usize)>, ModelFileError> {
    match postcard::take_from_bytes::<T>(bytes) {
        Ok((value, rest)) => Ok(Some((value, bytes.len() - rest.len()))),
        Err(postcard::Error::DeserializeUnexpectedEnd) => Ok(None),
        Err(e) => Err(ModelFileError::Corrupt(e.to_string())),
    }
}

/// A postcard varint (a sequence's length) from the front of `bytes`.
fn varint(bytes: &[u8]) -> Result<Option<(u64, usize)>, ModelFileError> {
    let mut n: u64 = 0;
    for (k, b) in bytes.iter().enumerate().take(10) {
        n |= u64::from(b & 0x7f) << (7 * k);
        if b & 0x80 == 0 {
            return Ok(Some((n, k + 1)));
        }
    }
    if bytes.len() >= 10 {
        return Err(ModelFileError::Corrupt("bad object count".into()));
    }
    Ok(None)
}

/// Reads a model file from `input` block by block, calling `object` for each object as it
/// is decoded; the world without its objects.
pub fn read_stream(
    input: &mut impl Read,
    object: &mut dyn FnMut(&World, usize, Object),
) -> Result<World, ModelFileError> {
    let mut stream = ModelStream::new();
    let mut block = vec![0u8; 1 << 16];
    loop {
        let n = match input.read(&mut block) {
            Ok(0) => break,
            Ok(n) => n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(e.into()),
        };
        stream.feed(&block[..n], object)?;
        if stream.stage == Stage::Done && stream.received == stream.len {
            break;
        }
    }
    stream.finish()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::colour::ColourTable;
    use crate::span::Source;

    fn compiled(name: &str, text: &str) -> World {
        let src = Source::new(name, text.to_string());
        crate::compile::compile(&crate::parse::parse(&src).unwrap(), &ColourTable::builtin())
            .unwrap()
            .world
    }

    fn worlds() -> Vec<World> {
        let mut w = vec![
            compiled(
                "cubes.yari",
                &crate::test_support::thesis_example("cubes.yari"),
            ),
            compiled(
                "tetra16.yari",
                &crate::test_support::thesis_example("tetra16.yari"),
            ),
        ];
        let mut empty = w[0].clone();
        empty.objects.clear();
        w.push(empty);
        let mut target = w[1].clone();
        target.target_error = Some(0.004);
        w.push(target);
        w
    }

    fn streamed(bytes: &[u8], piece: usize) -> Result<World, ModelFileError> {
        let mut stream = ModelStream::new();
        let mut objects = Vec::new();
        for p in bytes.chunks(piece.max(1)) {
            stream.feed(p, &mut |_, i, o| {
                assert_eq!(i, objects.len());
                objects.push(o)
            })?;
        }
        let mut world = stream.finish()?;
        world.objects = objects;
        Ok(world)
    }

    #[test]
    fn a_stream_in_pieces_of_any_size_decodes_what_postcard_does() {
        for world in worlds() {
            let bytes = super::super::to_bytes(&world).unwrap();
            // A version 3 payload is the World in postcard; an older one is the World
            // without its target error (which it has none of).
            if super::super::version_for(&world) == VERSION {
                let whole: World = postcard::from_bytes(&bytes[HEADER_LEN..]).unwrap();
                assert_eq!(whole, world);
            }
            for piece in [1, 2, 7, 28, 29, 1000, bytes.len()] {
                assert_eq!(streamed(&bytes, piece).unwrap(), world, "pieces of {piece}");
            }
            let mut reader = &bytes[..];
            let mut n = 0;
            let head = read_stream(&mut reader, &mut |_, _, _| n += 1).unwrap();
            assert_eq!(n, world.objects.len());
            assert!(head.objects.is_empty());
            assert_eq!(head.features, world.features);
        }
    }

    #[test]
    fn a_damaged_stream_is_an_error_at_the_latest_when_it_ends() {
        let world = worlds().remove(0);
        let bytes = super::super::to_bytes(&world).unwrap();
        for n in 0..bytes.len() {
            assert!(streamed(&bytes[..n], 5).is_err(), "a prefix of {n} bytes");
        }
        let mut flipped = bytes.clone();
        let last = flipped.len() - 1;
        flipped[last] ^= 0x01;
        assert!(streamed(&flipped, 64).is_err());
        // A surface index out of range is refused before the object is handed over.
        let mut bad = world.clone();
        bad.objects[3].surface = 999;
        let bad = super::super::to_bytes(&bad).unwrap();
        let mut handed = 0;
        let mut stream = ModelStream::new();
        stream.feed(&bad, &mut |_, _, _| handed += 1).unwrap();
        assert_eq!(handed, 3);
        let r = stream.finish();
        assert!(matches!(r, Err(ModelFileError::Invalid(_))), "{r:?}");
    }
}
