//! The checksum of a prepared scene file and its seal.
//!
//! The checksum is the file's CRC-32 (crc32fast, the zip and PNG checksum, which the image
//! crate already builds; hardware-assisted, a few milliseconds over a mapped file of a
//! million triangles) with its length in the high 32 bits. A CRC catches every change of up to
//! 32 consecutive bits; it is no defence against a writer that means harm, only against
//! damage: a file cut short, bits changed on disk.
//!
//! The seal is a small file beside the prepared one (`NAME.seal`), written only after the
//! file was written, read back and checked in full; it holds the file's length and
//! checksum. A reader trusts a file whose seal is there and matches: its length and
//! checksum (and the cheap checks of its tables) are checked again, its contents not.

use std::path::{Path, PathBuf};

/// The checksum of `bytes` (see the module's text).
pub fn checksum(bytes: &[u8]) -> u64 {
    (bytes.len() as u64) << 32 | u64::from(crc32fast::hash(bytes))
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
