//! What a publication holds and when it is due, on a store in memory.

use super::*;
use crate::distrib::checkpoint::tests::MemStore;

fn store(limit: usize) -> MemStore {
    MemStore {
        limit,
        ..Default::default()
    }
}

fn page(store: &MemStore) -> Value {
    serde_json::from_slice(&store.map.lock().unwrap()[&json_key("j")]).unwrap()
}

fn png(store: &MemStore) -> image::RgbImage {
    let bytes = store.map.lock().unwrap()[&png_key("j")].clone();
    image::load_from_memory(&bytes).unwrap().to_rgb8()
}

#[test]
fn a_fault_is_a_line_for_people_and_chatty_events_are_not() {
    let mut v = WebView::new("j", Vec::new());
    v.on_event(&json!({"event": "fault", "node": 2, "host": "c",
        "reason": "host c lost", "given_back": 3}));
    v.on_event(&json!({"event": "silent", "node": 1, "host": "b", "given_back": 1}));
    for chatty in ["line", "assign", "checkpoint", "progress", "bad-line"] {
        v.on_event(&json!({"event": chatty, "node": 1, "line": 4, "done": 5}));
    }
    let got: Vec<(&str, &str)> = v.events().map(|e| (&*e.kind, &*e.text)).collect();
    assert_eq!(
        got,
        [
            (
                "fault",
                "node 2 on c failed: host c lost; 3 lines given back"
            ),
            ("silent", "node 1 on b went silent; 1 line given back"),
        ]
    );
}

#[test]
fn the_history_keeps_the_last_100_events() {
    let old = (0..150)
        .map(|i| Event::now("spawned", &format!("e{i}")))
        .collect();
    let mut v = WebView::new("j", old);
    assert_eq!(v.events().count(), MAX_EVENTS);
    assert_eq!(v.events().next().unwrap().text, "e50");
    v.on_event(&json!({"event": "finished", "done": 96}));
    assert_eq!(v.events().count(), MAX_EVENTS);
    assert_eq!(v.events().next().unwrap().text, "e51");
    assert_eq!(v.events().last().unwrap().text, "finished: 96 lines in");
    v.on_event(&json!({"event": "not-stored", "done": 96}));
    let last = v.events().last().unwrap();
    assert_eq!(last.kind, "not-stored");
    assert!(last.text.ends_with("refused the last save: not finished"));
    let long = Event::now("fault", &"é".repeat(1000));
    assert_eq!(
        WebView::new("j", vec![long])
            .events()
            .next()
            .unwrap()
            .text
            .chars()
            .count(),
        300
    );
}

#[tokio::test]
async fn a_new_controller_carries_the_history_of_its_job_on() {
    let s = store(1 << 20);
    // An earlier job of the same id left its page; submitting the new one replaces it.
    let old = json!({"events": [{"unix_ms": 1, "kind": "controller", "text": "old"}]});
    s.put(&json_key("j"), serde_json::to_vec(&old).unwrap())
        .await
        .unwrap();
    submitted(&s, "j", "a.nff 3000x20", 2, (3000, 20))
        .await
        .unwrap();
    let p = page(&s);
    assert_eq!(p["nodes"]["rows"], json!([]));
    let want = json!({"width": 3000, "height": 20, "lines": 0, "full": false,
        "png_width": 1000, "png_height": 7});
    assert_eq!(p["image"], want);
    assert_eq!(png(&s).dimensions(), (1000, 7));
    // The job's first controller, though a reused id's epoch is above 1.
    let h = history(&s, "j", "b", 4).await;
    let texts: Vec<&str> = h.iter().map(|e| &*e.text).collect();
    assert_eq!(
        texts,
        [
            "submitted: a.nff 3000x20, 2 worker(s)",
            "controller started on b, epoch 4"
        ]
    );
    // Its successor: the history goes on.
    let mut v = WebView::new("j", h);
    v.on_event(&json!({"event": "failed", "done": 1}));
    v.publish(&s, &[], &Film::new(3000, 20), 1, true)
        .await
        .unwrap();
    let h = history(&s, "j", "c", 5).await;
    assert_eq!(h.len(), 4);
    assert_eq!(h[3].text, "controller moved to c, epoch 5");
    let first = history(&store(1 << 20), "k", "b", 1).await;
    assert_eq!(first.len(), 1);
    assert_eq!(first[0].text, "controller started on b, epoch 1");
}

#[tokio::test(start_paused = true)]
async fn the_page_holds_the_table_the_events_and_the_image_so_far() {
    let s = store(1 << 20);
    let mut film = Film::new(64, 96);
    for y in 0..40 {
        film.set_line(y, &[[0.5, 0.5, 0.5]; 64]);
    }
    let node = NodeStats {
        node: 1,
        host: "b".into(),
        outcome: Outcome::Ok,
        scanlines: 40,
        cpu_s: 1.23456,
        ..Default::default()
    };
    let mut v = WebView::new("j", vec![Event::now("controller", "started")]);
    v.set_timeline(&crate::distrib::timeline::Timeline {
        controller_started: Some(0.25),
        first_line: Some(0.5),
        ..Default::default()
    });
    let t0 = Instant::now();
    assert!(v.due(t0, 40), "the first is due at once");
    v.publish(&s, &[node], &film, 40, false).await.unwrap();
    let p = page(&s);
    assert_eq!(
        p["timeline"],
        json!([["controller", 0.25], ["first line", 0.5]])
    );
    assert_eq!(p["nodes"]["columns"].as_array().unwrap().len(), 9);
    assert_eq!(
        p["nodes"]["rows"][0],
        json!([1, "b", "ok", 40, 0, 0, 0, 1.23, 0.0])
    );
    assert_eq!(p["events"][0]["kind"], "controller");
    assert!(p["events"][0]["unix_ms"].as_u64().unwrap() > 0);
    let want = json!({"width": 64, "height": 96, "lines": 40, "full": false,
        "png_width": 64, "png_height": 96});
    assert_eq!(p["image"], want);
    let img = png(&s);
    assert_eq!(img.dimensions(), (64, 96));
    assert_eq!(img.get_pixel(3, 39).0, [128; 3]);
    assert_eq!(img.get_pixel(3, 40).0, [0; 3], "a line not yet in is black");
    // At most once a second, and only when something changed.
    assert!(!v.due(t0 + Duration::from_millis(500), 41));
    assert!(!v.due(t0 + EVERY, 40));
    assert!(v.due(t0 + EVERY, 41));
    v.on_event(&json!({"event": "silent", "node": 1, "host": "b", "given_back": 0}));
    assert!(v.due(t0 + EVERY, 40));
}

/// A `width` x 10 image of noise (a PNG that does not compress).
fn noise(width: u32) -> Film {
    let mut f = Film::new(width, 10);
    let mut x = 12345u32;
    for p in &mut f.pixels {
        *p = [0; 3].map(|_| {
            x = x.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (x >> 8) as f32 / (1u32 << 24) as f32
        });
    }
    f
}

#[tokio::test(start_paused = true)]
async fn a_large_image_is_shrunk_while_running_and_whole_at_the_end_if_it_fits() {
    let film = noise(2000);
    // A failure (the store takes nothing) is reported once; the next try waits for RETRY.
    let refusing = store(0);
    let mut v = WebView::new("j", Vec::new());
    assert!(v.publish(&refusing, &[], &film, 1, false).await.is_err());
    let t = Instant::now();
    assert!(!v.due(t + EVERY, 2) && v.due(t + RETRY, 2));
    assert!(
        v.publish(&refusing, &[], &film, 2, true).await.is_ok(),
        "not again"
    );
    let big = store(1 << 20);
    let mut v = WebView::new("j", Vec::new());
    v.publish(&big, &[], &film, 10, false).await.unwrap();
    assert_eq!(png(&big).dimensions(), (1000, 5));
    assert_eq!(page(&big)["image"]["png_width"], 1000);
    v.publish(&big, &[], &film, 10, true).await.unwrap();
    assert_eq!(png(&big).dimensions(), (2000, 10));
    assert_eq!(page(&big)["image"]["full"], true);
    // 60,000 bytes of noise do not fit 30,000; the shrunk image (15,000) does.
    let small = store(30_000);
    let mut v = WebView::new("j", Vec::new());
    v.publish(&small, &[], &film, 10, true).await.unwrap();
    assert_eq!(png(&small).dimensions(), (1000, 5));
    assert_eq!(page(&small)["image"]["full"], false);
}

/// Another picture (a job rendered to an error publishes its samples map) is stored under its
/// own key before the page's data, which names it with its caption; sized as the image is.
#[tokio::test(start_paused = true)]
async fn another_picture_is_stored_and_named_in_the_page() {
    let s = store(1 << 20);
    let mut v = WebView::new("j", Vec::new());
    let film = noise(2000);
    let mut map = Film::new(2000, 10);
    map.pixels[0] = [1.0; 3];
    let mut p = v.take_due(&[], &film, (10, true), s.max_bytes()).unwrap();
    p.add_view(("samples", "samples per pixel"), &map, true, s.max_bytes());
    p.write(&s).await.unwrap();
    let views = &page(&s)["image"]["views"];
    assert_eq!(
        *views,
        json!([{"name": "samples", "caption": "samples per pixel"}])
    );
    let bytes = s.map.lock().unwrap()[&view_key("j", "samples")].clone();
    let got = image::load_from_memory(&bytes).unwrap().to_rgb8();
    assert_eq!(got.dimensions(), (2000, 10));
    assert_eq!(got.get_pixel(0, 0).0, [255; 3]);
    assert_eq!(got.get_pixel(1, 0).0, [0; 3]);
    // Without one, the page names none.
    let mut v = WebView::new("k", Vec::new());
    v.publish(&s, &[], &film, 10, false).await.unwrap();
    let page_k: Value = serde_json::from_slice(&s.map.lock().unwrap()[&json_key("k")]).unwrap();
    assert!(page_k["image"].get("views").is_none());
}
