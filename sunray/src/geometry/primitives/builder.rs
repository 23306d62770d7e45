//! Objects to primitives, one object at a time (so a model is decoded as a stream and never
//! held whole beside its primitives). Polygons are triangulated into the mesh (a smooth
//! polygon's triangles also get their corner normals in the smooth table), static
//! spheres go to their table, the rest stay [`Primitive`]s; degenerate objects are dropped
//! and listed, never turned into NaNs. Transparent static polygons are remembered until
//! [`PrimitivesBuilder::finish`], which finds the closed meshes among them
//! ([`crate::geometry::solid`]) and makes their triangles solid faces.
//!
//! A builder made by [`PrimitivesBuilder::counting`] goes through the same rules (the same
//! triangulation, limits and dropped objects) but keeps only the counts
//! ([`PrimitiveCounts`]): what a submitting host needs of a scene it ships and never renders.

use super::super::polygon::{triangulate_indexed, Degenerate};
use super::super::primitive::Dropped;
use super::super::solid::{closed_faces_of, Face, Polygon};
use super::super::{Primitive, PrimitiveKind, Vec3};
use super::{Primitives, StaticSphere, MAX_PER_KIND, OTHER, SPHERE, TRIANGLE};
use yari::model::{Object, Shape, Surface};
use yari::polygon::{against, unit_normals};

/// A transparent static polygon, a candidate face of a closed mesh.
struct Candidate {
    polygon: Polygon,
    triangles: std::ops::Range<usize>,
}

/// Builds [`Primitives`] object by object.
pub struct PrimitivesBuilder {
    out: Primitives,
    dropped: Vec<Dropped>,
    candidates: Vec<Candidate>,
    objects: usize,
    /// `Some` when only counting ([`PrimitivesBuilder::counting`]).
    counts: Option<PrimitiveCounts>,
}

/// What a counting builder keeps: the primitives the scene would have, by table.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PrimitiveCounts {
    /// Primitives in all.
    pub primitives: usize,
    /// Of those, the ones without bounds (planes, unclipped quadrics).
    pub unbounded: usize,
    /// Static triangles (the mesh).
    pub triangles: usize,
    /// Static spheres.
    pub spheres: usize,
    /// The others (ellipsoids, quadrics, moving shapes).
    pub others: usize,
}

impl PrimitiveCounts {
    /// The counts of built primitives.
    pub fn of(p: &Primitives) -> PrimitiveCounts {
        PrimitiveCounts {
            primitives: p.len(),
            unbounded: p.unbounded_count(),
            triangles: p.mesh.triangles.len(),
            spheres: p.spheres.len(),
            others: p.others.len(),
        }
    }
}

impl Default for PrimitivesBuilder {
    fn default() -> PrimitivesBuilder {
        PrimitivesBuilder::new()
    }
}

impl PrimitivesBuilder {
    /// An empty builder.
    pub fn new() -> PrimitivesBuilder {
        PrimitivesBuilder {
            out: Primitives::default(),
            dropped: Vec::new(),
            candidates: Vec::new(),
            objects: 0,
            counts: None,
        }
    }

    /// A builder that only counts: it keeps no primitive, only [`PrimitiveCounts`] and the
    /// objects dropped, as [`PrimitivesBuilder::new`]'s would be.
    pub fn counting() -> PrimitivesBuilder {
        PrimitivesBuilder {
            counts: Some(PrimitiveCounts::default()),
            ..PrimitivesBuilder::new()
        }
    }

    /// The counts so far: a counting builder's, else those of the primitives built.
    pub fn counts(&self) -> PrimitiveCounts {
        self.counts
            .unwrap_or_else(|| PrimitiveCounts::of(&self.out))
    }

    /// The objects dropped so far.
    pub fn dropped(&self) -> &[Dropped] {
        &self.dropped
    }

    /// Objects added so far.
    pub fn objects(&self) -> usize {
        self.objects
    }

    /// Adds the next object of the model, shaded with `surfaces[obj.surface]`.
    pub fn add(&mut self, surfaces: &[Surface], obj: &Object) {
        let index = self.objects;
        self.objects += 1;
        let motion = if obj.motion.is_finite() {
            obj.motion
        } else {
            Vec3::ZERO
        };
        let mk = |kind| Primitive {
            kind,
            object: index as u32,
            surface: obj.surface,
            motion,
        };
        let reason = match &obj.shape {
            Shape::Sphere { center, radius } => {
                if center.is_finite() && radius.is_finite() && *radius > 0.0 {
                    return self.add_primitive(mk(PrimitiveKind::Sphere {
                        centre: *center,
                        radius: *radius,
                    }));
                }
                "sphere with a non-positive or non-finite radius"
            }
            Shape::Ellipsoid { to_world } => {
                let det = to_world.matrix3.determinant();
                if det.is_finite() && det.abs() > 1e-300 && to_world.translation.is_finite() {
                    return self.add_primitive(mk(PrimitiveKind::Ellipsoid {
                        to_local: to_world.inverse(),
                    }));
                }
                "ellipsoid with a singular transformation"
            }
            Shape::Quadric(q) => {
                if q.q.iter().all(|c| c.is_finite()) && q.q.iter().any(|c| *c != 0.0) {
                    return self.add_primitive(mk(PrimitiveKind::Quadric(q.clone())));
                }
                "quadric with no or non-finite coefficients"
            }
            Shape::Polygon { vertices } => {
                match self.add_polygon(surfaces, obj, motion, vertices, None) {
                    Ok(()) => return,
                    Err(reason) => reason,
                }
            }
            Shape::SmoothPolygon { vertices, normals } => {
                match self.add_polygon(surfaces, obj, motion, vertices, Some(normals)) {
                    Ok(()) => return,
                    Err(reason) => reason,
                }
            }
        };
        self.dropped.push(Dropped {
            object: index,
            reason: reason.to_string(),
        });
    }

    /// Adds polygon `vertices` of object `obj` (the one being added) as triangles: to the
    /// mesh when static, as plain primitives when moving; with `normals`, each triangle's
    /// corner normals go to the smooth table (unit length, used negated when they point
    /// away from the polygon's plane normal, as [`yari::polygon::shading_normals`] turns
    /// them; the polygon is flat if they cannot be normalised).
    /// The reason it was dropped otherwise.
    fn add_polygon(
        &mut self,
        surfaces: &[Surface],
        obj: &Object,
        motion: Vec3,
        vertices: &[Vec3],
        normals: Option<&[Vec3]>,
    ) -> Result<(), &'static str> {
        let index = self.objects - 1;
        let t = match triangulate_indexed(vertices) {
            Ok(t) => t,
            Err(Degenerate::TooFewVertices) => {
                return Err("polygon with fewer than 3 distinct vertices")
            }
            Err(Degenerate::ZeroArea) => return Err("polygon with zero area"),
        };
        let normals = normals
            .filter(|n| n.len() == vertices.len())
            .and_then(unit_normals)
            .map(|n| {
                let negate = against(&n, t.normal);
                (n, negate)
            });
        if let Some(c) = self.counts.as_mut().filter(|_| motion == Vec3::ZERO) {
            if c.triangles + t.triangles.len() > MAX_PER_KIND {
                return Err("polygon beyond the most triangles a scene may have (2^30)");
            }
            c.triangles += t.triangles.len();
            c.primitives += t.triangles.len();
            return Ok(());
        }
        let corners: Vec<[Vec3; 3]> = t.triangles.iter().map(|c| c.map(|k| vertices[k])).collect();
        let first = self.out.slots.len() as u32;
        if motion == Vec3::ZERO {
            if self.out.mesh.triangles.len() + corners.len() > MAX_PER_KIND {
                return Err("polygon beyond the most triangles a scene may have (2^30)");
            }
            let range = self
                .out
                .mesh
                .add_polygon(&corners, t.normal, first, obj.surface);
            self.out
                .slots
                .edit()
                .extend(range.clone().map(|k| TRIANGLE | k as u32));
            if range.len() > 1 && super::flat(vertices, t.normal) {
                let end = first + range.len() as u32;
                self.out.flat_polygons.push([first, end]);
            }
            let transparent = surfaces
                .get(obj.surface as usize)
                .is_some_and(|s| s.kst() > 0.0);
            if transparent {
                self.candidates.push(Candidate {
                    polygon: Polygon::new(index, vertices),
                    triangles: range,
                });
            }
        } else {
            for v in corners {
                self.add_primitive(Primitive {
                    kind: PrimitiveKind::Triangle {
                        v,
                        normal: t.normal,
                        solid: false,
                    },
                    object: index as u32,
                    surface: obj.surface,
                    motion,
                });
            }
        }
        if let Some((n, negate)) = normals {
            let last = self.out.slots.len() as u32;
            for (k, tri) in t.triangles.iter().enumerate() {
                let prim = first + k as u32;
                if prim < last {
                    self.out.smooth.add(prim, tri.map(|c| n[c]), negate);
                }
            }
        }
        Ok(())
    }

    /// Adds one primitive as the next one (static triangles go to the mesh, as open or
    /// solid faces by their `solid`; static spheres to their table).
    pub fn add_primitive(&mut self, p: Primitive) {
        if self.counts.is_some() {
            return self.count_primitive(&p);
        }
        let prim = self.out.slots.len() as u32;
        let slot = match p.kind {
            PrimitiveKind::Triangle { v, normal, solid }
                if p.motion == Vec3::ZERO && self.out.mesh.triangles.len() < MAX_PER_KIND =>
            {
                let range = self.out.mesh.add_polygon(&[v], normal, prim, p.surface);
                if solid {
                    self.out.mesh.make_solid(range.clone(), false);
                }
                TRIANGLE | range.start as u32
            }
            PrimitiveKind::Sphere { centre, radius }
                if p.motion == Vec3::ZERO && self.out.spheres.len() < MAX_PER_KIND =>
            {
                self.out.spheres.push(StaticSphere {
                    centre,
                    radius,
                    prim,
                    surface: p.surface,
                });
                SPHERE | (self.out.spheres.len() - 1) as u32
            }
            _ if self.out.others.len() < MAX_PER_KIND => {
                self.out.other_prims.push(prim);
                self.out.other_bounds.push(p.bounds());
                self.out.others.push(p);
                OTHER | (self.out.others.len() - 1) as u32
            }
            _ => return self.too_many(&p),
        };
        self.out.slots.edit().push(slot);
    }

    /// [`add_primitive`](Self::add_primitive) of a counting builder: the same tables and
    /// limits, counted.
    fn count_primitive(&mut self, p: &Primitive) {
        let Some(c) = self.counts.as_mut() else {
            return;
        };
        let fits = match p.kind {
            PrimitiveKind::Triangle { .. }
                if p.motion == Vec3::ZERO && c.triangles < MAX_PER_KIND =>
            {
                c.triangles += 1;
                true
            }
            PrimitiveKind::Sphere { .. } if p.motion == Vec3::ZERO && c.spheres < MAX_PER_KIND => {
                c.spheres += 1;
                true
            }
            _ if c.others < MAX_PER_KIND => {
                c.others += 1;
                c.unbounded += usize::from(p.bounds().is_none());
                true
            }
            _ => false,
        };
        if fits {
            c.primitives += 1;
        } else {
            self.too_many(p);
        }
    }

    fn too_many(&mut self, p: &Primitive) {
        self.dropped.push(Dropped {
            object: p.object as usize,
            reason: "beyond the most primitives a scene may have".into(),
        });
    }

    /// The primitives, and the objects dropped as degenerate.
    pub fn finish(mut self) -> (Primitives, Vec<Dropped>) {
        let polygons: Vec<&Polygon> = self.candidates.iter().map(|c| &c.polygon).collect();
        let faces = closed_faces_of(&polygons);
        for (c, face) in self.candidates.iter().zip(faces) {
            match face {
                Face::Open => {}
                Face::Outward => self.out.mesh.make_solid(c.triangles.clone(), false),
                Face::Inward => self.out.mesh.make_solid(c.triangles.clone(), true),
            }
        }
        drop(self.candidates);
        let mut out = self.out;
        out.mesh.finish();
        out.smooth.finish();
        out.index_slots();
        out.slots.edit().shrink_to_fit();
        out.spheres.shrink_to_fit();
        out.others.shrink_to_fit();
        out.other_prims.shrink_to_fit();
        out.other_bounds.shrink_to_fit();
        out.flat_polygons.shrink_to_fit();
        (out, self.dropped)
    }
}
