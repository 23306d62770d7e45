//! SunRay III jobs as REM keeps them: each job's record (REM's `JobRecord`: state, progress,
//! epoch, on two hosts, removed some time after the job ended) carries SunRay's own fields
//! (`JobEntry`: scene, hosts, output) as its application bytes. `sunray jobs` lists them
//! with no index of its own; a job's lines done count its checkpoint, which the controller
//! writes more often than the record.

use super::checkpoint::Store;
use super::messages::proto::{CheckpointHeader, JobEntry};
use prost::Message;

/// The longest title REM takes, in bytes.
pub const MAX_TITLE: usize = 200;

/// What a job is, for people (REM's `JobRecord.title`, shown by `remd --web`): the scene
/// file's name, not its path, and the image's size, as `mount6.nff 64x96`; a name too long
/// for [`MAX_TITLE`] is cut.
pub fn title(scene: &str, width: u32, height: u32) -> String {
    let name = std::path::Path::new(scene)
        .file_name()
        .map_or_else(|| scene.into(), |n| n.to_string_lossy());
    let size = format!(" {width}x{height}");
    let mut name = name.into_owned();
    while name.len() + size.len() > MAX_TITLE {
        name.pop();
    }
    name + &size
}

/// REM's record of `entry` at `epoch`, for an image `width` pixels wide (the entry holds the
/// height).
pub fn to_record(entry: &JobEntry, width: u32, epoch: u64) -> rem::JobRecord {
    let app = JobEntry {
        epoch: 0,
        controller_host: String::new(),
        message: String::new(),
        user: String::new(),
        priority: 0,
        slots: 0,
        ..entry.clone()
    };
    rem::JobRecord {
        id: entry.job.clone(),
        state: entry.state.clone(),
        epoch,
        created_unix_ms: entry.started_unix_ms,
        progress_done: entry.lines_done.into(),
        progress_total: entry.height.into(),
        app: app.encode_to_vec(),
        title: title(&entry.scene, width, entry.height),
        priority: entry.priority,
        slots: entry.slots,
        ..rem::JobRecord::default()
    }
}

/// The entry a record carries, with REM's state, progress and times (which are newer than
/// what the application bytes say).
pub fn from_record(r: &rem::JobRecord) -> JobEntry {
    let mut e = JobEntry::decode(r.app.as_slice()).unwrap_or_default();
    e.job = r.id.clone();
    e.state = r.state.clone();
    e.lines_done = u32::try_from(r.progress_done).unwrap_or(u32::MAX);
    e.height = u32::try_from(r.progress_total).unwrap_or(u32::MAX);
    e.started_unix_ms = r.created_unix_ms;
    e.updated_unix_ms = r.updated_unix_ms;
    e.epoch = r.epoch;
    e.controller_host = r.controller_host.clone();
    e.message = r.message.clone();
    e.user = r.user.clone();
    e.priority = r.priority;
    e.slots = r.slots;
    e
}

/// Stores the record of `entry` (an image `width` pixels wide) in REM at `epoch`.
pub async fn update(
    client: &rem::RemClient,
    entry: &JobEntry,
    width: u32,
    epoch: u64,
) -> Result<(), rem::Error> {
    client
        .put_job(to_record(entry, width, epoch))
        .await
        .map(|_| ())
}

/// The record of job `id`, if a live host holds one.
pub async fn find(client: &rem::RemClient, id: &str) -> Result<Option<rem::JobRecord>, rem::Error> {
    Ok(client.list_jobs().await?.into_iter().find(|r| r.id == id))
}

/// The epoch a job run from this terminal takes: one past its record's (a job resumed, or
/// an id used again), else 1.
pub async fn next_epoch(client: &rem::RemClient, id: &str) -> Result<u64, rem::Error> {
    Ok(find(client, id).await?.map_or(1, |r| r.epoch + 1))
}

/// Your jobs, oldest first; an unfinished job's lines done and last change are its
/// checkpoint's when those are newer.
pub async fn list(client: &rem::RemClient) -> Result<Vec<JobEntry>, rem::Error> {
    let mut jobs: Vec<JobEntry> = client.list_jobs().await?.iter().map(from_record).collect();
    // A finished job's record says every line; any other's may be behind its checkpoint
    // (the controller checkpoints more often than it writes the record, and one killed or
    // cancelled writes no last record).
    for e in jobs.iter_mut().filter(|e| e.state != "finished") {
        if let Some(h) = header(client, &e.job).await? {
            catch_up(e, &h);
        }
    }
    jobs.sort_by_key(|j| j.started_unix_ms);
    Ok(jobs)
}

/// A job's checkpoint header, if there is one that decodes (its segments are not read).
pub(crate) async fn header(
    store: &impl Store,
    job: &str,
) -> Result<Option<CheckpointHeader>, rem::Error> {
    Ok(store
        .get(job)
        .await?
        .and_then(|b| CheckpointHeader::decode(b.as_slice()).ok()))
}

/// Takes the checkpoint's progress when it is ahead of the record's.
fn catch_up(e: &mut JobEntry, h: &CheckpointHeader) {
    e.lines_done = e.lines_done.max(h.lines_done);
    e.updated_unix_ms = e.updated_unix_ms.max(h.updated_unix_ms);
}

/// How long a running job's record and checkpoint may go unwritten, with no live worker,
/// before the job counts as interrupted.
pub const STALE_MS: u64 = 15_000;

/// Records `interrupted` for each job that a record still calls running but that counts as
/// interrupted at `now_ms` ([`shown_state`] with no live worker): on the private daemon of the
/// default set-up, whose state outlives it, such a job's command ended without saying so
/// (killed, crashed) and nothing takes an in-process job over. A failure leaves the record as
/// it was (`sunray jobs` still shows it interrupted).
pub async fn close_abandoned(client: &rem::RemClient, now_ms: u64) {
    let Ok(records) = client.list_jobs().await else {
        return;
    };
    for mut r in records.into_iter().filter(|r| r.state == "running") {
        let mut e = from_record(&r);
        if let Ok(Some(h)) = header(client, &e.job).await {
            catch_up(&mut e, &h);
        }
        if shown_state(&e, 0, now_ms, STALE_MS) == "interrupted" {
            r.state = "interrupted".into();
            r.progress_done = r.progress_done.max(u64::from(e.lines_done));
            r.message = "its command ended before the job did".into();
            let _ = client.put_job(r).await;
        }
    }
}

/// A job's state as `sunray jobs` shows it: a job marked running whose controller has not
/// written for a while and has no live workers was interrupted.
pub fn shown_state(entry: &JobEntry, live_workers: usize, now_ms: u64, stale_ms: u64) -> String {
    let stale = now_ms.saturating_sub(entry.updated_unix_ms) > stale_ms;
    match entry.state.as_str() {
        "running" if stale && live_workers == 0 => "interrupted".to_string(),
        s => s.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn entry(job: &str, state: &str, started: u64) -> JobEntry {
        JobEntry {
            job: job.into(),
            state: state.into(),
            started_unix_ms: started,
            height: 64,
            scene: "mount6.nff".into(),
            hosts: 3,
            ..Default::default()
        }
    }

    #[test]
    fn an_entry_travels_in_a_record_and_the_checkpoint_counts_its_lines() {
        let mut e = entry("b", "running", 20);
        e.lines_done = 5;
        let mut r = to_record(&e, 48, 2);
        assert_eq!((r.progress_done, r.progress_total, r.epoch), (5, 64, 2));
        assert_eq!(r.title, "mount6.nff 48x64");
        r.updated_unix_ms = 1_000;
        let mut back = from_record(&r);
        assert_eq!(back.scene, "mount6.nff");
        assert_eq!((back.hosts, back.started_unix_ms), (3, 20));
        // The controller checkpointed 17 lines since it last wrote the record.
        let h = CheckpointHeader {
            lines_done: 17,
            updated_unix_ms: 5_000,
            ..Default::default()
        };
        catch_up(&mut back, &h);
        assert_eq!((back.lines_done, back.updated_unix_ms), (17, 5_000));
        // An older checkpoint does not move it back.
        catch_up(&mut back, &CheckpointHeader::default());
        assert_eq!((back.lines_done, back.updated_unix_ms), (17, 5_000));
        // Garbage application bytes still list the job, with REM's fields.
        r.app = vec![0xff; 3];
        assert_eq!(from_record(&r).job, "b");
    }

    #[test]
    fn a_title_names_the_scene_file_and_the_size_within_remds_limit() {
        assert_eq!(title("/home/u/spd/mount6.nff", 64, 96), "mount6.nff 64x96");
        assert_eq!(title("@example", 640, 480), "@example 640x480");
        let long = title(&format!("/x/{}.nff", "é".repeat(150)), 4096, 4096);
        assert!(
            long.len() <= MAX_TITLE && long.ends_with("é 4096x4096"),
            "{long}"
        );
    }

    #[test]
    fn a_stale_running_job_without_workers_is_interrupted() {
        let mut e = entry("a", "running", 0);
        e.updated_unix_ms = 1_000;
        assert_eq!(shown_state(&e, 0, 20_000, 10_000), "interrupted");
        assert_eq!(shown_state(&e, 2, 20_000, 10_000), "running");
        assert_eq!(shown_state(&e, 0, 5_000, 10_000), "running");
        e.state = "finished".into();
        assert_eq!(shown_state(&e, 0, 20_000, 10_000), "finished");
    }
}
