//! Scenes larger than a REM message through the farm: the model travels as REM chunks
//! named by their hash, each host caches what it fetched, and a second job of the same
//! scene ships nothing. tetra at size 9 (262,144 triangles) compiles to about 26 MB, over
//! REM's 16 MiB message limit, and at size 10 (1,048,576 triangles) to about 104 MB; both go
//! through real remd daemons at their default settings, and the 1M one through the embedded
//! default too. A host whose chunk cache sits on a full file system still renders the same
//! image. A host keeps the scene prepared (primitives and BVH) in its process cache, and a
//! later job maps it and fetches nothing; a damaged or cut prepared scene or BVH file is
//! made anew, and the image stays the same. A first job goes to the farm, as a user's does:
//! its end stops no keeper, so every host keeps the scene, whether its worker rendered or
//! not; the later jobs run their controller in the submitting process, whose end waits for
//! every host's figures ([`IN_PROCESS`]). The tests of this file take turns ([`heavy`]):
//! each starts workers that hold a million triangles, and the machine may have two cores.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a test: a failed unwrap is a failed test

use ::sunray::accel::cache::FILE_SUFFIX;
use std::path::{Path, PathBuf};
use std::sync::{Mutex, MutexGuard, OnceLock};
use sunray_e2e::bins::sunray;
use sunray_e2e::reference::{accel_figures, mapped_figures, reference, scene_figures, succeed};
use sunray_e2e::remd::LoopbackCluster;
use sunray_e2e::small_fs::SmallFs;

const FLAGS: [&str; 2] = ["--resolution", "48x32"];

/// The image of the 1M-triangle tests: small, as the cost is in the scene, not the pixels.
const FLAGS_1M: [&str; 2] = ["--resolution", "64x64"];

/// One test of this file at a time.
fn heavy() -> MutexGuard<'static, ()> {
    static TURN: Mutex<()> = Mutex::new(());
    TURN.lock().unwrap_or_else(|e| e.into_inner())
}

/// `sunray spd tetra --size 10` (1,048,576 triangles) and its `sunray render` at
/// [`FLAGS_1M`], made once per run of this file in cargo's temporary folder for tests.
fn tetra10() -> &'static (PathBuf, Vec<u8>) {
    static MADE: OnceLock<(PathBuf, Vec<u8>)> = OnceLock::new();
    MADE.get_or_init(|| {
        let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("big_scenes");
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("tetra10.nff");
        let st = sunray()
            .args(["spd", "tetra", "--size", "10", "-o"])
            .arg(&path)
            .status()
            .unwrap();
        assert!(st.success());
        let (want, stats) = reference(&dir, &path, &FLAGS_1M);
        assert_eq!(stats["primitives"], 1_048_576, "{stats}");
        (path, want)
    })
}

/// `sunray spd tetra --size 9` into `dir`.
fn tetra9(dir: &Path) -> std::path::PathBuf {
    let path = dir.join("tetra9.nff");
    let st = sunray()
        .args(["spd", "tetra", "--size", "9", "-o"])
        .arg(&path)
        .status()
        .unwrap();
    assert!(st.success());
    path
}

/// Submits `scene` on three hosts through daemon a, the controller in the submitting
/// process (see [`IN_PROCESS`]), following it; its statistics.
fn submit(cluster: &LoopbackCluster, scene: &Path, out: &Path) -> serde_json::Value {
    submit_with(cluster.submit(), &IN_PROCESS, &FLAGS, scene, out)
}

/// Three hosts, the controller in the submitting process: its job ends once the workers
/// still starting or fetching have said how their scene came (3 s at most), so every host's
/// figures are in the statistics these tests read; a farm job's statistics are those of the
/// moment its image was stored.
const IN_PROCESS: [&str; 3] = ["--hosts", "3", "--in-process"];

/// Runs `submit` (a `sunray submit` command) with `args` and `flags` on `scene` into `out`,
/// following the job; its statistics.
fn submit_with(
    mut submit: std::process::Command,
    args: &[&str],
    flags: &[&str],
    scene: &Path,
    out: &Path,
) -> serde_json::Value {
    let json = out.with_extension("json");
    succeed(
        submit
            .args(args)
            .args(["-q", "-o"])
            .arg(out)
            .arg("--stats-json")
            .arg(&json)
            .args(flags)
            .arg(scene),
    );
    serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap()
}

/// A first job's statistics, submitted to the farm through a: they are those of the moment
/// the image was stored, so the nodes that had said how their scene came by then (building
/// or rendering) are judged: a had the model; b and c lacked it, fetched it from the others
/// and built their BVH. a sent the peers their copies.
fn check_first_farm_job(stats: &serde_json::Value) {
    let nodes = stats["nodes"].as_array().unwrap();
    assert_eq!(nodes.len(), 3, "{stats}");
    let said: Vec<&serde_json::Value> = nodes
        .iter()
        .filter(|n| n["stage"] == "building" || n["stage"] == "rendering")
        .collect();
    assert!(!said.is_empty(), "someone rendered the image: {stats}");
    for n in said {
        let (bytes, cached) = (
            n["scene_bytes_received"].as_u64().unwrap(),
            n["scene_cached"].as_bool().unwrap(),
        );
        if n["host"] == "a" {
            assert!(
                cached && bytes == 0,
                "the submitting host had the model: {n}"
            );
        } else {
            // a put each chunk on one peer: b and c each fetched what the other holds.
            assert!(!cached && bytes > 0, "{n}");
        }
        assert_eq!(n["accel_cached"], false, "{n}");
    }
    assert!(stats["scene_bytes_sent"].as_u64().unwrap() > 0, "{stats}");
}

/// Waits (two minutes at most) until each of `hosts` has a prepared scene sealed since
/// `since`: a job's end stopped none of their keepers.
fn wait_sealed(cluster: &LoopbackCluster, hosts: &[&str], since: std::time::SystemTime) {
    let sealed = |h: &str| {
        let cache = cluster.dir.path().join(format!("state-{h}")).join("cache");
        files_in(&cache).iter().any(|(_, f)| {
            let modified = std::fs::metadata(f).and_then(|m| m.modified()).ok();
            f.to_string_lossy()
                .ends_with(&format!("{FILE_SUFFIX}.seal"))
                && modified >= Some(since)
        })
    };
    let t0 = std::time::Instant::now();
    while !hosts.iter().all(|h| sealed(h)) {
        assert!(t0.elapsed().as_secs() < 120, "a host never kept the scene");
        std::thread::sleep(std::time::Duration::from_millis(200));
    }
}

#[test]
fn a_scene_over_the_message_limit_renders_and_a_second_job_ships_nothing() {
    let _turn = heavy();
    let cluster = LoopbackCluster::start(3);
    let dir = tempfile::tempdir().unwrap();
    let scene = tetra9(dir.path());
    let (want, _) = reference(dir.path(), &scene, &FLAGS);

    // The first job goes to the farm, as a user's does; every host keeps the scene.
    let first = dir.path().join("first.png");
    let began = std::time::SystemTime::now();
    let stats = submit_with(cluster.submit(), &["--hosts", "3"], &FLAGS, &scene, &first);
    assert!(
        std::fs::read(&first).unwrap() == want,
        "differs from sunray render"
    );
    check_first_farm_job(&stats);
    wait_sealed(&cluster, &["a", "b", "c"], began);

    let second = dir.path().join("second.png");
    let stats = submit(&cluster, &scene, &second);
    assert!(std::fs::read(&second).unwrap() == want);
    let figures = scene_figures(&stats);
    assert!(
        figures.iter().all(|f| f.1 == 0 && f.2),
        "every host had the scene cached: {figures:?}"
    );
    let mapped = mapped_figures(&stats);
    assert!(
        mapped.len() == 3 && mapped.iter().all(|m| m.1),
        "every host mapped the scene it kept prepared: {mapped:?}"
    );

    // A chunk corrupted in one host's cache is dropped and fetched again (b's prepared scene
    // removed, so b needs the model); c's prepared scene damaged and a's cut short, with
    // a's BVH: both are made anew, with a warning, and the image is the same.
    let cache = |host: &str| {
        cluster
            .dir
            .path()
            .join(format!("state-{host}"))
            .join("cache")
    };
    for (host, f) in ["a", "b", "c"].iter().flat_map(|h| files_in(&cache(h))) {
        let mut bytes = std::fs::read(&f).unwrap();
        let name = f.file_name().unwrap().to_string_lossy().into_owned();
        match (host, name.ends_with(FILE_SUFFIX)) {
            ("b", _) => std::fs::remove_file(&f).unwrap(),
            ("c", true) if name.starts_with("sunray-scene") => {
                let at = bytes.len() / 2;
                bytes[at] ^= 0x40;
                std::fs::write(&f, bytes).unwrap();
            }
            ("a", true) => std::fs::write(&f, &bytes[..bytes.len() / 3]).unwrap(),
            _ => {}
        }
    }
    let damaged_at = std::time::SystemTime::now();
    let chunks = cluster.dir.path().join("state-b").join("chunks");
    let mut corrupted = 0;
    for sub in std::fs::read_dir(&chunks).unwrap().flatten() {
        for f in std::fs::read_dir(sub.path()).unwrap().flatten() {
            let mut bytes = std::fs::read(f.path()).unwrap();
            bytes[1000] ^= 0x55;
            std::fs::write(f.path(), bytes).unwrap();
            corrupted += 1;
        }
    }
    assert!(corrupted > 0);
    let third = dir.path().join("third.png");
    let stats = submit(&cluster, &scene, &third);
    assert!(
        std::fs::read(&third).unwrap() == want,
        "a corrupt chunk was rendered"
    );
    let b: Vec<_> = scene_figures(&stats)
        .into_iter()
        .filter(|f| f.0 == "b")
        .collect();
    assert!(
        b.iter().all(|f| !f.2 && f.1 > 0),
        "b fetched its corrupted chunks again: {b:?}"
    );
    // Each host's keeper made its prepared scene anew, even where the job ended first; the
    // next job maps them all.
    wait_sealed(&cluster, &["a", "b", "c"], damaged_at);
    let fourth = dir.path().join("fourth.png");
    let stats = submit(&cluster, &scene, &fourth);
    assert!(std::fs::read(&fourth).unwrap() == want);
    let mapped = mapped_figures(&stats);
    assert!(
        mapped.iter().all(|m| m.1),
        "each host mapped the prepared scene made anew: {mapped:?}"
    );
}

/// The files in `dir` (none when it is not there), each with `host`.
fn files_in(dir: &Path) -> Vec<(&'static str, PathBuf)> {
    let host = match dir
        .parent()
        .and_then(|p| p.file_name())
        .map(|n| n.to_string_lossy())
    {
        Some(n) if n.ends_with('a') => "a",
        Some(n) if n.ends_with('b') => "b",
        _ => "c",
    };
    std::fs::read_dir(dir)
        .map(|d| d.flatten().map(|e| (host, e.path())).collect())
        .unwrap_or_default()
}

#[test]
fn a_million_triangles_through_the_embedded_default_twice() {
    let _turn = heavy();
    let (scene, want) = tetra10();
    let dir = tempfile::tempdir().unwrap();
    // The embedded default keeps its state (the chunk cache with it) in $SUNRAY_STATE_DIR,
    // which outlives each `sunray submit`; here a folder of this test's own. Its only host is
    // the submitting one, which put the model into its own cache: so even the first job
    // finds it there, and the second ships nothing and fetches nothing either.
    let embedded = || {
        let mut c = sunray();
        c.arg("submit")
            .env("SUNRAY_STATE_DIR", dir.path().join("state"));
        c
    };
    for run in ["first", "second"] {
        let out = dir.path().join(format!("{run}.png"));
        let stats = submit_with(embedded(), &["--hosts", "2"], &FLAGS_1M, scene, &out);
        assert!(
            std::fs::read(&out).unwrap() == *want,
            "the {run} job differs from sunray render"
        );
        let figures = scene_figures(&stats);
        assert_eq!(figures.len(), 2, "{figures:?}");
        assert!(
            figures.iter().all(|f| f.1 == 0 && f.2),
            "{run} job: the host had the scene cached: {figures:?}"
        );
        assert_eq!(stats["scene_bytes_sent"], 0, "one host: nobody to send to");
        if run == "second" {
            let accel = accel_figures(&stats);
            assert!(
                accel.iter().all(|a| a.1),
                "the host kept the BVH the first job built: {accel:?}"
            );
        }
    }
    let cached = cache_files(&dir.path().join("state").join("chunks"));
    assert!(
        cached.len() >= 25,
        "the model (about 104 MB) is in 4 MiB chunks in the cache: {}",
        cached.len()
    );
}

#[test]
fn a_million_triangles_on_three_daemons_and_a_second_job_ships_nothing() {
    let _turn = heavy();
    let (scene, want) = tetra10();
    let cluster = LoopbackCluster::start(3);
    let dir = tempfile::tempdir().unwrap();

    // The first job goes to the farm, as a user's does.
    let first = dir.path().join("first.png");
    let began = std::time::SystemTime::now();
    let stats = submit_with(
        cluster.submit(),
        &["--hosts", "3"],
        &FLAGS_1M,
        scene,
        &first,
    );
    assert!(
        std::fs::read(&first).unwrap() == *want,
        "differs from sunray render"
    );
    check_first_farm_job(&stats);
    // About one copy of the model left the submitting host, not one per host.
    let sent = stats["scene_bytes_sent"].as_u64().unwrap();
    assert!(
        (90_000_000..=120_000_000).contains(&sent),
        "one copy of the 104 MB model: {sent}"
    );
    // The farm job's end waited for the hosts still fetching, and no keeper was stopped by
    // it: every host's prepared scene is made and sealed, whether its worker rendered or not.
    wait_sealed(&cluster, &["a", "b", "c"], began);

    // The second, in this process so that every host's figures are in: nothing is shipped,
    // fetched or built.
    let second = dir.path().join("second.png");
    let stats = submit_with(cluster.submit(), &IN_PROCESS, &FLAGS_1M, scene, &second);
    assert!(
        std::fs::read(&second).unwrap() == *want,
        "the second job differs from sunray render"
    );
    let figures = scene_figures(&stats);
    assert_eq!(figures.len(), 3, "{figures:?}");
    assert!(
        figures.iter().all(|f| f.1 == 0 && f.2),
        "every host had the scene cached: {figures:?}"
    );
    assert_eq!(stats["scene_bytes_sent"], 0, "the peers had every chunk");
    let accel = accel_figures(&stats);
    assert!(
        accel.iter().all(|a| a.1),
        "every host kept the BVH it built: {accel:?}"
    );
    let mapped = mapped_figures(&stats);
    assert!(mapped.iter().all(|m| m.1), "{mapped:?}");
}

/// The files under a chunk cache folder (`DIR/xx/NAME`), by name.
fn cache_files(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut files = Vec::new();
    for sub in std::fs::read_dir(dir).unwrap().flatten() {
        if !sub.path().is_dir() {
            continue;
        }
        for f in std::fs::read_dir(sub.path()).unwrap().flatten() {
            let name = f.file_name().to_string_lossy().to_string();
            files.push((name, std::fs::read(f.path()).unwrap()));
        }
    }
    files.sort();
    files
}

#[test]
fn a_chunk_cache_on_a_full_file_system_still_gives_the_same_image() {
    let _turn = heavy();
    // Host b's chunk cache is a 10 MiB tmpfs: two of tetra9's seven 4 MiB chunks fit, the
    // third write runs out of space half way.
    let Some(fs) = SmallFs::mount_as_root("10m") else {
        return;
    };
    let cluster = LoopbackCluster::start_with(3, |name, state| {
        if name == "b" {
            std::fs::create_dir_all(state).unwrap();
            std::os::unix::fs::symlink(fs.path(), state.join("chunks")).unwrap();
        }
    });
    let dir = tempfile::tempdir().unwrap();
    let scene = tetra9(dir.path());
    let (want, _) = reference(dir.path(), &scene, &FLAGS);

    let out = dir.path().join("full.png");
    let stats = submit(&cluster, &scene, &out);
    assert!(
        std::fs::read(&out).unwrap() == want,
        "a full disk changed the image"
    );
    let b: Vec<_> = scene_figures(&stats)
        .into_iter()
        .filter(|f| f.0 == "b")
        .collect();
    assert!(b.iter().all(|f| !f.2 && f.1 > 0), "{b:?}");
    let log = cluster.log("b");
    assert!(
        log.contains("WARN") && log.contains("serving it from memory"),
        "b said nothing of its full disk: {log}"
    );
    // What b kept is whole chunks only: no write cut short by the full disk is left behind.
    let kept = cache_files(fs.path());
    assert!(!kept.is_empty(), "the first chunks fitted");
    for (name, bytes) in &kept {
        assert!(
            rem::wire::chunk_name::is_chunk_name(name)
                && rem::wire::chunk_name::name_of(bytes) == *name,
            "{name}: not a whole chunk ({} bytes)",
            bytes.len()
        );
    }
    let total: usize = kept.iter().map(|k| k.1.len()).sum();
    assert!(total <= 10 << 20, "{total}");
    drop(cluster);
}
