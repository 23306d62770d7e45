//! The farm's queue: every user's active jobs with the slots the [rule](crate::daemon::shares)
//! gives them, computed here from the replicated job records and the live hosts' slots.

use super::Daemon;
use crate::daemon::shares::{self, Demand};
use crate::error::Result;
use crate::store::job_store;
use crate::wire::proto::{HostInfo, JobRecord, QueueEntry, QueueReply};

impl Daemon {
    /// The active jobs, oldest first, with their shares and places in the queue.
    pub async fn queue(&self) -> Result<QueueReply> {
        let records = self.job_records(None).await?;
        let hosts = self.membership.hosts();
        Ok(queue_of(records, &hosts, self.limits.user_slots))
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
