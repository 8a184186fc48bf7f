//! A deterministic glTF 2.0 binary writer for generated scenes: meshes
//! (one primitive each), instance nodes with f64 translations, one group
//! node per category, a small material palette.
//!
//! The JSON is written by hand in a fixed order with Rust's shortest
//! round-trip float formatting, so equal inputs give equal bytes. Vertex
//! data (positions, normals) and indices live in two buffer views of one
//! buffer, as glTF validators expect.

use std::fmt::Write as _;
use std::io::Write;

use gigawalk_scene::Aabb;
use glam::{DMat4, DQuat, DVec3, Vec3};

use crate::shapes::Mesh;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MeshId(usize);

#[derive(Clone, Copy, Debug)]
pub struct Material {
    pub name: &'static str,
    pub colour: [f32; 4],
    pub metallic: f32,
    pub roughness: f32,
}

struct MeshRec {
    name: String,
    material: usize,
    /// Byte offset of the positions in the vertex data; normals follow.
    vtx_offset: usize,
    vertices: usize,
    idx_offset: usize,
    indices: usize,
    min: Vec3,
    max: Vec3,
}

struct NodeRec {
    name: String,
    mesh: MeshId,
    /// Its group node: an index into `groups`.
    group: usize,
    translation: DVec3,
    rotation: Option<DQuat>,
    scale: Option<DVec3>,
}

/// Builds the scene and keeps the running totals that tests compare against
/// an import of the written file.
pub struct GlbBuilder {
    generator: String,
    vtx: Vec<u8>,
    idx: Vec<u8>,
    meshes: Vec<MeshRec>,
    nodes: Vec<NodeRec>,
    /// Group node names, in order of first use.
    groups: Vec<&'static str>,
    materials: Vec<Material>,
    triangles: u64,
    bounds: Aabb,
}

impl GlbBuilder {
    pub fn new(generator: String, materials: &[Material]) -> Self {
        GlbBuilder {
            generator,
            vtx: Vec::new(),
            idx: Vec::new(),
            meshes: Vec::new(),
            nodes: Vec::new(),
            groups: Vec::new(),
            materials: materials.to_vec(),
            triangles: 0,
            bounds: Aabb::EMPTY,
        }
    }

    /// Triangles placed so far, counting every instance.
    pub fn triangles(&self) -> u64 {
        self.triangles
    }

    pub fn objects(&self) -> usize {
        self.nodes.len()
    }

    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    pub fn mesh_triangles(&self, m: MeshId) -> u64 {
        (self.meshes[m.0].indices / 3) as u64
    }

    /// Stores a mesh (in its local frame) for any number of instances.
    pub fn add_mesh(&mut self, name: &str, material: usize, mesh: &Mesh) -> MeshId {
        debug_assert!(material < self.materials.len());
        debug_assert!(!mesh.indices.is_empty());
        let mut min = Vec3::splat(f32::INFINITY);
        let mut max = Vec3::splat(f32::NEG_INFINITY);
        let vtx_offset = self.vtx.len();
        for p in &mesh.positions {
            min = min.min(*p);
            max = max.max(*p);
            for c in p.to_array() {
                self.vtx.extend_from_slice(&c.to_le_bytes());
            }
        }
        for n in &mesh.normals {
            for c in n.to_array() {
                self.vtx.extend_from_slice(&c.to_le_bytes());
            }
        }
        let idx_offset = self.idx.len();
        for i in &mesh.indices {
            self.idx.extend_from_slice(&i.to_le_bytes());
        }
        self.meshes.push(MeshRec {
            name: name.to_owned(),
            material,
            vtx_offset,
            vertices: mesh.positions.len(),
            idx_offset,
            indices: mesh.indices.len(),
            min,
            max,
        });
        MeshId(self.meshes.len() - 1)
    }

    /// Places one instance of `mesh` under the group node `group`.
    /// Rotation and scale are optional; they cost an exact per-vertex
    /// bounds update, where a plain translation only shifts the mesh box.
    pub fn instance(
        &mut self,
        group: &'static str,
        name: &str,
        mesh: MeshId,
        translation: DVec3,
        rotation: Option<DQuat>,
        scale: Option<DVec3>,
    ) {
        let rec = &self.meshes[mesh.0];
        self.triangles += (rec.indices / 3) as u64;
        // The same f64 arithmetic as an importer flattening the node, so the
        // reported bounds match an import exactly.
        if rotation.is_none() && scale.is_none() {
            self.bounds.grow(rec.min.as_dvec3() + translation);
            self.bounds.grow(rec.max.as_dvec3() + translation);
        } else {
            let q = rotation.unwrap_or(DQuat::IDENTITY);
            let m = DMat4::from_scale_rotation_translation(
                scale.unwrap_or(DVec3::ONE),
                q / q.length(),
                translation,
            );
            for v in 0..rec.vertices {
                let o = rec.vtx_offset + 12 * v;
                let c = |k: usize| {
                    f32::from_le_bytes(self.vtx[o + 4 * k..o + 4 * k + 4].try_into().unwrap())
                        as f64
                };
                self.bounds
                    .grow(m.transform_point3(DVec3::new(c(0), c(1), c(2))));
            }
        }
        let group = match self.groups.iter().position(|&g| g == group) {
            Some(g) => g,
            None => {
                self.groups.push(group);
                self.groups.len() - 1
            }
        };
        self.nodes.push(NodeRec {
            name: name.to_owned(),
            mesh,
            group,
            translation,
            rotation,
            scale,
        });
    }

    /// Stores a one-off mesh built in world coordinates: re-centred on its
    /// box centre (which becomes the node translation) so vertex data stays
    /// small and precise.
    pub fn object(&mut self, group: &'static str, name: &str, material: usize, mut mesh: Mesh) {
        if mesh.indices.is_empty() {
            return;
        }
        let mut min = Vec3::splat(f32::INFINITY);
        let mut max = Vec3::splat(f32::NEG_INFINITY);
        for p in &mesh.positions {
            min = min.min(*p);
            max = max.max(*p);
        }
        let c = ((min + max) * 0.5).round();
        for p in &mut mesh.positions {
            *p -= c;
        }
        let id = self.add_mesh(name, material, &mesh);
        self.instance(group, name, id, c.as_dvec3(), None, None);
    }

    /// Splits the instances into `parts` runs of consecutive instances
    /// (the generators place them region by region, so each run is a
    /// compact piece of the scene) with about equal triangles each; every
    /// run is non-empty, so there are at most as many as instances.
    pub fn split(&self, parts: usize) -> Vec<std::ops::Range<usize>> {
        let parts = parts.clamp(1, self.nodes.len().max(1));
        let mut runs = Vec::with_capacity(parts);
        let (mut start, mut so_far) = (0, 0u64);
        for (i, n) in self.nodes.iter().enumerate() {
            so_far += (self.meshes[n.mesh.0].indices / 3) as u64;
            let left = self.nodes.len() - i - 1;
            let runs_left = parts - runs.len() - 1;
            // Close this run once it holds its share of the triangles, or
            // when every later run needs one of the remaining instances.
            let share = self.triangles * (runs.len() as u64 + 1) / parts as u64;
            if runs_left > 0 && (so_far >= share || left == runs_left) {
                runs.push(start..i + 1);
                start = i + 1;
            }
        }
        runs.push(start..self.nodes.len());
        runs
    }

    /// The instances `nodes` (a run from [`GlbBuilder::split`]) with the
    /// meshes they use, as a scene of their own: the same materials and
    /// group names, each mesh stored once however often the run uses it.
    pub fn part(&self, nodes: std::ops::Range<usize>) -> GlbBuilder {
        let mut out = GlbBuilder::new(self.generator.clone(), &self.materials);
        let mut mesh_in_part: Vec<Option<MeshId>> = vec![None; self.meshes.len()];
        for i in nodes {
            let n = &self.nodes[i];
            let id = *mesh_in_part[n.mesh.0].get_or_insert_with(|| {
                let m = &self.meshes[n.mesh.0];
                let vtx = &self.vtx[m.vtx_offset..m.vtx_offset + 24 * m.vertices];
                let idx = &self.idx[m.idx_offset..m.idx_offset + 4 * m.indices];
                out.meshes.push(MeshRec {
                    name: m.name.clone(),
                    vtx_offset: out.vtx.len(),
                    idx_offset: out.idx.len(),
                    ..*m
                });
                out.vtx.extend_from_slice(vtx);
                out.idx.extend_from_slice(idx);
                MeshId(out.meshes.len() - 1)
            });
            out.instance(
                self.groups[n.group],
                &n.name,
                id,
                n.translation,
                n.rotation,
                n.scale,
            );
        }
        out
    }

    fn json(&self) -> String {
        let mut j = String::with_capacity(256 + self.nodes.len() * 80 + self.meshes.len() * 400);
        let n_inst = self.nodes.len();
        j += "{\"asset\":{\"version\":\"2.0\",\"generator\":\"";
        j += &self.generator;
        j += "\"},\"scene\":0,\"scenes\":[{\"nodes\":[";
        for g in 0..self.groups.len() {
            if g > 0 {
                j.push(',');
            }
            let _ = write!(j, "{}", n_inst + g);
        }
        j += "]}],\"nodes\":[";
        for (i, n) in self.nodes.iter().enumerate() {
            if i > 0 {
                j.push(',');
            }
            let t = n.translation;
            let _ = write!(
                j,
                "{{\"name\":\"{}\",\"mesh\":{},\"translation\":[{},{},{}]",
                n.name, n.mesh.0, t.x, t.y, t.z
            );
            if let Some(r) = n.rotation {
                let _ = write!(j, ",\"rotation\":[{},{},{},{}]", r.x, r.y, r.z, r.w);
            }
            if let Some(s) = n.scale {
                let _ = write!(j, ",\"scale\":[{},{},{}]", s.x, s.y, s.z);
            }
            j.push('}');
        }
        let mut children = vec![Vec::new(); self.groups.len()];
        for (i, n) in self.nodes.iter().enumerate() {
            children[n.group].push(i);
        }
        for (name, children) in self.groups.iter().zip(&children) {
            j.push(',');
            let _ = write!(j, "{{\"name\":\"{name}\",\"children\":[");
            for (k, c) in children.iter().enumerate() {
                if k > 0 {
                    j.push(',');
                }
                let _ = write!(j, "{c}");
            }
            j += "]}";
        }
        j += "],\"meshes\":[";
        for (i, m) in self.meshes.iter().enumerate() {
            if i > 0 {
                j.push(',');
            }
            let _ = write!(
                j,
                "{{\"name\":\"{}\",\"primitives\":[{{\"attributes\":{{\"POSITION\":{},\"NORMAL\":{}}},\"indices\":{},\"material\":{}}}]}}",
                m.name,
                3 * i,
                3 * i + 1,
                3 * i + 2,
                m.material
            );
        }
        j += "],\"materials\":[";
        for (i, m) in self.materials.iter().enumerate() {
            if i > 0 {
                j.push(',');
            }
            let c = m.colour;
            let _ = write!(
                j,
                "{{\"name\":\"{}\",\"pbrMetallicRoughness\":{{\"baseColorFactor\":[{},{},{},{}],\"metallicFactor\":{},\"roughnessFactor\":{}}}}}",
                m.name, c[0], c[1], c[2], c[3], m.metallic, m.roughness
            );
        }
        j += "],\"accessors\":[";
        for (i, m) in self.meshes.iter().enumerate() {
            if i > 0 {
                j.push(',');
            }
            let _ = write!(
                j,
                "{{\"bufferView\":0,\"byteOffset\":{},\"componentType\":5126,\"count\":{},\"type\":\"VEC3\",\"min\":[{},{},{}],\"max\":[{},{},{}]}},",
                m.vtx_offset, m.vertices, m.min.x, m.min.y, m.min.z, m.max.x, m.max.y, m.max.z
            );
            let _ = write!(
                j,
                "{{\"bufferView\":0,\"byteOffset\":{},\"componentType\":5126,\"count\":{},\"type\":\"VEC3\"}},",
                m.vtx_offset + 12 * m.vertices,
                m.vertices
            );
            let _ = write!(
                j,
                "{{\"bufferView\":1,\"byteOffset\":{},\"componentType\":5125,\"count\":{},\"type\":\"SCALAR\"}}",
                m.idx_offset, m.indices
            );
        }
        let _ = write!(
            j,
            "],\"bufferViews\":[{{\"buffer\":0,\"byteOffset\":0,\"byteLength\":{},\"byteStride\":12,\"target\":34962}},{{\"buffer\":0,\"byteOffset\":{},\"byteLength\":{},\"target\":34963}}],\"buffers\":[{{\"byteLength\":{}}}]}}",
            self.vtx.len().max(4),
            self.vtx.len(),
            self.idx.len().max(4),
            self.bin_len()
        );
        j
    }

    /// Bytes of vertex and index data (the bulk of a written file).
    pub fn bin_len(&self) -> usize {
        self.vtx.len() + self.idx.len()
    }

    /// Writes the .glb: 12-byte header, JSON chunk (space-padded), BIN
    /// chunk (glTF 2.0 spec, section 4.4).
    pub fn write_glb<W: Write + ?Sized>(&self, w: &mut W) -> std::io::Result<u64> {
        let mut json = self.json().into_bytes();
        while !json.len().is_multiple_of(4) {
            json.push(b' ');
        }
        let bin_len = self.bin_len();
        let bin_padded = bin_len.div_ceil(4) * 4;
        let total = 12 + 8 + json.len() + 8 + bin_padded;
        let too_big = || {
            std::io::Error::new(
                std::io::ErrorKind::FileTooLarge,
                "scene exceeds the 4 GiB limit of a .glb file",
            )
        };
        let total32 = u32::try_from(total).map_err(|_| too_big())?;
        w.write_all(b"glTF")?;
        w.write_all(&2u32.to_le_bytes())?;
        w.write_all(&total32.to_le_bytes())?;
        w.write_all(&(json.len() as u32).to_le_bytes())?;
        w.write_all(b"JSON")?;
        w.write_all(&json)?;
        w.write_all(&(bin_padded as u32).to_le_bytes())?;
        w.write_all(b"BIN\0")?;
        w.write_all(&self.vtx)?;
        w.write_all(&self.idx)?;
        w.write_all(&vec![0u8; bin_padded - bin_len])?;
        Ok(total as u64)
    }
}
