//! The tileset JSON (3D Tiles 1.1): the main `tileset.json` and the
//! external tilesets the tree is cut into, tiles as the plan gives them,
//! boxes in the root's z-up frame relative to the scene origin.

use gigawalk_scene::{Aabb, Skeleton};
use glam::{DMat4, DVec3};
use serde_json::{json, Value};

use crate::georef::z_up;
use crate::plan::{Files, Plan};

/// What the JSON needs of each written content, by tile.
#[derive(Clone, Copy, Debug)]
pub(crate) struct ContentInfo {
    pub bounds: Aabb,
}

/// Where tile `t`'s content is, relative to the output directory.
pub(crate) fn content_path(t: u32) -> String {
    format!("content/{}/{t}.glb", t / 1000)
}

/// Where the external tileset rooted at tile `t` is, relative to the
/// output directory.
pub(crate) fn external_path(t: u32) -> String {
    format!("tilesets/{t}.json")
}

/// A box in 3D Tiles' form (centre, then three half-axis vectors), z up,
/// relative to `origin`, its faces moved outward onto a grid of step
/// `quantum` and one step further: short decimals that still hold every
/// point of the box (JSON numbers are most of a tileset file). The same
/// grid for every box keeps boxes nested that were nested.
pub(crate) fn box_json(b: &Aabb, origin: DVec3, quantum: Quantum) -> Value {
    let lo = z_up(b.min - origin);
    let hi = z_up(b.max - origin);
    let mut v = vec![json!(0); 12];
    for k in 0..3 {
        // z_up negates one axis: its min and max swap.
        let (a, b) = (lo[k].min(hi[k]), lo[k].max(hi[k]));
        if !(a.is_finite() && b.is_finite() && (b - a) / quantum.step() < 1e15) {
            // Not a box a grid can hold (an empty node's): as it is.
            v[k] = json!((a + b) * 0.5);
            v[3 + 4 * k] = json!((b - a) * 0.5);
            continue;
        }
        let (i0, i1) = (quantum.floor(a) - 1, quantum.ceil(b) + 1);
        // Centre and half extent in half steps: exact decimals.
        v[k] = quantum.half_steps(i0 + i1);
        v[3 + 4 * k] = quantum.half_steps(i1 - i0);
    }
    Value::Array(v)
}

/// The grid boxes are rounded to: a power of ten, 1e-6 of the scene's
/// extent or finer.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Quantum {
    /// The step is 10^exp.
    exp: i32,
}

impl Quantum {
    pub fn for_extent(extent: f64) -> Quantum {
        let exp = if extent.is_finite() && extent > 0.0 {
            (extent.log10().floor() as i32 - 6).clamp(-12, 12)
        } else {
            -6
        };
        Quantum { exp }
    }

    fn step(self) -> f64 {
        10f64.powi(self.exp)
    }

    /// The grid line at or below `x`.
    fn floor(self, x: f64) -> i64 {
        (x / self.step()).floor() as i64
    }

    /// The grid line at or above `x`.
    fn ceil(self, x: f64) -> i64 {
        (x / self.step()).ceil() as i64
    }

    /// `n` half steps as a JSON number: n x 5 x 10^(exp - 1), written
    /// through its exact decimal, so the number is the shortest one that
    /// reads back as the nearest double to it.
    fn half_steps(self, n: i64) -> Value {
        let text = format!("{}e{}", n * 5, self.exp - 1);
        json!(text.parse::<f64>().expect("a decimal parses"))
    }
}

/// A geometric error as the shortest decimal at or above it: a client
/// never reads an error below the measured bound.
pub(crate) fn error_json(e: f64) -> Value {
    if !e.is_finite() || e == 0.0 {
        return json!(e);
    }
    for digits in 1..17 {
        let v: f64 = format!("{:.*e}", digits - 1, e)
            .parse()
            .expect("a formatted number parses");
        if v >= e && v - e <= e * 1e-7 {
            return json!(v);
        }
    }
    json!(e)
}

pub(crate) struct Writer<'a> {
    pub skeleton: &'a Skeleton,
    pub plan: &'a Plan,
    pub files: &'a Files,
    pub contents: &'a [Option<ContentInfo>],
    /// Where the scene origin goes: the georeferencing frame after the
    /// origin's translation.
    pub root_transform: DMat4,
    /// The tileset's own geometric error (nothing drawn at all).
    pub top_error: f64,
    /// The grid boxes are rounded outward to.
    pub quantum: Quantum,
}

impl Writer<'_> {
    /// The JSON of the file rooted at tile `root`.
    pub fn file(&self, root: u32) -> Value {
        let main = root == 0;
        let mut tile = self.tile(root, main);
        tile["refine"] = json!("REPLACE");
        if main {
            tile["transform"] = json!(self.root_transform.to_cols_array());
        }
        let error = if main {
            self.top_error
        } else {
            self.plan.tiles[root as usize].error
        };
        json!({
            "asset": {
                "version": "1.1",
                "generator": concat!("gigawalk export-tiles ", env!("CARGO_PKG_VERSION")),
            },
            "geometricError": error_json(error),
            "root": tile,
        })
    }

    /// Tile `t`'s box: its nodes' boxes (each holds its levels and its
    /// children's boxes, so a tile's box holds its children's).
    fn bounds(&self, t: u32) -> Value {
        let b = self.plan.tiles[t as usize]
            .nodes
            .iter()
            .fold(Aabb::EMPTY, |b, &n| b.union(&self.skeleton.node(n).bounds));
        box_json(&b, self.skeleton.origin(), self.quantum)
    }

    /// Tile `t` and the tiles of its file below it; `main` when the file is
    /// the main tileset (URIs are relative to the file).
    fn tile(&self, t: u32, main: bool) -> Value {
        let tile = &self.plan.tiles[t as usize];
        let up = if main { "" } else { "../" };
        let mut v = json!({
            "boundingVolume": {"box": self.bounds(t)},
            "geometricError": error_json(tile.error),
        });
        if let Some(c) = &self.contents[t as usize] {
            v["content"] = json!({
                "uri": format!("{up}{}", content_path(t)),
                "boundingVolume": {"box": box_json(&c.bounds, self.skeleton.origin(), self.quantum)},
            });
        }
        let children: Vec<Value> = tile
            .children
            .iter()
            .map(|&c| {
                if self.files.is_root[c as usize] {
                    let uri = if main {
                        external_path(c)
                    } else {
                        format!("{c}.json")
                    };
                    json!({
                        "boundingVolume": {"box": self.bounds(c)},
                        "geometricError": error_json(self.plan.tiles[c as usize].error),
                        "content": {"uri": uri},
                    })
                } else {
                    self.tile(c, main)
                }
            })
            .collect();
        if !children.is_empty() {
            v["children"] = Value::Array(children);
        }
        v
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rounded_boxes_hold_the_box_and_stay_short() {
        let q = Quantum::for_extent(350.0);
        let b = Aabb {
            min: DVec3::new(1.234567891, -0.1, 7.0),
            max: DVec3::new(2.5, 0.333333333, 7.000001),
        };
        let origin = DVec3::new(0.5, 0.0, -3.0);
        let v = box_json(&b, origin, q);
        let n: Vec<f64> = v
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect();
        let (lo, hi) = (z_up(b.min - origin), z_up(b.max - origin));
        for k in 0..3 {
            let (a, c) = (lo[k].min(hi[k]), lo[k].max(hi[k]));
            let h = n[3 + 4 * k];
            assert!(n[k] - h <= a && n[k] + h >= c, "axis {k}: {v}");
            assert!(
                h - (c - a) / 2.0 <= 3e-4,
                "axis {k} grows by at most 1.5 steps: {v}"
            );
        }
        assert!(v.to_string().len() < 80, "{v}");
    }

    #[test]
    fn errors_round_up() {
        for e in [
            0.1f32 as f64,
            1.0 / 3.0,
            2.6975631044479087e-06,
            5.16279935836792,
            1e-30,
        ] {
            let v = error_json(e).as_f64().unwrap();
            assert!(v >= e && v - e <= e * 1e-7, "{e} -> {v}");
        }
        assert_eq!(error_json(0.0), json!(0.0));
        assert!(error_json(0.1f32 as f64).to_string().len() <= 12);
    }
}
