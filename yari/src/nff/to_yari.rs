//! The NFF to YARI mapping (the thesis's `nff2gfx`); `docs/nff-mapping.md` explains each rule.
//!
//! - `b` -> `background`. NFF has no ambient light; Haines's SPD README asks for one, and
//!   for an ambient term on every object: `ambient` is white times sqrt(n)/(2n) for n lights
//!   (1/2 with none), and each surface's `ka` makes its ambient term Kd * rgb, like its
//!   diffuse term.
//! - `v` -> `camera` with HALF of NFF's full `angle`, and `resolution`; `hither` has no YARI
//!   counterpart and is dropped.
//! - `l` -> `light`; every light's colour (white when none is given) is scaled by
//!   sqrt(n)/(2n) for n lights, the relative intensity Haines's SPD README gives.
//! - `f` -> `attribute` on the Hall model: kdr = 1 - Ks, kdt = 1 - T, colour = rgb Kd / kdr
//!   (so the diffuse term kdr * colour is NFF's Kd * rgb), phong = Shine, refract = ior.
//! - `s` -> `sphere`, `p` -> `polygon`, `pp` -> `polygon` with `normals = ...` (shaded
//!   flat, without them, when one of its normals has no direction), `c` -> a clipped
//!   `quadric` ([`super::cone`]).

use super::cone::cone_quadric;
use super::scene::{Entity, Fill, NffScene};
use crate::ast::{
    has_direction, AttrField, BodyItem, CameraDef, ColorSpec, LightDef, Primitive, Scene, Spanned,
    Vec3, ViewStmt,
};
use crate::span::Span;

/// Maps an NFF scene onto the YARI syntax tree. Spans point into the NFF source.
pub fn to_yari(nff: &NffScene) -> Scene {
    let mut scene = Scene::default();
    let mut mapping = Mapping::default();
    for e in &nff.entities {
        if let Some(item) = mapping.entity(e.clone()) {
            scene.body.items.push(item);
        }
    }
    scene.view = mapping.view();
    if let (Some(first), Some(last)) = (scene.body.items.first(), scene.body.items.last()) {
        scene.body.span = first.span.to(last.span);
    }
    scene
}

/// The mapping applied entity by entity, as a reader hands them over: each `f`, `s`, `p`,
/// `pp` and `c` becomes a world-block item at once; `b`, `v` and `l` are kept for the
/// preamble, which is complete only at the end (every light's intensity depends on how
/// many there are).
#[derive(Default)]
pub struct Mapping {
    view: Vec<Spanned<ViewStmt>>,
    lights: usize,
    first: Option<Span>,
}

impl Mapping {
    /// The world-block item of one entity, if it makes one (a degenerate cone makes none).
    pub fn entity(&mut self, e: Spanned<Entity>) -> Option<Spanned<BodyItem>> {
        let span = e.span;
        self.first.get_or_insert(span);
        let primitive = match e.node {
            Entity::Background(c) => {
                let stmt = ViewStmt::Background(rgb(c, span));
                self.view.push(Spanned::new(stmt, span));
                return None;
            }
            Entity::View(v) => {
                if let Some([x, y]) = v.resolution {
                    self.view
                        .push(Spanned::new(ViewStmt::Resolution(x, y), span));
                }
                let camera = CameraDef {
                    position: v.from,
                    at: v.at,
                    up: v.up,
                    angle: v.angle / 2.0,
                    aperture: None,
                    focus: None,
                };
                self.view.push(Spanned::new(ViewStmt::Camera(camera), span));
                return None;
            }
            Entity::Light { position, color } => {
                // Scaled by the number of lights in `view`.
                let light = LightDef {
                    position,
                    color: rgb(color.unwrap_or([1.0; 3]), span),
                    radius: None,
                };
                self.lights += 1;
                self.view.push(Spanned::new(ViewStmt::Light(light), span));
                return None;
            }
            Entity::Fill(f) => {
                let fields = fill_attribute(&f)
                    .into_iter()
                    .map(|a| Spanned::new(a, span))
                    .collect();
                return Some(Spanned::new(BodyItem::Attribute(fields), span));
            }
            Entity::Sphere { center, radius } => Primitive::Sphere { center, radius },
            Entity::Polygon { vertices, normals } => {
                let normals =
                    normals.filter(|n| n.len() == vertices.len() && n.iter().all(has_direction));
                Primitive::Polygon { vertices, normals }
            }
            Entity::Cone {
                base,
                base_radius,
                apex,
                apex_radius,
            } => cone_quadric(base, base_radius, apex, apex_radius)?,
        };
        Some(Spanned::new(BodyItem::Primitive(primitive), span))
    }

    /// The preamble: Haines's ambient light (NFF has none; explicitly rather than YARI's
    /// default), then the `b`, `v` and `l` statements in order, each light's colour scaled
    /// by [`haines_intensity`].
    pub fn view(self) -> Vec<Spanned<ViewStmt>> {
        let scale = haines_intensity(self.lights);
        let first = self.first.unwrap_or_default();
        let mut view = Vec::with_capacity(self.view.len() + 1);
        view.push(Spanned::new(
            ViewStmt::Ambient(rgb([scale; 3], first)),
            first,
        ));
        for mut stmt in self.view {
            if let ViewStmt::Light(l) = &mut stmt.node {
                if let ColorSpec::Rgb(c) = &mut l.color.node {
                    *c = c.map(|x| x * scale);
                }
            }
            view.push(stmt);
        }
        view
    }
}

/// The relative intensity of each light and of the ambient light for `lights` lights,
/// Haines's sqrt(n)/(2n) (SPD README): 1/2 for one light (and for none), 0.2236 for five.
pub fn haines_intensity(lights: usize) -> f64 {
    let n = lights.max(1) as f64;
    n.sqrt() / (2.0 * n)
}

/// The Hall-model attribute fields of an NFF fill. `ka` makes the ambient term `ka * colour`
/// equal `Kd * rgb`, as the diffuse term is.
pub fn fill_attribute(f: &Fill) -> Vec<AttrField> {
    let kd = f.kd.clamp(0.0, 1.0);
    let kdr = (1.0 - f.ks).clamp(0.0, 1.0);
    let kdt = (1.0 - f.t).clamp(0.0, 1.0);
    let color = if kdr > 0.0 {
        f.color.map(|c| c * kd / kdr)
    } else {
        f.color
    };
    let refract = if f.ior > 0.0 { f.ior } else { 1.0 };
    vec![
        AttrField::Color(Spanned::new(ColorSpec::Rgb(color), Span::default())),
        AttrField::Kdr(kdr),
        AttrField::Kdt(kdt),
        AttrField::Ka(if kdr > 0.0 { kdr } else { kd }),
        AttrField::Phong(f.shine),
        AttrField::Refract(refract),
    ]
}

fn rgb(c: Vec3, span: Span) -> Spanned<ColorSpec> {
    Spanned::new(ColorSpec::Rgb(c), span)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::nff::scene::View;

    fn attr(fields: &[AttrField]) -> (Vec3, f64, f64, f64, f64, f64) {
        let mut out = ([0.0; 3], -1.0, -1.0, -1.0, -1.0, -1.0);
        for f in fields {
            match f {
                AttrField::Color(c) => match &c.node {
                    ColorSpec::Rgb(c) => out.0 = *c,
                    ColorSpec::Named(_) => panic!(),
                },
                AttrField::Kdr(x) => out.1 = *x,
                AttrField::Kdt(x) => out.2 = *x,
                AttrField::Ka(x) => out.3 = *x,
                AttrField::Phong(x) => out.4 = *x,
                AttrField::Refract(x) => out.5 = *x,
                _ => panic!(),
            }
        }
        out
    }

    #[test]
    fn spd_fills_map_onto_hall() {
        // mount6's glass: f 1 1 1 0.1 0.1 101.148 0.9 1.5
        let glass = Fill {
            color: [1.0; 3],
            kd: 0.1,
            ks: 0.1,
            shine: 101.148,
            t: 0.9,
            ior: 1.5,
        };
        let (c, kdr, kdt, ka, phong, refract) = attr(&fill_attribute(&glass));
        assert!((kdr - 0.9).abs() < 1e-12 && (kdt - 0.1).abs() < 1e-12);
        assert!(
            (kdr * c[0] - 0.1).abs() < 1e-12,
            "diffuse term must stay Kd * rgb"
        );
        assert_eq!((ka, phong, refract), (kdr, 101.148, 1.5));
        assert!(
            (ka * c[0] - 0.1).abs() < 1e-12,
            "ambient term Kd * rgb, as the diffuse term"
        );
        // mount6's rock: f 0.5 0.45 0.35 1 0 100000 0 0 (ior 0 becomes 1)
        let rock = Fill {
            color: [0.5, 0.45, 0.35],
            kd: 1.0,
            ks: 0.0,
            shine: 100000.0,
            t: 0.0,
            ior: 0.0,
        };
        let (c, kdr, kdt, _, _, refract) = attr(&fill_attribute(&rock));
        assert_eq!((c, kdr, kdt, refract), ([0.5, 0.45, 0.35], 1.0, 1.0, 1.0));
        // balls4's mirror: f 1 0.9 0.7 0.5 0.5 3.0827 0 1
        let mirror = Fill {
            color: [1.0, 0.9, 0.7],
            kd: 0.5,
            ks: 0.5,
            shine: 3.0827,
            t: 0.0,
            ior: 1.0,
        };
        let (c, kdr, kdt, _, _, _) = attr(&fill_attribute(&mirror));
        assert_eq!((c, kdr, kdt), ([1.0, 0.9, 0.7], 0.5, 1.0));
        // A perfect mirror keeps its colour (irrelevant, no diffuse term).
        let perfect = Fill {
            color: [0.2, 0.3, 0.4],
            kd: 0.0,
            ks: 1.0,
            shine: 10.0,
            t: 0.0,
            ior: 1.0,
        };
        let (c, _, _, ka, _, _) = attr(&fill_attribute(&perfect));
        assert_eq!(
            (c, ka),
            ([0.2, 0.3, 0.4], 0.0),
            "Kd 0: no ambient term either"
        );
        // A diffuse mirror (Ks 1, Kd 0.5): colour rgb, so ka is Kd.
        let shiny = Fill { kd: 0.5, ..perfect };
        assert_eq!(attr(&fill_attribute(&shiny)).3, 0.5);
    }

    #[test]
    fn haines_intensities() {
        assert_eq!(haines_intensity(0), 0.5);
        assert_eq!(haines_intensity(1), 0.5);
        assert!((haines_intensity(3) - 0.288_675).abs() < 1e-6);
        assert!((haines_intensity(5) - 0.223_607).abs() < 1e-6);
        assert!((haines_intensity(7) - 0.188_982).abs() < 1e-6);
    }

    #[test]
    fn view_lights_and_primitives() {
        let mut nff = NffScene::default();
        nff.push(Entity::Background([0.1, 0.2, 0.3]));
        nff.push(Entity::View(View {
            from: [0.0, -5.0, 0.0],
            at: [0.0; 3],
            up: [0.0, 0.0, 1.0],
            angle: 45.0,
            hither: 1.0,
            resolution: Some([640, 480]),
        }));
        for i in 0..4 {
            nff.push(Entity::Light {
                position: [i as f64, 0.0, 0.0],
                color: None,
            });
        }
        nff.push(Entity::Sphere {
            center: [0.0; 3],
            radius: 1.0,
        });
        nff.push(Entity::Cone {
            base: [0.0; 3],
            base_radius: 1.0,
            apex: [0.0, 0.0, 1.0],
            apex_radius: 1.0,
        });
        let y = to_yari(&nff);
        let mut saw = (false, false, 0);
        for s in &y.view {
            match &s.node {
                ViewStmt::Camera(c) => {
                    assert_eq!(c.angle, 22.5);
                    saw.0 = true;
                }
                ViewStmt::Ambient(c) => {
                    // Haines's sqrt(n)/(2n) for 4 lights, as each light.
                    assert_eq!(c.node, ColorSpec::Rgb([0.25; 3]));
                    saw.1 = true;
                }
                ViewStmt::Light(l) => {
                    assert_eq!(l.color.node, ColorSpec::Rgb([0.25; 3]));
                    saw.2 += 1;
                }
                _ => {}
            }
        }
        assert_eq!(saw, (true, true, 4));
        assert_eq!(y.body.items.len(), 2);
        assert!(matches!(
            y.body.items[1].node,
            BodyItem::Primitive(Primitive::Quadric { .. })
        ));
    }

    #[test]
    fn pp_keeps_its_normals_into_the_model() {
        use crate::model::Shape;
        let text = "v\nfrom 0 0 5\nat 0 0 0\nup 0 1 0\nangle 40\nhither 1\nresolution 8 8\n\
                    l 0 0 5\nf 1 1 1 1 0 0 0 1\n\
                    pp 3\n0 0 0 -1 -1 1\n1 0 0 1 0 2\n0 1 0 0 1 1\n\
                    p 3\n0 0 1\n1 0 1\n0 1 1\n\
                    pp 3\n0 0 2 0 0 1\n1 0 2 0 0 0\n0 1 2 0 0 1\n";
        let src = crate::span::Source::new("t.nff", text);
        let (scene, warnings) = crate::nff::parse_with_warnings(&src).unwrap();
        // The pp with a zero normal is shaded flat, with a located warning.
        let w: Vec<String> = warnings.warnings().map(|d| d.message.clone()).collect();
        assert_eq!(w.len(), 1, "{w:?}");
        assert!(
            w[0].contains("the normal of vertex 2 has no direction"),
            "{w:?}"
        );
        assert!(warnings.render(&src).contains("t.nff:20:7: warning:"));
        let world = crate::compile::compile(&scene, &crate::colour::ColourTable::builtin())
            .unwrap()
            .world;
        let shapes: Vec<&Shape> = world.objects.iter().map(|o| &o.shape).collect();
        match shapes[0] {
            Shape::SmoothPolygon { vertices, normals } => {
                assert_eq!(vertices[1], glam::DVec3::X);
                assert_eq!(
                    normals,
                    &vec![
                        glam::DVec3::new(-1.0, -1.0, 1.0),
                        glam::DVec3::new(1.0, 0.0, 2.0),
                        glam::DVec3::new(0.0, 1.0, 1.0)
                    ]
                );
            }
            other => panic!("{other:?}"),
        }
        assert!(matches!(shapes[1], Shape::Polygon { .. }));
        assert!(matches!(shapes[2], Shape::Polygon { .. }));
        // And back to YARI text with the normals.
        let yari = crate::writer::write_scene(&scene);
        assert!(yari.contains("normals =  -1,-1,1  1,0,2  0,1,1)"), "{yari}");
    }
}
