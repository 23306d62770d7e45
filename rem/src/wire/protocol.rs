//! Which REM protocol a daemon speaks, and what it says of a peer that speaks another.
//!
//! A farm is upgraded one host at a time (docs/cluster.md, "Upgrading a farm"), so for a
//! while daemons of two versions work together. Every daemon announces its protocol number
//! in the load report it gossips ([`crate::wire::proto::Load`]'s `protocol`); a report
//! without it comes from a daemon older than the announcement (protocol 1). The rules that let two protocols work together:
//!
//! - messages only gain fields (protobuf: an older daemon skips what it does not know, a
//!   newer one reads a missing field as its default);
//! - a newer daemon calls a method an older peer lacks only after checking the peer's
//!   announced protocol (an older daemon answers an unknown method `Unimplemented`);
//! - the membership datagram's seal ("RS1") changes its number when its layout changes, and
//!   a daemon that receives a newer seal says so and drops the datagram.
//!
//! A daemon logs one warning the first time it hears a peer of another protocol (newer: this
//! daemon is the one to upgrade; older: that peer is), never more for the same peer and
//! protocol, and never stops for it.

use std::collections::HashSet;

/// The protocol this build speaks. 1: every daemon before protocols were announced.
/// 2: the load report announces the protocol.
pub const PROTOCOL: u32 = 2;
/// Peers (name, protocol) whose difference was logged, at most.
const MAX_NOTICED: usize = 4096;

/// The protocol a peer announced in its load report: 1 when it announced none.
pub fn announced(protocol: u32) -> u32 {
    protocol.max(1)
}

/// Says once per peer and protocol how a peer's protocol differs from this daemon's.
#[derive(Debug)]
pub struct ProtocolNotices {
    ours: u32,
    noticed: HashSet<(String, u32)>,
}

impl ProtocolNotices {
    /// For a daemon announcing `ours`.
    pub fn new(ours: u32) -> ProtocolNotices {
        ProtocolNotices {
            ours,
            noticed: HashSet::new(),
        }
    }

    /// The protocol this daemon announces.
    pub fn ours(&self) -> u32 {
        self.ours
    }

    /// The line to log the first time peer `name` is heard announcing `protocol`, if it
    /// differs from ours.
    pub fn notice(&mut self, name: &str, protocol: u32) -> Option<String> {
        let theirs = announced(protocol);
        if theirs == self.ours || self.noticed.len() >= MAX_NOTICED {
            return None;
        }
        if !self.noticed.insert((name.to_string(), theirs)) {
            return None;
        }
        Some(if theirs > self.ours {
            format!(
                "peer {name} speaks REM protocol {theirs}, newer than this \
                     daemon's {}: the two work together on what protocol {} has; upgrade \
                     this daemon too",
                self.ours, self.ours
            )
        } else {
            format!(
                "peer {name} speaks REM protocol {theirs}, older than this \
                     daemon's {}: the two work together on what protocol {theirs} has until \
                     that peer is upgraded",
                self.ours
            )
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_peer_of_another_protocol_is_noticed_once_and_ours_never() {
        let mut n = ProtocolNotices::new(2);
        assert!(n.notice("a", 2).is_none(), "the same protocol");
        let line = n.notice("b", 3).unwrap();
        assert!(
            line.contains("peer b speaks REM protocol 3, newer than this daemon's 2"),
            "{line}"
        );
        assert!(n.notice("b", 3).is_none(), "once");
        let line = n.notice("c", 0).unwrap();
        assert!(
            line.contains("peer c speaks REM protocol 1, older than this daemon's 2"),
            "{line}"
        );
        assert!(n.notice("b", 4).is_some(), "b upgraded again");
    }

    #[test]
    fn what_is_noticed_is_bounded() {
        let mut n = ProtocolNotices::new(2);
        for i in 0..MAX_NOTICED + 10 {
            n.notice(&format!("h{i}"), 3);
        }
        assert_eq!(n.noticed.len(), MAX_NOTICED);
        assert!(n.notice("late", 3).is_none());
    }
}
