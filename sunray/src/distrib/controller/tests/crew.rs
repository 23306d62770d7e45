//! A job whose site adds and retires workers as its share of the farm moves: a retiring
//! worker gets no more lines, what it finishes is taken and what it hands back goes to the
//! others; a worker added mid-job gets the Scene and lines; a job with no worker left waits
//! for more (it is queued), unless its workers keep failing.

use super::{assert_image_complete, FakeLink, Job};
use crate::distrib::controller::crew::Crew;
use crate::distrib::controller::{Input, WorkerProc, FAULTS_WITH_A_CREW};
use crate::distrib::messages::{proto, Body};
use crate::distrib::nodes::Outcome;
use rem::ProcId;
use std::time::Duration;
use tokio::sync::oneshot;

fn worker(host: &str) -> WorkerProc {
    WorkerProc {
        proc_id: ProcId::new(host, 1),
        host: host.into(),
        pid: 200,
        load_at_start: None,
        adopted: false,
        slots: 1,
    }
}

#[tokio::test(start_paused = true)]
async fn workers_retire_and_join_while_the_job_runs_and_every_line_comes_in_once() {
    let crew = Crew::default();
    let c = crew.clone();
    let mut job = Job::configured(FakeLink::default(), 8, 2, None, |cfg| cfg.crew = Some(c));
    job.ready(0, 2).await;
    job.ready(1, 2).await;
    let on_1 = job.link.take_grants(&job.procs[1]);
    assert_eq!(on_1.len(), 2);
    assert_eq!(crew.view().slots(), 2);
    // Give back one slot: the newest worker (node 2) retires.
    let (done, told) = oneshot::channel();
    let retire = Input::Retire {
        slots: 1,
        keep_one: true,
        done: Some(done),
    };
    job.handle.tx.send(retire).await.unwrap();
    told.await.unwrap();
    assert!(job
        .link
        .got(&job.procs[1], |b| matches!(b, Body::Retire(_))));
    assert_eq!(crew.view().slots(), 1);
    // It finishes its first line, hands back the second, asks again: nothing comes.
    job.done(1, on_1[0].line, on_1[0].grant).await;
    let back = proto::Request {
        window: 4,
        released: vec![on_1[1].grant],
        ..Default::default()
    };
    job.say(1, Body::Request(back)).await;
    assert!(job.link.take_grants(&job.procs[1]).is_empty());
    job.exits(1, Some(0), None).await;
    // A worker joins: it gets the Scene, then lines.
    let added = worker("h9");
    job.procs.push(added.proc_id.clone());
    let (done, told) = oneshot::channel();
    job.handle
        .tx
        .send(Input::Workers(vec![added], Some(done)))
        .await
        .unwrap();
    told.await.unwrap();
    assert_eq!(crew.view().slots(), 2);
    assert!(
        job.link
            .got(&job.procs[2], |b| matches!(b, Body::NoMoreWork(_))),
        "the Scene"
    );
    job.ready(2, 2).await;
    let serve = async {
        for _ in 0..1000 {
            if job.handle.task.is_finished() {
                return;
            }
            for n in [0, 2] {
                for g in job.link.take_grants(&job.procs[n]) {
                    job.done(n, g.line, g.grant).await;
                }
            }
            tokio::time::sleep(Duration::from_millis(20)).await;
        }
    };
    serve.await;
    let (r, _) = job.end().await;
    assert_image_complete(&r, 8);
    let outcomes: Vec<Outcome> = r.nodes.iter().map(|n| n.outcome).collect();
    assert_eq!(outcomes[1], Outcome::Retired, "{outcomes:?}");
    assert_eq!((r.nodes[1].scanlines, r.nodes[1].dropped), (1, 0));
    assert!(r.nodes[2].scanlines > 0);
    assert_eq!(r.lines.total, 8);
}

#[tokio::test(start_paused = true)]
async fn with_a_crew_no_worker_left_is_a_wait_until_they_keep_failing() {
    let crew = Crew::default();
    let c = crew.clone();
    let job = Job::configured(FakeLink::default(), 4, 1, None, |cfg| cfg.crew = Some(c));
    job.ready(0, 1).await;
    // Its only worker retires (a higher priority took the slot): the job waits.
    let retire = Input::Retire {
        slots: 1,
        keep_one: false,
        done: None,
    };
    job.handle.tx.send(retire).await.unwrap();
    job.exits(0, Some(0), None).await;
    tokio::time::sleep(Duration::from_secs(30)).await;
    assert!(
        !job.handle.task.is_finished(),
        "a queued job waits for its turn"
    );
    // Workers that keep dying end it (REM then starts its controller again).
    for i in 0..FAULTS_WITH_A_CREW {
        let w = worker(&format!("f{i}"));
        let id = w.proc_id.clone();
        job.handle
            .tx
            .send(Input::Workers(vec![w], None))
            .await
            .unwrap();
        let mut ev = rem::JobEvent {
            proc_id: id.to_string(),
            host: id.host().to_string(),
            exit_code: Some(1),
            ..Default::default()
        };
        ev.set_kind(rem::EventKind::Exited);
        job.handle
            .tx
            .send(Input::Relay(Ok(rem::Incoming::Event(ev))))
            .await
            .unwrap();
        tokio::time::sleep(Duration::from_millis(200)).await;
    }
    tokio::time::sleep(Duration::from_secs(1)).await;
    assert!(job.handle.task.is_finished());
    assert_eq!(crew.view().faults, FAULTS_WITH_A_CREW);
}

#[tokio::test(start_paused = true)]
async fn a_host_of_another_image_version_is_refused_and_not_asked_again() {
    let crew = Crew::default();
    let c = crew.clone();
    let job = Job::configured(FakeLink::default(), 4, 2, None, |cfg| cfg.crew = Some(c));
    let newer = proto::Ready {
        image_version: crate::render::image_version::IMAGE_VERSION + 1,
        ..Default::default()
    };
    job.say(0, Body::Ready(newer)).await;
    job.ready(1, 2).await;
    let view = crew.view();
    assert_eq!(view.faults, 1);
    assert_eq!(view.hosts(), ["h1"]);
    assert!(view.refused_hosts.contains("h0"), "{view:?}");
    assert_eq!(view.avoid(&[], false), ["h0", "h1"]);
    job.serve_until_done(1).await;
    let (r, _) = job.end().await;
    assert_image_complete(&r, 4);
}
