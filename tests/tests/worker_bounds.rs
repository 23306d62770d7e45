//! A real `sunray worker`, started by a real remd, is sent a Scene whose render settings are
//! out of bounds (the issue "Security": workers trusted RenderSettings, so width = u32::MAX
//! aborted on allocation and a huge depth with a negative weight threshold overflowed the
//! stack). The test plays the controller: it owns the job, waits for the worker's Ready,
//! sends the Scene, and must get the worker's WorkerError message (not silence) naming the
//! field, then the worker's exit with a code (1), not a signal.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a test: a failed unwrap is a failed test

use rem::{EventKind, Incoming, JobEvent, ProcId, RemClient, Secret, SpawnRequest};
use std::time::Duration;
use sunray::distrib::messages::{self, proto, Body};
use sunray::distrib::model_chunks;
use sunray::render::{Overrides, Settings};
use sunray::scene::load::{compile_for_job, SceneSource};
use sunray_e2e::bins::sunray_bin;
use sunray_e2e::remd::{LoopbackCluster, SECRET};

/// How long any one step may take (a worker starts and answers in well under a second).
const STEP: Duration = Duration::from_secs(30);

/// The built-in scene's model and its own (valid) settings, as `sunray submit` sends them.
fn scene_and_settings() -> (Vec<u8>, Settings) {
    let compiled = compile_for_job(&SceneSource::Builtin, None).unwrap();
    let settings = Overrides::default()
        .settings_for(&compiled.summary)
        .unwrap();
    (compiled.model, settings)
}

/// What the worker said and how it ended.
struct Refusal {
    /// The WorkerError message.
    message: String,
    /// Its Exited event.
    exited: JobEvent,
    /// Its standard error, as remd kept it.
    stderr: String,
}

/// Starts one worker through a real remd, sends it a Scene with `settings`, and returns its
/// WorkerError message and exit.
fn refusal(job: &str, settings: proto::RenderSettings) -> Refusal {
    let cluster = LoopbackCluster::start(1);
    let (model, _) = scene_and_settings();
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .unwrap();
    rt.block_on(async {
        let client = RemClient::connect(&cluster.daemons[0].addr, Secret::new(SECRET).unwrap())
            .await
            .unwrap();
        let relay = client.attach(Some(job)).await.unwrap();
        let spawned = client
            .spawn(SpawnRequest {
                program: sunray_bin().display().to_string(),
                args: vec!["worker".into(), "--threads".into(), "1".into()],
                count: 1,
                allow_same_host: true,
                job: Some(job.to_string()),
                owner: Some(relay.id().clone()),
                ..SpawnRequest::default()
            })
            .await
            .unwrap();
        let worker: ProcId = spawned.processes[0].proc_id.clone();
        let (sender, mut receiver) = relay.split();

        // The worker says Ready first; then it waits for its Scene.
        let mut events = Vec::new();
        tokio::time::timeout(STEP, async {
            loop {
                match receiver.recv().await.unwrap() {
                    Incoming::Message { from, payload } if from == worker.as_str() => {
                        if let Ok(Body::Ready(_)) = messages::decode(&payload) {
                            return;
                        }
                    }
                    Incoming::Event(e) => events.push(e),
                    _ => {}
                }
            }
        })
        .await
        .expect("no Ready from the worker");
        assert!(
            events.iter().all(|e| e.kind() != EventKind::Exited),
            "the worker exited before its Scene: {events:?}"
        );

        let shipped = model_chunks::ship(&client, &model.clone().into())
            .await
            .unwrap();
        let scene = messages::encode(Body::Scene(shipped.scene(settings, job, 0)));
        sender.send(&worker, scene).await.unwrap();

        // Its WorkerError and its exit, in whichever order remd delivers them.
        let mut message = None;
        let mut exited = None;
        tokio::time::timeout(STEP, async {
            while message.is_none() || exited.is_none() {
                match receiver.recv().await.unwrap() {
                    Incoming::Message { from, payload } if from == worker.as_str() => {
                        if let Ok(Body::WorkerError(e)) = messages::decode(&payload) {
                            message = Some(e.message);
                        }
                    }
                    Incoming::Event(e) if e.kind() == EventKind::Exited => exited = Some(e),
                    Incoming::Event(e) if e.kind() == EventKind::Lost => {
                        panic!("the worker was lost: {e:?}")
                    }
                    _ => {}
                }
            }
        })
        .await
        .unwrap_or_else(|_| {
            panic!("no WorkerError and exit within {STEP:?}: message {message:?}, exit {exited:?}")
        });
        let logs = client.logs(&worker).await.unwrap();
        Refusal {
            message: message.unwrap(),
            exited: exited.unwrap(),
            stderr: String::from_utf8_lossy(&logs.stderr).into_owned(),
        }
    })
}

/// The worker ended with exit code 1 (an error), not a signal (an abort or a stack overflow),
/// and said why on one line, without a panic.
fn assert_clean_refusal(r: &Refusal, field: &str, value: &str) {
    assert!(
        r.message.contains(field) && r.message.contains(value) && !r.message.contains('\n'),
        "WorkerError {:?} does not name {field} = {value} on one line",
        r.message
    );
    assert_eq!(
        (r.exited.exit_code, r.exited.signal),
        (Some(1), None),
        "the worker did not exit with code 1: {:?}; stderr: {}",
        r.exited,
        r.stderr
    );
    assert!(!r.stderr.contains("panicked"), "{}", r.stderr);
    assert!(r.stderr.contains(field), "stderr: {}", r.stderr);
}

#[test]
fn a_worker_sent_width_u32_max_says_so_and_exits_with_a_code() {
    let (_, settings) = scene_and_settings();
    let mut p = settings.to_proto();
    p.width = u32::MAX;
    let r = refusal("bounds-width", p);
    assert_clean_refusal(&r, "width", "4294967295");
    assert!(r.message.contains("16384"), "{}", r.message);
}

#[test]
fn a_worker_sent_a_huge_depth_and_a_negative_weight_says_so_and_exits_with_a_code() {
    let (_, settings) = scene_and_settings();
    let mut p = settings.to_proto();
    p.max_depth = 1_000_000_000;
    p.min_weight = -1.0;
    let r = refusal("bounds-depth", p);
    // The first field out of bounds is the one named.
    assert_clean_refusal(&r, "max_depth", "1000000000");
    assert!(r.message.contains("1..=64"), "{}", r.message);

    let mut p = settings.to_proto();
    p.min_weight = -1.0;
    let r = refusal("bounds-weight", p);
    assert_clean_refusal(&r, "min_weight", "-1");
}
