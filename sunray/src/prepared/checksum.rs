//! The checksum of a prepared scene file and its seal.
//!
//! The checksum is a 64-bit hash of the file's bytes, read as little-endian words in four
//! lanes (each step a xor, an odd multiply and a rotation: a bijection of the lane, so a
//! change confined to one word always changes the sum), fast enough to run over a mapped
//! file of a million triangles in a few milliseconds. It is no defence against a writer that
//! means harm, only against damage: a file cut short, bits changed on disk.
//!
//! The seal is a small file beside the prepared one (`NAME.seal`), written only after the
//! file was written, read back and checked in full; it holds the file's length and
//! checksum. A reader trusts a file whose seal is there and matches: its length and
//! checksum (and the cheap checks of its tables) are checked again, its contents not.

use std::path::{Path, PathBuf};

const SEED: u64 = 0x243f_6a88_85a3_08d3;
const PRIME: u64 = 0x9e37_79b9_7f4a_7c15;

#[inline(always)]
fn step(lane: u64, word: u64) -> u64 {
    (lane ^ word).wrapping_mul(PRIME).rotate_left(29)
}

fn word(bytes: &[u8]) -> u64 {
    let mut w = [0u8; 8];
    w[..bytes.len()].copy_from_slice(bytes);
    u64::from_le_bytes(w)
}

/// The checksum of `bytes` (see the module's text).
pub fn checksum(bytes: &[u8]) -> u64 {
    let mut lanes = [SEED, SEED ^ 1, SEED ^ 2, SEED ^ 3];
    let mut blocks = bytes.chunks_exact(32);
    for block in &mut blocks {
        for (k, lane) in lanes.iter_mut().enumerate() {
            *lane = step(*lane, word(&block[k * 8..k * 8 + 8]));
        }
    }
    for (k, piece) in blocks.remainder().chunks(8).enumerate() {
        lanes[k] = step(lanes[k], word(piece));
    }
    let mut h = bytes.len() as u64;
    for lane in lanes {
        h = step(h, lane);
        h ^= h >> 31;
    }
    h
}

/// The seal of the prepared file at `path`.
pub fn seal_path(path: &Path) -> PathBuf {
    let mut name = path.as_os_str().to_owned();
    name.push(".seal");
    PathBuf::from(name)
}

fn seal_text(len: u64, sum: u64) -> String {
    format!("sunray prepared scene: {len} bytes, checksum {sum:016x}\n")
}

/// Seals the prepared file at `path` (of `len` bytes with checksum `sum`), atomically.
pub fn seal(path: &Path, len: u64, sum: u64) -> std::io::Result<()> {
    crate::film::write_atomically(&seal_path(path), seal_text(len, sum).as_bytes())
        .map_err(|e| std::io::Error::other(e.to_string()))
}

/// Whether the seal beside `path` says `len` bytes with checksum `sum`; None when there is
/// no seal.
pub fn sealed(path: &Path, len: u64, sum: u64) -> Option<bool> {
    let text = std::fs::read(seal_path(path)).ok()?;
    Some(text == seal_text(len, sum).as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn any_change_of_one_byte_or_of_the_length_changes_the_sum() {
        let bytes: Vec<u8> = (0..301u32).map(|i| (i * 37 % 251) as u8).collect();
        let sum = checksum(&bytes);
        for at in 0..bytes.len() {
            for bit in [0, 3, 7] {
                let mut b = bytes.clone();
                b[at] ^= 1 << bit;
                assert_ne!(checksum(&b), sum, "{at} {bit}");
            }
        }
        for n in 0..bytes.len() {
            assert_ne!(checksum(&bytes[..n]), sum, "a prefix of {n}");
        }
        let mut zeros = bytes.clone();
        zeros.push(0);
        assert_ne!(checksum(&zeros), sum, "a zero appended");
    }

    #[test]
    fn a_seal_matches_only_its_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("f");
        assert_eq!(sealed(&path, 10, 5), None);
        seal(&path, 10, 5).unwrap();
        assert_eq!(sealed(&path, 10, 5), Some(true));
        assert_eq!(sealed(&path, 11, 5), Some(false));
        assert_eq!(sealed(&path, 10, 6), Some(false));
    }
}
