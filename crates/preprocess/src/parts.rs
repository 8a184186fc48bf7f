//! The working objects the pipeline reshapes: sets of triangles that point
//! into the imported model, so partitioning and clustering move indices,
//! never geometry. Also the input checks that make every later step safe.

use gigawalk_import::Object;

use crate::identity::{Identities, Seen};
use crate::source::{Source, SpillError};
use gigawalk_scene::Aabb;
use glam::DVec3;
use rayon::prelude::*;

/// Triangles of one imported object that belong to a part, sorted.
#[derive(Clone, Debug, PartialEq)]
pub struct Piece {
    pub object: u32,
    pub triangles: Tris,
}

/// Sorted triangle indices of one object: all of them, kept as their
/// count (most pieces of most models: 4 bytes a triangle saved), or a
/// list.
#[derive(Clone, Debug, PartialEq)]
pub enum Tris {
    /// Triangles `0..n`.
    All(u32),
    List(Vec<u32>),
}

impl Tris {
    /// `list`, sorted and of distinct indices of an object of
    /// `object_triangles` triangles: [`Tris::All`] when it holds them all.
    pub fn of(list: Vec<u32>, object_triangles: usize) -> Tris {
        if list.len() == object_triangles {
            Tris::All(list.len() as u32)
        } else {
            Tris::List(list)
        }
    }

    pub fn len(&self) -> usize {
        match self {
            Tris::All(n) => *n as usize,
            Tris::List(v) => v.len(),
        }
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The indices, in order.
    pub fn iter(&self) -> impl Iterator<Item = u32> + '_ {
        let (all, list) = match self {
            Tris::All(n) => (0..*n, &[][..]),
            Tris::List(v) => (0..0, &v[..]),
        };
        all.chain(list.iter().copied())
    }

    /// The indices as a list.
    pub fn to_vec(&self) -> Vec<u32> {
        self.iter().collect()
    }
}

/// One working object: after Partition-I a piece of one imported object,
/// after clustering a union of such pieces.
#[derive(Clone, Debug, PartialEq)]
pub struct Part {
    /// Sorted by object.
    pub pieces: Vec<Piece>,
    /// Box of the part's vertices.
    pub bounds: Aabb,
    pub triangles: usize,
}

/// Why a model cannot be preprocessed.
#[derive(Debug, thiserror::Error, PartialEq)]
#[non_exhaustive]
pub enum InputError {
    #[error("object {index} ({name}): index count {count} is not a multiple of 3")]
    IndexCount {
        index: usize,
        name: String,
        count: usize,
    },
    #[error("object {index} ({name}): triangle {triangle} uses vertex {vertex}, but the object has {vertices} vertices")]
    IndexOutOfRange {
        index: usize,
        name: String,
        triangle: usize,
        vertex: u32,
        vertices: usize,
    },
    #[error("object {index} ({name}): vertex {vertex} has a non-finite position")]
    NonFinite {
        index: usize,
        name: String,
        vertex: usize,
    },
    #[error("object {index} ({name}): {what} has {got} entries for {vertices} vertices")]
    AttributeCount {
        index: usize,
        name: String,
        what: &'static str,
        got: usize,
        vertices: usize,
    },
    #[error(
        "object {index} ({name}) has {vertices} vertices, more than 32-bit indices can address"
    )]
    TooManyVertices {
        index: usize,
        name: String,
        vertices: usize,
    },
    #[error("the model has no triangles (after dropping {dropped} degenerate ones)")]
    Empty { dropped: u64 },
    #[error(transparent)]
    Spill(#[from] SpillError),
}

/// The positions of triangle `t` of `o`.
#[inline]
pub fn triangle(o: &Object, t: u32) -> [DVec3; 3] {
    let i = 3 * t as usize;
    [
        o.positions[o.indices[i] as usize],
        o.positions[o.indices[i + 1] as usize],
        o.positions[o.indices[i + 2] as usize],
    ]
}

/// Checks every object and lists, per object, the triangles worth keeping:
/// degenerate ones (a repeated vertex or zero area) are dropped and counted.
/// Returns one part per object that keeps any triangle.
pub fn initial_parts(model: &dyn Source) -> Result<(Vec<Part>, u64), InputError> {
    initial_parts_identified(model).map(|(parts, dropped, _)| (parts, dropped))
}

/// [`initial_parts`], and who each object is (the scene's object table).
pub(crate) fn initial_parts_identified(
    model: &dyn Source,
) -> Result<(Vec<Part>, u64, Identities), InputError> {
    /// An object's part, degenerate triangles dropped and identity.
    type Checked = Option<(Part, u64, Seen)>;
    let per_object: Vec<Result<Checked, InputError>> = (0..model.len())
        .into_par_iter()
        .map(|index| {
            let o = model.object(index as u32)?;
            Ok(check_object(index, &o)?.map(|(p, d)| {
                let seen = Seen::of(index as u32, &o, p.bounds, p.triangles as u64);
                (p, d, seen)
            }))
        })
        .collect();
    let mut parts = Vec::new();
    let mut seen = Vec::new();
    let mut dropped = 0;
    for r in per_object {
        if let Some((p, d, s)) = r? {
            dropped += d;
            parts.push(p);
            seen.push(s);
        }
    }
    if parts.is_empty() {
        return Err(InputError::Empty { dropped });
    }
    Ok((parts, dropped, Identities::new(model.len(), seen)))
}

fn check_object(index: usize, o: &Object) -> Result<Option<(Part, u64)>, InputError> {
    let name = || o.name.clone();
    let nv = o.positions.len();
    if nv > u32::MAX as usize {
        return Err(InputError::TooManyVertices {
            index,
            name: name(),
            vertices: nv,
        });
    }
    if !o.indices.len().is_multiple_of(3) {
        return Err(InputError::IndexCount {
            index,
            name: name(),
            count: o.indices.len(),
        });
    }
    if o.normals.len() != nv {
        return Err(InputError::AttributeCount {
            index,
            name: name(),
            what: "normals",
            got: o.normals.len(),
            vertices: nv,
        });
    }
    if let Some(c) = &o.vertex_colours {
        if c.len() != nv {
            return Err(InputError::AttributeCount {
                index,
                name: name(),
                what: "vertex colours",
                got: c.len(),
                vertices: nv,
            });
        }
    }
    if let Some(vertex) = o.positions.iter().position(|p| !p.is_finite()) {
        return Err(InputError::NonFinite {
            index,
            name: name(),
            vertex,
        });
    }
    let tris = o.indices.len() / 3;
    let mut keep = Vec::with_capacity(tris);
    let mut dropped = 0u64;
    let mut bounds = Aabb::EMPTY;
    for t in 0..tris {
        let idx = &o.indices[3 * t..3 * t + 3];
        if let Some(&vertex) = idx.iter().find(|&&v| v as usize >= nv) {
            return Err(InputError::IndexOutOfRange {
                index,
                name: name(),
                triangle: t,
                vertex,
                vertices: nv,
            });
        }
        let [a, b, c] = triangle(o, t as u32);
        let repeated = idx[0] == idx[1] || idx[1] == idx[2] || idx[0] == idx[2];
        if repeated || (b - a).cross(c - a).length_squared() == 0.0 {
            dropped += 1;
            continue;
        }
        bounds.grow(a);
        bounds.grow(b);
        bounds.grow(c);
        keep.push(t as u32);
    }
    if keep.is_empty() {
        return Ok(None);
    }
    let triangles = keep.len();
    let part = Part {
        pieces: vec![Piece {
            object: index as u32,
            triangles: Tris::of(keep, tris),
        }],
        bounds,
        triangles,
    };
    Ok(Some((part, dropped)))
}

/// Box of the vertices of some triangles of one object.
pub fn piece_bounds(o: &Object, tris: impl IntoIterator<Item = u32>) -> Aabb {
    let mut b = Aabb::EMPTY;
    for t in tris {
        for p in triangle(o, t) {
            b.grow(p);
        }
    }
    b
}

#[cfg(test)]
mod tests {
    use super::*;
    use gigawalk_import::Model;
    use glam::Vec3;

    fn object(positions: &[[f64; 3]], indices: &[u32]) -> Object {
        Object {
            name: "o".into(),
            positions: positions.iter().map(|p| DVec3::from_array(*p)).collect(),
            normals: vec![Vec3::Z; positions.len()],
            indices: indices.to_vec(),
            colour: [1.0; 4],
            vertex_colours: None,
            identity: Default::default(),
        }
    }

    #[test]
    fn degenerate_triangles_are_dropped_and_counted() {
        let o = object(
            &[
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [2.0, 0.0, 0.0],
            ],
            &[0, 1, 2, 0, 0, 1, 0, 1, 3],
        );
        let m = Model {
            objects: vec![o],
            ..Default::default()
        };
        let (parts, dropped) = initial_parts(&m).unwrap();
        assert_eq!(dropped, 2);
        assert_eq!(parts[0].pieces[0].triangles, Tris::List(vec![0]));
        assert_eq!(
            parts[0].bounds,
            Aabb::new(DVec3::ZERO, DVec3::new(1.0, 1.0, 0.0))
        );
    }

    #[test]
    fn out_of_range_index_names_object_and_triangle() {
        let o = object(
            &[[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
            &[0, 1, 2, 0, 1, 7],
        );
        let m = Model {
            objects: vec![o],
            ..Default::default()
        };
        let e = initial_parts(&m).unwrap_err();
        assert_eq!(
            e.to_string(),
            "object 0 (o): triangle 1 uses vertex 7, but the object has 3 vertices"
        );
    }

    #[test]
    fn nan_position_is_rejected() {
        let o = object(
            &[[0.0; 3], [f64::NAN, 0.0, 0.0], [0.0, 1.0, 0.0]],
            &[0, 1, 2],
        );
        let m = Model {
            objects: vec![o],
            ..Default::default()
        };
        assert!(matches!(
            initial_parts(&m),
            Err(InputError::NonFinite { vertex: 1, .. })
        ));
    }

    #[test]
    fn empty_model_is_an_error() {
        let m = Model::default();
        assert_eq!(initial_parts(&m), Err(InputError::Empty { dropped: 0 }));
    }
}
