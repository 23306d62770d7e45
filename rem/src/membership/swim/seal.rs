//! Sealed datagrams: every membership datagram carries the sender's boot id, a sequence
//! number and its clock, and ends with an HMAC-SHA256 tag (16 bytes) under a key derived from
//! the cluster secret. A datagram is believed only if its tag is right, its clock is within
//! [`MAX_SKEW_MS`] of ours, and its (boot id, sequence) was not seen before (a sliding window
//! of 64 per sender, as IPsec's anti-replay), so a host without the secret can neither
//! join, nor accuse a member, nor be believed about load, and a captured datagram cannot be
//! replayed.
//!
//! ```text
//! "RS1" | boot id u64 | seq u64 | unix ms u64 | payload | tag[16] = HMAC(key, all before)
//! ```

use std::collections::HashMap;

use hmac::{Mac, SimpleHmac};
use sha2::Sha256;

/// Bytes a seal adds to a payload.
pub const OVERHEAD: usize = MAGIC.len() + 24 + TAG;
/// Largest clock difference believed between two members (their clocks are NTP's).
pub const MAX_SKEW_MS: u64 = 30_000;
/// Senders whose sequence windows are kept at most (the oldest goes first).
pub const MAX_SENDERS: usize = 8192;

const MAGIC: &[u8; 3] = b"RS1";
const TAG: usize = 16;
const WINDOW: u64 = 64;

type HmacSha256 = SimpleHmac<Sha256>;

/// Why a datagram was not believed.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum Rejected {
    /// Too short, or not ours.
    #[error("not a sealed membership datagram")]
    Malformed,
    /// Sealed with another secret, or altered.
    #[error("wrong tag (another cluster's secret, or forged)")]
    Tag,
    /// Its sender's clock (ms) differs from ours by more than [`MAX_SKEW_MS`].
    #[error("its clock is {0} ms from ours (at most {MAX_SKEW_MS})")]
    Clock(i64),
    /// Seen before, or too far behind its sender's newest.
    #[error("replayed")]
    Replay,
    /// Sealed by a newer membership protocol ("RS2" and on): its sender runs a newer remd.
    #[error("sealed as RS{0}, a newer membership protocol than this daemon's RS1")]
    Newer(u8),
}

struct Window {
    highest: u64,
    seen: u64,
    last_ms: u64,
}

/// Seals this member's datagrams and opens others'.
pub struct Sealer {
    key: [u8; 32],
    boot: u64,
    seq: u64,
    windows: HashMap<u64, Window>,
}

impl Sealer {
    /// `secret` is the cluster secret; `boot` is random at every start.
    pub fn new(secret: &[u8], boot: u64) -> Sealer {
        Sealer {
            key: crate::auth::identity::derive(secret, b"rem membership datagram v1"),
            boot,
            seq: 0,
            windows: HashMap::new(),
        }
    }

    fn mac(&self) -> HmacSha256 {
        <HmacSha256 as Mac>::new_from_slice(&self.key)
            .unwrap_or_else(|_| unreachable!("HMAC accepts keys of every length"))
    }

    /// `payload` sealed at `now_ms`.
    pub fn seal(&mut self, payload: &[u8], now_ms: u64) -> Vec<u8> {
        self.seq += 1;
        let mut out = Vec::with_capacity(payload.len() + OVERHEAD);
        out.extend_from_slice(MAGIC);
        out.extend_from_slice(&self.boot.to_be_bytes());
        out.extend_from_slice(&self.seq.to_be_bytes());
        out.extend_from_slice(&now_ms.to_be_bytes());
        out.extend_from_slice(payload);
        let mut mac = self.mac();
        mac.update(&out);
        out.extend_from_slice(&mac.finalize().into_bytes()[..TAG]);
        out
    }

    /// The payload of `datagram`, if it is believed at `now_ms`.
    pub fn open<'a>(&mut self, datagram: &'a [u8], now_ms: u64) -> Result<&'a [u8], Rejected> {
        if datagram.len() < OVERHEAD || !datagram.starts_with(MAGIC) {
            return Err(match datagram {
                [b'R', b'S', n @ b'2'..=b'9', ..] => Rejected::Newer(n - b'0'),
                _ => Rejected::Malformed,
            });
        }
        let (body, tag) = datagram.split_at(datagram.len() - TAG);
        let mut mac = self.mac();
        mac.update(body);
        mac.verify_truncated_left(tag).map_err(|_| Rejected::Tag)?;
        let word = |i: usize| {
            let at = MAGIC.len() + 8 * i;
            u64::from_be_bytes(body[at..at + 8].try_into().unwrap_or_default())
        };
        let (boot, seq, sent_ms) = (word(0), word(1), word(2));
        let skew = sent_ms as i64 - now_ms as i64;
        if skew.unsigned_abs() > MAX_SKEW_MS {
            return Err(Rejected::Clock(skew));
        }
        self.accept(boot, seq, now_ms)?;
        Ok(&body[MAGIC.len() + 24..])
    }

    /// Marks (boot, seq) seen; refuses one seen before or older than the window.
    fn accept(&mut self, boot: u64, seq: u64, now_ms: u64) -> Result<(), Rejected> {
        if !self.windows.contains_key(&boot) && self.windows.len() >= MAX_SENDERS {
            self.forget_oldest(now_ms);
        }
        let w = self.windows.entry(boot).or_insert(Window {
            highest: 0,
            seen: 0,
            last_ms: now_ms,
        });
        if seq > w.highest {
            let shift = seq - w.highest;
            w.seen = if shift >= WINDOW { 0 } else { w.seen << shift };
            w.seen |= 1;
            w.highest = seq;
        } else {
            let back = w.highest - seq;
            if back >= WINDOW || w.seen & (1 << back) != 0 {
                return Err(Rejected::Replay);
            }
            w.seen |= 1 << back;
        }
        w.last_ms = now_ms;
        Ok(())
    }

    /// Drops windows idle for longer than the clock bound (their datagrams are refused by
    /// the clock now), else the least recently used one.
    fn forget_oldest(&mut self, now_ms: u64) {
        let before = self.windows.len();
        self.windows
            .retain(|_, w| now_ms.saturating_sub(w.last_ms) <= 2 * MAX_SKEW_MS);
        if self.windows.len() == before {
            if let Some(oldest) = self
                .windows
                .iter()
                .min_by_key(|(_, w)| w.last_ms)
                .map(|(b, _)| *b)
            {
                self.windows.remove(&oldest);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_the_secrets_holders_datagrams_are_believed_and_once() {
        let mut a = Sealer::new(b"secret", 1);
        let mut b = Sealer::new(b"secret", 2);
        let mut other = Sealer::new(b"another cluster", 3);
        let d = a.seal(b"ping", 1_000_000);
        assert_eq!(b.open(&d, 1_000_010), Ok(&b"ping"[..]));
        assert_eq!(b.open(&d, 1_000_020), Err(Rejected::Replay));
        assert_eq!(
            b.open(&other.seal(b"ping", 1_000_000), 1_000_000),
            Err(Rejected::Tag)
        );
        let mut newer = a.seal(b"ping", 1_000_000);
        newer[2] = b'2';
        assert_eq!(b.open(&newer, 1_000_000), Err(Rejected::Newer(2)));
        assert_eq!(b.open(b"RSx", 1_000_000), Err(Rejected::Malformed));
        let mut flipped = a.seal(b"down", 1_000_000);
        flipped[30] ^= 1;
        assert_eq!(b.open(&flipped, 1_000_000), Err(Rejected::Tag));
        assert_eq!(b.open(b"RS1", 0), Err(Rejected::Malformed));
        assert_eq!(b.open(&[0u8; 100], 0), Err(Rejected::Malformed));
        let late = a.seal(b"old", 1_000_000);
        assert_eq!(
            b.open(&late, 1_000_000 + MAX_SKEW_MS + 1),
            Err(Rejected::Clock(-(MAX_SKEW_MS as i64) - 1))
        );
    }

    #[test]
    fn out_of_order_datagrams_within_the_window_pass_once() {
        let mut a = Sealer::new(b"s", 1);
        let mut b = Sealer::new(b"s", 2);
        let ds: Vec<_> = (0..100).map(|_| a.seal(b"x", 5)).collect();
        // Sequence numbers 6, 4, 5, 71, 11 (60 behind 71), 100.
        for i in [5, 3, 4, 70, 10, 99] {
            assert!(b.open(&ds[i], 5).is_ok(), "{i}");
        }
        // 64 or more behind the highest (100) is refused, seen or not.
        assert_eq!(b.open(&ds[20], 5), Err(Rejected::Replay));
        assert_eq!(b.open(&ds[99], 5), Err(Rejected::Replay), "seen");
        assert!(b.open(&ds[98], 5).is_ok(), "within the window, unseen");
    }

    #[test]
    fn the_sender_table_is_bounded() {
        let mut b = Sealer::new(b"s", 0);
        for boot in 1..=(MAX_SENDERS as u64 + 10) {
            let mut a = Sealer::new(b"s", boot);
            assert!(b.open(&a.seal(b"x", 7), 7).is_ok());
        }
        assert!(b.windows.len() <= MAX_SENDERS);
    }
}
