//! The other eight databases against Haines's own programs, as [`super::reference_tests`]
//! does for tetra, mount and balls: the NFF text our generators print must have exactly the
//! length and SHA-256 of what his `gears`, `rings`, `tree`, `teapot`, `lattice`, `shells`,
//! `jacks` and `sombrero` print (built from his SPD 3.14 sources with gcc on x86-64 Linux and
//! run as `prog -s SIZE`, NFF being his default output), at his default size and at one
//! other, small size (`jacks` and `sombrero` default to 1, so their second size is larger).
//! His files are not kept in the repository.

use super::reference_tests::hex;
use super::{generate, Database};
use crate::nff::{read, write};
use crate::span::Source;
use sha2::{Digest, Sha256};

/// Haines's output: database, size factor, length in bytes, SHA-256 (hex), measured with
/// `wc -c` and `sha256sum` on the output of his generators.
const HAINES: [(Database, u32, usize, &str); 16] = [
    (
        Database::Gears,
        4,
        1_335_003,
        "888b3b7f3573891dbfe3e5b5c852020677fb2c526f0455a57018ed57702c0336",
    ),
    (
        Database::Gears,
        1,
        19_765,
        "f76119e960f489595856ba42781dfd0b6651331325b9dd96ea623341b1cd5b36",
    ),
    (
        Database::Rings,
        7,
        421_988,
        "e0f31dca34897a69575da1492d1bcdd3c5a8b1101c109ea3040e28c3ca4cc042",
    ),
    (
        Database::Rings,
        1,
        3_507,
        "ff117c4f7319a7c502401cea6d704b7b17a90446ac88bfb7f5d121d1a4baff07",
    ),
    (
        Database::Tree,
        11,
        475_128,
        "57ae111e5e70e6ca13caf5868804a43a1ca68dadf5dfffcbef265adefcada8a2",
    ),
    (
        Database::Tree,
        1,
        500,
        "8815735de8a099336636e2ced5bb0445df210e8d51b8160b468e61afac534926",
    ),
    (
        Database::Teapot,
        6,
        360_747,
        "bf83a1dda1d4312369b844f5d04a1f4aa3e62f841d4c24d2a293b387190e9dc1",
    ),
    (
        Database::Teapot,
        1,
        5_097,
        "c4802b1c3b109082466c78c21c2985b5b91326b11116012e602c37da2d6cb1cf",
    ),
    (
        Database::Lattice,
        12,
        767_285,
        "768ec7e5327a523027235e71a898783e6e4d9cb2500c79ca25dfe6931ca66177",
    ),
    (
        Database::Lattice,
        1,
        1_407,
        "9f83e1269e6dc08d9430d8366a73476b2b37d9c9a1f8a1c72fc644e1faf02354",
    ),
    (
        Database::Shells,
        5,
        233_896,
        "58732817189612a0c7b68983cf75e2cd040b0d35968a7db22ca6a0546681890b",
    ),
    (
        Database::Shells,
        1,
        14_805,
        "465e7fbcaf60b59334c8b634c92fa47eefcee055040d0b4cbc721a6af6f414ca",
    ),
    (
        Database::Jacks,
        1,
        524,
        "070a6ba5f7f93728f006659c1af31faf0c1daa835d473ee55e4d18ea49959d2d",
    ),
    (
        Database::Jacks,
        3,
        32_708,
        "082caed085ab90255bba2bba5a7ba1fb3cb12befc4678155731355bb437e7c34",
    ),
    (
        Database::Sombrero,
        1,
        155_626,
        "d52225d469879283d9b951aa4814a6982450ed08215ea0d49aa2444e9819ff81",
    ),
    (
        Database::Sombrero,
        2,
        650_450,
        "c77e81fb5bd5a2a9305feb44e7e62b49cb09b4144a1cbf9f0dad6a118f23bf36",
    ),
];

/// Our text for `db` at every recorded size, checked to be Haines's byte for byte.
fn texts(db: Database) -> Vec<(u32, String)> {
    let rows: Vec<_> = HAINES.iter().filter(|h| h.0 == db).collect();
    assert_eq!(rows.len(), 2, "{db:?}: two recorded sizes");
    rows.iter()
        .map(|&&(_, size, len, sha)| {
            let text = write(&generate(db, size).unwrap());
            let name = format!("{} -s {size}", db.name());
            assert_eq!(
                text.len(),
                len,
                "{name}: length differs from Haines's output"
            );
            assert_eq!(
                hex(&Sha256::digest(text.as_bytes())),
                sha,
                "{name}: text differs from Haines's output"
            );
            (size, text)
        })
        .collect()
}

#[test]
fn gears_matches_haines() {
    texts(Database::Gears);
}

#[test]
fn rings_matches_haines() {
    texts(Database::Rings);
}

#[test]
fn tree_matches_haines() {
    texts(Database::Tree);
}

#[test]
fn teapot_matches_haines() {
    texts(Database::Teapot);
}

#[test]
fn lattice_matches_haines() {
    texts(Database::Lattice);
}

#[test]
fn shells_matches_haines() {
    texts(Database::Shells);
}

#[test]
fn jacks_matches_haines() {
    texts(Database::Jacks);
}

#[test]
fn sombrero_matches_haines() {
    texts(Database::Sombrero);
}

/// His text read back prints the same text (the reader takes his one-line `c` and his `pp`).
#[test]
fn haines_output_reads_back_to_the_same_text() {
    for db in NEW {
        for (size, text) in texts(db) {
            let name = format!("{}{size}.nff", db.name());
            let src = Source::new(&name, text.clone());
            let (scene, _) = read(&src).unwrap_or_else(|d| panic!("{}", d.render(&src)));
            assert_eq!(write(&scene), text, "{name}");
        }
    }
}

/// The eight databases of this file.
const NEW: [Database; 8] = [
    Database::Gears,
    Database::Rings,
    Database::Tree,
    Database::Teapot,
    Database::Lattice,
    Database::Shells,
    Database::Jacks,
    Database::Sombrero,
];

/// (spheres, polygons, cones) at the default sizes: the counts in the headers of his
/// programs (teapot: 36 squares and 64 * 36 - 8 * 6 triangles).
#[test]
fn default_sizes_have_his_counts() {
    let want = [
        (Database::Gears, (0, 9345, 0)),
        (Database::Rings, (4200, 1, 4200)),
        (Database::Tree, (4095, 1, 4095)),
        (Database::Teapot, (0, 36 + 2256, 0)),
        (Database::Lattice, (2197, 0, 6084)),
        (Database::Shells, (5761, 0, 0)),
        (Database::Jacks, (6, 0, 3)),
        (Database::Sombrero, (0, 1922, 0)),
    ];
    for (db, counts) in want {
        let scene = generate(db, db.default_size()).unwrap();
        assert_eq!(scene.counts(), counts, "{db:?}");
    }
}

#[test]
fn sizes_out_of_range_are_refused() {
    for db in NEW {
        let sizes = db.sizes();
        assert!(sizes.contains(&db.default_size()), "{db:?}");
        assert!(generate(db, 0).is_err(), "{db:?} 0");
        let over = *sizes.end() + 1;
        let err = generate(db, over).unwrap_err();
        assert_eq!((err.name, err.size, err.min), (db.name(), over, 1));
    }
}

/// Every new database, at size 2, maps to YARI and compiles without a warning, with its
/// primitives: spheres to spheres, `p` and `pp` to polygons, `c` to clipped quadrics.
#[test]
fn small_sizes_compile_to_worlds() {
    let colours = crate::colour::ColourTable::builtin();
    for db in NEW {
        let nff = generate(db, 2).unwrap();
        let (spheres, polygons, cones) = nff.counts();
        let compiled = crate::compile::compile(&crate::nff::to_yari(&nff), &colours)
            .unwrap_or_else(|d| panic!("{db:?}: {d:?}"));
        assert_eq!(compiled.warnings.warnings().count(), 0, "{db:?}");
        let f = &compiled.world.features;
        assert_eq!(
            (f.spheres, f.polygons, f.quadrics),
            (spheres, polygons, cones),
            "{db:?}"
        );
    }
}

/// Haines warns that teapot size 1 "is not supported": four of its triangles, at the tip of
/// the spout (patch corners all on the line y = 0, z = 2.4), have no area. His program writes them all the same, and
/// so do we; the compiler drops them with a warning each.
#[test]
fn teapot_size_1_has_degenerate_triangles() {
    let nff = generate(Database::Teapot, 1).unwrap();
    assert_eq!(nff.counts(), (0, 57, 0));
    let compiled = crate::compile::compile(
        &crate::nff::to_yari(&nff),
        &crate::colour::ColourTable::builtin(),
    )
    .unwrap();
    assert_eq!(compiled.world.features.polygons, 53);
    let warnings: Vec<_> = compiled.warnings.warnings().collect();
    assert_eq!(warnings.len(), 4);
    assert!(warnings.iter().all(|w| w.message.contains("no area")));
}
