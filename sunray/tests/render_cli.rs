//! `sunray render` end to end: files, formats, statistics JSON, thread-count independence.
#![allow(clippy::unwrap_used, clippy::expect_used)] // a test: a failed unwrap is a failed test

use std::path::PathBuf;
use std::process::Command;

fn sunray() -> Command {
    Command::new(env!("CARGO_BIN_EXE_sunray"))
}

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("sunray-cli-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

mod support;

fn tetra() -> PathBuf {
    support::thesis("tetra16.yari")
}

#[test]
fn threads_do_not_change_the_file_and_stats_are_written() {
    let d = tmp("threads");
    let mut outputs = Vec::new();
    for threads in ["1", "2"] {
        let out = d.join(format!("t{threads}.png"));
        let json = d.join(format!("t{threads}.json"));
        let st = sunray()
            .args([
                "render",
                "-q",
                "--resolution",
                "64x48",
                "--samples",
                "4",
                "--threads",
                threads,
            ])
            .arg(tetra())
            .arg("-o")
            .arg(&out)
            .arg("--stats-json")
            .arg(&json)
            .status()
            .unwrap();
        assert!(st.success());
        let v: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
        assert_eq!(v.pointer("/rays/eye").unwrap(), 64 * 48 * 4);
        assert_eq!(
            v.pointer("/threads").unwrap().as_u64(),
            Some(threads.parse().unwrap())
        );
        for key in [
            "/rays/eye_hits",
            "/rays/shadow",
            "/intersection_tests",
            "/time/cpu_s",
            "/time/preprocess_s",
        ] {
            assert!(v.pointer(key).is_some(), "{key}");
        }
        outputs.push(std::fs::read(&out).unwrap());
    }
    assert!(outputs[0] == outputs[1]);
    std::fs::remove_dir_all(&d).unwrap();
}

#[test]
fn ppm_and_pfm_by_extension_and_bad_input_fails_cleanly() {
    let d = tmp("formats");
    for (ext, magic) in [
        ("ppm", &b"P6\n16 16\n255\n"[..]),
        ("pfm", &b"PF\n16 16\n-1.0\n"[..]),
    ] {
        let out = d.join(format!("a.{ext}"));
        let st = sunray()
            .args(["render", "-q", "--resolution", "16x16"])
            .arg(tetra())
            .arg("-o")
            .arg(&out)
            .status()
            .unwrap();
        assert!(st.success());
        assert!(std::fs::read(&out).unwrap().starts_with(magic));
    }
    // An unknown format is refused before rendering; a bad scene gives file:line:col.
    let gif = sunray()
        .args(["render", "-q"])
        .arg(tetra())
        .arg("-o")
        .arg(d.join("a.gif"))
        .output()
        .unwrap();
    assert!(!gif.status.success());
    let bad = d.join("bad.yari");
    std::fs::write(&bad, "begin\n sphere(center=0,0,0; radius=1)\nend\n").unwrap();
    let out = sunray()
        .args(["render", "-q"])
        .arg(&bad)
        .arg("-o")
        .arg(d.join("bad.png"))
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("bad.yari:2:"),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let names: Vec<String> = std::fs::read_dir(&d)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    let mut names = names;
    names.sort();
    assert_eq!(
        names,
        ["a.pfm", "a.ppm", "bad.yari"],
        "no half images or temporaries"
    );
    std::fs::remove_dir_all(&d).unwrap();
}

/// Without SCENE, `sunray render` renders the built-in example (as `sunray submit` does),
/// to example.png in the current directory; `@example` names it explicitly.
#[test]
fn no_scene_renders_the_built_in_example() {
    let d = tmp("builtin");
    let st = sunray()
        .current_dir(&d)
        .args(["render", "-q", "--resolution", "32x24"])
        .status()
        .unwrap();
    assert!(st.success());
    let by_name = d.join("named.png");
    let st = sunray()
        .args(["render", "-q", "--resolution", "32x24", "@example", "-o"])
        .arg(&by_name)
        .status()
        .unwrap();
    assert!(st.success());
    let default = std::fs::read(d.join("example.png")).unwrap();
    assert_eq!(default, std::fs::read(&by_name).unwrap());
    let img = image::load_from_memory(&default).unwrap().to_rgb8();
    assert_eq!(img.dimensions(), (32, 24));
    let distinct: std::collections::HashSet<_> = img.pixels().map(|p| p.0).collect();
    assert!(distinct.len() > 20, "a real picture, not a blank");
}

/// `--target-error`: the image is the same for 1 and 2 threads, the statistics say what the
/// pixels reached and took (the histogram counts every pixel once, the eye rays are the
/// samples taken), and `--samples-map` writes a map of the image's size.
#[test]
fn a_target_error_reports_its_error_and_writes_a_samples_map() {
    let d = tmp("target-error");
    let mut images = Vec::new();
    for threads in ["1", "2"] {
        let (out, json, map) = (
            d.join(format!("t{threads}.png")),
            d.join(format!("t{threads}.json")),
            d.join(format!("map{threads}.png")),
        );
        let st = sunray()
            .args([
                "render",
                "-q",
                "--resolution",
                "48x40",
                "--threads",
                threads,
            ])
            .args(["--target-error", "0.02", "--max-samples", "128"])
            .arg("-o")
            .arg(&out)
            .arg("--stats-json")
            .arg(&json)
            .arg("--samples-map")
            .arg(&map)
            .status()
            .unwrap();
        assert!(st.success());
        images.push(std::fs::read(&out).unwrap());
        let s: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
        let e = &s["error"];
        assert_eq!(e["target"], 0.02);
        let buckets = e["histogram"].as_array().unwrap();
        let pixels: u64 = buckets.iter().map(|b| b["pixels"].as_u64().unwrap()).sum();
        assert_eq!(pixels, 48 * 40);
        assert!(buckets.len() >= 2, "{e}");
        // The fewest is min-samples (4 at E = 0.02); raised pixels take 4 x as many.
        assert_eq!(buckets[0]["from"], 4, "the fewest is min-samples: {e}");
        assert_eq!(buckets[1]["from"], 16, "a raised pixel's fewest: {e}");
        let mean = e["mean_samples"].as_f64().unwrap();
        let eye = s["rays"]["eye"].as_u64().unwrap() as f64;
        assert!((mean * 48.0 * 40.0 - eye).abs() < 0.5, "{mean} {eye}");
        let (rms, max) = (e["rms"].as_f64().unwrap(), e["max"].as_f64().unwrap());
        assert!(rms > 0.0 && rms <= 0.02 && max >= rms, "{e}");
        assert!(
            max <= 0.02 || e["at_max_samples"].as_u64().unwrap() > 0,
            "{e}"
        );
        let map = image::open(&map).unwrap();
        assert_eq!((map.width(), map.height()), (48, 40));
    }
    assert_eq!(images[0], images[1]);
    // OpenEXR holds the linear values PFM holds (PFM's rows run bottom to top).
    let (exr, pfm) = (d.join("t.exr"), d.join("t.pfm"));
    for out in [&exr, &pfm] {
        let st = sunray()
            .args([
                "render",
                "-q",
                "--resolution",
                "24x16",
                "--target-error",
                "0.05",
            ])
            .arg("-o")
            .arg(out)
            .status()
            .unwrap();
        assert!(st.success());
    }
    let exr = image::open(&exr).unwrap().to_rgb32f();
    let bytes = std::fs::read(&pfm).unwrap();
    let floats: Vec<f32> = bytes[bytes.len() - 24 * 16 * 12..]
        .chunks(4)
        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect();
    let rows: Vec<&[f32]> = floats.chunks(24 * 3).rev().collect();
    assert_eq!(exr.as_raw().as_slice(), rows.concat().as_slice());
    // A scene's own `target_error(E)` renders as `--target-error E`; `--samples N` overrides it.
    let body =
        "resolution(24,16);\ncamera(position = 0,0,6; at = 0,0,0; up = 0,1,0; angle = 20);\n\
                light(position = 3,4,5; color = white; radius = 0.8);\n\
                begin attribute(color = orange); sphere(center = 0,0,0; radius = 1); end\n";
    let (asks, plain) = (d.join("asks.yari"), d.join("plain.yari"));
    std::fs::write(&asks, format!("target_error(0.04);\n{body}")).unwrap();
    std::fs::write(&plain, body).unwrap();
    let png = |scene: &PathBuf, flags: &[&str], name: &str| {
        let out = d.join(name);
        let st = sunray()
            .args(["render", "-q"])
            .arg(scene)
            .args(flags)
            .arg("-o")
            .arg(&out)
            .status()
            .unwrap();
        assert!(st.success());
        std::fs::read(&out).unwrap()
    };
    let by_scene = png(&asks, &[], "asks.png");
    assert!(by_scene == png(&plain, &["--target-error", "0.04"], "flag.png"));
    assert!(by_scene != png(&plain, &[], "one.png"));
    assert!(png(&asks, &["--samples", "2"], "n.png") == png(&plain, &["--samples", "2"], "m.png"));
    // A bad target is one line naming the flag, and nothing is written.
    let out = d.join("bad.png");
    let o = sunray()
        .args(["render", "-q", "--target-error", "nan", "-o"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(
        err.contains("--target-error must be a number above 0"),
        "{err}"
    );
    assert!(!out.exists());
}

#[test]
fn bench_scenes_writes_the_accuracy_scenes_that_render_renders() {
    let d = tmp("bench-scenes");
    let out = sunray()
        .args([
            "bench",
            "scenes",
            "--accuracy-resolution",
            "24",
            "--out-dir",
        ])
        .arg(&d)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let colours = yari::colour::ColourTable::builtin();
    for (name, _, text) in sunray::bench::accuracy::cases() {
        let file = d.join(format!("{name}.yari"));
        assert!(String::from_utf8_lossy(&out.stdout).contains(&*file.to_string_lossy()));
        let read = yari::load::load_path(&file, &colours).unwrap().world;
        assert_eq!(
            read,
            sunray::bench::accuracy::world(name, text, 24).unwrap(),
            "{name}"
        );
        let png = d.join(format!("{name}.png"));
        let st = sunray()
            .args(["render", "-q", "--samples", "2", "--threads", "1"])
            .arg(&file)
            .arg("-o")
            .arg(&png)
            .status()
            .unwrap();
        assert!(st.success(), "{name}");
        let img = image::open(&png).unwrap();
        assert_eq!((img.width(), img.height()), (24, 24), "{name}");
    }
    let bad = sunray()
        .args(["bench", "scenes", "--accuracy-resolution", "0", "--out-dir"])
        .arg(d.join("zero"))
        .output()
        .unwrap();
    assert!(!bad.status.success());
    assert!(!d.join("zero").exists());
}
