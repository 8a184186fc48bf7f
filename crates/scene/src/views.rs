//! Saved views: named cameras with the selection and the hidden objects,
//! in a small JSON file beside the scene (`SCENE.views.json`,
//! docs/views-format.md). Objects are named by their table index and
//! `file/path`, so a view still finds them in a scene preprocessed again
//! (by path) and says which it no longer finds.

use std::path::{Path, PathBuf};

use glam::{DQuat, DVec3};
use serde::{Deserialize, Serialize};

use crate::objects::ObjectTable;
use crate::path::Pose;

pub const VIEWS_VERSION: u32 = 1;

/// An object as a view names it.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct ObjectRef {
    /// Its index in the object table when saved.
    pub id: u32,
    /// Its `file/path` ([`crate::objects::ObjectRecord::full_path`]).
    pub path: String,
}

impl ObjectRef {
    pub fn of(table: &ObjectTable, id: u32) -> Option<ObjectRef> {
        table.object(id).map(|o| ObjectRef {
            id,
            path: o.full_path(),
        })
    }
}

/// One saved view.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SavedView {
    pub name: String,
    /// Eye, world coordinates.
    pub position: [f64; 3],
    /// Camera-to-world rotation as x, y, z, w (the camera looks along its
    /// -Z with +Y up, as in camera paths).
    pub orientation: [f64; 4],
    /// Vertical field of view, degrees.
    pub fovy_deg: f64,
    #[serde(default)]
    pub selected: Vec<ObjectRef>,
    #[serde(default)]
    pub hidden: Vec<ObjectRef>,
    /// When set, every object but these is hidden too (isolate).
    #[serde(default)]
    pub isolated: Option<Vec<ObjectRef>>,
    /// Section planes and box in effect ([`crate::section`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub section: Option<crate::section::SectionSpec>,
    /// X-ray: the hidden objects drawn as faint ghosts.
    #[serde(default)]
    pub xray: bool,
}

impl SavedView {
    /// The view's camera as a path pose (time 0), when its numbers are
    /// usable.
    pub fn pose(&self) -> Result<Pose, String> {
        let position = DVec3::from_array(self.position);
        let q = DQuat::from_array(self.orientation);
        if !position.is_finite() {
            return Err("its position is not finite".into());
        }
        let len = q.length();
        if !(len.is_finite() && len > 1e-6) {
            return Err("its orientation is not a rotation quaternion".into());
        }
        if !(self.fovy_deg > 0.0 && self.fovy_deg < 180.0) {
            return Err(format!(
                "fovy_deg {} is not between 0 and 180",
                self.fovy_deg
            ));
        }
        Ok(Pose {
            time: 0.0,
            position,
            orientation: q / len,
            fovy: self.fovy_deg.to_radians(),
        })
    }

    /// A view of `pose` with these objects.
    pub fn new(name: &str, pose: &Pose) -> SavedView {
        SavedView {
            name: name.to_string(),
            position: pose.position.to_array(),
            orientation: pose.orientation.to_array(),
            fovy_deg: pose.fovy.to_degrees(),
            selected: Vec::new(),
            hidden: Vec::new(),
            isolated: None,
            section: None,
            xray: false,
        }
    }
}

/// A views file's contents.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Views {
    pub version: u32,
    pub views: Vec<SavedView>,
}

/// Why a views file could not be read or written.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ViewsError {
    #[error("{file}: cannot read saved views: {source}")]
    Read {
        file: PathBuf,
        source: std::io::Error,
    },
    #[error("{file}: not a saved-views file (docs/views-format.md): {detail}")]
    Parse { file: PathBuf, detail: String },
    #[error("{file}: view {name:?}: {detail}")]
    BadView {
        file: PathBuf,
        name: String,
        detail: String,
    },
    #[error("{file}: cannot write saved views: {source}")]
    Write {
        file: PathBuf,
        source: std::io::Error,
    },
    #[error("{file}: no view named {name:?} (the file has: {have})")]
    NoSuchView {
        file: PathBuf,
        name: String,
        have: String,
    },
}

impl Views {
    /// Where a scene's views are kept: `SCENE.views.json` beside it.
    pub fn file_for(scene: &Path) -> PathBuf {
        let mut name = scene.file_name().unwrap_or_default().to_os_string();
        name.push(".views.json");
        scene.with_file_name(name)
    }

    /// The views in `file`; none when it does not exist. A file that is
    /// not valid is an error naming it, never taken as empty (saving over
    /// it would lose its views).
    pub fn read(file: &Path) -> Result<Views, ViewsError> {
        let text = match std::fs::read_to_string(file) {
            Ok(t) => t,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                return Ok(Views {
                    version: VIEWS_VERSION,
                    views: Vec::new(),
                })
            }
            Err(source) => {
                return Err(ViewsError::Read {
                    file: file.to_path_buf(),
                    source,
                })
            }
        };
        let v: Views = serde_json::from_str(&text).map_err(|e| ViewsError::Parse {
            file: file.to_path_buf(),
            detail: e.to_string(),
        })?;
        if v.version != VIEWS_VERSION {
            return Err(ViewsError::Parse {
                file: file.to_path_buf(),
                detail: format!("version {}; this gigawalk reads {VIEWS_VERSION}", v.version),
            });
        }
        for view in &v.views {
            view.pose().map_err(|detail| ViewsError::BadView {
                file: file.to_path_buf(),
                name: view.name.clone(),
                detail,
            })?;
        }
        Ok(v)
    }

    #[cfg(not(target_arch = "wasm32"))]
    /// Writes the views to `file` atomically.
    pub fn write(&self, file: &Path) -> Result<(), ViewsError> {
        let text = serde_json::to_string_pretty(self).map_err(|e| ViewsError::Write {
            file: file.to_path_buf(),
            source: std::io::Error::other(e),
        })?;
        crate::write_atomic(file, text.as_bytes()).map_err(|source| ViewsError::Write {
            file: file.to_path_buf(),
            source,
        })
    }

    /// Adds `view`, replacing one of the same name.
    pub fn put(&mut self, view: SavedView) {
        self.version = VIEWS_VERSION;
        match self.views.iter_mut().find(|v| v.name == view.name) {
            Some(v) => *v = view,
            None => self.views.push(view),
        }
    }

    /// The view named `name`, or an error listing those there are.
    pub fn get(&self, file: &Path, name: &str) -> Result<&SavedView, ViewsError> {
        self.views
            .iter()
            .find(|v| v.name == name)
            .ok_or_else(|| ViewsError::NoSuchView {
                file: file.to_path_buf(),
                name: name.to_string(),
                have: if self.views.is_empty() {
                    "none".into()
                } else {
                    self.views
                        .iter()
                        .map(|v| format!("{:?}", v.name))
                        .collect::<Vec<_>>()
                        .join(", ")
                },
            })
    }

    /// A name no view has yet: `view N`.
    pub fn next_name(&self) -> String {
        (1..)
            .map(|i| format!("view {i}"))
            .find(|n| self.views.iter().all(|v| &v.name != n))
            .unwrap_or_default()
    }
}

/// The table indices of `refs`: by index where that object still has the
/// saved path, else the first object with it; and the paths it no longer
/// finds.
pub fn resolve(refs: &[ObjectRef], table: &ObjectTable) -> (Vec<u32>, Vec<String>) {
    let mut found = Vec::new();
    let mut missing = Vec::new();
    let mut by_path: Option<std::collections::HashMap<String, u32>> = None;
    for r in refs {
        if table.object(r.id).is_some_and(|o| o.full_path() == r.path) {
            found.push(r.id);
            continue;
        }
        let map = by_path.get_or_insert_with(|| {
            let mut m = std::collections::HashMap::new();
            for (i, o) in table.objects().iter().enumerate() {
                m.entry(o.full_path()).or_insert(i as u32);
            }
            m
        });
        match map.get(&r.path) {
            Some(&i) => found.push(i),
            None => missing.push(r.path.clone()),
        }
    }
    (found, missing)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::objects::ObjectRecord;
    use crate::Aabb;

    fn table() -> ObjectTable {
        let o = |name: &str| ObjectRecord {
            name: name.into(),
            path: format!("root/{name}"),
            file: "a.glb".into(),
            metadata: None,
            bounds: Aabb {
                min: DVec3::ZERO,
                max: DVec3::ONE,
            },
            triangles: 1,
        };
        ObjectTable::new(vec![o("pump"), o("valve"), o("pipe")], Vec::new())
    }

    #[test]
    fn views_round_trip_and_a_bad_file_is_an_error_not_empty() {
        let dir = std::env::temp_dir().join(format!("gw-views-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let file = Views::file_for(&dir.join("plant.gwk"));
        assert!(file.ends_with("plant.gwk.views.json"));
        let mut v = Views::read(&file).unwrap();
        assert!(v.views.is_empty());
        let pose = Pose {
            time: 0.0,
            position: DVec3::new(1e7, 2.0, -3.0),
            orientation: DQuat::from_rotation_y(0.5),
            fovy: 1.0,
        };
        let mut view = SavedView::new(&v.next_name(), &pose);
        view.hidden = vec![ObjectRef::of(&table(), 1).unwrap()];
        view.xray = true;
        v.put(view.clone());
        assert_eq!(v.next_name(), "view 2");
        v.write(&file).unwrap();
        let back = Views::read(&file).unwrap();
        assert_eq!(back, v);
        let p = back.get(&file, "view 1").unwrap().pose().unwrap();
        assert_eq!(p.position, pose.position);
        assert!(p.orientation.abs_diff_eq(pose.orientation, 1e-12));
        let e = back.get(&file, "nope").unwrap_err().to_string();
        assert!(e.contains("\"view 1\""), "{e}");
        for bad in [
            "{",
            "{\"version\": 2, \"views\": []}",
            "{\"version\": 1, \"views\": [{\"name\": \"x\", \"position\": [0,0,0], \"orientation\": [0,0,0,0], \"fovy_deg\": 60}]}",
            "{\"version\": 1, \"views\": [{\"name\": \"x\", \"position\": [0,0,0], \"orientation\": [0,0,0,1], \"fovy_deg\": 0}]}",
            "{\"version\": 1, \"views\": [{\"name\": \"x\", \"position\": [0,0,0], \"orientation\": [0,0,0,1], \"fovy_deg\": 60, \"xray\": \"yes\"}]}",
        ] {
            std::fs::write(&file, bad).unwrap();
            let e = Views::read(&file).unwrap_err().to_string();
            assert!(e.contains("plant.gwk.views.json"), "{e}");
        }
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn objects_are_found_by_index_then_by_path_and_the_rest_named() {
        let t = table();
        let refs = vec![
            ObjectRef {
                id: 1,
                path: "a.glb/root/valve".into(),
            },
            // Renumbered: found by its path.
            ObjectRef {
                id: 0,
                path: "a.glb/root/pipe".into(),
            },
            ObjectRef {
                id: 7,
                path: "a.glb/root/gone".into(),
            },
        ];
        let (found, missing) = resolve(&refs, &t);
        assert_eq!(found, vec![1, 2]);
        assert_eq!(missing, vec!["a.glb/root/gone".to_string()]);
    }
}
