//! The finished primitives in two parts, for a prepared scene file
//! ([`crate::prepared`]): the large tables ([`Tables`]: slots, corners, triangles), which a
//! file holds as flat arrays and gives back as views into its mapping, and the rest
//! ([`Rest`]: spheres, other primitives, smooth normals; small for a big mesh), serialized.
//! Put back together, they are the primitives that were taken apart, to the bit, so the
//! images are the same.

use super::mesh::{Mesh, MeshTriangle};
use super::smooth::SmoothTable;
use super::{Primitives, Slot, StaticSphere, KIND, OTHER, SPHERE, TRIANGLE};
use crate::geometry::{Aabb, Primitive, Vec3};
use crate::store::Store;

/// The large tables of the primitives.
#[derive(Clone, Debug, Default)]
pub struct Tables {
    /// Primitive number to slot.
    pub slots: Store<Slot>,
    /// The mesh's distinct corners.
    pub vertices: Store<Vec3>,
    /// The mesh's triangles.
    pub triangles: Store<MeshTriangle>,
}

/// Everything of the primitives but their large tables.
#[derive(Clone, Debug, Default, serde::Serialize, serde::Deserialize)]
pub struct Rest {
    mesh_normals: Vec<Vec3>,
    spheres: Vec<StaticSphere>,
    other_prims: Vec<u32>,
    others: Vec<Primitive>,
    other_bounds: Vec<Option<Aabb>>,
    smooth: SmoothTable,
    flat_polygons: Vec<[u32; 2]>,
    ordered: bool,
}

impl Primitives {
    /// The large tables, as slices (for writing).
    pub fn table_slices(&self) -> (&[Slot], &[Vec3], &[MeshTriangle]) {
        (&self.slots, &self.mesh.vertices, &self.mesh.triangles)
    }

    /// A copy of everything but the large tables.
    pub fn rest(&self) -> Rest {
        Rest {
            mesh_normals: self.mesh.normals().to_vec(),
            spheres: self.spheres.clone(),
            other_prims: self.other_prims.clone(),
            others: self.others.clone(),
            other_bounds: self.other_bounds.clone(),
            smooth: self.smooth.clone(),
            flat_polygons: self.flat_polygons.clone(),
            ordered: self.ordered,
        }
    }

    /// The primitives of `tables` and `rest`, checked so that every index points at
    /// something: every slot into its table, every table entry back at its primitive,
    /// every triangle at corners and a normal that exist.
    pub fn from_parts(tables: Tables, rest: Rest) -> Result<Primitives, String> {
        let mesh = Mesh::from_tables(tables.vertices, tables.triangles, rest.mesh_normals)?;
        let n = tables.slots.len();
        let others = rest.others.len();
        if rest.other_prims.len() != others || rest.other_bounds.len() != others {
            return Err("the other primitives' tables differ in length".into());
        }
        if mesh.triangles.len() + rest.spheres.len() + others != n {
            return Err("the tables do not hold one entry per primitive".into());
        }
        if rest
            .flat_polygons
            .iter()
            .any(|r| r[0] > r[1] || r[1] as usize > n)
        {
            return Err("a flat polygon past the primitives".into());
        }
        let prims = Primitives {
            slots: tables.slots,
            mesh,
            spheres: rest.spheres,
            other_prims: rest.other_prims,
            others: rest.others,
            other_bounds: rest.other_bounds,
            smooth: rest.smooth,
            flat_polygons: rest.flat_polygons,
            ordered: rest.ordered,
        };
        let consistent = (0..n as u32).all(|i| prims.prim_of_checked(prims.slot(i)) == Some(i));
        if !consistent {
            return Err("a slot does not lead back to its primitive".into());
        }
        Ok(prims)
    }

    /// The primitive number of `slot`, or None when its table has no such entry.
    pub fn prim_of_checked(&self, slot: Slot) -> Option<u32> {
        let k = (slot & !KIND) as usize;
        match slot & KIND {
            TRIANGLE => self.mesh.triangles.get(k).map(|t| t.prim),
            SPHERE => self.spheres.get(k).map(|s| s.prim),
            OTHER => self.other_prims.get(k).copied(),
            _ => None,
        }
    }

    /// Whether the large tables are views into a mapped file.
    pub fn is_mapped(&self) -> bool {
        self.slots.is_mapped() && self.mesh.triangles.is_mapped() && self.mesh.vertices.is_mapped()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn prims() -> Primitives {
        let w = crate::bench::spd_world(yari::spd::Database::Tetra, 2).unwrap();
        let mut p = crate::scene::Scene::new(w).prims;
        crate::accel::bvh::Bvh::build(&mut p);
        p
    }

    fn tables_of(p: &Primitives) -> Tables {
        let (s, v, t) = p.table_slices();
        Tables {
            slots: s.to_vec().into(),
            vertices: v.to_vec().into(),
            triangles: t.to_vec().into(),
        }
    }

    #[test]
    fn primitives_taken_apart_and_put_back_are_the_same() {
        let p = prims();
        let back = Primitives::from_parts(tables_of(&p), p.rest()).unwrap();
        assert_eq!(back.len(), p.len());
        for i in 0..p.len() as u32 {
            assert_eq!(back.slot(i), p.slot(i));
            assert_eq!(back.bounds(i), p.bounds(i));
            assert_eq!(back.surface(i), p.surface(i));
        }
    }

    #[test]
    fn tables_that_do_not_fit_together_are_refused() {
        let p = prims();
        let mut t = tables_of(&p);
        t.slots.edit().swap(0, 1);
        assert!(Primitives::from_parts(t, p.rest()).is_err());
        let mut t = tables_of(&p);
        t.slots.edit().pop();
        assert!(Primitives::from_parts(t, p.rest()).is_err());
        let mut t = tables_of(&p);
        t.vertices.edit().pop();
        assert!(Primitives::from_parts(t, p.rest()).is_err());
    }
}
