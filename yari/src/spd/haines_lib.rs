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
