//! Which stored dataset answers each level of the pyramid, and how.
//!
//! The pyramid's levels are fixed by level 0 ([`levels_for`](super::super::levels_for): each
//! halves the last, rounding up, and level `l`'s voxel `i` covers level 0's voxels
//! `[i 2^l, (i + 1) 2^l)`), so that the lookup needs no per-level table. A store's own pyramid
//! may differ: ome-zarr-py halves x and y but keeps z, odd sizes are halved rounding down, and
//! the factors may be anything. Each dataset is placed by its coordinate transformations
//! against dataset 0; a dataset whose factor on every axis is a power of two that divides the
//! level's answers that level by averaging `ratio` of its voxels per axis (1 where it matches),
//! starting at the whole-voxel offset its translation gives. The one reading the fewest voxels
//! is chosen; a level no dataset answers within [`MAX_RATIO`] voxels per voxel is built from
//! the level below (`lazy_levels`).

use super::ome::Transform;
use crate::bricks::Coarsening;

/// The most dataset voxels averaged into one level voxel when reading a level from a finer
/// dataset (a brick reads at most this many bricks' worth of voxels).
pub(super) const MAX_RATIO: u64 = 16;

/// How a level is read.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum LevelPlan {
    /// From dataset `dataset`: level voxel `i` is the mean of the dataset's voxels
    /// `[i ratio + offset, (i + 1) ratio + offset)` per axis (clamped to the dataset).
    Read { dataset: usize, ratio: [u32; 3], offset: [i64; 3] },
    /// As the 2x2x2 average of the level below.
    Built,
}

/// A dataset's placement against dataset 0, per axis x, y, z: its voxel size as a multiple of
/// dataset 0's (`factor`), the centre of its first voxel in dataset 0's voxels (`shift`), and
/// its voxels (`dims`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Placement {
    pub(super) factor: [f64; 3],
    pub(super) shift: [f64; 3],
    pub(super) dims: [u32; 3],
}

impl Placement {
    /// The placement of a dataset of `dims` voxels whose transform is `t` against dataset 0's
    /// `t0`, for the array axes `space` (x, y, z).
    pub(super) fn of(t: &Transform, t0: &Transform, space: [usize; 3], dims: [u32; 3]) -> Placement {
        let factor = space.map(|i| t.scale[i] / t0.scale[i]);
        let shift = space.map(|i| (t.translation[i] - t0.translation[i]) / t0.scale[i]);
        Placement { factor, shift, dims }
    }
}

/// The plan of each of `levels` levels over datasets placed as `placements` (dataset 0 first).
pub(super) fn plan_levels(levels: usize, placements: &[Placement]) -> Vec<LevelPlan> {
    (0..levels)
        .map(|l| {
            let span = 1u64 << l.min(62);
            let candidates = placements.iter().enumerate().filter_map(|(d, p)| {
                let mut ratio = [0u32; 3];
                let mut offset = [0i64; 3];
                for a in 0..3 {
                    let f = power_of_two(p.factor[a], p.dims[a])?;
                    if f > span {
                        return None;
                    }
                    ratio[a] = u32::try_from(span / f).ok()?;
                    // Level voxel i's box starts at level-0 voxel i 2^l - 1/2 (centres at whole
                    // numbers); the dataset's voxel j covers [shift + (j - 1/2) f, ...).
                    offset[a] = ((f as f64 / 2.0 - 0.5 - p.shift[a]) / f as f64).round() as i64;
                }
                let read: u64 = ratio.iter().map(|&r| r as u64).product();
                (read <= MAX_RATIO || l == 0).then_some((read, d, ratio, offset))
            });
            match candidates.min_by_key(|c| (c.0, c.1)) {
                Some((_, dataset, ratio, offset)) => LevelPlan::Read { dataset, ratio, offset },
                None => LevelPlan::Built,
            }
        })
        .collect()
}

/// The power of two `p` a voxel size factor `f` stands for: within one voxel over the
/// dataset's `n` voxels (`|f - p| n <= p`). Tools that downsample by resizing (ome-zarr-py,
/// scikit-image) write the size ratio, which an odd size makes a little more than 2 (37 / 18).
fn power_of_two(f: f64, n: u32) -> Option<u64> {
    if !(1.0..=(1u64 << 62) as f64).contains(&f) {
        return None;
    }
    let p = 1u64 << (f.log2().round() as u32);
    ((f - p as f64).abs() * n as f64 <= p as f64 * (1.0 + 1e-6)).then_some(p)
}

/// The dataset voxels `[lo, hi)` (per axis) that the level voxels `[lo, hi)` read with `ratio`
/// and `offset` from a dataset of `dims`: the box clamped to the dataset, never empty.
pub(super) fn source_box(
    lo: [u32; 3],
    hi: [u32; 3],
    ratio: [u32; 3],
    offset: [i64; 3],
    dims: [u32; 3],
) -> ([u32; 3], [u32; 3]) {
    let clamp = |v: i64, a: usize| v.clamp(0, dims[a] as i64) as u32;
    let slo = [0, 1, 2].map(|a| clamp(lo[a] as i64 * ratio[a] as i64 + offset[a], a).min(dims[a] - 1));
    let shi = [0, 1, 2].map(|a| clamp(hi[a] as i64 * ratio[a] as i64 + offset[a], a).max(slo[a] + 1));
    (slo, shi)
}

/// The level voxels of the box `[lo, hi)` from the dataset voxels `values` of the box
/// `[slo, shi)` (x fastest): each the mean of the voxels its window covers (the first of them
/// with [`Coarsening::First`]), or, past the dataset's end (a level rounded up over a dataset
/// rounded down), the nearest voxel.
pub(super) fn resample(
    values: Vec<f32>,
    (slo, shi): ([u32; 3], [u32; 3]),
    (lo, hi): ([u32; 3], [u32; 3]),
    ratio: [u32; 3],
    offset: [i64; 3],
    coarsening: Coarsening,
) -> Vec<f32> {
    // A dataset that is the level (every brick of level 0, on the loaders' path): as read.
    if ratio == [1, 1, 1] && offset == [0, 0, 0] && slo == lo && shi == hi {
        return values;
    }
    let ssize = [0, 1, 2].map(|a| (shi[a] - slo[a]) as usize);
    // Per axis and level voxel: the window of box indices it averages.
    let windows = |a: usize| -> Vec<(usize, usize)> {
        (lo[a]..hi[a])
            .map(|v| {
                let start = v as i64 * ratio[a] as i64 + offset[a] - slo[a] as i64;
                let end = start + ratio[a] as i64;
                let n = ssize[a] as i64;
                let (s, e) = (start.clamp(0, n), end.clamp(0, n));
                if s < e {
                    // The first voxel alone, or all it covers.
                    let e = if coarsening == Coarsening::First { s + 1 } else { e };
                    (s as usize, e as usize)
                } else {
                    let i = start.clamp(0, n - 1) as usize;
                    (i, i + 1)
                }
            })
            .collect()
    };
    let (wx, wy, wz) = (windows(0), windows(1), windows(2));
    // Row by row: each output row of voxels sums its windows of the rows its (z, y) window
    // covers, in one buffer, reading each row once and in order (the sums as a voxel-by-voxel
    // loop adds them: z, then y, then x).
    let mut out = Vec::with_capacity(wx.len() * wy.len() * wz.len());
    let mut sums = vec![0.0f64; wx.len()];
    for &(z0, z1) in &wz {
        for &(y0, y1) in &wy {
            sums.fill(0.0);
            for z in z0..z1 {
                for y in y0..y1 {
                    let row = &values[(z * ssize[1] + y) * ssize[0]..][..ssize[0]];
                    for (sum, &(x0, x1)) in sums.iter_mut().zip(&wx) {
                        *sum += row[x0..x1].iter().map(|&v| f64::from(v)).sum::<f64>();
                    }
                }
            }
            let zy = (z1 - z0) * (y1 - y0);
            out.extend(sums.iter().zip(&wx).map(|(sum, &(x0, x1))| (sum / (zy * (x1 - x0)) as f64) as f32));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn placed(factor: [f64; 3], shift: [f64; 3]) -> Placement {
        Placement { factor, shift, dims: [100; 3] }
    }

    #[test]
    fn ome_zarr_py_pyramids_answer_the_levels_they_can() {
        // x and y halved, z kept: dataset k has factors (2^k, 2^k, 1), no translation.
        let p: Vec<Placement> = (0..4).map(|k| placed([(1 << k) as f64, (1 << k) as f64, 1.0], [0.0; 3])).collect();
        let plans = plan_levels(5, &p);
        assert_eq!(plans[0], LevelPlan::Read { dataset: 0, ratio: [1, 1, 1], offset: [0, 0, 0] });
        assert_eq!(plans[2], LevelPlan::Read { dataset: 2, ratio: [1, 1, 4], offset: [0, 0, 0] });
        assert_eq!(plans[3], LevelPlan::Read { dataset: 3, ratio: [1, 1, 8], offset: [0, 0, 0] });
        // Level 4 would read dataset 3 with 2 x 2 x 16 voxels per voxel: more than the limit.
        assert_eq!(plans[4], LevelPlan::Built);
        // The size ratio ome-zarr-py writes for an odd size (37 / 18) stands for 2; 3 does not.
        assert_eq!(power_of_two(37.0 / 18.0, 18), Some(2));
        assert_eq!(power_of_two(3.0, 10), None);
        assert_eq!(power_of_two(40.0 / 2.0, 10), None);
        assert_eq!(power_of_two(40.0 / 2.0, 2), Some(16));
    }

    #[test]
    fn factors_that_are_not_powers_of_two_are_not_read() {
        let p = [placed([1.0; 3], [0.0; 3]), placed([3.0; 3], [1.0; 3]), placed([2.0; 3], [0.5; 3])];
        let plans = plan_levels(2, &p);
        assert_eq!(plans[1], LevelPlan::Read { dataset: 2, ratio: [1, 1, 1], offset: [0, 0, 0] });
        // A translated dataset is read from the voxel its translation puts first.
        let shifted = [placed([1.0; 3], [0.0; 3]), placed([2.0; 3], [-4.0; 3])];
        assert_eq!(plan_levels(2, &shifted)[1], LevelPlan::Read { dataset: 1, ratio: [1, 1, 1], offset: [2, 2, 2] });
    }

    /// The row sums give each level voxel the mean of its window's box, in 3D, with
    /// uneven ratios, an offset and a box clamped at the dataset's edge.
    #[test]
    fn resampling_is_the_mean_of_each_voxels_box() {
        let (slo, shi) = ([1, 0, 2], [8, 6, 7]);
        let size = [7usize, 6, 5];
        let values: Vec<f32> = (0..size.iter().product::<usize>()).map(|i| ((i * 37) % 101) as f32 * 0.5).collect();
        let (lo, hi, ratio, offset) = ([0, 0, 1], [4, 3, 3], [2, 2, 4], [1, 0, -2]);
        let out = resample(values.clone(), (slo, shi), (lo, hi), ratio, offset, Coarsening::Mean);
        let mut want = Vec::new();
        for z in lo[2]..hi[2] {
            for y in lo[1]..hi[1] {
                for x in lo[0]..hi[0] {
                    let p = [x, y, z];
                    let range = |a: usize| {
                        let start =
                            (p[a] as i64 * ratio[a] as i64 + offset[a] - slo[a] as i64).clamp(0, size[a] as i64);
                        let end = (start + ratio[a] as i64).clamp(0, size[a] as i64);
                        start as usize..end as usize
                    };
                    let (mut sum, mut n) = (0.0f64, 0);
                    for k in range(2) {
                        for j in range(1) {
                            for i in range(0) {
                                sum += f64::from(values[(k * size[1] + j) * size[0] + i]);
                                n += 1;
                            }
                        }
                    }
                    want.push((sum / f64::from(n)) as f32);
                }
            }
        }
        assert_eq!(out, want);
    }

    #[test]
    fn resampling_averages_windows_and_repeats_past_the_end() {
        // A 1D row (x) of 5 dataset voxels read as 3 level voxels with ratio 2: the last has one.
        let values = [1.0, 3.0, 5.0, 7.0, 9.0];
        let row =
            |c| resample(values.to_vec(), ([0, 0, 0], [5, 1, 1]), ([0, 0, 0], [3, 1, 1]), [2, 1, 1], [0, 0, 0], c);
        assert_eq!(row(Coarsening::Mean), [2.0, 6.0, 9.0]);
        // Label ids: the first of each window, never a mean.
        assert_eq!(row(Coarsening::First), [1.0, 5.0, 9.0]);
        // A level rounded up over a dataset rounded down: the voxel past the end repeats.
        let out = resample(
            values[..2].to_vec(),
            ([0, 0, 0], [2, 1, 1]),
            ([0, 0, 0], [3, 1, 1]),
            [1, 1, 1],
            [0, 0, 0],
            Coarsening::Mean,
        );
        assert_eq!(out, [1.0, 3.0, 3.0]);
        assert_eq!(source_box([0, 0, 0], [3, 1, 1], [1, 1, 1], [0, 0, 0], [2, 1, 1]), ([0, 0, 0], [2, 1, 1]));
    }
}
