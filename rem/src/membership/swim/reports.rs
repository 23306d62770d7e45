//! Load reports, piggybacked: every member adds its own report (load figures, whether it
//! accepts work) as a foca custom broadcast once a [`super::SwimConfig::report_every`], with
//! a sequence number; foca carries it on the pings, acks and gossip it sends anyway, and a
//! newer report of a member replaces an older one still being spread. The table keeps the
//! newest report of each member and when it was made (the sender's clock), so a reader
//! knows its age.

use std::collections::HashMap;
use std::sync::{Arc, Mutex};

use foca::{BroadcastHandler, Invalidates};
use prost::Message;
use serde::{Deserialize, Serialize};

use super::member::MemberId;
use crate::wire::proto::Load;
use crate::wire::protocol::{ProtocolNotices, PROTOCOL};

/// Members whose reports are kept at most.
pub const MAX_REPORTS: usize = 16_384;
/// Largest encoded load figures believed.
const MAX_LOAD_BYTES: usize = 512;

/// One member's report as sent.
#[derive(Clone, Debug, Serialize, Deserialize)]
struct Item {
    name: String,
    seq: u64,
    sent_ms: u64,
    accepting: bool,
    load: Vec<u8>,
}

/// A member's newest report.
#[derive(Clone, Debug, PartialEq)]
pub struct Report {
    /// Its sender's count of reports.
    pub seq: u64,
    /// When its sender made it (its clock, unix ms).
    pub sent_ms: u64,
    /// Whether the member takes new work.
    pub accepting: bool,
    /// Its load figures.
    pub load: Load,
}

/// The newest report of every member heard of.
#[derive(Debug)]
pub struct ReportTable {
    reports: HashMap<String, Report>,
    /// Items that did not decode or were out of bounds.
    pub refused: u64,
    /// Says once when a member announces a protocol other than this daemon's.
    pub notices: ProtocolNotices,
}

impl Default for ReportTable {
    fn default() -> ReportTable {
        ReportTable {
            reports: HashMap::new(),
            refused: 0,
            notices: ProtocolNotices::new(PROTOCOL),
        }
    }
}

impl ReportTable {
    /// Member `name`'s newest report.
    pub fn get(&self, name: &str) -> Option<&Report> {
        self.reports.get(name)
    }

    /// Forgets member `name`'s report.
    pub fn remove(&mut self, name: &str) {
        self.reports.remove(name);
    }
}

/// Which report an item is, for foca to drop older ones of the same member.
#[derive(Debug)]
pub struct ReportKey {
    name: String,
    seq: u64,
    /// A hash of the name: foca compares a new key with every key it is spreading, so the
    /// comparison must be cheap (a thousand members' reports).
    name_hash: u64,
}

impl ReportKey {
    fn new(name: String, seq: u64) -> ReportKey {
        use std::hash::{Hash, Hasher};
        let mut h = std::hash::DefaultHasher::new();
        name.hash(&mut h);
        ReportKey {
            name_hash: h.finish(),
            name,
            seq,
        }
    }
}

impl Invalidates for ReportKey {
    fn invalidates(&self, other: &Self) -> bool {
        self.name_hash == other.name_hash && self.seq > other.seq && self.name == other.name
    }
}

/// foca's handler of custom broadcasts: keeps what is new in the shared table.
#[derive(Clone, Debug, Default)]
pub struct LoadReports {
    /// The table, shared with whoever reads the reports.
    pub table: Arc<Mutex<ReportTable>>,
}

/// Never returned: an item that is not believed is dropped alone, not the datagram.
#[derive(Debug, thiserror::Error)]
#[error("load report")]
pub struct ReportError;

impl LoadReports {
    /// This member's report, encoded for [`foca::Foca::add_broadcast`].
    pub fn encode(name: &str, seq: u64, sent_ms: u64, accepting: bool, load: &Load) -> Vec<u8> {
        let item = Item {
            name: name.to_string(),
            seq,
            sent_ms,
            accepting,
            load: load.encode_to_vec(),
        };
        postcard::to_stdvec(&item).unwrap_or_default()
    }

    fn table(&self) -> std::sync::MutexGuard<'_, ReportTable> {
        self.table.lock().unwrap_or_else(|e| e.into_inner())
    }
}

impl BroadcastHandler<MemberId> for LoadReports {
    type Key = ReportKey;
    type Error = ReportError;

    fn receive_item(
        &mut self,
        data: &[u8],
        _sender: Option<&MemberId>,
    ) -> Result<Option<ReportKey>, ReportError> {
        let mut table = self.table();
        let item = match postcard::from_bytes::<Item>(data) {
            Ok(i) if crate::wire::ids::is_valid_name(&i.name) && i.load.len() <= MAX_LOAD_BYTES => {
                i
            }
            _ => {
                table.refused += 1;
                return Ok(None);
            }
        };
        let Ok(load) = Load::decode(item.load.as_slice()) else {
            table.refused += 1;
            return Ok(None);
        };
        let known = table.reports.get(&item.name).map(|r| r.seq);
        if known.is_some_and(|k| k >= item.seq) {
            return Ok(None);
        }
        if known.is_none() && table.reports.len() >= MAX_REPORTS {
            return Ok(None);
        }
        if let Some(line) = table.notices.notice(&item.name, load.protocol) {
            tracing::warn!("{line}");
        }
        table.reports.insert(
            item.name.clone(),
            Report {
                seq: item.seq,
                sent_ms: item.sent_ms,
                accepting: item.accepting,
                load,
            },
        );
        Ok(Some(ReportKey::new(item.name, item.seq)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn load(cores: u32) -> Load {
        Load {
            cores,
            ..Load::default()
        }
    }

    #[test]
    fn newer_reports_replace_older_and_bad_items_are_dropped_alone() {
        let mut h = LoadReports::default();
        let r1 = LoadReports::encode("a", 1, 100, true, &load(2));
        let r2 = LoadReports::encode("a", 2, 200, false, &load(4));
        assert!(h.receive_item(&r2, None).unwrap().is_some());
        assert!(h.receive_item(&r1, None).unwrap().is_none(), "older");
        assert!(h.receive_item(&r2, None).unwrap().is_none(), "known");
        let got = h.table().get("a").cloned().unwrap();
        assert_eq!((got.seq, got.sent_ms, got.accepting), (2, 200, false));
        assert_eq!(got.load.cores, 4);
        assert!(h.receive_item(b"\xff\xff\xff", None).unwrap().is_none());
        let newer = Load {
            protocol: PROTOCOL + 1,
            ..load(1)
        };
        let r3 = LoadReports::encode("a", 3, 300, true, &newer);
        assert!(
            h.receive_item(&r3, None).unwrap().is_some(),
            "a newer peer is heard"
        );
        assert_eq!(h.table().get("a").unwrap().load.protocol, PROTOCOL + 1);
        let bad = LoadReports::encode("../x", 1, 1, true, &load(1));
        assert!(h.receive_item(&bad, None).unwrap().is_none());
        assert_eq!(h.table().refused, 2);
        let k2 = ReportKey::new("a".into(), 2);
        let k1 = ReportKey::new("a".into(), 1);
        assert!(k2.invalidates(&k1) && !k1.invalidates(&k2));
        assert!(
            !ReportKey::new("b".into(), 3).invalidates(&k1),
            "another member's"
        );
    }
}
