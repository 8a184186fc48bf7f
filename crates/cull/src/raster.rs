//! A software depth rasterizer for occlusion: what STC draws of the frame
//! it is traversing, so the lazy occlusion grid can occlude with it in the
//! same frame (Hey, Tobler and Purgathofer's "software z-buffer").
//!
//! Same conventions as the GPU pipeline (docs/culling.md): camera-relative
//! clip space in f64, reversed Z (nearer is larger, cleared to 0), near
//! clipping at `z <= w`, pixel `(x, y)` centred at NDC
//! `((x + 0.5) / w * 2 - 1, 1 - (y + 0.5) / h * 2)`, row 0 at the top, no
//! back-face culling (the visible pass culls none).
//!
//! Conservative for occlusion: it never writes a depth nearer than the
//! GPU's at a pixel. A pixel is covered only when its centre lies inside
//! the triangle by [`INNER_MARGIN_PX`] (the GPU covers every such pixel,
//! whatever its vertex snapping and tie rule), and the depth written is
//! the exact plane depth lowered by [`DEPTH_SLOPE_PX`] pixels of the
//! triangle's depth slope and a relative [`DEPTH_REL_SLACK`] (the GPU's
//! f32 vertex transform and interpolation).

use glam::{DMat4, DVec3, DVec4, Vec3};

/// How far inside a triangle (in pixels) a pixel centre must lie to be
/// covered.
pub const INNER_MARGIN_PX: f64 = 1.0 / 32.0;
/// Depth is lowered by the triangle's depth change over this many pixels.
pub const DEPTH_SLOPE_PX: f64 = 1.0 / 32.0;
/// ... and by this fraction of itself.
pub const DEPTH_REL_SLACK: f64 = 1.0 / (1u64 << 18) as f64;

/// An inclusive pixel rectangle `[x0, x1] x [y0, y1]`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PixelRect {
    pub x0: u32,
    pub y0: u32,
    pub x1: u32,
    pub y1: u32,
}

impl PixelRect {
    fn union(a: Option<PixelRect>, b: PixelRect) -> PixelRect {
        match a {
            None => b,
            Some(a) => PixelRect {
                x0: a.x0.min(b.x0),
                y0: a.y0.min(b.y0),
                x1: a.x1.max(b.x1),
                y1: a.y1.max(b.y1),
            },
        }
    }
}

/// A reversed-Z depth image the CPU draws into.
#[derive(Clone, Debug, Default)]
pub struct SoftDepth {
    width: u32,
    height: u32,
    depth: Vec<f32>,
    /// Clip-space vertices of the mesh being drawn (kept between calls).
    clip: Vec<DVec4>,
    /// Only pixels in `[x, y, w, h]` are written (a tile), when set.
    scissor: Option<[u32; 4]>,
    /// Written depth is lowered by this much too: the GPU's absolute
    /// depth error ([`SoftDepth::set_absolute_slack`]).
    abs_slack: f64,
}

impl SoftDepth {
    pub fn new() -> Self {
        SoftDepth::default()
    }

    /// Clears to `width x height`, all infinitely far (0).
    pub fn reset(&mut self, width: u32, height: u32) {
        self.width = width;
        self.height = height;
        self.depth.clear();
        self.depth.resize(width as usize * height as usize, 0.0);
        self.scissor = None;
    }

    /// Lowers every depth written by `slack` (absolute), for a GPU whose
    /// stored depth may lie that far from the exact one (wgpu's GL
    /// backend), so the software depth stays never nearer than it. Kept
    /// across [`SoftDepth::reset`].
    pub fn set_absolute_slack(&mut self, slack: f64) {
        self.abs_slack = slack.max(0.0);
    }

    /// Later draws write only pixels in `[x, y, w, h]` (`None`: anywhere),
    /// as a GPU scissor rectangle does.
    pub fn set_scissor(&mut self, rect: Option<[u32; 4]>) {
        self.scissor = rect;
    }

    pub fn width(&self) -> u32 {
        self.width
    }

    pub fn height(&self) -> u32 {
        self.height
    }

    /// Row-major, row 0 = top.
    pub fn depth(&self) -> &[f32] {
        &self.depth
    }

    pub fn get(&self, x: u32, y: u32) -> f32 {
        self.depth[y as usize * self.width as usize + x as usize]
    }

    /// Draws an indexed triangle mesh whose positions are f32 offsets from
    /// `rel_origin` (its origin minus the eye, in f64), seen through the
    /// camera-relative `view_proj`. Returns the rectangle of pixels it
    /// wrote, if any. Indices out of range are skipped.
    ///
    /// The vertices are placed as the GPU places them: the offset rounded
    /// to f32 and added to each f32 position in f32 (the shaders'
    /// `position + offset`), so a mesh far from the eye lands where the
    /// GPU draws it, not where exact arithmetic would.
    pub fn draw_mesh(
        &mut self,
        view_proj: &DMat4,
        rel_origin: DVec3,
        positions: &[[f32; 3]],
        indices: &[u32],
    ) -> Option<PixelRect> {
        let offset = rel_origin.as_vec3();
        let mut clip = std::mem::take(&mut self.clip);
        clip.clear();
        clip.extend(
            positions
                .iter()
                .map(|p| *view_proj * (Vec3::from(*p) + offset).as_dvec3().extend(1.0)),
        );
        let mut rect = None;
        for t in indices.chunks_exact(3) {
            let (Some(&a), Some(&b), Some(&c)) = (
                clip.get(t[0] as usize),
                clip.get(t[1] as usize),
                clip.get(t[2] as usize),
            ) else {
                continue;
            };
            if let Some(r) = self.draw_clip_triangle([a, b, c]) {
                rect = Some(PixelRect::union(rect, r));
            }
        }
        self.clip = clip;
        rect
    }

    /// Draws one clip-space triangle: near-clipped, then rasterized.
    pub fn draw_clip_triangle(&mut self, clip: [DVec4; 3]) -> Option<PixelRect> {
        // Wholly beside the view: nothing to draw (w > 0 is implied by
        // these for points in front; behind-the-eye points fail z <= w).
        let out = |f: &dyn Fn(DVec4) -> bool| clip.iter().all(|&v| f(v));
        if out(&|v| v.x > v.w)
            || out(&|v| v.x < -v.w)
            || out(&|v| v.y > v.w)
            || out(&|v| v.y < -v.w)
        {
            return None;
        }
        // Sutherland-Hodgman against z <= w: at most 4 vertices.
        let mut poly = [DVec4::ZERO; 4];
        let mut n = 0;
        for i in 0..3 {
            let (a, b) = (clip[i], clip[(i + 1) % 3]);
            let (da, db) = (a.w - a.z, b.w - b.z);
            if da >= 0.0 {
                poly[n] = a;
                n += 1;
            }
            if (da >= 0.0) != (db >= 0.0) {
                poly[n] = a + (b - a) * (da / (da - db));
                n += 1;
            }
        }
        if n < 3 {
            return None;
        }
        let (wf, hf) = (self.width as f64, self.height as f64);
        let screen = |v: DVec4| {
            DVec3::new(
                (v.x / v.w * 0.5 + 0.5) * wf,
                (0.5 - v.y / v.w * 0.5) * hf,
                v.z / v.w,
            )
        };
        let s = poly.map(screen);
        let mut rect = None;
        for i in 1..n - 1 {
            if let Some(r) = self.draw_screen_triangle([s[0], s[i], s[i + 1]]) {
                rect = Some(PixelRect::union(rect, r));
            }
        }
        rect
    }

    /// Rasterizes a triangle in pixel coordinates (x right, y down, z =
    /// depth) with the inner margin and conservative depth of the module
    /// docs; keeps the nearest (largest) depth per pixel.
    fn draw_screen_triangle(&mut self, [a, b, c]: [DVec3; 3]) -> Option<PixelRect> {
        let area = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
        if !(area.abs() > 0.0 && area.is_finite()) {
            return None;
        }
        let sign = area.signum();
        // Edge p->q as A x + B y + C, positive inside, offset inward by
        // the margin (in pixels: the edge function over its gradient).
        let edge = |p: DVec3, q: DVec3| {
            let a = -(q.y - p.y) * sign;
            let b = (q.x - p.x) * sign;
            let c = -(a * p.x + b * p.y) - INNER_MARGIN_PX * a.hypot(b);
            (a, b, c)
        };
        let edges = [edge(b, c), edge(c, a), edge(a, b)];
        // Depth plane z = a.z + dzdx (x - a.x) + dzdy (y - a.y).
        let dzdx = ((b.z - a.z) * (c.y - a.y) - (c.z - a.z) * (b.y - a.y)) / area;
        let dzdy = ((c.z - a.z) * (b.x - a.x) - (b.z - a.z) * (c.x - a.x)) / area;
        let slope_slack = (dzdx.abs() + dzdy.abs()) * DEPTH_SLOPE_PX;
        let zmax = a.z.max(b.z).max(c.z);
        let lo = a.min(b).min(c);
        let hi = a.max(b).max(c);
        let (wf, hf) = (self.width as f64, self.height as f64);
        // Pixel centres x + 0.5 within [lo.x, hi.x], inside the image.
        let [sx, sy, sw, sh] = self.scissor.unwrap_or([0, 0, self.width, self.height]);
        let (sx, sy) = (sx as f64, sy as f64);
        let y0 = (lo.y - 0.5).ceil().max(sy);
        let y1 = (hi.y - 0.5).floor().min(hf - 1.0).min(sy + sh as f64 - 1.0);
        let bx0 = (lo.x - 0.5).ceil().max(sx);
        let bx1 = (hi.x - 0.5).floor().min(wf - 1.0).min(sx + sw as f64 - 1.0);
        if !(y0 <= y1 && bx0 <= bx1) {
            return None;
        }
        let mut rect: Option<PixelRect> = None;
        let w = self.width as usize;
        for y in y0 as u32..=y1 as u32 {
            let py = y as f64 + 0.5;
            // The span of centres inside all three edges on this row.
            let (mut xl, mut xr) = (bx0 + 0.5, bx1 + 0.5);
            for &(ea, eb, ec) in &edges {
                let r = -(eb * py + ec);
                let x = r / ea;
                if x.is_nan() && ea != 0.0 {
                    // Cannot happen for a finite, non-degenerate triangle;
                    // drawing nothing is the safe answer.
                    xl = f64::INFINITY;
                } else if ea > 0.0 {
                    xl = xl.max(x);
                } else if ea < 0.0 {
                    xr = xr.min(x);
                } else if r > 0.0 {
                    xl = f64::INFINITY;
                }
            }
            let x0 = (xl - 0.5).ceil().max(bx0);
            let x1 = (xr - 0.5).floor().min(bx1);
            if x0.is_nan() || x1.is_nan() || x0 > x1 {
                continue;
            }
            let (x0, x1) = (x0 as u32, x1 as u32);
            let row = &mut self.depth[y as usize * w..(y as usize + 1) * w];
            let z_row = a.z + dzdy * (py - a.y);
            for x in x0..=x1 {
                let z = (z_row + dzdx * (x as f64 + 0.5 - a.x)).min(zmax);
                let z = (z - slope_slack - z.abs() * DEPTH_REL_SLACK - self.abs_slack) as f32;
                let d = &mut row[x as usize];
                if z > *d {
                    *d = z;
                }
            }
            rect = Some(PixelRect::union(
                rect,
                PixelRect {
                    x0,
                    y0: y,
                    x1,
                    y1: y,
                },
            ));
        }
        rect
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 90 degree square reversed-Z infinite projection, near 1, looking
    /// down -Z.
    fn proj() -> DMat4 {
        DMat4::from_cols(
            DVec4::new(1.0, 0.0, 0.0, 0.0),
            DVec4::new(0.0, 1.0, 0.0, 0.0),
            DVec4::new(0.0, 0.0, 0.0, -1.0),
            DVec4::new(0.0, 0.0, 1.0, 0.0),
        )
    }

    fn quad(z: f32, half: f32) -> (Vec<[f32; 3]>, Vec<u32>) {
        (
            vec![
                [-half, -half, z],
                [half, -half, z],
                [half, half, z],
                [-half, half, z],
            ],
            vec![0, 1, 2, 0, 2, 3],
        )
    }

    #[test]
    fn a_wall_fills_the_image_just_behind_its_depth() {
        let mut d = SoftDepth::new();
        d.reset(8, 6);
        let (p, i) = quad(-4.0, 100.0);
        let r = d.draw_mesh(&proj(), DVec3::ZERO, &p, &i).unwrap();
        assert_eq!(
            r,
            PixelRect {
                x0: 0,
                y0: 0,
                x1: 7,
                y1: 5
            }
        );
        for &z in d.depth() {
            assert!(z <= 0.25 && z > 0.25 * (1.0 - 1e-5), "{z}");
        }
    }

    #[test]
    fn a_pixel_centre_on_an_edge_is_not_covered() {
        let mut d = SoftDepth::new();
        d.reset(4, 4);
        // The right half of the image exactly: its left edge runs through
        // no centre, but a 2-pixel quad whose edge passes within the
        // margin of centres covers only the inner ones.
        let p = vec![
            [0.0, -1.0, -1.0],
            [1.0, -1.0, -1.0],
            [1.0, 1.0, -1.0],
            [0.0, 1.0, -1.0],
        ];
        d.draw_mesh(&proj(), DVec3::ZERO, &p, &[0, 1, 2, 0, 2, 3]);
        for y in 0..4 {
            assert_eq!(d.get(1, y), 0.0);
            assert!(d.get(2, y) > 0.0 && d.get(3, y) > 0.0);
        }
        // Edge through the centres of column 1 (x = 1.5 px = NDC -0.25).
        d.reset(4, 4);
        let p = vec![
            [-0.25, -1.0, -1.0],
            [1.0, -1.0, -1.0],
            [1.0, 1.0, -1.0],
            [-0.25, 1.0, -1.0],
        ];
        d.draw_mesh(&proj(), DVec3::ZERO, &p, &[0, 1, 2, 0, 2, 3]);
        assert!((0..4).all(|y| d.get(1, y) == 0.0 && d.get(2, y) > 0.0));
    }

    #[test]
    fn near_plane_crossing_and_behind_the_eye_are_clipped() {
        let mut d = SoftDepth::new();
        d.reset(16, 16);
        // A floor from behind the eye to far ahead.
        let p = vec![
            [-50.0, -1.0, 10.0],
            [50.0, -1.0, 10.0],
            [50.0, -1.0, -100.0],
            [-50.0, -1.0, -100.0],
        ];
        d.draw_mesh(&proj(), DVec3::ZERO, &p, &[0, 1, 2, 0, 2, 3]);
        // Bottom half covered, never nearer than the near plane (1).
        assert!(d.get(8, 15) > 0.0 && d.get(8, 15) < 1.0);
        assert_eq!(d.get(8, 2), 0.0);
        assert!(d.depth().iter().all(|z| z.is_finite() && *z <= 1.0));
        // Wholly behind the eye: nothing.
        d.reset(16, 16);
        let (p, i) = quad(5.0, 1.0);
        assert_eq!(d.draw_mesh(&proj(), DVec3::ZERO, &p, &i), None);
    }

    #[test]
    fn degenerate_and_bad_input_draw_nothing() {
        let mut d = SoftDepth::new();
        d.reset(8, 8);
        let p = vec![
            [0.0, 0.0, -1.0],
            [0.0, 0.0, -1.0],
            [1.0, 1.0, -1.0],
            [f32::NAN, 0.0, -1.0],
        ];
        assert_eq!(
            d.draw_mesh(&proj(), DVec3::ZERO, &p, &[0, 1, 2, 0, 3, 2, 0, 9, 1]),
            None
        );
        d.reset(0, 0);
        let (p, i) = quad(-4.0, 100.0);
        assert_eq!(d.draw_mesh(&proj(), DVec3::ZERO, &p, &i), None);
    }
}
