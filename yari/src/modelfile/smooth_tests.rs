//! Model files with smooth polygons: version 2, read back whole and as a stream; a world
//! without them still writes version 1; damaged and hostile normals are errors, never a
//! panic or an allocation the file does not pay for.

use super::*;
use crate::model::Shape;
use glam::DVec3;

fn world(text: &str) -> World {
    let src = crate::span::Source::new("s.yari", text);
    let scene = crate::parse::parse(&src).unwrap_or_else(|d| panic!("{}", d.render(&src)));
    crate::compile::compile(&scene, &crate::colour::ColourTable::builtin())
        .unwrap()
        .world
}

const SMOOTH: &str = "begin attribute(color = red);
    polygon(vertices = 3; 0,0,0 1,0,0 0,1,0);
    begin scale(2,1,1); polygon(vertices = 4; 0,0,0 1,0,0 1,1,0 0,1,0; normals = 0,0,1 1,0,1 1,1,1 0,1,1); end
    polygon(vertices = 3; 0,0,1 1,0,1 0,1,1; normals = 0,0,1 0,0,1 0,0,1);
end";

/// The payload of `bytes` changed by `edit`, with the header's length and checksum redone.
fn reseal(bytes: &[u8], edit: impl FnOnce(&mut Vec<u8>)) -> Vec<u8> {
    let mut payload = bytes[HEADER_LEN..].to_vec();
    edit(&mut payload);
    let mut out = bytes[..HEADER_LEN].to_vec();
    out[12..20].copy_from_slice(&(payload.len() as u64).to_le_bytes());
    out[20..28].copy_from_slice(&fnv1a(&payload).to_le_bytes());
    out.extend_from_slice(&payload);
    out
}

/// Where `object`'s encoding starts in `payload` (it must occur once).
fn find(payload: &[u8], object: &Object) -> usize {
    let enc = postcard::to_allocvec(object).unwrap();
    let at: Vec<usize> = (0..=payload.len() - enc.len())
        .filter(|&i| payload[i..i + enc.len()] == enc[..])
        .collect();
    assert_eq!(at.len(), 1);
    at[0]
}

#[test]
fn smooth_polygons_need_version_2_and_round_trip() {
    let w = world(SMOOTH);
    assert!(matches!(w.objects[1].shape, Shape::SmoothPolygon { .. }));
    let bytes = to_bytes(&w).unwrap();
    assert_eq!(u32::from_le_bytes(bytes[8..12].try_into().unwrap()), 2);
    assert_eq!(from_bytes(&bytes).unwrap(), w);
    // Without the smooth polygons the file is version 1, as every file was before.
    let mut flat = w.clone();
    flat.objects
        .retain(|o| matches!(o.shape, Shape::Polygon { .. }));
    let flat_bytes = to_bytes(&flat).unwrap();
    assert_eq!(version_for(&flat), 1);
    assert_eq!(u32::from_le_bytes(flat_bytes[8..12].try_into().unwrap()), 1);
    assert_eq!(from_bytes(&flat_bytes).unwrap(), flat);
    // A smooth polygon in a file that says version 1 is refused.
    let mut v1 = bytes.clone();
    v1[8] = 1;
    let r = from_bytes(&v1);
    assert!(
        matches!(&r, Err(ModelFileError::Invalid(m)) if m.contains("version 1")),
        "{r:?}"
    );
}

#[test]
fn damaged_and_hostile_normals_are_errors_not_panics() {
    let w = world(SMOOTH);
    let bytes = to_bytes(&w).unwrap();
    // Every prefix and every single flipped byte: an error or a world, never a panic.
    for n in 0..bytes.len() {
        assert!(from_bytes(&bytes[..n]).is_err());
    }
    for i in HEADER_LEN..bytes.len() {
        let _ = from_bytes(&reseal(&bytes, |p| p[i - HEADER_LEN] ^= 0x5a));
    }
    // Worlds that decode but break the rules for normals.
    let bad = |f: &dyn Fn(&mut Vec<DVec3>)| {
        let mut w = w.clone();
        if let Shape::SmoothPolygon { normals, .. } = &mut w.objects[1].shape {
            f(normals);
        }
        from_bytes(&to_bytes(&w).unwrap())
    };
    for r in [
        bad(&|n| {
            n.pop();
        }),
        bad(&|n| n.push(DVec3::Z)),
        bad(&|n| n[0] = DVec3::ZERO),
        bad(&|n| n[1] = DVec3::new(f64::NAN, 0.0, 1.0)),
        bad(&|n| n[2] = DVec3::new(0.0, f64::INFINITY, 0.0)),
        bad(&|n| n[3] = DVec3::new(1e-200, 0.0, 0.0)),
    ] {
        assert!(matches!(r, Err(ModelFileError::Invalid(_))), "{r:?}");
    }
    // A normal count of 2^62 in a small file: refused, nothing of that size allocated.
    let at = find(&bytes[HEADER_LEN..], &w.objects[1]);
    // variant (1 byte), vertex count (1), 4 vertices of 24 bytes, then the normal count.
    let count_at = at + 2 + 4 * 24;
    assert_eq!(bytes[HEADER_LEN + count_at], 4);
    let huge = reseal(&bytes, |p| {
        let varint = [0x80, 0x80, 0x80, 0x80, 0x80, 0x80, 0x80, 0x80, 0x40];
        p.splice(count_at..count_at + 1, varint);
    });
    assert!(from_bytes(&huge).is_err());
    // The same in a stream fed byte by byte.
    let mut stream = stream::ModelStream::new();
    for b in huge.chunks(1) {
        stream.feed(b, &mut |_, _, _| {}).unwrap();
    }
    assert!(stream.finish().is_err());
}

/// A scene's `target_error(E)` is kept in a version 3 file (with or without smooth
/// polygons), read back whole and as a stream; a world without one writes the version it
/// wrote before; a target that is not above 0 is refused by the compiler and by the reader.
#[test]
fn a_target_error_needs_version_3_and_round_trips() {
    for (text, before) in [
        (SMOOTH, 2),
        ("begin sphere(center = 0,0,0; radius = 1); end", 1),
    ] {
        let plain = world(text);
        assert_eq!(version_for(&plain), before);
        let w = world(&format!("target_error(0.0125);\n{text}"));
        assert_eq!(w.target_error, Some(0.0125));
        let bytes = to_bytes(&w).unwrap();
        assert_eq!(u32::from_le_bytes(bytes[8..12].try_into().unwrap()), 3);
        assert_eq!(from_bytes(&bytes).unwrap(), w);
        let mut streamed = Vec::new();
        let head = read_stream(&mut &bytes[..], &mut |_, _, o| streamed.push(o)).unwrap();
        assert_eq!(
            (head.target_error, streamed),
            (w.target_error, w.objects.clone())
        );
        // Written out as YARI, it reads back the same.
        assert_eq!(
            world(&crate::writer::write_world(&w)).target_error,
            Some(0.0125)
        );
        // A hostile file: the target's 8 bytes (after its Some tag) set to NaN.
        let nan = reseal(&bytes, |p| {
            let at = find_target(p, 0.0125);
            p[at..at + 8].copy_from_slice(&f64::NAN.to_le_bytes());
        });
        assert!(matches!(from_bytes(&nan), Err(ModelFileError::Invalid(_))));
    }
    for bad in ["0", "-1"] {
        let src = crate::span::Source::new("s.yari", format!("target_error({bad}); begin end"));
        let scene = crate::parse::parse(&src).unwrap();
        let e =
            crate::compile::compile(&scene, &crate::colour::ColourTable::builtin()).unwrap_err();
        assert!(
            e.render(&src)
                .contains("target_error must be a number above 0"),
            "{bad}"
        );
    }
}

/// Where the little-endian bytes of `value` occur in `payload` (once).
fn find_target(payload: &[u8], value: f64) -> usize {
    let enc = value.to_le_bytes();
    let at: Vec<usize> = (0..=payload.len() - 8)
        .filter(|&i| payload[i..i + 8] == enc)
        .collect();
    assert_eq!(at.len(), 1);
    at[0]
}
