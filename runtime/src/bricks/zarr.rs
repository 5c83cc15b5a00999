//! A [`BrickSource`] over a Zarr v2 or v3 store on disk, through the `zarrs` crate: one array,
//! or an OME-Zarr group (v0.4 `multiscales` in `.zattrs`, v0.5 under `ome` in `zarr.json`)
//! whose datasets are the pyramid's levels.
//!
//! - Axes: Zarr arrays are C order (last axis fastest), so an array of shape `[z, y, x]` is a
//!   grid of dims `[x, y, z]`. Leading axes (OME `t`, `c`, or unnamed) must have size 1 and are
//!   read at index 0.
//! - Levels: dataset `i + 1` must be dataset `i` halved, rounding up (what [`levels_for`]
//!   expects); datasets past the one-brick level are ignored. A store with fewer levels than
//!   [`levels_for`] gives (a single array, say) gets the missing coarse levels built on demand:
//!   each brick the 2x2x2 box average of the next finer level's bricks, which are kept in a
//!   cache bounded by [`CACHE_BYTES`] (`lazy_levels`, shared with the memory-mapped source).
//! - World: the OME `scale` and `translation` (of dataset 0, then of the multiscale) give the
//!   grid-to-world transform, in the unit of the x axis (`millimeter` when none is named;
//!   `micrometer`, `nanometer`, `centimeter`, `meter` are converted to mm). No axis is flipped:
//!   Zarr has no anatomical orientation, so x, y, z are taken as R, A, S. A plain array has 1 mm
//!   voxels at the origin.
//! - Data types: int8/16/32, uint8/16/32 and float32/64, converted to `f32` data units.
//! - Missing chunks: before a brick is decoded, the chunks under it are looked up in the store;
//!   a brick none of whose chunks exist is [`BrickData::Constant`] of the fill value without
//!   reading, and the missing chunks are counted for [`BrickSource::warnings`]. Memory stays
//!   bounded by what one brick's chunks decode to, whatever shape the metadata claims.

use std::collections::HashSet;
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, OnceLock};

use glam::{Mat4, Vec3, Vec4};
use serde_json::{Value, json};
use zarrs::array::data_type::{
    Float32DataType, Float64DataType, Int8DataType, Int16DataType, Int32DataType, UInt8DataType, UInt16DataType,
    UInt32DataType,
};
use zarrs::array::{Array, ArrayError, ArrayMetadata, ArraySubsetTraits, DataType, ElementOwned};
use zarrs::filesystem::FilesystemStore;
use zarrs::storage::ReadableStorageTraits;

#[cfg(test)]
use super::lazy_levels::BrickCache;
pub use super::lazy_levels::CACHE_BYTES;
use super::lazy_levels::{LazyLevels, box_index, stored_box, sub};
use super::pyramid::{check_brick, cut_brick};
use super::{BRICK, BrickData, BrickError, BrickSource, Level, levels_for, table_entries};

pub use super::MAX_BRICKS;

/// The most chunks whose presence is looked up for one brick; past that (tiny chunks) the
/// brick is decoded directly, missing chunks reading as the fill value uncounted.
const MAX_CHUNK_LOOKUPS: u64 = 4096;

/// Missing chunks remembered per level (for the count in the warnings).
const MAX_MISSING_KEPT: usize = 1 << 20;

/// The most chunk files of a level that are listed once (a set of their keys); a level with
/// more looks each chunk up.
const MAX_LISTED_CHUNKS: u64 = 1 << 21;

/// Bricks read at open to estimate the value range (see [`ZarrSource::estimate_range`]).
const RANGE_BRICKS: usize = 64;

/// [`RANGE_BRICKS`] spread over a grid of bricks: this many per axis.
const RANGE_BRICKS_PER_AXIS: u32 = 4;

/// Metadata files larger than this are refused rather than read.
const MAX_METADATA_BYTES: u64 = 16 << 20;

/// A Zarr store read a brick at a time.
pub struct ZarrSource {
    /// The store's file name, for messages.
    name: String,
    /// Its directory.
    root: PathBuf,
    levels: Vec<Level>,
    /// The levels the store holds, finest first (`scales.len() <= levels.len()`).
    scales: Vec<Scale>,
    store: Arc<FilesystemStore>,
    grid_to_world: Mat4,
    range: [f32; 2],
    /// Per stored level, the chunks found missing so far.
    missing: Mutex<Vec<HashSet<Vec<u64>>>>,
    /// Builds the levels the store lacks from bricks of finer levels.
    lazy: LazyLevels,
    /// Per stored level, its chunk files listed once when first needed (`None`: too many).
    listings: Vec<OnceLock<Option<Listing>>>,
}

/// The chunks a stored level has on disk.
struct Listing {
    keys: HashSet<String>,
    /// Their indices (all axes, leading ones included).
    indices: Vec<Vec<u64>>,
}

/// One array of the store: a level of the pyramid.
struct Scale {
    array: Array<FilesystemStore>,
    /// Its path in the store, for messages.
    path: String,
    dtype: Dtype,
    fill: f32,
    /// Leading axes (size 1) before z, y, x.
    lead: usize,
}

/// The data types read, each converted to `f32`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Dtype {
    I8,
    I16,
    I32,
    U8,
    U16,
    U32,
    F32,
    F64,
}

/// A box of a level's voxels in data units, x fastest.
enum Region {
    Constant(f32),
    Voxels(Vec<f32>),
}

impl ZarrSource {
    /// Opens the Zarr array or OME-Zarr group at `path` (a directory), reading its metadata and
    /// a few coarse bricks for the value range.
    pub fn open(path: &Path) -> Result<ZarrSource, BrickError> {
        let name = path.file_name().map_or_else(|| path.display().to_string(), |n| n.to_string_lossy().into_owned());
        let fail = |m: String| BrickError(format!("{name}: {m}"));
        if !path.is_dir() {
            return Err(fail(format!("{} is not a directory (a Zarr store is one)", path.display())));
        }
        let store = Arc::new(FilesystemStore::new(path).map_err(|e| fail(e.to_string()))?);
        let (datasets, world) = match root_node(path).map_err(fail)? {
            Root::Array => (vec![String::new()], None),
            Root::Group(attributes) => {
                let multiscale = multiscale_of(&attributes).map_err(fail)?;
                let datasets = dataset_paths(multiscale).map_err(fail)?;
                (datasets, Some(multiscale.clone()))
            }
        };
        let scales = open_scales(&store, &datasets).map_err(fail)?;
        let levels = check_levels(&scales).map_err(fail)?;
        let grid_to_world = match &world {
            Some(m) => world_of(m, scales[0].array.shape().len()).map_err(fail)?,
            None => Mat4::IDENTITY,
        };
        let mut source = ZarrSource {
            name,
            root: path.to_path_buf(),
            missing: Mutex::new(vec![HashSet::new(); scales.len().min(levels.len())]),
            scales: scales.into_iter().take(levels.len()).collect(),
            levels,
            store,
            grid_to_world,
            range: [0.0, 0.0],
            lazy: LazyLevels::new(CACHE_BYTES),
            listings: Vec::new(),
        };
        source.listings = source.scales.iter().map(|_| OnceLock::new()).collect();
        source.range = source.estimate_range()?;
        Ok(source)
    }

    /// How many levels the store holds; the others are built from them.
    pub fn stored_levels(&self) -> usize {
        self.scales.len()
    }

    fn error(&self, message: impl std::fmt::Display) -> BrickError {
        BrickError(format!("{}: {message}", self.name))
    }

    /// The finite range of some bricks of the coarsest stored level: all of them when it has
    /// at most [`RANGE_BRICKS`]; else, when its chunk files are listed, the bricks at up to
    /// [`RANGE_BRICKS`] of its chunks (so a sparse store's data is seen) and the fill value;
    /// else bricks spread evenly over it.
    fn estimate_range(&self) -> Result<[f32; 2], BrickError> {
        let level = self.scales.len() - 1;
        let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
        for brick in self.range_bricks(level) {
            let values = match self.read(level, brick)? {
                BrickData::Constant(v) => vec![v],
                BrickData::Voxels(v) => v,
            };
            for v in values.into_iter().filter(|v| v.is_finite()) {
                lo = lo.min(v);
                hi = hi.max(v);
            }
        }
        // Missing chunks show the fill value.
        let scale = &self.scales[level];
        let chunks = scale.array.chunk_grid_shape().iter().fold(1u64, |a, &n| a.saturating_mul(n));
        if self.listing(level).is_some_and(|l| (l.indices.len() as u64) < chunks) && scale.fill.is_finite() {
            lo = lo.min(scale.fill);
            hi = hi.max(scale.fill);
        }
        Ok(if lo <= hi { [lo, hi] } else { [0.0, 0.0] })
    }

    /// The bricks [`ZarrSource::estimate_range`] reads.
    fn range_bricks(&self, level: usize) -> Vec<[u32; 3]> {
        let level_info = self.levels[level];
        let spread = |n: u32| -> Vec<u32> {
            let k = RANGE_BRICKS_PER_AXIS.min(n);
            let mut v: Vec<u32> = (0..k).map(|i| if k == 1 { 0 } else { i * (n - 1) / (k - 1) }).collect();
            v.dedup();
            v
        };
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
        let scale = &self.scales[level];
        let Some(listing) = self.listing(level) else { return grid(&spread) };
        let step = listing.indices.len().div_ceil(RANGE_BRICKS).max(1);
        let mut bricks: Vec<[u32; 3]> = listing
            .indices
            .iter()
            .step_by(step)
            .filter_map(|index| scale.array.chunk_origin(index).ok())
            .map(|o| {
                let o = &o[scale.lead..];
                [0, 1, 2].map(|a| (o[2 - a] / BRICK as u64) as u32)
            })
            .collect();
        bricks.sort_unstable();
        bricks.dedup();
        bricks
    }

    /// The box `[lo, hi)` (x, y, z) of stored level `level`.
    fn read_region(&self, level: usize, lo: [u32; 3], hi: [u32; 3]) -> Result<Region, BrickError> {
        let scale = &self.scales[level];
        let subset = scale.subset(lo, hi);
        let chunks = scale
            .array
            .chunks_in_array_subset(&subset)
            .map_err(|e| self.error(format_args!("`{}`: {e}", scale.path)))?
            .ok_or_else(|| self.error(format_args!("`{}`: its chunk grid cannot be indexed", scale.path)))?;
        let chunk_ranges = chunks.to_ranges();
        if chunk_count(&chunk_ranges) <= MAX_CHUNK_LOOKUPS {
            let mut present = Vec::new();
            let mut absent = Vec::new();
            for_each_index(&chunk_ranges, |index| {
                match self.chunk_exists(level, index)? {
                    true => present.push(index.to_vec()),
                    false => absent.push(index.to_vec()),
                }
                Ok(())
            })?;
            self.note_missing(level, absent);
            if present.is_empty() {
                return Ok(Region::Constant(scale.fill));
            }
            scale.read_f32(&subset).map(Region::Voxels).map_err(|e| self.diagnose(scale, &present, e))
        } else {
            scale.read_f32(&subset).map(Region::Voxels).map_err(|e| self.error(format_args!("`{}`: {e}", scale.path)))
        }
    }

    /// Whether chunk `index` of stored level `level` is in the store.
    fn chunk_exists(&self, level: usize, index: &[u64]) -> Result<bool, BrickError> {
        let key = self.scales[level].array.chunk_key(index);
        if let Some(listing) = self.listing(level) {
            return Ok(listing.keys.contains(key.as_str()));
        }
        self.store.size_key(&key).map(|s| s.is_some()).map_err(|e| self.error(format_args!("chunk `{key}`: {e}")))
    }

    /// The chunk files of stored level `level`, listed on first use when the level has at most
    /// [`MAX_LISTED_CHUNKS`] chunk files (so the listing's memory is bounded).
    fn listing(&self, level: usize) -> Option<&Listing> {
        self.listings[level].get_or_init(|| list_chunks(&self.root, &self.scales[level])).as_ref()
    }

    /// Whether stored level `level` may have a chunk in the box `[lo, hi)` (x, y, z): `true`
    /// when that is not cheap to rule out.
    fn may_have_chunks(&self, level: usize, lo: [u32; 3], hi: [u32; 3]) -> Result<bool, BrickError> {
        let scale = &self.scales[level];
        let Ok(Some(chunks)) = scale.array.chunks_in_array_subset(&scale.subset(lo, hi)) else { return Ok(true) };
        let ranges = chunks.to_ranges();
        if let Some(listing) = self.listing(level)
            && (listing.indices.len() as u64) < chunk_count(&ranges)
        {
            let inside = |i: &Vec<u64>| i.iter().zip(&ranges).all(|(v, r)| r.contains(v));
            return Ok(listing.indices.iter().any(inside));
        }
        if chunk_count(&ranges) > MAX_CHUNK_LOOKUPS {
            return Ok(true);
        }
        let mut any = false;
        for_each_index(&ranges, |index| {
            any |= self.chunk_exists(level, index)?;
            Ok(())
        })?;
        Ok(any)
    }

    /// An error naming the chunk at fault when one of `chunks` fails to decode alone, else
    /// `error` as it came.
    fn diagnose(&self, scale: &Scale, chunks: &[Vec<u64>], error: ArrayError) -> BrickError {
        for index in chunks {
            let Ok(subset) = scale.array.chunk_subset_bounded(index) else { continue };
            if let Err(e) = scale.read_f32(&subset) {
                let key = scale.array.chunk_key(index);
                return self.error(format_args!("chunk `{key}` of `{}` cannot be read: {e}", scale.path));
            }
        }
        self.error(format_args!("`{}`: {error}", scale.path))
    }

    fn note_missing(&self, level: usize, absent: Vec<Vec<u64>>) {
        if absent.is_empty() {
            return;
        }
        let mut missing = self.missing.lock().unwrap_or_else(|e| e.into_inner());
        let seen = &mut missing[level];
        for index in absent {
            if seen.len() >= MAX_MISSING_KEPT {
                break;
            }
            seen.insert(index);
        }
    }

    /// Brick `brick` of a stored level.
    fn read_stored(&self, level: usize, brick: [u32; 3]) -> Result<BrickData, BrickError> {
        let dims = self.levels[level].dims;
        let (lo, hi) = stored_box(dims, brick);
        let size = sub(hi, lo);
        match self.read_region(level, lo, hi)? {
            Region::Constant(v) => Ok(BrickData::Constant(v)),
            Region::Voxels(data) => Ok(cut_brick(dims, brick, |p| data[box_index(sub(p, lo), size)]).collapse()),
        }
    }

    /// Brick `brick` of a level the store lacks: the 2x2x2 box average of the finer level (the
    /// mean of the existing children at odd edges), read a finer brick at a time.
    fn build_brick(&self, level: usize, brick: [u32; 3]) -> Result<BrickData, BrickError> {
        let dims = self.levels[level].dims;
        let (lo, hi) = stored_box(dims, brick);
        // A brick over a part of the store without chunks is its fill value, without reading
        // the finer levels in between.
        let stored = self.scales.len() - 1;
        let shift = level - stored;
        if shift < 32 {
            let below = self.levels[stored].dims;
            let slo = lo.map(|v| v.saturating_mul(1 << shift));
            let shi = [0, 1, 2].map(|a| hi[a].saturating_mul(1 << shift).min(below[a]));
            if !self.may_have_chunks(stored, slo, shi)? {
                return Ok(BrickData::Constant(self.scales[stored].fill));
            }
        }
        self.lazy.build(&self.levels, level, brick, &|l, b| self.read(l, b))
    }
}

impl BrickSource for ZarrSource {
    fn levels(&self) -> &[Level] {
        &self.levels
    }

    fn grid_to_world(&self) -> Mat4 {
        self.grid_to_world
    }

    fn range(&self) -> [f32; 2] {
        self.range
    }

    fn read(&self, level: usize, brick: [u32; 3]) -> Result<BrickData, BrickError> {
        check_brick(&self.levels, level, brick).map_err(|e| self.error(e))?;
        if level < self.scales.len() { self.read_stored(level, brick) } else { self.build_brick(level, brick) }
    }

    fn warnings(&self) -> Vec<String> {
        let missing = self.missing.lock().unwrap_or_else(|e| e.into_inner());
        let mut out = Vec::new();
        for (level, seen) in missing.iter().enumerate().filter(|(_, s)| !s.is_empty()) {
            let scale = &self.scales[level];
            let at_least = if seen.len() >= MAX_MISSING_KEPT { "at least " } else { "" };
            out.push(format!(
                "{}: {at_least}{} chunks of level {level} (`{}`) are missing; shown as the fill value {}",
                self.name,
                seen.len(),
                scale.path,
                scale.fill
            ));
        }
        out
    }
}

impl Scale {
    /// The array subset of the box `[lo, hi)` (x, y, z): index 0 of the leading axes, then z, y, x.
    fn subset(&self, lo: [u32; 3], hi: [u32; 3]) -> Vec<Range<u64>> {
        let mut ranges = vec![0..1; self.lead];
        ranges.extend((0..3).rev().map(|a| lo[a] as u64..hi[a] as u64));
        ranges
    }

    /// The subset's values in data units, x fastest.
    fn read_f32(&self, subset: &dyn ArraySubsetTraits) -> Result<Vec<f32>, ArrayError> {
        fn get<T: ElementOwned + Copy>(
            array: &Array<FilesystemStore>,
            subset: &dyn ArraySubsetTraits,
            f: impl Fn(T) -> f32,
        ) -> Result<Vec<f32>, ArrayError> {
            Ok(array.retrieve_array_subset::<Vec<T>>(subset)?.into_iter().map(f).collect())
        }
        let a = &self.array;
        match self.dtype {
            Dtype::I8 => get(a, subset, |v: i8| v as f32),
            Dtype::I16 => get(a, subset, |v: i16| v as f32),
            Dtype::I32 => get(a, subset, |v: i32| v as f32),
            Dtype::U8 => get(a, subset, |v: u8| v as f32),
            Dtype::U16 => get(a, subset, |v: u16| v as f32),
            Dtype::U32 => get(a, subset, |v: u32| v as f32),
            Dtype::F32 => get(a, subset, |v: f32| v),
            Dtype::F64 => get(a, subset, |v: f64| v as f32),
        }
    }
}

impl Dtype {
    fn of(data_type: &DataType) -> Option<Dtype> {
        let d = data_type;
        Some(if d.is::<Int8DataType>() {
            Dtype::I8
        } else if d.is::<Int16DataType>() {
            Dtype::I16
        } else if d.is::<Int32DataType>() {
            Dtype::I32
        } else if d.is::<UInt8DataType>() {
            Dtype::U8
        } else if d.is::<UInt16DataType>() {
            Dtype::U16
        } else if d.is::<UInt32DataType>() {
            Dtype::U32
        } else if d.is::<Float32DataType>() {
            Dtype::F32
        } else if d.is::<Float64DataType>() {
            Dtype::F64
        } else {
            return None;
        })
    }

    /// A value of this type from its native-endian bytes (0 when they do not fit).
    fn decode(self, b: &[u8]) -> f32 {
        fn arr<const N: usize>(b: &[u8]) -> Option<[u8; N]> {
            b.try_into().ok()
        }
        let v = match self {
            Dtype::I8 => arr::<1>(b).map(|a| i8::from_ne_bytes(a) as f32),
            Dtype::I16 => arr::<2>(b).map(|a| i16::from_ne_bytes(a) as f32),
            Dtype::I32 => arr::<4>(b).map(|a| i32::from_ne_bytes(a) as f32),
            Dtype::U8 => arr::<1>(b).map(|a| a[0] as f32),
            Dtype::U16 => arr::<2>(b).map(|a| u16::from_ne_bytes(a) as f32),
            Dtype::U32 => arr::<4>(b).map(|a| u32::from_ne_bytes(a) as f32),
            Dtype::F32 => arr::<4>(b).map(f32::from_ne_bytes),
            Dtype::F64 => arr::<8>(b).map(|a| f64::from_ne_bytes(a) as f32),
        };
        v.unwrap_or(0.0)
    }
}

/// What the store's root is.
enum Root {
    Array,
    /// A group, with its attributes.
    Group(Value),
}

/// Reads the root metadata (v3 `zarr.json`, v2 `.zarray` / `.zgroup` + `.zattrs`).
fn root_node(dir: &Path) -> Result<Root, String> {
    if let Some(meta) = read_json(&dir.join("zarr.json"))? {
        return match meta.get("node_type").and_then(Value::as_str) {
            Some("array") => Ok(Root::Array),
            Some("group") => Ok(Root::Group(meta.get("attributes").cloned().unwrap_or(json!({})))),
            other => Err(format!("zarr.json: `node_type` is {other:?}, not \"array\" or \"group\"")),
        };
    }
    if dir.join(".zarray").is_file() {
        return Ok(Root::Array);
    }
    if dir.join(".zgroup").is_file() {
        return Ok(Root::Group(read_json(&dir.join(".zattrs"))?.unwrap_or(json!({}))));
    }
    Err("not a Zarr store: it has no zarr.json, .zarray or .zgroup".into())
}

/// A JSON file, `None` when it does not exist.
fn read_json(path: &Path) -> Result<Option<Value>, String> {
    let name = path.file_name().unwrap_or_default().to_string_lossy();
    let len = match std::fs::metadata(path) {
        Ok(m) => m.len(),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(format!("{name}: {e}")),
    };
    if len > MAX_METADATA_BYTES {
        return Err(format!("{name}: {len} bytes is too large for metadata"));
    }
    let text = std::fs::read(path).map_err(|e| format!("{name}: {e}"))?;
    serde_json::from_slice(&text).map(Some).map_err(|e| format!("{name}: not valid JSON: {e}"))
}

/// The first OME multiscale of a group's attributes (v0.5 under `ome`, v0.4 at the top).
fn multiscale_of(attributes: &Value) -> Result<&Value, String> {
    let list = attributes
        .get("ome")
        .and_then(|o| o.get("multiscales"))
        .or_else(|| attributes.get("multiscales"))
        .ok_or("a group without OME-Zarr `multiscales` metadata: open one of its arrays instead")?;
    list.as_array().and_then(|l| l.first()).ok_or_else(|| "`multiscales` is not a non-empty list".to_string())
}

fn dataset_paths(multiscale: &Value) -> Result<Vec<String>, String> {
    let datasets = multiscale
        .get("datasets")
        .and_then(Value::as_array)
        .filter(|d| !d.is_empty())
        .ok_or("`multiscales[0].datasets` is not a non-empty list")?;
    datasets
        .iter()
        .enumerate()
        .map(|(i, d)| {
            d.get("path")
                .and_then(Value::as_str)
                .map(|p| p.trim_matches('/').to_string())
                .ok_or_else(|| format!("`datasets[{i}]` has no `path`"))
        })
        .collect()
}

/// Opens each dataset and checks its shape and type.
fn open_scales(store: &Arc<FilesystemStore>, datasets: &[String]) -> Result<Vec<Scale>, String> {
    datasets.iter().map(|path| open_scale(store, path)).collect()
}

fn open_scale(store: &Arc<FilesystemStore>, path: &str) -> Result<Scale, String> {
    let shown = if path.is_empty() { "/".to_string() } else { path.to_string() };
    let array = Array::open(store.clone(), &format!("/{path}")).map_err(|e| format!("array `{shown}`: {e}"))?;
    let dtype = Dtype::of(array.data_type()).ok_or_else(|| {
        format!(
            "array `{shown}` has data type {}; volumes must be int8/16/32, uint8/16/32, float32 or float64",
            array.data_type()
        )
    })?;
    let shape = array.shape();
    if !(3..=5).contains(&shape.len()) {
        return Err(format!("array `{shown}` has {} axes ({shape:?}); a volume needs 3 (z, y, x)", shape.len()));
    }
    let lead = shape.len() - 3;
    if let Some(n) = shape[..lead].iter().find(|&&n| n != 1) {
        return Err(format!(
            "array `{shown}` has shape {shape:?}: the axes before z, y, x (time, channel) must have size 1, not {n}"
        ));
    }
    if let Some(n) = shape[lead..].iter().find(|&&n| n == 0 || n > u32::MAX as u64) {
        return Err(format!("array `{shown}` has shape {shape:?}: an axis of {n} voxels"));
    }
    let fill = dtype.decode(array.fill_value().as_ne_bytes());
    Ok(Scale { array, path: shown, dtype, fill, lead })
}

/// The chunk files of `scale` in the store at `root` (see [`ZarrSource::listing`]): the
/// array's directory walked, giving up (`None`) past [`MAX_LISTED_CHUNKS`] files so that memory
/// stays bounded whatever the store holds.
fn list_chunks(root: &Path, scale: &Scale) -> Option<Listing> {
    let grid = scale.array.chunk_grid_shape();
    let prefix = if scale.path == "/" { String::new() } else { format!("{}/", scale.path) };
    let mut keys = Vec::new();
    walk(&root.join(&prefix), &prefix, &mut keys)?;
    let mut listing = Listing { keys: HashSet::new(), indices: Vec::new() };
    for key in keys {
        // Files that are not chunks (metadata) fail the round trip through the key encoding.
        let rest = &key[prefix.len()..];
        let rest = rest.strip_prefix("c/").or_else(|| rest.strip_prefix("c.")).unwrap_or(rest);
        let index: Option<Vec<u64>> = rest.split(['/', '.']).map(|p| p.parse().ok()).collect();
        let Some(index) = index.filter(|i| i.len() == grid.len() && i.iter().zip(grid).all(|(v, n)| v < n)) else {
            continue;
        };
        if scale.array.chunk_key(&index).as_str() == key {
            listing.keys.insert(key);
            listing.indices.push(index);
        }
    }
    Some(listing)
}

/// Appends the store keys (`prefix` + path, `/`-separated) of the files under `dir`; `None`
/// past [`MAX_LISTED_CHUNKS`] of them or when a directory cannot be read.
fn walk(dir: &Path, prefix: &str, keys: &mut Vec<String>) -> Option<()> {
    for entry in std::fs::read_dir(dir).ok()? {
        let entry = entry.ok()?;
        let name = entry.file_name().into_string().ok()?;
        let kind = entry.file_type().ok()?;
        if kind.is_dir() {
            walk(&entry.path(), &format!("{prefix}{name}/"), keys)?;
        } else {
            if keys.len() as u64 >= MAX_LISTED_CHUNKS {
                return None;
            }
            keys.push(format!("{prefix}{name}"));
        }
    }
    Some(())
}

/// Dims `[x, y, z]` of an array.
fn dims_of(scale: &Scale) -> [u32; 3] {
    let s = &scale.array.shape()[scale.lead..];
    [s[2] as u32, s[1] as u32, s[0] as u32]
}

/// The pyramid: [`levels_for`] level 0, checking that each stored level is the previous halved.
fn check_levels(scales: &[Scale]) -> Result<Vec<Level>, String> {
    let dims = dims_of(&scales[0]);
    let levels = levels_for(dims);
    let entries = table_entries(&levels);
    if entries > MAX_BRICKS {
        return Err(format!(
            "array `{}` of {dims:?} voxels (x, y, z) needs {entries} page-table entries for its bricks of {BRICK}^3, more than the {MAX_BRICKS} a volume may have",
            scales[0].path
        ));
    }
    for (i, pair) in scales.windows(2).enumerate().take(levels.len() - 1) {
        let (finer, coarser) = (dims_of(&pair[0]), dims_of(&pair[1]));
        let expected = finer.map(|n| n.div_ceil(2));
        if coarser != expected {
            return Err(format!(
                "dataset `{}` has {coarser:?} voxels (x, y, z) but level {} must be `{}`'s {finer:?} halved, rounding up: {expected:?}",
                pair[1].path,
                i + 1,
                pair[0].path
            ));
        }
    }
    Ok(levels)
}

/// Millimetres per unit of an OME axis unit (`None`: millimetres).
fn unit_mm(unit: Option<&str>) -> Result<f32, String> {
    Ok(match unit {
        None | Some("millimeter") => 1.0,
        Some("micrometer") => 1e-3,
        Some("nanometer") => 1e-6,
        Some("angstrom") => 1e-7,
        Some("centimeter") => 10.0,
        Some("meter") => 1e3,
        Some(other) => return Err(format!("axis unit `{other}` is not a length this viewer knows")),
    })
}

/// The grid-to-world transform of an OME multiscale for arrays of `ndim` axes.
fn world_of(multiscale: &Value, ndim: usize) -> Result<Mat4, String> {
    let axes = multiscale.get("axes").and_then(Value::as_array).cloned().unwrap_or_default();
    if !axes.is_empty() && axes.len() != ndim {
        return Err(format!("`axes` names {} axes but the arrays have {ndim}", axes.len()));
    }
    let name = |a: &Value| a.as_str().or_else(|| a.get("name").and_then(Value::as_str)).map(str::to_string);
    let spatial: Vec<Option<String>> = axes.iter().skip(ndim.saturating_sub(3)).map(name).collect();
    if spatial.iter().all(Option::is_some) && !spatial.is_empty() {
        let names: Vec<&str> = spatial.iter().flatten().map(String::as_str).collect();
        if names != ["z", "y", "x"] {
            return Err(format!("the last three axes are {names:?}; only z, y, x (x fastest) is supported"));
        }
    }
    let unit = axes.last().and_then(|a| a.get("unit")).and_then(Value::as_str);
    let mm = unit_mm(unit)?;
    let dataset = &multiscale["datasets"][0];
    let (s1, t1) = transforms(dataset.get("coordinateTransformations"), ndim)?;
    let (s2, t2) = transforms(multiscale.get("coordinateTransformations"), ndim)?;
    let (scale, offset) = (s1 * s2 * mm, (t1 * s2 + t2) * mm);
    Ok(Mat4::from_cols(
        Vec4::new(scale.x, 0.0, 0.0, 0.0),
        Vec4::new(0.0, scale.y, 0.0, 0.0),
        Vec4::new(0.0, 0.0, scale.z, 0.0),
        offset.extend(1.0),
    ))
}

/// The scale and translation (x, y, z) of a list of OME coordinate transformations.
fn transforms(list: Option<&Value>, ndim: usize) -> Result<(Vec3, Vec3), String> {
    let (mut scale, mut offset) = (Vec3::ONE, Vec3::ZERO);
    let Some(list) = list else { return Ok((scale, offset)) };
    let list = list.as_array().ok_or("`coordinateTransformations` is not a list")?;
    for t in list {
        let kind = t.get("type").and_then(Value::as_str).unwrap_or("");
        let xyz = |field: &str| -> Result<Vec3, String> {
            let v: Option<Vec<f32>> = t
                .get(field)
                .and_then(Value::as_array)
                .map(|a| a.iter().filter_map(|x| x.as_f64()).map(|x| x as f32).collect());
            match v {
                Some(v) if v.len() == ndim && v.iter().all(|x| x.is_finite()) => {
                    Ok(Vec3::new(v[ndim - 1], v[ndim - 2], v[ndim - 3]))
                }
                _ => Err(format!("a `{kind}` transformation needs {ndim} finite numbers in `{field}`")),
            }
        };
        match kind {
            "identity" => {}
            "scale" => {
                let s = xyz("scale")?;
                if s.cmple(Vec3::ZERO).any() {
                    return Err(format!("scale {s} is not positive"));
                }
                scale *= s;
                offset *= s;
            }
            "translation" => offset += xyz("translation")?,
            other => return Err(format!("coordinate transformation `{other}` is not supported")),
        }
    }
    Ok((scale, offset))
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

/// Writes an OME-Zarr (v0.4-style: Zarr v2 arrays, `multiscales` in `.zattrs`) group of uint16
/// arrays into `dir/test.ome.zarr` and returns its path: `levels` levels (level `l` has `dims`
/// halved `l` times, rounding up) of 1 mm voxels at level 0, chunks of `chunk` voxels (x, y, z)
/// compressed with zstd. A test and benchmark helper.
///
/// `value(level, voxel)` gives each voxel (rounded and clamped to uint16). It is only called for
/// the chunks `occupied(level, min, max)` says may hold non-zero data (`min` the chunk's first
/// voxel, `max` one past its last, both x, y, z); the others, and chunks that come out all zero,
/// are not written (the fill value 0), so a huge sparse volume is cheap to write. Chunks are
/// written by 2 threads.
pub fn write_test_zarr(
    dir: &Path,
    dims: [u32; 3],
    chunk: [u32; 3],
    levels: usize,
    value: impl Fn(usize, [u32; 3]) -> f32 + Sync,
    occupied: impl Fn(usize, [u32; 3], [u32; 3]) -> bool + Sync,
) -> Result<PathBuf, BrickError> {
    let fail = |m: String| BrickError(format!("write_test_zarr: {m}"));
    if dims.contains(&0) || chunk.contains(&0) || levels == 0 {
        return Err(fail(format!("dims {dims:?}, chunk {chunk:?} and {levels} levels must be non-zero")));
    }
    let root = dir.join("test.ome.zarr");
    std::fs::create_dir_all(&root).map_err(|e| fail(format!("{}: {e}", root.display())))?;
    let write =
        |name: &str, v: Value| std::fs::write(root.join(name), v.to_string()).map_err(|e| fail(format!("{name}: {e}")));
    write(".zgroup", json!({ "zarr_format": 2 }))?;
    let datasets: Vec<Value> = (0..levels)
        .map(|l| {
            let s = (1u64 << l) as f64;
            json!({ "path": l.to_string(), "coordinateTransformations": [{ "type": "scale", "scale": [s, s, s] }] })
        })
        .collect();
    let axes: Vec<Value> =
        ["z", "y", "x"].iter().map(|n| json!({ "name": n, "type": "space", "unit": "millimeter" })).collect();
    write(
        ".zattrs",
        json!({ "multiscales": [{ "version": "0.4", "name": "test", "axes": axes, "datasets": datasets }] }),
    )?;
    let store = Arc::new(FilesystemStore::new(&root).map_err(|e| fail(e.to_string()))?);
    for level in 0..levels {
        let ldims = dims.map(|n| n.div_ceil(1 << level.min(31)).max(1));
        write_test_level(&store, level, ldims, chunk, &value, &occupied).map_err(fail)?;
    }
    Ok(root)
}

/// One level of [`write_test_zarr`].
fn write_test_level(
    store: &Arc<FilesystemStore>,
    level: usize,
    dims: [u32; 3],
    chunk: [u32; 3],
    value: &(impl Fn(usize, [u32; 3]) -> f32 + Sync),
    occupied: &(impl Fn(usize, [u32; 3], [u32; 3]) -> bool + Sync),
) -> Result<(), String> {
    let metadata: ArrayMetadata = serde_json::from_value(json!({
        "zarr_format": 2,
        "shape": [dims[2], dims[1], dims[0]],
        "chunks": [chunk[2], chunk[1], chunk[0]],
        "dtype": "<u2",
        "compressor": { "id": "zstd", "level": 1 },
        "fill_value": 0,
        "order": "C",
        "filters": null,
        "dimension_separator": "/",
    }))
    .map_err(|e| e.to_string())?;
    let array = Array::new_with_metadata(store.clone(), &format!("/{level}"), metadata).map_err(|e| e.to_string())?;
    array.store_metadata().map_err(|e| e.to_string())?;
    let grid = [0, 1, 2].map(|a| dims[a].div_ceil(chunk[a]));
    let total = grid.iter().map(|&n| n as u64).product::<u64>();
    let write_one = |i: u64| -> Result<(), String> {
        let c = [i % grid[0] as u64, (i / grid[0] as u64) % grid[1] as u64, i / (grid[0] as u64 * grid[1] as u64)]
            .map(|v| v as u32);
        let min = [0, 1, 2].map(|a| c[a] * chunk[a]);
        let max = [0, 1, 2].map(|a| (min[a] + chunk[a]).min(dims[a]));
        if !occupied(level, min, max) {
            return Ok(());
        }
        // A v2 chunk is whole even past the array's end: the rest stays the fill value 0.
        let mut data = vec![0u16; chunk.iter().map(|&n| n as usize).product()];
        for z in min[2]..max[2] {
            for y in min[1]..max[1] {
                for x in min[0]..max[0] {
                    let v = value(level, [x, y, z]).round().clamp(0.0, u16::MAX as f32) as u16;
                    data[box_index(sub([x, y, z], min), chunk)] = v;
                }
            }
        }
        if data.iter().all(|&v| v == 0) {
            return Ok(());
        }
        let index = [c[2] as u64, c[1] as u64, c[0] as u64];
        array.store_chunk(&index, data).map_err(|e| format!("chunk {index:?} of level {level}: {e}"))
    };
    std::thread::scope(|s| {
        let workers: Vec<_> = (0..2u64)
            .map(|t| {
                let write_one = &write_one;
                s.spawn(move || (t..total).step_by(2).try_for_each(write_one))
            })
            .collect();
        workers.into_iter().try_for_each(|w| w.join().map_err(|_| "a writer thread panicked".to_string())?)
    })
}

#[cfg(test)]
#[path = "tests_zarr.rs"]
mod tests;
