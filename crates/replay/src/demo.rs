//! `gigawalk demo`'s scene: the procedural plant and its walk, generated and
//! preprocessed once into a cache directory and reused while the cache's
//! stamp matches; and the demo's replay options.

use std::path::{Path, PathBuf};

use gigawalk_procgen::{generate, Kind};
use gigawalk_runtime::RuntimeOptions;
use gigawalk_scene::path::{CameraPath, PathReadError, PathWriteError};
use gigawalk_scene::{ReadError, SceneReader};

use crate::mode::Mode;
use crate::replay::ReplayOptions;

/// The demo scene. The defaults are sized so that `gigawalk demo` finishes
/// in a few minutes on a 2-core machine with lavapipe (docs/results.md,
/// "The demo plant").
#[derive(Clone, Debug, PartialEq)]
pub struct DemoScene {
    pub triangles: u64,
    pub seed: u64,
    /// Poses of the walk (10 a second), one frame each.
    pub poses: usize,
}

impl Default for DemoScene {
    fn default() -> Self {
        DemoScene {
            triangles: DEFAULT_TRIANGLES,
            seed: 1,
            poses: DEFAULT_FRAMES,
        }
    }
}

/// Default plant size: large enough that drawing everything in the frustum
/// (`vfc`) is far slower than drawing what occlusion and HLODs keep, small
/// enough to generate and preprocess in about a minute on 2 cores.
pub const DEFAULT_TRIANGLES: u64 = 4_000_000;
/// Default walk: 20 seconds at 10 poses a second.
pub const DEFAULT_FRAMES: usize = 200;
/// Default viewport of the demo replay.
pub const DEFAULT_WIDTH: u32 = 640;
pub const DEFAULT_HEIGHT: u32 = 360;

/// Why the demo scene could not be prepared.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DemoError {
    #[error("{file}: {source}")]
    Io {
        file: PathBuf,
        source: std::io::Error,
    },
    #[error("cannot import the generated plant: {0}")]
    Import(#[from] gigawalk_import::ImportError),
    #[error("cannot preprocess the generated plant into {file}: {source}")]
    Preprocess {
        file: PathBuf,
        source: gigawalk_preprocess::PreprocessError,
    },
    #[error(transparent)]
    PathWrite(#[from] PathWriteError),
    #[error(transparent)]
    PathRead(#[from] PathReadError),
    #[error("the freshly written scene does not open: {0}")]
    Scene(#[from] ReadError),
}

/// The cached scene and path files.
#[derive(Clone, Debug)]
pub struct Prepared {
    pub scene: PathBuf,
    pub path: PathBuf,
    /// Whether this call generated and preprocessed them (false: cache hit).
    pub built: bool,
}

impl DemoScene {
    fn stem(&self) -> String {
        format!(
            "plant-{}-seed{}-{}poses",
            self.triangles, self.seed, self.poses
        )
    }

    /// What the cached files were made from; a different stamp means stale.
    fn stamp(&self, params: &gigawalk_preprocess::Params) -> String {
        let v = serde_json::json!({
            "kind": "plant",
            "triangles": self.triangles,
            "seed": self.seed,
            "poses": self.poses,
            "preprocess": params.to_json(),
            "preprocess_revision": gigawalk_preprocess::REVISION,
            "gigawalk_replay": env!("CARGO_PKG_VERSION"),
            "scene_format": [gigawalk_scene::FORMAT_MAJOR, gigawalk_scene::FORMAT_MINOR],
        });
        serde_json::to_string_pretty(&v).expect("stamp serialises") + "\n"
    }

    /// Returns the cached scene and path under `cache`, generating and
    /// preprocessing them first when missing, stale (stamp differs, files
    /// unreadable) or `rebuild` is set. `log` gets one line per step;
    /// `progress` watches the preprocessor.
    pub fn prepare(
        &self,
        cache: &Path,
        rebuild: bool,
        log: &mut dyn FnMut(&str),
        progress: &dyn gigawalk_preprocess::Progress,
    ) -> Result<Prepared, DemoError> {
        let io = |file: &Path| {
            let file = file.to_owned();
            move |source| DemoError::Io { file, source }
        };
        std::fs::create_dir_all(cache).map_err(io(cache))?;
        let stem = self.stem();
        let scene = cache.join(format!("{stem}.gwk"));
        let path = cache.join(format!("{stem}.path"));
        let stamp_file = cache.join(format!("{stem}.stamp.json"));
        let params = gigawalk_preprocess::Params::default();
        let stamp = self.stamp(&params);
        let fresh = !rebuild
            && std::fs::read_to_string(&stamp_file).is_ok_and(|s| s == stamp)
            && SceneReader::open(&scene).is_ok()
            && CameraPath::read(&path).is_ok();
        if fresh {
            log(&format!("using cached {}", scene.display()));
            return Ok(Prepared {
                scene,
                path,
                built: false,
            });
        }
        // The stamp goes last: an interrupted build leaves a stale cache.
        let _ = std::fs::remove_file(&stamp_file);
        log(&format!(
            "generating a {}-triangle plant (seed {}) and a {}-pose walk",
            self.triangles, self.seed, self.poses
        ));
        let t = std::time::Instant::now();
        let g = generate(Kind::Plant, self.triangles, self.seed, self.poses);
        let model = gigawalk_import::import_glb_bytes(&g.glb_bytes(), &stem)?;
        log(&format!(
            "generated and imported {} triangles in {} objects in {:.1} s",
            g.report.triangles,
            g.report.objects,
            t.elapsed().as_secs_f64()
        ));
        g.path.write(&path)?;
        drop(g);
        log(&format!("preprocessing into {}", scene.display()));
        let source = format!(
            "gigawalk demo: procgen plant triangles={} seed={}",
            self.triangles, self.seed
        );
        gigawalk_preprocess::preprocess(&model, &params, &scene, &source, progress).map_err(
            |source| DemoError::Preprocess {
                file: scene.clone(),
                source,
            },
        )?;
        drop(model);
        SceneReader::open(&scene)?;
        gigawalk_scene::write_atomic(&stamp_file, stamp.as_bytes()).map_err(io(&stamp_file))?;
        Ok(Prepared {
            scene,
            path,
            built: true,
        })
    }
}

/// The demo's replay: all four modes at pixel error 1, pipelined on two
/// devices, accuracy every 10th frame.
pub fn replay_options(frames: usize, width: u32, height: u32) -> ReplayOptions {
    ReplayOptions {
        modes: Mode::ALL.to_vec(),
        pixel_errors: vec![1.0],
        cullers: vec![Default::default()],
        runtime: RuntimeOptions {
            width,
            height,
            ..RuntimeOptions::default()
        },
        memory_budget: Default::default(),
        near: None,
        frames: Some(frames),
        accuracy_every: 10,
        warmup: 5,
        target: None,
        adapter: None,
        visibility: None,
        section: None,
        look: Default::default(),
        ghosts: None,
    }
}
