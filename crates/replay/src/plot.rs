//! The report's plots with plotters (bitmap backend, PNG): frame rate along
//! the path per run (the paper's Figure 9) and, for a pixel-error sweep,
//! frame rate against image error.
//!
//! Text goes through ab_glyph with a vendored DejaVu Sans subset
//! (assets/, with its licence), so plots need no system fonts.

use std::path::Path;
use std::sync::Once;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::{register_font, FontStyle};

use crate::mode::Mode;
use crate::replay::Replay;
use crate::summary::{measured, Summary};

static FONT: &[u8] = include_bytes!("../assets/DejaVuSans-ascii.ttf");
const FAMILY: &str = "sans-serif";

fn fonts() {
    static REGISTER: Once = Once::new();
    REGISTER.call_once(|| {
        // The font is compiled in and checked by the plot tests: failing to
        // parse it is a build defect, not a user error.
        if register_font(FAMILY, FontStyle::Normal, FONT).is_err() {
            debug_assert!(false, "vendored font does not parse");
        }
    });
}

fn colour(mode: Mode, shade: usize) -> RGBColor {
    let base = match mode {
        Mode::Vfc => (200, 40, 40),
        Mode::Hlod => (230, 150, 20),
        Mode::Occ => (40, 90, 200),
        Mode::Och => (30, 150, 60),
    };
    // Later runs of a swept mode get darker.
    let k = 1.0 / (1.0 + 0.45 * shade as f64);
    let f = |c: u8| (c as f64 * k) as u8;
    RGBColor(f(base.0), f(base.1), f(base.2))
}

/// More than one pixel error among the runs that use one, or a run held
/// to a target frame rate.
pub fn is_sweep(s: &Summary) -> bool {
    let mut errs: Vec<f64> = s
        .modes
        .iter()
        .filter(|m| m.name.parse::<Mode>().is_ok_and(|m| m.uses_pixel_error()))
        .map(|m| m.pixel_error)
        .collect();
    errs.sort_by(f64::total_cmp);
    errs.dedup();
    errs.len() > 1 || s.modes.iter().any(|m| m.target_fps.is_some())
}

/// Why a plot could not be made.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PlotError {
    /// Drawing it in memory failed (plotters).
    #[error("{0}")]
    Draw(#[source] Box<dyn std::error::Error + Send + Sync>),
    /// Encoding it as PNG failed.
    #[error("{0}")]
    Encode(#[source] png::EncodingError),
    /// Writing the file failed (nothing is left at its path).
    #[error("{0}")]
    Write(#[source] std::io::Error),
}

fn err<E: std::error::Error + Send + Sync + 'static>(e: E) -> PlotError {
    PlotError::Draw(Box::new(e))
}

/// Draws a plot of `size` in memory with `draw`, then writes it to `file`
/// as PNG ([`write_png`]).
fn plot_png(
    file: &Path,
    size: (u32, u32),
    draw: impl FnOnce(&DrawingArea<BitMapBackend<'_>, Shift>) -> Result<(), PlotError>,
) -> Result<(), PlotError> {
    let mut rgb = vec![0; size.0 as usize * size.1 as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, size).into_drawing_area();
        draw(&root)?;
        root.present().map_err(err)?;
    }
    write_png(file, size, &rgb)
}

/// Encodes a plot drawn in memory as PNG and writes it to `file` whole
/// or not at all (through a temporary file renamed into place): a full
/// disk leaves no truncated image beside the report.
fn write_png(file: &Path, size: (u32, u32), rgb: &[u8]) -> Result<(), PlotError> {
    let mut bytes = Vec::new();
    let mut encoder = png::Encoder::new(&mut bytes, size.0, size.1);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    let mut writer = encoder.write_header().map_err(PlotError::Encode)?;
    writer.write_image_data(rgb).map_err(PlotError::Encode)?;
    writer.finish().map_err(PlotError::Encode)?;
    gigawalk_scene::write_atomic(file, &bytes).map_err(PlotError::Write)
}

/// Rounds a positive range out to whole decades for a log axis.
fn decades(lo: f64, hi: f64) -> (f64, f64) {
    let lo = if lo.is_finite() && lo > 0.0 { lo } else { 0.1 };
    let hi = if hi.is_finite() && hi > lo {
        hi
    } else {
        lo * 10.0
    };
    (
        10f64.powf(lo.log10().floor()),
        10f64.powf(hi.log10().ceil()),
    )
}

/// A run's label, mode and (frame, fps) points.
type Series = (String, Mode, Vec<(f64, f64)>);

/// fps.png: each run's frame rate (1000 / frame ms) along the path, log
/// scale, warm-up frames left out.
pub fn fps(replay: &Replay, file: &Path) -> Result<(), PlotError> {
    fonts();
    plot_png(file, (1000, 520), |root| {
        root.fill(&WHITE).map_err(err)?;
        let series: Vec<Series> = replay
            .runs
            .iter()
            .map(|r| {
                let pts = measured(&r.frames)
                    .iter()
                    .filter_map(|f| f.frame_ms.map(|ms| (f.frame as f64, 1e3 / ms)))
                    .collect();
                (r.label(), r.mode, pts)
            })
            .collect();
        let all = series.iter().flat_map(|s| s.2.iter());
        let (lo, hi) = all.fold((f64::INFINITY, 0f64), |(lo, hi), p| {
            (lo.min(p.1), hi.max(p.1))
        });
        let (lo, hi) = decades(lo, hi);
        let frames = replay.frames.max(2) as f64;
        let mut chart = ChartBuilder::on(root)
            .caption(
                format!(
                    "Frame rate along the path ({}x{})",
                    replay.options.runtime.width, replay.options.runtime.height
                ),
                (FAMILY, 22),
            )
            .margin(12)
            .x_label_area_size(42)
            .y_label_area_size(60)
            .build_cartesian_2d(0f64..frames - 1.0, (lo..hi).log_scale())
            .map_err(err)?;
        chart
            .configure_mesh()
            .x_desc("frame (pose along the path)")
            .y_desc("frames per second (log)")
            .label_style((FAMILY, 14))
            .x_label_formatter(&|v| format!("{v:.0}"))
            .y_label_formatter(&|v| {
                if *v >= 1.0 {
                    format!("{v:.0}")
                } else {
                    format!("{v}")
                }
            })
            .draw()
            .map_err(err)?;
        let mut shade = std::collections::HashMap::new();
        for (label, mode, pts) in series {
            let s = shade.entry(mode).or_insert(0usize);
            let c = colour(mode, *s);
            *s += 1;
            chart
                .draw_series(LineSeries::new(pts, c.stroke_width(2)))
                .map_err(err)?
                .label(label)
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(3))
                });
        }
        chart
            .configure_series_labels()
            .label_font((FAMILY, 15))
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .position(SeriesLabelPosition::UpperLeft)
            .draw()
            .map_err(err)?;
        Ok(())
    })
}

/// pixel_error.png (a target frame rate): the pixel-error tolerance each
/// controlled run chose along the path, with its frame time against the
/// target on a second panel.
pub fn pixel_error(replay: &Replay, file: &Path) -> Result<(), PlotError> {
    fonts();
    plot_png(file, (1000, 640), |root| {
        root.fill(&WHITE).map_err(err)?;
        let (top, bottom) = root.split_vertically(330);
        let runs: Vec<_> = replay
            .runs
            .iter()
            .filter(|r| r.frames.iter().any(|f| f.controller_us.is_some()))
            .collect();
        let frames = replay.frames.max(2) as f64;
        let max_p = runs
            .iter()
            .flat_map(|r| r.frames.iter().map(|f| f.pixel_error_used))
            .fold(1.0f64, f64::max);
        let mut chart = ChartBuilder::on(&top)
            .caption("Pixel error chosen for the target frame rate", (FAMILY, 20))
            .margin(10)
            .x_label_area_size(30)
            .y_label_area_size(60)
            .build_cartesian_2d(0f64..frames - 1.0, 0f64..max_p * 1.1)
            .map_err(err)?;
        chart
            .configure_mesh()
            .y_desc("pixel error")
            .label_style((FAMILY, 14))
            .draw()
            .map_err(err)?;
        let target = replay.options.target.map_or(f64::NAN, |t| t.ms);
        let max_ms = runs
            .iter()
            .flat_map(|r| r.frames.iter().filter_map(|f| f.frame_ms))
            .fold(target * 2.0, f64::max);
        let mut lower = ChartBuilder::on(&bottom)
            .margin(10)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(0f64..frames - 1.0, 0f64..max_ms.min(target * 4.0))
            .map_err(err)?;
        lower
            .configure_mesh()
            .x_desc("frame (pose along the path)")
            .y_desc(format!("frame ms (target {target:.1}, black)"))
            .label_style((FAMILY, 14))
            .draw()
            .map_err(err)?;
        lower
            .draw_series(LineSeries::new(
                [(0.0, target), (frames - 1.0, target)],
                BLACK.stroke_width(1),
            ))
            .map_err(err)?;
        let mut shade = std::collections::HashMap::new();
        for r in runs {
            let s = shade.entry(r.mode).or_insert(0usize);
            let c = colour(r.mode, *s);
            *s += 1;
            let p: Vec<(f64, f64)> = r
                .frames
                .iter()
                .map(|f| (f.frame as f64, f.pixel_error_used))
                .collect();
            chart
                .draw_series(LineSeries::new(p, c.stroke_width(2)))
                .map_err(err)?
                .label(r.label())
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(3))
                });
            let ms: Vec<(f64, f64)> = r
                .frames
                .iter()
                .filter_map(|f| f.frame_ms.map(|ms| (f.frame as f64, ms)))
                .collect();
            lower
                .draw_series(LineSeries::new(ms, c.stroke_width(1)))
                .map_err(err)?;
        }
        chart
            .configure_series_labels()
            .label_font((FAMILY, 14))
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .draw()
            .map_err(err)?;
        Ok(())
    })
}

/// tradeoff.png: mean frame rate against the fraction of pixels breaking
/// the pixel-error bound (or against the pixel error when accuracy was not
/// measured), one line per mode through its pixel errors. The bound, not
/// differing colour, because it says whether a tolerance of p pixels keeps
/// its promise: a coarse LOD that shades slightly differently but stays in
/// place differs everywhere without breaking it.
pub fn tradeoff(s: &Summary, file: &Path) -> Result<(), PlotError> {
    fonts();
    let with_accuracy = s.modes.iter().all(|m| m.bound_violating_fraction.is_some());
    let with_popping = with_accuracy && s.modes.iter().all(|m| m.popping.is_some());
    plot_png(file, (if with_popping { 1400 } else { 900 }, 560), |root| {
        root.fill(&WHITE).map_err(err)?;
        let bound = |m: &crate::summary::ModeSummary| {
            if with_accuracy {
                100.0 * m.bound_violating_fraction.unwrap_or(0.0)
            } else {
                m.pixel_error
            }
        };
        let bound_desc = if with_accuracy {
            "pixels breaking the pixel-error bound against the full-detail reference (%)"
        } else {
            "pixel error tolerance (px)"
        };
        if with_popping {
            let (left, right) = root.split_horizontally(760);
            tradeoff_panel(s, &left, "Speed against image error", &bound, bound_desc)?;
            let popping = |m: &crate::summary::ModeSummary| 100.0 * m.popping.unwrap_or(0.0);
            tradeoff_panel(
                s,
                &right,
                "Speed against popping",
                &popping,
                "pixels popping a frame (%)",
            )?;
        } else {
            tradeoff_panel(s, root, "Speed against image error", &bound, bound_desc)?;
        }
        Ok(())
    })
}

/// One panel of tradeoff.png: mean fps against `x_of`, a line per mode
/// through its fixed pixel errors, target-frame-rate runs as triangles.
fn tradeoff_panel<DB: DrawingBackend>(
    s: &Summary,
    area: &DrawingArea<DB, plotters::coord::Shift>,
    caption: &str,
    x_of: &dyn Fn(&crate::summary::ModeSummary) -> f64,
    x_desc: &str,
) -> Result<(), PlotError>
where
    DB::ErrorType: 'static,
{
    let xs = s.modes.iter().map(x_of);
    let x_hi = xs.fold(0f64, f64::max).max(1e-3) * 1.15;
    let (lo, hi) = s.modes.iter().fold((f64::INFINITY, 0f64), |(lo, hi), m| {
        (lo.min(m.mean_fps), hi.max(m.mean_fps))
    });
    let (lo, hi) = decades(lo, hi);
    let mut chart = ChartBuilder::on(area)
        .caption(caption, (FAMILY, 22))
        .margin(12)
        .x_label_area_size(42)
        .y_label_area_size(60)
        .build_cartesian_2d(0f64..x_hi, (lo..hi).log_scale())
        .map_err(err)?;
    chart
        .configure_mesh()
        .x_desc(x_desc)
        .y_desc("mean frames per second (log)")
        .label_style((FAMILY, 14))
        .y_label_formatter(&|v| format!("{v}"))
        .draw()
        .map_err(err)?;
    for mode in Mode::ALL {
        let of_mode =
            |m: &&crate::summary::ModeSummary| m.name == mode.name() && m.mean_fps.is_finite();
        let mut pts: Vec<(f64, f64, f64)> = s
            .modes
            .iter()
            .filter(of_mode)
            .filter(|m| m.target_fps.is_none())
            .map(|m| (x_of(m), m.mean_fps, m.pixel_error))
            .collect();
        let held: Vec<(f64, f64, f64)> = s
            .modes
            .iter()
            .filter(of_mode)
            .filter_map(|m| Some((x_of(m), m.mean_fps, m.target_fps?)))
            .collect();
        if pts.is_empty() && held.is_empty() {
            continue;
        }
        pts.sort_by(|a, b| a.2.total_cmp(&b.2));
        let c = colour(mode, 0);
        chart
            .draw_series(LineSeries::new(
                pts.iter().map(|p| (p.0, p.1)),
                c.stroke_width(2),
            ))
            .map_err(err)?
            .label(mode.name())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(3)));
        chart
            .draw_series(pts.iter().map(|&(x, y, px)| {
                EmptyElement::at((x, y))
                    + Circle::new((0, 0), 4, c.filled())
                    + Text::new(
                        if mode.uses_pixel_error() {
                            format!("{px}px")
                        } else {
                            String::new()
                        },
                        (6, -16),
                        (FAMILY, 13),
                    )
            }))
            .map_err(err)?;
        chart
            .draw_series(held.iter().map(|&(x, y, fps)| {
                EmptyElement::at((x, y))
                    + TriangleMarker::new((0, 0), 7, c.filled())
                    + Text::new(format!("target {fps:.0} fps"), (8, 4), (FAMILY, 13))
            }))
            .map_err(err)?;
    }
    chart
        .configure_series_labels()
        .label_font((FAMILY, 15))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .position(SeriesLabelPosition::UpperRight)
        .draw()
        .map_err(err)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vendored_font_parses() {
        assert!(register_font("gigawalk-test", FontStyle::Normal, FONT).is_ok());
    }

    #[test]
    fn plots_are_written_whole_or_not_at_all() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("p.png");
        let rgb: Vec<u8> = (0..2 * 3 * 3).map(|i| i as u8 * 10).collect();
        write_png(&file, (2, 3), &rgb).unwrap();
        let decoder = png::Decoder::new(std::fs::File::open(&file).unwrap());
        let mut reader = decoder.read_info().unwrap();
        let mut out = vec![0; reader.output_buffer_size()];
        let info = reader.next_frame(&mut out).unwrap();
        assert_eq!((info.width, info.height), (2, 3));
        assert_eq!(&out[..info.buffer_size()], &rgb[..]);
        // Nowhere to write: an error, and nothing left in the directory
        // (no partial image, no temporary file).
        let missing = dir.path().join("gone").join("p.png");
        assert!(write_png(&missing, (2, 3), &rgb).is_err());
        let names: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names, vec![std::ffi::OsString::from("p.png")]);
    }

    #[test]
    fn decade_ranges() {
        assert_eq!(decades(2.0, 35.0), (1.0, 100.0));
        assert_eq!(decades(0.5, 0.7), (0.1, 1.0));
        assert_eq!(decades(f64::INFINITY, 0.0), (0.1, 1.0));
    }
}
