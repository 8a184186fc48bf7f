//! What a site of the browser viewer is made of, shared by `gigawalk web`
//! (which writes it) and the server (which serves it without writing it):
//! finding and listing the viewer's bundle, checking the scene, and the
//! `config.json` that tells the page where the scene is.

use std::path::{Path, PathBuf};

/// The environment variable naming the bundle directory.
pub const BUNDLE_ENV: &str = "GIGAWALK_WEB_BUNDLE";
/// What builds the bundle, and where it puts it.
const BUILD_HINT: &str = "build it with crates/web/build.sh (it writes target/web/bundle), \
     or give --bundle DIR or set GIGAWALK_WEB_BUNDLE";
/// The files a bundle cannot do without: the page and the viewer.
const REQUIRED: [&str; 2] = ["index.html", "gigawalk_web_bg.wasm"];
/// The name of the scene on the site, where config.json points by default.
pub const SCENE_NAME: &str = "scene.gwk";
/// The file the page reads to find the scene.
pub const CONFIG_NAME: &str = "config.json";

/// Why the viewer's bundle cannot be used.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum BundleError {
    #[error(
        "the browser viewer's bundle is missing: where this executable is cannot be told, so \
         there is no default place; {}",
        BUILD_HINT
    )]
    NoDefault,
    #[error(
        "the browser viewer's bundle is missing: {} ({origin}) does not exist; {}",
        dir.display(),
        BUILD_HINT
    )]
    Missing { dir: PathBuf, origin: String },
    #[error("{} ({origin}): cannot list the browser viewer's bundle: {source}", dir.display())]
    List {
        dir: PathBuf,
        origin: String,
        #[source]
        source: std::io::Error,
    },
    #[error(
        "{} ({origin}): not the browser viewer's bundle: {} missing; {}",
        dir.display(),
        missing.join(" and "),
        BUILD_HINT
    )]
    NotBundle {
        dir: PathBuf,
        origin: String,
        missing: Vec<&'static str>,
    },
}

/// Why a file is not a scene to put on a site.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SceneError {
    #[error(transparent)]
    Read(#[from] gigawalk_scene::ReadError),
    #[error("{}: cannot read: {source}", path.display())]
    Metadata {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
}

/// The viewer's bundle: its directory and the files served or copied from
/// it.
#[derive(Clone, Debug)]
pub struct Bundle {
    pub dir: PathBuf,
    /// File names, sorted: every regular file directly in `dir` (a link
    /// to one too) whose name is UTF-8, except hidden ones (starting with
    /// `.`) and the two names the site's own files take (`config.json`,
    /// `scene.gwk`: a site written before can be used as a bundle).
    pub files: Vec<String>,
}

impl Bundle {
    /// The bundle from `given` (`--bundle`), else [`BUNDLE_ENV`], else
    /// `../web/bundle` beside the executable (`target/web/bundle` for
    /// `target/release/gigawalk`); an error says where it looked and how
    /// to build it.
    pub fn find(given: Option<&Path>) -> Result<Bundle, BundleError> {
        if let Some(dir) = given {
            return Bundle::open(dir, "--bundle");
        }
        if let Some(dir) = std::env::var_os(BUNDLE_ENV).filter(|v| !v.is_empty()) {
            return Bundle::open(Path::new(&dir), &format!("${BUNDLE_ENV}"));
        }
        let beside = std::env::current_exe().ok().and_then(|exe| {
            exe.parent()
                .and_then(Path::parent)
                .map(|d| d.join("web").join("bundle"))
        });
        let Some(dir) = beside else {
            return Err(BundleError::NoDefault);
        };
        Bundle::open(
            &dir,
            &format!("the default beside this executable, ${BUNDLE_ENV} being unset"),
        )
    }

    /// The bundle in `dir`, which must hold the [`REQUIRED`] files;
    /// `origin` says where `dir` came from, for errors.
    pub fn open(dir: &Path, origin: &str) -> Result<Bundle, BundleError> {
        let list_error = |source: std::io::Error| BundleError::List {
            dir: dir.to_path_buf(),
            origin: origin.to_string(),
            source,
        };
        let entries = std::fs::read_dir(dir).map_err(|e| match e.kind() {
            std::io::ErrorKind::NotFound => BundleError::Missing {
                dir: dir.to_path_buf(),
                origin: origin.to_string(),
            },
            _ => list_error(e),
        })?;
        let mut files = Vec::new();
        for e in entries {
            let e = e.map_err(list_error)?;
            let Ok(name) = e.file_name().into_string() else {
                continue;
            };
            if name.starts_with('.') || name == CONFIG_NAME || name == SCENE_NAME {
                continue;
            }
            // Follows links: a link to a regular file is one.
            if std::fs::metadata(e.path()).is_ok_and(|m| m.is_file()) {
                files.push(name);
            }
        }
        files.sort();
        let missing: Vec<&'static str> = REQUIRED
            .into_iter()
            .filter(|r| !files.iter().any(|f| f == r))
            .collect();
        if !missing.is_empty() {
            return Err(BundleError::NotBundle {
                dir: dir.to_path_buf(),
                origin: origin.to_string(),
                missing,
            });
        }
        Ok(Bundle {
            dir: dir.to_path_buf(),
            files,
        })
    }
}

/// Checks that `scene` is a scene file (its header and skeleton read);
/// returns its size in bytes.
pub fn check_scene(scene: &Path) -> Result<u64, SceneError> {
    gigawalk_scene::SceneReader::open(scene)?;
    let len = std::fs::metadata(scene)
        .map_err(|source| SceneError::Metadata {
            path: scene.to_path_buf(),
            source,
        })?
        .len();
    Ok(len)
}

/// config.json: where the page finds the scene.
pub fn config_json(scene_url: &str) -> String {
    format!("{}\n", serde_json::json!({ "scene": scene_url }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_bundle_lists_its_served_files_only() {
        let t = tempfile::tempdir().unwrap();
        for name in [
            "index.html",
            "gigawalk_web_bg.wasm",
            "main.js",
            ".hidden",
            CONFIG_NAME,
            SCENE_NAME,
        ] {
            std::fs::write(t.path().join(name), name).unwrap();
        }
        std::fs::create_dir(t.path().join("sub")).unwrap();
        let b = Bundle::open(t.path(), "here").unwrap();
        assert_eq!(b.files, ["gigawalk_web_bg.wasm", "index.html", "main.js"]);
    }

    #[test]
    fn a_bundle_without_its_page_or_viewer_names_what_is_missing() {
        let t = tempfile::tempdir().unwrap();
        std::fs::write(t.path().join("main.js"), "x").unwrap();
        let e = Bundle::open(t.path(), "here").unwrap_err().to_string();
        for w in [
            "index.html and gigawalk_web_bg.wasm missing",
            "(here)",
            "crates/web/build.sh",
        ] {
            assert!(e.contains(w), "{w:?} not in {e}");
        }
        let gone = t.path().join("gone");
        let e = Bundle::open(&gone, "--bundle").unwrap_err().to_string();
        assert!(e.contains("does not exist") && e.contains(&*gone.to_string_lossy()));
    }

    #[test]
    fn config_points_at_the_scene_as_json() {
        let c = config_json("a \"b\".gwk");
        assert_eq!(
            serde_json::from_str::<serde_json::Value>(&c).unwrap(),
            serde_json::json!({ "scene": "a \"b\".gwk" })
        );
        assert!(c.ends_with('\n'));
    }
}
