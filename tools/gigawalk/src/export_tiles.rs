//! `gigawalk export-tiles`: a scene file as a 3D Tiles 1.1 tileset
//! (gigawalk-tiles does the work; docs/tiles.md says what is written).

use std::path::PathBuf;

use crate::preprocess::PhaseBar;
use anyhow::Context as _;
use gigawalk_tiles::{Encoding, ExportError, ExportOptions, Georef, Progress};

#[derive(clap::Args)]
pub struct Args {
    /// The scene file (.gwk) to export
    scene: PathBuf,
    /// The output directory: tileset.json, tilesets/ (external tilesets of
    /// a large tree) and content/ (one .glb per tile with content); refused when it
    /// exists and is not empty, unless --force
    #[arg(short, long, value_name = "DIR")]
    out: PathBuf,
    /// Write into an output directory that is not empty: its tileset.json,
    /// content/ and tilesets/ are removed first (tileset.json before
    /// anything else); nothing else in it is touched
    #[arg(long)]
    force: bool,
    /// How contents store geometry: meshopt (integer positions and
    /// normals, KHR_mesh_quantization, compressed by EXT_meshopt_compression;
    /// CesiumJS, 3d-tiles-renderer and Cesium for Unreal/Unity read it),
    /// quantized (the integers uncompressed), plain (core glTF, f32)
    #[arg(long, value_name = "KIND", default_value = "meshopt", value_parser = ["meshopt", "quantized", "plain"])]
    encoding: String,
    /// Core glTF only, for clients without the extensions: --encoding plain
    #[arg(long, conflicts_with = "encoding")]
    plain: bool,
    /// Georeference: the model's origin at this WGS84 longitude and
    /// latitude (degrees) and height above the ellipsoid (metres), x east,
    /// y up, -z north, model units taken as metres. Without it (and
    /// --transform) the tileset is in local model units at its own origin
    #[arg(long, value_name = "LON,LAT,HEIGHT", allow_hyphen_values = true)]
    origin: Option<String>,
    /// Georeference by a matrix instead: 16 numbers, column-major, that
    /// take the model's z-up frame (its x, -z, y) to the tileset's (ECEF),
    /// scale included (e.g. 0.001 for a model in mm)
    #[arg(
        long,
        value_name = "MATRIX",
        conflicts_with = "origin",
        allow_hyphen_values = true
    )]
    transform: Option<String>,
    /// At most this many tiles in one tileset file; the rest of a large
    /// tree goes into external tilesets (about 300 bytes of JSON a tile)
    #[arg(long, value_name = "N", default_value_t = gigawalk_tiles::DEFAULT_TILES_PER_FILE)]
    tiles_per_file: usize,
    /// About this many triangles a content: a tile unites the stored
    /// levels of as many hierarchy nodes as fit (fewer, larger contents
    /// are fewer requests and draws for a client)
    #[arg(long, value_name = "N", default_value_t = gigawalk_tiles::plan::DEFAULT_CONTENT_TRIANGLES)]
    content_triangles: u64,
    /// Print what was written as JSON
    #[arg(long)]
    json: bool,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let encoding = match (args.plain, args.encoding.as_str()) {
        (true, _) | (_, "plain") => Encoding::Plain,
        (_, "quantized") => Encoding::Quantized,
        _ => Encoding::Meshopt,
    };
    let georef = match (&args.origin, &args.transform) {
        (Some(o), _) => Georef::parse_origin(o)
            .map_err(anyhow::Error::msg)
            .context("--origin")?,
        (_, Some(t)) => Georef::parse_transform(t)
            .map_err(anyhow::Error::msg)
            .context("--transform")?,
        _ => Georef::Local,
    };
    if args.tiles_per_file < 2 {
        anyhow::bail!("--tiles-per-file {}: at least 2", args.tiles_per_file);
    }
    if args.content_triangles == 0 {
        anyhow::bail!("--content-triangles 0: at least 1");
    }
    let options = ExportOptions {
        content_triangles: args.content_triangles,
        encoding,
        georef,
        force: args.force,
        tiles_per_file: args.tiles_per_file,
        ..ExportOptions::default()
    };
    let display = PhaseBar::new();
    let s = match gigawalk_tiles::export(&args.scene, &args.out, &options, &display) {
        Ok(s) => s,
        Err(e @ ExportError::OutputExists(_)) => {
            anyhow::bail!("{e}; give --force to write over it, or another directory")
        }
        Err(e) => return Err(e.into()),
    };
    if args.json {
        let v = serde_json::json!({
            "tileset": args.out.join("tileset.json"),
            "encoding": encoding.name(),
            "tiles": s.tiles,
            "contents": s.contents,
            "tileset_files": s.tileset_files,
            "content_bytes": s.content_bytes,
            "json_bytes": s.json_bytes,
            "largest_json_bytes": s.largest_json_bytes,
            "triangles": s.triangles,
            "median_content_triangles": s.median_content_triangles,
            "parts": s.parts,
            "contents_with_features": s.contents_with_features,
            "identity": s.identity,
            "levels_left_out": s.levels_left_out,
            "depth": s.depth,
            "seconds": s.seconds,
        });
        out!("{}", serde_json::to_string_pretty(&v)?)?;
        return Ok(());
    }
    out!("tileset     {}", args.out.join("tileset.json").display())?;
    out!(
        "tiles       {} ({} with content, {} deep), {} stored levels in them, {} levels no band draws",
        s.tiles,
        s.contents,
        s.depth,
        s.parts,
        s.levels_left_out
    )?;
    out!(
        "bytes       {} of {} contents, {} of JSON in {} file(s), the largest {}",
        mib(s.content_bytes),
        encoding.name(),
        mib(s.json_bytes),
        s.tileset_files,
        mib(s.largest_json_bytes)
    )?;
    out!(
        "triangles   {} over every content, {} in the median one",
        s.triangles,
        s.median_content_triangles
    )?;
    if s.identity {
        out!(
            "objects     feature IDs and a property table in {} of {} contents",
            s.contents_with_features,
            s.contents
        )?;
    } else {
        out!(
            "objects     none: the scene holds no object identity (preprocess it again to have it)"
        )?;
    }
    out!("time        {:.2} s", s.seconds)?;
    Ok(())
}

fn mib(b: u64) -> String {
    format!("{:.2} MiB", b as f64 / (1 << 20) as f64)
}

/// The export's phases: a bar on a terminal, a line a phase.
impl Progress for PhaseBar {
    fn start(&self, phase: &str, total: u64) {
        self.show(
            phase,
            total,
            "{prefix:>9} [{bar:40}] {pos}/{len} {elapsed_precise} eta {eta}",
            None,
        );
    }

    fn advance(&self, n: u64) {
        self.inc(n);
    }

    fn finish(&self, phase: &str, seconds: f64) {
        self.clear();
        eprintln!("{phase:>9} done in {seconds:.2} s");
    }
}
