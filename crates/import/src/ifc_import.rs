//! IFC files through gigawalk-ifc: each product with geometry becomes one
//! [`Object`] whose identity keeps its IFC name, spatial path (ending
//! with class and GlobalId), entity id and metadata.

use std::path::Path;

use crate::model::{Identity, ImportStats, Object, Unsupported};
use crate::ImportError;

/// Reads the IFC file at `path` (`file` in messages), handing each
/// product's object to `sink`.
pub fn import_ifc_each(
    path: &Path,
    file: &str,
    sink: &mut dyn FnMut(Object) -> Result<(), ImportError>,
) -> Result<ImportStats, ImportError> {
    let bytes = std::fs::read(path).map_err(|source| ImportError::Io {
        file: file.to_string(),
        source,
    })?;
    let ifc = gigawalk_ifc::IfcFile::parse(bytes, file)?;
    let mut failed = None;
    let s = ifc.read(&mut |o| match sink(object(o, file)) {
        Ok(()) => true,
        Err(e) => {
            failed = Some(e);
            false
        }
    });
    if let Some(e) = failed {
        return Err(e);
    }
    let s = s?;
    Ok(ImportStats {
        triangles: s.triangles + s.degenerate_triangles_dropped,
        degenerate_triangles_dropped: s.degenerate_triangles_dropped,
        skipped_primitives: 0,
        warnings: s.warnings,
        unsupported: s
            .unsupported
            .into_iter()
            .map(|(kind, u)| {
                (
                    kind,
                    Unsupported {
                        items: u.items,
                        products: u.products,
                    },
                )
            })
            .collect(),
    })
}

/// IFC's Z-up world as glTF's Y-up, which gigawalk's cameras, walk mode
/// and generated scenes share: (x, y, z) to (x, z, -y), a rotation about
/// x (windings and handedness kept), so a building stands upright and
/// its north (IFC's +y) looks along -z.
fn y_up(p: glam::DVec3) -> glam::DVec3 {
    glam::DVec3::new(p.x, p.z, -p.y)
}

fn object(o: gigawalk_ifc::IfcObject, file: &str) -> Object {
    Object {
        name: o.name.clone(),
        positions: o.positions.into_iter().map(y_up).collect(),
        normals: o
            .normals
            .into_iter()
            .map(|n| glam::Vec3::new(n.x, n.z, -n.y))
            .collect(),
        indices: o.indices,
        colour: o.colour,
        vertex_colours: o.vertex_colours,
        identity: Identity {
            name: o.name,
            path: o.path,
            file: file.to_string(),
            extras: Some(o.extras),
            // The entity id: two products never share it, so never merge.
            node: Some(o.entity as usize),
        },
    }
}
