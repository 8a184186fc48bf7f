//! IFC (STEP physical file, IFC2X3, IFC4 and IFC4X3) reading: every
//! product with a body representation becomes one triangle-mesh object in
//! world metres that keeps its IFC identity (class, GlobalId, spatial
//! path, property sets).
//!
//! Main types: [`IfcFile`] (a parsed, indexed file; [`IfcFile::read`]
//! hands out its [`IfcObject`]s), [`IfcStats`] (what was read and what
//! was not, by kind), [`IfcError`]. Underneath, [`step`] indexes the file
//! and decodes entities on demand; the geometry readers work in file
//! units and the objects are scaled to metres at the end.
//!
//! Not read (counted in [`IfcStats::unsupported`] by kind, never dropped
//! silently): swept solids along curves, CSG spheres, intersections with
//! and subtractions of non-convex solids, among others (docs/ifc.md).

#![forbid(unsafe_code)]

mod brep;
mod bspline;
pub mod classes;
mod clip;
mod colour;
mod curve;
mod error;
mod extrude;
mod face_set;
mod geom;
mod identity;
mod items;
mod placement;
mod profile;
mod revolve;
pub mod step;
mod swept;
mod triangulate;
mod units;

use std::cell::RefCell;
use std::collections::{BTreeMap, HashMap};

use glam::{DVec3, Vec3};

pub use error::IfcError;
pub use step::Schema;

use geom::{Ctx, GeomError, Tri};
use identity::Relations;
use step::StepFile;

/// One product: its triangles in world metres and who it is.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct IfcObject {
    /// The product's Name, else `Class GlobalId`.
    pub name: String,
    /// Its place in the spatial structure, `/`-joined, ending with its
    /// class and GlobalId: `Project/Site/Building/Storey/IfcWall 2O2Fr$t4X7Zf8NOew3FL9r`.
    pub path: String,
    /// Its class as the schema spells it (`IfcWallStandardCase`).
    pub class: String,
    pub global_id: String,
    /// The name of the building storey it is in, if any.
    pub storey: Option<String>,
    /// The entity id (`#id`) in its file.
    pub entity: u32,
    /// Compact JSON: ifc_class, GlobalId, entity, storey, type,
    /// ObjectType, psets, quantities (values as the file gives them, in
    /// its units).
    pub extras: String,
    pub positions: Vec<DVec3>,
    /// Unit face normals, one per position (vertices are shared only
    /// within a flat face).
    pub normals: Vec<Vec3>,
    pub indices: Vec<u32>,
    /// Linear RGBA: the most used colour of its triangles.
    pub colour: [f32; 4],
    /// Per-vertex colours when its triangles have several.
    pub vertex_colours: Option<Vec<[f32; 4]>>,
}

/// What could not be read, of one kind.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Unsupported {
    /// Items (or faces, for a brep's faces) of this kind.
    pub items: u64,
    /// Products with such items, by class.
    pub products: BTreeMap<String, u64>,
}

/// What a read found and what it could not read.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct IfcStats {
    /// Products with a body representation.
    pub products: u64,
    /// Products that became objects (with triangles).
    pub objects: u64,
    pub triangles: u64,
    pub degenerate_triangles_dropped: u64,
    /// Kind ("IfcSphere", "IfcAdvancedFace on
    /// IfcBSplineSurfaceWithKnots", "opening: non-convex brep") -> counts.
    pub unsupported: BTreeMap<String, Unsupported>,
    /// Openings subtracted from their elements.
    pub openings_subtracted: u64,
    /// Malformed entities skipped, each named.
    pub warnings: Vec<String>,
}

impl IfcStats {
    /// `IfcSphere: 3 items in 2 IfcFlowFitting; ...`, or empty.
    pub fn unsupported_summary(&self) -> String {
        self.unsupported
            .iter()
            .map(|(k, u)| {
                let products: Vec<String> =
                    u.products.iter().map(|(c, n)| format!("{n} {c}")).collect();
                format!("{k}: {} items in {}", u.items, products.join(", "))
            })
            .collect::<Vec<_>>()
            .join("; ")
    }

    /// Counts one product's `kinds` not read (one entry per item).
    fn note(&mut self, kinds: Vec<String>, class: &str) {
        let mut per_kind: BTreeMap<String, u64> = BTreeMap::new();
        for k in kinds {
            *per_kind.entry(k).or_default() += 1;
        }
        for (k, n) in per_kind {
            let u = self.unsupported.entry(k).or_default();
            u.items += n;
            *u.products.entry(class.to_string()).or_default() += 1;
        }
    }
}

/// Products whose geometry gigawalk does not draw: room volumes and the
/// voids cut from elements (subtracted, not drawn).
const NOT_DRAWN: &[&str] = &[
    "IFCSPACE",
    "IFCOPENINGELEMENT",
    "IFCOPENINGSTANDARDCASE",
    "IFCVOIDINGFEATURE",
];

/// A parsed, indexed IFC file.
pub struct IfcFile {
    step: StepFile,
    project: u32,
}

impl IfcFile {
    /// Reads and indexes the file at `path`.
    pub fn open(path: &std::path::Path) -> Result<IfcFile, IfcError> {
        let file = path.display().to_string();
        let bytes = std::fs::read(path).map_err(|source| IfcError::Io {
            file: file.clone(),
            source,
        })?;
        IfcFile::parse(bytes, &file)
    }

    /// Indexes `bytes`, the file named `file` in messages.
    pub fn parse(bytes: Vec<u8>, file: &str) -> Result<IfcFile, IfcError> {
        let step = StepFile::parse(bytes, file)?;
        let project = step
            .ids_of_type("IFCPROJECT")
            .next()
            .ok_or_else(|| IfcError::NoProject { file: file.into() })?;
        Ok(IfcFile { step, project })
    }

    pub fn schema(&self) -> Schema {
        self.step.schema
    }

    /// The indexed STEP file (entities by id and type).
    pub fn step(&self) -> &StepFile {
        &self.step
    }

    /// The product types in the file: those whose instances have an
    /// IfcProductDefinitionShape as their 7th attribute.
    fn product_ids(&self) -> Vec<u32> {
        let mut types: Vec<&str> = Vec::new();
        for (ty, _) in self.step.types() {
            if NOT_DRAWN.contains(&ty) {
                continue;
            }
            for id in self.step.ids_of_type(ty) {
                let Ok(e) = self.step.get(id) else { break };
                // Fewer attributes: not an IfcProduct (points, properties).
                if e.args.len() < 7 {
                    break;
                }
                match e.arg(6) {
                    step::Value::Ref(r) => {
                        if self.step.type_of(*r) == Some("IFCPRODUCTDEFINITIONSHAPE")
                            && e.opt_str(0).is_some()
                        {
                            types.push(ty);
                        }
                        break;
                    }
                    step::Value::Null => continue,
                    _ => break,
                }
            }
        }
        let mut ids: Vec<u32> = types
            .iter()
            .flat_map(|t| self.step.ids_of_type(t))
            .collect();
        ids.sort_unstable();
        ids
    }

    /// Reads every product with geometry, handing each object to `sink`
    /// (which returns false to stop). A file none of whose products gives
    /// a triangle is an error naming it.
    pub fn read(&self, sink: &mut dyn FnMut(IfcObject) -> bool) -> Result<IfcStats, IfcError> {
        let step = &self.step;
        let project = step.get(self.project)?;
        let (length, angle) = units::units(step, &project);
        let mut colour_maps = HashMap::new();
        for id in step.ids_of_type("IFCINDEXEDCOLOURMAP") {
            if let Some(target) = step.get(id).ok().and_then(|e| e.opt_ref(0)) {
                colour_maps.insert(target, id);
            }
        }
        let ctx = Ctx {
            step,
            angle,
            length,
            placements: RefCell::new(HashMap::new()),
            notes: RefCell::new(Vec::new()),
            colour_maps,
            styles: colour::Styles::new(step),
            mapped: RefCell::new(HashMap::new()),
            warnings: RefCell::new(Vec::new()),
        };
        let rel = Relations::new(step);
        let mut stats = IfcStats::default();
        for id in self.product_ids() {
            let e = step.get(id)?;
            let Some(body) = body_representations(step, &e) else {
                continue;
            };
            stats.products += 1;
            let class = classes::camel(e.ty);
            let tris = match product_triangles(&ctx, &rel, &e, &body, &mut stats) {
                Ok(t) => t,
                Err(GeomError::Unsupported(k)) => {
                    ctx.notes.borrow_mut().push(k);
                    Vec::new()
                }
                Err(GeomError::Bad(err)) => {
                    ctx.notes.borrow_mut().push(format!("malformed {class}"));
                    stats.warnings.push(err.to_string());
                    Vec::new()
                }
            };
            let notes = std::mem::take(&mut *ctx.notes.borrow_mut());
            stats.note(notes, &class);
            stats.warnings.append(&mut ctx.warnings.borrow_mut());
            if tris.is_empty() {
                continue;
            }
            let default = ctx
                .styles
                .product
                .get(&id)
                .copied()
                .unwrap_or_else(|| colour::class_default(e.ty));
            let who = identity::who(step, &rel, &e);
            let object = mesh(tris, length, default, who, id, &mut stats);
            if object.indices.is_empty() {
                continue;
            }
            stats.objects += 1;
            stats.triangles += object.indices.len() as u64 / 3;
            if !sink(object) {
                break;
            }
        }
        if stats.objects == 0 {
            let reason = if stats.products == 0 {
                "no product has a body representation".to_string()
            } else {
                format!(
                    "{} products with body representations, none read; {}",
                    stats.products,
                    stats.unsupported_summary()
                )
            };
            return Err(IfcError::NoGeometry {
                file: step.file.clone(),
                reason,
            });
        }
        Ok(stats)
    }
}

/// The representations of `e` to draw: those named Body (else
/// Facetation, else unnamed ones of a solid or surface type).
fn body_representations(step: &StepFile, e: &step::Entity) -> Option<Vec<u32>> {
    let shape = step.get(e.opt_ref(6)?).ok()?;
    let reps = shape.refs(2).ok()?;
    let mut by_id: [Vec<u32>; 3] = Default::default();
    for r in reps {
        let Ok(re) = step.get(r) else { continue };
        let ident = re.opt_str(1).unwrap_or_default();
        let kind = re.opt_str(2).unwrap_or_default();
        let slot = match ident {
            "Body" => 0,
            "Facetation" => 1,
            "" if !matches!(
                kind,
                "Curve2D"
                    | "Curve3D"
                    | "GeometricCurveSet"
                    | "Annotation2D"
                    | "BoundingBox"
                    | "Point"
            ) =>
            {
                2
            }
            _ => continue,
        };
        by_id[slot].push(r);
    }
    by_id.into_iter().find(|v| !v.is_empty())
}

/// A product's triangles in world file units, openings subtracted.
fn product_triangles(
    ctx: &Ctx,
    rel: &Relations,
    e: &step::Entity,
    body: &[u32],
    stats: &mut IfcStats,
) -> Result<Vec<Tri>, GeomError> {
    let placement = match e.opt_ref(5) {
        Some(p) => placement::local_placement(ctx, p)?,
        None => glam::DMat4::IDENTITY,
    };
    let mut tris = Vec::new();
    for &r in body {
        items::representation(ctx, r, 0, &mut tris)?;
    }
    geom::transform(&mut tris, &placement);
    if tris.is_empty() {
        return Ok(tris);
    }
    let openings = rel.voids.get(&e.id).map_or(&[][..], |v| v.as_slice());
    for &o in openings {
        match opening_pieces(ctx, o) {
            Ok(pieces) => {
                let size = extent(&tris);
                for c in &pieces {
                    tris = clip::cut(tris, c, size);
                }
                stats.openings_subtracted += 1;
            }
            Err(GeomError::Unsupported(k)) => ctx.notes.borrow_mut().push(format!("opening: {k}")),
            Err(GeomError::Bad(err)) => {
                ctx.notes.borrow_mut().push("opening: malformed".into());
                stats.warnings.push(err.to_string());
            }
        }
    }
    Ok(tris)
}

fn extent(tris: &[Tri]) -> f64 {
    let (lo, hi) = tris.iter().flat_map(|t| t.p).fold(
        (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
        |(lo, hi), p| (lo.min(p), hi.max(p)),
    );
    (hi - lo).length()
}

/// An opening element's body as convex pieces in world file units.
fn opening_pieces(ctx: &Ctx, id: u32) -> Result<Vec<clip::Convex>, GeomError> {
    let o = ctx.get(id)?;
    let placement = match o.opt_ref(5) {
        Some(p) => placement::local_placement(ctx, p)?,
        None => glam::DMat4::IDENTITY,
    };
    let Some(body) = body_representations(ctx.step, &o) else {
        return Err(GeomError::Unsupported("no body".into()));
    };
    let mut pieces = Vec::new();
    for r in body {
        for i in ctx.get(r)?.refs(3)? {
            pieces.extend(items::convex_pieces(ctx, i, &placement, 0)?);
        }
    }
    Ok(pieces)
}

/// A vertex: its position's bits, its normal quantized, its colour's bits.
type VertexKey = ([u64; 3], [i32; 3], [u32; 4]);

/// The object: triangles scaled to metres, vertices shared within flat
/// faces of one colour, degenerate triangles dropped.
fn mesh(
    tris: Vec<Tri>,
    length: f64,
    default: [f32; 4],
    who: identity::Who,
    entity: u32,
    stats: &mut IfcStats,
) -> IfcObject {
    let mut positions = Vec::new();
    let mut normals = Vec::new();
    let mut colours: Vec<[f32; 4]> = Vec::new();
    let mut indices = Vec::with_capacity(tris.len() * 3);
    let mut seen: HashMap<VertexKey, u32> = HashMap::new();
    let mut uses: HashMap<[u32; 4], usize> = HashMap::new();
    for t in tris {
        let p = t.p.map(|q| q * length);
        let cross = (p[1] - p[0]).cross(p[2] - p[0]);
        // Below a square micrometre a triangle is a sliver of clipping or
        // of a degenerate face.
        let n = match cross.try_normalize() {
            Some(n) if cross.length() > 1e-12 && p.iter().all(|q| q.is_finite()) => n,
            _ => {
                stats.degenerate_triangles_dropped += 1;
                continue;
            }
        };
        let c = if t.c[3] < 0.0 { default } else { t.c };
        *uses.entry(c.map(f32::to_bits)).or_default() += 1;
        let nf = n.as_vec3();
        let nq = (nf * 1e5).round().as_ivec3().to_array();
        for q in p {
            let key = (q.to_array().map(f64::to_bits), nq, c.map(f32::to_bits));
            let i = *seen.entry(key).or_insert_with(|| {
                positions.push(q);
                normals.push(nf);
                colours.push(c);
                (positions.len() - 1) as u32
            });
            indices.push(i);
        }
    }
    let colour = uses
        .iter()
        .max_by_key(|(k, n)| (**n, std::cmp::Reverse(**k)))
        .map_or(default, |(k, _)| k.map(f32::from_bits));
    let vertex_colours = (uses.len() > 1).then_some(colours);
    IfcObject {
        name: who.name,
        path: who.path,
        class: who.class,
        global_id: who.global_id,
        storey: who.storey,
        entity,
        extras: who.extras,
        positions,
        normals,
        indices,
        colour,
        vertex_colours,
    }
}
