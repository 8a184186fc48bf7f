//! A small CPU reference rasterizer for depth: the ground truth the culling
//! and pipeline tests compare against.
//!
//! Same conventions as the GPU pipeline: clip space from a camera-relative
//! view-projection (positions have the eye subtracted in f64 first),
//! reversed-Z (NDC depth 1 at the near plane, 0 at infinity, nearer is
//! larger), clipping to `0 <= z <= w` (only the near plane `z <= w` can
//! cut with an infinite far plane), a fragment wherever a pixel centre lies
//! inside a triangle, pixel `(x, y)` centred at NDC
//! `((x + 0.5) / w * 2 - 1, 1 - (y + 0.5) / h * 2)`, row 0 at the top.
//!
//! Differences from a GPU, on purpose: all math is f64, edges are inclusive
//! on both sides (no top-left rule, so a pixel centre on a shared edge gets
//! both triangles' fragments), there is no back-face culling, and
//! zero-area triangles make no fragments. The tests only need "the nearest
//! depth at each pixel", which these choices give exactly or conservatively.

use gigawalk_scene::Aabb;
use glam::{DMat4, DVec3, DVec4};

/// A reversed-Z depth image as the GPU reads it back: row-major f32,
/// row 0 = top, cleared to 0 (infinitely far).
#[derive(Clone, Debug, PartialEq)]
pub struct DepthImage {
    pub width: u32,
    pub height: u32,
    pub depth: Vec<f32>,
}

impl DepthImage {
    /// A `width x height` image cleared to 0.
    pub fn new(width: u32, height: u32) -> Self {
        DepthImage {
            width,
            height,
            depth: vec![0.0; width as usize * height as usize],
        }
    }

    pub fn get(&self, x: u32, y: u32) -> f32 {
        self.depth[(y * self.width + x) as usize]
    }

    /// Draws one clip-space triangle with depth test GreaterEqual (keeps the
    /// nearest depth per pixel).
    pub fn draw_triangle(&mut self, clip: [DVec4; 3]) {
        let (w, d) = (self.width, &mut self.depth);
        for_each_fragment(w, self.height, clip, |x, y, z| {
            let px = &mut d[(y * w + x) as usize];
            *px = px.max(z as f32);
        });
    }

    /// Draws the 12 triangles of a world-space box seen through a
    /// camera-relative view-projection from `eye`.
    pub fn draw_box(&mut self, view_proj_rel: &DMat4, eye: DVec3, b: &Aabb) {
        for tri in box_triangles(b) {
            self.draw_triangle(tri.map(|p| *view_proj_rel * (p - eye).extend(1.0)));
        }
    }
}

/// The 12 triangles (2 per face) of a box, in world space.
pub fn box_triangles(b: &Aabb) -> [[DVec3; 3]; 12] {
    let c = |i: usize| {
        DVec3::new(
            if i & 1 == 0 { b.min.x } else { b.max.x },
            if i & 2 == 0 { b.min.y } else { b.max.y },
            if i & 4 == 0 { b.min.z } else { b.max.z },
        )
    };
    // Faces as corner-index quads (bit 0 = x, bit 1 = y, bit 2 = z).
    const FACES: [[usize; 4]; 6] = [
        [0, 2, 6, 4],
        [1, 5, 7, 3],
        [0, 4, 5, 1],
        [2, 3, 7, 6],
        [0, 1, 3, 2],
        [4, 6, 7, 5],
    ];
    let mut out = [[DVec3::ZERO; 3]; 12];
    for (f, q) in FACES.iter().enumerate() {
        out[2 * f] = [c(q[0]), c(q[1]), c(q[2])];
        out[2 * f + 1] = [c(q[0]), c(q[2]), c(q[3])];
    }
    out
}

/// Every fragment of a world-space box: calls `f(x, y, depth)` per covered
/// pixel and triangle (a pixel may come more than once).
pub fn for_each_box_fragment(
    width: u32,
    height: u32,
    view_proj_rel: &DMat4,
    eye: DVec3,
    b: &Aabb,
    mut f: impl FnMut(u32, u32, f64),
) {
    for tri in box_triangles(b) {
        let clip = tri.map(|p| *view_proj_rel * (p - eye).extend(1.0));
        for_each_fragment(width, height, clip, &mut f);
    }
}

/// Rasterizes one clip-space triangle into a `width x height` viewport:
/// clips it to the near plane, then calls `f(x, y, depth)` for every pixel
/// whose centre it covers, with the reversed-Z NDC depth there.
pub fn for_each_fragment(
    width: u32,
    height: u32,
    clip: [DVec4; 3],
    mut f: impl FnMut(u32, u32, f64),
) {
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
        return;
    }
    let screen = |v: DVec4| {
        DVec3::new(
            (v.x / v.w * 0.5 + 0.5) * width as f64,
            (0.5 - v.y / v.w * 0.5) * height as f64,
            v.z / v.w,
        )
    };
    let s: Vec<DVec3> = poly[..n].iter().map(|&v| screen(v)).collect();
    for i in 1..n - 1 {
        raster_screen_triangle(width, height, [s[0], s[i], s[i + 1]], &mut f);
    }
}

/// Rasterizes a triangle already in pixel coordinates (x right, y down,
/// z = depth), sampling pixel centres, edges inclusive.
fn raster_screen_triangle(
    width: u32,
    height: u32,
    [a, b, c]: [DVec3; 3],
    f: &mut impl FnMut(u32, u32, f64),
) {
    let area = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
    if area == 0.0 || !area.is_finite() {
        return;
    }
    let lo = a.min(b).min(c);
    let hi = a.max(b).max(c);
    // Pixels whose centre x + 0.5 lies in [lo.x, hi.x].
    let x0 = (lo.x - 0.5).ceil().max(0.0);
    let x1 = (hi.x - 0.5).floor().min(width as f64 - 1.0);
    let y0 = (lo.y - 0.5).ceil().max(0.0);
    let y1 = (hi.y - 0.5).floor().min(height as f64 - 1.0);
    if x0 > x1 || y0 > y1 {
        return;
    }
    let edge =
        |p: DVec3, q: DVec3, x: f64, y: f64| (q.x - p.x) * (y - p.y) - (q.y - p.y) * (x - p.x);
    for y in y0 as u32..=y1 as u32 {
        let py = y as f64 + 0.5;
        for x in x0 as u32..=x1 as u32 {
            let px = x as f64 + 0.5;
            // Barycentric weights, signed by the triangle's winding.
            let wa = edge(b, c, px, py) / area;
            let wb = edge(c, a, px, py) / area;
            let wc = edge(a, b, px, py) / area;
            if wa >= 0.0 && wb >= 0.0 && wc >= 0.0 {
                f(x, y, wa * a.z + wb * b.z + wc * c.z);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 90 degree square reversed-Z infinite projection, near 1, looking down -Z.
    fn proj() -> DMat4 {
        DMat4::from_cols(
            DVec4::new(1.0, 0.0, 0.0, 0.0),
            DVec4::new(0.0, 1.0, 0.0, 0.0),
            DVec4::new(0.0, 0.0, 0.0, -1.0),
            DVec4::new(0.0, 0.0, 1.0, 0.0),
        )
    }

    #[test]
    fn wall_fills_image_with_its_depth() {
        let mut img = DepthImage::new(4, 3);
        let wall = Aabb::new(
            DVec3::new(-100.0, -100.0, -11.0),
            DVec3::new(100.0, 100.0, -10.0),
        );
        img.draw_box(&proj(), DVec3::ZERO, &wall);
        assert!(
            img.depth.iter().all(|&d| (d - 0.1).abs() < 1e-7),
            "{:?}",
            img.depth
        );
    }

    #[test]
    fn box_far_from_origin_matches_box_at_origin() {
        let b = Aabb::new(DVec3::new(-1.0, -0.5, -4.0), DVec3::new(0.5, 1.0, -3.0));
        let mut at_origin = DepthImage::new(17, 9);
        at_origin.draw_box(&proj(), DVec3::ZERO, &b);
        let t = DVec3::splat(1e7);
        let mut far = DepthImage::new(17, 9);
        far.draw_box(&proj(), t, &Aabb::new(b.min + t, b.max + t));
        assert_eq!(at_origin, far);
        assert!(at_origin.depth.iter().any(|&d| d > 0.0));
    }

    #[test]
    fn triangle_crossing_near_plane_is_clipped() {
        // From z = -0.5 (in front of the eye, before near) to z = -2.
        let mut img = DepthImage::new(8, 8);
        let tri = [
            DVec3::new(-1.0, -1.0, -0.5),
            DVec3::new(1.0, -1.0, -0.5),
            DVec3::new(0.0, 0.2, -2.0),
        ];
        img.draw_triangle(tri.map(|p| proj() * p.extend(1.0)));
        assert!(img.depth.iter().all(|&d| d <= 1.0));
        assert!(img.depth.iter().any(|&d| d > 0.5));
    }

    #[test]
    fn triangle_behind_eye_draws_nothing() {
        let mut img = DepthImage::new(8, 8);
        let tri = [
            DVec3::new(-1.0, -1.0, 2.0),
            DVec3::new(1.0, -1.0, 2.0),
            DVec3::new(0.0, 1.0, 2.0),
        ];
        img.draw_triangle(tri.map(|p| proj() * p.extend(1.0)));
        assert!(img.depth.iter().all(|&d| d == 0.0));
    }

    #[test]
    fn one_pixel_image_samples_its_centre() {
        let mut img = DepthImage::new(1, 1);
        let small = Aabb::new(DVec3::new(-0.1, -0.1, -5.0), DVec3::new(0.1, 0.1, -4.0));
        img.draw_box(&proj(), DVec3::ZERO, &small);
        assert!((img.get(0, 0) - 0.25).abs() < 1e-7);
        let mut miss = DepthImage::new(1, 1);
        let off = Aabb::new(DVec3::new(0.5, 0.5, -5.0), DVec3::new(1.0, 1.0, -4.0));
        miss.draw_box(&proj(), DVec3::ZERO, &off);
        assert_eq!(miss.get(0, 0), 0.0);
    }
}
