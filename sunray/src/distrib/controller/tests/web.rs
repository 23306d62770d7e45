//! What the controller publishes for remd's web view: `JOB.web.json` and `JOB.web.png`
//! through its link when the job has a web view, nothing when it has none.

use super::{FakeLink, Job, JOB, WIDTH};
use crate::distrib::web_view::{json_key, png_key, Event};
use serde_json::Value;
use std::time::Duration;

impl FakeLink {
    fn stored(&self, key: &str) -> Option<Vec<u8>> {
        self.0.lock().unwrap().store.get(key).cloned()
    }

    fn page(&self) -> Value {
        serde_json::from_slice(&self.stored(&json_key(JOB)).unwrap()).unwrap()
    }
}

#[tokio::test(start_paused = true)]
async fn a_published_job_shows_its_table_its_history_and_its_image() {
    let earlier = Event::now("controller", "controller moved to h9, epoch 2");
    let job = Job::launch(FakeLink::default(), 12, 2, None, Some(vec![earlier]));
    job.ready(0, 3).await;
    job.ready(1, 3).await;
    // Published at the start, and again within a second of a change.
    tokio::time::sleep(Duration::from_millis(150)).await;
    assert_eq!(job.link.page()["image"]["lines"], 0);
    let held = job.link.take_grants(&job.procs[0]);
    job.exits(0, None, Some(9)).await;
    job.serve_until_done(1).await;
    let (r, link) = job.end().await;
    assert!(r.finished);
    let page = link.page();
    let rows = page["nodes"]["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 2);
    assert_eq!(rows[0][2], "fault");
    // The survivor rendered every line (and, never exiting here, was killed at the end).
    assert_eq!((&rows[1][2], &rows[1][3]), (&"silent".into(), &12.into()));
    let kinds: Vec<&str> = page["events"]
        .as_array()
        .unwrap()
        .iter()
        .map(|e| e["kind"].as_str().unwrap())
        .collect();
    assert_eq!(
        kinds,
        [
            "controller",
            "spawned",
            "spawned",
            "ready",
            "ready",
            "fault",
            "finished"
        ]
    );
    let fault = &page["events"][5]["text"];
    let want = format!(
        "node 1 on h0 failed: killed by signal 9; {} lines given back",
        held.len()
    );
    assert_eq!(fault, &Value::from(want));
    let want = serde_json::json!({"width": WIDTH, "height": 12, "lines": 12, "full": true,
        "png_width": WIDTH, "png_height": 12});
    assert_eq!(page["image"], want);
    let png = image::load_from_memory(&link.stored(&png_key(JOB)).unwrap())
        .unwrap()
        .to_rgb8();
    assert_eq!(png.dimensions(), (WIDTH, 12));
    // Every pixel of line y is y (clamped to 1): line 5 is white, line 0 black.
    assert_eq!(png.get_pixel(1, 5).0, [255; 3]);
    assert_eq!(png.get_pixel(1, 0).0, [0; 3]);
}

#[tokio::test(start_paused = true)]
async fn a_job_without_a_web_view_publishes_nothing() {
    let job = Job::start(6, 1, None);
    job.ready(0, 2).await;
    job.serve_until_done(0).await;
    let (r, link) = job.end().await;
    assert!(r.finished);
    let store = &link.0.lock().unwrap().store;
    assert!(
        store.keys().all(|k| !k.contains(".web.")),
        "{:?}",
        store.keys()
    );
    assert!(store.contains_key(JOB), "the checkpoint is there");
}
