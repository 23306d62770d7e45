use super::jitter::{grid, stratum};
use super::*;

/// A Sobol stream's draws go in pairs, each pair one scramble of `sobol_burley`'s
/// sequence: the first draw dimensions 0 and 1, the second 2 and 3, bit for bit (a 1-D
/// draw the first of those): what every image rendered with `--sampler sobol` or a target
/// error is made of.
#[test]
fn sobol_draws_are_dimensions_0_to_3_of_their_pairs_scramble() {
    for (x, y, seed, index) in [
        (0, 0, 0, 0),
        (3, 9, 0, 1),
        (511, 7, 2, 65_535),
        (40, 2, 1, 12),
    ] {
        let mut s = SampleStream::sobol(x, y, seed, index);
        let scramble = |pair: u64| {
            let key = mix64(s.pixel_key ^ pair);
            (key ^ (key >> 32)) as u32
        };
        // Draws 1-2, 3-4, ...: 2-D and 2-D, then 2-D and 1-D, then 1-D and 2-D.
        let mut want = Vec::new();
        for (pair, shape) in [(1, [2, 2]), (2, [2, 1]), (3, [1, 2]), (4, [2, 2])] {
            let key = scramble(pair);
            for (second, width) in shape.into_iter().enumerate() {
                let first_dim = 2 * second as u32;
                for d in 0..width {
                    want.push(f64::from(sobol_burley::sample(index, first_dim + d, key)));
                }
            }
        }
        let mut got = Vec::new();
        for width in [2, 2, 2, 1, 1, 2, 2, 2] {
            if width == 2 {
                let (u, v) = s.next_2d();
                got.extend([u, v]);
            } else {
                got.push(s.next_real());
            }
        }
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(
            bits(&got),
            bits(&want),
            "pixel ({x}, {y}) seed {seed} sample {index}"
        );
    }
}

#[test]
fn streams_depend_only_on_their_key() {
    let mut a = SampleStream::new(3, 4, 5);
    let mut b = SampleStream::new(3, 4, 5);
    let mut c = SampleStream::new(4, 3, 5);
    let va: Vec<Real> = (0..8).map(|_| a.next_real()).collect();
    let vb: Vec<Real> = (0..8).map(|_| b.next_real()).collect();
    let vc: Vec<Real> = (0..8).map(|_| c.next_real()).collect();
    assert_eq!(va, vb);
    assert_ne!(va, vc);
    assert!(va.iter().all(|v| (0.0..1.0).contains(v)));
}

#[test]
fn uniform_mean_is_about_a_half() {
    let mut s = SampleStream::new(1, 2, 3);
    let mean: Real = (0..10_000).map(|_| s.next_real()).sum::<Real>() / 10_000.0;
    assert!((mean - 0.5).abs() < 0.02, "{mean}");
}

#[test]
fn stratified_offsets_fall_in_their_cells() {
    let mut s = SampleStream::new(0, 0, 0);
    for k in 0..4 {
        let (u, v) = pixel_offset(4, k, &mut s);
        assert_eq!(((u * 2.0) as u32, (v * 2.0) as u32), (k % 2, k / 2));
    }
    assert_eq!(pixel_offset(1, 0, &mut s), (0.5, 0.5));
}

#[test]
fn every_count_is_stratified_in_the_pixel() {
    for n in [2u32, 3, 8, 12, 32] {
        let mut cells = std::collections::HashSet::new();
        let (a, b) = grid(n);
        assert_eq!(a * b, n);
        for k in 0..n {
            let mut s = SampleStream::stratified(5, 6, k, k, n);
            let (u, v) = pixel_offset(n, k, &mut s);
            cells.insert(((u * a as Real) as u32, (v * b as Real) as u32));
        }
        assert_eq!(cells.len(), n as usize, "n = {n}");
    }
}

#[test]
fn secondary_draws_of_a_pixel_take_distinct_cells() {
    for n in [4u32, 16, 12, 7] {
        let (a, b) = grid(n);
        let mut cells = std::collections::HashSet::new();
        for k in 0..n {
            let mut s = SampleStream::stratified(1, 2, k, k, n);
            let _ = pixel_offset(n, k, &mut s);
            let (u, v) = s.next_2d();
            assert!((0.0..1.0).contains(&u) && (0.0..1.0).contains(&v));
            cells.insert(((u * a as Real) as u32, (v * b as Real) as u32));
        }
        assert_eq!(cells.len(), n as usize, "n = {n}");
    }
    // The mean of a stratified dimension over many pixels is still 1/2 (unbiased).
    let mut sum = 0.0;
    for x in 0..500 {
        for k in 0..4 {
            sum += SampleStream::stratified(x, 0, k, k, 4).next_2d().0;
        }
    }
    assert!((sum / 2000.0 - 0.5).abs() < 0.01, "{}", sum / 2000.0);
}

/// Every power-of-two prefix of a pixel's Sobol samples is stratified: its n points fall
/// one in each of the n strata of a 1-D draw, and one in each elementary box (2^a x 2^b,
/// a + b = log2 n) of a 2-D draw that opens a pair (dimensions 0 and 1); the pixel point
/// and a later draw alike. (A pair's second draw, dimensions 2 and 3, is stratified with
/// the first in four dimensions: [`a_pair_of_draws_is_stratified_in_four_dimensions`].)
/// Another pixel or seed is another scramble.
#[test]
fn sobol_prefixes_are_stratified_in_every_draw() {
    for (x, y, seed) in [(0, 0, 0), (17, 3, 0), (17, 3, 9)] {
        for k in 0..=8u32 {
            let n = 1u32 << k;
            let draws: Vec<[(Real, Real); 2]> = (0..n)
                .map(|i| {
                    let mut s = SampleStream::sobol(x, y, seed, i);
                    let p = pixel_offset(1, 0, &mut s);
                    let _ = s.next_real();
                    let later = s.next_2d();
                    [p, later]
                })
                .collect();
            for d in 0..2 {
                for a in 0..=k {
                    let (cols, rows) = (1u32 << a, 1u32 << (k - a));
                    let boxes: std::collections::HashSet<(u32, u32)> = draws
                        .iter()
                        .map(|p| {
                            let (u, v) = p[d];
                            ((u * cols as Real) as u32, (v * rows as Real) as u32)
                        })
                        .collect();
                    assert_eq!(boxes.len(), n as usize, "n {n}, draw {d}, {cols}x{rows}");
                }
            }
        }
        let one_d: std::collections::HashSet<u32> = (0..64)
            .map(|i| {
                let mut s = SampleStream::sobol(x, y, seed, i);
                let _ = s.next_2d();
                (s.next_real() * 64.0) as u32
            })
            .collect();
        assert_eq!(one_d.len(), 64);
    }
    let first = |x, seed| SampleStream::sobol(x, 0, seed, 0).next_2d();
    assert_ne!(first(1, 0), first(2, 0));
    assert_ne!(first(1, 0), first(1, 1));
}

/// The two draws of a pair are stratified together in four dimensions: the first 2^k
/// samples' (pixel point, lens point) put 2^3 in every elementary box of volume 2^(3-k)
/// (every split of k - 3 halvings among the four axes; the first four Sobol dimensions are
/// a (3, 4)-sequence or better). Draws scrambled each on its own are stratified only
/// pair by pair and fail this.
#[test]
fn a_pair_of_draws_is_stratified_in_four_dimensions() {
    for (x, y, seed) in [(0, 0, 0), (17, 3, 0), (17, 3, 9), (250, 90, 4)] {
        for k in 4..=10u32 {
            let n = 1u32 << k;
            let points: Vec<[Real; 4]> = (0..n)
                .map(|i| {
                    let mut s = SampleStream::sobol(x, y, seed, i);
                    let (a, b) = s.next_2d();
                    let (c, d) = s.next_2d();
                    [a, b, c, d]
                })
                .collect();
            let m = k - 3;
            for a in 0..=m {
                for b in 0..=m - a {
                    for c in 0..=m - a - b {
                        let splits = [a, b, c, m - a - b - c];
                        let mut boxes = std::collections::HashMap::new();
                        for p in &points {
                            let cell: Vec<u32> = (0..4)
                                .map(|i| (p[i] * Real::from(1u32 << splits[i])) as u32)
                                .collect();
                            *boxes.entry(cell).or_insert(0) += 1;
                        }
                        assert!(
                            boxes.len() == 1 << m && boxes.values().all(|&c| c == 8),
                            "pixel ({x}, {y}) seed {seed}, {n} samples, boxes {splits:?}"
                        );
                    }
                }
            }
        }
    }
}

/// The power-of-two paths of the grid, the cell and the permutation are the general
/// formulas to the bit, so an image rendered with 4, 16 or 64 samples keeps its bytes.
#[test]
fn power_of_two_counts_take_the_general_formulas_bit_for_bit() {
    let mut h = 99u64;
    for k in 0..=16u32 {
        let n = 1u32 << k;
        let mut a = (n as f64).sqrt() as u32;
        while a > 1 && !n.is_multiple_of(a) {
            a -= 1;
        }
        let a = a.max(1);
        assert_eq!(grid(n), (a, n / a), "grid of {n}");
        let b = n / a;
        for _ in 0..200 {
            let cell = (splitmix64(&mut h) % u64::from(n)) as u32;
            let (u, v) = (unit_f64(&mut h), unit_f64(&mut h));
            let (i, j) = (cell % a, cell / a);
            let want = ((i as Real + u) / a as Real, (j as Real + v) / b as Real);
            let got = stratum(cell, n, u, v);
            assert_eq!(
                (got.0.to_bits(), got.1.to_bits()),
                (want.0.to_bits(), want.1.to_bits())
            );
            let (p, i) = ((h >> 7) as u32, cell);
            assert_eq!(
                i.wrapping_add(p) & (n - 1),
                ((u64::from(i) + u64::from(p)) % u64::from(n)) as u32
            );
        }
    }
}

#[test]
fn disc_samples_stay_in_the_disc() {
    let mut s = SampleStream::new(9, 9, 9);
    for _ in 0..1000 {
        let (u, v) = s.next_2d();
        let (x, y) = sample_disc(u, v);
        assert!(x * x + y * y <= 1.0 + 1e-12);
    }
}
