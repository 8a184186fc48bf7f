//! What the geometry readers share: the triangle soup they produce, the
//! reading context (the file, units, caches) and the error that tells an
//! unsupported kind from a malformed entity.

use std::cell::RefCell;
use std::collections::HashMap;

use glam::{DMat4, DVec3};

use crate::error::IfcError;
use crate::step::{Entity, StepFile};

/// A triangle in some frame, with its colour (linear RGBA; alpha below
/// zero = not yet styled).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tri {
    pub p: [DVec3; 3],
    pub c: [f32; 4],
}

/// No colour yet: the item's style or the product's default fills it in.
pub const UNSET: [f32; 4] = [0.0, 0.0, 0.0, -1.0];

impl Tri {
    pub fn new(a: DVec3, b: DVec3, c: DVec3) -> Tri {
        Tri {
            p: [a, b, c],
            c: UNSET,
        }
    }

    /// Twice the area, along the normal.
    pub fn cross(&self) -> DVec3 {
        (self.p[1] - self.p[0]).cross(self.p[2] - self.p[0])
    }
}

/// Why an item gave no triangles: a kind gigawalk does not read (counted
/// by name), or an entity that breaks the schema (a warning).
#[derive(Debug)]
pub enum GeomError {
    /// The IFC class (CamelCase) or a short description of the case.
    Unsupported(String),
    Bad(IfcError),
}

impl From<IfcError> for GeomError {
    fn from(e: IfcError) -> GeomError {
        GeomError::Bad(e)
    }
}

pub type G<T> = Result<T, GeomError>;

/// A representation map's triangles and the kinds not read in it.
pub type MappedShape = (Vec<Tri>, Vec<String>);

/// The file and what is read once per file.
pub struct Ctx<'a> {
    pub step: &'a StepFile,
    /// Radians per plane angle unit.
    pub angle: f64,
    /// Metres per length unit.
    pub length: f64,
    /// IfcLocalPlacement id -> its world matrix (file units).
    pub placements: RefCell<HashMap<u32, DMat4>>,
    pub styles: crate::colour::Styles,
    /// IfcRepresentationMap id -> its triangles (map frame) and the
    /// kinds not read in it.
    pub mapped: RefCell<HashMap<u32, MappedShape>>,
    /// Malformed items skipped while reading the current product.
    pub warnings: RefCell<Vec<String>>,
    /// Parts of the current item not read (a brep's B-spline faces), by
    /// kind, each counted once per part.
    pub notes: RefCell<Vec<String>>,
    /// IfcTriangulatedFaceSet / IfcPolygonalFaceSet id -> its
    /// IfcIndexedColourMap.
    pub colour_maps: HashMap<u32, u32>,
}

impl<'a> Ctx<'a> {
    pub fn get(&self, id: u32) -> Result<Entity<'a>, IfcError> {
        self.step.get(id)
    }

    /// Entity `id`, which must be of one of `types`.
    pub fn expect(&self, id: u32, types: &[&str]) -> G<Entity<'a>> {
        let e = self.get(id)?;
        if types.contains(&e.ty) {
            Ok(e)
        } else {
            Err(GeomError::Unsupported(crate::classes::camel(e.ty)))
        }
    }

    /// Segments for a full circle of radius `r` (file units): chords
    /// within 1 mm of the arc or 0.5 rad apart, whichever is finer, as
    /// IfcOpenShell's default deflections, capped for huge radii.
    pub fn circle_segments(&self, r: f64, sweep: f64) -> usize {
        let r_m = (r * self.length).abs();
        let deflection = 0.001;
        let step = if r_m > deflection {
            (2.0 * (1.0 - deflection / r_m).acos()).min(0.5)
        } else {
            0.5
        };
        let n = (sweep.abs() / step).ceil();
        (n as usize).clamp(3, 256)
    }
}

/// Transforms triangles by `m`, keeping them facing outward when `m`
/// mirrors.
pub fn transform(tris: &mut [Tri], m: &DMat4) {
    let flip = m.determinant() < 0.0;
    for t in tris {
        for p in &mut t.p {
            *p = m.transform_point3(*p);
        }
        if flip {
            t.p.swap(1, 2);
        }
    }
}
