use super::*;
use glam::DVec3;

/// The web view's live samples map of a large image picks every step-th pixel of the
/// whole map, without making it.
#[test]
fn the_samples_map_every_step_picks_the_whole_maps_pixels() {
    let a = Adaptive::new(0.01, Some(4), Some(64));
    let mut passes = LinePasses::new(a, 5, 3);
    for (i, s) in passes.summaries.iter_mut().enumerate() {
        s.samples = 4 << (i % 5);
    }
    let whole = passes.samples_map();
    let every = passes.samples_map_every(2);
    assert_eq!((every.width, every.height), (3, 2));
    for y in 0..2 {
        for x in 0..3 {
            assert_eq!(
                every.pixels[(y * 3 + x) as usize],
                whole.pixels[(2 * y * 5 + 2 * x) as usize]
            );
        }
    }
    assert_ne!(whole.pixels[0], whole.pixels[4], "the map shows the counts");
}

/// Lines come in out of order; each is decided once every line within two of it has
/// its first samples: those near the one open pixel go on, the rest are finished.
#[test]
fn a_line_waits_for_its_neighbourhood_then_goes_on_or_is_finished() {
    let a = Adaptive::new(0.01, Some(4), Some(64));
    let (w, h) = (8u32, 6u32);
    let mut passes = LinePasses::new(a, w, h);
    let flat = adaptive::constant_pixel(DVec3::splat(0.5), &a);
    let mut noisy = PixelEstimate::default();
    for k in 0..4 {
        noisy.add(DVec3::splat(f64::from(k % 2)));
    }
    noisy.first_samples_in(&a);
    assert!(noisy.is_open() && noisy.awaits_decision(&a) && !flat.is_open());
    let first = |y: u32| {
        let mut l = vec![flat; w as usize];
        if y == 0 {
            l[0] = noisy;
        }
        passes_decode(&a, w, &l)
    };
    let mut decided = Vec::new();
    for y in [5, 0, 3, 1] {
        let got = passes.pass_in(y, first(y));
        assert!(
            got.waiting && !got.more && got.decided.is_empty(),
            "line {y}"
        );
        assert_eq!(passes.stage(y), LineStage::Waiting);
    }
    assert_eq!(passes.between[&0], first(0), "held exactly");
    let (picked, columns) = passes.grant_bytes(0, 1, true);
    assert!(
        picked.is_empty(),
        "no pixel takes samples before its decision"
    );
    assert!(Columns::from_bytes(&columns, w).unwrap().is_empty());
    for y in [2, 4] {
        decided.extend(passes.pass_in(y, first(y)).decided);
    }
    let order: Vec<(u32, bool)> = decided.iter().map(|d| (d.line, d.more)).collect();
    assert_eq!(
        order,
        [
            (0, true),
            (1, true),
            (2, true),
            (3, false),
            (4, false),
            (5, false)
        ]
    );
    for d in decided.iter().filter(|d| !d.more) {
        // A finished line's record is settled: its pixels and what each took.
        assert!(d.estimates.is_empty(), "line {}", d.line);
        let (pixels, settled) = d.settled.clone().unwrap();
        let pixels = messages::pixels_from_bytes(&pixels, w).unwrap();
        assert_eq!(pixels, vec![[0.5; 3]; w as usize], "line {}", d.line);
        let settled = settled::from_bytes(&settled, w, &a).unwrap();
        assert_eq!(settled, vec![SettledPixel::of(&flat); w as usize]);
    }
    for d in decided.iter().filter(|d| d.more) {
        assert!(d.settled.is_none());
        let e = passes.decode(&d.estimates).unwrap();
        for (x, p) in e.iter().enumerate() {
            assert!(!p.awaits_decision(&a), "line {} decided", d.line);
            // Raised: within two columns and two lines of the open pixel (0, 0).
            let raised = d.line <= 2 && x <= 2;
            assert_eq!(p.is_done(&a), !raised, "line {} pixel {x}", d.line);
        }
        let stage = if d.more {
            LineStage::Pass
        } else {
            LineStage::Settled
        };
        assert_eq!(passes.stage(d.line), stage);
    }
    // Handed out decided, with the raised pixels alone.
    let decided_0 = passes.decode(&decided[0].estimates).unwrap();
    let (picked, columns) = passes.grant_bytes(0, 1, true);
    assert_eq!(columns, vec![0b0000_0111], "line 0's raised pixels");
    assert_eq!(picked, messages::estimates_to_bytes(&decided_0[..3]));
    assert_eq!(
        passes.grant_bytes(0, 1, false),
        (decided[0].estimates.clone(), Vec::new()),
        "the whole line for a worker of an earlier build"
    );
    assert_eq!(
        passes.grant_bytes(3, 1, true),
        (Vec::new(), Vec::new()),
        "a finished line is let go"
    );
    // Line 0's next passes: its raised pixels go on until they are done, each pass carrying
    // the pixels it takes alone, as a worker does.
    for pass in 1.. {
        let (bytes, columns) = passes.grant_bytes(0, pass, true);
        let taking = Columns::from_bytes(&columns, w).unwrap();
        let mut e = messages::picked_estimates_from_bytes(&bytes, &taking, w, &a).unwrap();
        for p in e.iter_mut() {
            while let Some(want) = p
                .next_count(&a)
                .filter(|&n| n <= adaptive::pass_cap(&a, pass))
            {
                while p.count() < want {
                    p.add(DVec3::splat(0.5));
                }
            }
        }
        let sent = messages::estimates_to_bytes(&e);
        let after = passes.decode_picked(0, pass, &columns, &sent).unwrap();
        let got = passes.pass_in(0, after);
        assert!(!got.waiting && got.decided.is_empty());
        if !got.more {
            let settled = settled::from_bytes(&got.settled, w, &a).unwrap();
            assert_eq!(settled[0].summary.samples, 64, "settled as it ended");
            assert!(settled[0].open && !settled[1].open);
            break;
        }
        assert!(got.settled.is_empty(), "a line going on is not settled");
        assert!(pass < adaptive::max_passes(&a), "line 0 never finished");
    }
    assert_eq!(passes.stage(0), LineStage::Settled);
    assert_eq!(
        passes.summaries()[0].samples,
        64,
        "the noisy pixel to the most"
    );
    assert_eq!(
        passes.summaries()[1].samples,
        16,
        "a raised flat one to 4 x 4"
    );
    assert_eq!(passes.summaries()[3].samples, 4, "a pixel not raised");
}

/// Past its bytes of estimates between passes, a job hands out its next passes first.
#[test]
fn past_its_held_bytes_the_next_passes_go_first() {
    let a = Adaptive::new(0.01, Some(4), Some(64));
    let line = PixelEstimate::BYTES * 8;
    let mut passes = LinePasses::new(a, 8, 6).with_held_bytes(2 * line);
    let mut noisy = PixelEstimate::default();
    (0..4).for_each(|k| noisy.add(DVec3::splat(f64::from(k % 2))));
    noisy.first_samples_in(&a);
    for y in 0..3 {
        assert!(!passes.next_passes_first(), "{y} lines held");
        let got = passes.pass_in(y, passes_decode(&a, 8, &[noisy; 8]));
        assert!(got.waiting);
    }
    assert!(passes.next_passes_first(), "3 lines held");
    assert!(!LinePasses::new(a, 8, 6).next_passes_first());
}

/// Estimates as a worker would send them, read back as the controller reads them.
fn passes_decode(a: &Adaptive, width: u32, e: &[PixelEstimate]) -> Vec<PixelEstimate> {
    messages::estimates_from_bytes(&messages::estimates_to_bytes(e), width, a).unwrap()
}

#[test]
fn estimates_that_are_not_the_lines_are_refused() {
    let a = Adaptive::new(0.01, Some(4), Some(64));
    let passes = LinePasses::new(a, 2, 3);
    let one = messages::estimates_to_bytes(&[PixelEstimate::default()]);
    assert!(passes.decode(&one).is_err(), "one pixel of two");
    let mut many = PixelEstimate::default();
    for _ in 0..65 {
        many.add(DVec3::ONE);
    }
    let e = passes
        .decode(&messages::estimates_to_bytes(&[many, many]))
        .unwrap_err()
        .to_string();
    assert!(e.contains("65 samples") && e.contains("64"), "{e}");
    // A stage byte this program does not write: unknown bits, or raised undecided.
    for stage in [8u8, 4] {
        let mut bytes = messages::estimates_to_bytes(&[PixelEstimate::default(); 2]);
        bytes[PixelEstimate::BYTES - 1] = stage;
        let e = passes.decode(&bytes).unwrap_err().to_string();
        assert!(e.contains("unknown stage"), "{stage}: {e}");
    }
}

/// A later pass's answer must carry exactly the pixels the pass takes, for a pass that
/// waits for it.
#[test]
fn a_pass_carrying_other_pixels_is_refused() {
    let a = Adaptive::new(0.01, Some(4), Some(64));
    let (w, h) = (10u32, 1u32);
    let mut passes = LinePasses::new(a, w, h);
    let mut noisy = PixelEstimate::default();
    (0..4).for_each(|k| noisy.add(DVec3::splat(f64::from(k % 2))));
    noisy.first_samples_in(&a);
    let flat = adaptive::constant_pixel(DVec3::splat(0.5), &a);
    let mut line = vec![flat; w as usize];
    line[9] = noisy;
    let decided = passes.pass_in(0, line).decided;
    assert!(decided[0].more, "pixels 7 to 9 raised");
    let (bytes, columns) = passes.grant_bytes(0, 1, true);
    assert_eq!(columns, vec![0b1000_0000, 0b0000_0011]);
    assert!(passes.decode_picked(0, 1, &columns, &bytes).is_ok());
    let refused = |columns: &[u8], bytes: &[u8], line: u32, pass: u32| {
        passes
            .decode_picked(line, pass, columns, bytes)
            .unwrap_err()
            .to_string()
    };
    let e = refused(&[0b1100_0000, 0b0000_0011], &bytes, 0, 1);
    assert!(e.contains("not the pixels the pass takes"), "{e}");
    let e = refused(&[0b1000_0000, 0b0000_0001], &bytes, 0, 1);
    assert!(e.contains("not the pixels the pass takes"), "{e}");
    let e = refused(&[0b1000_0000, 0b0000_0111], &bytes, 0, 1);
    assert!(e.contains("past the end"), "{e}");
    let e = refused(&[0b1000_0000], &bytes, 0, 1);
    assert!(e.contains("bitmap of 1 bytes"), "{e}");
    let e = refused(&columns, &bytes[1..], 0, 1);
    assert!(e.contains("per pixel for 3 pixels"), "{e}");
    let e = refused(&columns, &bytes, 0, 0);
    assert!(e.contains("no pass of the line waits"), "{e}");
    let e = LinePasses::new(a, w, h)
        .decode_picked(0, 1, &columns, &bytes)
        .unwrap_err()
        .to_string();
    assert!(e.contains("no pass of the line waits"), "{e}");
}
