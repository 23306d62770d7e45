//! The pieces of Haines's SPD vector library (`libvec.c`) the generators need, with his
//! conventions kept exactly so the output matches his programs digit for digit: 4x4 matrices
//! in row-major form applied to ROW vectors (`v' = v M`), angles in radians.

/// `MATRIX` of `def.h`: row major, row vectors.
pub type Matrix = [[f64; 4]; 4];
/// `COORD4`: x, y, z and a fourth value (a radius, or w).
pub type Coord4 = [f64; 4];

/// `lib_create_identity_matrix`.
pub fn identity() -> Matrix {
    let mut m = [[0.0; 4]; 4];
    for (i, row) in m.iter_mut().enumerate() {
        row[i] = 1.0;
    }
    m
}

/// Axes for [`rotate_matrix`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Axis {
    /// Rotation about x, from y towards z.
    X,
    /// Rotation about y, from z towards x.
    Y,
    /// Rotation about z, from x towards y.
    Z,
}

/// `lib_create_rotate_matrix` about the X, Y or Z axis.
pub fn rotate_matrix(axis: Axis, angle: f64) -> Matrix {
    let mut m = [[0.0; 4]; 4];
    let (c, s) = (angle.cos(), angle.sin());
    match axis {
        Axis::X => {
            m[0][0] = 1.0;
            m[1][1] = c;
            m[2][2] = c;
            m[1][2] = s;
            m[2][1] = -s;
        }
        Axis::Y => {
            m[1][1] = 1.0;
            m[0][0] = c;
            m[2][2] = c;
            m[2][0] = s;
            m[0][2] = -s;
        }
        Axis::Z => {
            m[2][2] = 1.0;
            m[0][0] = c;
            m[1][1] = c;
            m[0][1] = s;
            m[1][0] = -s;
        }
    }
    m[3][3] = 1.0;
    m
}

/// `lib_create_axis_rotate_matrix`: rotation by `angle` about the unit vector `axis`.
pub fn axis_rotate_matrix(axis: [f64; 3], angle: f64) -> Matrix {
    let (c, s) = (angle.cos(), angle.sin());
    let omc = 1.0 - c;
    let [x, y, z] = axis;
    [
        [
            x * x + (1.0 - x * x) * c,
            x * y * omc + z * s,
            x * z * omc - y * s,
            0.0,
        ],
        [
            x * y * omc - z * s,
            y * y + (1.0 - y * y) * c,
            y * z * omc + x * s,
            0.0,
        ],
        [
            x * z * omc + y * s,
            y * z * omc - x * s,
            z * z + (1.0 - z * z) * c,
            0.0,
        ],
        [0.0, 0.0, 0.0, 1.0],
    ]
}

/// `lib_create_translate_matrix`: the identity with `v` in the bottom row.
pub fn translate_matrix(v: [f64; 3]) -> Matrix {
    let mut m = identity();
    m[3][0] = v[0];
    m[3][1] = v[1];
    m[3][2] = v[2];
    m
}

/// `lib_create_scale_matrix`: `v` on the diagonal, 1 in the corner.
pub fn scale_matrix(v: [f64; 3]) -> Matrix {
    let mut m = [[0.0; 4]; 4];
    m[0][0] = v[0];
    m[1][1] = v[1];
    m[2][2] = v[2];
    m[3][3] = 1.0;
    m
}

/// `lib_matrix_multiply`: `a b` (with row vectors, `a` is applied first).
pub fn matrix_multiply(a: &Matrix, b: &Matrix) -> Matrix {
    std::array::from_fn(|i| {
        std::array::from_fn(|j| {
            a[i][0] * b[0][j] + a[i][1] * b[1][j] + a[i][2] * b[2][j] + a[i][3] * b[3][j]
        })
    })
}

/// `lib_transpose_matrix`.
pub fn transpose(m: &Matrix) -> Matrix {
    std::array::from_fn(|i| std::array::from_fn(|j| m[j][i]))
}

/// `lib_transform_point`: x, y, z times the upper 3x3, plus the bottom row (the
/// translation). The translation is added even when it is zero, as his code does (it turns
/// a -0 into 0).
pub fn transform_point(v: [f64; 3], m: &Matrix) -> [f64; 3] {
    std::array::from_fn(|j| v[0] * m[0][j] + v[1] * m[1][j] + v[2] * m[2][j] + m[3][j])
}

/// `lib_normalize_vector` returning the length too (his function returns the divisor).
pub fn normalize_len(v: [f64; 3]) -> ([f64; 3], f64) {
    let d = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    if d > 0.0 {
        ([v[0] / d, v[1] / d, v[2] / d], d)
    } else {
        (v, d)
    }
}

/// `lib_transform_vector`: x, y, z times the upper 3x3.
pub fn transform_vector(v: [f64; 3], m: &Matrix) -> [f64; 3] {
    [
        v[0] * m[0][0] + v[1] * m[1][0] + v[2] * m[2][0],
        v[0] * m[0][1] + v[1] * m[1][1] + v[2] * m[2][1],
        v[0] * m[0][2] + v[1] * m[1][2] + v[2] * m[2][2],
    ]
}

/// `lib_transform_coord`: a 4-vector times the matrix.
pub fn transform_coord(v: Coord4, m: &Matrix) -> Coord4 {
    std::array::from_fn(|j| v[0] * m[0][j] + v[1] * m[1][j] + v[2] * m[2][j] + v[3] * m[3][j])
}

/// `lib_transform_normal`: x, y, z times the transpose of the upper 3x3 (give it the
/// inverse of a transformation to carry normals through that transformation; the result is
/// not normalized).
pub fn transform_normal(v: [f64; 3], m: &Matrix) -> [f64; 3] {
    [
        v[0] * m[0][0] + v[1] * m[0][1] + v[2] * m[0][2],
        v[0] * m[1][0] + v[1] * m[1][1] + v[2] * m[1][2],
        v[0] * m[2][0] + v[1] * m[2][1] + v[2] * m[2][2],
    ]
}

/// `det3x3` of `libvec.c`: the determinant of the matrix with columns (a1 a2 a3), (b1 b2 b3),
/// (c1 c2 c3), in his order of operations.
#[allow(clippy::too_many_arguments)]
fn det3x3(a1: f64, a2: f64, a3: f64, b1: f64, b2: f64, b3: f64, c1: f64, c2: f64, c3: f64) -> f64 {
    a1 * (b2 * c3 - b3 * c2) - b1 * (a2 * c3 - a3 * c2) + c1 * (a2 * b3 - a3 * b2)
}

/// `lib_invert_matrix`: the adjoint divided by the determinant (`adjoint` and
/// `lib_matrix_det4x4` of `libvec.c`, term for term); the identity when the determinant is
/// smaller than `EPSILON` (1e-8) in magnitude.
pub fn invert_matrix(m: &Matrix) -> Matrix {
    let [[a1, b1, c1, d1], [a2, b2, c2, d2], [a3, b3, c3, d3], [a4, b4, c4, d4]] = *m;
    let mut out = [[0.0; 4]; 4];
    out[0][0] = det3x3(b2, b3, b4, c2, c3, c4, d2, d3, d4);
    out[1][0] = -det3x3(a2, a3, a4, c2, c3, c4, d2, d3, d4);
    out[2][0] = det3x3(a2, a3, a4, b2, b3, b4, d2, d3, d4);
    out[3][0] = -det3x3(a2, a3, a4, b2, b3, b4, c2, c3, c4);
    out[0][1] = -det3x3(b1, b3, b4, c1, c3, c4, d1, d3, d4);
    out[1][1] = det3x3(a1, a3, a4, c1, c3, c4, d1, d3, d4);
    out[2][1] = -det3x3(a1, a3, a4, b1, b3, b4, d1, d3, d4);
    out[3][1] = det3x3(a1, a3, a4, b1, b3, b4, c1, c3, c4);
    out[0][2] = det3x3(b1, b2, b4, c1, c2, c4, d1, d2, d4);
    out[1][2] = -det3x3(a1, a2, a4, c1, c2, c4, d1, d2, d4);
    out[2][2] = det3x3(a1, a2, a4, b1, b2, b4, d1, d2, d4);
    out[3][2] = -det3x3(a1, a2, a4, b1, b2, b4, c1, c2, c4);
    out[0][3] = -det3x3(b1, b2, b3, c1, c2, c3, d1, d2, d3);
    out[1][3] = det3x3(a1, a2, a3, c1, c2, c3, d1, d2, d3);
    out[2][3] = -det3x3(a1, a2, a3, b1, b2, b3, d1, d2, d3);
    out[3][3] = det3x3(a1, a2, a3, b1, b2, b3, c1, c2, c3);
    let det = a1 * det3x3(b2, b3, b4, c2, c3, c4, d2, d3, d4)
        - b1 * det3x3(a2, a3, a4, c2, c3, c4, d2, d3, d4)
        + c1 * det3x3(a2, a3, a4, b2, b3, b4, d2, d3, d4)
        - d1 * det3x3(a2, a3, a4, b2, b3, b4, c2, c3, c4);
    if det.abs() < 1.0e-8 {
        return identity();
    }
    for row in out.iter_mut() {
        for x in row.iter_mut() {
            *x /= det;
        }
    }
    out
}

/// `lib_rotate_cube_face` with the major axis z: turns `v` 90 degrees to the next face of a
/// cube; called with faces 0 to 5 in turn (cumulatively) it visits all six.
pub fn rotate_cube_face(v: &mut [f64; 3], face: usize) {
    let (a, b) = match (face + 2) % 3 {
        0 => (0, 1),
        1 => (1, 2),
        _ => (0, 2),
    };
    let swap = v[a];
    v[a] = -v[b];
    v[b] = swap;
}

/// `lib_normalize_vector` (a zero vector is returned unchanged).
pub fn normalize(v: [f64; 3]) -> [f64; 3] {
    let d = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    if d > 0.0 {
        [v[0] / d, v[1] / d, v[2] / d]
    } else {
        v
    }
}

/// `CROSS` of `def.h`.
pub fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// `lib_gauss_rand`: Haines's portable Gaussian deviate (Numerical Recipes' GASDEV driven by a
/// small linear congruential generator seeded with `seed`). Kept operation for operation,
/// including the macro expansion `ix * 2.0 * 1.0/M1`, so results match bit for bit.
pub fn gauss_rand(seed: i64) -> f64 {
    const M1: i64 = 134_456;
    const IA1: i64 = 8121;
    const IC1: i64 = 28_411;
    let mut ix2 = seed;
    loop {
        let ix1 = (IC1 + ix2 * IA1) % M1;
        ix2 = (IC1 + ix1 * IA1) % M1;
        let v1 = ix1 as f64 * 2.0 * 1.0 / M1 as f64 - 1.0;
        let v2 = ix2 as f64 * 2.0 * 1.0 / M1 as f64 - 1.0;
        let r = v1 * v1 + v2 * v2;
        if r < 1.0 {
            let fac = (-2.0 * r.ln() / r).sqrt();
            return v1 * fac;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rotations_are_orthonormal_and_row_vector() {
        // Row-vector convention: rotating x by +90 degrees about z gives +y.
        let m = rotate_matrix(Axis::Z, std::f64::consts::FRAC_PI_2);
        let v = transform_vector([1.0, 0.0, 0.0], &m);
        assert!((v[0]).abs() < 1e-15 && (v[1] - 1.0).abs() < 1e-15);
        let a = axis_rotate_matrix([0.0, 0.0, 1.0], std::f64::consts::FRAC_PI_2);
        let w = transform_vector([1.0, 0.0, 0.0], &a);
        assert!((w[1] - 1.0).abs() < 1e-15, "{w:?}");
    }

    #[test]
    fn inverse_undoes_the_matrix() {
        let m = matrix_multiply(
            &axis_rotate_matrix(normalize([1.0, 2.0, 3.0]), 0.7),
            &matrix_multiply(
                &scale_matrix([0.5, 0.5, 0.5]),
                &translate_matrix([1.0, -2.0, 3.0]),
            ),
        );
        let p = matrix_multiply(&m, &invert_matrix(&m));
        for (i, row) in p.iter().enumerate() {
            for (j, x) in row.iter().enumerate() {
                let id = if i == j { 1.0 } else { 0.0 };
                assert!((x - id).abs() < 1e-12, "{p:?}");
            }
        }
        assert_eq!(invert_matrix(&[[0.0; 4]; 4]), identity());
    }

    #[test]
    fn six_cube_face_turns_visit_every_face() {
        let mut v = [0.0, 0.0, 1.0];
        let mut seen = Vec::new();
        for face in 0..6 {
            rotate_cube_face(&mut v, face);
            seen.push(v.map(|x| x as i32));
        }
        seen.sort_unstable();
        seen.dedup();
        assert_eq!(seen.len(), 6, "{seen:?}");
    }

    #[test]
    fn gauss_rand_is_a_fixed_sequence_of_plausible_deviates() {
        let xs: Vec<f64> = (0..2000).map(gauss_rand).collect();
        let mean = xs.iter().sum::<f64>() / xs.len() as f64;
        let var = xs.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / xs.len() as f64;
        assert!(
            mean.abs() < 0.1 && (var - 1.0).abs() < 0.15,
            "mean {mean} var {var}"
        );
        assert_eq!(gauss_rand(21).to_bits(), gauss_rand(21).to_bits());
    }
}
