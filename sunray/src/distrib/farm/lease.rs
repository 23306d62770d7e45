//! A farm controller's lease on its job: the job's record in REM, written at the epoch REM
//! gave the controller every [`LEASE_WRITE`]; REM restarts a controller that stops writing,
//! and refuses the writes of one whose epoch is past (it then stands down).

use super::FarmError;
use crate::distrib::controller::crew::Crew;
use crate::distrib::job_record;
use rem::RemClient;
use std::sync::atomic::{AtomicU32, Ordering};
use std::time::Duration;

/// How often the controller writes its record (REM's lease is several times longer).
pub const LEASE_WRITE: Duration = Duration::from_secs(1);

/// How often it looks whether the slots its workers hold changed (then it writes at once).
const LOOK: Duration = Duration::from_millis(100);

/// The job's record at this epoch, waiting briefly for the write of whoever started this
/// process; a newer epoch means this controller is not needed.
pub(super) async fn own_record(
    client: &RemClient,
    job: &str,
    epoch: u64,
) -> Result<rem::JobRecord, FarmError> {
    let deadline = tokio::time::Instant::now() + Duration::from_secs(5);
    loop {
        match job_record::find(client, job).await? {
            Some(r) if r.epoch > epoch => {
                return Err(FarmError::Superseded {
                    job: job.to_string(),
                    reason: format!(
                        "the job is at epoch {}, this controller's is {epoch}",
                        r.epoch
                    ),
                })
            }
            Some(mut r) if r.epoch == epoch || tokio::time::Instant::now() > deadline => {
                r.epoch = epoch;
                return Ok(r);
            }
            None if tokio::time::Instant::now() > deadline => {
                return Err(FarmError::NoRecord(job.to_string()))
            }
            _ => tokio::time::sleep(Duration::from_millis(100)).await,
        }
    }
}

/// Writes the record; a refusal for a newer epoch (or an ended job) is [`FarmError::Superseded`].
pub(super) async fn put_record(
    client: &RemClient,
    record: &rem::JobRecord,
    job: &str,
) -> Result<(), FarmError> {
    match client.put_job(record.clone()).await {
        Ok(_) => Ok(()),
        Err(e) if e.is_fenced() => Err(FarmError::Superseded {
            job: job.to_string(),
            reason: e.to_string(),
        }),
        Err(e) => Err(e.into()),
    }
}

/// Writes the record with the checkpoint's progress and the slots its workers hold every
/// [`LEASE_WRITE`], and as soon as those slots change (what the farm's queue and `sunray
/// jobs` show; a job holding none is `queued`); returns only when REM refuses it for a
/// newer epoch or an ended job (a cancel).
pub(super) async fn keep_lease(
    client: &RemClient,
    record: &mut rem::JobRecord,
    (checkpointed, crew): (&AtomicU32, &Crew),
    job: &str,
) -> FarmError {
    let mut written = tokio::time::Instant::now();
    loop {
        tokio::time::sleep(LOOK).await;
        let slots = crew.view().slots();
        if slots == record.slots && written.elapsed() < LEASE_WRITE {
            continue;
        }
        written = tokio::time::Instant::now();
        record.progress_done = u64::from(checkpointed.load(Ordering::Relaxed));
        record.slots = slots;
        record.state = if record.slots > 0 {
            "running"
        } else {
            "queued"
        }
        .into();
        // REM stores the record here before it sends the copy to a peer; a peer that hangs
        // (a host stopped) holds the answer up to REM's peer timeout, longer than a lease,
        // so the write is left after LEASE_WRITE and the next one renews the lease.
        match tokio::time::timeout(LEASE_WRITE, put_record(client, record, job)).await {
            Ok(Err(e @ FarmError::Superseded { .. })) => return e,
            // A daemon that does not answer now may later: the lease is REM's to judge.
            Ok(Err(e)) => eprintln!("sunray controller: warning: the job's record: {e}"),
            Ok(Ok(())) | Err(_) => {}
        }
    }
}
