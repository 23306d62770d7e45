//! The controller <-> worker messages of `proto/sunray.proto` and their conversions: one
//! [`proto::SunrayMessage`] per REM envelope, pixels as little-endian `f32`, counters as in
//! [`crate::stats::Counters`], render settings as [`RenderOptions`] + [`AccelOptions`].

use crate::accel::AccelOptions;
use crate::render::adaptive::{Adaptive, PixelEstimate};
use crate::render::columns::Columns;
use crate::render::image_version::{self, IMAGE_VERSION};
use crate::render::settings::{self, SettingsError};
use crate::render::{RenderOptions, Settings};
use crate::shading::TraceOptions;
use crate::stats::Counters;
use prost::Message;

/// Generated from `proto/sunray.proto`.
#[allow(clippy::all, missing_docs)]
pub mod proto {
    include!(concat!(env!("OUT_DIR"), "/sunray.v1.rs"));
}

pub use proto::sunray_message::Body;

/// A message that is not a valid SunRay message.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum MessageError {
    /// The bytes are not a protobuf SunrayMessage.
    #[error("undecodable message: {0}")]
    Decode(#[from] prost::DecodeError),
    /// The envelope has no body.
    #[error("empty message")]
    Empty,
    #[error("{got} bytes of pixels for a line of {width} pixels")]
    /// A line's pixel bytes are not 12 (three little-endian f32) per pixel of the width.
    PixelCount {
        /// Bytes received.
        got: usize,
        /// Pixels in a line.
        width: u32,
    },
    /// A line's estimates are not [`PixelEstimate::BYTES`] per pixel of the width, or one
    /// holds more samples than the render's most.
    #[error("bad pixel estimates for a line of {width} pixels: {why}")]
    Estimates {
        /// Pixels in a line.
        width: u32,
        /// What is wrong, with the values.
        why: String,
    },
    /// A settled line's pixels ([`super::settled`]) are not 9 bytes per pixel of the width,
    /// or one is not a pixel a render to the job's error leaves done.
    #[error("bad settled pixels for a line of {width} pixels: {why}")]
    Settled {
        /// Pixels in a line.
        width: u32,
        /// What is wrong, with the values.
        why: String,
    },
    /// The render settings are out of bounds (or name an accelerator this program does not
    /// know).
    #[error(transparent)]
    Settings(#[from] SettingsError),
    /// The settings were sent by a build that renders other pixels
    /// ([`crate::render::image_version`]).
    #[error("the job's pixels are image version {theirs} and this sunray renders version {ours} (see `sunray --version`): use a sunray of image version {theirs}")]
    ImageVersion {
        /// The sender's version.
        theirs: u32,
        /// This build's.
        ours: u32,
    },
}

/// Encodes one message body for an envelope.
pub fn encode(body: Body) -> Vec<u8> {
    proto::SunrayMessage { body: Some(body) }.encode_to_vec()
}

/// Decodes an envelope's payload.
pub fn decode(bytes: &[u8]) -> Result<Body, MessageError> {
    proto::SunrayMessage::decode(bytes)?
        .body
        .ok_or(MessageError::Empty)
}

/// A scanline's pixels as bytes: 3 little-endian `f32` per pixel.
pub fn pixels_to_bytes(pixels: &[[f32; 3]]) -> Vec<u8> {
    let mut out = Vec::with_capacity(pixels.len() * 12);
    for p in pixels {
        for c in p {
            out.extend_from_slice(&c.to_le_bytes());
        }
    }
    out
}

/// The inverse of [`pixels_to_bytes`], checking there are exactly `width` pixels.
pub fn pixels_from_bytes(bytes: &[u8], width: u32) -> Result<Vec<[f32; 3]>, MessageError> {
    if bytes.len() != width as usize * 12 {
        return Err(MessageError::PixelCount {
            got: bytes.len(),
            width,
        });
    }
    Ok(bytes
        .chunks_exact(12)
        .map(|p| {
            let f = |i: usize| f32::from_le_bytes([p[i], p[i + 1], p[i + 2], p[i + 3]]);
            [f(0), f(4), f(8)]
        })
        .collect())
}

/// A line's pixel estimates as bytes ([`PixelEstimate::to_le_bytes`], one after another).
pub fn estimates_to_bytes(estimates: &[PixelEstimate]) -> Vec<u8> {
    estimates.iter().flat_map(|e| e.to_le_bytes()).collect()
}

/// The inverse of [`estimates_to_bytes`], checking there are exactly `width` estimates and
/// that none holds more samples than `a` allows.
pub fn estimates_from_bytes(
    bytes: &[u8],
    width: u32,
    a: &Adaptive,
) -> Result<Vec<PixelEstimate>, MessageError> {
    decode_estimates(bytes, width as usize, width, a)
}

/// The estimates of the pixels `columns` names (a line of `width` pixels), left to right, as
/// a later pass's grant and its answer carry them ([`Columns::pick`]), checked as
/// [`estimates_from_bytes`] checks a whole line's.
pub fn picked_estimates_from_bytes(
    bytes: &[u8],
    columns: &Columns,
    width: u32,
    a: &Adaptive,
) -> Result<Vec<PixelEstimate>, MessageError> {
    decode_estimates(bytes, columns.len(), width, a)
}

/// `count` estimates of a line of `width` pixels.
fn decode_estimates(
    bytes: &[u8],
    count: usize,
    width: u32,
    a: &Adaptive,
) -> Result<Vec<PixelEstimate>, MessageError> {
    let bad = |why: String| MessageError::Estimates { width, why };
    if bytes.len() != count * PixelEstimate::BYTES {
        return Err(bad(format!(
            "{} bytes, not {} per pixel for {count} pixels",
            bytes.len(),
            PixelEstimate::BYTES
        )));
    }
    let mut out = Vec::with_capacity(count);
    for b in bytes.chunks_exact(PixelEstimate::BYTES) {
        let e = PixelEstimate::from_le_bytes(b.try_into().unwrap_or(&[0; PixelEstimate::BYTES]));
        if !e.stage_is_valid() {
            return Err(bad(format!("pixel {} has an unknown stage", out.len())));
        }
        if e.count() > a.max_samples {
            return Err(bad(format!(
                "pixel {} has {} samples, more than --max-samples {}",
                out.len(),
                e.count(),
                a.max_samples
            )));
        }
        out.push(e);
    }
    Ok(out)
}

/// The counters travel as `proto::Counters`, field by field (the list is
/// [`with_counters!`](crate::stats::with_counters)); `line_s` is the line's own.
macro_rules! counters_on_the_wire {
    (
        rays { $($(#[$rdoc:meta])* $ray:ident: $rlabel:literal,)* }
        work { $($(#[$wdoc:meta])* $work:ident: $wlabel:literal,)* }
    ) => {
        impl From<&Counters> for proto::Counters {
            fn from(c: &Counters) -> proto::Counters {
                proto::Counters {
                    $($ray: c.$ray,)*
                    $($work: c.$work,)*
                    line_s: 0.0,
                }
            }
        }

        impl From<&proto::Counters> for Counters {
            fn from(c: &proto::Counters) -> Counters {
                Counters {
                    $($ray: c.$ray,)*
                    $($work: c.$work,)*
                }
            }
        }
    };
}
crate::stats::with_counters!(counters_on_the_wire);

/// The render settings travel as `proto::RenderSettings`: everything a worker needs besides
/// the model to render what `sunray render` would.
impl Settings {
    /// The settings as sent in a `Scene` message and kept in checkpoints.
    pub fn to_proto(&self) -> proto::RenderSettings {
        let r = &self.render;
        proto::RenderSettings {
            width: r.width,
            height: r.height,
            samples: r.samples,
            max_depth: r.trace.max_depth,
            min_weight: r.trace.min_weight,
            spawn_all: r.trace.spawn_all,
            accel: self.accel.kind.name().to_string(),
            max_per_voxel: self.accel.max_per_voxel.min(u32::MAX as usize) as u32,
            octree_max_depth: self.accel.max_depth,
            mailbox: self.mailbox,
            target_error: r.adaptive.map_or(0.0, |a| a.target_error),
            min_samples: r.adaptive.map_or(0, |a| a.min_samples),
            max_samples: r.adaptive.map_or(0, |a| a.max_samples),
            sampler: r.sampler.name().to_string(),
            image_version: IMAGE_VERSION,
        }
    }

    /// The settings of a `Scene` message or a checkpoint, as they came: every field checked
    /// against its bound ([`Settings::check`]) and the accelerator name against the known
    /// ones, before anything is allocated for them. Nothing is clamped: 0 pixels, samples or
    /// primitives per voxel are refused, as `to_proto` never sends them; so are settings sent
    /// by a build of another image version ([`image_version`]).
    pub fn from_proto(p: &proto::RenderSettings) -> Result<Settings, MessageError> {
        if let Some(theirs) = image_version::other_than_ours(p.image_version) {
            return Err(MessageError::ImageVersion {
                theirs,
                ours: IMAGE_VERSION,
            });
        }
        let s = Settings {
            render: RenderOptions {
                width: p.width,
                height: p.height,
                samples: p.samples,
                trace: TraceOptions {
                    max_depth: p.max_depth,
                    min_weight: p.min_weight,
                    spawn_all: p.spawn_all,
                },
                // 0 is "not asked"; anything else (NaN, a negative) is checked below.
                adaptive: (p.target_error != 0.0).then_some(Adaptive {
                    target_error: p.target_error,
                    min_samples: p.min_samples,
                    max_samples: p.max_samples,
                }),
                sampler: settings::sampler(&p.sampler)?,
            },
            accel: AccelOptions {
                kind: settings::accel_kind(&p.accel)?,
                max_per_voxel: p.max_per_voxel as usize,
                max_depth: p.octree_max_depth,
            },
            mailbox: p.mailbox,
        };
        s.check()?;
        Ok(s)
    }
}

/// The Assigns that hand `lines` to one worker, in order, each at most `max_bytes` encoded
/// (the relay's message limit): with a target error a grant carries its line's estimates, 149
/// bytes a pixel, and a worker's window of 3840-pixel lines made a 43 MB Assign, which the
/// relay refused (the worker was taken for lost). A grant too large alone goes alone.
pub fn assigns(lines: Vec<proto::LineGrant>, echo_s: f64, max_bytes: usize) -> Vec<Vec<u8>> {
    use prost::encoding::encoded_len_varint;
    // The Assign's tag and length inside the message, and its echo_s (the most either takes).
    const FRAME: usize = 1 + 10 + 9;
    let mut out = Vec::new();
    let mut batch: Vec<proto::LineGrant> = Vec::new();
    let mut bytes = FRAME;
    let mut send = |batch: Vec<proto::LineGrant>| {
        out.push(encode(Body::Assign(proto::Assign {
            lines: batch,
            echo_s,
        })))
    };
    for l in lines {
        let len = l.encoded_len();
        let len = 1 + encoded_len_varint(len as u64) + len;
        if !batch.is_empty() && bytes + len > max_bytes {
            send(std::mem::take(&mut batch));
            bytes = FRAME;
        }
        bytes += len;
        batch.push(l);
    }
    if !batch.is_empty() {
        send(batch);
    }
    out
}

/// FNV-1a, 64 bits: the model hash a resumed job is checked against.
pub fn fnv1a(bytes: &[u8]) -> u64 {
    yari::modelfile::fnv1a(bytes)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::AccelKind;

    #[test]
    fn pixels_round_trip_bit_for_bit() {
        let px = vec![[0.0, -1.5, f32::MAX], [1e-30, 0.25, f32::MIN_POSITIVE]];
        let bytes = pixels_to_bytes(&px);
        assert_eq!(bytes.len(), 24);
        assert_eq!(pixels_from_bytes(&bytes, 2).unwrap(), px);
        assert!(matches!(
            pixels_from_bytes(&bytes, 3),
            Err(MessageError::PixelCount { got: 24, width: 3 })
        ));
    }

    /// Grants of wide lines' estimates go in as many Assigns as the limit needs, each within
    /// it, every line once and in order.
    #[test]
    fn assigns_stay_within_the_message_limit() {
        let grant = |line: u32| proto::LineGrant {
            line,
            grant: u64::from(line) << 40,
            pass: 1,
            estimates: vec![7; 3840 * 149],
            ..Default::default()
        };
        let limit = 16 << 20;
        let out = assigns((0..75).map(grant).collect(), 12.5, limit);
        assert_eq!(out.len(), 3, "75 grants of 572 KB: 29 a message");
        let mut lines = Vec::new();
        for m in &out {
            assert!(m.len() <= limit, "{} bytes", m.len());
            let Body::Assign(a) = decode(m).unwrap() else {
                panic!("not an Assign")
            };
            assert_eq!(a.echo_s, 12.5);
            lines.extend(a.lines.iter().map(|l| l.line));
        }
        assert_eq!(lines, (0..75).collect::<Vec<_>>());
        // Small grants: one message; a grant over the limit alone: a message of its own.
        assert_eq!(
            assigns(
                (0..75)
                    .map(|l| proto::LineGrant {
                        line: l,
                        ..Default::default()
                    })
                    .collect(),
                0.0,
                limit
            )
            .len(),
            1
        );
        assert_eq!(assigns(vec![grant(0), grant(1)], 0.0, 1000).len(), 2);
    }

    #[test]
    fn messages_round_trip_and_garbage_is_an_error() {
        let m = Body::Assign(proto::Assign {
            lines: vec![
                proto::LineGrant {
                    line: 7,
                    grant: 42,
                    duplicate: false,
                    ..Default::default()
                },
                proto::LineGrant {
                    line: 3,
                    grant: 43,
                    duplicate: true,
                    pass: 2,
                    estimates: vec![1; 52],
                    columns: vec![0b101],
                },
            ],
            echo_s: 1.25,
        });
        assert_eq!(decode(&encode(m.clone())).unwrap(), m);
        assert!(decode(&[0xff, 0xff, 0xff]).is_err());
        assert!(matches!(decode(&[]), Err(MessageError::Empty)));
    }

    #[test]
    fn counters_and_settings_round_trip() {
        let c = Counters {
            eye: 1,
            eye_hits: 2,
            shadow: 3,
            shadow_behind: 4,
            reflected: 5,
            refracted: 6,
            total_internal: 11,
            intersection_tests: 7,
            voxels: 8,
            mailbox_hits: 9,
            mailbox_uses: 10,
        };
        assert_eq!(Counters::from(&proto::Counters::from(&c)), c);
        let s = Settings {
            render: RenderOptions {
                width: 64,
                height: 48,
                samples: 4,
                trace: TraceOptions {
                    max_depth: 3,
                    min_weight: 0.01,
                    spawn_all: true,
                },
                adaptive: None,
                sampler: crate::sampler::Sampler::Sobol,
            },
            accel: AccelOptions {
                kind: AccelKind::Bvh,
                max_per_voxel: 12,
                max_depth: 6,
            },
            mailbox: false,
        };
        assert_eq!(Settings::from_proto(&s.to_proto()).unwrap(), s);
        let mut bad = s.to_proto();
        bad.accel = "kd-tree".into();
        assert!(Settings::from_proto(&bad).is_err());
        let mut bad = s.to_proto();
        bad.sampler = "halton".into();
        let e = Settings::from_proto(&bad).unwrap_err().to_string();
        assert!(e.contains("sampler = \"halton\""), "{e}");
        // Sent before there was a choice: stratified.
        let mut old = s.to_proto();
        old.sampler.clear();
        assert_eq!(
            Settings::from_proto(&old).unwrap().render.sampler,
            crate::sampler::Sampler::Stratified
        );
    }

    #[test]
    fn settings_out_of_bounds_are_refused_with_the_field_named() {
        let good = Settings {
            render: RenderOptions {
                width: 64,
                height: 48,
                samples: 1,
                trace: TraceOptions::default(),
                adaptive: Some(Adaptive::new(0.01, None, None)),
                sampler: crate::sampler::Sampler::Stratified,
            },
            accel: AccelOptions::default(),
            mailbox: true,
        }
        .to_proto();
        type Change = fn(&mut proto::RenderSettings);
        let cases: [(Change, &str); 14] = [
            (|p| p.width = u32::MAX, "width"),
            (|p| p.width = 0, "width"),
            (|p| p.height = u32::MAX, "height"),
            (|p| p.samples = 0, "samples"),
            (|p| p.max_depth = 1_000_000_000, "max_depth"),
            (|p| p.min_weight = -1.0, "min_weight"),
            (|p| p.min_weight = f64::NAN, "min_weight"),
            (|p| p.max_per_voxel = u32::MAX, "max_per_voxel"),
            (|p| p.octree_max_depth = 1_000, "octree_max_depth"),
            (|p| p.accel = "kd-tree".into(), "accel"),
            (|p| p.target_error = f64::NAN, "--target-error"),
            (|p| p.target_error = -0.5, "--target-error"),
            (|p| p.min_samples = 0, "--min-samples"),
            (|p| p.max_samples = u32::MAX, "--max-samples"),
        ];
        for (change, field) in cases {
            let mut p = good.clone();
            change(&mut p);
            let e = Settings::from_proto(&p).unwrap_err();
            assert!(matches!(e, MessageError::Settings(_)), "{e}");
            let text = e.to_string();
            assert!(
                text.contains(field) && !text.contains('\n'),
                "{field}: {text}"
            );
        }
        // Nothing is clamped silently, nothing in bounds refused.
        assert!(Settings::from_proto(&good).is_ok());
    }
}
