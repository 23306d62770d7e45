//! A job's checkpoints: a resumed job renders only the lines its checkpoint lacks, the last
//! save is tried again while the store refuses it (and the result says when it never got
//! in), and a job no worker is left for ends checkpointed.

use super::super::actions::FINAL_SAVE_TRIES;
use super::{assert_image_complete, pixels, spec, FakeLink, Job, JOB};
use crate::distrib::checkpoint::{self, Checkpointer};
use crate::distrib::controller::JobResult;
use crate::distrib::messages::{self, proto};
use crate::distrib::nodes::Outcome;

#[tokio::test(start_paused = true)]
async fn a_resumed_job_hands_out_only_the_missing_lines() {
    // An earlier run checkpointed lines 0, 1, 2 and 5.
    let link = FakeLink::default();
    let mut earlier = Checkpointer::new(JOB, spec(8), 7, None);
    for y in [0u32, 1, 2, 5] {
        earlier.record(
            proto::FinishedLine {
                line: y,
                pixels: messages::pixels_to_bytes(&pixels(y)),
                counters: Some(proto::Counters::default()),
                ..Default::default()
            },
            true,
        );
    }
    earlier.save(&link, "failed").await.unwrap();
    let restored = checkpoint::load(&link, JOB).await.unwrap();
    let job = Job::start_on(link, 8, 1, restored);
    job.ready(0, 8).await;
    let grants = job.link.take_grants(&job.procs[0]);
    let mut given: Vec<u32> = grants.iter().map(|g| g.line).collect();
    given.sort_unstable();
    assert_eq!(given, vec![3, 4, 6, 7]);
    for g in grants {
        job.done(0, g.line, g.grant).await;
    }
    job.serve_until_done(0).await;
    let (r, link) = job.end().await;
    assert_image_complete(&r, 8);
    assert_eq!((r.lines.resumed, r.lines.rendered), (4, 4));
    // The final checkpoint holds every line.
    let reread = checkpoint::load(&link, JOB).await.unwrap().unwrap();
    assert_eq!(reread.lines.len(), 8);
    assert_eq!(reread.header.state, "finished");
}

/// A job of four lines whose store refuses the next `refused` writes as its last line comes
/// in, run to its end: the last save's first tries fail.
async fn last_save_refused(refused: u32) -> (JobResult, FakeLink) {
    let job = Job::start(4, 1, None);
    job.ready(0, 4).await;
    let grants = job.link.take_grants(&job.procs[0]);
    let last = grants.len() - 1;
    for g in &grants[..last] {
        job.done(0, g.line, g.grant).await;
    }
    job.link.0.lock().unwrap().failing_puts = refused;
    job.done(0, grants[last].line, grants[last].grant).await;
    job.serve_until_done(0).await;
    let (r, link) = job.end().await;
    assert_image_complete(&r, 4);
    (r, link)
}

#[tokio::test(start_paused = true)]
async fn a_last_save_refused_for_a_moment_is_tried_again_until_stored() {
    let (r, link) = last_save_refused(3).await;
    let reread = checkpoint::load(&link, JOB).await.unwrap().unwrap();
    assert_eq!(reread.header.state, "finished");
    assert_eq!(reread.lines.len(), 4, "every line stored, the last one too");
    assert!(r.finished && r.stored);
}

/// A store that refuses every try of the last save: the job's image is whole, but the result
/// says it is not stored (a farm controller then exits for REM to start another, which
/// renders the lines the store lacks; `submit` writes the image and says `fetch` cannot give
/// it), and the stored checkpoint is the one before, not marked finished.
#[tokio::test(start_paused = true)]
async fn a_last_save_refused_every_time_says_the_image_is_not_stored() {
    let (r, link) = last_save_refused(10 * FINAL_SAVE_TRIES).await;
    assert!(r.finished, "every line is in");
    assert!(!r.stored, "but the store has not got them all");
    if let Some(reread) = checkpoint::load(&link, JOB).await.unwrap() {
        assert_ne!(reread.header.state, "finished");
        assert!(reread.lines.len() < 4);
    }
}

/// The web view says `finished` only for a job whose last save was stored.
#[test]
fn the_view_calls_a_job_finished_only_when_its_image_is_stored() {
    use super::super::end_event;
    assert_eq!(end_event(true, true), "finished");
    assert_eq!(end_event(true, false), "not-stored");
    assert_eq!(end_event(false, true), "failed");
    assert_eq!(end_event(false, false), "failed");
}

#[tokio::test(start_paused = true)]
async fn with_no_worker_left_the_job_ends_unfinished_and_checkpointed() {
    let job = Job::start(6, 1, None);
    job.ready(0, 2).await;
    let grants = job.link.take_grants(&job.procs[0]);
    job.done(0, grants[0].line, grants[0].grant).await;
    job.exits(0, Some(1), None).await;
    let (r, link) = job.end().await;
    assert!(!r.finished);
    assert_eq!(r.lines.rendered, 1);
    assert_eq!(r.nodes[0].outcome, Outcome::Fault);
    let reread = checkpoint::load(&link, JOB).await.unwrap().unwrap();
    assert_eq!(reread.lines.len(), 1);
    assert_eq!(reread.header.state, "failed");
}
