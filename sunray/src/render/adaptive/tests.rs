use super::*;

fn adaptive(target_error: f64, min_samples: u32, max_samples: u32) -> Adaptive {
    Adaptive {
        target_error,
        min_samples,
        max_samples,
    }
}

/// Feeds `sample(k)` as the estimate asks; the estimate at the end.
fn run(a: &Adaptive, mut sample: impl FnMut(u32) -> DVec3) -> PixelEstimate {
    let mut est = PixelEstimate::default();
    while let Some(want) = est.next_count(a) {
        assert!(want > est.count() && want <= a.max_samples);
        while est.count() < want {
            est.add(sample(est.count()));
        }
    }
    est
}

#[test]
fn a_constant_pixel_stops_at_min_samples_with_no_error() {
    let a = adaptive(1e-6, 4, 1024);
    let c = DVec3::new(0.2, 0.7, 0.123_456_789);
    let est = run(&a, |_| c);
    assert_eq!(est.count(), 4);
    assert_eq!(est.mean(), c, "exactly the colour");
    assert_eq!(est.standard_error(), 0.0);
    assert_eq!(constant_pixel(c, &a), est);
}

/// Samples 0 and 1 in turn in one channel: s^2 -> 1/4, so the error sqrt(s^2/n) reaches E
/// at n = 1/(4 E^2). The count stops at the first the schedule reaches at or past it, never
/// more than twice it (the schedule at most doubles).
#[test]
fn a_pixel_of_known_variance_takes_the_count_the_formula_says() {
    for e in [0.1, 0.05, 0.02, 0.01] {
        let a = adaptive(e, 4, 65_536);
        let est = run(&a, |k| DVec3::new(0.0, f64::from(k % 2), 0.5));
        let formula = 1.0 / (4.0 * e * e);
        let n = f64::from(est.count());
        assert!(est.standard_error() <= e, "{e}: {}", est.standard_error());
        assert!(
            n >= formula * 0.95 && n <= 2.0 * formula + 4.0,
            "E {e}: {n} samples, formula {formula}"
        );
        assert!(
            (est.mean().y - 0.5).abs() <= 1.0 / n,
            "{n}: {}",
            est.mean().y
        );
    }
}

#[test]
fn the_count_stops_at_max_samples() {
    let a = adaptive(1e-9, 4, 100);
    let est = run(&a, |k| DVec3::splat(f64::from(k % 2)));
    assert_eq!(est.count(), 100);
    assert!(est.standard_error() > a.target_error);
}

#[test]
fn bad_targets_and_bounds_are_refused_with_their_flag() {
    assert!(Adaptive::new(0.01, None, None).check().is_ok());
    for (a, said) in [
        (adaptive(0.0, 4, 8), "--target-error"),
        (adaptive(-1.0, 4, 8), "--target-error"),
        (adaptive(f64::NAN, 4, 8), "--target-error"),
        (adaptive(f64::INFINITY, 4, 8), "--target-error"),
        (adaptive(0.1, 1, 8), "--min-samples"),
        (adaptive(0.1, 9, 8), "--min-samples"),
        (adaptive(0.1, 4, 70_000), "--max-samples"),
    ] {
        let e = a.check().unwrap_err().to_string();
        assert!(e.starts_with(said), "{a:?}: {e}");
    }
}

#[test]
fn the_first_samples_grow_as_the_target_falls() {
    let firsts: Vec<u32> = [0.1, 0.01, 0.005, 0.002, 1e-5, 1e-300]
        .iter()
        .map(|&e| default_min_samples(e))
        .collect();
    assert_eq!(firsts, [16, 16, 32, 128, 16_384, 65_536]);
    let a = Adaptive::new(0.002, None, None);
    assert_eq!((a.min_samples, a.max_samples), (128, DEFAULT_MAX_SAMPLES));
    // Never above the most asked for, and what is given is kept.
    assert_eq!(Adaptive::new(1e-4, None, Some(64)).min_samples, 64);
    assert_eq!(Adaptive::new(1e-4, Some(4), Some(64)).min_samples, 4);
    assert!(Adaptive::new(1e-4, None, Some(64)).check().is_ok());
}
