//! The store writer's mailboxes: a publication or a save not yet begun is replaced by a newer
//! one (so a slow store never builds a queue), and the lines finished meanwhile add up.

use super::super::store_writer::{Report, StoreWriter};
use super::{spec, FakeLink, JOB};
use crate::distrib::checkpoint::{self, Checkpointer};
use crate::distrib::messages::{self, proto};
use crate::distrib::web_view::{json_key, png_key, WebView};
use crate::film::Film;
use std::sync::Arc;
use std::time::Duration;

fn line(n: u32) -> proto::FinishedLine {
    proto::FinishedLine {
        line: n,
        pixels: messages::pixels_to_bytes(&vec![[n as f32; 3]; super::WIDTH as usize]),
        counters: None,
        ..Default::default()
    }
}

/// A writer on a store whose every write takes `takes`.
fn slow_writer(height: u32, takes: Duration) -> (FakeLink, StoreWriter) {
    let link = FakeLink::default();
    link.0.lock().unwrap().put_takes = takes;
    let checkpointer = Checkpointer::new(JOB, spec(height), 7, None);
    let writer = StoreWriter::start(Arc::new(link.clone()), checkpointer, None);
    (link, writer)
}

#[tokio::test(start_paused = true)]
async fn a_publication_not_yet_begun_is_replaced_by_the_newest() {
    // Within the web view's time for a write.
    let (link, mut writer) = slow_writer(8, Duration::from_secs(1));
    let mut view = WebView::new(JOB, Vec::new());
    for lines in 1..=4 {
        let p = view
            .take_due(&[], &Film::new(4, 8), (lines, true), 1 << 20)
            .unwrap();
        writer.publish(p);
        tokio::time::sleep(Duration::from_millis(1)).await;
    }
    let reports = writer.close().await;
    assert_eq!(reports.len(), 2, "{reports:?}");
    let puts = link.0.lock().unwrap().puts.clone();
    let (png, json) = (png_key(JOB), json_key(JOB));
    assert_eq!(
        puts,
        [png.clone(), json.clone(), png, json.clone()],
        "the first and the last"
    );
    let page: serde_json::Value =
        serde_json::from_slice(&link.0.lock().unwrap().store[&json]).unwrap();
    assert_eq!(page["image"]["lines"], 4);
}

#[tokio::test(start_paused = true)]
async fn lines_add_up_while_saves_wait_and_a_replaced_save_is_not_answered() {
    let (link, mut writer) = slow_writer(8, Duration::from_secs(10));
    (0..3).for_each(|n| writer.record(line(n), true));
    let first = writer.save("running");
    tokio::time::sleep(Duration::from_millis(1)).await;
    (3..5).for_each(|n| writer.record(line(n), true));
    let replaced = writer.save("running");
    let last = writer.save("finished");
    let reports = writer.close().await;
    let answered: Vec<_> = reports
        .iter()
        .map(|r| match r {
            Report::Saved {
                id, state, lines, ..
            } => (*id, state.clone(), *lines),
            other => panic!("{other:?}"),
        })
        .collect();
    assert_eq!(
        answered,
        [(first, "running".into(), 3), (last, "finished".into(), 5)],
        "save {replaced} was replaced"
    );
    let stored = checkpoint::load(&link, JOB).await.unwrap().unwrap();
    assert_eq!(stored.lines.len(), 5);
    assert_eq!(stored.header.state, "finished");
}
