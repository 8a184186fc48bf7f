//! A build in one process from the model's files: import under a memory
//! budget (spilling if need be), then [`crate::preprocess`].

use std::path::{Path, PathBuf};
use std::time::Instant;

use crate::shards::{mib, peak_text};
use crate::source::{import_within, MEMORY_SHARE, RESIDENT_SHARE};
use crate::{preprocess, Params, PreprocessError, Progress, Stats};

/// Why [`preprocess_files`] failed.
#[derive(Debug, thiserror::Error)]
pub enum FilesError {
    #[error("cannot import {inputs}")]
    Import {
        inputs: String,
        #[source]
        source: gigawalk_import::ImportError,
    },
    #[error("cannot preprocess {inputs} into {}", output.display())]
    Preprocess {
        inputs: String,
        output: PathBuf,
        #[source]
        source: PreprocessError,
    },
}

/// Imports `inputs` (files or directories, [`gigawalk_import::model_files`])
/// under `budget`, spilling beside `output` if need be, and writes the
/// scene to `output`. `label` names the inputs in messages and the
/// provenance. Returns the statistics, with the import's time and the
/// triangles it dropped, and the model's files.
pub fn preprocess_files(
    inputs: &[PathBuf],
    label: &str,
    params: &Params,
    output: &Path,
    budget: Option<u64>,
    progress: &dyn Progress,
) -> Result<(Stats, Vec<PathBuf>), FilesError> {
    let import_err = |source| FilesError::Import {
        inputs: label.to_string(),
        source,
    };
    let t = Instant::now();
    let files = gigawalk_import::model_files(inputs).map_err(import_err)?;
    let spill_dir = match output.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let model = import_within(&files, budget, spill_dir, &mut |i, n, path| {
        progress.line(&match n {
            1 => format!("importing {}", path.display()),
            _ => format!("importing {}/{n}: {}", i + 1, path.display()),
        })
    })
    .map_err(import_err)?;
    let import_secs = t.elapsed().as_secs_f64();
    let import_stats = model.stats().clone();
    let spilled = model.spilled_bytes();
    let peak = || peak_text(crate::stats::peak_memory_bytes().unwrap_or(0));
    progress.line(&format!(
        "import: {} objects, {} triangles ({} degenerate dropped) in {import_secs:.2} s, {}",
        model.source().len(),
        import_stats.triangles - import_stats.degenerate_triangles_dropped,
        import_stats.degenerate_triangles_dropped,
        match spilled {
            0 => format!("in memory, {}", peak()),
            b => format!(
                "spilled to disk ({}: the objects would take over {:.0}% of the memory budget, or the process over {:.0}%), {}",
                mib(b),
                100.0 * MEMORY_SHARE,
                100.0 * RESIDENT_SHARE,
                peak()
            ),
        }
    ));
    for w in &import_stats.warnings {
        tracing::warn!("{w}");
    }
    let import_dropped = import_stats.degenerate_triangles_dropped;
    let mut stats =
        preprocess(model.source(), params, output, label, progress).map_err(|source| {
            FilesError::Preprocess {
                inputs: label.to_string(),
                output: output.to_path_buf(),
                source,
            }
        })?;
    stats.spilled_bytes = spilled;
    drop(model);
    stats
        .phase_seconds
        .insert(0, ("import".into(), import_secs));
    // Triangles the importer dropped never reach the preprocessor; count
    // them too.
    stats.degenerate_dropped += import_dropped;
    stats.input_triangles += import_dropped;
    Ok((stats, files))
}
