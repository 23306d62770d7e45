//! `sunray submit` on three real remd daemons on loopback gives a PNG byte-identical to
//! `sunray render`, with every strategy, and its statistics count every line exactly once.
//! Also: the embedded default (no remd) and the built-in scene, and a PLY mesh.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a test: a failed unwrap is a failed test

use sunray_e2e::bins::sunray;
use sunray_e2e::fixtures::{default_scene, spd};
use sunray_e2e::reference::{output, read_json, reference};
use sunray_e2e::remd::LoopbackCluster;

/// Submits `scene` with `strategy` and checks the image and the statistics.
fn identical(cluster: &LoopbackCluster, scene: &str, strategy: &str) {
    let dir = tempfile::tempdir().unwrap();
    let flags = ["--resolution", "64x64"];
    let (want, want_stats) = reference(dir.path(), &spd(scene), &flags);
    let out = dir.path().join("submit.png");
    let json = dir.path().join("submit.json");
    let st = output(
        cluster
            .submit()
            .args(["--hosts", "3", "--strategy", strategy, "-q"])
            .args(flags)
            .arg(spd(scene))
            .arg("-o")
            .arg(&out)
            .arg("--stats-json")
            .arg(&json),
    );
    assert!(st.status.success(), "{scene} {strategy}");
    assert!(
        std::fs::read(&out).unwrap() == want,
        "{scene} with {strategy}: the image differs from sunray render"
    );
    let s = read_json(&json);
    let nodes = s["nodes"].as_array().unwrap();
    assert_eq!(nodes.len(), 3);
    let hosts: std::collections::BTreeSet<&str> =
        nodes.iter().map(|n| n["host"].as_str().unwrap()).collect();
    assert_eq!(hosts.len(), 3, "one worker per host: {hosts:?}");
    let lines: u64 = nodes.iter().map(|n| n["scanlines"].as_u64().unwrap()).sum();
    assert_eq!(lines, 64, "every line accepted exactly once");
    // The statistics are those of the moment the image was stored: a worker may not have
    // said Ready by then ("starting"); none failed or went silent.
    for n in nodes {
        assert!(n["outcome"] == "ok" || n["outcome"] == "starting", "{n}");
        if n["outcome"] == "ok" {
            assert!(n["cores"].as_u64().unwrap() >= 1, "{n}");
        }
    }
    assert_eq!(s["lines"]["rendered"], 64);
    // Counted, not estimated: the totals are those of the local render.
    for key in [
        "/rays/eye",
        "/rays/shadow",
        "/rays/reflected",
        "/rays/refracted",
        "/intersection_tests",
    ] {
        assert_eq!(
            s["totals"].pointer(key),
            want_stats.pointer(key),
            "{scene} {strategy} {key}"
        );
    }
    if strategy == "blocks" {
        // SunRay I: each node renders its own contiguous band, about a third.
        for n in nodes {
            let l = n["scanlines"].as_u64().unwrap();
            assert!((21..=22).contains(&l), "{n}");
        }
    }
}

#[test]
fn tetra6_and_mount6_on_three_daemons_with_every_strategy() {
    let cluster = LoopbackCluster::start(3);
    for scene in ["tetra6", "mount6"] {
        for strategy in ["dynamic", "blocks", "interleaved"] {
            identical(&cluster, scene, strategy);
        }
    }
}

#[test]
fn the_embedded_default_renders_the_built_in_scene() {
    let dir = tempfile::tempdir().unwrap();
    let flags = ["--resolution", "48x40", "--samples", "2"];
    let (want, _) = reference(dir.path(), &default_scene(), &flags);
    let out = dir.path().join("default.png");
    let json = dir.path().join("default.json");
    // No --remd and no REM_ADDR: a private remd and two local worker processes.
    let st = output(
        sunray()
            .current_dir(dir.path())
            .env("SUNRAY_STATE_DIR", dir.path().join("state"))
            .args(["submit", "--hosts", "2", "--nice"])
            .args(flags)
            .arg("-o")
            .arg(&out)
            .arg("--stats-json")
            .arg(&json),
    );
    assert!(st.status.success());
    let table = String::from_utf8_lossy(&st.stderr);
    assert!(
        table.contains("intersections") && table.contains("local"),
        "{table}"
    );
    assert!(
        std::fs::read(&out).unwrap() == want,
        "differs from sunray render"
    );
    let s = read_json(&json);
    assert_eq!(s["nodes"].as_array().unwrap().len(), 2);
    assert_eq!(s["lines"]["rendered"], 40);

    // The job is listed by `sunray jobs` on the same private state.
    let jobs = output(
        sunray()
            .env("SUNRAY_STATE_DIR", dir.path().join("state"))
            .args(["jobs", "--json"]),
    );
    assert!(jobs.status.success());
    let listed: serde_json::Value = serde_json::from_slice(&jobs.stdout).unwrap();
    let job = s["job"].as_str().unwrap();
    let entry = listed
        .as_array()
        .unwrap()
        .iter()
        .find(|j| j["job"] == job)
        .unwrap_or_else(|| panic!("{job} not in {listed}"));
    assert_eq!(entry["state"], "finished");
    assert_eq!(entry["lines_done"], 40);
}

/// `sunray submit --hosts HOSTS -q ARGS SCENE -o OUT` on `cluster`, which must succeed: the
/// image's bytes.
fn submitted(
    cluster: &LoopbackCluster,
    hosts: &str,
    args: &[&str],
    scene: &std::path::Path,
    out: &std::path::Path,
) -> Vec<u8> {
    let st = output(
        cluster
            .submit()
            .args(["--hosts", hosts, "-q"])
            .args(args)
            .arg(scene)
            .arg("-o")
            .arg(out),
    );
    assert!(
        st.status.success(),
        "{}",
        String::from_utf8_lossy(&st.stderr)
    );
    std::fs::read(out).unwrap()
}

#[test]
fn a_ply_mesh_goes_through_the_farm_identical_to_sunray_render() {
    let cluster = LoopbackCluster::start(2);
    let dir = tempfile::tempdir().unwrap();
    let ply = dir.path().join("teapot.ply");
    let st = sunray()
        .args(["spd", "teapot", "--size", "2", "-o"])
        .arg(&ply)
        .status()
        .unwrap();
    assert!(st.success());
    let flags = ["--resolution", "48x48"];
    let (want, _) = reference(dir.path(), &ply, &flags);
    let out = dir.path().join("submit.png");
    assert!(
        submitted(&cluster, "2", &flags, &ply, &out) == want,
        "the PLY's image through the farm differs from sunray render"
    );
}

/// Rendering to an error: `--target-error` through the farm (a line and pass at a time) on
/// one, two and three hosts gives `sunray render`'s bytes (each pixel's samples depend only
/// on its own), with the same (adaptive) eye-ray count, error statistics and samples map; a
/// bad target is refused before any worker starts. `--sampler sobol` goes through it too.
#[test]
fn a_target_error_goes_through_the_farm_identical_to_sunray_render() {
    let cluster = LoopbackCluster::start(3);
    let dir = tempfile::tempdir().unwrap();
    let flags = [
        "--resolution",
        "40x32",
        "--target-error",
        "0.03",
        "--max-samples",
        "64",
    ];
    let want_map = dir.path().join("reference-map.png");
    let map_flag = ["--samples-map", want_map.to_str().unwrap()];
    let (want, want_stats) = reference(
        dir.path(),
        &default_scene(),
        &[&flags[..], &map_flag].concat(),
    );
    let eye = want_stats["rays"]["eye"].as_u64().unwrap();
    assert!(
        eye > 16 * 40 * 32,
        "some pixels took more than min-samples: {eye}"
    );
    assert!(want_stats["error"]["mean_samples"].as_f64().unwrap() > 16.0);
    for hosts in ["1", "2", "3"] {
        let out = dir.path().join(format!("submit-{hosts}.png"));
        let json = dir.path().join(format!("submit-{hosts}.json"));
        let map = dir.path().join(format!("submit-{hosts}-map.png"));
        let args = [
            &flags[..],
            &["--stats-json", json.to_str().unwrap()],
            &["--samples-map", map.to_str().unwrap()],
        ]
        .concat();
        assert!(
            submitted(&cluster, hosts, &args, &default_scene(), &out) == want,
            "{hosts} hosts: differs from sunray render"
        );
        let stats = read_json(&json);
        assert_eq!(stats["totals"]["rays"]["eye"], eye, "{hosts} hosts");
        assert_eq!(
            stats["totals"]["error"], want_stats["error"],
            "{hosts} hosts"
        );
        assert!(
            std::fs::read(&map).unwrap() == std::fs::read(&want_map).unwrap(),
            "{hosts} hosts: the samples map differs from sunray render's"
        );
        // `sunray fetch` gives both again from the job's checkpoint, whose finished lines
        // are settled (pixels and what each took, not the estimates).
        let job = stats["job"].as_str().unwrap();
        let (fetched, fetched_map) = (dir.path().join("f.png"), dir.path().join("f-map.png"));
        let st = output(
            cluster
                .sunray_via("a")
                .args(["fetch", job, "-o"])
                .arg(&fetched)
                .arg("--samples-map")
                .arg(&fetched_map),
        );
        assert!(
            st.status.success(),
            "{}",
            String::from_utf8_lossy(&st.stderr)
        );
        assert!(
            std::fs::read(&fetched).unwrap() == want,
            "{hosts} hosts: fetched"
        );
        assert!(
            std::fs::read(&fetched_map).unwrap() == std::fs::read(&want_map).unwrap(),
            "{hosts} hosts: the fetched samples map"
        );
    }
    // A scene's own `target_error(E)` goes through the farm as the flag does.
    let scene = dir.path().join("asks.yari");
    let text = std::fs::read_to_string(default_scene()).unwrap();
    std::fs::write(&scene, format!("target_error(0.05);\n{text}")).unwrap();
    let small = ["--resolution", "24x20"];
    let (want, _) = reference(dir.path(), &scene, &small);
    let out = dir.path().join("asks.png");
    assert!(
        submitted(&cluster, "2", &small, &scene, &out) == want,
        "the scene's target error through the farm"
    );
    // A fixed count from Sobol sequences (`--sampler sobol`) goes through the farm too, and
    // is not the stratified image.
    let sobol = [
        "--resolution",
        "24x20",
        "--samples",
        "8",
        "--sampler",
        "sobol",
    ];
    let (want, _) = reference(dir.path(), &default_scene(), &sobol);
    let out = dir.path().join("sobol.png");
    assert!(
        submitted(&cluster, "2", &sobol, &default_scene(), &out) == want,
        "--sampler sobol through the farm"
    );
    let (stratified, _) = reference(dir.path(), &default_scene(), &sobol[..4]);
    assert!(stratified != want, "--sampler sobol renders other samples");
    let st = output(
        cluster
            .submit()
            .args(["--hosts", "2", "-q", "--target-error=-1"])
            .arg(default_scene())
            .arg("-o")
            .arg(dir.path().join("bad.png")),
    );
    assert!(!st.status.success());
    assert!(String::from_utf8_lossy(&st.stderr).contains("--target-error must be a number above 0"));
    assert!(!dir.path().join("bad.png").exists());
}
