//! remd's web view (`remd --web`) on real daemons running a real farm job: the JSON API and
//! its authentication over HTTP, and the page itself in a headless Chromium (hosts listed,
//! the job's progress moving, its image filling in, a killed worker host shown lost with a
//! fault in the job's events). The browser leaves screenshots in `target/web-screenshots`.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a test: a failed unwrap is a failed test

use std::time::{Duration, Instant};
use sunray_e2e::fixtures::spd;
use sunray_e2e::reference::{reference, succeed};
use sunray_e2e::remd::{LoopbackCluster, SECRET};
use sunray_e2e::web::{chromedriver, chromium, Auth, Page, WebClient};

/// A detached job of alice's on mount6, each line taking at least `delay_ms`.
fn submit(cluster: &LoopbackCluster, job: &str, size: &str, delay_ms: u32) {
    submit_with(cluster, job, &["--resolution", size], delay_ms);
}

/// [`submit`] with `flags` (the resolution among them).
fn submit_with(cluster: &LoopbackCluster, job: &str, flags: &[&str], delay_ms: u32) {
    succeed(
        cluster
            .submit()
            .env("REM_USER", "alice")
            .env("SUNRAY_WORKER_LINE_DELAY_MS", delay_ms.to_string())
            .args(["--detach", "--hosts", "2", "--checkpoint-ms", "200"])
            .args(["--job", job])
            .args(flags)
            .arg(spd("mount6")),
    );
}

/// A small job rendered to an error: it publishes its samples map beside its image.
const TO_ERROR: [&str; 6] = [
    "--resolution",
    "32x24",
    "--target-error",
    "0.05",
    "--max-samples",
    "64",
];

fn secret() -> rem::Secret {
    rem::Secret::new(SECRET).unwrap()
}

fn token(user: &str) -> String {
    secret().client_key_line(user).unwrap()
}

/// The job `id` in a `/api/jobs` reply.
fn listed<'a>(jobs: &'a serde_json::Value, id: &str) -> Option<&'a serde_json::Value> {
    jobs["jobs"]
        .as_array()
        .unwrap()
        .iter()
        .find(|j| j["id"] == id)
}

#[test]
fn the_api_needs_a_credential_and_shows_each_user_only_their_jobs() {
    let cluster = LoopbackCluster::start_web(2);
    let web = WebClient::new(&cluster.web_url());

    // The page itself is public (it asks for a login), hardened by its headers.
    let page = web.get("/", &Auth::None);
    assert_eq!(page.status, 200);
    assert!(page.text().contains("<title>REM farm</title>"));
    assert!(page.csp.unwrap().contains("script-src 'self'"));

    // No credential, a wrong one, a stale cookie: 401 everywhere in the API.
    let junk = [
        Auth::None,
        Auth::Bearer("nope".into()),
        Auth::Bearer(
            rem::Secret::new("another")
                .unwrap()
                .client_key_line("alice")
                .unwrap(),
        ),
        Auth::Bearer(SECRET.into()),
        Auth::Cookie {
            id: "0".repeat(64),
            csrf: None,
        },
    ];
    for auth in &junk {
        for path in [
            "/api/session",
            "/api/hosts",
            "/api/jobs",
            "/api/jobs/x",
            "/api/jobs/x/image.png",
            "/api/stream",
        ] {
            assert_eq!(web.get(path, auth).status, 401, "GET {path} with {auth:?}");
        }
        assert_eq!(web.post("/api/jobs/x/cancel", auth).status, 401);
    }

    // The login form: a wrong token goes back to the form; another site's page cannot log
    // anyone in; an oversized body is refused.
    let failed = web.post_login("rem-client-key-v2:alice:00", None);
    assert_eq!(
        (failed.status, failed.location.as_deref()),
        (303, Some("/?login=failed"))
    );
    assert!(failed.set_cookie.is_none());
    assert_eq!(
        web.post_login(&token("alice"), Some("http://evil.example"))
            .status,
        403
    );
    assert_eq!(web.post_login(&"x".repeat(20_000), None).status, 413);

    let alice = web.login(&token("alice"));
    let session = web.get("/api/session", &alice).json();
    assert_eq!(
        (session["user"].as_str(), session["admin"].as_bool()),
        (Some("alice"), Some(false))
    );
    let hosts = web.wait_json(
        "/api/hosts",
        &alice,
        "two hosts alive",
        Duration::from_secs(10),
        |v| {
            v["hosts"]
                .as_array()
                .unwrap()
                .iter()
                .filter(|h| h["alive"] == true)
                .count()
                == 2
        },
    );
    let a = &hosts["hosts"][0];
    assert_eq!(a["name"], "a");
    assert!(a["cores"].as_u64().unwrap() >= 1 && a["mem_total_bytes"].as_u64().unwrap() > 0);
    assert_eq!(
        a["slots"], a["cores"],
        "a host lends its cores by default: {a}"
    );

    // alice's job, followed through the API to its end.
    submit(&cluster, "web1", "64x96", 20);
    let bob = Auth::Bearer(token("bob"));
    let admin = Auth::Bearer(rem::daemon::web::login::admin_token(&secret()).unwrap());
    let jobs = web.wait_json(
        "/api/jobs",
        &alice,
        "web1 listed",
        Duration::from_secs(20),
        |v| listed(v, "web1").is_some(),
    );
    let row = listed(&jobs, "web1").unwrap();
    assert_eq!(
        (row["user"].as_str(), row["total"].as_u64()),
        (Some("alice"), Some(96))
    );
    assert!(row["title"].as_str().unwrap().contains("mount6"), "{row}");
    // Its place in the farm's queue: it runs (no place), at the default priority.
    assert_eq!(
        (row["priority"].as_u64(), &row["queue_position"]),
        (Some(50), &serde_json::Value::Null),
        "{row}"
    );

    // bob sees nothing of it, not even that it exists; the admin sees it.
    assert!(listed(&web.get("/api/jobs", &bob).json(), "web1").is_none());
    for path in ["/api/jobs/web1", "/api/jobs/web1/image.png"] {
        assert_eq!(web.get(path, &bob).status, 404, "bob: GET {path}");
    }
    assert_eq!(web.post("/api/jobs/web1/cancel", &bob).status, 404);
    let seen = web.wait_json(
        "/api/jobs",
        &admin,
        "the admin sees web1",
        Duration::from_secs(10),
        |v| listed(v, "web1").is_some(),
    );
    assert_eq!(listed(&seen, "web1").unwrap()["user"], "alice");

    // Finished: the image is the job's, as `sunray render` makes it; the published view has
    // the per-node table and the events.
    let done = web.wait_json(
        "/api/jobs/web1",
        &alice,
        "web1 finished",
        Duration::from_secs(60),
        |v| v["job"]["state"] == "finished" && v["published"]["view"]["image"]["full"] == true,
    );
    let view = &done["published"]["view"];
    let columns = view["nodes"]["columns"].as_array().unwrap();
    assert!(columns.iter().any(|c| c == "host"), "{view}");
    assert_eq!(view["nodes"]["rows"].as_array().unwrap().len(), 2, "{view}");
    let events = view["events"].as_array().unwrap();
    assert!(
        events
            .iter()
            .any(|e| e["text"].as_str().unwrap().contains("controller")),
        "{view}"
    );
    // And the job's timeline, to its end.
    let t = &view["timeline"];
    let steps: Vec<(&str, f64)> = t
        .as_array()
        .unwrap()
        .iter()
        .map(|s| (s[0].as_str().unwrap(), s[1].as_f64().unwrap()))
        .collect();
    let names: Vec<&str> = steps.iter().map(|s| s.0).collect();
    let names_wanted = [
        "model ready",
        "model stored",
        "controller",
        "first line",
        "last line",
        "image stored",
        "finished",
    ];
    assert_eq!(names, names_wanted, "{t}");
    assert!(steps.windows(2).all(|w| w[0].1 <= w[1].1), "{t}");
    let png = web.get("/api/jobs/web1/image.png", &alice);
    assert_eq!(
        (png.status, png.content_type.as_deref()),
        (200, Some("image/png"))
    );
    let dir = tempfile::tempdir().unwrap();
    let (want, _) = reference(dir.path(), &spd("mount6"), &["--resolution", "64x96"]);
    let got = image::load_from_memory(&png.body).unwrap().to_rgb8();
    let want = image::load_from_memory(&want).unwrap().to_rgb8();
    assert_eq!(got.dimensions(), (64, 96));
    assert!(
        got == want,
        "the web view's image differs from sunray render's"
    );

    // A job rendered to an error also publishes its samples map, named in its view; at the
    // end it is `sunray render --samples-map`'s.
    submit_with(&cluster, "web3", &TO_ERROR, 0);
    let done = web.wait_json(
        "/api/jobs/web3",
        &alice,
        "web3 finished",
        Duration::from_secs(60),
        |v| v["job"]["state"] == "finished" && v["published"]["view"]["image"]["full"] == true,
    );
    let views = &done["published"]["view"]["image"]["views"];
    assert_eq!(views[0]["name"], "samples", "{views}");
    assert!(
        views[0]["caption"]
            .as_str()
            .unwrap()
            .contains("black 4, white 64"),
        "{views}"
    );
    let map = web.get("/api/jobs/web3/view/samples", &alice);
    assert_eq!(
        (map.status, map.content_type.as_deref()),
        (200, Some("image/png"))
    );
    let want_map = dir.path().join("map.png");
    let map_flag = ["--samples-map", want_map.to_str().unwrap()];
    reference(
        dir.path(),
        &spd("mount6"),
        &[&TO_ERROR[..], &map_flag].concat(),
    );
    let got = image::load_from_memory(&map.body).unwrap().to_rgb8();
    let want = image::open(&want_map).unwrap().to_rgb8();
    assert!(
        got == want,
        "the web view's samples map differs from render's"
    );
    for (path, who) in [
        ("/api/jobs/web3/view/samples", &bob),
        ("/api/jobs/web3/view/Samples", &alice),
        ("/api/jobs/web3/view/nodes", &alice),
        ("/api/jobs/web1/view/samples", &alice),
    ] {
        assert_eq!(web.get(path, who).status, 404, "GET {path}");
    }

    // Cancelling: a cookie without the CSRF token is refused; with it, the job is cancelled
    // and its processes end; twice is a conflict.
    submit(&cluster, "web2", "64x96", 400);
    web.wait_json(
        "/api/jobs",
        &alice,
        "web2 running",
        Duration::from_secs(20),
        |v| listed(v, "web2").is_some_and(|j| j["state"] == "running"),
    );
    let Auth::Cookie { id, .. } = &alice else {
        unreachable!()
    };
    let no_csrf = Auth::Cookie {
        id: id.clone(),
        csrf: None,
    };
    assert_eq!(web.post("/api/jobs/web2/cancel", &no_csrf).status, 403);
    let cancelled = web.post("/api/jobs/web2/cancel", &alice);
    assert_eq!(cancelled.status, 200, "{}", cancelled.text());
    assert_eq!(web.post("/api/jobs/web2/cancel", &alice).status, 409);
    let r = web.wait_json(
        "/api/jobs/web2",
        &alice,
        "web2 cancelled",
        Duration::from_secs(10),
        |v| v["job"]["state"] == "cancelled",
    );
    assert!(
        r["job"]["message"].as_str().unwrap().contains("web view"),
        "{r}"
    );
    let end = Instant::now() + Duration::from_secs(15);
    while cluster
        .processes()
        .iter()
        .any(|p| p.state == "running" && (p.job.starts_with("web2.") || p.job_record == "web2"))
    {
        assert!(Instant::now() < end, "web2's processes still run");
        std::thread::sleep(Duration::from_millis(200));
    }

    // Event streams: jobs arrive on them; at most 16 are open at once; logging out ends the
    // session.
    let (status, mut events) = web.stream("?job=web1", &alice);
    assert_eq!(status, 200);
    let mut kinds = std::collections::BTreeSet::new();
    while kinds.len() < 3 {
        let (name, data) = events.next_event().unwrap();
        if name == "jobs" {
            assert!(data.contains("\"web1\""), "{data}");
        }
        kinds.insert(name);
    }
    assert_eq!(
        kinds.into_iter().collect::<Vec<_>>(),
        ["hosts", "job", "jobs"]
    );
    let mut open = vec![events];
    for _ in 1..rem::daemon::web::MAX_STREAMS {
        let (status, s) = web.stream("", &alice);
        assert_eq!(status, 200);
        open.push(s);
    }
    assert_eq!(web.stream("", &alice).0, 503, "one stream too many");
    drop(open);
    assert_eq!(web.post("/logout", &no_csrf).status, 403);
    assert_eq!(web.post("/logout", &alice).status, 204);
    assert_eq!(web.get("/api/session", &alice).status, 401);
}

#[test]
fn the_page_shows_hosts_a_job_filling_in_and_a_lost_worker_host() {
    let (Some(browser), Some(_)) = (chromium(), chromedriver()) else {
        assert!(
            std::env::var_os("CI").is_none(),
            "no Chromium or ChromeDriver: .ci/run installs Debian's chromium and chromium-driver"
        );
        eprintln!("skipped: no chromium here (apt-get install chromium chromium-driver)");
        return;
    };
    // One render slot a host: a third job waits in the farm's queue (below).
    let mut cluster = LoopbackCluster::start_web_with(3, &["--slots", "1"]);
    submit(&cluster, "film", "128x96", 250);
    let page = Page::open(browser, &cluster.web_url());
    page.wait_for(
        "!document.getElementById('login').hidden",
        "the login form",
        Duration::from_secs(10),
    );
    page.login(&token("alice"));
    page.wait_for(
        "document.querySelectorAll('#hosts tbody tr[data-alive=\"true\"]').length === 3",
        "three hosts alive",
        Duration::from_secs(15),
    );

    // The job's row moves, and opening it shows its image and nodes.
    let done = "Number(document.querySelector('#jobs tr[data-job=\"film\"]')?.dataset.done ?? -1)";
    page.wait_for(
        &format!("{done} > 4"),
        "film under way",
        Duration::from_secs(30),
    );
    let before = page.eval(done).as_f64().unwrap();
    page.wait_for(
        &format!("{done} > {before}"),
        "film's progress moving",
        Duration::from_secs(15),
    );
    page.click("#jobs tr[data-job=\"film\"]");
    page.wait_for(
        "document.getElementById('job-image').naturalWidth === 128 && document.querySelectorAll('#nodes tbody tr').length === 2",
        "the job's image and its two nodes",
        Duration::from_secs(15),
    );
    page.screenshot("web-job-running.png");

    // Kill a host that runs one of its workers (not a, which serves the page).
    let worker_host = cluster
        .processes()
        .into_iter()
        .find(|p| p.state == "running" && p.job.starts_with("film.") && p.host != "a")
        .map(|p| p.host)
        .expect("a worker on b or c");
    cluster.kill_daemon(&worker_host);
    page.wait_for(
        &format!("document.querySelector('#hosts tr[data-host=\"{worker_host}\"]')?.dataset.alive === 'false'"),
        "the killed host lost",
        Duration::from_secs(15),
    );
    page.wait_for(
        "document.querySelectorAll('#events li.fault').length > 0",
        "a fault in the job's events",
        Duration::from_secs(20),
    );
    page.screenshot("web-worker-lost.png");
    page.wait_for(
        "document.getElementById('job').dataset.state === 'finished'",
        "the job finished",
        Duration::from_secs(90),
    );
    page.wait_for(
        "/^Timeline \\(seconds since submit\\): model ready [0-9.]+ s, model stored [0-9.]+ s, controller [0-9.]+ s, first line .*, finished [0-9.]+ s$/.test(document.getElementById('timeline').textContent)",
        "the job's timeline on its page",
        Duration::from_secs(15),
    );
    page.screenshot("web-job-finished.png");

    // A job rendered to an error offers its samples map beside its image.
    submit_with(&cluster, "refine", &TO_ERROR, 0);
    page.wait_for(
        "document.querySelector('#jobs tr[data-job=\"refine\"]')?.dataset.state === 'finished'",
        "the job rendered to an error listed, finished",
        Duration::from_secs(60),
    );
    page.click("#jobs tr[data-job=\"refine\"]");
    page.wait_for(
        "document.querySelector('#job-views button[data-view=\"samples\"]') !== null",
        "a button for the samples map",
        Duration::from_secs(15),
    );
    page.click("#job-views button[data-view=\"samples\"]");
    page.wait_for(
        "document.getElementById('job-image').dataset.view === 'samples' && document.getElementById('job-image').complete && document.getElementById('job-image').naturalWidth === 32 && document.getElementById('job-image-caption').textContent.startsWith('samples per pixel')",
        "the samples map shown",
        Duration::from_secs(15),
    );
    page.screenshot("web-samples-map.png");

    // The image the page shows is the finished one.
    let web = WebClient::new(&cluster.web_url());
    let png = web.get("/api/jobs/film/image.png", &Auth::Bearer(token("alice")));
    let got = image::load_from_memory(&png.body).unwrap().to_rgb8();
    let dir = tempfile::tempdir().unwrap();
    let (want, _) = reference(dir.path(), &spd("mount6"), &["--resolution", "128x96"]);
    assert!(got == image::load_from_memory(&want).unwrap().to_rgb8());

    // Two hosts are left, one slot each: two jobs hold them, the third waits, first in line.
    for job in ["busy1", "busy2", "waits"] {
        submit(&cluster, job, "64x96", 400);
    }
    page.wait_for(
        "document.querySelector('#jobs tr[data-job=\"waits\"]')?.dataset.queue === '1' && document.querySelector('#jobs tr[data-job=\"waits\"] td:nth-child(4)').textContent === 'queued #1'",
        "the third job queued, first in line",
        Duration::from_secs(30),
    );
    page.screenshot("web-queued.png");
}
