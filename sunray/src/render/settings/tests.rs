use super::*;
use crate::scene::load::{load, SceneSource};

#[test]
fn overrides_replace_the_scenes_own_size_and_samples() {
    let scene = load(&SceneSource::Builtin, None).unwrap().scene;
    let own = Overrides::default().settings(&scene).unwrap();
    assert_eq!(own.render, RenderOptions::for_scene(&scene));
    let s = Overrides {
        resolution: Some((64, 32)),
        samples: Some(0),
        ..Overrides::default()
    }
    .settings(&scene)
    .unwrap();
    assert_eq!(
        (s.render.width, s.render.height, s.render.samples),
        (64, 32, 1)
    );
    let c = Overrides {
        resolution: Some((64, 32)),
        spd_corners: true,
        ..Overrides::default()
    }
    .settings(&scene)
    .unwrap();
    assert_eq!((c.render.width, c.render.height), (65, 33));
    assert_eq!(c.render.trace.min_weight, 0.0);
}

/// Settings well inside every bound.
fn base() -> Settings {
    Settings {
        render: RenderOptions {
            width: 64,
            height: 48,
            samples: 4,
            trace: TraceOptions::default(),
            adaptive: None,
            sampler: crate::sampler::Sampler::Stratified,
        },
        accel: AccelOptions::default(),
        mailbox: true,
    }
}

/// `base()` changed by `f`, checked.
fn check(f: impl FnOnce(&mut Settings)) -> Result<(), SettingsError> {
    let mut s = base();
    f(&mut s);
    s.check()
}

/// `f` out of range: the error names `field`, `value` and the range, on one line.
fn refused(f: impl FnOnce(&mut Settings), field: Field, value: u64, min: u64, max: u64) {
    let e = check(f).unwrap_err();
    assert_eq!(
        e,
        SettingsError::OutOfRange {
            field,
            value,
            min,
            max
        }
    );
    let text = e.to_string();
    assert!(
        text.contains(field.name())
            && text.contains(&value.to_string())
            && text.contains(&format!("{min}..={max}"))
            && !text.contains('\n'),
        "{text}"
    );
}

#[test]
fn the_bounds_are_generous_for_real_use() {
    assert_eq!((MAX_SIDE, MAX_DEPTH), (16_384, 64));
    // The defaults; a 16K UHD frame at the accuracy benchmark's reference sample count,
    // ray depth 20, the thesis's octree (10 a voxel, depth 8).
    base().check().unwrap();
    Overrides::default()
        .settings(&load(&SceneSource::Builtin, None).unwrap().scene)
        .unwrap();
    check(|x| {
        (x.render.width, x.render.height, x.render.samples) = (15_360, 8_640, 16_384);
        x.render.trace.max_depth = 20;
        x.accel = AccelOptions {
            kind: AccelKind::Octree,
            max_per_voxel: 10,
            max_depth: 8,
        };
    })
    .unwrap();
}

#[test]
fn width_and_height_are_within_1_to_max_side() {
    let s = u64::from(MAX_SIDE);
    for w in [1, MAX_SIDE] {
        check(|x| (x.render.width, x.render.height) = (w, 1)).unwrap();
        check(|x| (x.render.width, x.render.height) = (1, w)).unwrap();
    }
    refused(|x| x.render.width = 0, Field::Width, 0, 1, s);
    refused(|x| x.render.width = MAX_SIDE + 1, Field::Width, s + 1, 1, s);
    refused(
        |x| x.render.width = u32::MAX,
        Field::Width,
        u32::MAX.into(),
        1,
        s,
    );
    refused(|x| x.render.height = 0, Field::Height, 0, 1, s);
    refused(
        |x| x.render.height = MAX_SIDE + 1,
        Field::Height,
        s + 1,
        1,
        s,
    );
}

#[test]
fn pixels_are_at_most_max_pixels() {
    // 16384 x 8192 = 2^27 exactly; one more line is over.
    let tall = (MAX_PIXELS / u64::from(MAX_SIDE)) as u32;
    check(|x| (x.render.width, x.render.height) = (MAX_SIDE, tall)).unwrap();
    let e = check(|x| (x.render.width, x.render.height) = (MAX_SIDE, tall + 1)).unwrap_err();
    assert_eq!(
        e,
        SettingsError::TooManyPixels {
            width: MAX_SIDE,
            height: tall + 1
        }
    );
    let text = e.to_string();
    assert!(
        text.contains("134234112 pixels") && text.contains("134217728"),
        "{text}"
    );
}

#[test]
fn samples_and_depth_are_bounded() {
    let (smax, dmax) = (u64::from(MAX_SAMPLES), u64::from(MAX_DEPTH));
    check(|x| x.render.samples = 1).unwrap();
    check(|x| x.render.samples = MAX_SAMPLES).unwrap();
    refused(|x| x.render.samples = 0, Field::Samples, 0, 1, smax);
    refused(
        |x| x.render.samples = MAX_SAMPLES + 1,
        Field::Samples,
        smax + 1,
        1,
        smax,
    );
    check(|x| x.render.trace.max_depth = 1).unwrap();
    check(|x| x.render.trace.max_depth = MAX_DEPTH).unwrap();
    refused(
        |x| x.render.trace.max_depth = 0,
        Field::MaxDepth,
        0,
        1,
        dmax,
    );
    refused(
        |x| x.render.trace.max_depth = MAX_DEPTH + 1,
        Field::MaxDepth,
        dmax + 1,
        1,
        dmax,
    );
    refused(
        |x| x.render.trace.max_depth = 1_000_000_000,
        Field::MaxDepth,
        1_000_000_000,
        1,
        dmax,
    );
}

#[test]
fn min_weight_is_a_finite_number_in_0_to_1() {
    for w in [0.0, 1e-300, 0.5, 1.0] {
        check(|x| x.render.trace.min_weight = w).unwrap();
    }
    for w in [
        -1.0,
        -f64::MIN_POSITIVE,
        1.0 + f64::EPSILON,
        f64::NAN,
        f64::INFINITY,
        f64::NEG_INFINITY,
    ] {
        let e = check(|x| x.render.trace.min_weight = w).unwrap_err();
        assert!(matches!(e, SettingsError::MinWeight { .. }), "{w}: {e}");
        let text = e.to_string();
        assert!(
            text.contains("min_weight") && text.contains("[0, 1]"),
            "{text}"
        );
    }
    assert!(check(|x| x.render.trace.min_weight = f64::NAN)
        .unwrap_err()
        .to_string()
        .contains("= NaN"));
}

#[test]
fn the_octree_parameters_are_bounded() {
    let (vmax, omax) = (u64::from(MAX_PER_VOXEL), u64::from(MAX_OCTREE_DEPTH));
    check(|x| x.accel.max_per_voxel = 1).unwrap();
    check(|x| x.accel.max_per_voxel = MAX_PER_VOXEL as usize).unwrap();
    refused(
        |x| x.accel.max_per_voxel = 0,
        Field::MaxPerVoxel,
        0,
        1,
        vmax,
    );
    refused(
        |x| x.accel.max_per_voxel = MAX_PER_VOXEL as usize + 1,
        Field::MaxPerVoxel,
        vmax + 1,
        1,
        vmax,
    );
    check(|x| x.accel.max_depth = 0).unwrap();
    check(|x| x.accel.max_depth = MAX_OCTREE_DEPTH).unwrap();
    refused(
        |x| x.accel.max_depth = MAX_OCTREE_DEPTH + 1,
        Field::OctreeMaxDepth,
        omax + 1,
        0,
        omax,
    );
}

#[test]
fn accelerators_are_known_by_name_only() {
    for name in ACCEL_NAMES {
        assert_eq!(accel_kind(name).unwrap().name(), name);
    }
    for bad in ["", "kd-tree", "BVH", "bvh ", "octree\n"] {
        let e = accel_kind(bad).unwrap_err();
        assert_eq!(e, SettingsError::Accel { name: bad.into() });
        assert!(!e.to_string().contains('\n'), "{e}");
    }
}

#[test]
fn overrides_out_of_bounds_are_refused_from_flags_and_scene() {
    let scene = load(&SceneSource::Builtin, None).unwrap().scene;
    let with = |o: Overrides| o.settings(&scene);
    let e = with(Overrides {
        resolution: Some((u32::MAX, 16)),
        ..Overrides::default()
    })
    .unwrap_err();
    assert!(matches!(
        e,
        SettingsError::OutOfRange {
            field: Field::Width,
            ..
        }
    ));
    assert!(with(Overrides {
        depth: 1_000_000_000,
        ..Overrides::default()
    })
    .is_err());
    assert!(with(Overrides {
        min_weight: -1.0,
        ..Overrides::default()
    })
    .is_err());
    assert!(with(Overrides {
        samples: Some(MAX_SAMPLES + 1),
        ..Overrides::default()
    })
    .is_err());
    // The corner grid is one larger than the image: a side of MAX_SIDE - 1 at most.
    let corners = |side: u32| {
        with(Overrides {
            resolution: Some((side, 1)),
            spd_corners: true,
            ..Overrides::default()
        })
    };
    assert_eq!(corners(MAX_SIDE - 1).unwrap().render.width, MAX_SIDE);
    assert!(corners(MAX_SIDE).is_err());
    assert!(corners(u32::MAX).is_err(), "no overflow of the corner grid");
    // A scene asking for a huge image is refused the same way.
    let mut huge = scene.clone();
    huge.world.resolution = [u32::MAX, u32::MAX];
    assert!(Overrides::default().settings(&huge).is_err());
}
