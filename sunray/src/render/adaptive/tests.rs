use super::*;

fn adaptive(target_error: f64, min_samples: u32, max_samples: u32) -> Adaptive {
    Adaptive {
        target_error,
        min_samples,
        max_samples,
    }
}

/// Feeds `sample(k)` as the estimate asks, the pixel raised after its first samples (as
/// when a pixel near it is open); the estimate at the end.
fn run(a: &Adaptive, sample: impl FnMut(u32) -> DVec3) -> PixelEstimate {
    run_decided(a, |_| true, sample)
}

/// [`run`], the pixel decided by `raise(its estimate after its first samples)`.
fn run_decided(
    a: &Adaptive,
    raise: impl Fn(&PixelEstimate) -> bool,
    mut sample: impl FnMut(u32) -> DVec3,
) -> PixelEstimate {
    let mut est = PixelEstimate::default();
    loop {
        while let Some(want) = est.next_count(a) {
            assert!(want > est.count() && want <= a.max_samples);
            while est.count() < want {
                est.add(sample(est.count()));
            }
            est.first_samples_in(a);
        }
        if !est.awaits_decision(a) {
            return est;
        }
        est.decide(raise(&est));
    }
}

#[test]
fn a_constant_pixel_stops_at_min_samples_with_no_error() {
    let a = adaptive(1e-6, 4, 1024);
    let c = DVec3::new(0.2, 0.7, 0.123_456_789);
    // Alone (nothing open near it): its first samples; raised: 4 times as many.
    let est = run_decided(&a, PixelEstimate::is_open, |_| c);
    assert_eq!(est.count(), 4);
    assert_eq!(est.mean(), c, "exactly the colour");
    assert_eq!(est.standard_error(), 0.0);
    let mut first = constant_pixel(c, &a);
    assert!(first.awaits_decision(&a));
    first.decide(false);
    assert_eq!(first, est);
    assert_eq!(run(&a, |_| c).count(), 16);
}

/// Pixels `0..pixels` rendered to the error `a` by `sample(pixel, k)`: each pixel's mean
/// error against `truth` (RMS over the pixels) and its mean sample count.
fn over_pixels(
    a: &Adaptive,
    pixels: u64,
    truth: f64,
    mut sample: impl FnMut(u64, u32) -> f64,
) -> (f64, f64) {
    let (mut sq, mut count) = (0.0, 0.0);
    for p in 0..pixels {
        let est = run(a, |k| DVec3::new(0.0, sample(p, k), 0.5));
        assert!(est.standard_error() <= a.target_error || est.count() == a.max_samples);
        sq += (est.mean().y - truth).powi(2);
        count += f64::from(est.count());
    }
    let n = pixels as f64;
    ((sq / n).sqrt(), count / n)
}

/// Independent samples of 0 or 1 (variance 1/4): the error of n's mean is 1 / (2 sqrt n),
/// so E takes about n = 1 / (4 E^2), and at most about twice that (the schedule at most
/// doubles). The error reached is E's, honestly: over many pixels its RMS lies between E/4
/// and 2E.
#[test]
fn a_pixel_of_known_variance_takes_the_count_the_formula_says() {
    for e in [0.1, 0.05, 0.02] {
        let a = adaptive(e, 4, 65_536);
        let mut state = e.to_bits();
        let (rms, count) = over_pixels(&a, 300, 0.5, |_, _| {
            f64::from(u8::from(crate::sampler::unit_f64(&mut state) < 0.5))
        });
        let formula = 1.0 / (4.0 * e * e);
        assert!(
            count >= 0.7 * formula && count <= 2.2 * formula + 16.0,
            "E {e}: {count} samples on average, formula {formula}"
        );
        assert!(rms >= e / 4.0 && rms <= 2.0 * e, "E {e}: RMS error {rms}");
    }
}

/// A slanted edge across a pixel seen through its Sobol sequence (x + y / 2 < 0.55 covers
/// 0.3 of it): the mean of n scrambled Sobol points converges far faster than n independent
/// samples' (the edge crosses few strata), and the spread of the sequence's blocks sees it:
/// the error is still E's, honestly, at a small fraction of the samples the variance of
/// independent samples would ask (0.21 / E^2).
#[test]
fn sobol_blocks_estimate_an_edge_honestly_with_few_samples() {
    for e in [0.01, 0.0025] {
        let a = adaptive(e, 4, 65_536);
        let (rms, count) = over_pixels(&a, 300, 0.3, |p, k| {
            let seed = crate::sampler::mix64(p) as u32;
            let (x, y) = (
                sobol_burley::sample(k, 0, seed),
                sobol_burley::sample(k, 1, seed),
            );
            f64::from(u8::from(x + y / 2.0 < 0.55))
        });
        let independent = 0.21 / (e * e);
        assert!(count < independent / 4.0, "E {e}: {count} samples");
        assert!(rms >= e / 4.0 && rms <= 2.0 * e, "E {e}: RMS error {rms}");
    }
}

/// The blocks are consecutive runs of the samples, at most [`BLOCKS`] of them, each pair
/// becoming one when a ninth would start; every count the schedule asks after the first is
/// whole blocks, and the estimate travels exactly.
#[test]
fn blocks_hold_consecutive_samples_and_steps_end_on_whole_blocks() {
    assert_eq!(
        [1, 8, 9, 16, 17, 32, 33, 4096].map(block_len),
        [1, 1, 2, 2, 4, 4, 8, 512]
    );
    assert_eq!(
        [1, 7, 9, 10, 17, 20, 33, 40, 65, 4097].map(whole_blocks),
        [1, 7, 10, 10, 20, 20, 40, 40, 80, 5120]
    );
    let mut state = 11;
    let samples: Vec<f64> = (0..100)
        .map(|_| crate::sampler::unit_f64(&mut state))
        .collect();
    for n in [3, 8, 9, 16, 40, 64, 65, 100] {
        let mut est = PixelEstimate::default();
        for &v in &samples[..n] {
            est.add(DVec3::splat(v));
        }
        let b = block_len(n as u32) as usize;
        for (j, block) in samples[..n].chunks(b).enumerate() {
            let mean = block.iter().sum::<f64>() / block.len() as f64;
            let kept = f64::from(est.blocks[j][0]);
            assert!(
                (kept - mean).abs() < 1e-6,
                "n {n}, block {j}: {kept} {mean}"
            );
        }
        assert!(est.blocks[n.div_ceil(b)..].iter().all(|m| *m == [0.0; 3]));
    }
    let a = adaptive(1e-3, 6, 1000);
    let mut est = PixelEstimate::default();
    for raise in [None, Some(true)] {
        if let Some(r) = raise {
            est.decide(r);
        }
        while let Some(want) = est.next_count(&a) {
            assert!(
                want == 6 || want == whole_blocks(want) || want == 1000,
                "{want}"
            );
            while est.count() < want {
                est.add(DVec3::splat(crate::sampler::unit_f64(&mut state)));
            }
            est.first_samples_in(&a);
        }
    }
    assert_eq!(est.count(), 1000);
    assert!(est.is_open() && est.is_done(&a));
    assert_eq!(PixelEstimate::from_le_bytes(&est.to_le_bytes()), est);
}

/// After its first samples a pixel waits for its neighbourhood: stopped, it is done there;
/// raised, it takes 4 x its first samples at least, even when it is flat itself.
#[test]
fn a_pixel_waits_for_its_decision_and_goes_on_only_when_raised() {
    let a = adaptive(0.01, 4, 1024);
    let flat = constant_pixel(DVec3::splat(0.3), &a);
    assert_eq!(flat.count(), 4);
    assert!(flat.awaits_decision(&a) && !flat.is_open() && !flat.is_done(&a));
    assert_eq!(flat.next_count(&a), None, "no samples while it waits");
    let (mut stopped, mut raised) = (flat, flat);
    stopped.decide(false);
    raised.decide(true);
    raised.decide(false);
    assert!(stopped.is_done(&a) && !stopped.awaits_decision(&a));
    assert_eq!(
        raised.next_count(&a),
        Some(16),
        "decided once: still raised"
    );
    for e in [stopped, raised] {
        assert!(e.stage_is_valid());
        assert_eq!(PixelEstimate::from_le_bytes(&e.to_le_bytes()), e);
    }
    // Open: its own first samples' spread is above the target.
    let noisy = run_decided(&a, PixelEstimate::is_open, |k| {
        DVec3::splat(f64::from(k % 2))
    });
    assert!(noisy.is_open() && noisy.count() > 16);
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
    assert_eq!(firsts, [4, 8, 16, 64, 8192, 65_536]);
    let a = Adaptive::new(0.002, None, None);
    assert_eq!((a.min_samples, a.max_samples), (64, DEFAULT_MAX_SAMPLES));
    assert_eq!(
        raised_samples(&a),
        256,
        "a raised pixel takes 4 x its first samples"
    );
    assert_eq!(raised_samples(&adaptive(0.01, 6, 1000)), 24);
    assert_eq!(
        raised_samples(&adaptive(0.01, 16, 40)),
        40,
        "at most the most"
    );
    // Never above the most asked for, and what is given is kept.
    assert_eq!(Adaptive::new(1e-4, None, Some(64)).min_samples, 64);
    assert_eq!(Adaptive::new(1e-4, Some(4), Some(64)).min_samples, 4);
    assert!(Adaptive::new(1e-4, None, Some(64)).check().is_ok());
}
