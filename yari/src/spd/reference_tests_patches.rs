//! The patches format ([`CurveFormat::Patches`], Haines's `-t`) against his own programs, as
//! [`super::reference_tests_rest`] does for the default format: the NFF text of every
//! database with spheres, cylinders or cones must have exactly the length and SHA-256 of
//! what his program prints when run as `prog -t -s SIZE` (SPD 3.14 built with gcc on x86-64
//! Linux), at his default size and at one other; one row is `balls -t 5 -s 2` (resolution
//! 5). His files are not kept in the repository.

use super::reference_tests::hex;
use super::{generate, generate_with, CurveFormat, Database, GenerateError};
use crate::nff::{read, write};
use crate::span::Source;
use sha2::{Digest, Sha256};

/// Haines's `-t` output: database, size factor, resolution given with `-t` (none: his
/// program's), length in bytes, SHA-256 (hex), measured with `wc -c` and `sha256sum`.
const HAINES_T: [(Database, u32, Option<u32>, usize, &str); 15] = [
    (
        Database::Balls,
        4,
        None,
        139_365_723,
        "8d820dab3c469c70f6a0149071ecb22ce6da65942b74aa8540d54d78e5bd6601",
    ),
    (
        Database::Balls,
        2,
        None,
        1_718_097,
        "e7c8eff988aa093c8d148d76a45f2303bd8a466b4067672207ced73f4ce6d637",
    ),
    (
        Database::Balls,
        2,
        Some(5),
        4_767_993,
        "ef44ed38e98a7a6956967f8c1674d79cc282184a7f40bc2df25b4a56d195cbea",
    ),
    (
        Database::Mount,
        6,
        None,
        705_560,
        "3ec269e47b4e625b9a4a7500770b8f9d8a9862480b2a7332c2c5870fc65e465b",
    ),
    (
        Database::Mount,
        3,
        None,
        81_167,
        "061f3f723cc8e8b4b751c1b25ed0cbd8e19a7f54bbea0a0f3958a060fa1bdf53",
    ),
    (
        Database::Rings,
        7,
        None,
        91_149_116,
        "2979cd080e635a1fb4293df4bcc9e6788d4cb3d1dd3879f085e7c6de5e3bf8e6",
    ),
    (
        Database::Rings,
        2,
        None,
        3_310_248,
        "198c3d7fa98e092f7aca36ff03880a90d7764b94bb834e2222c789a911e24c1b",
    ),
    (
        Database::Tree,
        11,
        None,
        91_187_056,
        "669dff95b02d8b7568d4cefd89d4fb97f9dcfdaeee63c3374421375a643158e7",
    ),
    (
        Database::Tree,
        3,
        None,
        336_664,
        "cab38e34cbb1d905b400b482d5a6ef0aea1fb9711aa5f3a9aa98edcd53f27880",
    ),
    (
        Database::Lattice,
        12,
        None,
        60_506_705,
        "038c2e6b4bd8fb43f1e3e79cbe92c5df12e0f6869984c5384a5daec00cad6d54",
    ),
    (
        Database::Lattice,
        2,
        None,
        670_724,
        "cccc15684eaec3995d21c5714b958537f6cd4b298a2275bc0baa808e7a5d4fea",
    ),
    (
        Database::Shells,
        5,
        None,
        110_811_810,
        "79fefa32a9a544f1de95c84a0173cee54a05e55d3b0459a4818026abaee32073",
    ),
    (
        Database::Shells,
        1,
        None,
        6_944_454,
        "ff8d02dc4d76697ac0cf5665b65f3f1f3a99f59521d20dc22bd9b175edcbdd4a",
    ),
    (
        Database::Jacks,
        1,
        None,
        57_225,
        "0c64d7ae47ca82b74a66deeb260a71a4fb42b6da705d39f843cb35929690bc8e",
    ),
    (
        Database::Jacks,
        3,
        None,
        4_061_189,
        "782e5cadd5b8be50535f570625d674ffe01d40200ef5998c7664cd52e61da0a6",
    ),
];

/// Our patches text for every recorded row of `db`, checked to be Haines's byte for byte.
fn check(db: Database) {
    let rows: Vec<_> = HAINES_T.iter().filter(|h| h.0 == db).collect();
    assert!(rows.len() >= 2, "{db:?}: two recorded sizes");
    assert!(rows.iter().any(|h| h.1 == db.default_size()), "{db:?}");
    for &&(_, size, resolution, len, sha) in &rows {
        let text = write(&generate_with(db, size, CurveFormat::Patches { resolution }).unwrap());
        let name = match resolution {
            Some(r) => format!("{} -t {r} -s {size}", db.name()),
            None => format!("{} -t -s {size}", db.name()),
        };
        assert_eq!(text.len(), len, "{name}: length differs from Haines's");
        assert_eq!(
            hex(&Sha256::digest(text.as_bytes())),
            sha,
            "{name}: text differs from Haines's"
        );
    }
}

#[test]
fn balls_patches_match_haines() {
    check(Database::Balls);
}

#[test]
fn mount_patches_match_haines() {
    check(Database::Mount);
}

#[test]
fn rings_patches_match_haines() {
    check(Database::Rings);
}

#[test]
fn tree_patches_match_haines() {
    check(Database::Tree);
}

#[test]
fn lattice_patches_match_haines() {
    check(Database::Lattice);
}

#[test]
fn shells_patches_match_haines() {
    check(Database::Shells);
}

#[test]
fn jacks_patches_match_haines() {
    check(Database::Jacks);
}

/// `-t` changes nothing in the databases without curved primitives (his programs print the
/// same text with and without it).
#[test]
fn patches_leave_polygon_databases_alone() {
    for db in Database::ALL {
        let size = if db.has_curves() {
            1
        } else {
            db.default_size()
        };
        let curves = write(&generate(db, size).unwrap());
        let patches = write(&generate_with(db, size, CurveFormat::PATCHES).unwrap());
        assert_eq!(curves == patches, !db.has_curves(), "{db:?}");
    }
}

/// Every sphere becomes 12 R^2 triangles and every cylinder or cone 8 R, R being 3 (jacks 2)
/// unless given; the polygons stay.
#[test]
fn patch_counts_follow_the_resolution() {
    for db in Database::ALL {
        let (spheres, polygons, cones) = generate(db, 2).unwrap().counts();
        for resolution in [None, Some(1), Some(4)] {
            let r = resolution.unwrap_or(db.patch_resolution()) as usize;
            let scene = generate_with(db, 2, CurveFormat::Patches { resolution }).unwrap();
            let want = polygons + 12 * r * r * spheres + 8 * r * cones;
            assert_eq!(scene.counts(), (0, want, 0), "{db:?} {resolution:?}");
        }
    }
}

#[test]
fn patches_beyond_the_limits_are_refused() {
    let too_big = generate_with(Database::Balls, 5, CurveFormat::PATCHES);
    assert!(
        matches!(
            too_big,
            Err(GenerateError::TooLarge {
                polygons: 7_174_441,
                ..
            })
        ),
        "{too_big:?}"
    );
    for resolution in [0, super::MAX_RESOLUTION + 1] {
        let format = CurveFormat::Patches {
            resolution: Some(resolution),
        };
        assert_eq!(
            generate_with(Database::Shells, 1, format),
            Err(GenerateError::Resolution { resolution })
        );
    }
    assert!(matches!(
        generate_with(Database::Tetra, 13, CurveFormat::PATCHES),
        Err(GenerateError::Size(_))
    ));
    // Curves are not limited by the patch limit.
    assert!(generate_with(Database::Balls, 5, CurveFormat::Curves).is_ok());
}

/// The patches text reads back (as `pp` polygons) and prints the same text.
#[test]
fn patches_read_back_to_the_same_text() {
    for db in [Database::Jacks, Database::Tree, Database::Mount] {
        let text = write(&generate_with(db, 2, CurveFormat::PATCHES).unwrap());
        let src = Source::new(db.name(), text.clone());
        let (scene, _) = read(&src).unwrap_or_else(|d| panic!("{}", d.render(&src)));
        assert_eq!(write(&scene), text, "{db:?}");
    }
}
