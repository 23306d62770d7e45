//! The controller's checkpoint, kept through REM's checkpoint store (on more than one host):
//! what the job is ([`proto::JobSpec`]) and every finished line with its pixels, so a job
//! whose controller died continues where it was (`sunray submit --resume JOB`).
//!
//! Layout: key `JOB` holds a [`proto::CheckpointHeader`]; keys `JOB.s0`, `JOB.s1`, ... hold
//! [`proto::CheckpointSegment`]s, each with the lines finished since the one before (so a
//! save costs what is new, not the whole image) and each under the relay's message limit.
//! Segments are written before the header that names them, so a crash between the two
//! leaves a consistent, slightly older checkpoint. The header names the live segments,
//! `base` to `segments` ([`Checkpointer`] compacts a render to an error's: those before
//! `base` hold superseded records and are emptied).
//!
//! With a target error a line is recorded after each of its passes, with its pixels'
//! estimates (a resumed job goes on from the line's last pass exactly), and once every pixel
//! is done, settled ([`super::settled`]: its pixels and what each took); the latest record
//! of a line is what it has, and its counters are summed over its records.
//!
//! A checkpoint read back is not trusted: [`load`] refuses one whose render settings are
//! missing or out of bounds (`render::settings`), or whose segments and lines disagree with
//! them (a line beyond the image's height, pixels that are not the image's width, estimates
//! that are not the width's or hold more samples than the settings allow).

use super::messages::proto::{CheckpointHeader, CheckpointSegment, FinishedLine, JobSpec};
use super::messages::MessageError;
use super::settled::{self, SettledPixel};
use crate::film::Film;
use crate::render::adaptive::{self, max_passes, Adaptive, PixelEstimate};
use crate::render::{pass, PixelSummary, Settings};
use futures_util::StreamExt;
use prost::Message;
use std::collections::BTreeMap;
use std::future::Future;

/// The header format this code writes and reads. Format 5: a render to an error's finished
/// lines are settled (format 4's kept their estimates). Format 4: the live segments start
/// at the header's `base` (format 3's at 0). Format 3: a render to an error's pixel
/// estimates carry their stage (open, decided, raised: the neighbourhood's decision after
/// the first samples; [`PixelEstimate`], 149 bytes). Format 2's were 148 bytes and decided
/// alone, format 1's were four replicates' (100 bytes, other samples), so a format 1 or 2
/// checkpoint is read only when its job renders a fixed sample count, which the changes
/// left as it was.
pub const FORMAT: u32 = 5;

/// The first format whose estimates a render to an error reads.
const ESTIMATES_FORMAT: u32 = 3;

/// Where checkpoints are kept: REM, or a map in tests.
pub trait Store {
    /// Stores `data` under `key`, replacing what was there.
    fn put(&self, key: &str, data: Vec<u8>) -> impl Future<Output = Result<(), rem::Error>> + Send;
    /// The blob under `key`; `None` when there is none.
    fn get(&self, key: &str) -> impl Future<Output = Result<Option<Vec<u8>>, rem::Error>> + Send;
    /// The largest blob `put` accepts.
    fn max_bytes(&self) -> usize;
}

impl Store for rem::RemClient {
    async fn put(&self, key: &str, data: Vec<u8>) -> Result<(), rem::Error> {
        self.put_checkpoint(key, data).await.map(|_| ())
    }
    async fn get(&self, key: &str) -> Result<Option<Vec<u8>>, rem::Error> {
        self.get_checkpoint(key).await
    }
    fn max_bytes(&self) -> usize {
        self.options().max_message
    }
}

/// REM's store as the controller of epoch `epoch` of job `job` writes it: refused
/// ([`rem::Error::is_fenced`]) once a newer controller has the job.
pub struct Fenced<'a> {
    /// The connection to REM.
    pub client: &'a rem::RemClient,
    /// The writer's epoch.
    pub epoch: u64,
    /// The job the epoch belongs to.
    pub job: &'a str,
}

impl Store for Fenced<'_> {
    async fn put(&self, key: &str, data: Vec<u8>) -> Result<(), rem::Error> {
        self.client
            .put_checkpoint_fenced(key, data, self.epoch, self.job)
            .await
            .map(|_| ())
    }
    async fn get(&self, key: &str) -> Result<Option<Vec<u8>>, rem::Error> {
        self.client.get_checkpoint(key).await
    }
    fn max_bytes(&self) -> usize {
        self.client.options().max_message
    }
}

/// Why a checkpoint could not be written or read back.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum CheckpointError {
    /// REM's checkpoint store failed.
    #[error("checkpoint store: {0}")]
    Rem(#[from] rem::Error),
    /// A header or segment did not decode.
    #[error("checkpoint {key} is corrupt: {reason}")]
    Corrupt {
        /// The store key of the blob (`JOB` or `JOB.sN`).
        key: String,
        /// The decoder's error.
        reason: String,
    },
    /// The header names a segment that the store no longer holds.
    #[error("checkpoint of job {job} names segment {segment}, which no host holds")]
    MissingSegment {
        /// The job id.
        job: String,
        /// The missing segment's number (key `JOB.s{segment}`).
        segment: u32,
    },
    /// The header was written by a program with another [`FORMAT`] (or format 1 or 2 with a
    /// target error).
    #[error("checkpoint format {0} is not supported (this program reads formats 1 to {FORMAT}, 1 and 2 only without a target error)")]
    Format(u32),
    /// The header holds no render settings.
    #[error("checkpoint of job {job} holds no render settings")]
    NoSettings {
        /// The job id.
        job: String,
    },
    /// The header's render settings are out of bounds.
    #[error("checkpoint of job {job}: {source}")]
    Settings {
        /// The job id.
        job: String,
        /// What is out of bounds.
        source: MessageError,
    },
    /// A header or segment disagrees with the header's render settings.
    #[error("checkpoint {key} disagrees with its header: {reason}")]
    Inconsistent {
        /// The store key of the blob (`JOB` or `JOB.sN`).
        key: String,
        /// What disagrees, with the values.
        reason: String,
    },
    /// One finished line alone is larger than the store accepts.
    #[error("a finished line of {bytes} bytes does not fit the checkpoint limit of {limit}")]
    TooLarge {
        /// The line's encoded size.
        bytes: usize,
        /// The store's limit less room for framing.
        limit: usize,
    },
}

/// The store key of segment `segment` of `job`: `JOB.sN`.
pub(crate) fn segment_key(job: &str, segment: u32) -> String {
    format!("{job}.s{segment}")
}

/// A checkpoint read back.
#[derive(Clone, Debug)]
pub struct Restored {
    /// The job spec, model hash, segment count and state as last saved.
    pub header: CheckpointHeader,
    /// Lines in by line number (with a target error, each line's latest pass, its counters
    /// summed over its passes).
    pub lines: BTreeMap<u32, FinishedLine>,
    /// The job's target error, when it has one.
    pub adaptive: Option<Adaptive>,
}

impl Restored {
    /// The image's (width, height) in the checkpoint's settings.
    pub fn size(&self) -> (u32, u32) {
        self.header
            .spec
            .as_ref()
            .and_then(|s| s.settings.as_ref())
            .map(|s| (s.width, s.height))
            .unwrap_or_default()
    }

    /// A `width` x `height` image with the lines in painted (with a target error, as far
    /// as their passes went), the rest black ([`load`] has checked every line's pixels
    /// against the settings).
    pub fn film(&self, width: u32, height: u32) -> Film {
        let mut film = Film::new(width, height);
        for l in self.lines.values().filter(|l| l.line < height) {
            let px = match self.estimates(l) {
                Some(e) => Some(pass::line_pixels(&e)),
                // A fixed sample count's line, or a settled one.
                None => super::messages::pixels_from_bytes(&l.pixels, width).ok(),
            };
            if let Some(px) = px {
                film.set_line(l.line, &px);
            }
        }
        film
    }

    /// The estimates of a line recorded after a pass (`None` without a target error, or
    /// for a settled line).
    pub fn estimates(&self, l: &FinishedLine) -> Option<Vec<PixelEstimate>> {
        let a = self.adaptive.as_ref()?;
        if l.estimates.is_empty() {
            return None;
        }
        super::messages::estimates_from_bytes(&l.estimates, self.size().0, a).ok()
    }

    /// What each pixel of a settled line took (`None` without a target error, or for a line
    /// recorded with its estimates).
    pub fn settled(&self, l: &FinishedLine) -> Option<Vec<SettledPixel>> {
        let a = self.adaptive.as_ref()?;
        if l.settled.is_empty() {
            return None;
        }
        settled::from_bytes(&l.settled, self.size().0, a).ok()
    }

    /// What each pixel of a line took so far (`None` without a target error).
    fn summaries(&self, l: &FinishedLine) -> Option<Vec<PixelSummary>> {
        match self.settled(l) {
            Some(s) => Some(s.iter().map(|p| p.summary).collect()),
            None => Some(self.estimates(l)?.iter().map(|e| e.summary()).collect()),
        }
    }

    /// Whether a line recorded is finished: with a target error, whether it is settled or
    /// its last pass left every pixel done.
    pub fn is_finished(&self, l: &FinishedLine) -> bool {
        match (&self.adaptive, self.estimates(l)) {
            (Some(a), Some(e)) => pass::line_done(&e, a),
            // `load` checked the settled bytes.
            (Some(_), None) => !l.settled.is_empty(),
            (None, _) => true,
        }
    }

    /// With a target error, the heat map of the samples each pixel took (as far as its line's
    /// passes went), as `sunray render --samples-map` draws it.
    pub fn samples_map(&self) -> Option<Film> {
        let a = self.adaptive.as_ref()?;
        let (width, height) = self.size();
        let mut summaries = vec![PixelSummary::default(); width as usize * height as usize];
        for l in self.lines.values() {
            let row = l.line as usize * width as usize;
            if let (Some(took), Some(s)) = (
                self.summaries(l),
                summaries.get_mut(row..row + width as usize),
            ) {
                s.copy_from_slice(&took);
            }
        }
        Some(adaptive::samples_map(&summaries, a, width, height))
    }

    /// How many lines are finished.
    pub fn finished_lines(&self) -> u32 {
        self.lines.values().filter(|l| self.is_finished(l)).count() as u32
    }
}

/// How many of a checkpoint's segments [`load`] reads at once.
const SEGMENT_READS: usize = 8;

/// Reads the checkpoint of `job`; `None` when there is none.
pub async fn load(store: &impl Store, job: &str) -> Result<Option<Restored>, CheckpointError> {
    let Some(bytes) = store.get(job).await? else {
        return Ok(None);
    };
    let corrupt = |key: &str, e: prost::DecodeError| CheckpointError::Corrupt {
        key: key.to_string(),
        reason: e.to_string(),
    };
    let header = CheckpointHeader::decode(bytes.as_slice()).map_err(|e| corrupt(job, e))?;
    if !(1..=FORMAT).contains(&header.format) {
        return Err(CheckpointError::Format(header.format));
    }
    let settings = header_settings(job, &header)?;
    if header.format < ESTIMATES_FORMAT && settings.render.adaptive.is_some() {
        return Err(CheckpointError::Format(header.format));
    }
    let (width, height) = (settings.render.width, settings.render.height);
    let inconsistent = |key: &str, reason: String| CheckpointError::Inconsistent {
        key: key.to_string(),
        reason,
    };
    // Every segment holds at least one line, each line is finished once, and with a target
    // error recorded once per pass.
    let adaptive = settings.render.adaptive;
    // (A line's decision after its first samples is one more record.)
    let records = height.saturating_mul(adaptive.as_ref().map_or(1, |a| max_passes(a) + 1));
    if header.base > header.segments {
        return Err(inconsistent(
            job,
            format!("base = {} past segments = {}", header.base, header.segments),
        ));
    }
    for (what, n, most) in [
        ("segments", header.segments - header.base, records),
        ("lines_done", header.lines_done, height),
    ] {
        if n > most {
            return Err(inconsistent(
                job,
                format!("{what} = {n}, more than the image's {height} lines allow ({most})"),
            ));
        }
    }
    let line_bytes = width as usize * 12;
    let mut lines = BTreeMap::new();
    // The segments are read SEGMENT_READS at a time, in order: one round trip each, to a
    // replica that may be another host, is a fixed cost of every image fetched.
    let live = header.base..header.segments;
    let keys: Vec<String> = live.clone().map(|s| segment_key(job, s)).collect();
    let mut segments = futures_util::stream::iter(keys.into_iter().zip(live).map(
        |(key, s): (String, u32)| async move {
            let got = read_segment(store, job, s).await;
            (key, got)
        },
    ))
    .buffered(SEGMENT_READS);
    while let Some((key, got)) = segments.next().await {
        for l in got?.lines {
            if l.line >= height {
                return Err(inconsistent(
                    &key,
                    format!("line {} of an image of {height} lines", l.line),
                ));
            }
            if let Some(a) = &adaptive {
                check_adaptive_line(&l, width, a)
                    .map_err(|why| inconsistent(&key, format!("line {}: {why}", l.line)))?;
            } else if l.pixels.len() != line_bytes {
                return Err(inconsistent(
                    &key,
                    format!(
                        "line {} has {} bytes of pixels, not {line_bytes} ({width} pixels)",
                        l.line,
                        l.pixels.len()
                    ),
                ));
            }
            keep_latest(&mut lines, l);
        }
    }
    Ok(Some(Restored {
        header,
        lines,
        adaptive,
    }))
}

/// Checks a line of a render to the error `a`: its estimates (and no pixels), or settled
/// (its pixels and what each took, and no estimates).
fn check_adaptive_line(l: &FinishedLine, width: u32, a: &Adaptive) -> Result<(), String> {
    if l.settled.is_empty() {
        super::messages::estimates_from_bytes(&l.estimates, width, a).map_err(|e| e.to_string())?;
        if !l.pixels.is_empty() {
            return Err("it has pixels and estimates".into());
        }
        return Ok(());
    }
    if !l.estimates.is_empty() {
        return Err("it is settled and has estimates".into());
    }
    super::messages::pixels_from_bytes(&l.pixels, width).map_err(|e| e.to_string())?;
    settled::from_bytes(&l.settled, width, a).map_err(|e| e.to_string())?;
    Ok(())
}

/// Segment `segment` of job `job`'s checkpoint, decoded (what it holds is checked by its
/// reader).
pub(crate) async fn read_segment(
    store: &impl Store,
    job: &str,
    segment: u32,
) -> Result<CheckpointSegment, CheckpointError> {
    let key = segment_key(job, segment);
    let bytes = store
        .get(&key)
        .await?
        .ok_or_else(|| CheckpointError::MissingSegment {
            job: job.to_string(),
            segment,
        })?;
    CheckpointSegment::decode(bytes.as_slice()).map_err(|e| CheckpointError::Corrupt {
        key,
        reason: e.to_string(),
    })
}

/// Keeps the latest record of a line (its highest pass; the last one written of equal
/// passes), its counters summed over the line's records.
pub(crate) fn keep_latest(lines: &mut BTreeMap<u32, FinishedLine>, mut l: FinishedLine) {
    let Some(old) = lines.get_mut(&l.line) else {
        lines.insert(l.line, l);
        return;
    };
    let counters = latest_records::summed(&old.counters, &l.counters);
    if l.pass >= old.pass {
        l.counters = Some(counters);
        *old = l;
    } else {
        old.counters = Some(counters);
    }
}

/// The render settings of a checkpoint's header, checked against their bounds.
fn header_settings(job: &str, header: &CheckpointHeader) -> Result<Settings, CheckpointError> {
    let p = header
        .spec
        .as_ref()
        .and_then(|s| s.settings.as_ref())
        .ok_or_else(|| CheckpointError::NoSettings {
            job: job.to_string(),
        })?;
    Settings::from_proto(p).map_err(|source| CheckpointError::Settings {
        job: job.to_string(),
        source,
    })
}

/// Milliseconds since the Unix epoch.
pub fn unix_ms() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_millis() as u64)
}

mod latest_records;
#[cfg(test)]
pub(crate) mod tests;
mod writer;
pub use writer::{Checkpointer, SLACK};
