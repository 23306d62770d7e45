//! Which peer keeps the second copy of a stored key (a checkpoint or a job record):
//! rendezvous hashing. Every host ranks the peers by a hash of (key, peer name) and tries
//! them in that order, so a key's copies stay on the same two hosts while they live (no
//! stale copies scattered over the cluster), keys spread evenly, and anyone who knows the
//! membership knows where a key is kept.

/// FNV-1a, 64 bits: stable across builds and platforms (unlike the standard hasher).
fn fnv1a(parts: &[&[u8]]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for part in parts {
        for &b in *part {
            h ^= u64::from(b);
            h = h.wrapping_mul(0x0000_0100_0000_01b3);
        }
        // A separator, so ("ab", "c") and ("a", "bc") differ.
        h ^= 0xff;
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

/// The weight of `host` for `key`: the highest wins. FNV-1a mixes its last bytes poorly,
/// so the result goes through splitmix64's finaliser.
pub fn weight(key: &str, host: &str) -> u64 {
    let mut z = fnv1a(&[key.as_bytes(), host.as_bytes()]);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// `hosts` in the order a writer tries them for `key`'s replica (ties by name).
pub fn order<'a>(key: &str, hosts: impl IntoIterator<Item = &'a str>) -> Vec<&'a str> {
    let mut v: Vec<&str> = hosts.into_iter().collect();
    v.sort_by(|a, b| weight(key, b).cmp(&weight(key, a)).then_with(|| a.cmp(b)));
    v
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_key_keeps_its_peer_and_keys_spread() {
        let hosts = ["a", "b", "c", "d"];
        let first = order("job-1", hosts)[0];
        // The order does not depend on how the hosts are listed, or on who is missing
        // (other than the host itself).
        assert_eq!(order("job-1", ["d", "c", "b", "a"])[0], first);
        let without: Vec<&str> = hosts
            .iter()
            .copied()
            .filter(|h| *h != "d" || first == "d")
            .collect();
        assert_eq!(order("job-1", without)[0], first);
        let mut counts = std::collections::HashMap::new();
        for i in 0..400 {
            *counts
                .entry(order(&format!("job-{i}"), hosts)[0])
                .or_insert(0) += 1;
        }
        assert_eq!(counts.len(), 4, "{counts:?}");
        assert!(counts.values().all(|&n| n > 60), "{counts:?}");
    }
}
