//! Solid textures (thesis 4.2): YARI's `texture = id  r,g,b  sx,sy,sz`.
//!
//! The hit point is mapped to texture space by [`yari::model::Texture::world_to_texture`] and
//! divided by `scale`; then, per [`TextureKind`]:
//! - 1 wood: rings around the texture z axis, one ring per 8 units, wobbled by noise; the
//!   rings are mixed from the base colour to the texture colour (C.5's dark veins).
//! - 2 marble: `sin` veins along x, 12 units apart, distorted by turbulence; base colour mixed
//!   towards the texture colour in the veins.
//! - 3 bumps: the normal is tilted by the noise gradient (features 4 units across, tilt up to
//!   about 0.3); the colour is the base colour.
//! - 4 turbulence: base colour mixed towards the texture colour by turbulence (clouds).
//! - 5 checker: unit cubes alternate base colour and texture colour (cell faces are shifted
//!   by 1e-4 so a plane lying on a face, like a floor at y = 0, does not flicker).

pub mod noise;

use crate::geometry::{Real, Vec3};
use noise::{noise, noise_gradient, turbulence};
use yari::model::{Texture, TextureKind};

/// Colour and shading normal of a textured surface at world point `p` with unit normal `n`.
pub fn apply(tex: &Texture, base: Vec3, p: Vec3, n: Vec3) -> (Vec3, Vec3) {
    let scale = Vec3::new(
        nonzero(tex.scale.x),
        nonzero(tex.scale.y),
        nonzero(tex.scale.z),
    );
    let q = tex.world_to_texture.transform_point3(p) / scale;
    if !q.is_finite() {
        return (base, n);
    }
    let mix = |f: Real| base.lerp(tex.color, f.clamp(0.0, 1.0));
    match tex.kind {
        TextureKind::Wood => {
            let r = (q.x * q.x + q.y * q.y).sqrt() / 8.0 + 0.6 * noise(q * 0.05);
            let ring = r - r.floor();
            // Sharp dark vein at the end of each ring.
            (mix(smoothstep(0.6, 0.9, ring)), n)
        }
        TextureKind::Marble => {
            let v = (q.x * std::f64::consts::PI / 12.0 + 6.0 * turbulence(q * 0.08, 5)).sin();
            (mix((1.0 - v.abs()).powi(3)), n)
        }
        TextureKind::Bumps => {
            let g = noise_gradient(q * 0.25);
            let tilted = (n + (g - n * g.dot(n)) * 0.3).try_normalize().unwrap_or(n);
            (base, tilted)
        }
        TextureKind::Turbulence => (mix(turbulence(q * 0.1, 6)), n),
        TextureKind::Checker => {
            // The small shift keeps faces that lie on a cell boundary (a floor at y = 0)
            // from flickering between two cells with rounding.
            let f = (q + Vec3::splat(CHECKER_SHIFT)).floor();
            let odd = (f.x as i64 + f.y as i64 + f.z as i64).rem_euclid(2) == 1;
            (if odd { tex.color } else { base }, n)
        }
    }
}

const CHECKER_SHIFT: Real = 1e-4;

fn nonzero(s: Real) -> Real {
    if s.abs() > 1e-300 && s.is_finite() {
        s
    } else {
        1.0
    }
}

fn smoothstep(a: Real, b: Real, x: Real) -> Real {
    let t = ((x - a) / (b - a)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DAffine3;

    fn tex(kind: TextureKind) -> Texture {
        Texture {
            kind,
            color: Vec3::new(0.0, 0.0, 1.0),
            scale: Vec3::ONE,
            world_to_texture: DAffine3::IDENTITY,
        }
    }

    #[test]
    fn checker_alternates_unit_cubes() {
        let t = tex(TextureKind::Checker);
        let base = Vec3::ONE;
        assert_eq!(apply(&t, base, Vec3::new(0.5, 0.5, 0.5), Vec3::Z).0, base);
        assert_eq!(
            apply(&t, base, Vec3::new(1.5, 0.5, 0.5), Vec3::Z).0,
            t.color
        );
        assert_eq!(
            apply(&t, base, Vec3::new(-0.5, 0.5, 0.5), Vec3::Z).0,
            t.color
        );
        // A plane on a cell boundary does not flicker with rounding.
        let a = apply(&t, base, Vec3::new(0.5, 1e-13, 0.5), Vec3::Y).0;
        let b = apply(&t, base, Vec3::new(0.5, -1e-13, 0.5), Vec3::Y).0;
        assert_eq!(a, b);
    }

    #[test]
    fn colours_stay_between_base_and_texture_colour() {
        for kind in [
            TextureKind::Wood,
            TextureKind::Marble,
            TextureKind::Turbulence,
        ] {
            let t = tex(kind);
            let mut seen_mix = false;
            for i in 0..200 {
                let p = Vec3::new(i as Real * 0.37, i as Real * 0.11, 3.0);
                let (c, n) = apply(&t, Vec3::ONE, p, Vec3::Z);
                assert!(
                    c.min_element() >= 0.0 && c.max_element() <= 1.0,
                    "{kind:?} {c}"
                );
                assert_eq!(n, Vec3::Z);
                seen_mix |= c != Vec3::ONE;
            }
            assert!(seen_mix, "{kind:?} never shows its colour");
        }
    }

    #[test]
    fn bumps_tilt_the_normal_but_keep_it_unit() {
        let t = tex(TextureKind::Bumps);
        let (_, n) = apply(&t, Vec3::ONE, Vec3::new(1.3, 2.2, 0.7), Vec3::Z);
        assert!((n.length() - 1.0).abs() < 1e-12);
        assert!(n != Vec3::Z && n.z > 0.5);
    }
}
