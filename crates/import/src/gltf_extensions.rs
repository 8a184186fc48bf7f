//! Which glTF extensions a file may require: the ones gigawalk reads, the
//! ones it may safely ignore, and a clear error for every other.

use crate::error::ImportError;

/// Extensions that change how geometry is stored and that the importer
/// decodes: integer positions and normals (read by the accessor reader,
/// which already dequantizes every integer type) and meshopt-compressed
/// buffer views (`meshopt_views`).
pub(crate) const READ: &[&str] = &[
    "KHR_mesh_quantization",
    "EXT_meshopt_compression",
    "KHR_meshopt_compression",
];

/// Extensions that only touch textures. gigawalk reads no texture, so a
/// file that requires one of these still imports to the same triangles
/// (gltfpack -tc marks KHR_texture_basisu required).
pub(crate) const IGNORED: &[&str] = &[
    "KHR_texture_basisu",
    "KHR_texture_transform",
    "EXT_texture_webp",
    "EXT_texture_avif",
    "MSFT_texture_dds",
];

pub(crate) const DRACO: &str = "KHR_draco_mesh_compression";

/// What to do with a Draco file. No Draco decoder is linked: the pure-Rust
/// ones (draco-core, draco-oxide) are young single-maintainer projects not
/// yet proven on untrusted input, and the C++ library would be a second
/// native build; so say how to turn the file into something gigawalk reads.
pub(crate) const DRACO_ADVICE: &str = "; decompress it first, e.g. `gltf-transform cp in.glb out.glb`, \
     or recompress it as `gltf-transform meshopt in.glb out.glb` (EXT_meshopt_compression, which gigawalk reads)";

/// Every entry of `extensionsRequired` must be read or ignorable.
pub(crate) fn check_required(required: &[String], file: &str) -> Result<(), ImportError> {
    for extension in required {
        let name = extension.as_str();
        if READ.contains(&name) || IGNORED.contains(&name) {
            continue;
        }
        return Err(unsupported(name, file));
    }
    Ok(())
}

/// The error for an extension the importer cannot read.
pub(crate) fn unsupported(extension: &str, file: &str) -> ImportError {
    let advice = if extension == DRACO {
        DRACO_ADVICE.to_owned()
    } else {
        format!(
            "; gigawalk reads {} and ignores texture extensions",
            READ.join(", ")
        )
    };
    ImportError::UnsupportedExtension {
        file: file.to_owned(),
        extension: extension.to_owned(),
        advice,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(required: &[&str]) -> Result<(), String> {
        let required: Vec<String> = required.iter().map(|s| s.to_string()).collect();
        check_required(&required, "f.glb").map_err(|e| e.to_string())
    }

    #[test]
    fn read_and_ignored_extensions_pass() {
        assert_eq!(check(&[]), Ok(()));
        assert_eq!(
            check(&[
                "KHR_mesh_quantization",
                "EXT_meshopt_compression",
                "KHR_texture_basisu"
            ]),
            Ok(())
        );
    }

    #[test]
    fn draco_names_the_extension_and_the_way_out() {
        let e = check(&["KHR_mesh_quantization", DRACO]).unwrap_err();
        assert!(e.starts_with("f.glb: requires glTF extension KHR_draco_mesh_compression"));
        assert!(e.contains("gltf-transform cp"), "{e}");
    }

    #[test]
    fn other_extensions_are_named() {
        let e = check(&["EXT_mesh_gpu_instancing"]).unwrap_err();
        assert!(e.contains("EXT_mesh_gpu_instancing"), "{e}");
        assert!(e.contains("KHR_mesh_quantization"), "{e}");
    }
}
