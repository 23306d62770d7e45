//! How deep the ray tree goes: the depth limit, the weight threshold, and the tracer's own
//! cap whatever the options ask, between two facing mirrors.

use super::tests::{square, world, Fixture};
use super::TraceOptions;
use crate::geometry::Vec3;
use yari::model::{Surface, World};

/// Two facing squares of `surface` at z = 0 and z = 4, no light, the camera between them.
fn facing_mirrors(surface: Surface) -> World {
    let mut w = world(
        vec![(square(0.0), surface.clone()), (square(4.0), surface)],
        vec![],
    );
    w.camera.position = Vec3::new(0.0, 0.0, 2.0);
    w
}

/// The reflected rays an eye ray from between the mirrors towards -z spawns with `opts`.
fn reflected(w: &World, opts: TraceOptions) -> u64 {
    let mut f = Fixture::new(w.clone());
    f.eye(opts, Vec3::new(0.0, 0.0, 2.0), -Vec3::Z);
    f.counters.reflected
}

fn limits(max_depth: u32, min_weight: f64) -> TraceOptions {
    TraceOptions {
        max_depth,
        min_weight,
        spawn_all: false,
    }
}

#[test]
fn ray_tree_stops_at_the_depth_limit_and_the_weight_threshold() {
    // Two facing mirrors: the eye ray bounces between them until the depth limit.
    let mirror = Surface {
        kdr: 0.0,
        ka: 0.0,
        ..Surface::default()
    };
    let mut w2 = facing_mirrors(mirror);
    assert_eq!(reflected(&w2, limits(5, 0.0)), 4);
    assert_eq!(reflected(&w2, limits(1, 0.0)), 0);
    // With ksr = 0.5 per bounce, weights are 0.5, 0.25, 0.125, ...: a threshold of 0.2 stops
    // after two reflections.
    let half = Surface {
        kdr: 0.5,
        ka: 0.0,
        ..Surface::default()
    };
    w2.objects.iter_mut().for_each(|o| o.surface = 0);
    w2.surfaces = vec![half];
    assert_eq!(reflected(&w2, limits(10, 0.2)), 2);
}

#[test]
fn the_ray_tree_never_goes_past_max_depth_whatever_it_is_asked() {
    // Two facing perfect mirrors, no depth limit asked and a negative weight threshold: only
    // the tracer's own cap stops the bounces (before, the recursion overflowed the stack).
    let w = facing_mirrors(Surface {
        kdr: 0.0,
        ka: 0.0,
        ..Surface::default()
    });
    for opts in [limits(u32::MAX, -1.0), limits(1_000_000_000, 0.0)] {
        assert_eq!(reflected(&w, opts), u64::from(TraceOptions::MAX_DEPTH - 1));
    }
}
