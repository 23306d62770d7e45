//! Shading with interpolated normals: a smooth triangle lit through its interpolated normal,
//! from either side, against hand-computed values; reflected and refracted directions that
//! the shading normal would send through the geometric surface.

use super::secondary::{mirror_direction, refracted_direction};
use super::tests::{trace, world};
use super::TraceOptions;
use crate::geometry::Vec3;
use yari::model::{Light, Shape, Surface};

fn matte() -> Surface {
    Surface {
        ka: 0.0,
        ..Surface::default()
    }
}

fn light_at_eye() -> Vec<Light> {
    vec![Light {
        position: Vec3::new(0.0, 0.0, 5.0),
        color: Vec3::ONE,
        radius: 0.0,
    }]
}

/// The triangle (-2,-2,0) (2,-2,0) (0,2,0), wound as given, with normals leaning out.
fn smooth_triangle(reverse: bool) -> Shape {
    let mut vertices = vec![
        Vec3::new(-2.0, -2.0, 0.0),
        Vec3::new(2.0, -2.0, 0.0),
        Vec3::new(0.0, 2.0, 0.0),
    ];
    let mut normals = vec![
        Vec3::new(-1.0, -1.0, 2.0),
        Vec3::new(1.0, -1.0, 2.0),
        Vec3::new(0.0, 1.0, 1.0),
    ];
    if reverse {
        vertices.reverse();
        normals.reverse();
    }
    Shape::SmoothPolygon { vertices, normals }
}

#[test]
fn a_smooth_triangle_is_lit_by_its_interpolated_normal() {
    // The eye ray along -z hits (0,0,0), where the corners weigh 1/4, 1/4 and 1/2. By hand:
    // 1/4 (-1,-1,2)/sqrt6 + 1/4 (1,-1,2)/sqrt6 + 1/2 (0,1,1)/sqrt2
    //   = (0, 1/(2 sqrt2) - 1/(2 sqrt6), 1/sqrt6 + 1/(2 sqrt2)),
    // and the light at the eye gives the diffuse term N.z of that normalised.
    let (s2, s6) = (2f64.sqrt(), 6f64.sqrt());
    let (y, z) = (0.5 / s2 - 0.5 / s6, 1.0 / s6 + 0.5 / s2);
    let want = z / (y * y + z * z).sqrt();
    assert!((want - 0.9813).abs() < 1e-4, "{want}");
    for reverse in [false, true] {
        let w = world(vec![(smooth_triangle(reverse), matte())], light_at_eye());
        let (c, counters) = trace(w, TraceOptions::default());
        assert!(
            (c - Vec3::splat(want)).abs().max_element() < 1e-12,
            "reverse {reverse}: {c}"
        );
        assert_eq!(counters.shadow, 1);
    }
    // The same triangle flat: N.L = 1.
    let flat = Shape::Polygon {
        vertices: vec![
            Vec3::new(-2.0, -2.0, 0.0),
            Vec3::new(2.0, -2.0, 0.0),
            Vec3::new(0.0, 2.0, 0.0),
        ],
    };
    let (c, _) = trace(
        world(vec![(flat, matte())], light_at_eye()),
        TraceOptions::default(),
    );
    assert_eq!(c, Vec3::ONE);
}

#[test]
fn normals_equal_to_the_plane_normal_shade_as_the_flat_polygon() {
    let vertices = vec![
        Vec3::new(-2.0, -2.0, 0.0),
        Vec3::new(2.0, -2.0, 0.0),
        Vec3::new(0.0, 2.0, 0.0),
    ];
    let smooth = Shape::SmoothPolygon {
        vertices: vertices.clone(),
        normals: vec![Vec3::Z; 3],
    };
    let light = vec![Light {
        position: Vec3::new(3.0, 1.0, 4.0),
        color: Vec3::ONE,
        radius: 0.0,
    }];
    let (a, _) = trace(
        world(vec![(smooth, matte())], light.clone()),
        TraceOptions::default(),
    );
    let (b, _) = trace(
        world(vec![(Shape::Polygon { vertices }, matte())], light),
        TraceOptions::default(),
    );
    assert!((a - b).abs().max_element() < 1e-15, "{a} {b}");
}

#[test]
fn directions_that_would_cross_the_geometric_surface_fall_back_to_it() {
    let ng = Vec3::Z;
    let d = Vec3::new(0.0, 0.0, -1.0);
    // A shading normal tilted 84 degrees: the mirror direction about it points below.
    let nf = Vec3::new(1.0, 0.0, 0.1).normalize();
    assert!(super::optics::reflect(d, nf).dot(ng) < 0.0);
    assert_eq!(mirror_direction(d, nf, ng), Vec3::Z);
    // A mild tilt keeps the shading normal's mirror direction.
    let mild = Vec3::new(0.1, 0.0, 1.0).normalize();
    assert_eq!(
        mirror_direction(d, mild, ng),
        super::optics::reflect(d, mild)
    );
    // Leaving glass (eta 1.5) through a shading normal tilted 63 degrees, a ray can be
    // bent back out above the geometric surface; through ng instead it is totally
    // reflected: no refracted ray.
    let tilted = Vec3::new(63.3f64.to_radians().sin(), 0.0, 63.3f64.to_radians().cos());
    let d = Vec3::new(-0.878, 0.468, -0.101).normalize();
    let r = super::optics::refract(d, tilted, 1.5).unwrap();
    assert!(r.dot(ng) > 0.1, "{r}");
    assert_eq!(refracted_direction(d, tilted, ng, 1.5), None);
    // Entering glass the shading normal's direction is kept.
    let r = refracted_direction(d, tilted, ng, 1.0 / 1.5).unwrap();
    assert!(r.dot(ng) < 0.0);
    assert_eq!(Some(r), super::optics::refract(d, tilted, 1.0 / 1.5));
}
