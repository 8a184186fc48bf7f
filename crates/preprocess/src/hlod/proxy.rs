//! Merged proxies: a watertight shell around a node's geometry at the
//! scale of an error, the coarse level that edge collapse cannot make of
//! an assembly of many small, thin, disjoint parts (bolts, fins, cable
//! runs, thin shells stop a collapse long before the error allows).
//!
//! As Unreal's mesh approximation and Pixyz's proxy mesh do it: the
//! geometry's unsigned distance on a grid of cells a fraction of the
//! error, the iso-surface at an offset of about a cell extracted by
//! surface nets (closed, since the grid's border lies outside the
//! offset), and that simplified by edge collapse. Parts closer than twice
//! the offset merge, gaps narrower close, and a thin open shell becomes a
//! closed slab of twice the offset, so a machine of 300k triangles can
//! stand as a few hundred at the error where it is far away.
//!
//! A proxy is only a candidate: its error is measured like every level's
//! ([`crate::hausdorff`], both ways against the surface it stands for),
//! and a chain keeps it only where it draws fewer triangles at a bounded
//! error ([`super::with_proxies`]). The shell's own accuracy (sampled
//! distances, the offset, the simplifier) only decides how good a
//! candidate it is, never a stored figure: hidden inner parts deeper than
//! the offset below the shell, for one, are measured and make the
//! candidate lose at fine errors.

use glam::Vec3A;
use meshopt::{SimplifyOptions, VertexDataAdapter};

use super::WorkMesh;

/// The iso-surface's offset from the geometry, in cells: gaps up to
/// twice this close, and a shell this far out is what the error pays for
/// closing them.
const OFFSET_CELLS: f32 = 1.0;

/// Samples on the geometry are at most this many cells apart: the
/// sampled distance is within about 0.6 of it of the true one.
const SAMPLE_CELLS: f32 = 0.5;

/// Most grid vertices a proxy's grid may have (16 bytes each: the
/// distance, the colour, the nearest site's slot and the surface's
/// cell): a 128-cell cube and its pad.
const MAX_GRID_VERTICES: usize = 1 << 22;

/// The box of the vertices `mesh`'s triangles use (relative to its
/// origin), `None` when it has none or any is not finite.
pub(super) fn bounds(mesh: &WorkMesh) -> Option<(Vec3A, Vec3A)> {
    let mut lo = Vec3A::splat(f32::INFINITY);
    let mut hi = Vec3A::splat(f32::NEG_INFINITY);
    for &i in &mesh.indices {
        let p = Vec3A::from_array(mesh.positions[i as usize]);
        lo = lo.min(p);
        hi = hi.max(p);
    }
    (lo.is_finite() && hi.is_finite()).then_some((lo, hi))
}

/// A proxy of `mesh`, whose [`bounds`] are `bounds`, on a grid of
/// `cell`-sized cells, simplified by edge collapse within about a cell;
/// `None` when the grid would exceed [`MAX_GRID_VERTICES`], the cell is
/// not a positive finite length, or nothing is left. Positions are
/// relative to `mesh.origin`, as the mesh's.
pub(super) fn proxy(mesh: &WorkMesh, bounds: (Vec3A, Vec3A), cell: f32) -> Option<WorkMesh> {
    crate::spent::timed(crate::spent::Kind::Proxy, || make(mesh, bounds, cell))
}

fn shell(mesh: &WorkMesh, (lo, hi): (Vec3A, Vec3A), cell: f32) -> Option<Shell> {
    if mesh.indices.is_empty() || !(cell.is_finite() && cell > 0.0) {
        return None;
    }
    let offset = OFFSET_CELLS * cell;
    // Distances are stamped out to `reach`; the border lies beyond it, so
    // every border vertex is outside and the shell is closed.
    let reach = offset + 1.5 * cell;
    let pad = reach + cell;
    let grid = Grid::new(lo - Vec3A::splat(pad), hi + Vec3A::splat(pad), cell)?;
    let field = grid.distances(mesh, reach);
    let (positions, colours, quads) = grid.surface_nets(&field, offset);
    if quads.is_empty() {
        return None;
    }
    let indices = simplify(&positions, &triangulate(&positions, &quads), cell);
    Some(Shell {
        positions,
        colours,
        indices,
    })
}

/// A proxy before it is fitted into its geometry's box: closed, and
/// consistently wound.
struct Shell {
    positions: Vec<Vec3A>,
    colours: Vec<[u8; 4]>,
    indices: Vec<u32>,
}

fn make(mesh: &WorkMesh, (lo, hi): (Vec3A, Vec3A), cell: f32) -> Option<WorkMesh> {
    let Shell {
        positions,
        colours,
        indices,
    } = shell(mesh, (lo, hi), cell)?;
    // Inside the geometry's own box, which the node's box holds: the
    // shell stands out by the offset, a flattened side moves it back by
    // at most that (the measured error includes it), and a side
    // flattened to nothing is dropped (a sheet's slab in the sheet's own
    // flat box becomes its two faces).
    let positions: Vec<Vec3A> = positions.iter().map(|p| p.clamp(lo, hi)).collect();
    let indices: Vec<u32> = indices
        .chunks_exact(3)
        .filter(|t| {
            let p = |k: usize| positions[t[k] as usize];
            (p(1) - p(0)).cross(p(2) - p(0)).length_squared() > 0.0
        })
        .flatten()
        .copied()
        .collect();
    if indices.is_empty() {
        return None;
    }
    Some(compact(mesh.origin, &positions, &colours, &indices))
}

/// The six face neighbours of a grid vertex: (axis, towards +).
const NEIGHBOURS: [(usize, bool); 6] = [
    (0, true),
    (0, false),
    (1, true),
    (1, false),
    (2, true),
    (2, false),
];

/// A grid of vertices `cell` apart from `origin`, `n` along each axis.
struct Grid {
    origin: Vec3A,
    cell: f32,
    n: [usize; 3],
}

/// The sampled distance from each grid vertex to the geometry (infinite
/// beyond the stamping reach), and the colour of the sample nearest it.
struct Field {
    distance: Vec<f32>,
    colour: Vec<[u8; 4]>,
    /// The vertices with a finite distance.
    touched: Vec<usize>,
}

impl Grid {
    fn new(lo: Vec3A, hi: Vec3A, cell: f32) -> Option<Grid> {
        let span = (hi - lo) / cell;
        let mut n = [0usize; 3];
        for (a, k) in n.iter_mut().enumerate() {
            let cells = span[a].ceil();
            if !(cells.is_finite() && cells < 1e6) {
                return None;
            }
            *k = cells as usize + 2;
        }
        let total = n[0].checked_mul(n[1])?.checked_mul(n[2])?;
        (total <= MAX_GRID_VERTICES).then_some(Grid {
            origin: lo,
            cell,
            n,
        })
    }

    fn index(&self, [x, y, z]: [usize; 3]) -> usize {
        (z * self.n[1] + y) * self.n[0] + x
    }

    fn point(&self, [x, y, z]: [usize; 3]) -> Vec3A {
        self.origin + Vec3A::new(x as f32, y as f32, z as f32) * self.cell
    }

    /// Samples every triangle at most [`SAMPLE_CELLS`] apart; each
    /// sample is the nearest site of its own cell's corners, and sites
    /// then spread to the neighbours of every vertex that took one, a
    /// cell a round, while within `reach` and nearer than the
    /// neighbour's own (a distance transform by nearest sites: each
    /// vertex ends with the nearest sample but for rare ties that a
    /// neighbour did not carry).
    fn distances(&self, mesh: &WorkMesh, reach: f32) -> Field {
        let total = self.n[0] * self.n[1] * self.n[2];
        let mut field = Field {
            distance: vec![f32::INFINITY; total],
            colour: vec![[0; 4]; total],
            touched: Vec::new(),
        };
        let spacing = SAMPLE_CELLS * self.cell;
        // Each touched vertex's nearest site so far, by its place in
        // `touched`.
        let mut slot = vec![u32::MAX; total];
        let mut sites: Vec<Vec3A> = Vec::new();
        let last = [self.n[0] - 1, self.n[1] - 1, self.n[2] - 1];
        let mut stamp = |p: Vec3A, colour: [u8; 4], field: &mut Field| {
            let g = ((p - self.origin) / self.cell).floor();
            let c = [g.x as usize, g.y as usize, g.z as usize];
            for corner in 0..8 {
                let q = [
                    (c[0] + (corner & 1)).min(last[0]),
                    (c[1] + ((corner >> 1) & 1)).min(last[1]),
                    (c[2] + (corner >> 2)).min(last[2]),
                ];
                let i = self.index(q);
                let d = (self.point(q) - p).length();
                if d < field.distance[i] {
                    if slot[i] == u32::MAX {
                        slot[i] = sites.len() as u32;
                        field.touched.push(i);
                        sites.push(p);
                    } else {
                        sites[slot[i] as usize] = p;
                    }
                    field.distance[i] = d;
                    field.colour[i] = colour;
                }
            }
        };
        // The vertices once each, then the samples inside triangles
        // longer than the spacing.
        let mut used = vec![false; mesh.positions.len()];
        for &i in &mesh.indices {
            if !std::mem::replace(&mut used[i as usize], true) {
                let colour = mesh.colours.get(i as usize).copied().unwrap_or([200; 4]);
                stamp(
                    Vec3A::from_array(mesh.positions[i as usize]),
                    colour,
                    &mut field,
                );
            }
        }
        for t in mesh.indices.chunks_exact(3) {
            let v: [Vec3A; 3] =
                std::array::from_fn(|k| Vec3A::from_array(mesh.positions[t[k] as usize]));
            let longest = (v[1] - v[0])
                .length_squared()
                .max((v[2] - v[1]).length_squared())
                .max((v[0] - v[2]).length_squared())
                .sqrt();
            if longest <= spacing {
                continue;
            }
            let colour = mesh.colours.get(t[0] as usize).copied().unwrap_or([200; 4]);
            // Barycentric samples k to an edge: at most `spacing` apart
            // (the corners are stamped already).
            let k = ((longest / spacing).ceil() as usize).clamp(1, 4096);
            for i in 0..=k {
                for j in 0..=k - i {
                    if (i == 0 && (j == 0 || j == k)) || (i == k && j == 0) {
                        continue;
                    }
                    let (a, b) = (i as f32 / k as f32, j as f32 / k as f32);
                    stamp(
                        v[0] + (v[1] - v[0]) * a + (v[2] - v[0]) * b,
                        colour,
                        &mut field,
                    );
                }
            }
        }
        drop(slot);
        // (vertex, its site) for the vertices whose site changed.
        let mut front: Vec<(usize, Vec3A)> = field.touched.iter().copied().zip(sites).collect();
        // Over the six face neighbours a site takes a round per cell of
        // each axis it moves along.
        let rounds = (3.0 * reach / self.cell).ceil() as usize;
        let mut next: Vec<(usize, Vec3A)> = Vec::new();
        for _ in 0..rounds {
            for &(i, s) in &front {
                if (self.point(self.coords(i)) - s).length() > field.distance[i] {
                    // Overtaken by a nearer site since it was queued.
                    continue;
                }
                let colour = field.colour[i];
                let c = self.coords(i);
                for (a, up) in NEIGHBOURS {
                    let mut q = c;
                    if up {
                        if q[a] == last[a] {
                            continue;
                        }
                        q[a] += 1;
                    } else {
                        if q[a] == 0 {
                            continue;
                        }
                        q[a] -= 1;
                    }
                    let j = self.index(q);
                    let d = (self.point(q) - s).length();
                    if d < field.distance[j] && d <= reach {
                        if field.distance[j] == f32::INFINITY {
                            field.touched.push(j);
                        }
                        field.distance[j] = d;
                        field.colour[j] = colour;
                        next.push((j, s));
                    }
                }
            }
            std::mem::swap(&mut front, &mut next);
            next.clear();
            if front.is_empty() {
                break;
            }
        }
        field
    }

    fn coords(&self, i: usize) -> [usize; 3] {
        let (x, rest) = (i % self.n[0], i / self.n[0]);
        [x, rest % self.n[1], rest / self.n[1]]
    }

    /// Surface nets on `field` at `iso`: a vertex per cell the iso-surface
    /// crosses (the mean of its edges' crossings) and a quad per crossed
    /// grid edge, wound to face out (from below `iso` to above). Only the
    /// cells and edges at a vertex below `iso` are visited.
    #[allow(clippy::type_complexity)]
    fn surface_nets(&self, field: &Field, iso: f32) -> (Vec<Vec3A>, Vec<[u8; 4]>, Vec<[u32; 4]>) {
        let inside = |i: usize| field.distance[i] < iso;
        let inner: Vec<usize> = field
            .touched
            .iter()
            .copied()
            .filter(|&i| inside(i))
            .collect();
        // Per cell (indexed by its lowest corner): its vertex, NONE when
        // not visited, or EMPTY when the surface does not cross it.
        const NONE: u32 = u32::MAX;
        const EMPTY: u32 = u32::MAX - 1;
        let mut cell_vertex = vec![NONE; field.distance.len()];
        let mut positions = Vec::new();
        let mut colours = Vec::new();
        // The 12 edges of a cell as pairs of its corners (bit 0: +x, 1: +y, 2: +z).
        const EDGES: [(usize, usize); 12] = [
            (0, 1),
            (2, 3),
            (4, 5),
            (6, 7),
            (0, 2),
            (1, 3),
            (4, 6),
            (5, 7),
            (0, 4),
            (1, 5),
            (2, 6),
            (3, 7),
        ];
        for &v in &inner {
            let [vx, vy, vz] = self.coords(v);
            // Vertices below `iso` lie at least the pad in from the
            // border: every cell with one at a corner is in the grid.
            for k in 0..8 {
                let cell = [vx - (k & 1), vy - ((k >> 1) & 1), vz - (k >> 2)];
                let ci = self.index(cell);
                if cell_vertex[ci] != NONE {
                    continue;
                }
                let corner = |c: usize| {
                    [
                        cell[0] + (c & 1),
                        cell[1] + ((c >> 1) & 1),
                        cell[2] + (c >> 2),
                    ]
                };
                let idx: [usize; 8] = std::array::from_fn(|c| self.index(corner(c)));
                let count = idx.iter().filter(|&&i| inside(i)).count();
                if count == 8 {
                    cell_vertex[ci] = EMPTY;
                    continue;
                }
                let mut sum = Vec3A::ZERO;
                let mut crossings = 0.0f32;
                for (a, b) in EDGES {
                    let (da, db) = (field.distance[idx[a]], field.distance[idx[b]]);
                    if (da < iso) == (db < iso) {
                        continue;
                    }
                    // A vertex beyond the reach has an infinite distance:
                    // the crossing is then taken a cell's slope from the
                    // other (the sampled distance grows at most that fast).
                    let (pa, pb) = (self.point(corner(a)), self.point(corner(b)));
                    let t = if da.is_finite() && db.is_finite() {
                        ((iso - da) / (db - da)).clamp(0.0, 1.0)
                    } else if da.is_finite() {
                        ((iso - da) / self.cell).clamp(0.0, 1.0)
                    } else {
                        1.0 - ((iso - db) / self.cell).clamp(0.0, 1.0)
                    };
                    sum += pa + (pb - pa) * t;
                    crossings += 1.0;
                }
                // The nearest corner's colour: the geometry's there.
                let nearest = idx
                    .iter()
                    .copied()
                    .min_by(|&a, &b| field.distance[a].total_cmp(&field.distance[b]))
                    .unwrap_or(idx[0]);
                cell_vertex[ci] = positions.len() as u32;
                positions.push(sum / crossings);
                colours.push(field.colour[nearest]);
            }
        }
        let mut quads = Vec::new();
        // A crossed edge along axis a from its lower vertex l: the four
        // cells around it are l minus 0 or 1 along the other two axes.
        for &v in &inner {
            let c = self.coords(v);
            for a in 0..3 {
                for up in [true, false] {
                    let mut w = c;
                    if up {
                        w[a] += 1;
                    } else {
                        w[a] -= 1;
                    }
                    if inside(self.index(w)) {
                        continue;
                    }
                    let lower = if up { c } else { w };
                    let (b, cc) = ((a + 1) % 3, (a + 2) % 3);
                    let cell = |db: usize, dc: usize| {
                        let mut k = lower;
                        k[b] -= db;
                        k[cc] -= dc;
                        match cell_vertex[self.index(k)] {
                            NONE | EMPTY => None,
                            q => Some(q),
                        }
                    };
                    let (Some(q0), Some(q1), Some(q2), Some(q3)) =
                        (cell(1, 1), cell(0, 1), cell(0, 0), cell(1, 0))
                    else {
                        continue;
                    };
                    // (b, c, a) is right-handed: q0..q3 run counter-
                    // clockwise seen from +a, facing +a; flipped when the
                    // outside lies towards -a.
                    quads.push(if up {
                        [q0, q1, q2, q3]
                    } else {
                        [q0, q3, q2, q1]
                    });
                }
            }
        }
        (positions, colours, quads)
    }
}

/// Two triangles a quad, split along its shorter diagonal.
fn triangulate(positions: &[Vec3A], quads: &[[u32; 4]]) -> Vec<u32> {
    let mut indices = Vec::with_capacity(6 * quads.len());
    for &[a, b, c, d] in quads {
        let p = |i: u32| positions[i as usize];
        if (p(a) - p(c)).length_squared() <= (p(b) - p(d)).length_squared() {
            indices.extend_from_slice(&[a, b, c, a, c, d]);
        } else {
            indices.extend_from_slice(&[a, b, d, b, c, d]);
        }
    }
    indices
}

/// Edge collapse as far as it goes within `max_error` model units (the
/// simplifier's estimate: the proxy is measured afterwards anyway).
fn simplify(positions: &[Vec3A], indices: &[u32], max_error: f32) -> Vec<u32> {
    let flat: Vec<[f32; 3]> = positions.iter().map(|p| p.to_array()).collect();
    let bytes = meshopt::typed_to_bytes(&flat);
    let Ok(adapter) = VertexDataAdapter::new(bytes, std::mem::size_of::<[f32; 3]>(), 0) else {
        return Vec::new();
    };
    crate::spent::timed(crate::spent::Kind::Simplify, || {
        meshopt::simplify(
            indices,
            &adapter,
            0,
            max_error,
            SimplifyOptions::ErrorAbsolute,
            None,
        )
    })
}

/// The used vertices of `indices` as a mesh relative to `origin`, with
/// area-weighted normals.
fn compact(
    origin: glam::DVec3,
    positions: &[Vec3A],
    colours: &[[u8; 4]],
    indices: &[u32],
) -> WorkMesh {
    let mut remap = vec![u32::MAX; positions.len()];
    let mut m = WorkMesh {
        origin,
        ..Default::default()
    };
    for &i in indices {
        let r = &mut remap[i as usize];
        if *r == u32::MAX {
            *r = m.positions.len() as u32;
            m.positions.push(positions[i as usize].to_array());
            m.colours.push(colours[i as usize]);
        }
        m.indices.push(*r);
    }
    let mut normals = vec![Vec3A::ZERO; m.positions.len()];
    for t in m.indices.chunks_exact(3) {
        let p = |k: usize| Vec3A::from_array(m.positions[t[k] as usize]);
        let n = (p(1) - p(0)).cross(p(2) - p(0));
        for &v in t {
            normals[v as usize] += n;
        }
    }
    m.normals = normals
        .into_iter()
        .map(|n| n.try_normalize().unwrap_or(Vec3A::Y).to_array())
        .collect();
    m
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hausdorff::{self, Nearest, Sampling};
    use crate::hlod::tests::mesh_of;
    use crate::test_models::{box_object, grid_object};
    use glam::DVec3;
    use rustc_hash::FxHashMap;

    /// Every directed edge of a closed, consistently wound surface
    /// appears once, and its reverse once.
    fn is_closed(m: &WorkMesh) -> bool {
        let mut edges: FxHashMap<(u32, u32), i32> = FxHashMap::default();
        for t in m.indices.chunks_exact(3) {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                *edges.entry((a.min(b), a.max(b))).or_default() += if a < b { 1 } else { -1 };
            }
        }
        edges.values().all(|&v| v == 0)
    }

    #[test]
    fn an_empty_mesh_or_a_bad_cell_makes_no_proxy() {
        let m = mesh_of(box_object(DVec3::ZERO, DVec3::ONE));
        assert!(bounds(&WorkMesh::default()).is_none());
        let b = bounds(&m).expect("a box");
        for cell in [0.0, -1.0, f32::NAN, f32::INFINITY] {
            assert!(proxy(&m, b, cell).is_none(), "cell {cell}");
        }
        // A grid past the cap.
        assert!(proxy(&m, b, 1e-4).is_none());
    }

    #[test]
    fn a_thin_open_sheet_becomes_a_closed_slab_within_its_bound() {
        // A single-sided 10 x 10 sheet: no volume at all. Its proxy is a
        // closed slab about a cell either side of it.
        let sheet = mesh_of(grid_object(DVec3::ZERO, 10.0, 8, 0.0));
        let cell = 0.5;
        let b = bounds(&sheet).expect("a box");
        let s = shell(&sheet, b, cell).expect("a shell");
        let closed = compact(sheet.origin, &s.positions, &s.colours, &s.indices);
        assert!(is_closed(&closed), "the slab is not closed");
        // Fitted into the sheet's flat box, its two faces.
        let p = proxy(&sheet, b, cell).expect("a proxy");
        assert!(p.triangles() >= 2, "{} triangles", p.triangles());
        let mut q = Nearest::new(sheet.surface());
        let sampling = Sampling {
            spacing: 0.25,
            floor: 1e-3,
            enough: 0.0,
        };
        let e = hausdorff::symmetric(sheet.surface(), &mut q, p.surface(), &sampling);
        // About the offset out and the corners rounded: within 3 cells.
        assert!(e < 3.0 * cell, "error {e}");
    }

    #[test]
    fn many_small_parts_merge_into_few_triangles() {
        let m = crate::hlod::tests::cubes();
        assert_eq!(m.triangles(), 4800);
        let b = bounds(&m).expect("a box");
        let s = shell(&m, b, 0.2).expect("a shell");
        assert!(is_closed(&compact(
            m.origin,
            &s.positions,
            &s.colours,
            &s.indices
        )));
        let p = proxy(&m, b, 0.2).expect("a proxy");
        assert!(p.triangles() < 600, "{} triangles", p.triangles());
    }
}
