//! Writes a job's checkpoint incrementally: the lines in since the last save as new
//! segments, then the header that names them.
//!
//! With a target error a line is recorded after each of its passes. Lines recorded again
//! before a save are written once (the latest record, its counters summed over the records
//! it replaces, as [`load`] sums them), so what waits for a save is bounded by the image.
//! Every record written stays in its segment after a later one supersedes it: a 1024 x
//! 1024 job at E = 0.04 wrote 60 segments of 16.6 MB, a gigabyte, and REM's checkpoint quota
//! (1 GiB a host) refused the rest of its saves and, until its retention, every other job's.
//! So such a checkpoint is compacted: when the live segments hold more than twice what each
//! line's latest record takes (and [`SLACK`] more), they are read back one at a time, each
//! line's latest record kept (its counters summed), written as new segments after the live
//! ones, then the header that makes them the live ones (`base`), and only then are the old
//! ones emptied. A crash or an error at any point leaves a consistent checkpoint: the old
//! one until the header is written, the new one after (old segments not yet emptied are then
//! never read, and REM's retention removes them with the job). Only the records the writer
//! does not hold are read back ([`LatestRecords`]): a finished line's record is held (21
//! bytes a pixel), an open line's estimates are not (the controller holds them between their
//! passes already, and a second copy of the image's estimates for the rare compaction would
//! double that), and only the segments that hold an open line's latest record are read.

use super::latest_records::LatestRecords;
use super::{
    keep_latest, read_segment, segment_key, unix_ms, CheckpointError, CheckpointHeader,
    CheckpointSegment, FinishedLine, JobSpec, Restored, Store, FORMAT,
};
use prost::Message;
use std::collections::BTreeMap;
use std::ops::Range;

/// Superseded records are let grow to this many bytes beyond the latest ones before a
/// compaction (so a small job is never rewritten).
pub const SLACK: u64 = 8 << 20;

/// Writes a job's checkpoint incrementally.
#[derive(Debug)]
pub struct Checkpointer {
    job: String,
    spec: JobSpec,
    model_hash: u64,
    /// The first live segment: those before it are emptied (or about to be).
    base: u32,
    /// One past the last segment written.
    segments: u32,
    lines_done: u32,
    /// Lines in since the last save, each line's latest record (counters summed).
    pending: BTreeMap<u32, FinishedLine>,
    /// With a target error: each line's latest record, where it lies, its counters.
    latest: LatestRecords,
    /// Bytes of the live segments.
    written: u64,
    /// Compact once the superseded records pass twice the latest ones and this ([`SLACK`]);
    /// `None` (tests): once a record is superseded.
    slack: Option<u64>,
    /// Segments a compaction superseded, emptied once a header naming the new `base` is
    /// stored (not before: a header put that failed may or may not have been stored).
    stale: Option<Range<u32>>,
}

impl Checkpointer {
    /// A checkpointer for `job`; a resumed job continues the segments it had.
    pub fn new(job: &str, spec: JobSpec, model_hash: u64, resumed: Option<&Restored>) -> Self {
        let latest = resumed
            .filter(|r| r.adaptive.is_some())
            .map(LatestRecords::restored)
            .unwrap_or_default();
        Checkpointer {
            job: job.to_string(),
            spec,
            model_hash,
            base: resumed.map_or(0, |r| r.header.base),
            segments: resumed.map_or(0, |r| r.header.segments),
            lines_done: resumed.map_or(0, Restored::finished_lines),
            pending: BTreeMap::new(),
            written: latest.live_bytes(),
            latest,
            slack: Some(SLACK),
            stale: None,
        }
    }

    /// The same, compacting once the superseded records pass `slack` bytes beyond twice the
    /// latest ones, or with `None` at every save that finds a record superseded (tests:
    /// [`SLACK`] is megabytes).
    pub fn with_slack(self, slack: Option<u64>) -> Self {
        Checkpointer { slack, ..self }
    }

    /// Notes a line in (stored by the next [`Checkpointer::save`]): `finished`, or with a
    /// target error a pass after which the line needs another.
    pub fn record(&mut self, line: FinishedLine, finished: bool) {
        if !line.estimates.is_empty() || !line.settled.is_empty() {
            self.latest.record(&line);
        }
        keep_latest(&mut self.pending, line);
        self.lines_done += u32::from(finished);
    }

    /// Notes lines in as [`Checkpointer::record`] does, `finished` of them finished.
    pub fn record_lines(&mut self, lines: BTreeMap<u32, FinishedLine>, finished: u32) {
        for l in lines.into_values() {
            self.record(l, false);
        }
        self.lines_done += finished;
    }

    /// True when lines were recorded since the last save.
    pub fn has_pending(&self) -> bool {
        !self.pending.is_empty()
    }

    /// Lines in the checkpoint after the next save.
    pub fn lines_done(&self) -> u32 {
        self.lines_done
    }

    /// Stores the new lines as segments, then the header with `state`; then compacts when
    /// the superseded records have grown past the latest ones (see the module's text). Lines
    /// not stored (an error) stay for the next save.
    pub async fn save(&mut self, store: &impl Store, state: &str) -> Result<(), CheckpointError> {
        let mut pending = std::mem::take(&mut self.pending);
        let mut placed = Vec::new();
        let written = self.write_segments(store, &mut pending, &mut placed).await;
        // What was stored is live, whether or not the rest was.
        self.latest.placed(placed);
        // What was not written waits for the next save, before anything recorded meanwhile.
        for (_, l) in std::mem::replace(&mut self.pending, pending) {
            keep_latest(&mut self.pending, l);
        }
        self.written += written?;
        self.write_header(store, state).await?;
        self.empty_stale(store).await;
        let live = self.latest.live_bytes();
        let due = match self.slack {
            Some(slack) => live.saturating_mul(2).saturating_add(slack),
            None => live,
        };
        if live > 0 && self.written > due {
            if let Err(e) = self.compact(store, state).await {
                tracing::warn!(job = %self.job, "compacting the checkpoint: {e}");
            }
        }
        Ok(())
    }

    /// Rewrites the live segments' latest records as new segments, names them in the
    /// header, then empties the old ones. On an error writing the new segments the header
    /// still names the old ones, and the next segments written take the place of any new
    /// ones. From then on the new ones are live: a header that failed to be stored (or was
    /// stored, its answer lost) names them at the next save, and the old ones are emptied
    /// only once one is stored. (Going back to the old ones on that error, as before, wrote
    /// the next lines over new segments a stored header named.)
    async fn compact(&mut self, store: &impl Store, state: &str) -> Result<(), CheckpointError> {
        let (old_base, old_end) = (self.base, self.segments);
        let mut read = BTreeMap::new();
        for s in self.latest.to_read(old_base..old_end) {
            let segment = read_segment(store, &self.job, s).await?;
            self.latest.keep_read(s, segment.lines, &mut read);
        }
        let mut lines = self
            .latest
            .compacted(read)
            .ok_or_else(|| CheckpointError::Corrupt {
                key: self.job.clone(),
                reason: "a line's latest record is not where it was written".into(),
            })?;
        let mut placed = Vec::new();
        let written = self.write_segments(store, &mut lines, &mut placed).await;
        let Ok(written) = written else {
            self.segments = old_end;
            return written.map(|_| ());
        };
        self.latest.placed(placed);
        self.base = old_end;
        self.written = written;
        let below = self
            .stale
            .take()
            .map_or(old_base, |r| r.start.min(old_base));
        self.stale = Some(below..old_end);
        self.write_header(store, state).await?;
        self.empty_stale(store).await;
        Ok(())
    }

    /// Empties the segments a stored header no longer names (emptied, not removed: REM has
    /// no removal; the file shrinks to its envelope). One that fails stays for the next save.
    async fn empty_stale(&mut self, store: &impl Store) {
        let Some(stale) = self.stale.take() else {
            return;
        };
        for s in stale.clone() {
            if let Err(e) = store.put(&segment_key(&self.job, s), Vec::new()).await {
                tracing::warn!(job = %self.job, "emptying an old checkpoint segment: {e}");
                self.stale = Some(s..stale.end);
                return;
            }
        }
    }

    /// Writes `lines` as segments from `self.segments` on, each under the store's limit,
    /// taking out each line once its segment is stored (and noting it in `placed`: line,
    /// pass, segment); returns the bytes written.
    async fn write_segments(
        &mut self,
        store: &impl Store,
        lines: &mut BTreeMap<u32, FinishedLine>,
        placed: &mut Vec<(u32, u32, u32)>,
    ) -> Result<u64, CheckpointError> {
        let limit = store.max_bytes().saturating_sub(1024).max(1);
        let mut written = 0;
        while !lines.is_empty() {
            let mut bytes = 0;
            let mut take = Vec::new();
            for l in lines.values() {
                let len = l.encoded_len() + 8;
                if len > limit {
                    return Err(CheckpointError::TooLarge { bytes: len, limit });
                }
                if bytes + len > limit {
                    break;
                }
                bytes += len;
                take.push(l.line);
            }
            let segment = CheckpointSegment {
                lines: take.iter().filter_map(|y| lines.remove(y)).collect(),
            };
            let bytes = segment.encode_to_vec();
            let len = bytes.len() as u64;
            if let Err(e) = store
                .put(&segment_key(&self.job, self.segments), bytes)
                .await
            {
                // Not stored: the lines stay for the next try.
                lines.extend(segment.lines.into_iter().map(|l| (l.line, l)));
                return Err(e.into());
            }
            written += len;
            placed.extend(
                segment
                    .lines
                    .iter()
                    .map(|l| (l.line, l.pass, self.segments)),
            );
            self.segments += 1;
        }
        Ok(written)
    }

    async fn write_header(&self, store: &impl Store, state: &str) -> Result<(), CheckpointError> {
        let header = CheckpointHeader {
            format: FORMAT,
            job: self.job.clone(),
            spec: Some(self.spec.clone()),
            model_hash: self.model_hash,
            segments: self.segments,
            lines_done: self.lines_done,
            state: state.to_string(),
            updated_unix_ms: unix_ms(),
            base: self.base,
        };
        store.put(&self.job, header.encode_to_vec()).await?;
        Ok(())
    }
}
