//! Screenshots: RGBA8 images to PNG (written atomically), and the few
//! statistics the scripted test uses to tell a rendered scene from a blank
//! or broken frame.

use std::collections::HashSet;
use std::io::Write;
use std::path::{Path, PathBuf};

/// Why a screenshot could not be written.
#[derive(Debug, thiserror::Error)]
pub enum ScreenshotError {
    #[error("{file}: {width}x{height} RGBA needs {expected} bytes, got {got}")]
    Size {
        file: PathBuf,
        width: u32,
        height: u32,
        expected: usize,
        got: usize,
    },
    #[error("{file}: cannot write PNG: {message}")]
    Write { file: PathBuf, message: String },
}

/// Writes sRGB RGBA8 pixels (row 0 at the top) as a PNG, via a temporary
/// file in the same directory so a reader never sees half a file.
pub fn write_png(file: &Path, width: u32, height: u32, rgba: &[u8]) -> Result<(), ScreenshotError> {
    let expected = width as usize * height as usize * 4;
    if rgba.len() != expected || width == 0 || height == 0 {
        return Err(ScreenshotError::Size {
            file: file.into(),
            width,
            height,
            expected,
            got: rgba.len(),
        });
    }
    let err = |message: String| ScreenshotError::Write {
        file: file.into(),
        message,
    };
    let tmp = gigawalk_scene::temp_file_for(file).map_err(|e| err(e.to_string()))?;
    {
        let mut w = std::io::BufWriter::new(tmp.as_file());
        let mut enc = png::Encoder::new(&mut w, width, height);
        enc.set_color(png::ColorType::Rgba);
        enc.set_depth(png::BitDepth::Eight);
        enc.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
        let mut writer = enc.write_header().map_err(|e| err(e.to_string()))?;
        writer
            .write_image_data(rgba)
            .map_err(|e| err(e.to_string()))?;
        writer.finish().map_err(|e| err(e.to_string()))?;
        w.flush().map_err(|e| err(e.to_string()))?;
    }
    // Temporary files are private (0600); a screenshot is an ordinary file.
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt as _;
        let _ = tmp
            .as_file()
            .set_permissions(std::fs::Permissions::from_mode(0o644));
    }
    tmp.persist(file).map_err(|e| err(e.to_string()))?;
    Ok(())
}

/// Reads a PNG written by [`write_png`] back: (width, height, RGBA8).
pub fn read_png(file: &Path) -> Result<(u32, u32, Vec<u8>), String> {
    let f = std::fs::File::open(file).map_err(|e| format!("{}: {e}", file.display()))?;
    let mut dec = png::Decoder::new(std::io::BufReader::new(f));
    dec.set_transformations(png::Transformations::EXPAND);
    let mut reader = dec
        .read_info()
        .map_err(|e| format!("{}: {e}", file.display()))?;
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader
        .next_frame(&mut buf)
        .map_err(|e| format!("{}: {e}", file.display()))?;
    buf.truncate(info.buffer_size());
    if info.color_type != png::ColorType::Rgba || info.bit_depth != png::BitDepth::Eight {
        return Err(format!(
            "{}: expected 8-bit RGBA, found {:?} {:?}",
            file.display(),
            info.color_type,
            info.bit_depth
        ));
    }
    Ok((info.width, info.height, buf))
}

/// What a frame shows, roughly.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImageStats {
    /// Distinct RGB colours.
    pub distinct_colours: usize,
    /// Fraction of pixels that are not the most common colour (the
    /// background, in a frame that shows a scene from inside or outside).
    pub non_background: f64,
}

pub fn image_stats(rgba: &[u8]) -> ImageStats {
    let mut counts = std::collections::HashMap::<[u8; 3], usize>::new();
    for p in rgba.chunks_exact(4) {
        *counts.entry([p[0], p[1], p[2]]).or_default() += 1;
    }
    let total = rgba.len() / 4;
    let top = counts.values().copied().max().unwrap_or(0);
    let distinct: HashSet<_> = counts.keys().collect();
    ImageStats {
        distinct_colours: distinct.len(),
        non_background: if total == 0 {
            0.0
        } else {
            (total - top) as f64 / total as f64
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blank_image_has_one_colour_and_no_foreground() {
        let s = image_stats(&[7, 8, 9, 255].repeat(100));
        assert_eq!(s.distinct_colours, 1);
        assert_eq!(s.non_background, 0.0);
    }

    #[test]
    fn quarter_drawn_image() {
        let mut px = [0u8, 0, 0, 255].repeat(4);
        px[0] = 200;
        let s = image_stats(&px);
        assert_eq!(s.distinct_colours, 2);
        assert_eq!(s.non_background, 0.25);
    }

    #[test]
    fn png_round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("shot.png");
        let px: Vec<u8> = (0..3 * 2 * 4).map(|i| (i * 10) as u8).collect();
        write_png(&file, 3, 2, &px).unwrap();
        assert_eq!(read_png(&file).unwrap(), (3, 2, px));
    }

    #[test]
    fn wrong_size_is_an_error_naming_the_file() {
        let e = write_png(Path::new("x.png"), 2, 2, &[0; 15]).unwrap_err();
        assert!(e.to_string().contains("x.png") && e.to_string().contains("16"));
    }
}
