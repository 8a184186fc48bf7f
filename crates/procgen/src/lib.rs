//! Deterministic procedural test scenes as glTF 2.0 binaries: an industrial
//! plant, a city, a forest and a machine hall, each with a camera path
//! walking through it.
//!
//! Main types: [`Kind`], [`Generated`] (from [`generate`]) with its
//! [`Report`] of triangles, objects and bounds, which an import of the
//! written file reproduces exactly. The same arguments give byte-identical
//! files: a fixed PRNG ([`rng`]), no hash maps, no time stamps.

#![forbid(unsafe_code)]

mod city;
mod forest;
mod glb;
mod machine;
mod plant;
pub mod rng;
pub mod shapes;
mod walk;

use std::io::Write;

use gigawalk_scene::path::CameraPath;
use gigawalk_scene::Aabb;

pub use walk::{DT as PATH_DT, EYE_HEIGHT};

/// Which scene to build.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// An industrial plant (the paper's Power Plant): building shell,
    /// equipment, site-spanning pipe runs, catwalks, thousands of small parts.
    Plant,
    /// City blocks whose building walls are large occluders, plus street
    /// furniture (the Coorg-Teller case).
    City,
    /// Many small occluders and deep visibility (the hard case for HZB
    /// culling; Hey et al., Bartz et al.).
    Forest,
    /// A factory floor of CAD-like machines in rows between aisles, no
    /// building shell: each machine hundreds of small disjoint parts (shells,
    /// fasteners, gears, segmented hoses and cables), the case where
    /// simplification must merge many separate pieces.
    Machine,
}

impl Kind {
    pub fn name(self) -> &'static str {
        match self {
            Kind::Plant => "plant",
            Kind::City => "city",
            Kind::Forest => "forest",
            Kind::Machine => "machine",
        }
    }
}

impl std::str::FromStr for Kind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "plant" => Ok(Kind::Plant),
            "city" => Ok(Kind::City),
            "forest" => Ok(Kind::Forest),
            "machine" => Ok(Kind::Machine),
            _ => Err(format!(
                "unknown scene kind {s:?} (expected plant, city, forest or machine)"
            )),
        }
    }
}

/// What was generated, as an importer will see it.
#[derive(Clone, Debug, PartialEq)]
pub struct Report {
    /// Triangles, counting every instance (an importer expands instances).
    pub triangles: u64,
    /// Mesh instances: the objects an importer produces.
    pub objects: usize,
    /// Bounds of every vertex in world coordinates.
    pub bounds: Aabb,
}

/// A generated scene: write it with [`Generated::write_glb`].
pub struct Generated {
    builder: glb::GlbBuilder,
    pub path: CameraPath,
    pub report: Report,
}

impl Generated {
    /// Writes the .glb; returns the bytes written.
    pub fn write_glb<W: Write>(&self, w: &mut W) -> std::io::Result<u64> {
        self.builder.write_glb(w)
    }

    /// The .glb in memory (for tests and small scenes).
    pub fn glb_bytes(&self) -> Vec<u8> {
        let mut v = Vec::new();
        self.write_glb(&mut v)
            .expect("writing to a Vec cannot fail");
        v
    }
}

/// Default number of camera poses: a one-minute walk at 10 poses a second.
pub const DEFAULT_POSES: usize = 600;

/// Builds a scene of about `triangles` triangles (the report says exactly
/// how many) and a camera path of `poses` poses through it.
pub fn generate(kind: Kind, triangles: u64, seed: u64, poses: usize) -> Generated {
    let mut rng = rng::Rng::new(seed);
    let generator = format!(
        "gigawalk-procgen {} triangles={triangles} seed={seed}",
        kind.name()
    );
    let (builder, grid) = match kind {
        Kind::Plant => plant::build(generator, triangles, &mut rng),
        Kind::City => city::build(generator, triangles, &mut rng),
        Kind::Forest => forest::build(generator, triangles, &mut rng),
        Kind::Machine => machine::build(generator, triangles, &mut rng),
    };
    let path = walk::walk(&grid, &mut rng.fork(), poses);
    let report = Report {
        triangles: builder.triangles(),
        objects: builder.objects(),
        bounds: builder.bounds(),
    };
    Generated {
        builder,
        path,
        report,
    }
}
