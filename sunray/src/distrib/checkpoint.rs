//! The controller's checkpoint, kept through REM's checkpoint store (on more than one host):
//! what the job is ([`proto::JobSpec`]) and every finished line with its pixels, so a job
//! whose controller died continues where it was (`sunray submit --resume JOB`).
//!
//! Layout: key `JOB` holds a [`proto::CheckpointHeader`]; keys `JOB.s0`, `JOB.s1`, ... hold
//! [`proto::CheckpointSegment`]s, each with the lines finished since the one before (so a
//! save costs what is new, not the whole image) and each under the relay's message limit.
//! Segments are written before the header that names them, so a crash between the two
//! leaves a consistent, slightly older checkpoint.
//!
//! A checkpoint read back is not trusted: [`load`] refuses one whose render settings are
//! missing or out of bounds (`render::settings`), or whose segments and lines disagree with
//! them (a line beyond the image's height, pixels that are not the image's width).

use super::messages::proto::{CheckpointHeader, CheckpointSegment, FinishedLine, JobSpec};
use super::messages::MessageError;
use crate::film::Film;
use crate::render::Settings;
use prost::Message;
use std::collections::BTreeMap;
use std::future::Future;

/// The header format this code writes and reads.
pub const FORMAT: u32 = 1;

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
    /// The header was written by a program with another [`FORMAT`].
    #[error("checkpoint format {0} is not supported (this program reads format {FORMAT})")]
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
    /// Finished lines by line number.
    pub lines: BTreeMap<u32, FinishedLine>,
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

    /// A `width` x `height` image with the lines in painted, the rest black ([`load`] has
    /// checked every line's pixels against the settings).
    pub fn film(&self, width: u32, height: u32) -> Film {
        let mut film = Film::new(width, height);
        for l in self.lines.values().filter(|l| l.line < height) {
            if let Ok(px) = super::messages::pixels_from_bytes(&l.pixels, width) {
                film.set_line(l.line, &px);
            }
        }
        film
    }
}

/// Writes a job's checkpoint incrementally.
#[derive(Debug)]
pub struct Checkpointer {
    job: String,
    spec: JobSpec,
    model_hash: u64,
    segments: u32,
    lines_done: u32,
    pending: Vec<FinishedLine>,
}

impl Checkpointer {
    /// A checkpointer for `job`; a resumed job continues the segments it had.
    pub fn new(job: &str, spec: JobSpec, model_hash: u64, resumed: Option<&Restored>) -> Self {
        Checkpointer {
            job: job.to_string(),
            spec,
            model_hash,
            segments: resumed.map_or(0, |r| r.header.segments),
            lines_done: resumed.map_or(0, |r| r.lines.len() as u32),
            pending: Vec::new(),
        }
    }

    /// Notes a finished line (stored by the next [`Checkpointer::save`]).
    pub fn record(&mut self, line: FinishedLine) {
        self.pending.push(line);
        self.lines_done += 1;
    }

    /// True when lines were recorded since the last save.
    pub fn has_pending(&self) -> bool {
        !self.pending.is_empty()
    }

    /// Lines in the checkpoint after the next save.
    pub fn lines_done(&self) -> u32 {
        self.lines_done
    }

    /// Stores the new lines as segments, then the header with `state`.
    pub async fn save(&mut self, store: &impl Store, state: &str) -> Result<(), CheckpointError> {
        let limit = store.max_bytes().saturating_sub(1024).max(1);
        while !self.pending.is_empty() {
            let mut bytes = 0;
            let mut n = 0;
            for l in &self.pending {
                let len = l.encoded_len() + 8;
                if len > limit {
                    return Err(CheckpointError::TooLarge { bytes: len, limit });
                }
                if bytes + len > limit {
                    break;
                }
                bytes += len;
                n += 1;
            }
            let segment = CheckpointSegment {
                lines: self.pending[..n].to_vec(),
            };
            store
                .put(
                    &segment_key(&self.job, self.segments),
                    segment.encode_to_vec(),
                )
                .await?;
            self.segments += 1;
            self.pending.drain(..n);
        }
        let header = CheckpointHeader {
            format: FORMAT,
            job: self.job.clone(),
            spec: Some(self.spec.clone()),
            model_hash: self.model_hash,
            segments: self.segments,
            lines_done: self.lines_done,
            state: state.to_string(),
            updated_unix_ms: unix_ms(),
        };
        store.put(&self.job, header.encode_to_vec()).await?;
        Ok(())
    }
}

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
    if header.format != FORMAT {
        return Err(CheckpointError::Format(header.format));
    }
    let settings = header_settings(job, &header)?;
    let (width, height) = (settings.render.width, settings.render.height);
    let inconsistent = |key: &str, reason: String| CheckpointError::Inconsistent {
        key: key.to_string(),
        reason,
    };
    // Every segment holds at least one line, and each line is finished once.
    for (what, n) in [
        ("segments", header.segments),
        ("lines_done", header.lines_done),
    ] {
        if n > height {
            return Err(inconsistent(
                job,
                format!("{what} = {n}, more than the image's {height} lines"),
            ));
        }
    }
    let line_bytes = width as usize * 12;
    let mut lines = BTreeMap::new();
    for s in 0..header.segments {
        let key = segment_key(job, s);
        let bytes = store
            .get(&key)
            .await?
            .ok_or_else(|| CheckpointError::MissingSegment {
                job: job.to_string(),
                segment: s,
            })?;
        let seg = CheckpointSegment::decode(bytes.as_slice()).map_err(|e| corrupt(&key, e))?;
        for l in seg.lines {
            if l.line >= height {
                return Err(inconsistent(
                    &key,
                    format!("line {} of an image of {height} lines", l.line),
                ));
            }
            if l.pixels.len() != line_bytes {
                return Err(inconsistent(
                    &key,
                    format!(
                        "line {} has {} bytes of pixels, not {line_bytes} ({width} pixels)",
                        l.line,
                        l.pixels.len()
                    ),
                ));
            }
            lines.insert(l.line, l);
        }
    }
    Ok(Some(Restored { header, lines }))
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

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::distrib::messages::proto::RenderSettings;
    use std::collections::HashMap;
    use std::sync::Mutex;

    /// A store in memory with a small limit.
    #[derive(Default)]
    pub struct MemStore {
        pub map: Mutex<HashMap<String, Vec<u8>>>,
        pub limit: usize,
        pub puts: Mutex<usize>,
    }

    impl Store for MemStore {
        async fn put(&self, key: &str, data: Vec<u8>) -> Result<(), rem::Error> {
            if data.len() > self.limit {
                return Err(rem::Error::TooLarge {
                    size: data.len(),
                    limit: self.limit,
                });
            }
            *self.puts.lock().unwrap() += 1;
            self.map.lock().unwrap().insert(key.to_string(), data);
            Ok(())
        }
        async fn get(&self, key: &str) -> Result<Option<Vec<u8>>, rem::Error> {
            Ok(self.map.lock().unwrap().get(key).cloned())
        }
        fn max_bytes(&self) -> usize {
            self.limit
        }
    }

    fn line(y: u32) -> FinishedLine {
        FinishedLine {
            line: y,
            pixels: vec![y as u8; 120],
            counters: None,
        }
    }

    /// Render settings of a `width` x `height` image (what a header carries).
    fn settings(width: u32, height: u32) -> RenderSettings {
        RenderSettings {
            width,
            height,
            samples: 1,
            max_depth: 5,
            min_weight: 0.001,
            accel: "auto".into(),
            max_per_voxel: 10,
            octree_max_depth: 8,
            mailbox: true,
            spawn_all: false,
        }
    }

    /// The spec of a 10 x 16 image: `line` writes 10 pixels (120 bytes).
    fn spec() -> JobSpec {
        JobSpec {
            scene: "/scenes/a.yari".into(),
            settings: Some(settings(10, 16)),
            hosts: 3,
            strategy: "dynamic".into(),
            ..Default::default()
        }
    }

    fn rt() -> tokio::runtime::Runtime {
        tokio::runtime::Builder::new_current_thread()
            .build()
            .unwrap()
    }

    #[test]
    fn saves_incrementally_and_restores_every_line() {
        rt().block_on(async {
            let store = MemStore {
                limit: 1024 + 400,
                ..Default::default()
            };
            assert!(load(&store, "j1").await.unwrap().is_none());
            let mut c = Checkpointer::new("j1", spec(), 77, None);
            for y in [3, 1, 4] {
                c.record(line(y));
            }
            c.save(&store, "running").await.unwrap();
            // 3 lines of ~130 bytes fit one 400-byte segment.
            assert_eq!(*store.puts.lock().unwrap(), 2);
            for y in [0, 2, 5, 6, 7] {
                c.record(line(y));
            }
            c.save(&store, "running").await.unwrap();
            let r = load(&store, "j1").await.unwrap().unwrap();
            assert_eq!(r.header.lines_done, 8);
            assert!(r.header.segments >= 3, "split under the limit");
            assert_eq!(r.header.model_hash, 77);
            assert_eq!(r.header.spec.as_ref().unwrap().hosts, 3);
            assert_eq!(
                r.lines.keys().copied().collect::<Vec<_>>(),
                (0..8).collect::<Vec<_>>()
            );
            assert_eq!(r.lines[&5].pixels, vec![5u8; 120]);

            // A resumed job continues the segment numbering.
            let mut c2 = Checkpointer::new("j1", spec(), 77, Some(&r));
            c2.record(line(8));
            c2.save(&store, "finished").await.unwrap();
            let r2 = load(&store, "j1").await.unwrap().unwrap();
            assert_eq!(r2.lines.len(), 9);
            assert_eq!(r2.header.state, "finished");
        });
    }

    #[test]
    fn a_missing_or_corrupt_segment_is_an_error() {
        rt().block_on(async {
            let store = MemStore {
                limit: 1 << 20,
                ..Default::default()
            };
            let mut c = Checkpointer::new("j2", spec(), 1, None);
            c.record(line(0));
            c.save(&store, "running").await.unwrap();
            store
                .map
                .lock()
                .unwrap()
                .insert(segment_key("j2", 0), vec![0xff, 0xff]);
            assert!(matches!(
                load(&store, "j2").await,
                Err(CheckpointError::Corrupt { .. })
            ));
            store.map.lock().unwrap().remove(&segment_key("j2", 0));
            assert!(matches!(
                load(&store, "j2").await,
                Err(CheckpointError::MissingSegment { segment: 0, .. })
            ));
        });
    }

    #[test]
    fn a_line_larger_than_the_limit_is_refused() {
        rt().block_on(async {
            let store = MemStore {
                limit: 1024 + 50,
                ..Default::default()
            };
            let mut c = Checkpointer::new("j3", spec(), 1, None);
            c.record(line(0));
            assert!(matches!(
                c.save(&store, "running").await,
                Err(CheckpointError::TooLarge { .. })
            ));
        });
    }

    /// Saves `lines` under `job` with header spec `spec`, in a fresh store.
    fn saved(spec: JobSpec, lines: &[FinishedLine]) -> MemStore {
        let store = MemStore {
            limit: 1 << 20,
            ..Default::default()
        };
        rt().block_on(async {
            let mut c = Checkpointer::new("j4", spec, 1, None);
            for l in lines {
                c.record(l.clone());
            }
            c.save(&store, "running").await.unwrap();
        });
        store
    }

    fn load_error(store: &MemStore) -> CheckpointError {
        rt().block_on(load(store, "j4")).unwrap_err()
    }

    #[test]
    fn a_header_without_settings_or_out_of_bounds_is_refused() {
        let none = saved(
            JobSpec {
                settings: None,
                ..spec()
            },
            &[line(0)],
        );
        let e = load_error(&none);
        assert!(matches!(e, CheckpointError::NoSettings { .. }), "{e}");

        for (bad, field) in [
            (settings(u32::MAX, 16), "width"),
            (settings(10, 0), "height"),
            (
                RenderSettings {
                    max_depth: 1_000_000_000,
                    ..settings(10, 16)
                },
                "max_depth",
            ),
            (
                RenderSettings {
                    min_weight: -1.0,
                    ..settings(10, 16)
                },
                "min_weight",
            ),
        ] {
            let store = saved(
                JobSpec {
                    settings: Some(bad),
                    ..spec()
                },
                &[line(0)],
            );
            let e = load_error(&store);
            assert!(matches!(e, CheckpointError::Settings { .. }), "{e}");
            let text = e.to_string();
            assert!(text.contains(field) && !text.contains('\n'), "{text}");
        }
    }

    #[test]
    fn lines_that_disagree_with_the_header_are_refused() {
        // A line beyond the image's 16 lines.
        let e = load_error(&saved(spec(), &[line(0), line(16)]));
        assert!(
            e.to_string().contains("line 16 of an image of 16 lines"),
            "{e}"
        );
        // A line of 11 pixels in an image 10 wide.
        let wide = FinishedLine {
            line: 2,
            pixels: vec![0; 132],
            counters: None,
        };
        let e = load_error(&saved(spec(), &[line(0), wide]));
        assert!(
            e.to_string().contains("132 bytes of pixels, not 120"),
            "{e}"
        );
        // A header naming more segments than the image has lines.
        let store = saved(spec(), &[line(0)]);
        let header = CheckpointHeader {
            segments: 17,
            ..CheckpointHeader::decode(store.map.lock().unwrap()["j4"].as_slice()).unwrap()
        };
        store
            .map
            .lock()
            .unwrap()
            .insert("j4".into(), header.encode_to_vec());
        let e = load_error(&store);
        assert!(matches!(e, CheckpointError::Inconsistent { .. }), "{e}");
        // The same lines under a matching header are read back.
        let ok = saved(spec(), &[line(0), line(15)]);
        let r = rt().block_on(load(&ok, "j4")).unwrap().unwrap();
        assert_eq!(r.lines.len(), 2);
    }
}
