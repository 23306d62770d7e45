//! A job rendered to an error: a line goes on past its first samples only once every line
//! within two of it has its own, and only if a pixel near it was open; a checkpoint holds the
//! decisions, and a job resumed with lines still waiting decides them as their neighbours
//! come in.

use super::{spec_with, FakeLink, Job, JOB, WIDTH};
use crate::distrib::checkpoint::{self, Checkpointer};
use crate::distrib::controller::JobResult;
use crate::distrib::messages::{self, proto, Body};
use crate::render::adaptive::{self, constant_pixel, Adaptive, PixelEstimate};
use crate::render::columns::Columns;
use glam::DVec3;

const HEIGHT: u32 = 8;

fn target() -> Adaptive {
    Adaptive::new(0.01, Some(4), Some(64))
}

/// Line `y`'s first samples: flat, but for an open pixel at (0, 0).
fn first_samples(y: u32) -> Vec<PixelEstimate> {
    let a = target();
    let mut line = vec![constant_pixel(DVec3::splat(0.5), &a); WIDTH as usize];
    if y == 0 {
        let mut noisy = PixelEstimate::default();
        for k in 0..4 {
            noisy.add(DVec3::splat(f64::from(k % 2)));
        }
        noisy.first_samples_in(&a);
        line[0] = noisy;
    }
    line
}

impl Job {
    /// Worker `node` renders pass `grant.pass` of its line: the first samples, or the
    /// pixels the grant carries (those the pass takes, or the whole line) taken on (with
    /// samples of 0.5) as far as the pass's cap, and answers with them, as a worker does.
    async fn pass_done(&self, node: usize, g: &proto::LineGrant) {
        let a = target();
        let mut est = if g.pass == 0 {
            first_samples(g.line)
        } else if g.columns.is_empty() {
            messages::estimates_from_bytes(&g.estimates, WIDTH, &a).unwrap()
        } else {
            let columns = Columns::from_bytes(&g.columns, WIDTH).unwrap();
            messages::picked_estimates_from_bytes(&g.estimates, &columns, WIDTH, &a).unwrap()
        };
        let cap = adaptive::pass_cap(&a, g.pass);
        for p in est.iter_mut() {
            while let Some(want) = p.next_count(&a).filter(|&n| n <= cap) {
                while p.count() < want {
                    p.add(DVec3::splat(0.5));
                }
            }
        }
        let done = proto::Done {
            line: g.line,
            grant: g.grant,
            pass: g.pass,
            estimates: messages::estimates_to_bytes(&est),
            columns: g.columns.clone(),
            counters: Some(proto::Counters::default()),
            window: 8,
            ..Default::default()
        };
        self.say(node, Body::Done(done)).await;
    }

    /// Worker `node` answers every grant until the job ends; the grants it answered.
    async fn serve_passes(&self, node: usize) -> Vec<(u32, u32)> {
        let mut answered = Vec::new();
        for _ in 0..10_000 {
            if self.handle.task.is_finished() {
                break;
            }
            for g in self.link.take_grants(&self.procs[node]) {
                self.pass_done(node, &g).await;
                answered.push((g.line, g.pass));
            }
            tokio::time::sleep(std::time::Duration::from_millis(20)).await;
        }
        answered
    }
}

/// The job `r` finished, and the pixels within two of the open one at (0, 0) went on: the
/// open one to the most, the others (lines 0 to 2, columns 0 to 2) raised to 4 x their first
/// samples; the rest stopped.
fn assert_pixels_near_the_open_one_went_on(r: JobResult) {
    assert!(r.finished);
    let took: Vec<u32> = r
        .passes
        .unwrap()
        .summaries()
        .iter()
        .map(|s| s.samples)
        .collect();
    let w = WIDTH as usize;
    assert_eq!(
        &took[..4],
        [64, 16, 16, 4],
        "line 0: open, raised, raised, too far"
    );
    for y in [1, 2] {
        assert_eq!(&took[y * w..y * w + 4], [16, 16, 16, 4], "line {y}");
    }
    assert!(took[3 * w..].iter().all(|&n| n == 4));
}

fn job(link: FakeLink, restored: Option<checkpoint::Restored>) -> Job {
    Job::configured(link, HEIGHT, 1, restored, |cfg| {
        cfg.adaptive = Some(target())
    })
}

#[tokio::test(start_paused = true)]
async fn a_line_goes_on_once_its_neighbours_have_their_first_samples() {
    let job = job(FakeLink::default(), None);
    job.ready(0, 8).await;
    let firsts = job.link.take_grants(&job.procs[0]);
    assert_eq!(firsts.len(), 8);
    assert!(firsts.iter().all(|g| g.pass == 0));
    // Line 0 waits for lines 1 and 2's first samples, line 1 for 0 to 3: no pass 1 before.
    for g in &firsts[..2] {
        job.pass_done(0, g).await;
    }
    assert!(job.link.take_grants(&job.procs[0]).is_empty());
    let mut answered = Vec::new();
    for (g, next) in firsts[2..4].iter().zip([(0, 1), (1, 1)]) {
        job.pass_done(0, g).await;
        let seconds = job.link.take_grants(&job.procs[0]);
        let got: Vec<(u32, u32)> = seconds.iter().map(|g| (g.line, g.pass)).collect();
        // Its line goes on; the next line still waits for the line after this one.
        assert!(got.contains(&next), "after line {}: {got:?}", g.line);
        assert!(
            got.iter().all(|&(line, _)| line <= next.0),
            "after line {}: {got:?}",
            g.line
        );
        for s in &seconds {
            // A current worker: a later pass carries the pixels it takes alone.
            assert!(s.pass == 0 || !s.columns.is_empty(), "line {}", s.line);
            job.pass_done(0, s).await;
            answered.push((s.line, s.pass));
        }
    }
    for g in &firsts[4..] {
        job.pass_done(0, g).await;
    }
    answered.extend(job.serve_passes(0).await);
    answered.sort_unstable();
    answered.dedup_by_key(|(line, _)| *line);
    // Lines 0 to 2 (the open pixel within two) go on; 3 to 7 stop at their first samples.
    assert_eq!(answered.iter().map(|l| l.0).collect::<Vec<_>>(), [0, 1, 2]);
    let (r, link) = job.end().await;
    assert_pixels_near_the_open_one_went_on(r);
    let reread = checkpoint::load(&link, JOB).await.unwrap().unwrap();
    assert_eq!(
        reread.finished_lines(),
        HEIGHT,
        "the decisions are in the checkpoint"
    );
}

/// A finished line is recorded settled (its pixels and what each took, 21 bytes a pixel,
/// not its estimates' 149), and a job resumed from settled lines decides their neighbours by
/// them: line 0's open pixel raises lines 1 and 2.
#[tokio::test(start_paused = true)]
async fn finished_lines_are_settled_and_a_resumed_job_decides_by_them() {
    let first = job(FakeLink::default(), None);
    first.ready(0, 8).await;
    first.serve_passes(0).await;
    let (r, link) = first.end().await;
    assert_pixels_near_the_open_one_went_on(r);
    let reread = checkpoint::load(&link, JOB).await.unwrap().unwrap();
    assert_eq!(reread.finished_lines(), HEIGHT);
    // Every line is settled: its pixels and 9 bytes a pixel of what it took, no estimates.
    for l in reread.lines.values() {
        assert!(l.estimates.is_empty(), "line {}", l.line);
        assert_eq!(l.pixels.len(), WIDTH as usize * 12, "line {}", l.line);
        assert_eq!(l.settled.len(), WIDTH as usize * 9, "line {}", l.line);
    }
    let settled = reread.settled(&reread.lines[&0]).unwrap();
    assert!(settled[0].open && settled[0].summary.samples == 64 && !settled[1].open);
    assert_eq!(
        reread.film(WIDTH, HEIGHT).pixels,
        vec![[0.5; 3]; (WIDTH * HEIGHT) as usize]
    );
    // A job resumed from line 0 alone (settled) decides lines 1 and 2 by its open pixel.
    let resumed = FakeLink::default();
    let mut earlier = Checkpointer::new(JOB, spec_with(HEIGHT, Some(target())), 7, None);
    earlier.record(reread.lines[&0].clone(), true);
    earlier.save(&resumed, "failed").await.unwrap();
    let restored = checkpoint::load(&resumed, JOB).await.unwrap();
    assert_eq!(restored.as_ref().unwrap().finished_lines(), 1);
    let second = job(resumed, restored);
    second.ready(0, 8).await;
    let answered = second.serve_passes(0).await;
    assert!(!answered.iter().any(|&(line, _)| line == 0), "{answered:?}");
    assert!(answered.contains(&(1, 1)) && answered.contains(&(2, 1)));
    let (r, _) = second.end().await;
    assert_pixels_near_the_open_one_went_on(r);
}

/// Its relay takes two grants with estimates a message at most (a larger one fails the
/// worker), and the resumed job's first Assign has three: it is split. Its worker is of an
/// earlier build: its later passes carry whole lines, and its answers are read.
#[tokio::test(start_paused = true)]
async fn a_resumed_job_decides_its_waiting_lines_as_their_neighbours_come_in() {
    // An earlier run had the first samples of lines 0 to 5, and no decision.
    let grant = WIDTH as usize * PixelEstimate::BYTES + 16;
    let link = FakeLink::with_max_message(2 * grant + 32);
    let mut earlier = Checkpointer::new(JOB, spec_with(HEIGHT, Some(target())), 7, None);
    for y in 0..6 {
        let line = proto::FinishedLine {
            line: y,
            estimates: messages::estimates_to_bytes(&first_samples(y)),
            counters: Some(proto::Counters::default()),
            ..Default::default()
        };
        earlier.record(line, false);
    }
    earlier.save(&link, "failed").await.unwrap();
    let restored = checkpoint::load(&link, JOB).await.unwrap();
    assert_eq!(restored.as_ref().unwrap().finished_lines(), 0);
    let job = job(link, restored);
    job.ready_earlier_build(0, 8).await;
    let grants = job.link.take_grants(&job.procs[0]);
    let whole = WIDTH as usize * PixelEstimate::BYTES;
    for g in grants.iter().filter(|g| g.pass > 0) {
        assert!(
            g.columns.is_empty() && g.estimates.len() == whole,
            "line {}",
            g.line
        );
    }
    let mut given: Vec<(u32, u32)> = grants.iter().map(|g| (g.line, g.pass)).collect();
    given.sort_unstable();
    // 0 to 2 raised (pass 1), 3 finished, 4 and 5 wait for 6 and 7 (pass 0).
    assert_eq!(given, [(0, 1), (1, 1), (2, 1), (6, 0), (7, 0)]);
    for g in &grants {
        job.pass_done(0, g).await;
    }
    let later = job.serve_passes(0).await;
    assert!(later.iter().all(|&(line, _)| line <= 2), "{later:?}");
    let (r, link) = job.end().await;
    assert_pixels_near_the_open_one_went_on(r);
    let reread = checkpoint::load(&link, JOB).await.unwrap().unwrap();
    assert_eq!(reread.finished_lines(), HEIGHT);
}
