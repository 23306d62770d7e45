//! Reference renders and their outputs: `sunray render` of a scene (what every distributed
//! image must equal byte for byte), JSON statistics, commands run to their end.

use super::bins::sunray;
use std::path::Path;
use std::process::{Command, Output};

/// `sunray render` of `scene` with `flags` into `dir`: the PNG bytes and the stats JSON.
pub fn reference(dir: &Path, scene: &Path, flags: &[&str]) -> (Vec<u8>, serde_json::Value) {
    let stem = scene
        .file_stem()
        .map_or("scene".into(), |s| s.to_string_lossy());
    let out = dir.join(format!("reference-{stem}.png"));
    let json = dir.join(format!("reference-{stem}.json"));
    let st = sunray()
        .arg("render")
        .arg("-q")
        .arg(scene)
        .args(flags)
        .arg("-o")
        .arg(&out)
        .arg("--stats-json")
        .arg(&json)
        .status()
        .unwrap();
    assert!(st.success(), "sunray render {}", scene.display());
    (std::fs::read(&out).unwrap(), read_json(&json))
}

/// A JSON file. A job's statistics (`submit --stats-json`: a `job` with `nodes`) must carry
/// its timeline, in order ([`check_timeline`]).
pub fn read_json(path: &Path) -> serde_json::Value {
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap();
    if v.get("job").is_some() && v.get("nodes").is_some() {
        if let Err(e) = check_timeline(&v) {
            panic!("{}: {e}", path.display());
        }
    }
    v
}

/// A job's timeline (seconds since submit) as its statistics give it: the model ready and
/// stored by the submitting host when known; the controller's start and the job's end always; the first and last line when lines were rendered; the
/// image stored when every line is in; every node spawned, and one that rendered has its
/// scene and accelerator ready and its first line; each in order.
pub fn check_timeline(stats: &serde_json::Value) -> Result<(), String> {
    let t = &stats["timeline"];
    let lines = &stats["lines"];
    let count = |k: &str| lines[k].as_u64().unwrap_or(0);
    let rendered = count("rendered") > 0;
    let complete = count("resumed") + count("rendered") == count("total");
    let job_steps = [
        // Unknown (0) when the submit took less than a millisecond to get there.
        ("model_ready", false),
        ("model_stored", false),
        ("controller_started", true),
        ("first_line", rendered),
        ("last_line", rendered),
        ("image_stored", complete),
        ("finished", true),
        ("image_written", false),
    ];
    in_order(t, &job_steps, "the job")?;
    let last = t["last_line"].as_f64().unwrap_or(f64::INFINITY);
    for n in stats["nodes"].as_array().ok_or("no nodes")? {
        let lines = n["scanlines"].as_u64().unwrap_or(0) > 0;
        let steps = [
            ("spawned", true),
            ("scene_ready", lines),
            ("accel_ready", lines),
            ("first_line", lines),
        ];
        let who = format!("node {}", n["node"]);
        in_order(&n["timeline"], &steps, &who)?;
        let spawned = n["timeline"]["spawned"].as_f64().unwrap_or(0.0);
        let controller = t["controller_started"].as_f64().unwrap_or(0.0);
        if spawned < controller || n["timeline"]["first_line"].as_f64().unwrap_or(0.0) > last {
            return Err(format!(
                "{who}'s timeline is outside the job's: {t} {}",
                n["timeline"]
            ));
        }
    }
    Ok(())
}

/// The steps of `timeline` that must be there are numbers, and those there are in order.
fn in_order(timeline: &serde_json::Value, steps: &[(&str, bool)], who: &str) -> Result<(), String> {
    let mut before = 0.0;
    for (step, needed) in steps {
        match timeline[*step].as_f64() {
            Some(s) if s >= before => before = s,
            Some(s) => {
                return Err(format!(
                    "{who}: {step} at {s} s comes before a step at {before} s: {timeline}"
                ))
            }
            None if *needed => return Err(format!("{who}: no {step} in its timeline: {timeline}")),
            None => {}
        }
    }
    Ok(())
}

/// Runs a command that must succeed (its stderr is the failure's message); its stdout.
pub fn succeed(cmd: &mut Command) -> String {
    let out = cmd.output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

/// Runs a command to its end, printing its stderr on failure.
pub fn output(cmd: &mut Command) -> Output {
    let out = cmd.output().unwrap();
    if !out.status.success() {
        eprintln!("{}", String::from_utf8_lossy(&out.stderr));
    }
    out
}

/// Per node of a job's statistics: its host and what `f` takes of the node.
fn per_node<T>(stats: &serde_json::Value, f: impl Fn(&serde_json::Value) -> T) -> Vec<(String, T)> {
    let nodes = stats["nodes"].as_array().unwrap();
    nodes
        .iter()
        .map(|n| (n["host"].as_str().unwrap().to_string(), f(n)))
        .collect()
}

/// Per node of a job's statistics: its host, the bytes of the scene it received and
/// whether its host had the whole scene cached.
pub fn scene_figures(stats: &serde_json::Value) -> Vec<(String, u64, bool)> {
    per_node(stats, |n| {
        (
            n["scene_bytes_received"].as_u64().unwrap(),
            n["scene_cached"].as_bool().unwrap(),
        )
    })
    .into_iter()
    .map(|(host, (bytes, cached))| (host, bytes, cached))
    .collect()
}

/// The hosts whose worker had its scene (its timeline says when) by the moment the job's
/// figures were taken: a worker still starting then says neither bytes received nor cached.
pub fn scene_ready_hosts(stats: &serde_json::Value) -> Vec<String> {
    hosts_where(stats, |n| !n["timeline"]["scene_ready"].is_null())
}

/// Per node of a job's statistics: its host and whether it read its accelerator from its
/// host's cache instead of building it.
pub fn accel_figures(stats: &serde_json::Value) -> Vec<(String, bool)> {
    per_node(stats, |n| n["accel_cached"].as_bool().unwrap())
}

/// Per node of a job's statistics: its host and whether it used its host's prepared scene,
/// mapped in place.
pub fn mapped_figures(stats: &serde_json::Value) -> Vec<(String, bool)> {
    per_node(stats, |n| n["scene_mapped"].as_bool().unwrap())
}

/// The hosts whose worker got as far as asking for work (so its accelerator was built or
/// read, and a built BVH kept): a worker still fetching or building when the image was done
/// is killed at the job's end, and keeps nothing.
pub fn prepared_hosts(stats: &serde_json::Value) -> Vec<String> {
    hosts_where(stats, |n| {
        let s = n["preprocess_s"].as_f64();
        s.unwrap_or_else(|| panic!("a node's statistics without preprocess_s: {n}")) > 0.0
    })
}

/// The hosts of the nodes of a job's statistics for which `f` holds.
fn hosts_where(stats: &serde_json::Value, f: impl Fn(&serde_json::Value) -> bool) -> Vec<String> {
    per_node(stats, f)
        .into_iter()
        .filter_map(|(host, yes)| yes.then_some(host))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::check_timeline;
    use serde_json::json;

    fn stats() -> serde_json::Value {
        json!({
            "job": "j",
            "lines": {"total": 4, "resumed": 0, "rendered": 4},
            "timeline": {"controller_started": 0.1, "first_line": 0.3, "last_line": 0.5,
                "image_stored": 0.6, "finished": 0.7},
            "nodes": [
                {"node": 1, "scanlines": 4, "timeline": {"spawned": 0.15, "scene_ready": 0.2,
                    "accel_ready": 0.25, "first_line": 0.3}},
                {"node": 2, "scanlines": 0, "timeline": {"spawned": 0.15, "scene_ready": null,
                    "accel_ready": null, "first_line": null}}
            ]
        })
    }

    #[test]
    fn a_timeline_in_order_passes() {
        check_timeline(&stats()).unwrap();
    }

    #[test]
    fn planted_defects_in_a_timeline_are_caught() {
        let mut late = stats();
        late["timeline"]["finished"] = json!(0.4);
        assert!(check_timeline(&late).unwrap_err().contains("finished"));
        let mut missing = stats();
        missing["nodes"][0]["timeline"]["accel_ready"] = json!(null);
        assert!(check_timeline(&missing)
            .unwrap_err()
            .contains("accel_ready"));
        let mut none = stats();
        none.as_object_mut().unwrap().remove("timeline");
        assert!(check_timeline(&none).is_err());
        let mut outside = stats();
        outside["nodes"][0]["timeline"]["first_line"] = json!(0.55);
        assert!(check_timeline(&outside).is_err());
        let mut unfinished = stats();
        unfinished["timeline"]["image_stored"] = json!(null);
        assert!(check_timeline(&unfinished).is_err());
        unfinished["lines"]["rendered"] = json!(3);
        check_timeline(&unfinished).unwrap();
    }
}
