//! The preprocessor's parameters: the paper's values (GigaWalk Section 6.3.1)
//! expressed relative to the model, and their resolution into model units.

use gigawalk_scene::Aabb;
use serde_json::{json, Map, Value};

/// A level is accepted only if it has at most this fraction of the previous
/// level's triangles; otherwise the simplifier has stalled (e.g. on many
/// tiny disconnected pieces that edge collapses cannot remove). So
/// `--lod-ratio` may not ask for more.
pub(crate) const MIN_SHRINK: f64 = 0.65;

/// The view-direction counts a cell tree can have
/// ([`crate::occluders::cell_directions`]): 4, 8 or 16 around +Y; 6, 14 or
/// 26 over the sphere.
pub const CELL_DIRECTIONS: [u32; 6] = [4, 6, 8, 14, 16, 26];

/// Every knob of the preprocess. Sizes are fractions of a model measure so
/// that the same defaults work on a model in millimetres or in kilometres;
/// [`Params::resolve`] turns them into model units for one model.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Params {
    /// Partition-I triangle threshold t1 (Section 4.2.1, 6.3.1: 1000).
    /// An object is split only when it has more triangles than this.
    pub t1: u32,
    /// Partition-I size threshold s1 as a fraction of the model size, the
    /// diagonal of the scene's bounding box (6.3.1: 0.1 x model dimension).
    pub s1: f64,
    /// Partition-I aspect-ratio threshold r1: largest over smallest box
    /// dimension (6.3.1: 2.5). Unitless.
    pub r1: f64,
    /// Clustering edge threshold D as a fraction of the largest box side
    /// of the larger of the two objects (Section 4.2.2, 6.3.1: D = 0.1 x
    /// max bounding box dimension, read per pair; see `cluster.rs` for
    /// why). Objects farther apart than their D share no edge.
    pub d: f64,
    /// Maximum cluster volume V as a fraction of the scene box volume
    /// (6.3.1: V = 1e-3 x total scene bounding box volume).
    pub v: f64,
    /// Clustering's volume cap by density: when set, V is at most the
    /// volume that this many triangles fill at the model's mean density
    /// (the scene box's volume x this / the model's triangles). `v` alone,
    /// a fraction of the whole scene's volume, makes every cluster and
    /// leaf bigger as the model grows, near the eye too; capped by density,
    /// they stay the same where the model grows by more of the same (rows
    /// added behind a floor, units added to a plant). The default, 4000,
    /// equals `v`'s 1e-3 on a 4M-triangle model, so models up to 4M
    /// triangles are clustered as by `v` alone (docs/results.md, "The far
    /// field on real CAD": 0.80x the triangles on a 10M floor of real CAD).
    /// `None`: `v` alone, as in the paper.
    #[serde(default)]
    pub v_triangles: Option<u64>,
    /// Felzenszwalb-Huttenlocher constant K (6.3.1: 1500), in thousandths of
    /// the edge's D. The criterion compares an edge weight w (a length, at most D) with
    /// I(C) + K/|C|, so K must be a length; the paper's bare 1500 would be
    /// 1500 model units, which in a model measured in metres lets every edge
    /// through and in one measured in kilometres none. Measured in D/1000,
    /// K = 1500 means a lone object accepts any neighbour (K/1 = 1.5 D > w),
    /// and a cluster of n objects accepts an edge only when it is within
    /// 1.5 D / n of its largest internal gap: the bias toward clusters of
    /// cardinality O(K) that Section 4.2.2 asks for, at every model scale.
    pub k: f64,
    /// Partition-II triangle threshold as a multiple of t1 (Section 4.2.3;
    /// the paper's 6.3.1 uses t2 = 10 t1). Default 1: a cluster of up to
    /// 10 t1 triangles may be a pipe run across the whole site, and a leaf
    /// is drawn whole at the LOD its nearest point needs, so long leaves
    /// near the eye draw their full detail far away too. Measured on a
    /// 4M-triangle plant (640x360, 1 px, frustum-only traversal): 918k
    /// triangles a frame at t2 = 10 t1, 401k at t2 = t1.
    pub t2_factor: f64,
    /// Partition-II size threshold as a multiple of s1 (6.3.1: s2 = 2 s1).
    pub s2_factor: f64,
    /// Partition-II aspect threshold as a multiple of r1 (6.3.1: r2 = 0.5 r1).
    pub r2_factor: f64,
    /// Each LOD aims for this fraction of the previous level's triangles
    /// (Section 4.3 leaves the ratio open; halving keeps the chain's total
    /// at about twice the finest level).
    pub lod_ratio: f64,
    /// A LOD chain stops once a level has at most this many triangles: below
    /// a few dozen triangles a node costs more to traverse than to draw.
    pub lod_floor: u32,
    /// The simplified levels 1..=collapse_levels of every chain (a leaf's
    /// levels after its own mesh, an inner node's from its first HLOD) are
    /// made by edge collapse (meshopt's topology-preserving simplify, which
    /// thins pieces rather than dropping them); coarser ones, and any level
    /// where collapse stalls, by sloppy vertex clustering. Measured on the
    /// 4M demo plant's walk (och, 1 px, 640x360, node budget 512): 8
    /// draws 41.4k triangles a frame against 49.6k with 1, at fewer
    /// bound-violating pixels and the same preprocess time; with a 1024
    /// budget it cost 1.3-2.2x the time (docs/results.md "Preprocessing
    /// knobs").
    pub collapse_levels: u32,
    /// Triangles of an inner node's finest HLOD, at most. Its children are
    /// cut at a matching error so they hold about `node_budget / lod_ratio`
    /// triangles together, and merged and simplified to this; so a node
    /// becomes drawable once that many triangles reach the pixel
    /// tolerance, and switching to its children multiplies the triangles
    /// drawn by about 1 / lod_ratio. Larger: fewer, bigger draws and a
    /// larger scene file; smaller: more nodes to traverse. With one collapse
    /// level, 512 drew 8% and 10% fewer triangles than 1024 on the 4M and
    /// 20M plants' walks (och, 1 px), in a 1.2x smaller scene.
    pub node_budget: u32,
    /// Error measurement: the cover of the samples taken on each surface,
    /// as a fraction of the largest distance found at the vertices
    /// (`hausdorff::Sampling::spacing`). A stored error exceeds the true
    /// Hausdorff distance by at most about this fraction (plus the floor);
    /// smaller is tighter and slower.
    pub bound_spacing: f64,
    /// Error measurement: the finest sample cover aimed for, as a fraction
    /// of the node's box diagonal (a kept surface still gets at least this
    /// much error; 1e-3 is a pixel once the node spans 1000 pixels).
    pub bound_floor: f64,
    /// Object-space culling's view cells (Coorg and Teller, Section 3.1):
    /// levels of the kD-tree over the eye's space (8: about 250 cells).
    pub cell_height: u32,
    /// ...occluders listed per cell and view direction (the paper: 32).
    pub cell_occluders: u32,
    /// ...view directions: 4, 8 (the paper's count) or 16 around the up
    /// axis (+Y), or 6, 14 or 26 over the sphere.
    pub cell_directions: u32,
    /// How the scene stores positions: on a grid over each LOD's box,
    /// meshopt-encoded (each LOD's error grows by what its vertices moved),
    /// or raw f32.
    pub position_bits: PositionBits,
    /// Bits of each octahedral normal coordinate in encoded LODs: 8 (the
    /// default: within 0.93 degrees, 0.34 on average; on the 1M plant's
    /// walk no channel of a full-detail frame moved by more than 2 of 255
    /// against 16 bits, for a 12% smaller scene) or 16 (within 0.004
    /// degrees).
    pub normal_bits: u8,
    /// zstd over each encoded blob, with a dictionary trained on the
    /// scene's first blobs (the default: on the 1M plant's blobs 0.62x of
    /// meshopt's output), or meshopt's output as it is.
    pub compress: bool,
    /// Which chains a leaf's levels are chosen from
    /// ([`crate::hlod::leaf_lods`]).
    #[serde(default, skip_serializing_if = "LeafChains::is_default")]
    pub leaf_chains: LeafChains,
    /// Whether chains' levels meet a pair contraction across gaps (GAPS,
    /// [`crate::hlod`]) as a rival, the better kept: it joins disjoint
    /// parts and closes holes that edge collapse keeps. On by default:
    /// on floors of real CAD 0.85-0.91x the triangles drawn (frustum and
    /// HLODs, 1 px) for 1.5-1.63x the preprocess CPU time.
    #[serde(default = "default_gaps")]
    pub gaps: bool,
    /// Whether merged proxies (watertight shells at the scale of an
    /// error, [`crate::hlod`]) are made and measured beside every chain's
    /// levels, and kept where they draw fewer triangles at a lower error.
    /// Off by default: on floors of real CAD 0.97x and 0.94x the
    /// triangles drawn (frustum and HLODs, 1 px) for 1.6x and 4.5x the
    /// preprocess time.
    #[serde(default)]
    pub proxies: bool,
    /// The finest merged proxies' cells across a node's longest side:
    /// proxies are tried on 8, 16, ... up to this many (8 to 128). Each
    /// halving of the cell costs about 4x the time of the last, and on a
    /// held-out real-CAD floor bought the most of the gain.
    #[serde(default = "default_proxy_cells")]
    pub proxy_cells: u32,
}

fn default_gaps() -> bool {
    true
}

fn default_proxy_cells() -> u32 {
    128
}

/// Which LOD chains a leaf gets.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum LeafChains {
    /// One chain, each vanished piece keeping its largest triangle.
    #[default]
    Kept,
    /// That chain and one that covers vanished pieces as an inner node's
    /// does; the one that draws fewer triangles over the distances the
    /// leaf may be seen from is kept. On the real-CAD floor 0.90x the
    /// triangles drawn (frustum and HLODs, 1 px) for 1.55x the preprocess
    /// time; on the generated plant 0.97x for 1.27x.
    Best,
}

impl LeafChains {
    fn is_default(&self) -> bool {
        *self == LeafChains::default()
    }
}

impl std::fmt::Display for LeafChains {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            LeafChains::Kept => "kept",
            LeafChains::Best => "best",
        })
    }
}

/// How a scene stores its positions.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum PositionBits {
    /// A grid of this many bits per axis over each LOD's box (8..=24).
    Grid(u8),
    /// f32 offsets from each LOD's centre, nothing encoded (format 1's
    /// layout).
    F32,
}

impl PositionBits {
    /// What the scene writer takes: the grid's bits, `None` for f32.
    pub fn bits(self) -> Option<u8> {
        match self {
            PositionBits::Grid(b) => Some(b),
            PositionBits::F32 => None,
        }
    }
}

impl std::fmt::Display for PositionBits {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            PositionBits::Grid(b) => write!(f, "{b}"),
            PositionBits::F32 => f.write_str("f32"),
        }
    }
}

impl std::str::FromStr for PositionBits {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        if s == "f32" {
            return Ok(PositionBits::F32);
        }
        match s.parse::<u8>() {
            Ok(b) if gigawalk_scene::codec::POSITION_BITS.contains(&b) => Ok(PositionBits::Grid(b)),
            _ => Err(format!(
                "{s:?} is neither f32 nor a number of bits from 8 to 24"
            )),
        }
    }
}

impl Default for Params {
    fn default() -> Self {
        Params {
            t1: 1000,
            s1: 0.1,
            r1: 2.5,
            d: 0.1,
            v: 1e-3,
            v_triangles: Some(4000),
            k: 1500.0,
            t2_factor: 1.0,
            s2_factor: 2.0,
            r2_factor: 0.5,
            lod_ratio: 0.5,
            lod_floor: 64,
            collapse_levels: 8,
            node_budget: 512,
            bound_spacing: 0.25,
            bound_floor: 1e-3,
            cell_height: 8,
            cell_occluders: 32,
            cell_directions: 8,
            position_bits: PositionBits::Grid(gigawalk_scene::DEFAULT_POSITION_BITS),
            normal_bits: 8,
            compress: true,
            leaf_chains: LeafChains::Kept,
            gaps: true,
            proxies: false,
            proxy_cells: default_proxy_cells(),
        }
    }
}

/// A parameter out of its valid range.
#[derive(Debug, thiserror::Error, PartialEq)]
#[error("parameter {name} = {value} is invalid: {why}")]
pub struct ParamError {
    pub name: &'static str,
    pub value: f64,
    pub why: &'static str,
}

impl Params {
    /// Checks every parameter's range; the CLI reports the first bad one.
    pub fn validate(&self) -> Result<(), ParamError> {
        let positive = |name, value: f64| {
            if value.is_finite() && value > 0.0 {
                Ok(())
            } else {
                Err(ParamError {
                    name,
                    value,
                    why: "must be a finite number above 0",
                })
            }
        };
        if self.t1 == 0 {
            return Err(ParamError {
                name: "t1",
                value: 0.0,
                why: "must be at least 1",
            });
        }
        positive("s1", self.s1)?;
        positive("r1", self.r1)?;
        if self.r1 < 1.0 {
            return Err(ParamError {
                name: "r1",
                value: self.r1,
                why: "an aspect ratio is at least 1",
            });
        }
        positive("d", self.d)?;
        positive("v", self.v)?;
        if self.v_triangles == Some(0) {
            return Err(ParamError {
                name: "v_triangles",
                value: 0.0,
                why: "must be at least 1",
            });
        }
        positive("k", self.k)?;
        positive("t2-factor", self.t2_factor)?;
        positive("s2-factor", self.s2_factor)?;
        positive("r2-factor", self.r2_factor)?;
        if self.r1 * self.r2_factor < 1.0 {
            return Err(ParamError {
                name: "r2-factor",
                value: self.r2_factor,
                why: "r1 x r2-factor must be at least 1 (an aspect ratio is at least 1)",
            });
        }
        if !(self.lod_ratio > 0.0 && self.lod_ratio <= MIN_SHRINK) {
            return Err(ParamError {
                name: "lod-ratio",
                value: self.lod_ratio,
                why: "must be above 0 and at most 0.65 (a level keeps at most 65% of the \
                      previous level's triangles, so a larger target makes almost no levels)",
            });
        }
        if self.node_budget == 0 {
            return Err(ParamError {
                name: "node-budget",
                value: 0.0,
                why: "must be at least 1",
            });
        }
        if !(8..=128).contains(&self.proxy_cells) {
            return Err(ParamError {
                name: "proxy-cells",
                value: self.proxy_cells as f64,
                why: "must be from 8 to 128 (a finer grid would pass the proxies' grid cap)",
            });
        }
        if !(self.bound_spacing > 0.0 && self.bound_spacing <= 1.0) {
            return Err(ParamError {
                name: "bound-spacing",
                value: self.bound_spacing,
                why: "must be above 0 and at most 1",
            });
        }
        if !(self.bound_floor > 0.0 && self.bound_floor <= 0.1) {
            return Err(ParamError {
                name: "bound-floor",
                value: self.bound_floor,
                why: "must be above 0 and at most 0.1",
            });
        }
        if self.cell_height > 16 {
            return Err(ParamError {
                name: "cell-height",
                value: self.cell_height as f64,
                why: "must be at most 16 (65,536 cells)",
            });
        }
        if !(1..=1024).contains(&self.cell_occluders) {
            return Err(ParamError {
                name: "cell-occluders",
                value: self.cell_occluders as f64,
                why: "must be 1 to 1024",
            });
        }
        if !CELL_DIRECTIONS.contains(&self.cell_directions) {
            return Err(ParamError {
                name: "cell-directions",
                value: self.cell_directions as f64,
                why: "must be 4, 8 or 16 (around +Y) or 6, 14 or 26 (the sphere)",
            });
        }
        if let PositionBits::Grid(b) = self.position_bits {
            if !gigawalk_scene::codec::POSITION_BITS.contains(&b) {
                return Err(ParamError {
                    name: "position-bits",
                    value: b as f64,
                    why: "must be 8 to 24 bits, or f32",
                });
            }
        }
        if !gigawalk_scene::codec::NORMAL_BITS.contains(&self.normal_bits) {
            return Err(ParamError {
                name: "normal-bits",
                value: self.normal_bits as f64,
                why: "must be 16 or 8",
            });
        }
        if self.lod_floor == 0 {
            return Err(ParamError {
                name: "lod-floor",
                value: 0.0,
                why: "must be at least 1",
            });
        }
        Ok(())
    }

    /// The Partition-I thresholds and the scene measures everything scales
    /// with. D depends on the objects after Partition-I, so it is resolved
    /// later by [`Resolved::with_d`].
    pub fn resolve(&self, scene: &Aabb, triangles: u64) -> Resolved {
        let extent = scene.extent();
        let model_size = scene.diagonal();
        // A flat scene (a city with no height, a single plate) has zero
        // volume; measuring every box with a small minimum thickness keeps
        // the volume cap meaningful there.
        let min_extent = 1e-3 * extent.max_element();
        let scene_volume = padded_volume(scene, min_extent);
        let t1 = self.t1 as usize;
        let s1 = self.s1 * model_size;
        Resolved {
            model_size,
            scene_volume,
            min_extent,
            t1,
            s1,
            r1: self.r1,
            d: 0.0,
            v: scene_volume
                * self
                    .v_triangles
                    .map_or(self.v, |n| self.v.min(n as f64 / triangles.max(1) as f64)),
            k: 0.0,
            t2: (self.t2_factor * t1 as f64).round().max(1.0) as usize,
            s2: self.s2_factor * s1,
            r2: self.r2_factor * self.r1,
        }
    }

    /// The parameters as given, for the scene file's provenance.
    pub fn to_json(&self) -> Map<String, Value> {
        let v = json!({
            "t1": self.t1,
            "s1_fraction_of_model_diagonal": self.s1,
            "r1": self.r1,
            "d_fraction_of_larger_object_side": self.d,
            "v_fraction_of_scene_volume": self.v,
            "k_in_thousandths_of_edge_d": self.k,
            "t2_factor": self.t2_factor,
            "s2_factor": self.s2_factor,
            "r2_factor": self.r2_factor,
            "lod_ratio": self.lod_ratio,
            "lod_floor": self.lod_floor,
            "collapse_levels": self.collapse_levels,
            "node_budget": self.node_budget,
            "bound_spacing": self.bound_spacing,
            "bound_floor_fraction_of_node_diagonal": self.bound_floor,
            "cell_height": self.cell_height,
            "cell_occluders": self.cell_occluders,
            "cell_directions": self.cell_directions,
            "position_bits": self.position_bits.to_string(),
            "normal_bits": self.normal_bits,
            "compress": if self.compress { "zstd" } else { "none" },
        });
        match v {
            Value::Object(mut m) => {
                // Only when set: a scene made with `v` alone (the paper's
                // rule) keeps the provenance, and bytes, it had before.
                if let Some(n) = self.v_triangles {
                    m.insert("v_triangles".into(), json!(n));
                }
                if !self.leaf_chains.is_default() {
                    m.insert("leaf_chains".into(), json!(self.leaf_chains.to_string()));
                }
                if !self.gaps {
                    m.insert("gaps".into(), json!(false));
                }
                if self.proxies {
                    m.insert("proxies".into(), json!(true));
                    m.insert("proxy_cells".into(), json!(self.proxy_cells));
                }
                m
            }
            _ => unreachable!("json! of an object literal is an object"),
        }
    }
}

/// Parameters in model units for one model.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Resolved {
    /// Diagonal of the scene box.
    pub model_size: f64,
    /// Volume of the scene box, each side at least `min_extent`.
    pub scene_volume: f64,
    /// Thinnest side a box is given when measuring its volume.
    pub min_extent: f64,
    pub t1: usize,
    pub s1: f64,
    pub r1: f64,
    /// The largest D of any edge: d x the largest object side.
    pub d: f64,
    pub v: f64,
    /// K as a length for that largest D: K x D / 1000.
    pub k: f64,
    pub t2: usize,
    pub s2: f64,
    pub r2: f64,
}

impl Resolved {
    /// Fills in the largest D (and K, measured in D/1000) from the largest
    /// box side of the objects entering clustering, for the record.
    pub fn with_d(mut self, params: &Params, max_object_dimension: f64) -> Self {
        self.d = params.d * max_object_dimension;
        self.k = params.k * self.d / 1000.0;
        self
    }
}

/// Volume of a box whose every side is at least `min_extent`.
pub fn padded_volume(b: &Aabb, min_extent: f64) -> f64 {
    let e = b.extent().max(glam::DVec3::splat(min_extent));
    e.x * e.y * e.z
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    #[test]
    fn a_cap_by_density_stays_the_same_where_the_model_grows_by_more_of_the_same() {
        let p = Params::default();
        assert_eq!(p.v_triangles, Some(4000));
        p.validate().unwrap();
        let floor = Aabb::new(DVec3::ZERO, DVec3::new(48.0, 3.0, 48.0));
        let deeper = Aabb::new(DVec3::ZERO, DVec3::new(48.0, 3.0, 96.0));
        let (one, two) = (
            p.resolve(&floor, 10_000_000),
            p.resolve(&deeper, 20_000_000),
        );
        assert!((one.v - 48.0 * 3.0 * 48.0 * 4e-4).abs() < 1e-9, "{}", one.v);
        assert!((two.v / one.v - 1.0).abs() < 1e-12);
        // By volume alone (the paper's), it doubles; up to 4M triangles
        // the density cap does not bind.
        let paper = Params {
            v_triangles: None,
            ..Params::default()
        };
        assert!((paper.resolve(&deeper, 1).v / paper.resolve(&floor, 1).v - 2.0).abs() < 1e-12);
        for t in [0, 1_000, 4_000_000] {
            assert_eq!(p.resolve(&floor, t).v, paper.resolve(&floor, t).v, "{t}");
        }
        // Zero is refused; the provenance names it only when set.
        let zero = Params {
            v_triangles: Some(0),
            ..Params::default()
        };
        assert_eq!(zero.validate().unwrap_err().name, "v_triangles");
        assert_eq!(p.to_json()["v_triangles"], 4000);
        assert!(!paper.to_json().contains_key("v_triangles"));
    }

    #[test]
    fn defaults_are_valid_and_scale_with_the_model() {
        let p = Params::default();
        p.validate().unwrap();
        let small = p.resolve(&Aabb::new(DVec3::ZERO, DVec3::splat(1.0)), 1_000);
        let big = p.resolve(&Aabb::new(DVec3::ZERO, DVec3::splat(1000.0)), 1_000);
        assert!((big.s1 / small.s1 - 1000.0).abs() < 1e-9);
        assert!((big.v / small.v - 1e9).abs() < 1e-3);
        assert_eq!(small.t2, 1_000);
        assert!((small.r2 - 1.25).abs() < 1e-12);
        let small = small.with_d(&p, 0.5);
        assert!((small.d - 0.05).abs() < 1e-12);
        assert!((small.k - 1.5 * small.d).abs() < 1e-12);
    }

    #[test]
    fn bad_values_are_named() {
        let p = Params {
            s1: -1.0,
            ..Params::default()
        };
        assert_eq!(p.validate().unwrap_err().name, "s1");
        for r in [1.0, 0.7, 0.0, f64::NAN] {
            let p = Params {
                lod_ratio: r,
                ..Params::default()
            };
            assert_eq!(p.validate().unwrap_err().name, "lod-ratio", "{r}");
        }
        let p = Params {
            lod_ratio: 0.65,
            ..Params::default()
        };
        assert!(p.validate().is_ok());
        let p = Params {
            v: f64::NAN,
            ..Params::default()
        };
        assert_eq!(p.validate().unwrap_err().name, "v");
        for (p, name) in [
            (
                Params {
                    cell_directions: 7,
                    ..Params::default()
                },
                "cell-directions",
            ),
            (
                Params {
                    normal_bits: 12,
                    ..Params::default()
                },
                "normal-bits",
            ),
            (
                Params {
                    position_bits: PositionBits::Grid(30),
                    ..Params::default()
                },
                "position-bits",
            ),
            (
                Params {
                    cell_occluders: 0,
                    ..Params::default()
                },
                "cell-occluders",
            ),
            (
                Params {
                    cell_height: 17,
                    ..Params::default()
                },
                "cell-height",
            ),
            (
                Params {
                    proxy_cells: 4,
                    ..Params::default()
                },
                "proxy-cells",
            ),
            (
                Params {
                    proxy_cells: 256,
                    ..Params::default()
                },
                "proxy-cells",
            ),
        ] {
            assert_eq!(p.validate().unwrap_err().name, name);
        }
    }

    #[test]
    fn flat_scene_has_a_volume() {
        let r = Params::default().resolve(
            &Aabb::new(DVec3::ZERO, DVec3::new(100.0, 0.0, 100.0)),
            1_000,
        );
        assert!(r.scene_volume > 0.0);
        assert!(r.v > 0.0);
    }

    #[test]
    fn position_bits_parse_and_print() {
        let p = |t: &str| t.parse::<PositionBits>();
        assert_eq!(p("16"), Ok(PositionBits::Grid(16)));
        assert_eq!(p("8"), Ok(PositionBits::Grid(8)));
        assert_eq!(p("24"), Ok(PositionBits::Grid(24)));
        assert_eq!(p("f32"), Ok(PositionBits::F32));
        for bad in ["7", "25", "", "16.0", "F32", "-1"] {
            assert!(p(bad).unwrap_err().contains("8 to 24"), "{bad}");
        }
        for b in [PositionBits::Grid(12), PositionBits::F32] {
            assert_eq!(p(&b.to_string()), Ok(b));
        }
        assert_eq!(PositionBits::F32.bits(), None);
        assert_eq!(Params::default().position_bits.bits(), Some(16));
    }
}
