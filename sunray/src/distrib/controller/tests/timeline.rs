//! A job's steps and its end: the timeline the controller keeps, what a node that rendered
//! nothing says, and which workers the job's end waits for.

use super::{assert_image_complete, FakeLink, Job};
use crate::distrib::messages::{proto, Body};
use crate::distrib::nodes::{Outcome, Stage};
use std::time::Duration;

#[tokio::test(start_paused = true)]
async fn the_timeline_is_kept_and_a_node_that_renders_nothing_says_why() {
    let job = Job::start(6, 2, None);
    let preparing = |stage: proto::preparing::Stage| {
        Body::Preparing(proto::Preparing {
            stage: stage as i32,
            fetch: None,
        })
    };
    job.say(0, Body::Ready(proto::Ready::default())).await;
    job.say(0, preparing(proto::preparing::Stage::Fetching))
        .await;
    job.say(0, preparing(proto::preparing::Stage::Building))
        .await;
    let request = proto::Request {
        window: 2,
        stamp_s: 5.0,
        steps: Some(proto::WorkerSteps {
            scene_ready_s: 4.0,
            accel_ready_s: 4.5,
        }),
        ..Default::default()
    };
    job.say(0, Body::Request(request)).await;
    // Node 2 is still building its accelerator when the job ends.
    job.say(1, Body::Ready(proto::Ready::default())).await;
    let fetched = proto::SceneFetch {
        bytes_received: 1234,
        cached: false,
        fetch_s: 0.5,
        ..Default::default()
    };
    let building = proto::Preparing {
        stage: proto::preparing::Stage::Building as i32,
        fetch: Some(fetched),
    };
    job.say(1, Body::Preparing(building)).await;
    job.serve_until_done(0).await;
    let (r, _) = job.end().await;
    assert_image_complete(&r, 6);
    let t = &r.timeline;
    assert!(t.first_line.is_some() && t.last_line.is_some(), "{t:?}");
    assert!(t.image_stored.is_some() && t.finished.is_some(), "{t:?}");
    assert!(t.is_ordered(), "{t:?}");
    let (done, idle) = (&r.nodes[0], &r.nodes[1]);
    assert_eq!(
        (done.stage, idle.stage),
        (Stage::Rendering, Stage::Building)
    );
    let n = &done.timeline;
    let steps = [n.spawned, n.scene_ready, n.accel_ready, n.first_line];
    assert!(steps.iter().all(Option::is_some), "{n:?}");
    assert!(steps.windows(2).all(|w| w[0] <= w[1]), "{n:?}");
    assert_eq!(idle.timeline.first_line, None);
    assert_eq!(
        idle.outcome,
        Outcome::Ok,
        "a node stopped while building was not needed, not silent"
    );
    assert_eq!(
        (
            idle.scene_bytes_received,
            idle.scene_cached,
            idle.scene_fetch_s
        ),
        (1234, false, 0.5),
        "a node stopped while building keeps how its model came"
    );
    let table = crate::distrib::nodes::table(&r.nodes);
    assert!(
        table.contains("rendered nothing: still building its accelerator"),
        "{table}"
    );
}

#[test]
fn the_wind_down_waits_only_for_active_workers_not_building() {
    use super::super::actions::waited_for;
    use crate::distrib::grants::NodeState;
    let active = Some(NodeState::Active);
    assert!(waited_for(false, active, Stage::Rendering));
    assert!(
        waited_for(false, active, Stage::Fetching),
        "its keeper needs the whole model"
    );
    assert!(waited_for(false, active, Stage::Spawned));
    assert!(
        !waited_for(false, active, Stage::Building),
        "its keeper goes on without it"
    );
    assert!(!waited_for(true, active, Stage::Rendering), "exited");
    assert!(!waited_for(
        false,
        Some(NodeState::Silent),
        Stage::Rendering
    ));
    assert!(!waited_for(false, None, Stage::Rendering));
}

fn preparing(stage: proto::preparing::Stage) -> Body {
    Body::Preparing(proto::Preparing {
        stage: stage as i32,
        fetch: None,
    })
}

#[tokio::test(start_paused = true)]
async fn the_image_is_told_before_the_end_which_waits_for_a_worker_still_fetching() {
    let grace = Duration::from_secs(30);
    let mut job = Job::configured(FakeLink::default(), 6, 3, None, |cfg| {
        cfg.fetch_grace = grace;
    });
    job.ready(0, 2).await;
    for node in [1, 2] {
        job.say(node, Body::Ready(proto::Ready::default())).await;
        job.say(node, preparing(proto::preparing::Stage::Fetching))
            .await;
    }
    let mut at_image = None;
    for _ in 0..50 {
        for g in job.link.take_grants(&job.procs[0]) {
            job.done(0, g.line, g.grant).await;
        }
        if let Ok(r) = job.handle.image.try_recv() {
            at_image = Some(r);
            break;
        }
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    let at_image = at_image.expect("the job's result is told when its image is stored");
    assert_image_complete(&at_image, 6);
    let t = &at_image.timeline;
    assert!(
        t.image_stored.is_some() && t.finished == t.image_stored,
        "{t:?}"
    );
    job.exits(0, Some(0), None).await;
    tokio::time::sleep(grace / 2).await;
    assert!(
        !job.handle.task.is_finished(),
        "the end waits for the workers still fetching"
    );
    // Node 2 has its model: its keeper builds on without it, so it is not waited for.
    job.say(1, preparing(proto::preparing::Stage::Building))
        .await;
    assert!(!job.handle.task.is_finished(), "node 3 is still fetching");
    let (r, link) = job.end().await;
    assert_image_complete(&r, 6);
    let outcomes: Vec<Outcome> = r.nodes.iter().map(|n| n.outcome).collect();
    assert_eq!(
        outcomes,
        [Outcome::Ok, Outcome::Ok, Outcome::Silent],
        "node 3 fetched for longer than the grace"
    );
    let killed = link.0.lock().unwrap().killed.clone();
    assert_eq!(killed, [job_procs(1), job_procs(2)]);
}

fn job_procs(node: usize) -> String {
    rem::ProcId::new(&format!("h{node}"), 1).to_string()
}
