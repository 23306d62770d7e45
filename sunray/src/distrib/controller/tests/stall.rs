//! The controller held up by its own writes (a checkpoint REM takes seconds to store while a
//! replica is stopped): workers are judged by when they spoke, not by when the controller got
//! round to reading them.

use super::{assert_image_complete, FakeLink, Job};
use std::time::Duration;

#[tokio::test(start_paused = true)]
async fn a_slow_checkpoint_write_does_not_make_working_workers_silent() {
    // When the write ends, the queued messages and the overdue tick are both ready and
    // `select!` takes either first; eight jobs make a lucky pass of the old order
    // (tick first: everyone silent) a 1-in-256 chance.
    for round in 0..8 {
        let job = Job::start_on(FakeLink::default(), 8, 2, None);
        job.ready(0, 2).await;
        job.ready(1, 2).await;
        let held: Vec<_> = (0..2)
            .map(|n| job.link.take_grants(&job.procs[n]))
            .collect();
        assert!(held.iter().all(|h| h.len() == 2), "{held:?}");
        // A line from each makes a checkpoint due (every 500 ms); from now on a write takes
        // 3 s, three times the workers' timeout.
        for (n, h) in held.iter().enumerate() {
            job.done(n, h[0].line, h[0].grant).await;
        }
        job.link.0.lock().unwrap().put_takes = Duration::from_secs(3);
        tokio::time::sleep(Duration::from_millis(700)).await;
        // The controller is inside the write; the workers go on and finish everything they
        // hold (the second line of their window and the one granted for the first).
        for (n, h) in held.iter().enumerate() {
            let mut rest = vec![h[1]];
            rest.extend(job.link.take_grants(&job.procs[n]));
            assert_eq!(rest.len(), 2, "{rest:?}");
            for g in rest {
                job.done(n, g.line, g.grant).await;
            }
        }
        tokio::time::sleep(Duration::from_secs(3)).await;
        job.link.0.lock().unwrap().put_takes = Duration::ZERO;
        tokio::join!(job.serve_until_done(0), job.serve_until_done(1));
        let (r, _) = job.end().await;
        assert_image_complete(&r, 8);
        // Judged silent, a worker gives its lines back and its late completions are
        // dropped. (At the end every worker here counts as silent: the test's workers never
        // exit when told to stop.)
        for n in &r.nodes {
            assert_eq!(
                (n.lines_given_back, n.dropped),
                (0, 0),
                "round {round}: {n:?}"
            );
        }
    }
}
