//! What a bricked volume is read from: its levels and one brick at a time.

use std::sync::Arc;

use glam::Mat4;

use super::{APRON, BRICK, STORED};

/// One level of a volume's mip pyramid.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Level {
    /// Voxels per axis.
    pub dims: [u32; 3],
    /// Bricks per axis: `ceil(dims / BRICK)`.
    pub bricks: [u32; 3],
}

impl Level {
    pub(crate) fn new(dims: [u32; 3]) -> Level {
        Level { dims, bricks: dims.map(|n| n.div_ceil(BRICK).max(1)) }
    }

    /// Bricks in the level.
    pub(crate) fn brick_count(&self) -> u64 {
        self.bricks.iter().map(|&n| n as u64).product()
    }

    /// Every brick of the level, x fastest.
    pub(crate) fn each_brick(&self) -> impl Iterator<Item = [u32; 3]> + use<> {
        let [nx, ny, nz] = self.bricks;
        (0..nz).flat_map(move |z| (0..ny).flat_map(move |y| (0..nx).map(move |x| [x, y, z])))
    }
}

/// The levels of a pyramid over a level-0 grid of `dims`: each halves the last (rounding up)
/// until every axis fits in one brick. Level `l`'s voxel `i` covers level 0's voxels
/// `[i * 2^l, (i + 1) * 2^l)`.
pub(crate) fn levels_for(dims: [u32; 3]) -> Vec<Level> {
    let mut levels = vec![Level::new(dims)];
    let mut scale = 1u32;
    while levels.last().is_some_and(|l| l.bricks.iter().any(|&b| b > 1)) {
        scale *= 2;
        levels.push(Level::new(dims.map(|n| n.div_ceil(scale).max(1))));
    }
    levels
}

/// One brick's voxels, read from a source.
#[derive(Clone, Debug, PartialEq)]
pub enum BrickData {
    /// Every voxel (apron included) has this value (data units): a brick that is never
    /// uploaded, its value kept in the page table. Missing chunks of a Zarr store (the fill
    /// value) come as one without being read.
    Constant(f32),
    /// `STORED`^3 values in data units, x fastest: the brick's voxels and its apron (voxels of
    /// the neighbouring bricks; at the volume's edges the edge voxel repeated, as a texture
    /// sampler clamps).
    Voxels(Vec<f32>),
}

impl BrickData {
    /// Values of a [`BrickData::Voxels`] brick.
    pub(crate) const LEN: usize = (STORED * STORED * STORED) as usize;

    /// The voxel at `[x, y, z]` of the stored brick (apron included: 0 is the outermost apron
    /// voxel before the brick's first voxel, which is at `APRON`).
    pub fn at(&self, [x, y, z]: [u32; 3]) -> f32 {
        match self {
            BrickData::Constant(v) => *v,
            BrickData::Voxels(v) => v[((z * STORED + y) * STORED + x) as usize],
        }
    }

    /// The brick's own voxel at `[x, y, z]` (0 is the brick's first voxel; the apron is not
    /// counted).
    pub fn voxel(&self, [x, y, z]: [u32; 3]) -> f32 {
        self.at([x + APRON, y + APRON, z + APRON])
    }

    /// A brick whose voxels all have one value becomes [`BrickData::Constant`].
    pub(crate) fn collapse(self) -> BrickData {
        match self {
            BrickData::Voxels(v)
                if v.first().is_some_and(|&a| v.iter().all(|&b| b == a || (a.is_nan() && b.is_nan()))) =>
            {
                BrickData::Constant(v[0])
            }
            other => other,
        }
    }
}

/// A problem reading a bricked volume: what and where, for the user.
#[derive(Clone, Debug, PartialEq)]
pub struct BrickError(pub String);

impl std::fmt::Display for BrickError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for BrickError {}

/// Shown each level-0 brick (its index and data) that a source reads of itself: what a bricked
/// volume learns of its values before it asks for any brick (see
/// [`BrickSource::observe_level0`]).
pub type Level0Observer = Arc<dyn Fn([u32; 3], &BrickData) + Send + Sync>;

/// A volume read a brick at a time. Shared with the loader threads, hence `Send + Sync`.
pub trait BrickSource: Send + Sync {
    /// The pyramid, finest first; level 0 is the volume's grid. Never empty.
    fn levels(&self) -> &[Level];

    /// Voxel index (i, j, k) of a level-0 voxel centre -> world position (mm, RAS+).
    fn grid_to_world(&self) -> Mat4;

    /// The finite value range in data units, as far as the source knows it without reading
    /// every voxel (a coarse level's range for a Zarr store).
    fn range(&self) -> [f32; 2];

    /// Brick `brick` of level `level` with its apron ([`BrickData`]). Errors name the file and
    /// the chunk; a source never allocates more than a few bricks' worth for one call.
    fn read(&self, level: usize, brick: [u32; 3]) -> Result<BrickData, BrickError>;

    /// Things the user should know that are not errors (chunks missing from a store, shown as
    /// its fill value), gathered so far.
    fn warnings(&self) -> Vec<String> {
        Vec::new()
    }

    /// Shows `observer` every level-0 brick the source reads of itself from now on: a source
    /// that builds the coarse levels it lacks reads all of level 0 for its coarsest level, and
    /// a volume in memory has it already. The default shows none (a store with a pyramid reads
    /// level 0 only where asked).
    fn observe_level0(&self, _observer: Level0Observer) {}
}

/// The first voxel (apron included) a stored brick starts at, per axis: `brick * BRICK - APRON`
/// (negative before the volume's start).
pub(crate) fn stored_origin(brick: [u32; 3]) -> [i64; 3] {
    brick.map(|b| b as i64 * BRICK as i64 - APRON as i64)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_pyramid_halves_until_one_brick() {
        let levels = levels_for([2048, 2048, 1024]);
        let dims: Vec<[u32; 3]> = levels.iter().map(|l| l.dims).collect();
        assert_eq!(
            dims,
            vec![[2048, 2048, 1024], [1024, 1024, 512], [512, 512, 256], [256, 256, 128], [128, 128, 64], [64, 64, 32]]
        );
        assert_eq!(levels[0].bricks, [32, 32, 16]);
        assert_eq!(levels_for([10, 70, 3]).len(), 2);
        assert_eq!(levels_for([1, 1, 1]), vec![Level::new([1, 1, 1])]);
    }

    #[test]
    fn bricks_of_one_value_collapse() {
        assert_eq!(BrickData::Voxels(vec![2.0; 8]).collapse(), BrickData::Constant(2.0));
        let mixed = BrickData::Voxels(vec![2.0, 3.0]);
        assert_eq!(mixed.clone().collapse(), mixed);
    }
}
