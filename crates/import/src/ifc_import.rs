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

fn object(o: gigawalk_ifc::IfcObject, file: &str) -> Object {
    Object {
        name: o.name.clone(),
        positions: o.positions,
        normals: o.normals,
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
