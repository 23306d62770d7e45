//! The farm's queue: every user's active jobs with the slots the [rule](crate::daemon::shares)
//! gives them, computed here from the replicated job records and the live hosts' slots.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use super::Daemon;
use crate::daemon::shares::{self, Demand};
use crate::error::Result;
use crate::store::job_store;
use crate::wire::proto::{HostInfo, JobRecord, QueueEntry, QueueReply};

impl Daemon {
    /// The active jobs, oldest first, with their shares and places in the queue: computed
    /// again at most every [`QUEUE_FRESH`] (every job's controller asks every 200 ms, and
    /// each answer asks every live daemon for its records).
    pub async fn queue(&self) -> Result<QueueReply> {
        let now = Instant::now();
        if let Some(q) = self.queue_memo.fresh(now) {
            return Ok(q);
        }
        let seen = self.queue_memo.changes();
        let records = self.job_records(None).await?;
        let hosts = self.membership.hosts();
        let q = queue_of(records, &hosts, self.limits.user_slots);
        self.queue_memo.keep(now, seen, q.clone());
        Ok(q)
    }
}

/// How long a computed queue is answered again.
pub const QUEUE_FRESH: Duration = Duration::from_millis(150);

/// The queue last computed here, and when; and how many times a record changed here.
#[derive(Debug, Default)]
pub struct QueueMemo(Mutex<Option<(Instant, QueueReply)>>, AtomicU64);

impl QueueMemo {
    /// The queue computed less than [`QUEUE_FRESH`] before `now`, if any.
    fn fresh(&self, now: Instant) -> Option<QueueReply> {
        let kept = self.0.lock().unwrap_or_else(|e| e.into_inner());
        kept.as_ref()
            .filter(|(at, _)| now.saturating_duration_since(*at) < QUEUE_FRESH)
            .map(|(_, q)| q.clone())
    }

    /// Forgets the queue kept (a job record changed).
    pub(crate) fn forget(&self) {
        let mut kept = self.0.lock().unwrap_or_else(|e| e.into_inner());
        self.1.fetch_add(1, Ordering::Relaxed);
        *kept = None;
    }

    /// The records changed here so far (a queue read before a change is not kept after it).
    fn changes(&self) -> u64 {
        self.1.load(Ordering::Relaxed)
    }

    /// Keeps `q`, computed from what was read at `at`, unless a record changed here since
    /// it was read (`seen`: [`QueueMemo::changes`] then).
    fn keep(&self, at: Instant, seen: u64, q: QueueReply) {
        let mut kept = self.0.lock().unwrap_or_else(|e| e.into_inner());
        if self.changes() == seen {
            *kept = Some((at, q));
        }
    }
}

/// The queue of `records` (every user's; the ended are left out, the rest listed oldest
/// first) on a farm of `hosts` (the live, accepting ones lend their slots), no user holding
/// more than `user_slots`.
pub(crate) fn queue_of(
    mut records: Vec<JobRecord>,
    hosts: &[HostInfo],
    user_slots: Option<u32>,
) -> QueueReply {
    records.retain(|r| !job_store::is_ended(&r.state));
    records.sort_by(|a, b| (a.created_unix_ms, &a.id).cmp(&(b.created_unix_ms, &b.id)));
    let slots: u32 = hosts
        .iter()
        .filter(|h| h.alive && h.accepting)
        .filter_map(|h| h.load)
        .map(|l| l.slots)
        .fold(0, u32::saturating_add);
    let demands: Vec<Demand> = records
        .iter()
        .map(|r| Demand {
            id: r.id.clone(),
            user: r.user.clone(),
            priority: r.priority,
            created_unix_ms: r.created_unix_ms,
            wanted: r.slots_wanted,
            min: 1,
        })
        .collect();
    let given = shares::shares(slots, user_slots, &demands);
    let jobs = records
        .into_iter()
        .zip(given)
        .map(|(r, s)| QueueEntry {
            id: r.id,
            user: r.user,
            state: r.state,
            priority: r.priority,
            created_unix_ms: r.created_unix_ms,
            slots: r.slots,
            slots_wanted: r.slots_wanted,
            share: s.slots,
            queue_position: s.queue_position,
            title: r.title,
        })
        .collect();
    QueueReply {
        jobs,
        slots,
        user_slots: user_slots.unwrap_or(0),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_queue_is_answered_again_while_fresh() {
        let memo = QueueMemo::default();
        let t0 = Instant::now();
        assert_eq!(memo.fresh(t0), None);
        let q = QueueReply {
            slots: 6,
            ..QueueReply::default()
        };
        memo.keep(t0, memo.changes(), q.clone());
        assert_eq!(memo.fresh(t0 + Duration::from_millis(100)), Some(q));
        assert_eq!(memo.fresh(t0 + QUEUE_FRESH), None, "stale: computed again");
        memo.keep(t0, memo.changes(), QueueReply::default());
        memo.forget();
        assert_eq!(memo.fresh(t0), None, "a record changed here");
        // A queue read before a change is not kept after it.
        let seen = memo.changes();
        memo.forget();
        memo.keep(t0, seen, QueueReply::default());
        assert_eq!(memo.fresh(t0), None);
    }
}
