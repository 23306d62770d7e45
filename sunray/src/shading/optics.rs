//! Reflection and refraction directions, and the Fresnel factor of a dielectric.

use crate::geometry::{Real, Vec3};

/// Mirror direction of `d` about the unit normal `n`.
#[inline]
pub fn reflect(d: Vec3, n: Vec3) -> Vec3 {
    d - n * (2.0 * d.dot(n))
}

/// Refraction of the unit direction `d` through a surface with unit normal `n` facing against
/// `d`, with `eta` = n_incident / n_transmitted; None on total internal reflection.
#[inline]
pub fn refract(d: Vec3, n: Vec3, eta: Real) -> Option<Vec3> {
    let cos_i = -d.dot(n);
    let sin2_t = eta * eta * (1.0 - cos_i * cos_i).max(0.0);
    if sin2_t > 1.0 {
        return None;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    Some(d * eta + n * (eta * cos_i - cos_t))
}

/// Fresnel reflectance of unpolarised light at a dielectric boundary: incidence cosine
/// `cos_i` (>= 0), refractive indices `n_i` (incident side) and `n_t`. 1 on total internal
/// reflection.
pub fn fresnel(cos_i: Real, n_i: Real, n_t: Real) -> Real {
    let cos_i = cos_i.clamp(0.0, 1.0);
    let eta = n_i / n_t;
    let sin2_t = eta * eta * (1.0 - cos_i * cos_i);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    let rs = (n_i * cos_i - n_t * cos_t) / (n_i * cos_i + n_t * cos_t);
    let rp = (n_i * cos_t - n_t * cos_i) / (n_i * cos_t + n_t * cos_i);
    let f = 0.5 * (rs * rs + rp * rp);
    if f.is_finite() {
        f.clamp(0.0, 1.0)
    } else {
        1.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normal_incidence_glass_reflects_four_percent() {
        let f = fresnel(1.0, 1.0, 1.5);
        assert!((f - 0.04).abs() < 1e-12, "{f}");
        assert_eq!(fresnel(1.0, 1.5, 1.5), 0.0);
        assert!(
            (fresnel(0.0, 1.0, 1.5) - 1.0).abs() < 1e-12,
            "grazing reflects everything"
        );
    }

    #[test]
    fn snell_and_total_internal_reflection() {
        let d = Vec3::new(0.5, -(0.75_f64).sqrt(), 0.0); // 30 degrees from the normal
        let t = refract(d, Vec3::Y, 1.0 / 1.5).unwrap();
        assert!((t.length() - 1.0).abs() < 1e-12);
        assert!((t.x - 0.5 / 1.5).abs() < 1e-12, "sin t = sin i / 1.5");
        let grazing = Vec3::new(0.9, -(0.19_f64).sqrt(), 0.0);
        assert!(refract(grazing, Vec3::Y, 1.5).is_none());
        assert_eq!(fresnel(0.19_f64.sqrt(), 1.5, 1.0), 1.0);
        assert_eq!(reflect(d, Vec3::Y), Vec3::new(0.5, (0.75_f64).sqrt(), 0.0));
    }
}
