//! Coarse levels a source does not store, built on demand: each brick the 2x2x2 box average of
//! the next finer level (the mean of the existing children at odd edges; for label ids the
//! first child, [`Coarsening::First`]), read a finer brick at a time through a cache bounded in
//! bytes (`summary`: what it lets go waits in a temporary file). Shared by the sources whose files hold only the
//! finest levels (a Zarr array without a pyramid, a memory-mapped raw file), so that every
//! source averages exactly as [`super::pyramid::PyramidSource`] does and gives the same bricks.

use std::ops::Range;
use std::sync::{Arc, Mutex, OnceLock};

use rayon::prelude::*;

use super::pyramid::cut_brick;
use super::source::stored_origin;
use super::summary::{HALF, Summary, SummaryCache};
use super::{BRICK, BrickData, BrickError, Coarsening, Level, Level0Observer, STORED};

/// Bytes of finer-level bricks kept to build the coarse levels a source does not store, out of
/// a volume's host budget of `host` bytes: a quarter, at most 256 MiB (the rest holds the
/// loader's normalized bricks, `loader.rs`).
pub(crate) fn cache_bytes(host: u64) -> u64 {
    (host / 4).min(256 << 20)
}

/// Builds bricks of levels a source lacks from the finer level. What a coarse brick needs of a
/// finer one is the sum of each 2x2x2 block of its voxels (a [`Summary`], an eighth of the
/// brick), so those are what the cache keeps: a finer brick is read once for all the coarse
/// bricks that cover it (up to 8, their aprons included) within a small budget.
pub(crate) struct LazyLevels {
    cache: Mutex<SummaryCache>,
    /// How a coarse voxel is made of the finer ones.
    pub(crate) coarsening: Coarsening,
    /// Shown each level-0 brick read to build level 1.
    observer: OnceLock<Level0Observer>,
}

impl LazyLevels {
    /// Levels built with a cache of at most `budget` bytes of finer bricks' sums.
    pub(crate) fn new(budget: u64) -> LazyLevels {
        LazyLevels {
            cache: Mutex::new(SummaryCache::new(budget)),
            coarsening: Coarsening::Mean,
            observer: OnceLock::new(),
        }
    }

    /// Shows `observer` every level-0 brick read from now on (the first observer only: a
    /// source belongs to one volume).
    pub(crate) fn observe_level0(&self, observer: Level0Observer) {
        let _ = self.observer.set(observer);
    }

    /// Brick `brick` of `level` (not 0) as the box average of `level - 1`, whose bricks come
    /// from `read` (the source's own read, so that a built level can come from another).
    pub(crate) fn build(
        &self,
        levels: &[Level],
        level: usize,
        brick: [u32; 3],
        read: &(dyn Fn(usize, [u32; 3]) -> Result<BrickData, BrickError> + Sync),
    ) -> Result<BrickData, BrickError> {
        let dims = levels[level].dims;
        let fine = levels[level - 1].dims;
        let (lo, hi) = stored_box(dims, brick);
        let size = sub(hi, lo);
        let mut sums = vec![0.0f32; size.iter().map(|&n| n as usize).product()];
        // The finer bricks under the box: finer brick b's voxels are coarse voxels
        // [b HALF, (b + 1) HALF).
        let bricks: [Range<u32>; 3] = [0, 1, 2].map(|a| lo[a] / HALF..(hi[a] - 1) / HALF + 1);
        let mut finer = Vec::new();
        for z in bricks[2].clone() {
            for y in bricks[1].clone() {
                finer.extend(bricks[0].clone().map(|x| [x, y, z]));
            }
        }
        // The finer bricks are read in parallel (each may build its own finer level in turn),
        // and added in one order, so that the sums do not depend on which came first.
        let summaries =
            finer.par_iter().map(|&fb| self.summary(level - 1, fb, fine, read)).collect::<Result<Vec<_>, _>>()?;
        let mut uniform: Option<Option<f32>> = None;
        for (&fb, summary) in finer.iter().zip(&summaries) {
            uniform = Some(match (uniform, &**summary) {
                (None, Summary::Constant(v)) => Some(*v),
                (Some(Some(u)), Summary::Constant(v)) if u.to_bits() == v.to_bits() => Some(u),
                _ => None,
            });
            add_summary(&mut sums, (lo, hi), summary, fb, fine, self.coarsening);
        }
        if let Some(Some(v)) = uniform {
            return Ok(BrickData::Constant(v));
        }
        if self.coarsening == Coarsening::Mean {
            divide_by_children(&mut sums, lo, size, fine);
        }
        Ok(cut_brick(dims, brick, |p| sums[box_index(sub(p, lo), size)]).collapse())
    }

    /// The summary of a finer brick, through the cache.
    fn summary(
        &self,
        level: usize,
        brick: [u32; 3],
        fine: [u32; 3],
        read: &(dyn Fn(usize, [u32; 3]) -> Result<BrickData, BrickError> + Sync),
    ) -> Result<Arc<Summary>, BrickError> {
        if let Some(hit) = self.cache.lock().unwrap_or_else(|e| e.into_inner()).get((level, brick)) {
            return Ok(hit);
        }
        // Read without the lock, so that other loader threads are not held up.
        let data = read(level, brick)?;
        if level == 0
            && let Some(observe) = self.observer.get()
        {
            observe(brick, &data);
        }
        let summary = Arc::new(Summary::of(&data, brick, fine, self.coarsening));
        self.cache.lock().unwrap_or_else(|e| e.into_inner()).insert((level, brick), summary.clone());
        Ok(summary)
    }
}

/// Adds the sums of finer brick `fb` (a level of `fine` dims) to the coarse voxels of the box
/// `[lo, hi)` it covers (with [`Coarsening::First`], its first voxels: each coarse voxel has
/// one block in one finer brick).
fn add_summary(
    sums: &mut [f32],
    (lo, hi): ([u32; 3], [u32; 3]),
    summary: &Summary,
    fb: [u32; 3],
    fine: [u32; 3],
    coarsening: Coarsening,
) {
    let size = sub(hi, lo);
    let start = [0, 1, 2].map(|a| lo[a].max(fb[a] * HALF));
    let end = [0, 1, 2].map(|a| hi[a].min((fb[a] + 1) * HALF));
    let children = |c: u32, n: u32| match coarsening {
        Coarsening::Mean => n.saturating_sub(2 * c).min(2) as f32,
        Coarsening::First => 1.0,
    };
    for z in start[2]..end[2] {
        for y in start[1]..end[1] {
            let row = box_index([0, y - lo[1], z - lo[2]], size);
            for x in start[0]..end[0] {
                sums[row + (x - lo[0]) as usize] += match summary {
                    // A constant brick's voxels inside the volume, each of its value.
                    Summary::Constant(v) => v * children(x, fine[0]) * children(y, fine[1]) * children(z, fine[2]),
                    Summary::Sums(s) => s[box_index([x, y, z].map(|c| c % HALF), [HALF; 3])],
                };
            }
        }
    }
}

/// Divides each sum of the box at `lo` of `size` by its number of children in a finer level
/// of `fine` dims: 2 per axis, 1 at an odd edge.
fn divide_by_children(sums: &mut [f32], lo: [u32; 3], size: [u32; 3], fine: [u32; 3]) {
    let children = |c: u32, n: u32| (n - 2 * c).min(2) as f32;
    for z in 0..size[2] {
        for y in 0..size[1] {
            let row = box_index([0, y, z], size);
            let cyz = children(lo[1] + y, fine[1]) * children(lo[2] + z, fine[2]);
            for x in 0..size[0] {
                sums[row + x as usize] /= children(lo[0] + x, fine[0]) * cyz;
            }
        }
    }
}

/// The box of a level's voxels a stored brick covers: its stored voxels clamped to the grid.
pub(crate) fn stored_box(dims: [u32; 3], brick: [u32; 3]) -> ([u32; 3], [u32; 3]) {
    let origin = stored_origin(brick);
    let lo = [0, 1, 2].map(|a| origin[a].max(0) as u32);
    let hi = [0, 1, 2].map(|a| (origin[a] + STORED as i64).min(dims[a] as i64) as u32);
    (lo, hi)
}

/// The box of a level's voxels that are a brick's own (no apron), clamped to the grid: all a
/// built level reads of a finer brick.
pub(crate) fn inside_box(dims: [u32; 3], brick: [u32; 3]) -> ([u32; 3], [u32; 3]) {
    let lo = brick.map(|b| b * BRICK);
    let hi = [0, 1, 2].map(|a| (lo[a] + BRICK).min(dims[a]));
    (lo, hi)
}

pub(crate) fn sub(a: [u32; 3], b: [u32; 3]) -> [u32; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// Index of `p` in a box of `size`, x fastest.
pub(crate) fn box_index(p: [u32; 3], size: [u32; 3]) -> usize {
    (p[2] as usize * size[1] as usize + p[1] as usize) * size[0] as usize + p[0] as usize
}
