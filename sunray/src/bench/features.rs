//! `sunray bench features`: a scene pays only for what it uses. (1) A diffuse scene rendered
//! as compiled (its `Features` say: no textures, transparency, area lights, gloss, ...) and
//! with every feature switch forced on although nothing uses them: the paths a scene does not
//! use are switched out per scene, and the table shows what they would cost if they were not.
//! (2) `--accel auto` against the measured fastest accelerator for growing scene sizes.

use super::{measure, spd_world, BenchError};
use crate::accel::{AccelKind, AccelOptions};
use std::fmt::Write;
use yari::model::World;
use yari::spd::Database;

fn best_of(n: usize, world: &World, size: u32, kind: AccelKind) -> (f64, u64) {
    let opts = AccelOptions {
        kind,
        ..AccelOptions::default()
    };
    let mut best = f64::MAX;
    let mut rays = 0;
    for _ in 0..n {
        let run = measure(world, size, &opts, true, 1);
        // CPU seconds (build + render, one thread): robust against other load.
        best = best.min(run.cpu_s);
        rays = run.counters.rays();
    }
    (best, rays)
}

/// Every feature switch on (the scene's surfaces are unchanged, so the picture is too).
fn all_switched_on(w: &World) -> World {
    let mut w = w.clone();
    let f = &mut w.features;
    (f.textures, f.transparency, f.reflection, f.area_lights) = (true, true, true, true);
    (f.gloss, f.translucency, f.depth_of_field, f.motion_blur) = (true, true, true, true);
    w
}

/// Runs both parts and returns a Markdown report.
pub fn run(resolution: u32) -> Result<String, BenchError> {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "### Unused feature paths (CPU seconds of build + render, one thread, {resolution}x{resolution}, best of 3, BVH)\n\n\
         | scene | as compiled (s) | all switches on (s) | on / compiled |\n|---|---:|---:|---:|"
    );
    for (db, size) in [(Database::Tetra, 6), (Database::Mount, 4)] {
        let w = spd_world(db, size)?;
        let (a, _) = best_of(3, &w, resolution, AccelKind::Bvh);
        let (b, _) = best_of(3, &all_switched_on(&w), resolution, AccelKind::Bvh);
        let _ = writeln!(
            out,
            "| {}{size} | {a:.3} | {b:.3} | {:.2} |",
            db.name(),
            b / a
        );
    }
    let _ = writeln!(
        out,
        "\n### `--accel auto` against the fastest (CPU seconds, one thread, 128x128, best of 3; SPD balls and tetra of small sizes)\n\n\
         | scene | primitives | exhaustive (s) | octree (s) | BVH (s) | fastest | auto picks |\n|---|---:|---:|---:|---:|---|---|"
    );
    for (db, size) in [
        (Database::Balls, 0),
        (Database::Tetra, 1),
        (Database::Balls, 1),
        (Database::Tetra, 2),
        (Database::Tetra, 3),
        (Database::Balls, 2),
        (Database::Balls, 3),
    ] {
        let w = spd_world(db, size)?;
        let n = crate::scene::Scene::new(w.clone()).prims.len();
        let times: Vec<(AccelKind, f64)> =
            [AccelKind::Exhaustive, AccelKind::Octree, AccelKind::Bvh]
                .into_iter()
                .map(|k| (k, best_of(3, &w, 128, k).0))
                .collect();
        let fastest = times
            .iter()
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map_or(AccelKind::Bvh, |t| t.0);
        let _ = writeln!(
            out,
            "| {}{size} | {n} | {:.4} | {:.4} | {:.4} | {} | {} |",
            db.name(),
            times[0].1,
            times[1].1,
            times[2].1,
            fastest.name(),
            AccelKind::Auto.resolve(n).name()
        );
    }
    Ok(out)
}
