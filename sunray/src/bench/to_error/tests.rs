//! The benchmark's arithmetic, and every method converging on a tiny scene.

use super::*;
use crate::bench::accuracy::{cases as accuracy_cases, scene};

#[test]
fn times_and_errors_are_interpolated_on_log_log_axes() {
    let curve = [(1.0, 0.1), (4.0, 0.05), (16.0, 0.025)];
    assert_eq!(time_to(&curve, 0.2), Some(1.0));
    assert!((time_to(&curve, 0.05).unwrap() - 4.0).abs() < 1e-12);
    assert!((time_to(&curve, 0.0353553).unwrap() - 8.0).abs() < 1e-3);
    assert_eq!(time_to(&curve, 0.01), None);
    assert!((rmse_at(&curve, 8.0).unwrap() - 0.0353553).abs() < 1e-6);
    assert_eq!(rmse_at(&curve, 32.0), None);
}

/// POV-Ray on its best terms: a point slower and no better than another is left out.
#[test]
fn the_lower_envelope_keeps_the_fastest_way_to_each_error() {
    let p = |seconds, rmse| Point {
        method: Method::Pov(0.1, 3),
        seconds,
        rmse,
        varying_rmse: None,
        stopped: None,
        estimated: None,
    };
    let kept = lower_envelope(vec![
        p(2.0, 0.01),
        p(1.0, 0.02),
        p(3.0, 0.015),
        p(4.0, 0.005),
    ]);
    let got: Vec<(f64, f64)> = kept.iter().map(|p| (p.seconds, p.rmse)).collect();
    assert_eq!(got, [(1.0, 0.02), (2.0, 0.01), (4.0, 0.005)]);
}

/// The pixels whose count the estimate decided: more than a raised pixel's fewest (4 x the
/// first samples), fewer than the most.
#[test]
fn the_pixels_stopped_by_the_target_are_between_raised_and_most() {
    let a = Adaptive::new(0.01, Some(16), Some(4096));
    let got = stopped_by_target(&[16, 17, 4096, 64, 65, 4095], &a);
    assert_eq!(got, [false, false, false, false, true, true]);
}

/// A pixel whose halves agree carries no error and is left out of the varying RMSE; the
/// reference's own error (half the halves' RMSE) is taken out of it.
#[test]
fn the_varying_pixels_are_those_whose_halves_differ() {
    let flat = Vec3::splat(0.5);
    let a = [flat, Vec3::new(0.4, 0.4, 0.4)];
    let b = [flat, Vec3::new(0.6, 0.6, 0.6)];
    let r = Reference::of_halves(&a, &b);
    assert_eq!(r.varying, [false, true]);
    assert!((r.own_rmse - 0.1).abs() < 1e-12);
    // An image 0.3 off the varying pixel's reference and exact on the flat one: sqrt(0.09 -
    // 0.01).
    let image = [flat, Vec3::splat(0.8)];
    assert!((r.varying_rmse(&image) - 0.08f64.sqrt()).abs() < 1e-12);
    // Off on the flat pixel only: not counted.
    assert_eq!(r.varying_rmse(&[Vec3::ZERO, Vec3::splat(0.5)]), 0.0);
    // Over the flat pixel alone: its whole error, the reference exact there.
    let flat_only = r.rmse_over(&[Vec3::splat(0.7), Vec3::splat(0.5)], &[true, false]);
    assert!((flat_only - 0.2).abs() < 1e-12);
}

/// At a tiny size every method's error falls as it is given more; the adaptive one's error
/// over the pixels its estimate stopped (more than their first samples, fewer than the
/// most) lies between E/4 and 2 E, and its whole image's between a quarter and twice the
/// RMSE it estimated for itself (the stats JSON's `error.rms`).
#[test]
fn every_method_converges_on_a_tiny_penumbra() {
    let (_, _, body) = accuracy_cases()[1];
    let mut s = scene("penumbra", body, 10).unwrap();
    let accel = Accel::build(&mut s.prims, &AccelOptions::default());
    let reference = Reference::render(&s, &accel, 2, 2048);
    let image = |m: Method| measure(&s, &accel, 2, &m.options(&s).unwrap()).image;
    let rmse = |m: Method| errors(&image(m), &reference.image).0;
    for (low, high) in [
        (Method::Stratified(4), Method::Stratified(64)),
        (Method::Sobol(4), Method::Sobol(64)),
        (Method::Adaptive(0.05), Method::Adaptive(0.01)),
    ] {
        let (l, h) = (rmse(low), rmse(high));
        assert!(h < 0.7 * l, "{low:?} {l} vs {high:?} {h}");
    }
    let e = 0.02;
    let m = measure(&s, &accel, 2, &Method::Adaptive(e).options(&s).unwrap());
    let stopped = stopped_by_target(&m.samples, &adaptive_of(e));
    let n = stopped.iter().filter(|&&s| s).count();
    let rmse = reference.rmse_over(&m.image, &stopped);
    assert!(n >= 10, "{n} pixels stopped by the estimate");
    assert!(
        (e / 4.0..2.0 * e).contains(&rmse),
        "RMSE {rmse} for E = {e} over the {n} pixels the estimate stopped"
    );
    let estimated = m.estimated_rms.unwrap();
    let whole = reference.rmse_over(&m.image, &vec![true; m.image.len()]);
    assert!(
        (estimated / 4.0..2.0 * estimated).contains(&whole),
        "RMSE {whole} over the image, {estimated} estimated"
    );
}

/// Gears (the SPD scene with glass) is among the cases, its Haines resolution replaced.
#[test]
fn the_cases_include_the_glass_gears_at_the_asked_size() {
    let all = cases(12).unwrap();
    let gears = all.iter().find(|c| c.name == "gears").unwrap();
    assert_eq!(gears.scene.world.resolution, [12, 12]);
    let sdl = gears.pov.as_deref().unwrap();
    assert!(sdl.contains("ior 1.1"), "the gears are glass");
    assert!(all.iter().any(|c| c.name == "edges" && c.pov.is_some()));
    assert!(all.iter().any(|c| c.name == "gloss" && c.pov.is_none()));
}
