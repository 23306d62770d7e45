use super::*;
use crate::distrib::messages::proto::RenderSettings;
use crate::distrib::settled::SettledPixel;
use std::collections::HashMap;
use std::sync::Mutex;

mod compaction;

/// A store in memory with a small limit.
#[derive(Default)]
pub struct MemStore {
    pub map: Mutex<HashMap<String, Vec<u8>>>,
    pub limit: usize,
    pub puts: Mutex<usize>,
    /// Puts from this many on fail (as a store that went away would).
    pub fail_from: Mutex<Option<usize>>,
    /// The put of this number (counting from 0) is stored, yet answered with an error (as
    /// one whose answer was lost would be).
    pub answer_lost: Mutex<Option<usize>>,
    /// Gets so far.
    pub gets: Mutex<usize>,
}

impl Store for MemStore {
    async fn put(&self, key: &str, data: Vec<u8>) -> Result<(), rem::Error> {
        if data.len() > self.limit {
            return Err(rem::Error::TooLarge {
                size: data.len(),
                limit: self.limit,
            });
        }
        let mut puts = self.puts.lock().unwrap();
        if self.fail_from.lock().unwrap().is_some_and(|n| *puts >= n) {
            return Err(rem::Error::Closed);
        }
        let lost = *self.answer_lost.lock().unwrap() == Some(*puts);
        *puts += 1;
        self.map.lock().unwrap().insert(key.to_string(), data);
        if lost {
            return Err(rem::Error::Closed);
        }
        Ok(())
    }
    async fn get(&self, key: &str) -> Result<Option<Vec<u8>>, rem::Error> {
        *self.gets.lock().unwrap() += 1;
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
        ..Default::default()
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
        ..RenderSettings::default()
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
            c.record(line(y), true);
        }
        c.save(&store, "running").await.unwrap();
        // 3 lines of ~130 bytes fit one 400-byte segment.
        assert_eq!(*store.puts.lock().unwrap(), 2);
        for y in [0, 2, 5, 6, 7] {
            c.record(line(y), true);
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
        c2.record(line(8), true);
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
        c.record(line(0), true);
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
        c.record(line(0), true);
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
            c.record(l.clone(), true);
        }
        c.save(&store, "running").await.unwrap();
    });
    store
}

fn load_error(store: &MemStore) -> CheckpointError {
    rt().block_on(load(store, "j4")).unwrap_err()
}

/// Replaces the stored header of job j4 by what `change` makes of it.
fn rewrite_header(store: &MemStore, change: impl FnOnce(CheckpointHeader) -> CheckpointHeader) {
    let mut map = store.map.lock().unwrap();
    let header = CheckpointHeader::decode(map["j4"].as_slice()).unwrap();
    map.insert("j4".into(), change(header).encode_to_vec());
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

    // Lines rendered by a build of another image version: this one would finish the image
    // with other pixels.
    let newer = crate::render::image_version::IMAGE_VERSION + 1;
    let store = saved(
        JobSpec {
            settings: Some(RenderSettings {
                image_version: newer,
                ..settings(10, 16)
            }),
            ..spec()
        },
        &[line(0)],
    );
    let text = load_error(&store).to_string();
    assert!(
        text.contains(&format!("the job's pixels are image version {newer}")),
        "{text}"
    );
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
        ..Default::default()
    };
    let e = load_error(&saved(spec(), &[line(0), wide]));
    assert!(
        e.to_string().contains("132 bytes of pixels, not 120"),
        "{e}"
    );
    // A header naming more segments than the image has lines.
    let store = saved(spec(), &[line(0)]);
    rewrite_header(&store, |h| CheckpointHeader { segments: 17, ..h });
    let e = load_error(&store);
    assert!(matches!(e, CheckpointError::Inconsistent { .. }), "{e}");
    // The same lines under a matching header are read back.
    let ok = saved(spec(), &[line(0), line(15)]);
    let r = rt().block_on(load(&ok, "j4")).unwrap().unwrap();
    assert_eq!(r.lines.len(), 2);
}

/// With a target error a line is recorded after each pass: a load keeps each line's latest
/// pass, its counters summed over its passes, and counts as finished only the lines whose
/// last pass left every pixel done; estimates that are not the line's are refused.
#[test]
fn a_render_to_an_error_keeps_each_lines_latest_pass() {
    use crate::render::adaptive::{constant_pixel, PixelEstimate};
    use glam::DVec3;
    let a = Adaptive::new(0.01, Some(4), Some(64));
    let to_error = JobSpec {
        settings: Some(RenderSettings {
            target_error: a.target_error,
            min_samples: a.min_samples,
            max_samples: a.max_samples,
            ..settings(2, 16)
        }),
        ..spec()
    };
    let mut noisy = PixelEstimate::default();
    (0..4).for_each(|k| noisy.add(DVec3::splat(f64::from(k % 2))));
    let mut done = constant_pixel(DVec3::splat(0.25), &a);
    done.decide(false);
    let record = |y: u32, pass: u32, px: [PixelEstimate; 2], eye: u64| FinishedLine {
        line: y,
        pass,
        estimates: crate::distrib::messages::estimates_to_bytes(&px),
        counters: Some(crate::distrib::messages::proto::Counters {
            eye,
            line_s: 0.5,
            ..Default::default()
        }),
        ..Default::default()
    };
    let store = saved(
        to_error.clone(),
        &[
            record(3, 0, [noisy, done], 8),
            record(5, 0, [noisy, noisy], 8),
            record(3, 1, [done, done], 16),
        ],
    );
    let r = rt().block_on(load(&store, "j4")).unwrap().unwrap();
    assert_eq!(r.lines.len(), 2);
    assert_eq!(r.lines[&3].pass, 1);
    let c = r.lines[&3].counters.unwrap();
    assert_eq!((c.eye, c.line_s), (24, 1.0), "summed over its passes");
    assert!(r.is_finished(&r.lines[&3]) && !r.is_finished(&r.lines[&5]));
    assert_eq!(r.finished_lines(), 1);
    assert_eq!(r.estimates(&r.lines[&5]).unwrap(), vec![noisy, noisy]);
    let film = r.film(2, 16);
    assert_eq!((film.pixels[6], film.pixels[10]), ([0.25; 3], [0.5; 3]));
    assert!(r.samples_map().is_some());

    let short = FinishedLine {
        estimates: vec![0; 52],
        ..record(1, 0, [done, done], 1)
    };
    let e = load_error(&saved(to_error.clone(), &[short])).to_string();
    assert!(e.contains("line 1") && e.contains("52 bytes"), "{e}");
    let with_pixels = FinishedLine {
        pixels: vec![0; 24],
        ..record(1, 0, [done, done], 1)
    };
    let e = load_error(&saved(to_error.clone(), &[with_pixels])).to_string();
    assert!(e.contains("pixels and estimates"), "{e}");

    // A settled line: its pixels and what each took, finished, read for the film and map.
    let settled = |y: u32, samples: u32| FinishedLine {
        line: y,
        pass: 2,
        pixels: crate::distrib::messages::pixels_to_bytes(&[[0.75; 3], [0.125; 3]]),
        settled: crate::distrib::settled::to_bytes([SettledPixel::of(&done); 2].map(|p| {
            SettledPixel {
                summary: crate::render::PixelSummary {
                    samples,
                    ..p.summary
                },
                ..p
            }
        })),
        ..Default::default()
    };
    let r = rt()
        .block_on(load(
            &saved(
                to_error.clone(),
                &[record(3, 0, [noisy, done], 8), settled(3, 16)],
            ),
            "j4",
        ))
        .unwrap()
        .unwrap();
    assert!(r.is_finished(&r.lines[&3]) && r.estimates(&r.lines[&3]).is_none());
    assert_eq!(r.settled(&r.lines[&3]).unwrap()[1].summary.samples, 16);
    assert_eq!(r.film(2, 16).pixels[6..8], [[0.75; 3], [0.125; 3]]);
    let map = r.samples_map().unwrap();
    assert_ne!(map.pixels[6], map.pixels[0], "16 samples against none");
    for (bad, why) in [
        (
            FinishedLine {
                estimates: record(3, 0, [done, done], 1).estimates,
                ..settled(3, 16)
            },
            "settled and has estimates",
        ),
        (
            FinishedLine {
                pixels: vec![0; 12],
                ..settled(3, 16)
            },
            "12 bytes of pixels",
        ),
        (settled(3, 65), "65 samples, not 4 to 64"),
    ] {
        let e = load_error(&saved(to_error.clone(), &[bad])).to_string();
        assert!(e.contains("line 3") && e.contains(why), "{e}");
    }
}

/// Formats 1 and 2 (before a render to an error's estimates changed) are read for a job of
/// a fixed sample count, whose lines are what they were, and refused with a target error; a
/// format this program does not know is refused.
#[test]
fn formats_1_and_2_are_read_only_without_a_target_error() {
    let with_format = |spec: JobSpec, format: u32| {
        let store = saved(spec, &[line(0)]);
        rewrite_header(&store, |h| CheckpointHeader { format, ..h });
        store
    };
    for format in [1, 2] {
        let r = rt().block_on(load(&with_format(spec(), format), "j4"));
        assert_eq!(r.unwrap().unwrap().lines.len(), 1);
    }
    let to_error = JobSpec {
        settings: Some(RenderSettings {
            target_error: 0.01,
            min_samples: 16,
            max_samples: 64,
            ..settings(10, 16)
        }),
        ..spec()
    };
    for (s, format) in [(to_error.clone(), 1), (to_error, 2), (spec(), 6)] {
        let e = load_error(&with_format(s, format));
        assert!(
            matches!(e, CheckpointError::Format(f) if f == format),
            "{e}"
        );
    }
}
