//! What the bricks read so far tell of a bricked volume's values, for empty-space skipping: the
//! value range of every texel of a grid as fine as a single texture's (`occupancy::BRICK`
//! voxels a texel), learnt from each level-0 brick the first time it arrives. A texel's samples
//! read voxels of one or more bricks (the voxels in their interiors, each voxel in one brick's);
//! its range is known once every one of those bricks has been read, and until then it is any
//! value (never skipped). A coarser level bounds nothing here: its voxels are averages.

use std::collections::HashSet;
use std::ops::RangeInclusive;
use std::sync::{Arc, Mutex};

use super::loader::{Normalized, pool_value};
use super::{APRON, BRICK, BrickData, BrickSource, STORED, lock};
use crate::occupancy::{self, BrickRanges, EMPTY, merge};
use crate::volume::{Scaling, Window};

/// Any value: a texel not yet known.
const ANY: (f32, f32) = (f32::NEG_INFINITY, f32::INFINITY);

/// The grid's ranges as far as the bricks read tell.
pub(crate) struct LearntRanges {
    dims: [u32; 3],
    texels: [u32; 3],
    /// Per texel along each axis, the voxels its samples read.
    spans: [Vec<RangeInclusive<u32>>; 3],
    /// Per texel: the range of the voxels read so far, and how many bricks are still to come.
    ranges: Vec<(f32, f32)>,
    missing: Vec<u8>,
    /// Level-0 bricks recorded (an evicted brick that arrives again tells nothing new).
    recorded: HashSet<[u32; 3]>,
    /// Whether something was learnt since [`LearntRanges::take_changed`].
    changed: bool,
}

impl LearntRanges {
    /// Nothing known yet of a volume of `dims` voxels.
    pub(crate) fn new(dims: [u32; 3]) -> LearntRanges {
        let texels = dims.map(|d| d.div_ceil(occupancy::BRICK).max(1));
        let spans = [0, 1, 2].map(|a| occupancy::texel_voxels(dims[a], texels[a]));
        let bricks_of = |a: usize| -> Vec<u8> {
            spans[a].iter().map(|s| (s.end() / BRICK - s.start() / BRICK + 1) as u8).collect()
        };
        let [bx, by, bz] = [bricks_of(0), bricks_of(1), bricks_of(2)];
        let mut missing = Vec::with_capacity(bx.len() * by.len() * bz.len());
        for z in &bz {
            for y in &by {
                for x in &bx {
                    missing.push(x * y * z);
                }
            }
        }
        let count = missing.len();
        LearntRanges {
            dims,
            texels,
            spans,
            ranges: vec![EMPTY; count],
            missing,
            recorded: HashSet::new(),
            changed: true,
        }
    }

    /// Takes in level-0 brick `brick`: `value(x, y, z)` gives its stored voxel (apron
    /// included) as the pool holds it.
    pub(crate) fn record(&mut self, brick: [u32; 3], value: impl Fn([u32; 3]) -> f32) {
        if !self.recorded.insert(brick) {
            return;
        }
        // Per axis: the brick's interior voxels and, for each, the texels that read it (a
        // contiguous run from the axis's first texel `first[a]`).
        let axes = [0, 1, 2].map(|a| self.interior_texels(a, brick[a]));
        let first = [0, 1, 2].map(|a| axes[a].iter().flat_map(|(_, t)| t.clone()).min().unwrap_or(0));
        let size = [0, 1, 2].map(|a| axes[a].iter().flat_map(|(_, t)| t.clone()).max().map_or(0, |m| m + 1 - first[a]));
        let mut partial = vec![EMPTY; (size[0] * size[1] * size[2]) as usize];
        for (z, tz) in &axes[2] {
            for (y, ty) in &axes[1] {
                for (x, tx) in &axes[0] {
                    let v = value([
                        x - brick[0] * BRICK + APRON,
                        y - brick[1] * BRICK + APRON,
                        z - brick[2] * BRICK + APRON,
                    ]);
                    for k in tz.clone() {
                        for j in ty.clone() {
                            for i in tx.clone() {
                                let local = (i - first[0]) + size[0] * ((j - first[1]) + size[1] * (k - first[2]));
                                let range = &mut partial[local as usize];
                                *range = merge(*range, (v, v));
                            }
                        }
                    }
                }
            }
        }
        for (local, range) in partial.into_iter().enumerate().filter(|(_, r)| r.0 <= r.1) {
            let local = local as u32;
            let [i, j, k] = [local % size[0], local / size[0] % size[1], local / (size[0] * size[1])];
            let texel = ((i + first[0]) + self.texels[0] * ((j + first[1]) + self.texels[1] * (k + first[2]))) as usize;
            self.ranges[texel] = merge(self.ranges[texel], range);
            self.missing[texel] = self.missing[texel].saturating_sub(1);
        }
        self.changed = true;
    }

    /// The interior voxels of brick `b` along axis `a`, each with the texels that read it.
    fn interior_texels(&self, a: usize, b: u32) -> Vec<(u32, RangeInclusive<u32>)> {
        let end = ((b + 1) * BRICK).min(self.dims[a]);
        let spans = &self.spans[a];
        (b * BRICK..end)
            .filter_map(|v| {
                let first = spans.iter().position(|s| s.contains(&v))? as u32;
                let count = spans[first as usize..].iter().take_while(|s| s.contains(&v)).count() as u32;
                Some((v, first..=first + count - 1))
            })
            .collect()
    }

    /// Takes every range known to `(lo(min), hi(max))`: with non-decreasing `lo <= hi`, what
    /// a range bounded bounds what the new one does.
    fn map(&mut self, lo: impl Fn(f32) -> f32, hi: impl Fn(f32) -> f32) {
        for range in self.ranges.iter_mut().filter(|r| r.0 <= r.1) {
            *range = (lo(range.0), hi(range.1));
        }
        self.changed = true;
    }

    /// The grid as far as it is known, when something was learnt since the last call.
    pub(crate) fn take_changed(&mut self) -> Option<BrickRanges> {
        if !std::mem::take(&mut self.changed) {
            return None;
        }
        let ranges = self.ranges.iter().zip(&self.missing).map(|(&r, &m)| if m == 0 { r } else { ANY }).collect();
        Some(BrickRanges::from_ranges(self.texels, ranges))
    }
}

/// A bricked volume's [`LearntRanges`], fed by the bricks that arrive from the loader and by
/// those its source reads of itself ([`BrickSource::observe_level0`]). Those may come before
/// the volume's window is known (a source without a stored pyramid reads level 0 whole to build
/// the coarsest level, which the automatic window is taken from), so until [`Self::set_window`]
/// values are kept in data units; from then on, as the pool holds them.
pub(crate) struct RangeLearner {
    ranges: LearntRanges,
    window: Option<Window>,
}

impl RangeLearner {
    /// A learner for `source`, shown every level-0 brick the source reads of itself from now on.
    pub(crate) fn of(source: &dyn BrickSource) -> Arc<Mutex<RangeLearner>> {
        let learner =
            Arc::new(Mutex::new(RangeLearner { ranges: LearntRanges::new(source.levels()[0].dims), window: None }));
        let recorder = learner.clone();
        source.observe_level0(Arc::new(move |brick, data| lock(&recorder).record_read(brick, data)));
        learner
    }

    /// Level-0 brick `brick` as the source read it (data units): once the window is known, as
    /// the loader will normalize it for the pool (a voxel a half float, a brick of one value
    /// exact).
    fn record_read(&mut self, brick: [u32; 3], data: &BrickData) {
        match (self.window, data) {
            (None, BrickData::Constant(v)) => self.ranges.record(brick, |_| *v),
            (None, BrickData::Voxels(_)) => self.ranges.record(brick, |at| data.at(at)),
            (Some(w), BrickData::Constant(v)) => self.ranges.record(brick, |_| w.apply(*v)),
            (Some(w), BrickData::Voxels(_)) => self.ranges.record(brick, |at| pool_value(w, data.at(at)).to_f32()),
        }
    }

    /// Level-0 brick `brick` as it arrived for the pool.
    pub(crate) fn record_arrival(&mut self, brick: [u32; 3], data: &Normalized) {
        match data {
            Normalized::Constant(v) => self.ranges.record(brick, |_| *v),
            Normalized::Voxels(voxels) => self.ranges.record(brick, |at| stored_voxel(voxels, at)),
        }
    }

    /// From now on values are mapped by `window` (data units to the pool's [0, 1]), and so are
    /// the ranges learnt so far.
    pub(crate) fn set_window(&mut self, window: [f32; 2]) {
        let window = Window::new(window, Scaling::IDENTITY);
        if self.window.is_none() {
            self.ranges.map(|v| in_pool(window, v).0, |v| in_pool(window, v).1);
        }
        self.window = Some(window);
    }

    /// [`LearntRanges::take_changed`], once the window is set (`None` before).
    pub(crate) fn take_changed(&mut self) -> Option<BrickRanges> {
        self.window?;
        self.ranges.take_changed()
    }
}

/// Bounds of value `v` (data units) as the pool holds it, whether it comes as a voxel (rounded
/// to a half float) or as a brick of one value (close to exact): for ranges learnt before the
/// window, which do not say which.
fn in_pool(window: Window, v: f32) -> (f32, f32) {
    let (voxel, exact) = (pool_value(window, v).to_f32(), window.apply(v));
    (voxel.min(exact) - f32::EPSILON, voxel.max(exact) + f32::EPSILON)
}

/// The stored voxel at `[x, y, z]` of a brick's half floats.
pub(crate) fn stored_voxel(voxels: &[half::f16], [x, y, z]: [u32; 3]) -> f32 {
    voxels[((z * STORED + y) * STORED + x) as usize].to_f32()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_texel_is_known_once_every_brick_its_samples_read_has_arrived() {
        // 100 voxels along x in bricks of 64: 13 texels; the one whose samples read voxels 63
        // and 64 reads both bricks.
        let mut learnt = LearntRanges::new([100, 8, 8]);
        let straddling = learnt.spans[0].iter().position(|s| s.contains(&63) && s.contains(&64)).expect("a texel");
        let grid = |learnt: &mut LearntRanges| learnt.take_changed().map(|r| r.max_grid().values());
        assert!(grid(&mut learnt).expect("the first grid").iter().all(|v| v.is_infinite()), "nothing known yet");
        // Brick 0: 0.1, but 0.9 at voxel 63.
        learnt.record([0, 0, 0], |[x, _, _]| if x == APRON + 63 { 0.9 } else { 0.1 });
        let after_0 = grid(&mut learnt).expect("brick 0 told something");
        assert!(after_0[0] < 0.11, "texel 0 lies in brick 0: {after_0:?}");
        assert!(after_0[straddling].is_infinite(), "the straddling texel waits for brick 1: {after_0:?}");
        assert!(after_0[12].is_infinite(), "the last texel lies in brick 1");
        assert!(grid(&mut learnt).is_none(), "nothing new");
        learnt.record([1, 0, 0], |_| 0.3);
        let after_1 = grid(&mut learnt).expect("brick 1 told something");
        assert!(after_1.iter().all(|v| v.is_finite()), "{after_1:?}");
        assert!((0.9..0.91).contains(&after_1[straddling]), "{after_1:?}");
        assert!((0.3..0.31).contains(&after_1[12]), "{after_1:?}");
        learnt.record([1, 0, 0], |_| 0.3);
        assert!(grid(&mut learnt).is_none(), "a brick read again tells nothing new");
    }

    #[test]
    fn ranges_read_before_the_window_is_known_are_mapped_by_it() {
        let mut learner = RangeLearner { ranges: LearntRanges::new([64, 8, 8]), window: None };
        learner.record_read([0, 0, 0], &BrickData::Constant(-1000.0));
        assert!(learner.take_changed().is_none(), "no grid before the window");
        learner.set_window([-1000.0, 1000.0]);
        let grid = learner.take_changed().expect("the grid once the window is set").max_grid().values();
        assert!(grid.iter().all(|&v| v.abs() < 1e-3), "-1000 is the window's bottom: {grid:?}");
        // A brick read after the window is set is mapped as it is read.
        let mut learner = RangeLearner { ranges: LearntRanges::new([64, 8, 8]), window: None };
        learner.set_window([-1000.0, 1000.0]);
        learner.record_read([0, 0, 0], &BrickData::Constant(0.0));
        let grid = learner.take_changed().expect("the grid").max_grid().values();
        assert!(grid.iter().all(|&v| (v - 0.5).abs() < 1e-3), "0 is the window's middle: {grid:?}");
    }
}
