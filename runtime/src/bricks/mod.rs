//! Bricked volumes: volumes larger than a texture or than memory, split into bricks of
//! `BRICK`^3 voxels (each stored with an `APRON` of two voxels on every side, so trilinear
//! filtering is seamless across bricks and a ray's segment may reach half a voxel past its brick) in a mip pyramid, read on demand from a [`BrickSource`]
//! and kept on the GPU in a brick pool that a page table indexes (`residency`).
//!
//! Sources: Zarr v2/v3 and OME-Zarr stores (`zarr`, through the `zarrs` crate; multiscales read
//! from the file), and every other format through a pyramid built at load (`pyramid`).

mod grid;
mod lazy_levels;
pub(crate) mod loader;
pub(crate) mod mapped;
pub(crate) mod pyramid;
pub(crate) mod ranges;
pub(crate) mod residency;
pub(crate) mod source;
mod summary;
mod view_layouts;
pub mod zarr;

pub(crate) use lazy_levels::cache_bytes;
pub use residency::Residency;
pub(crate) use residency::{BrickView, BrickedVolume, BrickedVolumes};
pub(crate) use source::levels_for;
pub use source::{BrickData, BrickError, BrickSource, Level, Level0Observer};
pub(crate) use view_layouts::ViewBrickLayouts;

/// How a level a source does not store is made from the finer one (or from a finer dataset
/// of a store, a few of its voxels per voxel).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Coarsening {
    /// Each voxel the mean of the finer voxels it covers (up to eight): intensities.
    #[default]
    Mean,
    /// Each voxel the first of the finer voxels it covers (lowest x, y and z), as a
    /// nearest-neighbour downsampling keeps it: label ids, which a mean would turn into
    /// other ids.
    First,
}

/// Voxels along each edge of a brick, without its apron.
pub(crate) const BRICK: u32 = 64;

/// Voxels of neighbouring data (or repeated edge voxels) stored on each side of a brick.
pub(crate) const APRON: u32 = 2;

/// Voxels along each edge of a brick as stored: the brick and its apron on both sides.
pub(crate) const STORED: u32 = BRICK + 2 * APRON;

/// The most page-table entries a volume may have (2^24, 64 MiB of page table; see
/// [`table_entries`]): larger grids are refused when they are opened, before anything is
/// allocated for them.
pub(crate) const MAX_BRICKS: u64 = 1 << 24;

/// Page-table entries of a pyramid: a block of level 0's brick count per level (each level is
/// indexed in level 0's strides, so the lookup needs no per-level table).
pub(crate) fn table_entries(levels: &[Level]) -> u64 {
    levels.first().map_or(0, Level::brick_count) * levels.len() as u64
}

/// Locks `m`, going on with the data of a thread that panicked while holding it (loader and
/// residency state stay consistent between the statements that change them).
pub(crate) fn lock<T>(m: &std::sync::Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}
