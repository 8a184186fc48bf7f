//! Hand-built objects for the unit tests: pipes, bumpy grids, boxes.

use std::f64::consts::TAU;

use gigawalk_import::Object;
use glam::{DVec3, Vec3};

fn object(name: &str, positions: Vec<DVec3>, normals: Vec<Vec3>, indices: Vec<u32>) -> Object {
    Object {
        name: name.into(),
        positions,
        normals,
        indices,
        colour: [0.5, 0.5, 0.5, 1.0],
        vertex_colours: None,
        identity: Default::default(),
    }
}

/// An open cylinder along +X from `start`: `along` x `around` quads, so
/// 2 x along x around triangles.
pub fn pipe_object(start: DVec3, length: f64, radius: f64, along: u32, around: u32) -> Object {
    let (mut p, mut n, mut idx) = (Vec::new(), Vec::new(), Vec::new());
    for i in 0..=along {
        for j in 0..around {
            let a = TAU * j as f64 / around as f64;
            let dir = DVec3::new(0.0, a.cos(), a.sin());
            p.push(start + DVec3::new(length * i as f64 / along as f64, 0.0, 0.0) + radius * dir);
            n.push(dir.as_vec3());
        }
    }
    for i in 0..along {
        for j in 0..around {
            let a = i * around + j;
            let b = i * around + (j + 1) % around;
            let (c, d) = (a + around, b + around);
            idx.extend_from_slice(&[a, b, d, a, d, c]);
        }
    }
    object("pipe", p, n, idx)
}

/// A `cells` x `cells` height field over [0, size]^2 in XZ at `origin`,
/// with sine bumps of height `bump`: 2 x cells^2 triangles.
pub fn grid_object(origin: DVec3, size: f64, cells: u32, bump: f64) -> Object {
    let (mut p, mut n, mut idx) = (Vec::new(), Vec::new(), Vec::new());
    let k = cells + 1;
    for i in 0..k {
        for j in 0..k {
            let (x, z) = (
                size * i as f64 / cells as f64,
                size * j as f64 / cells as f64,
            );
            let y = bump * (x * 1.3).sin() * (z * 0.7).cos();
            p.push(origin + DVec3::new(x, y, z));
            n.push(Vec3::Y);
        }
    }
    for i in 0..cells {
        for j in 0..cells {
            let a = i * k + j;
            idx.extend_from_slice(&[a, a + 1, a + k + 1, a, a + k + 1, a + k]);
        }
    }
    object("grid", p, n, idx)
}

/// An axis-aligned box from `min` to `max`: 12 triangles, 8 shared vertices.
pub fn box_object(min: DVec3, max: DVec3) -> Object {
    let p: Vec<DVec3> = (0..8)
        .map(|i| {
            DVec3::new(
                if i & 1 == 0 { min.x } else { max.x },
                if i & 2 == 0 { min.y } else { max.y },
                if i & 4 == 0 { min.z } else { max.z },
            )
        })
        .collect();
    let n = p
        .iter()
        .map(|q| (*q - (min + max) * 0.5).normalize_or_zero().as_vec3())
        .collect();
    #[rustfmt::skip]
    let idx = vec![
        0, 2, 3, 0, 3, 1, 4, 5, 7, 4, 7, 6, 0, 1, 5, 0, 5, 4,
        2, 6, 7, 2, 7, 3, 0, 4, 6, 0, 6, 2, 1, 3, 7, 1, 7, 5,
    ];
    object("box", p, n, idx)
}

/// A closed prism along +Y from `base`: an `around`-gon of `radius`,
/// `height` tall, capped (fans from the centre): 4 x around triangles.
pub fn prism_object(base: DVec3, radius: f64, height: f64, around: u32) -> Object {
    let (mut p, mut n, mut idx) = (Vec::new(), Vec::new(), Vec::new());
    for y in [0.0, height] {
        for j in 0..around {
            let a = TAU * j as f64 / around as f64;
            let dir = DVec3::new(a.cos(), 0.0, a.sin());
            p.push(base + DVec3::new(0.0, y, 0.0) + radius * dir);
            n.push(dir.as_vec3());
        }
    }
    let (bottom, top) = (p.len() as u32, p.len() as u32 + 1);
    p.push(base);
    n.push(-Vec3::Y);
    p.push(base + DVec3::new(0.0, height, 0.0));
    n.push(Vec3::Y);
    for j in 0..around {
        let (a, b) = (j, (j + 1) % around);
        let (c, d) = (a + around, b + around);
        idx.extend_from_slice(&[a, c, d, a, d, b, bottom, b, a, top, c, d]);
    }
    object("prism", p, n, idx)
}

/// A torus in the XY plane around `centre`: `major` radius of the ring,
/// `minor` of its tube, `along` x `around` quads.
pub fn ring_object(centre: DVec3, major: f64, minor: f64, along: u32, around: u32) -> Object {
    let (mut p, mut n, mut idx) = (Vec::new(), Vec::new(), Vec::new());
    for i in 0..along {
        let u = TAU * i as f64 / along as f64;
        let axis = DVec3::new(u.cos(), u.sin(), 0.0);
        for j in 0..around {
            let v = TAU * j as f64 / around as f64;
            let dir = axis * v.cos() + DVec3::Z * v.sin();
            p.push(centre + major * axis + minor * dir);
            n.push(dir.as_vec3());
        }
    }
    for i in 0..along {
        for j in 0..around {
            let a = i * around + j;
            let b = i * around + (j + 1) % around;
            let c = ((i + 1) % along) * around + j;
            let d = ((i + 1) % along) * around + (j + 1) % around;
            idx.extend_from_slice(&[a, b, d, a, d, c]);
        }
    }
    object("ring", p, n, idx)
}

/// A bolt standing on `base`: a hexagonal head on a square shank, two
/// disjoint closed pieces as CAD often leaves them: 40 triangles.
pub fn bolt_objects(base: DVec3, size: f64) -> [Object; 2] {
    [
        prism_object(base, 0.35 * size, 2.0 * size, 4),
        prism_object(base + DVec3::new(0.0, 2.0 * size, 0.0), size, 0.7 * size, 6),
    ]
}
