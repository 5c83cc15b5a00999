//! A [`crate::bricks::BrickSource`] over a Zarr v2 or v3 store, on disk or over HTTP(S), through the `zarrs`
//! crate: one array, or an OME-Zarr image (NGFF v0.4 in `.zattrs`, v0.5 under `ome` in
//! `zarr.json`) whose datasets stand in for the pyramid's levels.
//!
//! - Axes: by the OME `axes` (name and type), a v3 array's `dimension_names`, or, without
//!   names, the last three as z, y, x after channel (4 axes) or time and channel (5). A time or
//!   channel axis is read at the index the [`ZarrSelection`] names (index 0 when it has one
//!   entry; more without a choice is an error that says how to choose).
//! - Levels: the pyramid is `levels_for` level 0; each dataset is placed by its coordinate
//!   transformations, and answers the levels it can (`plan.rs`: any power-of-two factors per
//!   axis, ome-zarr-py's x-y pyramids, odd sizes halved either way, translations). Levels no
//!   dataset answers are built from the level below on demand (`lazy_levels`), through a cache
//!   whose size the caller gives (part of the host budget).
//! - World: dataset 0's scale and translation (then the multiscale's), each axis in its own
//!   unit (converted to mm; `millimeter` when none), along the RAS+ direction of its RFC-4
//!   anatomical `orientation`, else x, y, z as R, A, S. A plain array has 1 mm voxels at the
//!   origin.
//! - Data types: bool, int8 to int64, uint8 to uint64, float16 to float64, as `f32` data units.
//! - Chunks left out of the store hold the fill value (zarr-python leaves out chunks that do):
//!   empty space, not an error. A brick none of whose chunks exist is
//!   [`BrickData::Constant`] without reading (a directory store's chunk files are listed once).
//! - An unreadable chunk is an error of the bricks that need it, naming the chunk (the
//!   residency draws them from the next coarser level); a level built from it takes the fill
//!   value there, with a note ([`crate::bricks::BrickSource::warnings`]).

mod dataset;
mod http;
mod ome;
mod plan;
mod store;
mod testdata;

use std::ops::Range;
#[cfg(test)]
use std::path::Path;
use std::sync::{Arc, Mutex, OnceLock};

use glam::{Mat4, Vec4};
use zarrs::array::{ArrayError, ArraySubsetTraits};

use super::grid::{GridSource, SourceGrid, spread};
use super::lazy_levels::{box_index, inside_box, stored_box, sub};
use super::pyramid::{check_brick, cut_brick};
use super::{BRICK, BrickData, BrickError, Coarsening, levels_for, lock, table_entries};
use dataset::{Dataset, Fixed, Store};
use ome::{Axis, AxisKind, Multiscale, Transform};
use plan::{LevelPlan, Placement};
use store::{Listing, Root};

pub(crate) use super::MAX_BRICKS;
pub use ome::LabelColor;
pub use store::StoreLocation;
pub use testdata::write_test_zarr;

/// The most chunks whose presence is looked up for one brick; past that (tiny chunks) the
/// brick is decoded directly, missing chunks reading as the fill value.
const MAX_CHUNK_LOOKUPS: u64 = 4096;

/// Bricks read at open to estimate the value range (see [`ZarrSource::estimate_range`]); as
/// many as [`spread`] gives over a grid of bricks.
const RANGE_BRICKS: usize = 64;

/// Notes about unreadable chunks kept (each names one).
const MAX_NOTES: usize = 32;

/// An entry of a store's list (a multiscale or a channel): its index or its name.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Choice {
    /// The entry at this position of the list.
    Index(u64),
    /// The entry of this name.
    Name(String),
}

/// What of a store a volume shows: the `[[volume]]` keys `multiscale`, `channel` and `time`.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ZarrSelection {
    /// The OME multiscale, by index or name (the first when `None`).
    pub(crate) multiscale: Option<Choice>,
    /// The channel, by index or `omero` label.
    pub channel: Option<Choice>,
    /// The time point.
    pub time: Option<u64>,
}

/// The label colours of the store at `location` when it is an OME-Zarr label image (a group
/// with `image-label` metadata; its `colors`, possibly none); `None` for any other store.
pub fn label_colors(location: &StoreLocation) -> Result<Option<Vec<LabelColor>>, BrickError> {
    let fail = |m: String| BrickError(format!("{}: {m}", location.name()));
    let opened = store::open(location).map_err(fail)?;
    Ok(match store::root_node(opened.store.as_ref()).map_err(fail)? {
        Root::Group(attributes) => ome::label_colors(&attributes),
        Root::Array(_) => None,
    })
}

/// A Zarr store read a brick at a time.
pub struct ZarrSource {
    /// The store's name (for messages), the pyramid and the world placement; the levels no
    /// dataset answers are built from the level below.
    grid: SourceGrid,
    /// The arrays read, dataset 0 (level 0) first.
    datasets: Vec<Dataset>,
    /// How each level is read.
    plans: Vec<LevelPlan>,
    /// The store's directory, when it is one (so its chunk files can be listed).
    dir: Option<std::path::PathBuf>,
    /// Per dataset, its chunk files listed once when first needed (`None`: too many, or remote).
    listings: Vec<OnceLock<Option<Listing>>>,
    /// Unreadable chunks met while building levels, once each.
    notes: Mutex<Vec<String>>,
}

/// A box of a dataset's voxels in data units, x fastest.
enum Region {
    Constant(f32),
    Voxels(Vec<f32>),
}

impl ZarrSource {
    #[cfg(test)]
    /// Opens the Zarr array or OME-Zarr image in the directory `path`, as it is (first
    /// multiscale, no time or channel chosen), with a 256 MiB cache for built levels.
    pub(crate) fn open(path: &Path) -> Result<ZarrSource, BrickError> {
        Self::open_at(&StoreLocation::Path(path.to_path_buf()), &ZarrSelection::default(), 256 << 20)
    }

    /// Checks that the store at `location` can be shown as `selection` picks it, from its
    /// metadata alone (no voxel is read): what `vrsc build` asks of a store.
    pub fn check_at(location: &StoreLocation, selection: &ZarrSelection) -> Result<(), BrickError> {
        Self::open_at(location, selection, 0).map(|_| ())
    }

    /// Opens the store at `location`, showing what `selection` picks, with `cache_bytes` for the
    /// sums of finer bricks that built levels are averaged from. Reads the metadata only: the
    /// value range ([`crate::bricks::BrickSource::range`]) reads a few coarse bricks when first asked for.
    pub fn open_at(
        location: &StoreLocation,
        selection: &ZarrSelection,
        cache_bytes: u64,
    ) -> Result<ZarrSource, BrickError> {
        let name = location.name();
        let fail = |m: String| BrickError(format!("{name}: {m}"));
        let opened = store::open(location).map_err(fail)?;
        let (datasets, transforms) = open_datasets(&opened.store, selection).map_err(fail)?;
        let levels = levels_for(datasets[0].dims);
        let entries = table_entries(&levels);
        if entries > MAX_BRICKS {
            return Err(fail(format!(
                "array `{}` of {:?} voxels (x, y, z) needs {entries} page-table entries for its bricks of {BRICK}^3, more than the {MAX_BRICKS} a volume may have",
                datasets[0].path, datasets[0].dims
            )));
        }
        let (placements, grid_to_world) = match &transforms {
            Some((axes, t)) => {
                let space = space_axes(axes);
                let placed = t.iter().zip(&datasets).map(|(d, ds)| Placement::of(d, &t[0], space, ds.dims)).collect();
                (placed, world(axes, &t[0]))
            }
            None => (vec![Placement { factor: [1.0; 3], shift: [0.0; 3], dims: datasets[0].dims }], Mat4::IDENTITY),
        };
        Ok(ZarrSource {
            plans: plan::plan_levels(levels.len(), &placements),
            grid: SourceGrid::new(name, levels, grid_to_world, cache_bytes),
            listings: datasets.iter().map(|_| OnceLock::new()).collect(),
            datasets,
            dir: opened.dir,
            notes: Mutex::new(Vec::new()),
        })
    }

    /// The source with its coarse levels made by `coarsening` (the mean by default): what
    /// label ids need ([`Coarsening::First`]). One setting for the levels read from a finer
    /// dataset and those built from the level below.
    pub fn coarsened_by(mut self, coarsening: Coarsening) -> ZarrSource {
        self.grid.lazy.coarsening = coarsening;
        self
    }

    /// How many levels a dataset answers at its own resolution; the others are averaged from
    /// a finer dataset or built from the level below.
    pub fn stored_levels(&self) -> usize {
        self.plans.iter().filter(|p| matches!(p, LevelPlan::Read { ratio: [1, 1, 1], .. })).count()
    }

    /// Remembers an unreadable chunk's note (once, at most [`MAX_NOTES`]).
    fn note(&self, message: String) {
        let mut notes = lock(&self.notes);
        if notes.len() < MAX_NOTES && !notes.contains(&message) {
            notes.push(message);
        }
    }

    /// The finite range of some bricks of the coarsest level a dataset answers: all of them
    /// when it has at most [`RANGE_BRICKS`]; else, when its dataset's chunk files are listed,
    /// the bricks at up to [`RANGE_BRICKS`] of its chunks (so a sparse store's data is seen)
    /// and the fill value; else bricks spread evenly over it. Unreadable bricks are left out.
    fn estimate_range(&self) -> [f32; 2] {
        let level = self.plans.iter().rposition(|p| matches!(p, LevelPlan::Read { .. })).unwrap_or(0);
        let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
        for brick in self.range_bricks(level) {
            // The brick's own voxels: its apron is its neighbours', and would read their chunks.
            let values = match self.read_inside(level, brick) {
                Ok(BrickData::Constant(v)) => vec![v],
                Ok(BrickData::Voxels(v)) => v,
                Err(e) => {
                    self.note(e.0);
                    continue;
                }
            };
            for v in values.into_iter().filter(|v| v.is_finite()) {
                lo = lo.min(v);
                hi = hi.max(v);
            }
        }
        // Chunks left out show the fill value.
        if let LevelPlan::Read { dataset, .. } = self.plans[level] {
            let d = &self.datasets[dataset];
            let chunks = d.array.chunk_grid_shape().iter().fold(1u64, |a, &n| a.saturating_mul(n));
            if self.listing(dataset).is_some_and(|l| (l.indices.len() as u64) < chunks) && d.fill.is_finite() {
                lo = lo.min(d.fill);
                hi = hi.max(d.fill);
            }
        }
        if lo <= hi { [lo, hi] } else { [0.0, 0.0] }
    }

    /// The bricks [`ZarrSource::estimate_range`] reads.
    fn range_bricks(&self, level: usize) -> Vec<[u32; 3]> {
        let level_info = self.grid.levels[level];
        let grid = |axis: &dyn Fn(u32) -> Vec<u32>| {
            let b = level_info.bricks;
            let mut out = Vec::new();
            for z in axis(b[2]) {
                for y in axis(b[1]) {
                    out.extend(axis(b[0]).into_iter().map(|x| [x, y, z]));
                }
            }
            out
        };
        if level_info.brick_count() <= RANGE_BRICKS as u64 {
            return grid(&|n| (0..n).collect());
        }
        let LevelPlan::Read { dataset, ratio, offset } = self.plans[level] else { return grid(&spread) };
        let Some(listing) = self.listing(dataset) else { return grid(&spread) };
        let d = &self.datasets[dataset];
        let step = listing.indices.len().div_ceil(RANGE_BRICKS).max(1);
        let mut bricks: Vec<[u32; 3]> = listing
            .indices
            .iter()
            .step_by(step)
            .filter_map(|index| d.array.chunk_subset_bounded(index).ok())
            .map(|s| {
                // The chunk's first voxel, as a voxel of the level, then its brick.
                let lo: [u32; 3] = [0, 1, 2].map(|a| s.start()[d.space_axis(a)] as u32);
                [0, 1, 2].map(|a| {
                    let v = (lo[a] as i64 - offset[a]).max(0) / ratio[a] as i64;
                    ((v as u32) / BRICK).min(level_info.bricks[a] - 1)
                })
            })
            .collect();
        bricks.sort_unstable();
        bricks.dedup();
        bricks
    }

    /// The box `[lo, hi)` (x, y, z) of dataset `d`.
    fn read_region(&self, d: usize, lo: [u32; 3], hi: [u32; 3]) -> Result<Region, BrickError> {
        let dataset = &self.datasets[d];
        let subset = dataset.subset(lo, hi);
        let chunks = dataset
            .array
            .chunks_in_array_subset(&subset)
            .map_err(|e| self.grid.error(format_args!("`{}`: {e}", dataset.path)))?
            .ok_or_else(|| self.grid.error(format_args!("`{}`: its chunk grid cannot be indexed", dataset.path)))?;
        let chunk_ranges = chunks.to_ranges();
        if chunk_count(&chunk_ranges) > MAX_CHUNK_LOOKUPS {
            let read = dataset.read_box(lo, hi);
            return read.map(Region::Voxels).map_err(|e| self.grid.error(format_args!("`{}`: {e}", dataset.path)));
        }
        let mut present = Vec::new();
        for_each_index(&chunk_ranges, |index| {
            if self.chunk_exists(d, index)? {
                present.push(index.to_vec());
            }
            Ok(())
        })?;
        if present.is_empty() {
            return Ok(Region::Constant(dataset.fill));
        }
        dataset.read_box(lo, hi).map(Region::Voxels).map_err(|e| self.diagnose(dataset, &present, e))
    }

    /// Whether chunk `index` of dataset `d` may be in the store: looked up in a directory
    /// store's listing, or on disk; a remote store answers `true` (its reads find out).
    fn chunk_exists(&self, d: usize, index: &[u64]) -> Result<bool, BrickError> {
        let key = self.datasets[d].array.chunk_key(index);
        if let Some(listing) = self.listing(d) {
            return Ok(listing.keys.contains(key.as_str()));
        }
        let Some(dir) = &self.dir else { return Ok(true) };
        Ok(dir.join(key.as_str()).exists())
    }

    /// The chunk files of dataset `d`, listed on first use (directory stores only).
    fn listing(&self, d: usize) -> Option<&Listing> {
        let dir = self.dir.as_ref()?;
        self.listings[d].get_or_init(|| store::list_chunks(dir, &self.datasets[d])).as_ref()
    }

    /// Whether dataset `d` may have a chunk in the box `[lo, hi)` (x, y, z): `true` when that
    /// is not cheap to rule out.
    fn may_have_chunks(&self, d: usize, lo: [u32; 3], hi: [u32; 3]) -> Result<bool, BrickError> {
        let dataset = &self.datasets[d];
        let Ok(Some(chunks)) = dataset.array.chunks_in_array_subset(&dataset.subset(lo, hi)) else { return Ok(true) };
        let ranges = chunks.to_ranges();
        if let Some(listing) = self.listing(d)
            && (listing.indices.len() as u64) < chunk_count(&ranges)
        {
            let inside = |i: &Vec<u64>| i.iter().zip(&ranges).all(|(v, r)| r.contains(v));
            return Ok(listing.indices.iter().any(inside));
        }
        if self.dir.is_none() || chunk_count(&ranges) > MAX_CHUNK_LOOKUPS {
            return Ok(true);
        }
        let mut any = false;
        for_each_index(&ranges, |index| {
            any |= self.chunk_exists(d, index)?;
            Ok(())
        })?;
        Ok(any)
    }

    /// An error naming the chunk at fault when one of `chunks` fails to decode alone, else
    /// `error` as it came.
    fn diagnose(&self, dataset: &Dataset, chunks: &[Vec<u64>], error: ArrayError) -> BrickError {
        for index in chunks {
            let Ok(subset) = dataset.array.chunk_subset_bounded(index) else { continue };
            if let Err(e) = dataset.read_f32(&subset as &dyn ArraySubsetTraits) {
                let key = dataset.array.chunk_key(index);
                return self.grid.error(format_args!("chunk `{key}` of `{}` cannot be read: {e}", dataset.path));
            }
        }
        self.grid.error(format_args!("`{}`: {error}", dataset.path))
    }

    /// Brick `brick` of a level a dataset answers, the voxels of `(lo, hi)` read: its stored
    /// box, or its own voxels alone ([`inside_box`]; the apron then repeats its edge voxels).
    fn read_planned(
        &self,
        level: usize,
        brick: [u32; 3],
        plan: (usize, [u32; 3], [i64; 3]),
        (lo, hi): ([u32; 3], [u32; 3]),
    ) -> Result<BrickData, BrickError> {
        let (d, ratio, offset) = plan;
        let dims = self.grid.levels[level].dims;
        let (slo, shi) = plan::source_box(lo, hi, ratio, offset, self.datasets[d].dims);
        match self.read_region(d, slo, shi)? {
            Region::Constant(v) => Ok(BrickData::Constant(v)),
            Region::Voxels(values) => {
                let level_values =
                    plan::resample(values, (slo, shi), (lo, hi), ratio, offset, self.grid.lazy.coarsening);
                let size = sub(hi, lo);
                let last = hi.map(|v| v - 1);
                let at = |p: [u32; 3]| [0, 1, 2].map(|a| p[a].clamp(lo[a], last[a]) - lo[a]);
                Ok(cut_brick(dims, brick, |p| level_values[box_index(at(p), size)]).collapse())
            }
        }
    }

    /// Brick `brick` of `level` as a built level reads it: only its own voxels are summed
    /// (`lazy_levels`), so a level a dataset answers reads them without the apron, which would
    /// decode the neighbouring chunks too (three chunks instead of one along an axis whose
    /// chunks are a brick long).
    fn read_inside(&self, level: usize, brick: [u32; 3]) -> Result<BrickData, BrickError> {
        check_brick(&self.grid.levels, level, brick).map_err(|e| self.grid.error(e))?;
        match self.plans[level] {
            LevelPlan::Read { dataset, ratio, offset } => {
                let inside = inside_box(self.grid.levels[level].dims, brick);
                self.read_planned(level, brick, (dataset, ratio, offset), inside)
            }
            LevelPlan::Built => self.build_brick(level, brick),
        }
    }

    /// Brick `brick` of a level no dataset answers: the 2x2x2 box average of the level below,
    /// read a finer brick at a time (an unreadable one counts as the fill value, noted).
    fn build_brick(&self, level: usize, brick: [u32; 3]) -> Result<BrickData, BrickError> {
        let (lo, hi) = stored_box(self.grid.levels[level].dims, brick);
        // A brick over a part of the store without chunks is its fill value, without reading
        // the finer levels in between: asked of the nearest finer level a dataset answers.
        let finer = (0..level).rev().find_map(|l| match self.plans[l] {
            LevelPlan::Read { dataset, ratio, offset } => Some((l, dataset, ratio, offset)),
            LevelPlan::Built => None,
        });
        if let Some((l, d, ratio, offset)) = finer
            && level - l < 32
        {
            let shift = level - l;
            let below = self.grid.levels[l].dims;
            let flo = lo.map(|v| v.saturating_mul(1 << shift));
            let fhi = [0, 1, 2].map(|a| hi[a].saturating_mul(1 << shift).min(below[a]));
            let (slo, shi) = plan::source_box(flo, fhi, ratio, offset, self.datasets[d].dims);
            if !self.may_have_chunks(d, slo, shi)? {
                return Ok(BrickData::Constant(self.datasets[d].fill));
            }
        }
        let fill = self.datasets[0].fill;
        let read = |l: usize, b: [u32; 3]| {
            self.read_inside(l, b).or_else(|e| {
                self.note(format!("{e}; levels built from it show the fill value {fill} there"));
                Ok(BrickData::Constant(fill))
            })
        };
        self.grid.lazy.build(&self.grid.levels, level, brick, &read)
    }
}

impl GridSource for ZarrSource {
    fn grid(&self) -> &SourceGrid {
        &self.grid
    }

    fn range_on_demand(&self) -> [f32; 2] {
        self.estimate_range()
    }

    fn read_brick(&self, level: usize, brick: [u32; 3]) -> Result<BrickData, BrickError> {
        match self.plans[level] {
            LevelPlan::Read { dataset, ratio, offset } => {
                let stored = stored_box(self.grid.levels[level].dims, brick);
                self.read_planned(level, brick, (dataset, ratio, offset), stored)
            }
            LevelPlan::Built => self.build_brick(level, brick),
        }
    }

    fn notes(&self) -> Vec<String> {
        lock(&self.notes).clone()
    }
}

/// The store's datasets (dataset 0 first) with the chosen time point and channel, and, for an
/// OME image, its axes and the datasets' transforms.
type Datasets = (Vec<Dataset>, Option<(Vec<Axis>, Vec<Transform>)>);

fn open_datasets(store: &Arc<Store>, selection: &ZarrSelection) -> Result<Datasets, String> {
    match store::root_node(store.as_ref())? {
        Root::Array(names) => {
            if let Some(choice) = &selection.multiscale {
                return Err(format!("`multiscale = {}` chooses a multiscale, but the store is one array", choice));
            }
            let array = zarrs::array::Array::open(store.clone(), "/").map_err(|e| format!("array `/`: {e}"))?;
            let ndim = array.shape().len();
            let axes = if names.len() == ndim && !names.is_empty() {
                ome::named_axes(&names)?
            } else {
                ome::unnamed_axes(ndim)?
            };
            let fixed = fixed_indices(selection, &[])?;
            Ok((vec![Dataset::from_array(array, "", &axes, fixed)?], None))
        }
        Root::Group(attributes) => {
            let chosen = ome::choose(&attributes, selection.multiscale.as_ref())?;
            let paths = ome::dataset_paths(chosen)?;
            let first = zarrs::array::Array::open(store.clone(), &format!("/{}", paths[0]))
                .map_err(|e| format!("array `{}`: {e}", paths[0]))?;
            let multiscale = Multiscale::parse(chosen, &attributes, first.shape().len())?;
            let fixed = fixed_indices(selection, &multiscale.channel_labels)?;
            let mut datasets = vec![Dataset::from_array(first, &paths[0], &multiscale.axes, fixed)?];
            for meta in &multiscale.datasets[1..] {
                datasets.push(Dataset::open(store, &meta.path, &multiscale.axes, fixed)?);
            }
            let transforms = multiscale.datasets.iter().map(|d| d.transform.clone()).collect();
            Ok((datasets, Some((multiscale.axes, transforms))))
        }
    }
}

/// The time point and channel index `selection` names (a channel by its label in `labels`).
fn fixed_indices(selection: &ZarrSelection, labels: &[String]) -> Result<Fixed, String> {
    let channel = match &selection.channel {
        None => None,
        Some(Choice::Index(i)) => Some(*i),
        Some(Choice::Name(n)) => Some(labels.iter().position(|l| l == n).map(|i| i as u64).ok_or_else(|| {
            let known: Vec<&str> = labels.iter().map(String::as_str).filter(|l| !l.is_empty()).collect();
            if known.is_empty() {
                format!("`channel = \"{n}\"`: the image names no channels; choose one by index")
            } else {
                format!("`channel = \"{n}\"` is not one of the image's channels: {}", known.join(", "))
            }
        })?),
    };
    Ok(Fixed { time: selection.time, channel })
}

impl std::fmt::Display for Choice {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Choice::Index(i) => write!(f, "{i}"),
            Choice::Name(n) => write!(f, "\"{n}\""),
        }
    }
}

/// The array axes of x, y and z.
fn space_axes(axes: &[Axis]) -> [usize; 3] {
    let mut out = [0; 3];
    for (i, axis) in axes.iter().enumerate() {
        if let AxisKind::Space(s) = axis.kind {
            out[s] = i;
        }
    }
    out
}

/// Dataset 0's voxel index (x, y, z) to patient space (mm, RAS+): each axis scaled and
/// translated in its unit, converted to mm, along its direction.
fn world(axes: &[Axis], t0: &Transform) -> Mat4 {
    let space = space_axes(axes);
    let column = |a: usize| {
        let axis = &axes[space[a]];
        let s = (t0.scale[space[a]] * axis.mm) as f32;
        Vec4::new(axis.direction[0] as f32 * s, axis.direction[1] as f32 * s, axis.direction[2] as f32 * s, 0.0)
    };
    let mut offset = Vec4::new(0.0, 0.0, 0.0, 1.0);
    for a in 0..3 {
        let axis = &axes[space[a]];
        let t = (t0.translation[space[a]] * axis.mm) as f32;
        offset += Vec4::new(axis.direction[0] as f32, axis.direction[1] as f32, axis.direction[2] as f32, 0.0) * t;
    }
    Mat4::from_cols(column(0), column(1), column(2), offset)
}

fn chunk_count(ranges: &[Range<u64>]) -> u64 {
    ranges.iter().map(|r| r.end - r.start).fold(1u64, |a, n| a.saturating_mul(n))
}

/// Calls `f` with every index of the box of `ranges` (last axis fastest).
fn for_each_index<E>(ranges: &[Range<u64>], mut f: impl FnMut(&[u64]) -> Result<(), E>) -> Result<(), E> {
    if ranges.iter().any(|r| r.is_empty()) {
        return Ok(());
    }
    let mut index: Vec<u64> = ranges.iter().map(|r| r.start).collect();
    loop {
        f(&index)?;
        // Advance like an odometer from the last axis.
        let mut axis = ranges.len();
        loop {
            if axis == 0 {
                return Ok(());
            }
            axis -= 1;
            index[axis] += 1;
            if index[axis] < ranges[axis].end {
                break;
            }
            index[axis] = ranges[axis].start;
        }
    }
}

#[cfg(test)]
mod tests;
