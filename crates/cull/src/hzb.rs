//! The hierarchical Z-buffer (HZB): a pyramid of farthest depths built from
//! the occluder pass's depth readback (GigaWalk Section 5.1.2, after Greene
//! et al. 1993), with the approximate variants of Section 5.3.
//!
//! Depth convention: reversed Z. The input is the GPU depth readback,
//! row-major f32, row 0 = top of the image, 1 at the near plane and 0 at
//! infinity (the clear value). *Farther is smaller*, so each HZB cell stores
//! the minimum of the texels it covers.
//!
//! Level 0 is the image itself; level k+1 has `ceil(w/2) x ceil(h/2)` cells of
//! level k. Cell `(x, y)` of level k covers exactly the base pixels
//! `[x 2^k, (x+1) 2^k) x [y 2^k, (y+1) 2^k)` clipped to the image, for any
//! size (odd and non-power-of-two included): a border cell of an odd-sized
//! level covers its one or two real children only.
//!
//! The pyramid is built here from the whole image ([`Hzb::rebuild`]), or
//! from one of its levels that OR's device built and read back
//! ([`Hzb::rebuild_from_level`]): then the finer levels are absent and
//! tests read no finer than that level.

use rayon::prelude::*;

/// Texels of the level OR reads back by default: the finest level with at
/// most this many (2^17: 0.5 MiB of f32 depth; level 3 at 3840x2160, 2
/// at 1920x1080, 1 at 640x360). What each level costs and culls is in
/// docs/results.md, "Frame cost on the CPU (null GPU)". OR reads it back;
/// the browser's page reads the same level.
pub const HZB_READ_TEXELS: u64 = 1 << 17;

/// The finest level of a `w x h` depth image's pyramid with at most
/// [`HZB_READ_TEXELS`] texels.
pub fn auto_hzb_level(w: u32, h: u32) -> u32 {
    let (mut w, mut h, mut k) = (w as u64, h as u64, 0);
    while w * h > HZB_READ_TEXELS {
        (w, h, k) = (w.div_ceil(2), h.div_ceil(2), k + 1);
    }
    k
}

/// How a 2x2 block of full-resolution texels becomes one level-1 cell.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Reduction {
    /// The farthest (minimum) depth: conservative.
    #[default]
    Farthest,
    /// The n-th farthest of the 4 texels, n in 1..=4 (1 = `Farthest`):
    /// approximate, "aggressive" culling that ignores holes of up to n-1
    /// pixels per 2x2 block (GigaWalk Section 5.3, after Greene 2001). Only
    /// the level 0 -> 1 step uses it; level 0 itself stays exact and higher
    /// levels take the farthest of level 1. Border cells of odd-sized images
    /// repeat their edge texels, which makes them a little more conservative.
    NthFarthest(u8),
}

/// Why an HZB could not be built.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
#[non_exhaustive]
pub enum HzbError {
    #[error("depth image is empty ({width}x{height})")]
    Empty { width: u32, height: u32 },
    #[error("depth image of {width}x{height} needs {expected} values, got {got}")]
    SizeMismatch {
        width: u32,
        height: u32,
        expected: usize,
        got: usize,
    },
    #[error("n-th farthest reduction needs n in 1..=4, got {0}")]
    BadN(u8),
    #[error("HZB level {level} of a {width}x{height} image: the pyramid has levels 0 to {top}")]
    NoLevel {
        level: u32,
        width: u32,
        height: u32,
        top: u32,
    },
}

/// One level of the pyramid.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct HzbLevel {
    pub width: u32,
    pub height: u32,
    /// Row-major, row 0 = top; empty for a level finer than the pyramid's
    /// [`Hzb::base`].
    pub data: Vec<f32>,
    /// Each cell's nearest (largest) value of the base level's cells it
    /// covers, for levels above the base (empty at and below it, where
    /// `data` is that value): a cell whose nearest does not hide a box
    /// shows it wherever the cell meets its footprint, so the test stops
    /// there instead of refining.
    pub near: Vec<f32>,
}

/// The sizes of a `width x height` image's pyramid levels, finest first:
/// halved (rounding up) until 1x1.
pub fn level_sizes(width: u32, height: u32) -> Vec<(u32, u32)> {
    let mut sizes = vec![(width, height)];
    while let Some(&(w, h)) = sizes.last() {
        if w <= 1 && h <= 1 {
            break;
        }
        sizes.push((w.div_ceil(2), h.div_ceil(2)));
    }
    sizes
}

/// A hierarchical Z-buffer; see the module docs for the depth convention.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Hzb {
    levels: Vec<HzbLevel>,
    /// The finest level that stores what the reduction promises: the
    /// base for `Farthest`, 1 for an approximate `NthFarthest` (level 0
    /// is exact).
    finest: usize,
    /// The finest level held: 0 when built from the whole image.
    base: usize,
}

/// Rows per rayon task: small enough to split 1080 rows over a few cores,
/// large enough that task overhead stays well under the per-row work.
const ROWS_PER_TASK: usize = 8;

/// Levels with fewer texels than this are reduced on the calling thread:
/// handing them to rayon's pool costs more than the reduction (a 320x180
/// level takes some 20 us; a wake-up of the pool is of that order).
const PARALLEL_TEXELS: usize = 1 << 16;

impl Hzb {
    /// An empty HZB, to be filled by [`Hzb::rebuild`].
    pub fn new() -> Self {
        Hzb::default()
    }

    /// Builds the pyramid of a `width x height` depth image.
    pub fn build(
        width: u32,
        height: u32,
        depth: &[f32],
        reduction: Reduction,
    ) -> Result<Self, HzbError> {
        let mut hzb = Hzb::new();
        hzb.rebuild(width, height, depth, reduction)?;
        Ok(hzb)
    }

    /// Rebuilds in place, reusing the allocations of the previous frame.
    /// Parallel across rows on rayon's pool.
    pub fn rebuild(
        &mut self,
        width: u32,
        height: u32,
        depth: &[f32],
        reduction: Reduction,
    ) -> Result<(), HzbError> {
        if width == 0 || height == 0 {
            return Err(HzbError::Empty { width, height });
        }
        let expected = width as usize * height as usize;
        if depth.len() != expected {
            return Err(HzbError::SizeMismatch {
                width,
                height,
                expected,
                got: depth.len(),
            });
        }
        if let Reduction::NthFarthest(n) = reduction {
            if !(1..=4).contains(&n) {
                return Err(HzbError::BadN(n));
            }
        }
        let sizes = self.size_levels(width, height, 0);
        self.finest = match reduction {
            Reduction::NthFarthest(n) if n > 1 => 1.min(sizes.len() - 1),
            _ => 0,
        };
        if self.levels.len() == 1 {
            self.levels[0].data.copy_from_slice(depth);
            return Ok(());
        }
        // Level 0 (a copy) and level 1 in one pass over the input, so the
        // 8 MB of a 1080p image are read once.
        let (l0, rest) = self.levels.split_at_mut(1);
        let l0 = &mut l0[0];
        let l1 = &mut rest[0];
        let w = width as usize;
        let w1 = l1.width as usize;
        l1.data
            .par_chunks_mut(w1)
            .zip(l1.near.par_chunks_mut(w1))
            .zip(l0.data.par_chunks_mut(2 * w))
            .zip(depth.par_chunks(2 * w))
            .with_min_len(ROWS_PER_TASK)
            .for_each(|(((out, near), copy), src)| {
                copy.copy_from_slice(src);
                let (r0, r1) = row_pair(src, w);
                match reduction {
                    Reduction::Farthest => reduce_row(r0, r1, out),
                    Reduction::NthFarthest(n) => reduce_row_nth(r0, r1, out, n as usize),
                }
                reduce_row_near(r0, r1, near);
            });
        self.reduce_from(1);
        Ok(())
    }

    /// Rebuilds from level `level` of the pyramid of a `width x height`
    /// depth image, made elsewhere (OR's device) with the farthest
    /// reduction: `data` holds that level's `ceil(width / 2^level) x
    /// ceil(height / 2^level)` cells, each the farthest depth of the
    /// pixels it covers. The coarser levels are reduced here; the finer
    /// ones stay empty, so a test reads no finer than `level` and a cell
    /// there that does not hide keeps the box: conservative, only coarser
    /// than the whole pyramid.
    pub fn rebuild_from_level(
        &mut self,
        width: u32,
        height: u32,
        level: u32,
        data: &[f32],
    ) -> Result<(), HzbError> {
        if width == 0 || height == 0 {
            return Err(HzbError::Empty { width, height });
        }
        let sizes = level_sizes(width, height);
        let Some(&(lw, lh)) = sizes.get(level as usize) else {
            return Err(HzbError::NoLevel {
                level,
                width,
                height,
                top: sizes.len() as u32 - 1,
            });
        };
        let expected = lw as usize * lh as usize;
        if data.len() != expected {
            return Err(HzbError::SizeMismatch {
                width: lw,
                height: lh,
                expected,
                got: data.len(),
            });
        }
        let base = level as usize;
        self.size_levels(width, height, base);
        self.finest = base;
        self.levels[base].data.copy_from_slice(data);
        self.reduce_from(base);
        Ok(())
    }

    /// Rebuilds from a device's read-back of its depth pyramid: `level`
    /// 0 (the depth image itself, reduced here by `reduction`) or a
    /// coarser level ([`Hzb::rebuild_from_level`]) of a `width x height`
    /// image. Every texel is first lowered by `depth_error`, the most the
    /// device's depth may lie off the exact surface (0 for float depth),
    /// so the HZB is never nearer than the surface; `scratch` holds the
    /// lowered copy, kept between frames. Lowering every texel lowers the
    /// farthest of any block by as much: the same whether the device
    /// reduced first or not.
    #[allow(clippy::too_many_arguments)]
    pub fn rebuild_from_device(
        &mut self,
        width: u32,
        height: u32,
        level: u32,
        depth: &[f32],
        depth_error: f32,
        reduction: Reduction,
        scratch: &mut Vec<f32>,
    ) -> Result<(), HzbError> {
        let depth = if depth_error > 0.0 {
            scratch.clear();
            scratch.extend(depth.iter().map(|&z| (z - depth_error).max(0.0)));
            scratch.as_slice()
        } else {
            depth
        };
        match level {
            0 => self.rebuild(width, height, depth, reduction),
            k => self.rebuild_from_level(width, height, k, depth),
        }
    }

    /// Sizes the levels of a `width x height` image's pyramid held from
    /// level `base` on (the finer ones empty), reusing allocations;
    /// returns the sizes.
    fn size_levels(&mut self, width: u32, height: u32, base: usize) -> Vec<(u32, u32)> {
        let sizes = level_sizes(width, height);
        self.levels.resize_with(sizes.len(), HzbLevel::default);
        self.base = base;
        for (k, (level, &(w, h))) in self.levels.iter_mut().zip(&sizes).enumerate() {
            level.width = w;
            level.height = h;
            let len = if k < base { 0 } else { w as usize * h as usize };
            level.data.resize(len, 0.0);
            level.near.resize(if k > base { len } else { 0 }, 0.0);
        }
        sizes
    }

    /// Each level above `k` from the one below it: farthest of 2x2, and
    /// the nearest of the base level below (`near`); levels of fewer than
    /// [`PARALLEL_TEXELS`] on this thread.
    fn reduce_from(&mut self, k: usize) {
        let base = self.base;
        for k in k..self.levels.len() - 1 {
            let (lo, hi) = self.levels.split_at_mut(k + 1);
            let src = &lo[k];
            let dst = &mut hi[0];
            let sw = src.width as usize;
            let dw = dst.width as usize;
            let near_src = if k == base { &src.data } else { &src.near };
            let rows = |((out, near), (src, nsrc)): RowPair| {
                let (r0, r1) = row_pair(src, sw);
                reduce_row(r0, r1, out);
                let (n0, n1) = row_pair(nsrc, sw);
                reduce_row_near(n0, n1, near);
            };
            if dst.data.len() < PARALLEL_TEXELS {
                dst.data
                    .chunks_mut(dw)
                    .zip(dst.near.chunks_mut(dw))
                    .zip(src.data.chunks(2 * sw).zip(near_src.chunks(2 * sw)))
                    .for_each(rows);
            } else {
                dst.data
                    .par_chunks_mut(dw)
                    .zip(dst.near.par_chunks_mut(dw))
                    .zip(src.data.par_chunks(2 * sw).zip(near_src.par_chunks(2 * sw)))
                    .with_min_len(ROWS_PER_TASK)
                    .for_each(rows);
            }
        }
    }

    /// The nearest base-level value under cell (cx, cy) of level `k`
    /// (`k` at least the base).
    #[inline]
    fn nearest(&self, k: usize, cx: u32, cy: u32) -> f32 {
        let level = &self.levels[k];
        let i = cy as usize * level.width as usize + cx as usize;
        if k == self.base {
            level.data[i]
        } else {
            level.near[i]
        }
    }

    /// The finest level held: 0 when built from the whole image, else the
    /// level [`Hzb::rebuild_from_level`] was given.
    pub fn base(&self) -> usize {
        self.base
    }

    /// Width of level 0 (the depth image) in pixels; 0 before the first build.
    pub fn width(&self) -> u32 {
        self.levels.first().map_or(0, |l| l.width)
    }

    /// Height of level 0 (the depth image) in pixels; 0 before the first build.
    pub fn height(&self) -> u32 {
        self.levels.first().map_or(0, |l| l.height)
    }

    pub fn levels(&self) -> &[HzbLevel] {
        &self.levels
    }

    /// The farthest stored depth over the level-0 pixel rectangle
    /// `[x0, x1] x [y0, y1]` (inclusive, `x0 <= x1 < width`,
    /// `y0 <= y1 < height`), read from the finest level where the rectangle
    /// spans at most 2x2 cells. Those cells cover every pixel of the
    /// rectangle, so the answer is never nearer than any of them.
    pub fn farthest_in_rect(&self, x0: u32, y0: u32, x1: u32, y1: u32) -> f32 {
        debug_assert!(x0 <= x1 && x1 < self.width() && y0 <= y1 && y1 < self.height());
        let k = self.cover_level(x0, y0, x1, y1);
        let level = &self.levels[k];
        let lw = level.width as usize;
        let (cx0, cx1) = ((x0 >> k) as usize, (x1 >> k) as usize);
        let (cy0, cy1) = ((y0 >> k) as usize, (y1 >> k) as usize);
        let d = &level.data;
        let a = farther(d[cy0 * lw + cx0], d[cy0 * lw + cx1]);
        let b = farther(d[cy1 * lw + cx0], d[cy1 * lw + cx1]);
        farther(a, b)
    }

    /// Whether every pixel of the level-0 rectangle `[x0, x1] x [y0, y1]`
    /// (inclusive, as [`Hzb::farthest_in_rect`]) satisfies `hides` on its
    /// stored depth, where `hides(d)` must hold for every depth nearer than
    /// a `d` it holds for (reversed Z: every larger value).
    ///
    /// Starts from the 2x2 cells of [`Hzb::farthest_in_rect`] and refines
    /// only the cells that do not hide as a whole, down to single pixels
    /// (to level 1 for an `NthFarthest` pyramid, whose level 0 would undo
    /// the approximation): where a box's footprint covers a cell only in
    /// part, the pixels outside the footprint no longer decide. After
    /// `max_cells` cells it stops and answers `false` (not hidden), so the
    /// answer is conservative at any budget and exact (the same as testing
    /// every pixel) when the budget suffices.
    pub fn rect_hides(
        &self,
        x0: u32,
        y0: u32,
        x1: u32,
        y1: u32,
        max_cells: usize,
        hides: impl Fn(f32) -> bool,
    ) -> bool {
        debug_assert!(x0 <= x1 && x1 < self.width() && y0 <= y1 && y1 < self.height());
        let q = RectQuery {
            hzb: self,
            rect: [x0, y0, x1, y1],
            hides,
        };
        let top = self.cover_level(x0, y0, x1, y1);
        let mut budget = max_cells;
        q.cells_hide(
            top,
            [x0 >> top, y0 >> top, x1 >> top, y1 >> top],
            &mut budget,
        )
    }

    /// Whether no pixel of the level-0 rectangle `[x0, x1] x [y0, y1]`
    /// (inclusive, as [`Hzb::farthest_in_rect`]) satisfies `hides` (as in
    /// [`Hzb::rect_hides`]), judged from the nearest base-level value under
    /// each of the at most 2x2 cells that cover it: a quick `true` for a
    /// box in front of everything around it, `false` when unsure. Cells
    /// of the base level meeting the rectangle are read whole, so this is
    /// exact at the base's resolution: what the pyramid can tell.
    pub fn rect_shows(
        &self,
        x0: u32,
        y0: u32,
        x1: u32,
        y1: u32,
        hides: impl Fn(f32) -> bool,
    ) -> bool {
        debug_assert!(x0 <= x1 && x1 < self.width() && y0 <= y1 && y1 < self.height());
        let k = self.cover_level(x0, y0, x1, y1);
        (y0 >> k..=y1 >> k).all(|cy| (x0 >> k..=x1 >> k).all(|cx| !hides(self.nearest(k, cx, cy))))
    }

    /// The finest level where the rectangle spans at most 2x2 cells.
    fn cover_level(&self, x0: u32, y0: u32, x1: u32, y1: u32) -> usize {
        // 2^k >= span guarantees at most 2 cells per axis; one level finer
        // may also do, and is tighter.
        let span = (x1 - x0).max(y1 - y0) + 1;
        let mut k = (u32::BITS - (span - 1).leading_zeros()).saturating_sub(1);
        if (x1 >> k) - (x0 >> k) > 1 || (y1 >> k) - (y0 >> k) > 1 {
            k += 1;
        }
        (k as usize).clamp(self.base, self.levels.len() - 1)
    }
}

/// One [`Hzb::rect_hides`] query: the rectangle and the predicate.
struct RectQuery<'a, F> {
    hzb: &'a Hzb,
    /// `[x0, y0, x1, y1]`, inclusive level-0 pixels.
    rect: [u32; 4],
    hides: F,
}

impl<F: Fn(f32) -> bool> RectQuery<'_, F> {
    /// Whether every rectangle pixel under the level-`k` cells
    /// `[cx0, cy0, cx1, cy1]` (inclusive) hides. All the cells are read
    /// before any is refined, so a cell that settles the answer on its own
    /// ends the query before deeper work on its siblings.
    fn cells_hide(&self, k: usize, [cx0, cy0, cx1, cy1]: [u32; 4], budget: &mut usize) -> bool {
        let level = &self.hzb.levels[k];
        let lw = level.width as usize;
        // At most 2x2 cells; those that do not hide and need refining.
        let mut refine = [(0u32, 0u32); 4];
        let mut n = 0;
        for cy in cy0..=cy1 {
            for cx in cx0..=cx1 {
                if *budget == 0 {
                    return false;
                }
                *budget -= 1;
                if (self.hides)(level.data[cy as usize * lw + cx as usize]) {
                    continue;
                }
                // A cell at the finest trusted level, or covering only
                // rectangle pixels, stores the depth of some rectangle
                // pixel (some finest-level cell of it): visible. So is one
                // whose nearest base cell does not hide: every base cell
                // under it that meets the rectangle (one does) would be
                // found visible by the refinement.
                if k <= self.hzb.finest
                    || self.inside(k, cx, cy)
                    || !(self.hides)(self.hzb.nearest(k, cx, cy))
                {
                    return false;
                }
                refine[n] = (cx, cy);
                n += 1;
            }
        }
        if n == 0 {
            return true;
        }
        // Only cells above the finest level are refined, so k >= 1 here.
        let [x0, y0, x1, y1] = self.rect;
        let j = k - 1;
        refine[..n].iter().all(|&(cx, cy)| {
            // The children of (cx, cy) at level j that meet the rectangle.
            let children = [
                (2 * cx).max(x0 >> j),
                (2 * cy).max(y0 >> j),
                (2 * cx + 1).min(x1 >> j),
                (2 * cy + 1).min(y1 >> j),
            ];
            self.cells_hide(j, children, budget)
        })
    }

    /// Whether cell (cx, cy) of level k covers only rectangle pixels.
    fn inside(&self, k: usize, cx: u32, cy: u32) -> bool {
        let [x0, y0, x1, y1] = self.rect;
        let (w, h) = (self.hzb.width(), self.hzb.height());
        let (px0, py0) = (cx << k, cy << k);
        let px1 = (((cx + 1) << k) - 1).min(w - 1);
        let py1 = (((cy + 1) << k) - 1).min(h - 1);
        px0 >= x0 && px1 <= x1 && py0 >= y0 && py1 <= y1
    }
}

/// Reversed Z: the farther of two depths is the smaller. Written as a plain
/// comparison so it compiles to a packed min.
#[inline(always)]
fn farther(a: f32, b: f32) -> f32 {
    if a < b {
        a
    } else {
        b
    }
}

/// One output row from two input rows (equal when the input has an odd last
/// row): each cell the farthest of its 2x2 block, the last cell of an odd
/// width covering one column.
#[inline]
fn reduce_row(r0: &[f32], r1: &[f32], out: &mut [f32]) {
    reduce_row_with(r0, r1, out, farther)
}

/// [`reduce_row`] keeping the nearer (larger) of each block.
#[inline]
fn reduce_row_near(r0: &[f32], r1: &[f32], out: &mut [f32]) {
    reduce_row_with(r0, r1, out, nearer)
}

/// [`reduce_row`] with `pick` choosing one of two depths.
#[inline(always)]
fn reduce_row_with(r0: &[f32], r1: &[f32], out: &mut [f32], pick: impl Fn(f32, f32) -> f32) {
    let pairs = r0.len() / 2;
    for ((o, a), b) in out[..pairs]
        .iter_mut()
        .zip(r0.chunks_exact(2))
        .zip(r1.chunks_exact(2))
    {
        *o = pick(pick(a[0], b[0]), pick(a[1], b[1]));
    }
    if r0.len() % 2 == 1 {
        let last = r0.len() - 1;
        out[pairs] = pick(r0[last], r1[last]);
    }
}

/// Output rows of farthest and nearest values, with the input rows
/// (farthest and nearest sources) they reduce.
type RowPair<'a> = ((&'a mut [f32], &'a mut [f32]), (&'a [f32], &'a [f32]));

/// The two input rows of one output row from the chunk of (up to) two rows
/// `src` of width `w`: the same row twice for the last row of an odd
/// height.
#[inline]
fn row_pair(src: &[f32], w: usize) -> (&[f32], &[f32]) {
    let (r0, r1) = src.split_at(w.min(src.len()));
    (r0, if r1.is_empty() { r0 } else { r1 })
}

/// Reversed Z: the nearer of two depths is the larger.
#[inline(always)]
fn nearer(a: f32, b: f32) -> f32 {
    if a > b {
        a
    } else {
        b
    }
}

/// The farther and the nearer of two depths.
#[inline(always)]
fn minmax(a: f32, b: f32) -> (f32, f32) {
    if a < b {
        (a, b)
    } else {
        (b, a)
    }
}

/// [`reduce_row`] keeping the n-th farthest (n-th smallest) of each block.
fn reduce_row_nth(r0: &[f32], r1: &[f32], out: &mut [f32], n: usize) {
    let w = r0.len();
    for (x, o) in out.iter_mut().enumerate() {
        let (c0, c1) = (2 * x, (2 * x + 1).min(w - 1));
        // A 5-comparator sorting network: far less work than a general sort.
        let (a, b) = minmax(r0[c0], r0[c1]);
        let (c, d) = minmax(r1[c0], r1[c1]);
        let (lo, m1) = minmax(a, c);
        let (m2, hi) = minmax(b, d);
        let (m1, m2) = minmax(m1, m2);
        *o = [lo, m1, m2, hi][n - 1];
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn brute_farthest(w: u32, d: &[f32], x0: u32, y0: u32, x1: u32, y1: u32) -> f32 {
        let mut m = f32::INFINITY;
        for y in y0..=y1 {
            for x in x0..=x1 {
                m = m.min(d[(y * w + x) as usize]);
            }
        }
        m
    }

    #[test]
    fn one_pixel_image_has_one_level() {
        let hzb = Hzb::build(1, 1, &[0.5], Reduction::Farthest).unwrap();
        assert_eq!(hzb.levels().len(), 1);
        assert_eq!(hzb.farthest_in_rect(0, 0, 0, 0), 0.5);
    }

    #[test]
    fn empty_and_mismatched_images_are_errors() {
        assert_eq!(
            Hzb::build(0, 3, &[], Reduction::Farthest),
            Err(HzbError::Empty {
                width: 0,
                height: 3
            })
        );
        assert!(matches!(
            Hzb::build(2, 2, &[0.0; 3], Reduction::Farthest),
            Err(HzbError::SizeMismatch { got: 3, .. })
        ));
        assert_eq!(
            Hzb::build(1, 1, &[0.0], Reduction::NthFarthest(5)),
            Err(HzbError::BadN(5))
        );
    }

    #[test]
    fn odd_sizes_halve_rounding_up() {
        let hzb = Hzb::build(5, 3, &[1.0; 15], Reduction::Farthest).unwrap();
        let sizes: Vec<_> = hzb.levels().iter().map(|l| (l.width, l.height)).collect();
        assert_eq!(sizes, [(5, 3), (3, 2), (2, 1), (1, 1)]);
    }

    #[test]
    fn single_far_pixel_reaches_the_top() {
        let (w, h) = (7u32, 5u32);
        let mut d = vec![0.9; (w * h) as usize];
        d[(4 * w + 6) as usize] = 0.1; // bottom-right corner, a border cell at every level
        let hzb = Hzb::build(w, h, &d, Reduction::Farthest).unwrap();
        assert_eq!(hzb.levels().last().unwrap().data, [0.1]);
        assert_eq!(hzb.farthest_in_rect(0, 0, 6, 4), 0.1);
        assert_eq!(hzb.farthest_in_rect(0, 0, 5, 3), 0.9);
    }

    /// Calls `check(hzb, depth, width, [x0, y0, x1, y1])` on every
    /// rectangle of five images, odd, even and one pixel wide.
    fn every_rect(mut check: impl FnMut(&Hzb, &[f32], u32, [u32; 4])) {
        for (w, h) in [(1, 9), (9, 1), (6, 5), (13, 11), (16, 16)] {
            let d: Vec<f32> = (0..w * h)
                .map(|i| ((i * 7919 + 13) % 101) as f32 / 100.0)
                .collect();
            let hzb = Hzb::build(w, h, &d, Reduction::Farthest).unwrap();
            for y0 in 0..h {
                for y1 in y0..h {
                    for x0 in 0..w {
                        for x1 in x0..w {
                            check(&hzb, &d, w, [x0, y0, x1, y1]);
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn rect_queries_match_brute_force_on_every_rect() {
        every_rect(|hzb, d, w, [x0, y0, x1, y1]| {
            let got = hzb.farthest_in_rect(x0, y0, x1, y1);
            let want = brute_farthest(w, d, x0, y0, x1, y1);
            // Never nearer than the true farthest.
            assert!(got <= want, "{w} wide, rect {x0},{y0}..{x1},{y1}");
        });
    }

    #[test]
    fn rect_hides_is_exact_with_budget_and_conservative_without() {
        every_rect(|hzb, d, w, [x0, y0, x1, y1]| {
            let farthest = brute_farthest(w, d, x0, y0, x1, y1);
            for t in [0.05, 0.3, 0.6, 0.95] {
                let hides = |v: f32| v > t;
                let want = farthest > t;
                let exact = hzb.rect_hides(x0, y0, x1, y1, usize::MAX, hides);
                assert_eq!(exact, want, "{w} wide, rect {x0},{y0}..{x1},{y1}, t {t}");
                for budget in [0, 1, 3, 7] {
                    let got = hzb.rect_hides(x0, y0, x1, y1, budget, hides);
                    assert!(!got || want, "budget {budget} hid a visible rect");
                }
            }
        });
    }

    #[test]
    fn rect_hides_refines_where_the_2x2_cells_overhang() {
        // Near (0.9) in columns 0..=10, far (0.1) from 11 on: a rectangle
        // over columns 7..=10 is read from 4-pixel cells reaching column 11.
        let (w, h) = (16u32, 16u32);
        let d: Vec<f32> = (0..w * h)
            .map(|i| if i % w <= 10 { 0.9 } else { 0.1 })
            .collect();
        let hzb = Hzb::build(w, h, &d, Reduction::Farthest).unwrap();
        assert_eq!(hzb.farthest_in_rect(7, 2, 10, 5), 0.1);
        assert!(hzb.rect_hides(7, 2, 10, 5, usize::MAX, |v| v > 0.5));
        assert!(!hzb.rect_hides(7, 2, 11, 5, usize::MAX, |v| v > 0.5));
    }

    #[test]
    fn rect_hides_keeps_the_nth_farthest_approximation() {
        // A one-pixel hole at (1, 1) in a 4x4 image; the 3x3 rectangle is
        // read from level 1. Refining to the exact level 0 would undo the
        // hole the 2nd-farthest reduction ignores.
        let mut d = [0.8; 16];
        d[5] = 0.0;
        let far = Hzb::build(4, 4, &d, Reduction::Farthest).unwrap();
        let second = Hzb::build(4, 4, &d, Reduction::NthFarthest(2)).unwrap();
        assert!(!far.rect_hides(0, 0, 2, 2, usize::MAX, |v| v > 0.5));
        assert!(second.rect_hides(0, 0, 2, 2, usize::MAX, |v| v > 0.5));
    }

    #[test]
    fn nth_farthest_ignores_one_pixel_hole() {
        let d = [0.0, 0.8, 0.9, 0.7];
        let far = Hzb::build(2, 2, &d, Reduction::Farthest).unwrap();
        let second = Hzb::build(2, 2, &d, Reduction::NthFarthest(2)).unwrap();
        assert_eq!(far.levels()[1].data, [0.0]);
        assert_eq!(second.levels()[1].data, [0.7]);
        let first = Hzb::build(2, 2, &d, Reduction::NthFarthest(1)).unwrap();
        assert_eq!(first, far);
    }

    #[test]
    fn a_pyramid_from_a_level_matches_the_whole_one_from_there_up() {
        for (w, h) in [
            (1, 1),
            (1, 9),
            (9, 1),
            (17, 9),
            (640, 1),
            (13, 11),
            (16, 16),
        ] {
            let d: Vec<f32> = (0..w * h)
                .map(|i| ((i * 7919 + 13) % 101) as f32 / 100.0)
                .collect();
            let whole = Hzb::build(w, h, &d, Reduction::Farthest).unwrap();
            for base in 0..whole.levels().len() {
                let mut part = Hzb::new();
                part.rebuild_from_level(w, h, base as u32, &whole.levels()[base].data)
                    .unwrap();
                assert_eq!((part.width(), part.height(), part.base()), (w, h, base));
                let b = &whole.levels()[base];
                for (k, (a, c)) in part.levels().iter().zip(whole.levels()).enumerate() {
                    assert_eq!((a.width, a.height), (c.width, c.height));
                    if k < base {
                        assert!(a.data.is_empty(), "{w}x{h} base {base}: level {k} held");
                        continue;
                    }
                    assert_eq!(a.data, c.data, "{w}x{h} base {base}: level {k}");
                    if k == base {
                        assert!(a.near.is_empty());
                        continue;
                    }
                    // Each cell's nearest: the largest base cell it covers.
                    let s = k - base;
                    for cy in 0..a.height {
                        for cx in 0..a.width {
                            let mut m = f32::NEG_INFINITY;
                            for y in (cy << s)..((cy + 1) << s).min(b.height) {
                                for x in (cx << s)..((cx + 1) << s).min(b.width) {
                                    m = m.max(b.data[(y * b.width + x) as usize]);
                                }
                            }
                            let got = a.near[(cy * a.width + cx) as usize];
                            assert_eq!(got, m, "{w}x{h} base {base} level {k} ({cx}, {cy})");
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn tests_against_a_pyramid_from_a_level_are_conservative_and_exact_at_its_cells() {
        every_rect(|hzb, d, w, [x0, y0, x1, y1]| {
            let h = hzb.height();
            let farthest = brute_farthest(w, d, x0, y0, x1, y1);
            for base in 1..hzb.levels().len() {
                let mut part = Hzb::new();
                part.rebuild_from_level(w, h, base as u32, &hzb.levels()[base].data)
                    .unwrap();
                // The farthest of the level-`base` cells the rectangle meets.
                let (k, lw) = (base as u32, hzb.levels()[base].width as usize);
                let mut cells = f32::INFINITY;
                for cy in y0 >> k..=y1 >> k {
                    for cx in x0 >> k..=x1 >> k {
                        cells = cells.min(hzb.levels()[base].data[cy as usize * lw + cx as usize]);
                    }
                }
                assert!(part.farthest_in_rect(x0, y0, x1, y1) <= farthest);
                for t in [0.05, 0.3, 0.6, 0.95] {
                    let got = part.rect_hides(x0, y0, x1, y1, usize::MAX, |v| v > t);
                    assert!(!got || farthest > t, "base {base} hid a visible rect");
                    assert_eq!(got, cells > t, "base {base}, rect {x0},{y0}..{x1},{y1}");
                }
            }
        });
    }

    #[test]
    fn a_level_the_pyramid_lacks_or_of_the_wrong_size_is_an_error() {
        let mut hzb = Hzb::new();
        assert_eq!(
            hzb.rebuild_from_level(5, 3, 4, &[0.0]),
            Err(HzbError::NoLevel {
                level: 4,
                width: 5,
                height: 3,
                top: 3
            })
        );
        assert!(matches!(
            hzb.rebuild_from_level(5, 3, 1, &[0.0; 5]),
            Err(HzbError::SizeMismatch {
                width: 3,
                height: 2,
                expected: 6,
                got: 5
            })
        ));
        assert!(matches!(
            hzb.rebuild_from_level(0, 3, 0, &[]),
            Err(HzbError::Empty { .. })
        ));
    }

    #[test]
    fn rebuild_reuses_and_resizes() {
        let mut hzb = Hzb::new();
        assert_eq!(hzb.width(), 0);
        hzb.rebuild(8, 8, &[0.5; 64], Reduction::Farthest).unwrap();
        assert_eq!(hzb.levels().len(), 4);
        hzb.rebuild(3, 1, &[0.1, 0.2, 0.3], Reduction::Farthest)
            .unwrap();
        let sizes: Vec<_> = hzb.levels().iter().map(|l| (l.width, l.height)).collect();
        assert_eq!(sizes, [(3, 1), (2, 1), (1, 1)]);
        assert_eq!(hzb.levels()[1].data, [0.1, 0.3]);
    }
}
