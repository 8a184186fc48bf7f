//! LODs and HLODs (GigaWalk Section 4.3), simplified with meshoptimizer.
//!
//! A leaf gets a chain of static LODs of its own geometry. An inner node
//! gets HLODs built from its children's coarsest levels, merged and
//! simplified further with meshopt's sloppy (vertex-clustering) mode, which
//! joins disjoint objects as the paper's GAPS does. Every level records its
//! object-space error in model units, accumulated along the chain, so a
//! coarser level (and a parent) never claims less error than what it was
//! built from.

use gigawalk_import::{Model, Object};
use gigawalk_scene::{Colours, LodMesh};
use glam::DVec3;
use meshopt::{SimplifyOptions, VertexDataAdapter};

use crate::parts::Part;

/// A level is accepted only if it has at most this fraction of the previous
/// level's triangles; otherwise the simplifier has stalled (e.g. on many
/// tiny disconnected pieces that edge collapses cannot remove).
const MIN_SHRINK: f64 = 0.8;

/// Geometry being simplified: f32 positions relative to `origin`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct WorkMesh {
    pub origin: DVec3,
    pub positions: Vec<[f32; 3]>,
    pub normals: Vec<[f32; 3]>,
    /// sRGB-encoded RGBA8, one per vertex.
    pub colours: Vec<[u8; 4]>,
    pub indices: Vec<u32>,
}

impl WorkMesh {
    pub fn triangles(&self) -> usize {
        self.indices.len() / 3
    }

    /// The scene file's form: one uniform colour when every vertex agrees.
    pub fn to_lod_mesh(&self) -> LodMesh {
        let colours = match self.colours.first() {
            Some(&c) if self.colours.iter().all(|&x| x == c) => Colours::Uniform(c),
            _ => Colours::PerVertex(self.colours.clone()),
        };
        LodMesh {
            origin: self.origin,
            positions: self.positions.clone(),
            normals: self.normals.clone(),
            colours,
            indices: self.indices.clone(),
        }
    }
}

/// One level of detail and its object-space error (model units).
#[derive(Clone, Debug, PartialEq)]
pub struct Lod {
    pub mesh: WorkMesh,
    pub error: f32,
}

/// How LOD chains are cut.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ChainParams {
    /// Target triangles of a level as a fraction of the previous level's.
    pub ratio: f64,
    /// Stop once a level has at most this many triangles.
    pub floor: usize,
    /// Levels 1..=collapse_levels of a leaf use edge collapse, the rest sloppy.
    pub collapse_levels: usize,
}

/// The full-detail mesh of a final object, relative to `origin`, with
/// only the vertices its triangles use.
pub fn leaf_mesh(model: &Model, part: &Part, origin: DVec3) -> WorkMesh {
    let mut m = WorkMesh {
        origin,
        ..Default::default()
    };
    m.indices.reserve(3 * part.triangles);
    let mut used: Vec<u32> = Vec::new();
    for piece in &part.pieces {
        let o: &Object = &model.objects[piece.object as usize];
        used.clear();
        for &t in &piece.triangles {
            used.extend_from_slice(&o.indices[3 * t as usize..3 * t as usize + 3]);
        }
        used.sort_unstable();
        used.dedup();
        let base = m.positions.len() as u32;
        let uniform = srgb8(o.colour);
        for &v in &used {
            let v = v as usize;
            m.positions
                .push((o.positions[v] - origin).as_vec3().to_array());
            m.normals.push(o.normals[v].to_array());
            m.colours.push(match &o.vertex_colours {
                Some(c) => srgb8(c[v]),
                None => uniform,
            });
        }
        for &t in &piece.triangles {
            for &v in &o.indices[3 * t as usize..3 * t as usize + 3] {
                // `used` holds every index of these triangles, so the search hits.
                let local = used.binary_search(&v).unwrap_or_default() as u32;
                m.indices.push(base + local);
            }
        }
    }
    m
}

/// A leaf's chain: the mesh itself (error 0), then coarser levels.
pub fn leaf_lods(mesh: WorkMesh, p: &ChainParams) -> Vec<Lod> {
    chain(Lod { mesh, error: 0.0 }, p, false)
}

/// An inner node's HLODs from its children's coarsest levels, re-expressed
/// relative to `origin`. The first HLOD's error is the largest error among
/// those levels plus the simplification's own, so it is never below any
/// child's.
pub fn inner_lods(children: &[&Lod], origin: DVec3, p: &ChainParams) -> Vec<Lod> {
    let merged = merge(children, origin);
    let base_error = children.iter().map(|l| l.error).fold(0.0f32, f32::max);
    if merged.triangles() <= p.floor {
        // Too small to be worth simplifying: the union is the HLOD.
        return vec![Lod {
            mesh: merged,
            error: base_error,
        }];
    }
    let target = target_triangles(merged.triangles(), p);
    match simplify(&merged, target, true) {
        Some((mesh, e)) if mesh.triangles() < merged.triangles() => chain(
            Lod {
                mesh,
                error: base_error + e,
            },
            p,
            true,
        ),
        _ => vec![Lod {
            mesh: merged,
            error: base_error,
        }],
    }
}

fn target_triangles(n: usize, p: &ChainParams) -> usize {
    ((n as f64 * p.ratio).round() as usize).clamp(1, n.saturating_sub(1).max(1))
}

/// Halves `first` repeatedly until the floor or until it stops shrinking.
/// `sloppy` starts with topology-merging simplification; otherwise edge
/// collapse is tried first and sloppy only when collapse stalls.
fn chain(first: Lod, p: &ChainParams, sloppy: bool) -> Vec<Lod> {
    let mut lods = vec![first];
    loop {
        let cur = lods.last().map(|l| (&l.mesh, l.error));
        let Some((mesh, error)) = cur else { break };
        let n = mesh.triangles();
        if n <= p.floor {
            break;
        }
        let target = target_triangles(n, p);
        let limit = (MIN_SHRINK * n as f64) as usize;
        let shrunk = |r: &Option<(WorkMesh, f32)>| matches!(r, Some((m, _)) if m.triangles() <= limit && m.triangles() > 0);
        let collapse = !sloppy && lods.len() <= p.collapse_levels;
        let mut next = if collapse {
            simplify(mesh, target, false)
        } else {
            None
        };
        if !shrunk(&next) {
            next = simplify(mesh, target, true);
        }
        if !shrunk(&next) {
            break;
        }
        let Some((mesh, e)) = next else { break };
        lods.push(Lod {
            mesh,
            error: error + e,
        });
    }
    lods
}

/// One simplification step towards `target` triangles. The error returned
/// is in model units: the distance meshopt estimates the result deviates
/// from `mesh`.
fn simplify(mesh: &WorkMesh, target: usize, sloppy: bool) -> Option<(WorkMesh, f32)> {
    if mesh.indices.is_empty() {
        return None;
    }
    let bytes = meshopt::typed_to_bytes(&mesh.positions);
    let adapter = VertexDataAdapter::new(bytes, std::mem::size_of::<[f32; 3]>(), 0).ok()?;
    // Weld vertices that share a position (normal or colour seams) so the
    // simplifier sees one connected surface; the output keeps one of the
    // welded vertices' attributes.
    let weld = meshopt::generate_position_remap(&adapter);
    let welded: Vec<u32> = mesh.indices.iter().map(|&i| weld[i as usize]).collect();
    let mut err = 0.0f32;
    let indices = if sloppy {
        let r = meshopt::simplify_sloppy(&welded, &adapter, 3 * target, f32::MAX, Some(&mut err));
        // Sloppy reports error relative to the mesh extent.
        err *= meshopt::simplify_scale(&adapter);
        r
    } else {
        meshopt::simplify(
            &welded,
            &adapter,
            3 * target,
            f32::MAX,
            SimplifyOptions::ErrorAbsolute,
            Some(&mut err),
        )
    };
    if indices.is_empty() {
        return None;
    }
    let err = if err.is_finite() {
        err.max(0.0)
    } else {
        return None;
    };
    Some((compact(mesh, &indices), err))
}

/// The vertices `indices` use, in first-use order.
fn compact(mesh: &WorkMesh, indices: &[u32]) -> WorkMesh {
    let mut remap = vec![u32::MAX; mesh.positions.len()];
    let mut out = WorkMesh {
        origin: mesh.origin,
        ..Default::default()
    };
    out.indices.reserve(indices.len());
    for &i in indices {
        let slot = &mut remap[i as usize];
        if *slot == u32::MAX {
            *slot = out.positions.len() as u32;
            out.positions.push(mesh.positions[i as usize]);
            out.normals.push(mesh.normals[i as usize]);
            out.colours.push(mesh.colours[i as usize]);
        }
        out.indices.push(*slot);
    }
    out
}

fn merge(children: &[&Lod], origin: DVec3) -> WorkMesh {
    let mut m = WorkMesh {
        origin,
        ..Default::default()
    };
    for c in children {
        let base = m.positions.len() as u32;
        let shift = c.mesh.origin - origin;
        m.positions.extend(c.mesh.positions.iter().map(|p| {
            (shift + glam::Vec3::from_array(*p).as_dvec3())
                .as_vec3()
                .to_array()
        }));
        m.normals.extend_from_slice(&c.mesh.normals);
        m.colours.extend_from_slice(&c.mesh.colours);
        m.indices.extend(c.mesh.indices.iter().map(|&i| base + i));
    }
    m
}

/// Linear RGBA in 0..=1 to sRGB-encoded RGBA8 (alpha stays linear).
pub fn srgb8(c: [f32; 4]) -> [u8; 4] {
    let enc = |x: f32| {
        let x = if x.is_finite() {
            x.clamp(0.0, 1.0)
        } else {
            0.0
        };
        let s = if x <= 0.003_130_8 {
            12.92 * x
        } else {
            1.055 * x.powf(1.0 / 2.4) - 0.055
        };
        (s * 255.0).round() as u8
    };
    let a = if c[3].is_finite() {
        c[3].clamp(0.0, 1.0)
    } else {
        1.0
    };
    [enc(c[0]), enc(c[1]), enc(c[2]), (a * 255.0).round() as u8]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::parts::initial_parts;
    use crate::test_models::{grid_object, pipe_object};

    const P: ChainParams = ChainParams {
        ratio: 0.5,
        floor: 64,
        collapse_levels: 1,
    };

    fn mesh_of(o: gigawalk_import::Object) -> WorkMesh {
        let m = Model {
            objects: vec![o],
            ..Default::default()
        };
        let (parts, _) = initial_parts(&m).unwrap();
        leaf_mesh(&m, &parts[0], parts[0].bounds.center())
    }

    #[test]
    fn srgb_endpoints_and_midpoint() {
        assert_eq!(srgb8([0.0, 1.0, 0.5, 0.5]), [0, 255, 188, 128]);
        assert_eq!(srgb8([f32::NAN, -1.0, 2.0, 1.0]), [0, 0, 255, 255]);
    }

    #[test]
    fn leaf_chain_halves_down_to_the_floor_with_growing_error() {
        let mesh = mesh_of(grid_object(DVec3::ZERO, 10.0, 64, 0.3));
        let full = mesh.triangles();
        let lods = leaf_lods(mesh, &P);
        assert!(lods.len() >= 4, "{} levels", lods.len());
        assert_eq!(lods[0].error, 0.0);
        assert_eq!(lods[0].mesh.triangles(), full);
        for w in lods.windows(2) {
            assert!(w[1].mesh.triangles() as f64 <= MIN_SHRINK * w[0].mesh.triangles() as f64);
            assert!(w[1].error >= w[0].error);
        }
        assert!(lods[1].error > 0.0);
        let last = lods.last().unwrap();
        assert!(last.mesh.triangles() <= P.floor || lods.len() > 8);
    }

    #[test]
    fn sloppy_fallback_reduces_many_disconnected_pieces() {
        // 300 separate tiny pipes: edge collapse cannot remove components.
        let mut all = pipe_object(DVec3::ZERO, 0.5, 0.05, 1, 3);
        for i in 1..300 {
            let p = pipe_object(
                DVec3::new((i % 20) as f64, (i / 20) as f64, 0.0),
                0.5,
                0.05,
                1,
                3,
            );
            let base = all.positions.len() as u32;
            all.positions.extend(p.positions);
            all.normals.extend(p.normals);
            all.indices.extend(p.indices.iter().map(|i| i + base));
        }
        let lods = leaf_lods(mesh_of(all), &P);
        assert!(lods.len() >= 2);
        assert!(lods.last().unwrap().mesh.triangles() < lods[0].mesh.triangles() / 2);
    }

    #[test]
    fn inner_hlod_error_is_at_least_every_child_coarsest() {
        let a = leaf_lods(mesh_of(grid_object(DVec3::ZERO, 10.0, 32, 0.2)), &P);
        let b = leaf_lods(
            mesh_of(grid_object(DVec3::new(12.0, 0.0, 0.0), 10.0, 32, 0.5)),
            &P,
        );
        let children = [a.last().unwrap(), b.last().unwrap()];
        let origin = DVec3::new(11.0, 0.0, 5.0);
        let lods = inner_lods(&children, origin, &P);
        assert!(!lods.is_empty());
        for l in &lods {
            assert!(l.error >= children[0].error && l.error >= children[1].error);
            assert_eq!(l.mesh.origin, origin);
        }
        for w in lods.windows(2) {
            assert!(w[1].error >= w[0].error);
        }
    }

    #[test]
    fn uniform_colour_is_detected() {
        let m = mesh_of(grid_object(DVec3::ZERO, 1.0, 4, 0.0));
        assert!(matches!(m.to_lod_mesh().colours, Colours::Uniform(_)));
        let mut m2 = m.clone();
        m2.colours[0] = [1, 2, 3, 4];
        assert!(matches!(m2.to_lod_mesh().colours, Colours::PerVertex(_)));
    }
}
