//! What the sources opened from a file or a store share ([`super::mapped::MappedSource`],
//! [`super::zarr::ZarrSource`]): a name for messages, the pyramid, the placement in the world,
//! the value range and the cache coarse levels are built through ([`SourceGrid`]); and the
//! [`BrickSource`] getters over them, written once for every [`GridSource`].

use glam::Mat4;
use std::sync::OnceLock;

use super::lazy_levels::LazyLevels;
use super::pyramid::check_brick;
use super::{BrickData, BrickError, BrickSource, Level, Level0Observer};

/// Bricks per axis read at open to estimate the value range (at most 4^3; see [`spread`]).
pub(super) const RANGE_BRICKS_PER_AXIS: u32 = 4;

/// The geometry and value range of a source opened from a file or a store.
pub(super) struct SourceGrid {
    /// The file's or store's name, for messages.
    pub(super) name: String,
    /// The pyramid over level 0's grid ([`super::levels_for`]).
    pub(super) levels: Vec<Level>,
    /// Level-0 voxel index -> world position (mm, RAS+).
    pub(super) grid_to_world: Mat4,
    /// The value range: estimated at open, or when first asked for
    /// ([`GridSource::range_on_demand`]).
    pub(super) range: OnceLock<[f32; 2]>,
    /// Builds the levels not read from the source from the level below.
    pub(super) lazy: LazyLevels,
}

impl SourceGrid {
    /// The grid of a source called `name` with the pyramid `levels` placed by `grid_to_world`,
    /// building coarse levels through a cache of `cache_bytes`; its range is set once the
    /// source can read bricks.
    pub(super) fn new(name: String, levels: Vec<Level>, grid_to_world: Mat4, cache_bytes: u64) -> SourceGrid {
        SourceGrid { name, levels, grid_to_world, range: OnceLock::new(), lazy: LazyLevels::new(cache_bytes) }
    }

    /// An error about the source: `message` after its name.
    pub(super) fn error(&self, message: impl std::fmt::Display) -> BrickError {
        BrickError(format!("{}: {message}", self.name))
    }
}

/// A source with a [`SourceGrid`]: it reads bricks that exist, and is a [`BrickSource`].
pub(super) trait GridSource: Send + Sync {
    /// Its geometry and value range.
    fn grid(&self) -> &SourceGrid;

    /// Brick `brick` of level `level`, both known to exist ([`BrickSource::read`]).
    fn read_brick(&self, level: usize, brick: [u32; 3]) -> Result<BrickData, BrickError>;

    /// The value range when it is first asked for, where the source did not estimate it at
    /// open (a store leaves it until then: its estimate reads coarse bricks, which nothing
    /// needs before the first picture).
    fn range_on_demand(&self) -> [f32; 2] {
        [0.0, 0.0]
    }

    /// [`BrickSource::warnings`]: none unless the source keeps some.
    fn notes(&self) -> Vec<String> {
        Vec::new()
    }
}

impl<S: GridSource> BrickSource for S {
    fn levels(&self) -> &[Level] {
        &self.grid().levels
    }

    fn grid_to_world(&self) -> Mat4 {
        self.grid().grid_to_world
    }

    fn range(&self) -> [f32; 2] {
        *self.grid().range.get_or_init(|| self.range_on_demand())
    }

    fn read(&self, level: usize, brick: [u32; 3]) -> Result<BrickData, BrickError> {
        check_brick(&self.grid().levels, level, brick).map_err(|e| self.grid().error(e))?;
        self.read_brick(level, brick)
    }

    fn warnings(&self) -> Vec<String> {
        self.notes()
    }

    fn observe_level0(&self, observer: Level0Observer) {
        self.grid().lazy.observe_level0(observer);
    }
}

/// Up to [`RANGE_BRICKS_PER_AXIS`] brick indices spread evenly over `n` bricks, both ends
/// included.
pub(super) fn spread(n: u32) -> Vec<u32> {
    let k = RANGE_BRICKS_PER_AXIS.min(n);
    let mut v: Vec<u32> = (0..k).map(|i| if k == 1 { 0 } else { i * (n - 1) / (k - 1) }).collect();
    v.dedup();
    v
}
