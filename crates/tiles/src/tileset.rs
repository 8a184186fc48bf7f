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

/// Where a tile's content is, relative to the output directory.
pub(crate) fn content_path(lod: u32) -> String {
    format!("content/{}/{lod}.glb", lod / 1000)
}

/// Where the external tileset rooted at tile `t` is, relative to the
/// output directory.
pub(crate) fn external_path(t: u32) -> String {
    format!("tilesets/{t}.json")
}

/// A box in 3D Tiles' form (centre, then three half-axis vectors), z up,
/// relative to `origin`.
pub(crate) fn box_json(b: &Aabb, origin: DVec3) -> Value {
    let c = z_up((b.min + b.max) * 0.5 - origin);
    let h = z_up((b.max - b.min) * 0.5);
    // The turn keeps each half extent on one axis; z_up negates one,
    // which a box does not care about.
    let (hx, hy, hz) = (h.x.abs(), h.y.abs(), h.z.abs());
    json!([c.x, c.y, c.z, hx, 0.0, 0.0, 0.0, hy, 0.0, 0.0, 0.0, hz])
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
            "geometricError": error,
            "root": tile,
        })
    }

    fn bounds(&self, t: u32) -> Value {
        let node = self.plan.tiles[t as usize].node;
        box_json(&self.skeleton.node(node).bounds, self.skeleton.origin())
    }

    /// Tile `t` and the tiles of its file below it; `main` when the file is
    /// the main tileset (URIs are relative to the file).
    fn tile(&self, t: u32, main: bool) -> Value {
        let tile = &self.plan.tiles[t as usize];
        let up = if main { "" } else { "../" };
        let mut v = json!({
            "boundingVolume": {"box": self.bounds(t)},
            "geometricError": tile.error,
        });
        if let Some(lod) = tile.lod {
            if let Some(c) = &self.contents[t as usize] {
                v["content"] = json!({
                    "uri": format!("{up}{}", content_path(lod)),
                    "boundingVolume": {"box": box_json(&c.bounds, self.skeleton.origin())},
                });
            }
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
                        "geometricError": self.plan.tiles[c as usize].error,
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
