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
    pub fn write_glb<W: Write + ?Sized>(&self, w: &mut W) -> std::io::Result<u64> {
        self.builder.write_glb(w)
    }

    /// Bytes of vertex and index data, about the size of the written file.
    pub fn data_bytes(&self) -> u64 {
        self.builder.bin_len() as u64
    }

    /// Splits the scene into `parts` pieces of about equal triangles, each
    /// a run of neighbouring objects, for scenes too big for one .glb file
    /// (glTF binaries are limited to 4 GiB). Fewer pieces when the scene
    /// has fewer objects than `parts`. Write each with
    /// [`Generated::write_glb_part`]; importing all of them gives the
    /// objects, triangles and bounds of the [`Report`].
    pub fn split(&self, parts: usize) -> Vec<Part> {
        self.builder
            .split(parts)
            .into_iter()
            .map(|nodes| Part { nodes })
            .collect()
    }

    /// Writes one piece from [`Generated::split`] as a .glb of its own;
    /// returns the bytes written and the piece's report.
    pub fn write_glb_part<W: Write + ?Sized>(
        &self,
        part: &Part,
        w: &mut W,
    ) -> std::io::Result<(u64, Report)> {
        let b = self.builder.part(part.nodes.clone());
        let report = Report {
            triangles: b.triangles(),
            objects: b.objects(),
            bounds: b.bounds(),
        };
        Ok((b.write_glb(w)?, report))
    }

    /// The .glb in memory (for tests and small scenes).
    pub fn glb_bytes(&self) -> Vec<u8> {
        let mut v = Vec::new();
        self.write_glb(&mut v)
            .expect("writing to a Vec cannot fail");
        v
    }
}

/// One piece of a [`Generated`] scene: a run of its objects.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Part {
    nodes: std::ops::Range<usize>,
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
