//! A store that takes far longer than the workers' timeout (a replica host stopped with
//! SIGSTOP): the controller's writes are on its store writer, so lines are granted and taken
//! at the workers' pace, nobody is judged silent, and only the job's end waits for the store
//! (the image is the user's once stored).

use super::{assert_image_complete, FakeLink, Job, JOB};
use crate::distrib::checkpoint;
use std::collections::BTreeSet;
use std::time::Duration;
use tokio::time::Instant;

#[tokio::test(start_paused = true)]
async fn a_store_that_takes_30_s_a_write_holds_up_no_line_and_no_worker() {
    let link = FakeLink::default();
    link.0.lock().unwrap().put_takes = Duration::from_secs(30);
    // A checkpoint is due every 500 ms and the web view publishes every second: both
    // writers are inside a write from the first lines on.
    let job = Job::launch(link, 8, 2, None, Some(Vec::new()));
    let t0 = Instant::now();
    job.ready(0, 2).await;
    job.ready(1, 2).await;
    let mut lines = BTreeSet::new();
    while lines.len() < 8 {
        for n in 0..2 {
            for g in job.link.take_grants(&job.procs[n]) {
                job.done(n, g.line, g.grant).await;
                lines.insert(g.line);
            }
        }
        tokio::time::sleep(Duration::from_millis(300)).await;
        assert!(t0.elapsed() < Duration::from_secs(10), "lines {lines:?}");
    }
    let rendered = t0.elapsed();
    assert!(rendered < Duration::from_secs(3), "{rendered:?}");
    let (r, link) = job.end().await;
    // The end waited for the store: the last save (segments, then the header) after the one
    // in flight.
    assert!(
        t0.elapsed() >= Duration::from_secs(60),
        "{:?}",
        t0.elapsed()
    );
    assert_image_complete(&r, 8);
    // Judged silent, a worker gives its lines back and its late completions are dropped.
    // (At the end every worker here counts as silent: the test's workers never exit when
    // told to stop.)
    for n in &r.nodes {
        assert_eq!((n.lines_given_back, n.dropped), (0, 0), "{n:?}");
    }
    let stored = checkpoint::load(&link, JOB).await.unwrap().unwrap();
    assert_eq!(
        (stored.header.state.as_str(), stored.lines.len()),
        ("finished", 8)
    );
}
