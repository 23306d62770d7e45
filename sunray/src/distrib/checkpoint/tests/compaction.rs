//! A render to an error's checkpoint, recorded pass after pass: lines recorded twice before
//! a save are written once, superseded records are compacted away, and what [`load`] reads
//! is the same as without either (each line's latest pass, its counters summed).

use super::*;
use crate::distrib::messages::proto::Counters as Wire;
use crate::render::adaptive::PixelEstimate;
use glam::DVec3;

const JOB: &str = "jc";
const HEIGHT: u32 = 16;

fn adaptive_spec() -> JobSpec {
    JobSpec {
        settings: Some(RenderSettings {
            target_error: 0.01,
            min_samples: 4,
            max_samples: 64,
            ..settings(2, HEIGHT)
        }),
        ..spec()
    }
}

/// Line `y` after pass `pass`: two pixels of `4 + pass` samples, one eye ray and half a
/// second counted (sums stay exact).
fn record(y: u32, pass: u32) -> FinishedLine {
    let mut e = PixelEstimate::default();
    for k in 0..4 + pass {
        e.add(DVec3::splat(f64::from((k + y) % 3)));
    }
    FinishedLine {
        line: y,
        pass,
        estimates: crate::distrib::messages::estimates_to_bytes(&[e, e]),
        counters: Some(Wire {
            eye: 1,
            line_s: 0.5,
            ..Default::default()
        }),
        ..Default::default()
    }
}

fn store() -> MemStore {
    MemStore {
        limit: 1024 + 2000,
        ..Default::default()
    }
}

/// Bytes the store holds for the job.
fn held(store: &MemStore) -> usize {
    let map = store.map.lock().unwrap();
    map.iter()
        .filter(|(k, _)| k.starts_with(JOB))
        .map(|(_, v)| v.len())
        .sum()
}

/// Passes 0..passes of every line, each pass saved (and line 3 recorded twice in pass 0).
async fn passes(c: &mut Checkpointer, store: &MemStore, passes: std::ops::Range<u32>) {
    for pass in passes {
        for y in 0..HEIGHT {
            c.record(record(y, pass), false);
        }
        if pass == 0 {
            c.record(record(3, 0), false);
        }
        c.save(store, "running").await.unwrap();
    }
}

#[test]
fn a_render_to_an_errors_passes_are_compacted_to_the_latest() {
    rt().block_on(async {
        let (plain, compacted) = (store(), store());
        let mut c = Checkpointer::new(JOB, adaptive_spec(), 1, None).with_slack(Some(u64::MAX / 4));
        passes(&mut c, &plain, 0..8).await;
        let mut c = Checkpointer::new(JOB, adaptive_spec(), 1, None).with_slack(Some(0));
        passes(&mut c, &compacted, 0..8).await;

        let (p, k) = (
            load(&plain, JOB).await.unwrap().unwrap(),
            load(&compacted, JOB).await.unwrap().unwrap(),
        );
        assert_eq!(
            p.lines, k.lines,
            "the same lines, passes and summed counters"
        );
        assert_eq!(p.lines[&5].pass, 7);
        let c5 = p.lines[&5].counters.unwrap();
        assert_eq!((c5.eye, c5.line_s), (8, 4.0));
        let c3 = k.lines[&3].counters.unwrap();
        assert_eq!(c3.eye, 9, "line 3's two records of pass 0 counted both");

        assert_eq!(p.header.base, 0);
        assert!(k.header.base > 0, "the live segments moved on");
        let emptied = (0..k.header.base)
            .filter(|&s| compacted.map.lock().unwrap()[&segment_key(JOB, s)].is_empty())
            .count();
        assert_eq!(emptied, k.header.base as usize, "every old segment emptied");
        let latest: usize = k.lines.values().map(|l| l.encoded_len()).sum();
        assert!(
            held(&compacted) <= 3 * latest + 4096,
            "{} {latest}",
            held(&compacted)
        );
        assert!(held(&plain) > 6 * latest, "{} {latest}", held(&plain));

        // A resumed job goes on from the compacted checkpoint.
        let mut c = Checkpointer::new(JOB, adaptive_spec(), 1, Some(&k)).with_slack(Some(0));
        passes(&mut c, &compacted, 8..10).await;
        let r = load(&compacted, JOB).await.unwrap().unwrap();
        assert_eq!(r.lines[&5].pass, 9);
        assert_eq!(r.lines[&5].counters.unwrap().eye, 10);
    });
}

#[test]
fn lines_not_stored_wait_for_the_next_save() {
    rt().block_on(async {
        let s = store();
        let mut c = Checkpointer::new(JOB, adaptive_spec(), 1, None);
        passes(&mut c, &s, 0..1).await;
        // The store goes away after one segment of pass 1: the header is not written.
        *s.fail_from.lock().unwrap() = Some(*s.puts.lock().unwrap() + 1);
        for y in 0..HEIGHT {
            c.record(record(y, 1), false);
        }
        assert!(c.save(&s, "running").await.is_err());
        assert_eq!(load(&s, JOB).await.unwrap().unwrap().lines[&5].pass, 0);
        *s.fail_from.lock().unwrap() = None;
        c.record(record(5, 2), false);
        c.save(&s, "running").await.unwrap();
        let r = load(&s, JOB).await.unwrap().unwrap();
        assert!((0..HEIGHT).all(|y| r.lines[&y].pass == if y == 5 { 2 } else { 1 }));
        assert_eq!(r.lines[&5].counters.unwrap().eye, 3);
    });
}

/// A format 3 checkpoint (before `base`) of a render to an error is read as it was.
#[test]
fn format_3_is_read() {
    let s = saved(adaptive_spec(), &[record(2, 0)]);
    let mut map = s.map.lock().unwrap();
    let header = CheckpointHeader::decode(map["j4"].as_slice()).unwrap();
    let old = CheckpointHeader {
        format: 3,
        ..header
    };
    map.insert("j4".into(), old.encode_to_vec());
    drop(map);
    let r = rt().block_on(load(&s, "j4")).unwrap().unwrap();
    assert_eq!(r.lines[&2].pass, 0);
}

/// The header naming a compaction's segments is stored but its answer is lost, then the next
/// save fails after one segment: what the store holds is still a consistent checkpoint (each
/// line at a pass it reached, its counters those of every pass to it), and the next save
/// that goes through empties the old segments.
#[test]
fn a_compactions_header_stored_with_its_answer_lost_leaves_a_consistent_checkpoint() {
    rt().block_on(async {
        // Where the compaction's header put falls, from the same saves on a store that
        // answers: the save whose header names a new base, less the old segments emptied.
        let probe = store();
        let mut c = Checkpointer::new(JOB, adaptive_spec(), 1, None).with_slack(Some(0));
        let mut base = 0;
        let mut at = None;
        for pass in 0..4 {
            passes(&mut c, &probe, pass..pass + 1).await;
            let b = load(&probe, JOB).await.unwrap().unwrap().header.base;
            if b != base && at.is_none() {
                let puts = *probe.puts.lock().unwrap();
                at = Some((pass, puts - (b - base) as usize - 1));
            }
            base = b;
        }
        let (pass, header_put) = at.expect("a compaction in four passes");

        let s = store();
        *s.answer_lost.lock().unwrap() = Some(header_put);
        let mut c = Checkpointer::new(JOB, adaptive_spec(), 1, None).with_slack(Some(0));
        for p in 0..=pass {
            for y in 0..HEIGHT {
                c.record(record(y, p), false);
            }
            if p == 0 {
                c.record(record(3, 0), false);
            }
            let saved = c.save(&s, "running").await;
            assert!(
                saved.is_ok(),
                "pass {p}: a compaction's error is not the save's"
            );
        }
        let stored = load(&s, JOB).await.unwrap().unwrap();
        assert!(
            stored.header.base > 0,
            "the lost answer's header was stored"
        );
        // The next save stores one segment, then the store goes away.
        *s.fail_from.lock().unwrap() = Some(*s.puts.lock().unwrap() + 1);
        for y in 0..HEIGHT {
            c.record(record(y, pass + 1), false);
        }
        assert!(c.save(&s, "running").await.is_err());
        let consistent = |r: &Restored| {
            (0..HEIGHT).all(|y| {
                let l = &r.lines[&y];
                let eye = l.counters.unwrap().eye;
                eye == u64::from(l.pass) + 1 + u64::from(y == 3)
            })
        };
        let r = load(&s, JOB).await.unwrap().unwrap();
        assert_eq!(r.lines.len(), HEIGHT as usize);
        assert!(consistent(&r), "{:?}", r.lines);
        // The store is back: the next save names the compacted segments, then empties the
        // old ones.
        *s.fail_from.lock().unwrap() = None;
        c.save(&s, "running").await.unwrap();
        let r = load(&s, JOB).await.unwrap().unwrap();
        assert!(consistent(&r) && r.lines.values().all(|l| l.pass == pass + 1));
        let map = s.map.lock().unwrap();
        assert!((0..r.header.base).all(|k| map[&segment_key(JOB, k)].is_empty()));
    });
}

/// Line `y` settled after pass `pass`: its two pixels done at `4 + pass` samples.
fn settled(y: u32, pass: u32) -> FinishedLine {
    use crate::distrib::settled::{to_bytes, SettledPixel};
    let a = crate::render::adaptive::Adaptive::new(0.01, Some(4), Some(64));
    let mut done = crate::render::adaptive::constant_pixel(DVec3::splat(0.25), &a);
    done.decide(false);
    let mut p = SettledPixel::of(&done);
    p.summary.samples = 4 + pass;
    FinishedLine {
        line: y,
        pass,
        pixels: crate::distrib::messages::pixels_to_bytes(&[[0.25; 3], [0.5; 3]]),
        settled: to_bytes([p; 2]),
        counters: Some(Wire {
            eye: 1,
            line_s: 0.5,
            ..Default::default()
        }),
        ..Default::default()
    }
}

/// The same records through a checkpointer that never compacts and one that compacts at
/// every save: `last` is recorded, then saved as `state`; what each store holds then, and
/// how many reads the compacting one made in that last save.
async fn both(
    before: std::ops::Range<u32>,
    last: &[(FinishedLine, bool)],
    state: &str,
) -> (Restored, Restored, (usize, u32), MemStore) {
    let (plain, compacted) = (store(), store());
    let mut p = Checkpointer::new(JOB, adaptive_spec(), 1, None).with_slack(Some(u64::MAX / 4));
    let mut k = Checkpointer::new(JOB, adaptive_spec(), 1, None).with_slack(None);
    passes(&mut p, &plain, before.clone()).await;
    passes(&mut k, &compacted, before).await;
    for c in [&mut p, &mut k] {
        for (l, finished) in last {
            c.record(l.clone(), *finished);
        }
    }
    p.save(&plain, state).await.unwrap();
    let base = load(&compacted, JOB).await.unwrap().unwrap().header.base;
    let gets = *compacted.gets.lock().unwrap();
    k.save(&compacted, state).await.unwrap();
    let read = *compacted.gets.lock().unwrap() - gets;
    let (p, k) = (
        load(&plain, JOB).await.unwrap().unwrap(),
        load(&compacted, JOB).await.unwrap().unwrap(),
    );
    // The segments the last save's compaction found live: from the base before to the new.
    let live = k.header.base - base;
    (p, k, (read, live), compacted)
}

/// A job's last save, every line finished: its compaction writes the finished lines it
/// holds and reads no segment back (it read every one, 67 MB for a 512 x 512 job).
#[test]
fn a_finished_jobs_last_compaction_reads_nothing_back() {
    rt().block_on(async {
        let last: Vec<_> = (0..HEIGHT).map(|y| (settled(y, 3), true)).collect();
        let (p, k, (read, _), compacted) = both(0..3, &last, "finished").await;
        assert_eq!(
            p.lines, k.lines,
            "the same lines, passes and summed counters"
        );
        assert_eq!(k.finished_lines(), HEIGHT);
        assert_eq!(
            k.lines[&3].counters.unwrap().eye,
            5,
            "line 3's five records"
        );
        assert!(k.header.base > 0, "compacted");
        assert_eq!(read, 0, "nothing read back");
        let latest: usize = k.lines.values().map(|l| l.encoded_len()).sum();
        assert!(
            held(&compacted) <= 2 * latest + 2048,
            "{}",
            held(&compacted)
        );
    });
}

/// Lines still open at a compaction are read back from the segments that hold their latest
/// records, and only those; the finished ones are written from what the writer holds.
#[test]
fn a_compaction_reads_only_the_segments_of_open_lines() {
    rt().block_on(async {
        let open = HEIGHT - 2;
        let last: Vec<_> = (0..HEIGHT)
            .map(|y| match y < open {
                true => (settled(y, 2), true),
                false => (record(y, 2), false),
            })
            .collect();
        let (p, k, (read, live), _) = both(0..2, &last, "running").await;
        assert_eq!(p.lines, k.lines);
        assert_eq!(k.finished_lines(), open);
        assert_eq!(k.lines[&15].pass, 2);
        assert!(read >= 1 && read < live as usize, "{read} of {live}");
    });
}

/// A resumed job's compaction does not know where its lines' records lie: it reads its live
/// segments (as every compaction did), the finished lines excepted, and loses nothing.
#[test]
fn a_resumed_jobs_compaction_reads_its_segments() {
    rt().block_on(async {
        let s = store();
        let mut c = Checkpointer::new(JOB, adaptive_spec(), 1, None).with_slack(Some(u64::MAX / 4));
        passes(&mut c, &s, 0..2).await;
        for y in 0..4 {
            c.record(settled(y, 2), true);
        }
        c.save(&s, "running").await.unwrap();
        let restored = load(&s, JOB).await.unwrap().unwrap();
        let mut c = Checkpointer::new(JOB, adaptive_spec(), 1, Some(&restored)).with_slack(None);
        let gets = *s.gets.lock().unwrap();
        c.record(record(9, 2), false);
        c.save(&s, "running").await.unwrap();
        let live = restored.header.segments - restored.header.base;
        let read = *s.gets.lock().unwrap() - gets;
        assert!(
            read >= live as usize,
            "the live segments read: {read} of {live}"
        );
        let r = load(&s, JOB).await.unwrap().unwrap();
        assert!(r.header.base > restored.header.base, "compacted");
        assert_eq!(r.finished_lines(), 4);
        assert_eq!(r.lines[&9].pass, 2);
        assert_eq!(r.lines[&9].counters.unwrap().eye, 3);
        assert_eq!(
            r.lines[&3].counters.unwrap().eye,
            4,
            "line 3: pass 0 twice, 1, settled"
        );
        assert_eq!(r.lines[&5], restored.lines[&5]);
    });
}
