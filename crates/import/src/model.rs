//! The imported model: a flat list of triangle-mesh objects in f64 world
//! coordinates, keeping only what rendering needs.

use std::collections::BTreeMap;

use glam::{DVec3, Vec3};

/// One object: a mesh-primitive instance (glTF) or a group/object (OBJ),
/// with every node transform already applied.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Object {
    /// Human-readable name for messages and stats (e.g. "Pipe.003#prim0").
    pub name: String,
    /// World-space positions (f64, so models far from the origin keep precision).
    pub positions: Vec<DVec3>,
    /// Unit normals, one per position (computed, area-weighted, when the file has none).
    pub normals: Vec<Vec3>,
    /// Triangle list: 3 indices per triangle, each `< positions.len()`.
    /// Degenerate (zero-area) triangles have been dropped.
    pub indices: Vec<u32>,
    /// Base colour, linear RGBA in 0..=1.
    pub colour: [f32; 4],
    /// Per-vertex colours (linear RGBA), when the file has them; overrides `colour`.
    pub vertex_colours: Option<Vec<[f32; 4]>>,
    /// What the object is in its file, for the people reviewing the model.
    pub identity: Identity,
}

/// Who an object is: what its file calls it and where in the file it is.
/// Objects with the same file and path are one object to a user (a glTF
/// node's primitives, each imported as an object of its own).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Identity {
    /// The file's name for it: the glTF node's name (else its mesh's,
    /// else `node N`), the OBJ group's.
    pub name: String,
    /// Where it is in its file: the glTF node names from the scene root
    /// down, joined by `/` (an unnamed node as `#N`, its index); the OBJ
    /// group's name.
    pub path: String,
    /// The file it came from, as named on the command line (empty when
    /// imported from memory).
    pub file: String,
    /// The glTF node's `extras`, compact JSON, when it has any; an IFC
    /// product's class, GlobalId, storey, property sets and quantities.
    pub extras: Option<String>,
    /// The glTF node's index (`None` for OBJ): siblings may share a name,
    /// so this, not the path, tells two nodes apart. An IFC product's
    /// entity id (`#id`).
    pub node: Option<usize>,
}

impl Identity {
    /// Whether `self` and `other` name the same object of the model.
    pub fn same_object(&self, other: &Identity) -> bool {
        self.node == other.node && self.file == other.file && self.path == other.path
    }
}

impl Object {
    pub fn triangle_count(&self) -> usize {
        self.indices.len() / 3
    }
}

/// What an import skipped or fixed, for the summary line users see.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ImportStats {
    pub triangles: u64,
    pub degenerate_triangles_dropped: u64,
    /// Point and line primitives skipped (glTF modes POINTS, LINES, ...).
    pub skipped_primitives: u64,
    pub warnings: Vec<String>,
    /// Geometry not read, by kind (an IFC item class such as
    /// `IfcSphere`): how many items, in how many products of
    /// each class.
    pub unsupported: BTreeMap<String, Unsupported>,
}

/// Items of one kind an import could not read.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Unsupported {
    pub items: u64,
    /// Products (IFC class -> how many) that had such items.
    pub products: BTreeMap<String, u64>,
}

#[derive(Clone, Debug, Default, PartialEq)]
pub struct Model {
    pub objects: Vec<Object>,
    pub stats: ImportStats,
}

impl Model {
    /// Appends `other`'s objects, each name prefixed with `label` and a
    /// slash (the file it came from, when one model is made of many).
    pub fn append(&mut self, other: Model, label: &str) {
        self.objects.extend(other.objects.into_iter().map(|mut o| {
            o.name = format!("{label}/{}", o.name);
            o
        }));
        self.stats.add(other.stats);
    }
}

impl Model {
    /// The model a streaming import (given the sink to call per object)
    /// makes, its objects collected in order.
    pub(crate) fn collect(
        import: impl FnOnce(
            &mut dyn FnMut(Object) -> Result<(), crate::ImportError>,
        ) -> Result<ImportStats, crate::ImportError>,
    ) -> Result<Model, crate::ImportError> {
        let mut objects = Vec::new();
        let stats = import(&mut |o| {
            objects.push(o);
            Ok(())
        })?;
        Ok(Model { objects, stats })
    }
}

impl ImportStats {
    /// Adds another file's stats to these.
    pub fn add(&mut self, o: ImportStats) {
        self.triangles += o.triangles;
        self.degenerate_triangles_dropped += o.degenerate_triangles_dropped;
        self.skipped_primitives += o.skipped_primitives;
        self.warnings.extend(o.warnings);
        for (kind, u) in o.unsupported {
            let mine = self.unsupported.entry(kind).or_default();
            mine.items += u.items;
            for (class, n) in u.products {
                *mine.products.entry(class).or_default() += n;
            }
        }
    }

    /// The one line users see after an import.
    pub fn summary(&self, objects: usize) -> String {
        let mut s = format!("{} triangles in {} objects", self.triangles, objects);
        if self.degenerate_triangles_dropped > 0 {
            s += &format!(
                ", {} degenerate triangles dropped",
                self.degenerate_triangles_dropped
            );
        }
        if self.skipped_primitives > 0 {
            s += &format!(
                ", {} point/line primitives skipped",
                self.skipped_primitives
            );
        }
        if !self.warnings.is_empty() {
            s += &format!(", {} warnings", self.warnings.len());
        }
        if !self.unsupported.is_empty() {
            let kinds: Vec<String> = self
                .unsupported
                .iter()
                .map(|(kind, u)| {
                    let products: Vec<String> =
                        u.products.iter().map(|(c, n)| format!("{n} {c}")).collect();
                    format!("{kind}: {} items in {}", u.items, products.join(", "))
                })
                .collect();
            s += &format!("; not read: {}", kinds.join("; "));
        }
        s
    }
}
