//! A [`BrickSource`] over a volume in memory (every format `crate::volume::load` reads, and the
//! phantoms): level 0 is the volume's own samples, the coarser levels are built once by 2x2x2
//! box averaging and kept as `f32`.
//!
//! Memory: the coarse levels together take about a seventh of the volume's voxels at 4 bytes
//! each (under 0.6 bytes per level-0 voxel), next to the samples the volume already holds.
//! `f32` rather than `f16` because data units can be large integers (16-bit microscopy, CT in
//! HU) that half floats would round.

use std::sync::Arc;

use glam::Mat4;

use super::source::stored_origin;
use super::{BrickData, BrickError, BrickSource, Coarsening, Level, Level0Observer, STORED, levels_for};
use crate::volume::Volume;

/// A volume in memory, read a brick at a time, with a box-averaged mip pyramid.
pub(crate) struct PyramidSource {
    volume: Arc<Volume>,
    levels: Vec<Level>,
    /// Levels 1.. in data units, x fastest (`coarse[l - 1]` is level `l`).
    coarse: Vec<Vec<f32>>,
}

impl PyramidSource {
    /// The pyramid over `volume`, its coarse levels made by `coarsening`. Its samples are
    /// cloned in their stored type (no `f32` copy of level 0); use
    /// [`PyramidSource::from_shared`] to share them instead.
    pub(crate) fn from_volume(volume: &Volume, coarsening: Coarsening) -> PyramidSource {
        PyramidSource::from_shared(Arc::new(volume.clone()), coarsening)
    }

    /// The pyramid over a shared volume, without copying its samples.
    pub(crate) fn from_shared(volume: Arc<Volume>, coarsening: Coarsening) -> PyramidSource {
        let levels = levels_for(volume.dims);
        let mut coarse: Vec<Vec<f32>> = Vec::with_capacity(levels.len().saturating_sub(1));
        for pair in levels.windows(2) {
            let (fine, dims) = (pair[0].dims, pair[1].dims);
            let level = match coarse.last() {
                // Level 1 reads the samples a row at a time (one type dispatch per row).
                None => downsample((fine, dims), coarsening, |start, len, f| {
                    volume.samples.for_each(start..start + len, |s| f(volume.scaling.apply(s)))
                }),
                Some(finer) => downsample((fine, dims), coarsening, |start, len, f| {
                    finer[start..start + len].iter().for_each(|&v| f(v))
                }),
            };
            coarse.push(level);
        }
        PyramidSource { volume, levels, coarse }
    }

    /// Data value of voxel `index` (x fastest) of `level`.
    fn value(&self, level: usize, index: usize) -> f32 {
        match level {
            0 => self.volume.value(index).unwrap_or(0.0),
            l => self.coarse[l - 1].get(index).copied().unwrap_or(0.0),
        }
    }
}

/// Brick `brick` of a grid of `dims` whose voxel `index` (x fastest) has `value(index)`.
fn brick_of(dims: [u32; 3], brick: [u32; 3], value: impl Fn(usize) -> f32) -> BrickData {
    let [dx, dy, _] = dims.map(|n| n as usize);
    cut_brick(dims, brick, |[x, y, z]| value((z as usize * dy + y as usize) * dx + x as usize)).collapse()
}

impl BrickSource for PyramidSource {
    fn levels(&self) -> &[Level] {
        &self.levels
    }

    fn grid_to_world(&self) -> Mat4 {
        self.volume.grid_to_world
    }

    fn range(&self) -> [f32; 2] {
        self.volume.range
    }

    fn read(&self, level: usize, brick: [u32; 3]) -> Result<BrickData, BrickError> {
        let info = check_brick(&self.levels, level, brick)?;
        Ok(brick_of(info.dims, brick, |index| self.value(level, index)))
    }

    /// Shows `observer` every level-0 brick, on a thread of its own (the volume is in memory:
    /// its bricks' values are known before any is asked for).
    fn observe_level0(&self, observer: Level0Observer) {
        let (volume, level) = (self.volume.clone(), self.levels[0]);
        std::thread::spawn(move || {
            for brick in level.each_brick() {
                observer(brick, &brick_of(level.dims, brick, |index| volume.value(index).unwrap_or(0.0)));
            }
        });
    }
}

/// The level `level`, if `brick` is one of its bricks; a clear error otherwise.
pub(crate) fn check_brick(levels: &[Level], level: usize, brick: [u32; 3]) -> Result<Level, BrickError> {
    let info = levels
        .get(level)
        .ok_or_else(|| BrickError(format!("level {level} does not exist (the pyramid has {})", levels.len())))?;
    if brick.iter().zip(info.bricks).any(|(&b, n)| b >= n) {
        return Err(BrickError(format!(
            "brick {brick:?} is outside level {level}, which has {:?} bricks",
            info.bricks
        )));
    }
    Ok(*info)
}

/// Brick `brick` of a grid of `dims` with its apron: `value` of each stored voxel's position,
/// clamped to the grid (so the edge voxels repeat, as a texture sampler clamps).
pub(crate) fn cut_brick(dims: [u32; 3], brick: [u32; 3], mut value: impl FnMut([u32; 3]) -> f32) -> BrickData {
    let origin = stored_origin(brick);
    // The clamped coordinate of each stored position, per axis, computed once.
    let axis = |a: usize| -> Vec<u32> {
        (0..STORED as i64).map(|s| (origin[a] + s).clamp(0, dims[a] as i64 - 1) as u32).collect()
    };
    let (xs, ys, zs) = (axis(0), axis(1), axis(2));
    let mut out = Vec::with_capacity(BrickData::LEN);
    for &z in &zs {
        for &y in &ys {
            out.extend(xs.iter().map(|&x| value([x, y, z])));
        }
    }
    BrickData::Voxels(out)
}

/// A level of `dims` made from a finer one of `fine` dims: each voxel the mean of the (up to
/// eight) finer voxels it covers, or the first of them ([`Coarsening`]). `row(start, len, f)`
/// calls `f` with the `len` finer values from index `start` (x fastest), in order.
fn downsample(
    (fine, dims): ([u32; 3], [u32; 3]),
    coarsening: Coarsening,
    mut row: impl FnMut(usize, usize, &mut dyn FnMut(f32)),
) -> Vec<f32> {
    let [fx, fy, fz] = fine.map(|n| n as usize);
    let [dx, dy, dz] = dims.map(|n| n as usize);
    let mut out = vec![0.0f32; dx * dy * dz];
    // How many finer voxels a coarse voxel takes along an axis: 2, or 1 at an odd edge; 1 when
    // it takes the first.
    let first = coarsening == Coarsening::First;
    let children = |i: usize, n: usize| if first { 1.0 } else { (n - 2 * i).min(2) as f32 };
    let step = if first { 2 } else { 1 };
    for z in 0..dz {
        let slice = &mut out[z * dx * dy..(z + 1) * dx * dy];
        for k in ((2 * z)..(2 * z + 2).min(fz)).step_by(step) {
            for j in (0..fy).step_by(step) {
                let sums = &mut slice[(j / 2) * dx..(j / 2 + 1) * dx];
                let mut i = 0;
                row((k * fy + j) * fx, fx, &mut |v| {
                    if !first || i % 2 == 0 {
                        sums[i / 2] += v;
                    }
                    i += 1;
                });
            }
        }
        let cz = children(z, fz);
        for y in 0..dy {
            let cy = children(y, fy);
            for (x, v) in slice[y * dx..(y + 1) * dx].iter_mut().enumerate() {
                *v /= children(x, fx) * cy * cz;
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bricks::{APRON, BRICK};
    use crate::volume::{Samples, Scaling};

    /// A volume whose voxel value encodes its position, stored as u16 with a scaling.
    fn ramp(dims: [u32; 3]) -> Volume {
        let mut data = Vec::new();
        for z in 0..dims[2] {
            for y in 0..dims[1] {
                for x in 0..dims[0] {
                    data.push((x + 3 * y + 7 * z) as u16);
                }
            }
        }
        Volume::from_samples(dims, Mat4::IDENTITY, Samples::U16(data), Scaling { slope: 2.0, intercept: -5.0 })
    }

    fn voxel(v: &Volume, [x, y, z]: [u32; 3]) -> f32 {
        v.value(((z * v.dims[1] + y) * v.dims[0] + x) as usize).unwrap()
    }

    #[test]
    fn a_bricks_interior_and_apron_are_the_volumes_voxels() {
        let volume = ramp([130, 70, 9]);
        let source = PyramidSource::from_volume(&volume, Coarsening::Mean);
        assert_eq!(source.levels()[0].bricks, [3, 2, 1]);
        let brick = source.read(0, [1, 0, 0]).unwrap();
        // Interior: stored (APRON, APRON, APRON) is voxel (64, 0, 0).
        const A: u32 = APRON;
        assert_eq!(brick.at([A, A, A]), voxel(&volume, [BRICK, 0, 0]));
        assert_eq!(brick.at([10, 20, 5]), voxel(&volume, [BRICK + 10 - A, 20 - A, 5 - A]));
        // The apron before x holds the neighbour brick's last voxels, after x the next one's first.
        assert_eq!(brick.at([0, 5, 5]), voxel(&volume, [BRICK - A, 5 - A, 5 - A]));
        assert_eq!(brick.at([STORED - 1, 5, 5]), voxel(&volume, [2 * BRICK + A - 1, 5 - A, 5 - A]));
        // Before y and z (the volume's start), and past z's 9 voxels, the edge voxel repeats.
        assert_eq!(brick.at([5, 0, 0]), voxel(&volume, [BRICK + 5 - A, 0, 0]));
        assert_eq!(brick.at([5, 3, STORED - 1]), voxel(&volume, [BRICK + 5 - A, 3 - A, 8]));
        assert_eq!(brick.at([5, 3, 30]), voxel(&volume, [BRICK + 5 - A, 3 - A, 8]));
        // The last brick along x: voxels 128, 129, then 129 repeated.
        let last = source.read(0, [2, 0, 0]).unwrap();
        assert_eq!(last.at([A + 1, A, A]), voxel(&volume, [129, 0, 0]));
        assert_eq!(last.at([40, A, A]), voxel(&volume, [129, 0, 0]));
    }

    #[test]
    fn level_one_is_the_average_of_the_children() {
        let volume = ramp([131, 5, 3]);
        let source = PyramidSource::from_volume(&volume, Coarsening::Mean);
        assert_eq!(source.levels()[1].dims, [66, 3, 2]);
        let brick = source.read(1, [0, 0, 0]).unwrap();
        let mean = |cells: &[[u32; 3]]| cells.iter().map(|&c| voxel(&volume, c)).sum::<f32>() / cells.len() as f32;
        let full: Vec<[u32; 3]> = (0..8).map(|i| [2 + (i & 1), 2 + ((i >> 1) & 1), (i >> 2) & 1]).collect();
        // Stored voxel s is level voxel s - APRON.
        const A: u32 = APRON;
        assert_eq!(brick.at([1 + A, 1 + A, A]), mean(&full));
        // At the odd edges only the existing children count: x 130 alone, y 4 alone, z 2 alone.
        assert_eq!(source.read(1, [1, 0, 0]).unwrap().at([1 + A, 2 + A, 1 + A]), mean(&[[130, 4, 2]]));
        assert_eq!(brick.at([A, 2 + A, 1 + A]), mean(&[[0, 4, 2], [1, 4, 2]]));
    }

    #[test]
    fn bricks_of_one_value_collapse_and_bad_indices_are_errors() {
        let volume = Volume::new([70, 3, 3], Mat4::IDENTITY, vec![4.0; 70 * 9]);
        let source = PyramidSource::from_volume(&volume, Coarsening::Mean);
        assert_eq!(source.read(0, [1, 0, 0]).unwrap(), BrickData::Constant(4.0));
        assert_eq!(source.read(1, [0, 0, 0]).unwrap(), BrickData::Constant(4.0));
        assert!(source.read(0, [2, 0, 0]).unwrap_err().0.contains("outside level 0"));
        assert!(source.read(5, [0, 0, 0]).unwrap_err().0.contains("level 5 does not exist"));
        assert_eq!(source.range(), [4.0, 4.0]);
    }

    #[test]
    fn an_observer_is_shown_every_level_0_brick_as_read() {
        let volume = ramp([130, 70, 9]);
        let source = PyramidSource::from_volume(&volume, Coarsening::Mean);
        let (send, seen) = std::sync::mpsc::channel();
        let send = std::sync::Mutex::new(send);
        source.observe_level0(Arc::new(move |brick, data: &BrickData| {
            send.lock().unwrap().send((brick, data.clone())).unwrap();
        }));
        let mut bricks = Vec::new();
        for _ in 0..6 {
            bricks.push(seen.recv_timeout(std::time::Duration::from_secs(10)).expect("every brick is shown"));
        }
        bricks.sort_by_key(|(brick, _)| [brick[2], brick[1], brick[0]]);
        assert_eq!(
            bricks.iter().map(|(b, _)| *b).collect::<Vec<_>>(),
            source.levels()[0].each_brick().collect::<Vec<_>>()
        );
        for (brick, data) in bricks {
            assert_eq!(data, source.read(0, brick).unwrap(), "brick {brick:?}");
        }
    }

    #[test]
    fn a_phantom_pyramid_ends_in_one_brick() {
        let volume = crate::volume::phantom("head", [96, 96, 40]).unwrap();
        let source = PyramidSource::from_volume(&volume, Coarsening::Mean);
        assert_eq!(source.levels().len(), 2);
        assert_eq!(source.levels()[1].bricks, [1, 1, 1]);
        let top = source.read(1, [0, 0, 0]).unwrap();
        // The centre of the coarse level averages the eight voxels under it.
        let c = [24u32, 24, 10];
        let mut sum = 0.0;
        for i in 0..8u32 {
            sum += voxel(&volume, [2 * c[0] + (i & 1), 2 * c[1] + ((i >> 1) & 1), 2 * c[2] + (i >> 2)]);
        }
        // Within the half float's rounding (bricks hold half floats; the phantom's smooth
        // edges reach the centre with values no half float holds exactly).
        let mean = sum / 8.0;
        assert!((top.at(c.map(|v| v + 1)) - mean).abs() <= 1e-3 * mean.abs().max(1.0), "{mean}");
        assert_eq!(source.grid_to_world(), volume.grid_to_world);
    }
}
