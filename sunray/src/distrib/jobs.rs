//! The job index for `sunray jobs`: REM keeps checkpoints by key but cannot list them, so
//! controllers also keep a small index under the key `sunray-jobs` (one per REM user, as every
//! checkpoint is; read, change, write; the newest write wins if two controllers race, which
//! loses at most a state change).

use super::checkpoint::{unix_ms, Store};
use super::messages::proto::{JobEntry, JobIndex};
use prost::Message;

/// The checkpoint key of the index.
pub const INDEX_KEY: &str = "sunray-jobs";
/// Entries kept (the oldest are dropped).
pub const KEEP: usize = 200;

/// The index, empty when there is none or it cannot be decoded.
pub async fn read_index(store: &impl Store) -> Result<JobIndex, rem::Error> {
    Ok(store
        .get(INDEX_KEY)
        .await?
        .and_then(|b| JobIndex::decode(b.as_slice()).ok())
        .unwrap_or_default())
}

/// Inserts or replaces the entry of `entry.job`, stamping it with the time.
pub async fn update(store: &impl Store, mut entry: JobEntry) -> Result<(), rem::Error> {
    let mut index = read_index(store).await?;
    entry.updated_unix_ms = unix_ms();
    match index.jobs.iter_mut().find(|j| j.job == entry.job) {
        Some(j) => {
            if entry.started_unix_ms == 0 {
                entry.started_unix_ms = j.started_unix_ms;
            }
            *j = entry;
        }
        None => index.jobs.push(entry),
    }
    index.jobs.sort_by_key(|j| j.started_unix_ms);
    let excess = index.jobs.len().saturating_sub(KEEP);
    index.jobs.drain(..excess);
    store.put(INDEX_KEY, index.encode_to_vec()).await
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
    use super::super::checkpoint::tests::MemStore;
    use super::*;

    fn entry(job: &str, state: &str, started: u64) -> JobEntry {
        JobEntry {
            job: job.into(),
            state: state.into(),
            started_unix_ms: started,
            height: 64,
            ..Default::default()
        }
    }

    #[test]
    fn entries_are_inserted_replaced_and_kept_in_start_order() {
        let rt = tokio::runtime::Builder::new_current_thread()
            .build()
            .unwrap();
        rt.block_on(async {
            let store = MemStore {
                limit: 1 << 20,
                ..Default::default()
            };
            assert!(read_index(&store).await.unwrap().jobs.is_empty());
            update(&store, entry("b", "running", 20)).await.unwrap();
            update(&store, entry("a", "running", 10)).await.unwrap();
            let mut done = entry("b", "finished", 0);
            done.lines_done = 64;
            update(&store, done).await.unwrap();
            let jobs = read_index(&store).await.unwrap().jobs;
            assert_eq!(
                jobs.iter().map(|j| j.job.as_str()).collect::<Vec<_>>(),
                vec!["a", "b"]
            );
            assert_eq!(jobs[1].state, "finished");
            assert_eq!(jobs[1].started_unix_ms, 20, "the start time is kept");
            assert!(jobs[1].updated_unix_ms > 0);
        });
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
